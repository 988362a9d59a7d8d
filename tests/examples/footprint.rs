//! Footprint and speed of the firmware on the MCU (a benchmark, not a test):
//! `cargo run --release -p motor-id-tests --example footprint`.
//!
//! - Instructions per identification of a 2,000-sample record: the QEMU build under
//!   `-icount shift=0` (1 ns of virtual time per instruction; SysTick at 168 MHz counts 0.168
//!   per instruction), `motor-id board identify` on a simulated record (steps, 100 Hz, 20 s,
//!   with current) with the host's default pipeline and with the board's, and a
//!   `motor-id board commission` (the board's own 2,000-sample experiment, then the board
//!   pipeline); the firmware reports the SysTick ticks from the request to the result.
//! - Stack high-water mark: the painted stack after that identification (and the power-up
//!   commissioning before it).
//! - Flash and static RAM: section sizes of the release ELFs (board and QEMU builds).

use motor_id_tests::{board_record, build_firmware, run_ok, s, Qemu};
use object::{Object, ObjectSection, SectionFlags};
use std::path::Path;
use std::time::Duration;

/// SysTick ticks per instruction under `-icount shift=0` (168 MHz, 1 ns per instruction).
const TICKS_PER_INSTRUCTION: f64 = 0.168;

/// (flash, static RAM) bytes of an ELF: allocated sections, RAM ones at 0x2000_0000.
fn sizes(elf: &Path) -> (u64, u64) {
    let data = std::fs::read(elf).expect("read the ELF");
    let file = object::File::parse(&*data).expect("parse the ELF");
    let (mut flash, mut ram) = (0, 0);
    for section in file.sections() {
        let alloc = match section.flags() {
            SectionFlags::Elf { sh_flags } => sh_flags & u64::from(object::elf::SHF_ALLOC) != 0,
            _ => false,
        };
        if !alloc || section.size() == 0 {
            continue;
        }
        let name = section.name().unwrap_or("");
        if section.address() >= 0x2000_0000 {
            ram += section.size();
            if name == ".data" {
                flash += section.size(); // its initial values live in flash
            }
        } else if section.address() >= 0x0800_0000 {
            flash += section.size();
        }
    }
    (flash, ram)
}

/// The next footprint line the firmware writes: its fields by name.
fn footprint_line(q: &Qemu) -> impl Fn(&str) -> f64 {
    let line = loop {
        let line = q
            .stderr
            .recv_timeout(Duration::from_secs(120))
            .expect("the firmware's footprint line");
        if line.starts_with("footprint:") {
            break line;
        }
    };
    move |key: &str| -> f64 {
        line.split_whitespace()
            .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{key} missing in {line:?}"))
    }
}

fn main() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let csv = board_record(dir.path());
    let q = Qemu::start_with(&["-icount", "shift=0"]);
    let json = dir.path().join("board.json");
    let board = |args: &[&str]| {
        let mut all = vec!["board", "--port", &q.pty, "--timeout", "120"];
        all.extend(["--json", s(&json), "-q"]);
        all.extend_from_slice(args);
        run_ok(&all);
        motor_id_tests::json(&json)
    };
    println!("| quantity | value | target |");
    println!("|---|---|---|");
    let mut stack = 0.0f64;
    // The target is the board's own identification; the other two are shown for scale.
    for (what, args, target) in [
        (
            "`board identify --pipeline board` (the board's pipeline)",
            vec!["identify", s(&csv), "--pipeline", "board"],
            "<= 40 M",
        ),
        (
            "`board identify` (the host's default pipeline)",
            vec!["identify", s(&csv)],
            "(informative)",
        ),
        (
            "`board commission` (2,000-sample experiment incl. QEMU's simulated plant, then the board pipeline)",
            vec!["commission"],
            "(informative)",
        ),
    ] {
        let report = board(&args);
        let field = footprint_line(&q);
        stack = stack.max(field("stack_bytes"));
        let millions = |key: &str| field(key) / TICKS_PER_INSTRUCTION / 1e6;
        println!(
            "| instructions, {what}: 2,000 samples with current, {} evaluations | {:.1} M | {target} |",
            report["evaluations"],
            millions("ticks")
        );
        if args[0] == "commission" {
            println!(
                "| instructions, the identification within `board commission` (from the drive's stop to the result: five motor parameters and tc, {} evaluations) | {:.1} M | <= 40 M |",
                report["evaluations"],
                millions("fit_ticks")
            );
        }
    }
    println!("| stack high-water mark (power-up commissioning and the jobs above) | {stack} B | <= 8 KB |");
    for (name, elf) in [
        ("board", build_firmware(&[], "target")),
        ("qemu", motor_id_tests::firmware_elf().to_path_buf()),
    ] {
        let (flash, ram) = sizes(&elf);
        println!(
            "| flash, {name} build | {:.1} KB | <= 96 KB |",
            flash as f64 / 1024.0
        );
        println!(
            "| static RAM, {name} build | {:.1} KB | <= 48 KB |",
            ram as f64 / 1024.0
        );
    }
}

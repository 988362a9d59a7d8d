//! Footprint and speed of the firmware on the MCU (a benchmark, not a test):
//! `cargo run --release -p motor-id-tests --example footprint`.
//!
//! - Instructions per identification of a 2,000-sample record: the QEMU build under
//!   `-icount shift=0` (1 ns of virtual time per instruction; SysTick at 168 MHz counts 0.168
//!   per instruction), `motor-id board identify` on a simulated record (steps, 100 Hz, 20 s,
//!   with current) with the host's default pipeline and with the board's, and a
//!   `motor-id board commission` (the board's probe and its two designed records, the slow
//!   one with a coast-down, then the board pipeline on both with Coulomb friction free); the
//!   firmware reports the SysTick
//!   ticks from the request to the result, and for a commissioning also from the drive's
//!   stop at the end of the experiment (the identification alone).
//! - The worst case of the board's stack: `board identify` of a speed-only record whose
//!   fit runs the FFO search and whose analysis runs the profile check (the motor of issue 13's
//!   first example, steps at 100 Hz for 20 s): its instructions are informative.
//! - Stack high-water mark: the painted stack after these jobs (and the power-up
//!   commissioning before them).
//! - Flash and static RAM: section sizes of the release ELFs (board and QEMU builds).

use motor_id_tests::{board_record, build_firmware, run_ok, s, Qemu};
use object::{Object, ObjectSection, SectionFlags};
use std::path::Path;
use std::time::Duration;

/// A motor whose speed-only fit at 100 Hz runs the FFO search and whose analysis runs the profile
/// check (a flat direction beside pinned `j` and `kv`): the deepest stack the board reaches.
const PROFILE_CHECK_MOTOR: &str =
    "ra=0.6252534,la=0.8401117,j=0.0011193017,b=0.00088091264,kv=1.6004144";

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
    let speed_only = dir.path().join("speed-only.csv");
    motor_id_tests::simulate(
        &speed_only,
        &[
            "--motor",
            PROFILE_CHECK_MOTOR,
            "--profile",
            "steps",
            "--rate",
            "100",
            "--duration",
            "20",
            "--noise-omega",
            "0.1",
            "--seed",
            "4",
            "--speed-only",
        ],
    );
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
    let mut job = |args: &[&str]| {
        let report = board(args);
        let field = footprint_line(&q);
        stack = stack.max(field("stack_bytes"));
        let millions = |key: &str| field(key) / TICKS_PER_INSTRUCTION / 1e6;
        (
            report["evaluations"].clone(),
            millions("ticks"),
            millions("fit_ticks"),
        )
    };
    let (board_evals, board_m, _) = job(&["identify", s(&csv), "--pipeline", "board"]);
    let (default_evals, default_m, _) = job(&["identify", s(&csv)]);
    let (commission_evals, commission_m, commission_fit_m) = job(&["commission"]);
    let (speed_evals, speed_m, _) = job(&["identify", s(&speed_only), "--pipeline", "board"]);
    // The profile check had work: a flat direction beside a pinned parameter (it only
    // unpins, so a parameter pinned after it was pinned before).
    let id = &motor_id_tests::json(&json)["identifiability"];
    let pinned = id["parameters"]
        .as_object()
        .expect("the board's estimates")
        .values()
        .any(|e| e["pinned"] == true);
    assert!(
        id["rank"].as_u64() < id["free"].as_u64() && pinned,
        "the speed-only job did not run the profile check: {id}"
    );
    // The targets are the board's own identifications; the other two rows are for scale.
    println!(
        "| instructions, `board identify --pipeline board` (the board's pipeline, five motor parameters, {board_evals} evaluations) | {board_m:.1} M | <= 40 M |"
    );
    println!(
        "| instructions, the identification within `board commission` (board pipeline, five motor parameters and `tc`, the slow and the fast record, {commission_evals} evaluations) | {commission_fit_m:.1} M | <= 170 M (1 s at 168 MHz) |"
    );
    println!(
        "| instructions, `board commission` as a whole (the probe and the records at the drive's 2 kHz incl. QEMU's simulated plant, identification) | {commission_m:.1} M | (informative) |"
    );
    println!(
        "| instructions, `board identify` (the host's default pipeline, {default_evals} evaluations) | {default_m:.1} M | (informative) |"
    );
    println!(
        "| instructions, `board identify --pipeline board` of a speed-only record with the FFO search and the profile check ({speed_evals} evaluations in the fit) | {speed_m:.1} M | (informative) |"
    );
    println!("| stack high-water mark (power-up commissioning and the jobs above) | {stack} B | <= 8 KB (8,192 B) |");
    // The budgets are the board's; the QEMU build is a test build (a simulated plant, its
    // command line read over semihosting, defmt over semihosting in place of RTT).
    let test_build = "(informative: a test build)";
    for (name, elf, flash_target, ram_target) in [
        (
            "board",
            build_firmware(&[], "target"),
            "<= 96 KB",
            "<= 48 KB",
        ),
        (
            "qemu",
            motor_id_tests::firmware_elf().to_path_buf(),
            test_build,
            test_build,
        ),
    ] {
        let (flash, ram) = sizes(&elf);
        println!(
            "| flash, {name} build | {:.1} KB | {flash_target} |",
            flash as f64 / 1024.0
        );
        println!(
            "| static RAM, {name} build | {:.1} KB | {ram_target} |",
            ram as f64 / 1024.0
        );
    }
}

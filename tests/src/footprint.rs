//! The firmware's budgets on the MCU (issue 21: flash <= 96 KB, static RAM <= 48 KB, stack
//! <= 8 KB painted) and how they are read: the ELF's allocated sections, and the footprint
//! line the QEMU build writes on semihosting stderr after each job (its painted stack's
//! high-water mark, its SysTick ticks). One reader for the benchmark
//! (`tests/examples/footprint.rs`) and the test that holds the budgets
//! (`tests/tests/firmware_budgets.rs`).

use crate::{steps_record, Qemu};
use object::{Object, ObjectSection, SectionFlags};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The board's flash budget in bytes (96 KB).
pub const FLASH_BUDGET: u64 = 96 * 1024;
/// The board's static RAM budget in bytes (48 KB).
pub const RAM_BUDGET: u64 = 48 * 1024;
/// The board's stack budget in bytes (8 KB, painted).
pub const STACK_BUDGET: f64 = 8.0 * 1024.0;

/// A motor whose speed-only fit at 100 Hz runs the FFO search and whose analysis runs the
/// profile check (a flat direction beside pinned `j` and `kv`): the deepest stack the board
/// reaches.
pub const PROFILE_CHECK_MOTOR: &str =
    "ra=0.6252534,la=0.8401117,j=0.0011193017,b=0.00088091264,kv=1.6004144";

/// SysTick ticks per instruction under `-icount shift=0` (168 MHz, 1 ns per instruction).
pub const TICKS_PER_INSTRUCTION: f64 = 0.168;

/// (flash, static RAM) bytes of an ELF: allocated sections, RAM ones at 0x2000_0000 (the
/// initial values of `.data` counted in flash too).
pub fn elf_sizes(elf: &Path) -> (u64, u64) {
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

/// The next footprint line the firmware writes for a job the host asked for (after the
/// job's result, which the caller has already received): its fields by name. The power-up
/// commissioning's line, if any, is passed over ([`power_up_footprint`]).
pub fn footprint_line(q: &Qemu) -> impl Fn(&str) -> f64 {
    fields(next_footprint(q, false))
}

/// The footprint of the commissioning the board ran at reset (the firmware meters it while
/// the host sends nothing; call before talking to the board): its fields by name, or None
/// when it ended without parameters (refused or aborted).
pub fn power_up_footprint(q: &Qemu) -> Option<impl Fn(&str) -> f64> {
    let line = next_footprint(q, true);
    (!line.contains("outcome=no-parameters")).then(|| fields(line))
}

/// The next footprint line of the power-up commissioning (`power_up`) or of another job.
fn next_footprint(q: &Qemu, power_up: bool) -> String {
    loop {
        let line = q
            .stderr
            .recv_timeout(Duration::from_secs(600))
            .expect("the firmware's footprint line");
        if line.starts_with("footprint:") && line.contains("job=power-up") == power_up {
            return line;
        }
    }
}

/// A footprint line's fields by name.
fn fields(line: String) -> impl Fn(&str) -> f64 {
    move |key: &str| -> f64 {
        line.split_whitespace()
            .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{key} missing in {line:?}"))
    }
}

/// The speed-only record of [`PROFILE_CHECK_MOTOR`] (steps, 100 Hz, 20 s), written to
/// `dir/speed-only.csv`.
pub fn speed_only_record(dir: &Path) -> PathBuf {
    steps_record(
        &dir.join("speed-only.csv"),
        &[
            "--motor",
            PROFILE_CHECK_MOTOR,
            "--noise-omega",
            "0.1",
            "--speed-only",
        ],
    )
}

/// The board's report of the last identification ran the profile check with work left:
/// a flat direction beside a pinned parameter (the check only unpins, so a parameter pinned
/// after it was pinned before).
pub fn ran_the_profile_check(report: &serde_json::Value) -> bool {
    let id = &report["identifiability"];
    let pinned = id["parameters"]
        .as_object()
        .expect("the board's estimates")
        .values()
        .any(|e| e["pinned"] == true);
    id["rank"].as_u64() < id["free"].as_u64() && pinned
}

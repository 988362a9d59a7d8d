//! The firmware's budgets on the MCU hold (issue 21; the figures themselves are measured by
//! `tests/examples/footprint.rs` into docs/measurements/footprint.md): the board build's
//! flash and static RAM, and the stack the QEMU build paints reaches at its deepest job.
//! Sizes and depths, not times: nothing here depends on the machine's load.

use motor_id_tests::footprint::{
    elf_sizes, footprint_line, ran_the_profile_check, speed_only_record, FLASH_BUDGET, RAM_BUDGET,
    STACK_BUDGET,
};
use motor_id_tests::{build_firmware, json, run_ok, s, Qemu};

#[test]
fn the_board_build_fits_its_flash_and_static_ram() {
    // A `f32::clamp` on bounds read at run time once brought the float formatting of its
    // panic message into the build: 17 KB of flash over the budget.
    let (flash, ram) = elf_sizes(&build_firmware(&[], "target"));
    assert!(
        flash <= FLASH_BUDGET,
        "flash {flash} B over the budget of {FLASH_BUDGET} B"
    );
    assert!(ram <= RAM_BUDGET, "static RAM {ram} B over {RAM_BUDGET} B");
}

#[test]
fn the_deepest_job_stays_within_the_painted_stack() {
    // The power-up commissioning, then the speed-only identification whose analysis runs
    // the profile check (the deepest stack the board reaches): the high-water mark after
    // both.
    let q = Qemu::start();
    let dir = tempfile::tempdir().unwrap();
    let csv = speed_only_record(dir.path());
    let report = dir.path().join("board.json");
    let mut args = q.board_args(&["--json", s(&report), "-q"]);
    args.extend(["identify", s(&csv), "--pipeline", "board"]);
    run_ok(&args);
    assert!(
        ran_the_profile_check(&json(&report)),
        "the job did not run the profile check: {}",
        json(&report)
    );
    let stack = footprint_line(&q)("stack_bytes");
    assert!(
        stack > 1024.0 && stack <= STACK_BUDGET,
        "stack high-water mark {stack} B (budget {STACK_BUDGET} B)"
    );
}

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

use motor_id_tests::footprint::{
    elf_sizes, footprint_line, ran_the_profile_check, speed_only_record, FLASH_BUDGET, RAM_BUDGET,
    STACK_BUDGET, TICKS_PER_INSTRUCTION,
};
use motor_id_tests::{board_record, build_firmware, run_ok, s, Qemu};

fn main() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let csv = board_record(dir.path());
    let speed_only = speed_only_record(dir.path());
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
    assert!(
        ran_the_profile_check(&motor_id_tests::json(&json)),
        "the speed-only job did not run the profile check"
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
    println!(
        "| stack high-water mark (power-up commissioning and the jobs above) | {stack} B | <= {} KB ({STACK_BUDGET} B) |",
        STACK_BUDGET / 1024.0
    );
    // The budgets are the board's; the QEMU build is a test build (a simulated plant, its
    // command line read over semihosting, defmt over semihosting in place of RTT).
    let test_build = "(informative: a test build)";
    for (name, elf, flash_target, ram_target) in [
        (
            "board",
            build_firmware(&[], "target"),
            format!("<= {} KB", FLASH_BUDGET / 1024),
            format!("<= {} KB", RAM_BUDGET / 1024),
        ),
        (
            "qemu",
            motor_id_tests::firmware_elf().to_path_buf(),
            test_build.to_string(),
            test_build.to_string(),
        ),
    ] {
        let (flash, ram) = elf_sizes(&elf);
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

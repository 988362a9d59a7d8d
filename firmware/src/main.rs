//! motor-id drive-board firmware. One application ([`app`], on top of
//! `motor_id_shared::device::service`) in two builds that differ only in their board layer:
//!
//! - `board` (default): the STM32F405 drive board ([`board`]): PWM to the H-bridge,
//!   timer-triggered ADC sampling of tacho and current by DMA, USART1 link, independent
//!   watchdog, parameters in a flash sector. `cargo run --release` flashes it through probe-rs.
//! - `qemu`: `qemu-system-arm -M netduinoplus2` ([`qemu`]): USART1 link, no clock set-up, a
//!   simulated motor behind the same drive trait, parameters in RAM.
#![no_std]
#![no_main]

#[cfg(all(feature = "board", feature = "qemu"))]
compile_error!(
    "choose one build: `--features board` (default) or `--no-default-features --features qemu`"
);
#[cfg(not(any(feature = "board", feature = "qemu")))]
compile_error!(
    "choose one build: `--features board` (default) or `--no-default-features --features qemu`"
);

mod app;
#[cfg(feature = "board")]
mod board;
mod link;
#[cfg(feature = "qemu")]
mod qemu;

#[cortex_m_rt::entry]
fn main() -> ! {
    // The record buffers, initialised at link time (.bss): `entry` turns this into a
    // `&'static mut` (a run-time initialiser would build its 24 KB on the stack first).
    static mut STORE: motor_id_shared::device::record_store::RecordStore<{ app::MAX_SAMPLES }> =
        motor_id_shared::device::record_store::RecordStore::new();
    // The fit's simulators (the Jacobian's fourteen, with the means of averaged readings),
    // likewise in static RAM rather than on the 8 KB stack.
    static mut WORKSPACE: motor_id_shared::fit::workspace::FitWorkspace =
        motor_id_shared::fit::workspace::FitWorkspace::new();
    let (hw, led) = init();
    app::run(hw, STORE, WORKSPACE, led)
}

/// Bring the board up, its hardware in a static: not on the stack the identification needs
/// (a frame of its own, gone before the application runs).
#[cfg(feature = "board")]
#[inline(never)]
fn init() -> (&'static mut board::BoardHardware, board::Led) {
    let (hw, led) = board::init();
    let hw = cortex_m::singleton!(: board::BoardHardware = hw).expect("init runs once");
    (hw, led)
}

/// Bring the emulated board up, its hardware in a static (see the board's `init`).
#[cfg(feature = "qemu")]
#[inline(never)]
fn init() -> (&'static mut qemu::QemuHardware, qemu::LogLed) {
    let (hw, led) = qemu::init();
    let hw = cortex_m::singleton!(: qemu::QemuHardware = hw).expect("init runs once");
    (hw, led)
}

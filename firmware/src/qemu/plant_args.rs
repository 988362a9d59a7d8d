//! The simulated plant's motor, chosen at run time from QEMU's semihosting command line, so
//! that one firmware binary commissions any motor in the tests: each argument `name=bits`
//! (a parameter's name as in `docs/CONTRACTS.md`: `ra`, `la`, `j`, `b`, `kv`, `tc`, ...;
//! its `f32` value as the hexadecimal bit pattern, exact and read without a float parser,
//! which would take some 20 KB of flash) replaces that parameter of the default motor, e.g.
//! `-semihosting-config enable=on,target=native,arg=firmware,arg=j=0x3a83126f` (j = 0.001).
//! Arguments without `=` (the program name) are skipped; anything else that does not name a
//! parameter and a number, or a motor the model refuses, stops the firmware with the reason.

use cortex_m_semihosting::{nr, syscall1};
use motor_id_shared::{ModelParams, ParamId};

/// Longest command line read [bytes].
const CMDLINE: usize = 256;

/// `default` with every parameter QEMU's command line gives replaced.
pub fn plant_motor(default: ModelParams) -> ModelParams {
    let mut buf = [0u8; CMDLINE];
    // SYS_GET_CMDLINE: a block of the buffer's address and length; the host writes the
    // length of the text back into it.
    let mut block = [buf.as_mut_ptr() as usize, CMDLINE - 1];
    // SAFETY: the block and the buffer outlive the call, and the host writes at most the
    // length given into the buffer (semihosting, "SYS_GET_CMDLINE (0x15)").
    let failed = unsafe { syscall1(nr::GET_CMDLINE, block.as_mut_ptr() as usize) } != 0;
    if failed {
        return default;
    }
    let text = core::str::from_utf8(&buf[..block[1].min(CMDLINE)]).unwrap_or("");
    let mut motor = default;
    for arg in text.split_whitespace() {
        let Some((name, value)) = arg.split_once('=') else {
            continue;
        };
        let Some(id) = ParamId::from_name(name) else {
            defmt::panic!("QEMU plant: '{}' names no parameter", name);
        };
        let bits = value
            .strip_prefix("0x")
            .map(|hex| u32::from_str_radix(hex, 16));
        let Some(Ok(bits)) = bits else {
            defmt::panic!(
                "QEMU plant: {} = '{}' is not 0x and 8 hex digits",
                name,
                value
            );
        };
        motor.set(id, f32::from_bits(bits));
    }
    if motor.validate().is_err() {
        defmt::panic!("QEMU plant: the motor of the command line is not valid");
    }
    if motor != default {
        defmt::info!("QEMU plant: the command line's motor {}", motor);
    }
    motor
}

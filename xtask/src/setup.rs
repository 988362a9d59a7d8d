//! What the tests need beyond Rust, installed when missing: the drive board's target
//! (`thumbv7em-none-eabihf`, by rustup), flip-link (the firmware's linker,
//! `firmware/.cargo/config.toml`, by cargo) and `qemu-system-arm` (the firmware tests, by the
//! system's package manager when this user may run it).

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::{Command, Stdio};

const TARGET: &str = "thumbv7em-none-eabihf";
const QEMU: &str = "qemu-system-arm";

/// The cargo that runs this task (`CARGO`, set by cargo), else `cargo` on the PATH.
pub fn cargo() -> OsString {
    std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into())
}

/// Install what is missing, in the order the tests need it; the first thing that cannot be
/// installed ends the setup with one line that names the command that installs it.
pub fn install_missing() -> Result<(), String> {
    cargo_bin_on_path();
    board_target()?;
    flip_link()?;
    qemu()
}

/// Put cargo's bin directory (`$CARGO_HOME/bin`, else `~/.cargo/bin`), where `cargo
/// install` puts flip-link, on this process's PATH, which the tests inherit: a rustup
/// install that did not add it to the shell's PATH still finds the linker.
fn cargo_bin_on_path() {
    let home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")));
    let Some(bin) = home.map(|h| h.join("bin")) else {
        return;
    };
    let path = std::env::var_os("PATH").unwrap_or_default();
    if std::env::split_paths(&path).any(|p| p == bin) {
        return;
    }
    let joined = std::env::join_paths(std::iter::once(bin).chain(std::env::split_paths(&path)));
    if let Ok(joined) = joined {
        // Single-threaded here, before any child process starts.
        std::env::set_var("PATH", joined);
    }
}

/// Whether `program args` runs and exits with success, its output discarded.
fn runs(program: &str, args: &[&str]) -> bool {
    Command::new(program)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Run `program args` with its output shown, as a step of the setup.
fn install(program: &str, args: &[&str]) -> Result<(), String> {
    eprintln!("xtask: running {program} {}", args.join(" "));
    let status = Command::new(program)
        .args(args)
        .status()
        .map_err(|e| format!("{program} could not start: {e}"))?;
    match status.success() {
        true => Ok(()),
        false => Err(format!("`{program} {}` failed ({status})", args.join(" "))),
    }
}

fn board_target() -> Result<(), String> {
    let Ok(out) = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
    else {
        // Without rustup the toolchain's own standard libraries decide; the firmware build
        // then says what is missing.
        return Ok(());
    };
    if String::from_utf8_lossy(&out.stdout)
        .lines()
        .any(|l| l.trim() == TARGET)
    {
        return Ok(());
    }
    install("rustup", &["target", "add", TARGET])
}

fn flip_link() -> Result<(), String> {
    if runs("flip-link", &["--help"]) {
        return Ok(());
    }
    let cargo = cargo();
    let cargo = cargo.to_string_lossy();
    install(&cargo, &["install", "flip-link", "--locked"])?;
    match runs("flip-link", &["--help"]) {
        true => Ok(()),
        false => {
            Err("flip-link was installed but is not on the PATH: add ~/.cargo/bin to it".into())
        }
    }
}

/// QEMU through the package manager: directly as root, through `sudo -n` where that needs no
/// password, through Homebrew as the user; otherwise one line with the command to run.
fn qemu() -> Result<(), String> {
    if runs(QEMU, &["--version"]) {
        return Ok(());
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout.trim_ascii() == b"0");
    let sudo = !root && runs("sudo", &["-n", "true"]);
    let as_admin = |args: &[&str]| -> Result<(), String> {
        match (root, sudo) {
            (true, _) => install(args[0], &args[1..]),
            (false, true) => install("sudo", &[&["-n"], args].concat()),
            (false, false) => Err(format!(
                "{QEMU} is missing (the firmware tests need it) and this user may not install it: run `sudo {}`",
                args.join(" ")
            )),
        }
    };
    if runs("apt-get", &["--version"]) {
        as_admin(&["apt-get", "update"])?;
        as_admin(&["apt-get", "install", "-y", QEMU])?;
    } else if runs("dnf", &["--version"]) {
        as_admin(&["dnf", "install", "-y", QEMU])?;
    } else if runs("pacman", &["--version"]) {
        as_admin(&["pacman", "-S", "--noconfirm", "qemu-system-arm"])?;
    } else if runs("brew", &["--version"]) {
        install("brew", &["install", "qemu"])?;
    } else {
        return Err(format!(
            "{QEMU} is missing (the firmware tests need it) and no known package manager was found: install QEMU's ARM system emulator"
        ));
    }
    match runs(QEMU, &["--version"]) {
        true => Ok(()),
        false => Err(format!("{QEMU} was installed but is not on the PATH")),
    }
}

#!/bin/sh
# Runner of `cargo qemu` (firmware/.cargo/config.toml): runs the firmware's QEMU build
# ELF in qemu-system-arm (netduinoplus2), its serial port on a pseudo-terminal for
# `motor-id board --port /dev/pts/N`.
#
# QEMU writes the line naming that pseudo-terminal (`char device redirected to
# /dev/pts/N ...`) on its standard output, and the firmware's defmt log (binary, through
# semihosting) follows it there. The line is passed on as it is; the log is decoded by
# `defmt-print -e ELF` when defmt-print is installed, and otherwise not printed (its raw
# bytes would garble the terminal): one line says so instead.
#
# Usage: qemu-run.sh ELF [QEMU ARGUMENTS...]
set -eu

if [ "$#" -lt 1 ]; then
    echo "usage: $0 ELF [QEMU ARGUMENTS...]" >&2
    exit 2
fi
elf=$1
shift

qemu-system-arm -M netduinoplus2 -nographic -monitor none -serial pty \
    -semihosting-config enable=on,target=native "$@" -kernel "$elf" | {
    # Text up to and including the line that names the pseudo-terminal (`read` takes
    # one line at a time from a pipe, never a byte of the log after it).
    while IFS= read -r line; do
        printf '%s\n' "$line"
        case $line in
        *char\ device\ redirected\ to*) break ;;
        esac
    done
    if command -v defmt-print >/dev/null 2>&1; then
        exec defmt-print -e "$elf"
    fi
    echo "qemu-run.sh: the firmware's defmt log is hidden (binary); to see it decoded: cargo install defmt-print" >&2
    # Keep reading, so that QEMU never blocks on (or dies of) a full or closed pipe.
    exec cat >/dev/null
}

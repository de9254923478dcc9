#!/usr/bin/env bash
# Every check CI runs, from a fresh machine: installs what it needs.
#   scripts/test.sh           all checks
#   LONG=1 scripts/test.sh    also the one-hour f32 stability run (~3 min)
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

step "toolchain: thumbv7em-none-eabihf, rustfmt, clippy"
rustup target add thumbv7em-none-eabihf
rustup component add rustfmt clippy

step "format"
cargo fmt --all --check

step "clippy (host crates, all targets)"
cargo clippy --all-targets -- -D warnings

step "clippy (monitor and firmware for the MCU)"
cargo clippy -p monitor -p firmware --target thumbv7em-none-eabihf -- -D warnings

step "clippy (on-target tests and benchmark for the MCU)"
cargo clippy -p qemu-tests --target thumbv7em-none-eabihf --features qemu --all-targets -- -D warnings

step "host tests (monitor, host-sim, golden; the goldens are up to date)"
cargo test --workspace

if [ "${LONG:-0}" = 1 ]; then
  step "one simulated hour in f32"
  cargo test --release -p host-sim --test long_run -- --ignored --nocapture
fi

step "monitor builds for thumbv7em-none-eabihf"
cargo build -p monitor --release --target thumbv7em-none-eabihf

step "firmware builds and links (release)"
cargo build -p firmware --release --target thumbv7em-none-eabihf
elf=target/thumbv7em-none-eabihf/release/firmware
# A firmware built without the link script is a few bytes: fail loudly.
text=$(python3 - "$elf" <<'PY'
import struct, sys
data = open(sys.argv[1], 'rb').read()
assert data[:4] == b'\x7fELF', 'not an ELF file'
shoff, = struct.unpack_from('<I', data, 0x20)
shentsize, shnum, shstrndx = struct.unpack_from('<HHH', data, 0x2e)
def sec(i):
    return struct.unpack_from('<IIIIIIIIII', data, shoff + i * shentsize)
names = sec(shstrndx)[4]
flash = ram = 0
for i in range(shnum):
    name_off, typ, flags, addr, off, size = sec(i)[:6]
    name = data[names + name_off:data.index(b'\0', names + name_off)].decode()
    if flags & 2:  # SHF_ALLOC
        if 0x08000000 <= addr < 0x08100000:
            flash += size
        elif 0x20000000 <= addr < 0x20020000:
            ram += size
        if name == '.data':
            flash += size
print(flash, ram)
PY
)
read -r flash ram <<<"$text"
echo "firmware: flash ${flash} B, static RAM ${ram} B"
[ "$flash" -gt 16384 ] || { echo "firmware image suspiciously small"; exit 1; }

step "QEMU: qemu-system-arm (Debian)"
if ! command -v qemu-system-arm >/dev/null; then
  sudo=""
  [ "$(id -u)" = 0 ] || sudo=sudo
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get install -y --no-install-recommends qemu-system-arm ||
    { $sudo apt-get update && $sudo apt-get install -y --no-install-recommends qemu-system-arm; }
fi
qemu-system-arm --version | sed -n 1p

step "QEMU: the monitor on a Cortex-M4F is bit-identical with the host (goldens)"
cargo qemu-test

step "QEMU: instructions per Monitor::step, static RAM, stack (budget)"
cargo qemu-bench

step "all checks passed"

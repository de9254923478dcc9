#!/usr/bin/env bash
# Cargo runner for the on-target tests (`cargo qemu-test`, `cargo qemu-bench`):
# runs a thumbv7em-none-eabihf ELF on QEMU's netduinoplus2 (an STM32F405,
# the same memory map as memory.x). The program talks over semihosting and
# ends with a semihosting exit, so QEMU's exit status is the test's.
#   scripts/qemu-run.sh ELF [ARGS...]   (ARGS, e.g. cargo bench's --bench, are ignored)
# -icount shift=0: one guest instruction = 1 ns of virtual time, so TIM2
# counts instructions exactly (tests/src/counter.rs) and every run is
# deterministic; sleep=off: while the guest waits for an interrupt (wfi),
# virtual time jumps to the next timer deadline instead of following the
# host's clock (the emulated-board tests idle most of the time).
# QEMU_TIMEOUT (s, default 600) stops a hung program.
set -euo pipefail
elf=${1:?usage: qemu-run.sh ELF [ARGS...]}
status=0
timeout --foreground "${QEMU_TIMEOUT:-600}" \
  qemu-system-arm -machine netduinoplus2 -nographic -monitor none -serial none \
  -icount shift=0,sleep=off -semihosting-config enable=on,target=native \
  -kernel "$elf" || status=$?
if [ "$status" = 124 ]; then
  echo "qemu-run.sh: $elf did not finish within ${QEMU_TIMEOUT:-600} s" >&2
fi
exit "$status"

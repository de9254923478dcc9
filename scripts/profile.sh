#!/usr/bin/env bash
# Where the instructions of Monitor::step go, exactly: runs the budget
# benchmark in QEMU with a small TCG plugin (tests/profile/insn_profile.c)
# that counts every executed instruction and the inclusive cost of every
# call site, then prints a call tree with inlined frames, per-filter stages
# and kinds of work (tests/profile/breakdown.py), in instructions per step.
#   scripts/profile.sh [--min PERCENT] [--depth N] [--root REGEX]
# Needs gcc, python3, llvm-symbolizer and llvm-objdump (Debian: gcc, llvm).
# A developer tool, not part of CI. The image is the bench's release build
# with full debug info and v0 symbol names (generic parameters visible);
# neither changes the code: the counts equal `cargo qemu-bench`'s.
set -euo pipefail
cd "$(dirname "$0")/.."
out=target/profile
mkdir -p "$out"
gcc -shared -fPIC -O2 -Wall -Wextra -fvisibility=hidden \
  -o "$out/insn_profile.so" tests/profile/insn_profile.c
elf=$(CARGO_PROFILE_RELEASE_DEBUG=2 CARGO_TARGET_DIR="$out" cargo bench -q \
  -p qemu-tests --target thumbv7em-none-eabihf --features qemu --no-run \
  --message-format=json \
  --config 'target.thumbv7em-none-eabihf.rustflags=["-C", "symbol-mangling-version=v0"]' |
  python3 -B -c 'import json, sys
for m in map(json.loads, sys.stdin):
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["name"] == "budget":
        print(m["executable"])')
status=0
qemu-system-arm -machine netduinoplus2 -nographic -monitor none -serial none \
  -icount shift=0 -semihosting-config enable=on,target=native \
  -plugin "$out/insn_profile.so,out=$out/budget.profile" -kernel "$elf" |
  grep -E "^budget: (Monitor|all)" || status=$?
[ "$status" = 0 ] || echo "(the benchmark reported a failure; profiling anyway)"
echo
python3 -B tests/profile/breakdown.py "$elf" "$out/budget.profile" "$@"

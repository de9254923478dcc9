#!/usr/bin/env bash
# Regenerate the golden cases of the on-target tests (golden/data) from
# the current monitor: run this after any change to the monitor's numbers,
# check `cargo qemu-test` still passes, and commit the files it changes.
# CI fails while they are stale (host-sim/tests/golden.rs).
#
# Each case: the first samples of an example recording (exact bit patterns)
# and the hash chains of what `host-sim replay` computes for them, with the
# filter warm-up shortened to 1 s so that a few seconds reach the decision
# layer's evidence phase and, for the leak, its alarms.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=golden/data
cargo build --release -p host-sim
hs=target/release/host-sim
mkdir -p "$dir"
rm -f "$dir"/*.input.bin "$dir"/*.expected.bin
# Healthy: 3 s (2 s past warm-up): no alarm.
"$hs" golden write examples/healthy.csv.gz --samples 3000 --warm-up 1 -o "$dir/healthy"
# Internal + external leak: 8 s: external alarm at 1.2 s, both at 1.3 s.
"$hs" golden write examples/both.csv.gz --samples 8000 --warm-up 1 -o "$dir/both"
"$hs" golden check "$dir"

#!/usr/bin/env bash
# The fuzz targets of fuzz/ (what each asserts: fuzz/src/*.rs).
#   scripts/fuzz.sh                   each target for FUZZ_SECONDS (30) s
#   FUZZ_TARGETS="params" scripts/fuzz.sh
# With a nightly toolchain: cargo-fuzz (installed if missing) runs every
# target from a temporary copy of its committed corpus, so new entries
# stay out of git; a crash leaves its input in fuzz/artifacts/<target>/
# and fails the script. Without nightly: the committed corpora are
# replayed through the same target bodies on the pinned stable toolchain.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"

seconds=${FUZZ_SECONDS:-30}
read -r -a targets <<<"${FUZZ_TARGETS:-recording params candump protocol_decoder command_gate}"

if ! cargo +nightly --version >/dev/null 2>&1; then
  echo "fuzz: no nightly toolchain: replaying the corpora on stable"
  cargo test --no-default-features -- --nocapture
  exit 0
fi
command -v cargo-fuzz >/dev/null || cargo +nightly install cargo-fuzz --locked

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# -a: debug assertions and overflow checks, as in the tests.
cargo +nightly fuzz build -a
summary=""
for t in "${targets[@]}"; do
  cp -r "corpus/$t" "$work/$t"
  echo "fuzz: $t for ${seconds} s"
  if ! cargo +nightly fuzz run -a "$t" "$work/$t" -- \
    -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    2>"$work/$t.log"; then
    tail -n 60 "$work/$t.log"
    echo "fuzz: $t FAILED (input in fuzz/artifacts/$t/)"
    exit 1
  fi
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/$t.log")
  cov=$(grep -o 'cov: [0-9]*' "$work/$t.log" | tail -n 1)
  summary+="  $t: ${execs:-?} runs in ${seconds} s, ${cov:-cov ?}, corpus $(find "$work/$t" -type f | wc -l) inputs"$'\n'
done
printf 'fuzz: no crash\n%s' "$summary"

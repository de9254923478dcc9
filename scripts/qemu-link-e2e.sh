#!/usr/bin/env bash
# The commissioning link end to end: the firmware's link task in QEMU (the
# emulated board, tests/qemu/emu/linked.rs) with USART1 on a TCP socket,
# driven by the release host-sim over `tcp:127.0.0.1:PORT`, as a user
# drives a board over USB:
#
# 1. record: `host-sim record` captures the combined-leak golden case from
#    the firmware's stream; the capture must equal, sample for sample, what
#    the host's pipeline steps for the same ADC codes
#    (scripts/compare-recording.py), and in QEMU every CAN frame must match
#    the host's reference while streaming, and every block be sent;
# 2. upload, as in commissioning: `host-sim params show` reads the running
#    set, `host-sim record` takes 4 s (the monitor warms up and energises
#    the relay meanwhile), one value of the set is changed and `host-sim
#    params upload` sends it; the identity host-sim prints must be the one
#    the firmware then sends in LM_Identity, which QEMU checks switched
#    once from the compiled-in set while the monitor restarted (relay
#    dropped), and the event memory (`host-sim events`) must hold the
#    reset, the alarms the case raised, and the parameter change.
#
# Exits non-zero, saying why, on any failure. Run by scripts/test.sh.
#   scripts/qemu-link-e2e.sh
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/lib/qemu-serial.sh
. scripts/lib/qemu-serial.sh

STEP=
fail() {
  echo "qemu-link-e2e ($STEP): FAILED: $*" >&2
  for f in "$QEMU_SERIAL_ERR" "$QEMU_SERIAL_OUT"; do
    if [ -n "$f" ] && [ -s "$f" ]; then
      echo "--- $(basename "$f") of QEMU:" >&2
      tail -n 60 "$f" >&2
    fi
  done
  exit 1
}

host_sim=target/release/host-sim
cargo build --release -p host-sim --quiet || fail "cannot build host-sim"
work=$(mktemp -d "${TMPDIR:-/tmp}/qemu-link-e2e.XXXXXX")
record_elf=$(qemu_serial_build_test firmware_link_record)
upload_elf=$(qemu_serial_build_test firmware_link_upload)
# The samples the host's pipeline steps for the case's codes
# (tests/build/emu.rs writes them into the build script's OUT_DIR).
out_dir=$(cargo qemu-test --test firmware_link_record --no-run --message-format=json 2>/dev/null |
  python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "build-script-executed" and "/tests#" in m["package_id"] + "#":
        print(m["out_dir"])
' | tail -n 1)
expected=$out_dir/both.samples.csv
[ -f "$expected" ] || fail "no $expected"

STEP=record
port=$(qemu_serial_free_port)
# Virtual time tied to the host's clock: the firmware leaves the host
# 3 s after the recording to read its event memory.
QEMU_ICOUNT=shift=0,sleep=on qemu_serial_start "$record_elf" "$port"
echo "qemu-link-e2e: record from $(basename "$record_elf") on 127.0.0.1:$port"
"$host_sim" record "tcp:127.0.0.1:$port" -o "$work/both.csv.gz" --duration 8 \
  --note "QEMU end-to-end" || fail "host-sim record"
"$host_sim" events "tcp:127.0.0.1:$port" | tee "$work/events.txt" || fail "host-sim events"
# The event memory: this boot's reset, and the alarms the case raises.
grep -qE '^ +1 +0\.000 +reset \(power_on\)$' "$work/events.txt" || fail "no power-on reset in the event memory"
grep -qE 'alarm raised: both leak' "$work/events.txt" || fail "no 'both' alarm in the event memory"
status=0
qemu_serial_wait 120 || status=$?
grep -E 'heartbeat|commissioning link|all checks passed|FAILED' "$QEMU_SERIAL_OUT" || true
[ "$status" = 0 ] || fail "the firmware's checks in QEMU (status $status)"
python3 scripts/compare-recording.py "$expected" "$work/both.csv.gz" ||
  fail "the recording differs from what the monitor stepped"
qemu_serial_cleanup

# The upload step's timing hangs on the host's clock (QEMU_ICOUNT
# sleep=on): on a loaded machine it has failed once in many runs. It runs
# again once; a real fault fails both times (the first run's QEMU output,
# with the relay's changes, is printed either way).
upload_step() {
  STEP=upload
  port=$(qemu_serial_free_port)
  QEMU_ICOUNT=shift=0,sleep=on qemu_serial_start "$upload_elf" "$port"
  echo "qemu-link-e2e: upload to $(basename "$upload_elf") on 127.0.0.1:$port"
  "$host_sim" params show "tcp:127.0.0.1:$port" >"$work/running.toml" || fail "host-sim params show"
  grep -q '^force_offset_n = 0.0$' "$work/running.toml" || fail "no force_offset_n = 0.0 in the running set"
  "$host_sim" record "tcp:127.0.0.1:$port" -o "$work/site.csv.gz" --duration 4 ||
    fail "host-sim record"
  sed 's/^force_offset_n = 0.0$/force_offset_n = 5.0/' "$work/running.toml" >"$work/site.toml"
  "$host_sim" params upload "tcp:127.0.0.1:$port" "$work/site.toml" | tee "$work/upload.txt" ||
    fail "host-sim params upload"
  "$host_sim" events "tcp:127.0.0.1:$port" | tee "$work/events-after.txt" || fail "host-sim events"
  status=0
  qemu_serial_wait 300 || status=$?
  grep -E 'parameter set|LM_Identity' "$QEMU_SERIAL_OUT" || true
  [ "$status" = 0 ] || fail "the firmware's identity check in QEMU (status $status)"
  # host-sim: "… version V crc C …"; the firmware: "after it version V crc C".
  said=$(grep -oE 'version [0-9]+ crc [0-9a-f]{8}' "$work/upload.txt" | head -n 1)
  sent=$(grep -oE 'after it version [0-9]+ crc [0-9a-f]{8}' "$QEMU_SERIAL_OUT" | sed 's/^after it //')
  [ -n "$said" ] && [ "$said" = "$sent" ] ||
    fail "host-sim says the active set is '$said', LM_Identity carries '$sent'"
  echo "qemu-link-e2e: LM_Identity carries the uploaded set ($sent)"
  grep -qF "parameters changed: $sent" "$work/events-after.txt" ||
    fail "no 'parameters changed: $sent' in the event memory"
}
# In the background so that `set -e` holds inside it.
upload_step &
if ! wait $!; then
  echo "qemu-link-e2e: the upload step failed; running it once more" >&2
  upload_step &
  wait $! || exit 1
fi
rm -rf "$work"
echo "qemu-link-e2e: all checks passed"

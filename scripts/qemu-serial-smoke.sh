#!/usr/bin/env bash
# Smoke test of the emulated board's USART driver (tests/qemu/emu/uart.rs)
# over a real socket: runs tests/qemu/uart_echo.rs in QEMU with USART1 on
# 127.0.0.1:PORT (scripts/lib/qemu-serial.sh), sends it 8 KiB of random
# bytes and checks that exactly they come back, then ends the program and
# checks its verdict: status 0, every byte echoed, and the driver held
# bytes back at least once (its receive ring was full and nothing was
# lost). Exits non-zero, saying why, otherwise.
#   scripts/qemu-serial-smoke.sh [PORT]   (default: a free port)
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/lib/qemu-serial.sh
. scripts/lib/qemu-serial.sh

fail() {
  echo "qemu-serial-smoke: FAILED: $*" >&2
  if [ -n "$QEMU_SERIAL_ERR" ] && [ -s "$QEMU_SERIAL_ERR" ]; then
    echo "--- QEMU stderr:" >&2
    cat "$QEMU_SERIAL_ERR" >&2
  fi
  if [ -n "$QEMU_SERIAL_OUT" ] && [ -s "$QEMU_SERIAL_OUT" ]; then
    echo "--- program output:" >&2
    cat "$QEMU_SERIAL_OUT" >&2
  fi
  exit 1
}

LEN=8192
elf=$(qemu_serial_build_test uart_echo)
port=${1:-$(qemu_serial_free_port)}
echo "qemu-serial-smoke: $elf on 127.0.0.1:$port"
qemu_serial_start "$elf" "$port"

# The program's protocol (see uart_echo.rs): a ready line, then the echo;
# EOT (0x04) ends it.
python3 - "$port" "$LEN" <<'PY' || fail "the echo over 127.0.0.1:$port"
import random, socket, sys, time

port, n = int(sys.argv[1]), int(sys.argv[2])
READY, QUIT = b"uart_echo ready\n", b"\x04"
s = socket.create_connection(("127.0.0.1", port), timeout=10)
s.settimeout(30)
got = b""
while not got.endswith(READY):
    chunk = s.recv(64)
    if not chunk:
        sys.exit(f"connection closed before the ready line (got {got!r})")
    got += chunk
rng = random.Random(405)
data = bytes(rng.choice([b for b in range(256) if b != QUIT[0]]) for _ in range(n))
t0 = time.monotonic()
s.sendall(data)
echo = b""
try:
    while len(echo) < n:
        chunk = s.recv(4096)
        if not chunk:
            break
        echo += chunk
except socket.timeout:
    pass
if echo != data:
    at = next((i for i, (a, b) in enumerate(zip(echo, data)) if a != b), min(len(echo), n))
    sys.exit(f"echo of {len(echo)} bytes for {n} sent, first difference at byte {at}")
print(f"qemu-serial-smoke: {n} bytes echoed in {time.monotonic() - t0:.1f} s")
s.sendall(QUIT)
s.close()
PY

status=0
qemu_serial_wait 30 || status=$?
[ "$status" = 0 ] || fail "QEMU exit status $status"
out=$(cat "$QEMU_SERIAL_OUT")
printf '%s\n' "$out"
grep -q "uart_echo: $LEN bytes echoed" <<<"$out" || fail "the program did not confirm $LEN bytes"
held=$(sed -n 's/.*receiver held back \([0-9]*\) times.*/\1/p' <<<"$out")
[ "${held:-0}" -gt 0 ] || fail "the receive ring never filled: back-pressure not exercised"
echo "qemu-serial-smoke: passed"

# shellcheck shell=bash
# Run an on-target test image in QEMU (netduinoplus2 = STM32F405) with its
# USART1 on a TCP socket, for scripts that talk to it from the host
# (scripts/qemu-serial-smoke.sh; host-sim's `tcp:HOST:PORT` port).
# Source it, then:
#   elf=$(qemu_serial_build_test NAME)  # build tests/ target NAME, print its ELF
#   port=$(qemu_serial_free_port)       # a free TCP port on 127.0.0.1
#   qemu_serial_start "$elf" "$port"    # QEMU in the background, listening
#   ...connect to 127.0.0.1:$port (the guest starts on the connection)...
#   qemu_serial_wait 30 || status=$?    # QEMU's exit status (semihosting exit)
#   cat "$QEMU_SERIAL_OUT"              # what the program printed
# qemu_serial_start sets an EXIT trap (replacing the caller's) that kills
# QEMU if it still runs (qemu_serial_stop) and removes its log directory.
# QEMU's stdout (the program's semihosting output) is in $QEMU_SERIAL_OUT,
# its stderr in $QEMU_SERIAL_ERR, until then.
#
# The machine flags are scripts/qemu-run.sh's (see its comment), except
# that the serial port is a socket server instead of none. QEMU_ICOUNT
# overrides the -icount options (default shift=0,sleep=off: virtual time
# jumps ahead while the guest idles; sleep=on ties it to the host's clock).
# With wait=on QEMU starts the guest only once a client connected, and
# the USART drops what arrives before the program enabled its receiver:
# a client must wait for a sign of life from the program (or retry)
# before its first bytes count.
# QEMU_TIMEOUT (s, default 600) stops a hung program.

QEMU_SERIAL_PID=
QEMU_SERIAL_OUT=
QEMU_SERIAL_ERR=
QEMU_SERIAL_DIR=

qemu_serial_die() {
  echo "qemu-serial: $*" >&2
  exit 1
}

# Build the test target NAME of tests/ (package qemu-tests) as
# `cargo qemu-test` does, without running it; print its ELF's path.
qemu_serial_build_test() {
  local name=${1:?qemu_serial_build_test NAME}
  local json elf
  json=$(cargo qemu-test --test "$name" --no-run --message-format=json-render-diagnostics) ||
    qemu_serial_die "cannot build test $name"
  elf=$(printf '%s\n' "$json" | python3 -c '
import json, sys
name = sys.argv[1]
for line in sys.stdin:
    msg = json.loads(line)
    if msg.get("reason") == "compiler-artifact" and msg["target"]["name"] == name and msg.get("executable"):
        print(msg["executable"])
' "$name")
  [ -n "$elf" ] && [ -f "$elf" ] || qemu_serial_die "cargo built no executable for test $name"
  printf '%s\n' "$elf"
}

# A TCP port on 127.0.0.1 free right now.
qemu_serial_free_port() {
  python3 -c '
import socket
s = socket.socket()
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1])
'
}

# Kill QEMU if it still runs.
qemu_serial_stop() {
  if [ -n "$QEMU_SERIAL_PID" ] && kill -0 "$QEMU_SERIAL_PID" 2>/dev/null; then
    kill "$QEMU_SERIAL_PID" 2>/dev/null || true
    wait "$QEMU_SERIAL_PID" 2>/dev/null || true
  fi
  QEMU_SERIAL_PID=
}

# The EXIT trap: stop QEMU, remove its logs.
qemu_serial_cleanup() {
  qemu_serial_stop
  if [ -n "$QEMU_SERIAL_DIR" ]; then
    rm -rf "$QEMU_SERIAL_DIR"
  fi
}

# Start ELF in QEMU with USART1 on a socket server at 127.0.0.1:PORT and
# return once QEMU listens (the guest has not started yet).
qemu_serial_start() {
  local elf=${1:?qemu_serial_start ELF PORT} port=${2:?qemu_serial_start ELF PORT}
  local i
  [ -f "$elf" ] || qemu_serial_die "$elf: no such image"
  [ -z "$QEMU_SERIAL_PID" ] || qemu_serial_die "QEMU already started"
  QEMU_SERIAL_DIR=$(mktemp -d "${TMPDIR:-/tmp}/qemu-serial.XXXXXX")
  QEMU_SERIAL_OUT=$QEMU_SERIAL_DIR/stdout
  QEMU_SERIAL_ERR=$QEMU_SERIAL_DIR/stderr
  trap qemu_serial_cleanup EXIT
  # `timeout` passes our kill on to QEMU.
  timeout "${QEMU_TIMEOUT:-600}" \
    qemu-system-arm -machine netduinoplus2 -nographic -monitor none \
    -chardev "socket,id=usart1,host=127.0.0.1,port=$port,server=on,wait=on" \
    -serial chardev:usart1 \
    -icount "${QEMU_ICOUNT:-shift=0,sleep=off}" -semihosting-config enable=on,target=native \
    -kernel "$elf" >"$QEMU_SERIAL_OUT" 2>"$QEMU_SERIAL_ERR" &
  QEMU_SERIAL_PID=$!
  for ((i = 0; i < 100; i++)); do
    if grep -q 'waiting for connection' "$QEMU_SERIAL_ERR" 2>/dev/null; then
      return 0
    fi
    if ! kill -0 "$QEMU_SERIAL_PID" 2>/dev/null; then
      cat "$QEMU_SERIAL_ERR" >&2
      qemu_serial_die "QEMU ended before listening on 127.0.0.1:$port"
    fi
    sleep 0.1
  done
  cat "$QEMU_SERIAL_ERR" >&2
  qemu_serial_stop
  qemu_serial_die "QEMU is not listening on 127.0.0.1:$port after 10 s"
}

# Wait at most SECONDS for QEMU to end; return its exit status (124 and
# QEMU killed when it did not end in time). Call it in this shell, not in
# a subshell ($(...)): only this shell can collect QEMU's status.
qemu_serial_wait() {
  local seconds=${1:?qemu_serial_wait SECONDS} status=0 i
  for ((i = 0; i < seconds * 10; i++)); do
    kill -0 "$QEMU_SERIAL_PID" 2>/dev/null || break
    sleep 0.1
  done
  if kill -0 "$QEMU_SERIAL_PID" 2>/dev/null; then
    echo "qemu-serial: QEMU still running after $seconds s: stopped" >&2
    qemu_serial_stop
    status=124
  else
    wait "$QEMU_SERIAL_PID" || status=$?
    QEMU_SERIAL_PID=
  fi
  return "$status"
}

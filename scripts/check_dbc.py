#!/usr/bin/env python3
"""The DBC file and the Rust protocol code agree, checked with independent tools.

1. Rust -> DBC: every frame the Rust encoder produced (the `can_vectors`
   example: id, data, and the physical value of every signal) is decoded by
   `cantools` against the DBC; every signal of the DBC message must be
   present on the Rust side and vice versa, and every value must match
   (`null` must be the DBC's `not_available` code). Every CRC is checked
   with the `autosar-e2e` package's E2E profile 1 implementation, and the
   counters must run 0, 1, ..., 14, 0, ... per identifier.
2. DBC -> Rust: `cantools` encodes frames of every DBC message (every
   enumerated value, range ends, random values, not-available codes),
   `autosar-e2e` protects them, and `host-sim decode --json` must decode
   each to the same physical values. A corrupted frame must be reported as
   a bad CRC and a skipped counter as a counter jump.
3. Acknowledge frames (LM_Command): each vector names its key and the
   challenge it answers; the tag in bytes 2..8 must be the first 6 bytes
   of HMAC-SHA256(key, "LM" 0x01 id-LE command counter challenge-LE),
   computed here with Python's own `hmac`, and the CRC covers the tag.
4. Node numbers: a vector with "node": N carries a frame of the monitor
   at node N; its identifier must be the DBC message's + 0x20 * N (the
   rule the DBC's comment states), and its CRC and tag are computed over
   that identifier.

usage: check_dbc.py DBC VECTORS.jsonl HOST_SIM_BINARY
"""

import hashlib
import hmac
import json
import random
import subprocess
import sys
import tempfile

import cantools
import e2e

COUNTER_MODULUS = 15
NODE_STRIDE = 0x20
HEADER = ("CRC", "Counter")

failures = []


def fail(msg):
    failures.append(msg)
    print("FAIL:", msg, file=sys.stderr)


def not_available_raw(signal):
    for raw, name in (signal.choices or {}).items():
        if str(name) == "not_available":
            return raw
    return None


def raw_of(signal, physical):
    return round((physical - signal.offset) / signal.scale)


def same(a, b):
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


def check_ack_tag(where, v, data, counter):
    ack = v["ack"]
    key = bytes.fromhex(ack["key"])
    command = data[1] >> 4
    msg = b"LM\x01" + v["id"].to_bytes(2, "little") + bytes([command, counter])
    msg += ack["challenge"].to_bytes(4, "little")
    tag = hmac.new(key, msg, hashlib.sha256).digest()[:6]
    if data[2:8] != tag:
        fail(f"{where}: tag {data[2:8].hex()}, HMAC-SHA256 gives {tag.hex()}")
        return 0
    return 1


def check_rust_frames(db, vectors):
    counters = {}
    checked = 0
    tags = 0
    nodes = set()
    for n, v in enumerate(vectors, 1):
        where = f"vector {n} ({v['message']})"
        data = bytes.fromhex(v["data"])
        node = v.get("node", 0)
        if node:
            nodes.add(node)
        try:
            msg = db.get_message_by_frame_id(v["id"] - NODE_STRIDE * node)
        except KeyError:
            fail(f"{where}: id {v['id']:#x} of node {node} not in the DBC")
            continue
        if msg.name != v["message"]:
            fail(f"{where}: the DBC calls id {v['id']:#x} {msg.name}")
        if len(data) != msg.length:
            fail(f"{where}: {len(data)} bytes, the DBC says {msg.length}")
            continue
        if not e2e.p01.e2e_p01_check(bytearray(data), v["id"]):
            fail(f"{where}: E2E profile 1 CRC check failed for {v['data']}")
        decoded = msg.decode(data, decode_choices=False)
        want = counters.get(v["id"], 0)
        if decoded["Counter"] != want:
            fail(f"{where}: counter {decoded['Counter']}, expected {want}")
        counters[v["id"]] = (decoded["Counter"] + 1) % COUNTER_MODULUS
        if "ack" in v:
            tags += check_ack_tag(where, v, data, decoded["Counter"])
        rust = v["signals"]
        dbc_names = {s.name for s in msg.signals} - set(HEADER)
        if set(rust) != dbc_names:
            fail(
                f"{where}: signals differ: only in Rust {sorted(set(rust) - dbc_names)}, "
                f"only in the DBC {sorted(dbc_names - set(rust))}"
            )
        for name in sorted(dbc_names & set(rust)):
            sig = msg.get_signal_by_name(name)
            got = decoded[name]
            exp = rust[name]
            checked += 1
            if exp is None:
                na = not_available_raw(sig)
                if na is None:
                    fail(f"{where}: {name} not available in Rust, the DBC has no not_available code")
                elif raw_of(sig, got) != na:
                    fail(f"{where}: {name} not available in Rust, cantools reads {got}")
            elif not same(got, exp):
                fail(f"{where}: {name}: Rust {exp}, cantools {got}")
    print(
        f"Rust -> DBC: {len(vectors)} frames, {checked} signals compared, "
        f"{tags} acknowledge tags verified, nodes other than 0: {sorted(nodes)}"
    )
    if not nodes:
        fail("no frame of a node other than 0 among the vectors")
    if tags == 0:
        fail("no acknowledge frame with a verified tag among the vectors")


def values_for(signal, rng):
    """Physical values to encode for one signal."""
    named = [raw for raw in (signal.choices or {}) if raw != not_available_raw(signal)]
    if named:
        return [float(raw) * signal.scale + signal.offset for raw in named]
    lo = raw_of(signal, signal.minimum)
    hi = raw_of(signal, signal.maximum)
    raws = [lo, hi, (lo + hi) // 2] + [rng.randint(lo, hi) for _ in range(3)]
    return [r * signal.scale + signal.offset for r in raws]


def build_frames(db, rng):
    """(message, data, expected physical values) for every DBC message."""
    frames = []
    for msg in db.messages:
        payload = [s for s in msg.signals if s.name not in HEADER]
        choices = {s.name: values_for(s, rng) for s in payload}
        # NA codes of numeric signals, e.g. -32768 on an i16 quantity.
        for s in payload:
            na = not_available_raw(s)
            if na is not None:
                choices[s.name].append(na * s.scale + s.offset)
        rounds = max(len(v) for v in choices.values())
        for k in range(rounds):
            values = {name: vals[k % len(vals)] for name, vals in choices.items()}
            values["CRC"] = 0
            values["Counter"] = 0
            data = bytearray(msg.encode(values, strict=False))
            frames.append((msg, data))
    return frames


def check_rust_decoder(db, host_sim, rng):
    frames = build_frames(db, rng)
    counters = {}
    lines = []
    expected = []
    t = 1_700_000_000.0
    for msg, data in frames:
        c = counters.get(msg.frame_id, 0)
        counters[msg.frame_id] = (c + 1) % COUNTER_MODULUS
        data[1] = (data[1] & 0xF0) | c
        e2e.p01.e2e_p01_protect(data, msg.frame_id, increment_counter=False)
        t += 0.001
        lines.append(f"({t:.6f}) vcan0 {msg.frame_id:03X}#{data.hex().upper()}")
        expected.append((msg, bytes(data), "ok", None))
    # A corrupted frame and a skipped counter must be flagged.
    bad = bytearray(expected[-1][1])
    bad[5] ^= 0x04
    last = expected[-1][0]
    lines.append(f"({t + 0.001:.6f}) vcan0 {last.frame_id:03X}#{bad.hex().upper()}")
    expected.append((last, bytes(bad), "bad_crc", None))
    skip = bytearray(expected[-2][1])
    c = counters[last.frame_id]
    skip[1] = (skip[1] & 0xF0) | ((c + 1) % COUNTER_MODULUS)
    e2e.p01.e2e_p01_protect(skip, last.frame_id, increment_counter=False)
    lines.append(f"({t + 0.002:.6f}) vcan0 {last.frame_id:03X}#{skip.hex().upper()}")
    expected.append((last, bytes(skip), "counter_jump", 1))

    with tempfile.NamedTemporaryFile("w", suffix=".log", delete=False) as f:
        f.write("\n".join(lines) + "\n")
        log = f.name
    run = subprocess.run([host_sim, "decode", "--json", log], capture_output=True, text=True)
    if run.returncode != 0:
        fail(f"host-sim decode exited {run.returncode}: {run.stderr.strip()}")
        return
    records = [json.loads(line) for line in run.stdout.splitlines()]
    if len(records) != len(expected):
        fail(f"host-sim decode printed {len(records)} records for {len(expected)} frames")
        return
    compared = 0
    for n, (rec, (msg, data, outcome, lost)) in enumerate(zip(records, expected), 1):
        where = f"frame {n} ({msg.name} {data.hex().upper()})"
        if rec.get("message") != msg.name or rec["id"] != msg.frame_id:
            fail(f"{where}: decoded as {rec.get('message')} id {rec['id']:#x}")
            continue
        if rec["outcome"] != outcome:
            fail(f"{where}: outcome {rec['outcome']} ({rec['text']}), expected {outcome}")
            continue
        if lost is not None and rec.get("lost") != lost:
            fail(f"{where}: {rec.get('lost')} frames lost, expected {lost}")
        if outcome == "bad_crc":
            continue
        want = msg.decode(data, decode_choices=False)
        if rec["counter"] != want["Counter"]:
            fail(f"{where}: counter {rec['counter']}, cantools {want['Counter']}")
        got = rec["signals"]
        names = {s.name for s in msg.signals} - set(HEADER)
        if set(got) != names:
            fail(f"{where}: signals {sorted(got)}, the DBC has {sorted(names)}")
            continue
        for name in sorted(names):
            sig = msg.get_signal_by_name(name)
            w = want[name]
            na = not_available_raw(sig)
            compared += 1
            if na is not None and raw_of(sig, w) == na:
                if got[name] is not None:
                    fail(f"{where}: {name}: not_available encoded, Rust decoded {got[name]}")
            elif got[name] is None or not same(got[name], w):
                fail(f"{where}: {name}: cantools encoded {w}, Rust decoded {got[name]}")
    print(f"DBC -> Rust: {len(records)} frames, {compared} signals compared")


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    dbc, vectors_path, host_sim = sys.argv[1:]
    db = cantools.database.load_file(dbc)
    with open(vectors_path) as f:
        vectors = [json.loads(line) for line in f if line.strip()]
    if not vectors:
        sys.exit(f"{vectors_path}: no vectors")
    kinds = {v["message"] for v in vectors}
    missing = {m.name for m in db.messages} - kinds
    if missing:
        fail(f"no Rust-encoded frames for {sorted(missing)}")
    check_rust_frames(db, vectors)
    check_rust_decoder(db, host_sim, random.Random(4))
    if failures:
        sys.exit(f"{len(failures)} disagreements between the DBC and the code")
    print("the DBC and the code agree")


if __name__ == "__main__":
    main()

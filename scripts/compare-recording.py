#!/usr/bin/env python3
"""Compare a recording captured by `host-sim record` with the samples it
must contain: `compare-recording.py EXPECTED.csv RECORDED.csv[.gz]`.

EXPECTED holds each value as the exact f32 the monitor stepped (written by
tests/build/emu.rs); RECORDED prints them with the recording writer's fixed
decimals (host-sim/src/recording/write.rs). Every row must be there, in
order, every empty field (an invalid reading) in the same place, and every
value equal up to half a unit of the printed last digit. Exit 0 if so;
else 1 with the first differences, naming row and column."""
import csv
import gzip
import sys

# Decimals the recording writer prints per column.
DECIMALS = {"t": 4, "p_supply": 3, "p_piston": 3, "p_rod": 3, "p_tank": 3,
            "x_piston": 6, "u_valve": 5, "temp_oil": 2}


def rows(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt", newline="") as f:
        lines = [l for l in f if not l.startswith("#")]
    return list(csv.DictReader(lines))


def main(expected_path, recorded_path):
    expected, recorded = rows(expected_path), rows(recorded_path)
    problems = []
    if len(recorded) != len(expected):
        problems.append(f"{len(recorded)} rows recorded, {len(expected)} expected")
    columns = [c for c in DECIMALS if c in expected[0]]
    missing = [c for c in columns if c not in recorded[0]] if recorded else columns
    if missing:
        problems.append(f"recorded columns missing: {', '.join(missing)}")
    for i, (e, r) in enumerate(zip(expected, recorded)):
        for c in columns:
            if c in missing:
                continue
            ev, rv = e[c], r[c]
            if (ev == "") != (rv == ""):
                problems.append(f"row {i + 1}, {c}: expected {ev or 'empty'}, recorded {rv or 'empty'}")
            elif ev:
                tol = 0.5 * 10 ** -DECIMALS[c] + 1e-6 * abs(float(ev)) + 1e-12
                if abs(float(rv) - float(ev)) > tol:
                    problems.append(f"row {i + 1}, {c}: expected {ev}, recorded {rv}")
        if len(problems) > 20:
            break
    if problems:
        print(f"{recorded_path} differs from {expected_path}:", file=sys.stderr)
        for p in problems[:20]:
            print(f"  {p}", file=sys.stderr)
        return 1
    print(f"{recorded_path}: {len(recorded)} samples, all equal to {expected_path} "
          f"(to the printed precision)")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2]))

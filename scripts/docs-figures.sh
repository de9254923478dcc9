#!/usr/bin/env bash
# Regenerate the measured figures in README.md and docs/: rerun what produces
# them and rewrite the marked blocks
#     <!-- figures:NAME:begin -->  …  <!-- figures:NAME:end -->
# in place. Text outside the markers is never touched; commit the result
# together with the change that moved the figures.
#
#   scripts/docs-figures.sh                  the default producers (below)
#   scripts/docs-figures.sh eval size        only these
#   REUSE=1 scripts/docs-figures.sh eval     rewrite from the outputs already in
#                                            target/docs-figures/ (no rerun)
#   EVAL_CACHE=DIR scripts/docs-figures.sh   the eval producers pass `--cache DIR`
#                                            (the plant runs are simulated once;
#                                            calibration and replay always rerun,
#                                            and the report says how many came
#                                            from the cache)
#
# Producers (outputs are kept in target/docs-figures/):
#   examples    host-sim replay --json of examples/*.csv.gz (their rig's set) → README.md (seconds)
#   golden      host-sim golden write of the two golden cases,
#               into target/ (the committed goldens are not touched) → docs/on-target-tests.md
#   throughput  a simulated 300 s recording (plain CSV), replayed 3 times;
#               the median, with the CPU it ran on                → docs/performance.md (~1 min)
#   eval        host-sim eval --set dev --quick                  → docs/evaluation.md (~5–8 min on 2 cores)
#   size        release firmware: flash, static RAM (same ELF reading as
#               scripts/test.sh), scripts/stack_estimate.py      → docs/firmware.md (a few min)
# Not in the default set (long, or need QEMU); run them by name:
#   bench       cargo qemu-bench: instructions per Monitor::step, static RAM,
#               stack high-water mark (needs qemu-system-arm)    → docs/performance.md
#   holdout     host-sim eval --set holdout --quick              → docs/evaluation.md (~5 min)
#   wide        host-sim eval --set wide --quick (24 further
#               development rigs)                                → docs/evaluation.md (~6 min; 2 from the cache)
#   survey      host-sim eval --set survey --quick (48 survey
#               development rigs)                                → docs/evaluation.md (~20 min; 3 from the cache)
#   surveyN     host-sim eval --set surveyN --quick, N ≥ 2 (the
#               Nth survey's 48 rigs; host-sim eval --help)      → docs/evaluation.md (~7 min each; 3 from the cache)
#   dev-full    host-sim eval --set dev (full matrix, 522 runs)  → docs/evaluation.md (~15 min or more)
# A block that has never been regenerated says so and names the commit its
# figures were measured at; running its producer replaces that note.
#
# Not produced here, and marked as such where they appear: the per-call-site
# profile of scripts/profile.sh (needs gcc and an LLVM build of the plugin)
# and the emulated board's frame-by-frame account (read from the output of
# `cargo qemu-test`).
set -euo pipefail
cd "$(dirname "$0")/.."

out=target/docs-figures
mkdir -p "$out"
hs=target/release/host-sim
reuse=${REUSE:-0}
# The figures depend on the code, not on the docs: name the last commit that
# changed what produces them (documentation-only commits do not move it).
code=(monitor plant host-sim firmware tests golden examples Cargo.toml Cargo.lock .cargo memory.x rust-toolchain.toml)
commit=$(git log -1 --format=%h -- "${code[@]}" 2>/dev/null || echo unknown)
dirty=$(git status --porcelain --untracked-files=no -- "${code[@]}" 2>/dev/null | head -1)
[ -z "$dirty" ] || commit="$commit + uncommitted changes"
rustc_v=$(rustc --version | cut -d' ' -f2)

step() { printf '\n==> %s\n' "$*"; }

# replace_block FILE NAME BODY: rewrite the marked block NAME in FILE with the
# contents of the file BODY.
replace_block() {
  python3 - "$1" "$2" "$3" <<'PY'
import sys
path, name = sys.argv[1], sys.argv[2]
body = open(sys.argv[3], encoding='utf-8').read().strip('\n')
if not body.strip():
    sys.exit(f'{path}: figures:{name}: the producer gave nothing; block left as it was')
begin, end = f'<!-- figures:{name}:begin -->', f'<!-- figures:{name}:end -->'
text = open(path, encoding='utf-8').read()
if text.count(begin) != 1 or text.count(end) != 1:
    sys.exit(f'{path}: expected exactly one {begin} … {end} block')
a = text.index(begin) + len(begin)
b = text.index(end)
if b < a:
    sys.exit(f'{path}: {end} before {begin}')
open(path, 'w', encoding='utf-8').write(text[:a] + '\n' + body + '\n' + text[b:])
print(f'{path}: figures:{name} rewritten')
PY
}

build_host_sim() {
  [ "$reuse" = 1 ] && [ -x "$hs" ] && return
  cargo build --release --quiet -p host-sim
}

fig_examples() {
  step "examples: host-sim replay --json --params examples/reference-rig.toml examples/*.csv.gz"
  if [ "$reuse" != 1 ] || [ ! -s "$out/examples.jsonl" ]; then
    build_host_sim
    "$hs" replay --json --params examples/reference-rig.toml examples/healthy.csv.gz examples/internal.csv.gz \
      examples/external.csv.gz examples/both.csv.gz > "$out/examples.jsonl"
  fi
  python3 - "$out/examples.jsonl" <<'PY' > "$out/examples.block.md"
import json, sys
print('| recording | verdict | first alarm | internal leak estimate | external leak estimate | mean NIS | noise (p_piston) |')
print('|---|---|---|---|---|---|---|')
for line in open(sys.argv[1]):
    r = json.loads(line)
    name = r['recording'].split('/')[-1]
    fa = '–' if r['first_alarm_s'] is None else f"{r['first_alarm_s']:.1f} s"
    lpm = lambda v: '–' if v is None else f'{v:.3f} l/min'
    nis = '–' if r.get('mean_nis') is None else f"{r['mean_nis']:.1f}"
    print(f"| `{name}` | {r['verdict']} | {fa} | {lpm(r['leak_internal_lpm'])} | "
          f"{lpm(r['leak_external_lpm'])} | {nis} | {r['noise']['p_piston_bar']:.3f} bar |")
PY
  replace_block README.md examples "$out/examples.block.md"
}

fig_golden() {
  step "golden: the golden cases' summaries (written into $out, not golden/data)"
  if [ "$reuse" != 1 ] || [ ! -s "$out/golden.txt" ]; then
    build_host_sim
    # The same arguments as scripts/golden.sh.
    {
      "$hs" golden write examples/healthy.csv.gz --samples 3000 --warm-up 1 -o "$out/golden-healthy"
      "$hs" golden write examples/both.csv.gz --samples 8000 --warm-up 1 -o "$out/golden-both"
    } > "$out/golden.txt"
  fi
  {
    echo "\`scripts/docs-figures.sh golden\` at commit \`$commit\`:"
    echo
    echo '```'
    cat "$out/golden.txt"
    echo '```'
  } > "$out/golden.block.md"
  replace_block docs/on-target-tests.md golden "$out/golden.block.md"
}

fig_throughput() {
  step "throughput: replay of a simulated 300 s recording (plain CSV), 3 runs"
  if [ "$reuse" != 1 ] || [ ! -s "$out/throughput.txt" ]; then
    build_host_sim
    [ -s "$out/throughput.csv" ] || "$hs" simulate -o "$out/throughput.csv" --duration 300
    for _ in 1 2 3; do
      "$hs" replay --params examples/reference-rig.toml "$out/throughput.csv" | sed -n 's/^throughput *\([0-9]*\) samples\/s/\1/p'
    done > "$out/throughput.txt"
  fi
  cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo 2>/dev/null | head -1)
  cores=$(nproc 2>/dev/null || echo '?')
  [ "$reuse" = 1 ] && [ -s "$out/throughput.load" ] || cut -d' ' -f1 /proc/loadavg > "$out/throughput.load" 2>/dev/null || echo '?' > "$out/throughput.load"
  python3 - "$out/throughput.txt" "$cpu" "$cores" "$commit" "$(cat "$out/throughput.load")" <<'PY' > "$out/throughput.block.md"
import sys
runs = sorted(int(x) for x in open(sys.argv[1]) if x.strip())
med = runs[len(runs) // 2]
fmt = lambda n: f'{n:,}'.replace(',', ' ')
print(f'Replay throughput, release build, one thread, plain CSV, a 300 s simulated '
      f'recording: **{fmt(med)} samples per second** (median of {len(runs)} runs: '
      f'{", ".join(fmt(r) for r in runs)}), i.e. about {med // 1000}× real time at 1 kHz. '
      f'Measured by `scripts/docs-figures.sh throughput` at commit `{sys.argv[4]}` on '
      f'{sys.argv[2] or "an unnamed CPU"} ({sys.argv[3]} cores, load average {sys.argv[5]} '
      f'when measured: other work shares the machine, so take it as an order of magnitude).')
PY
  replace_block docs/performance.md throughput "$out/throughput.block.md"
}

# eval_block NAME TITLE ARGS…: run host-sim eval ARGS and put its report,
# headings demoted by one level, into the block NAME of docs/evaluation.md.
eval_block() {
  local name=$1
  shift
  step "eval ($name): host-sim eval $*"
  if [ "$reuse" != 1 ] || [ ! -s "$out/eval-$name.md" ]; then
    build_host_sim
    "$hs" eval "$@" ${EVAL_CACHE:+--cache "$EVAL_CACHE"} --json "$out/eval-$name.json" -o "$out/eval-$name.md"
  fi
  python3 - "$out/eval-$name.md" "$commit" "$*" <<'PY' > "$out/eval-$name.block.md"
import re, sys
lines = open(sys.argv[1], encoding='utf-8').read().split('\n')
# The report: a title, a line with the matrix and wall time, a paragraph on
# the method (docs/evaluation.md says it once), then one section per set.
stats = next(l for l in lines if l.startswith('`host-sim eval'))
first = next(i for i, l in enumerate(lines) if l.startswith('## '))
print(f'`scripts/docs-figures.sh` ran `host-sim eval {sys.argv[3]}` at commit `{sys.argv[2]}`: '
      + stats[stats.index(':') + 2:])
print()
for l in lines[first:]:
    print('#' + l if re.match(r'#{2,5} ', l) else l)
PY
  replace_block docs/evaluation.md "eval-$name" "$out/eval-$name.block.md"
}

fig_size() {
  step "size: release firmware (flash, static RAM, stack estimate)"
  local elf=target/thumbv7em-none-eabihf/release/firmware
  if [ "$reuse" != 1 ] || [ ! -s "$out/size.txt" ]; then
    command -v flip-link >/dev/null || { echo "size: needs flip-link (cargo install flip-link --locked)"; exit 1; }
    cargo build --quiet -p firmware --release --target thumbv7em-none-eabihf
    {
      # Sum the allocated sections as scripts/test.sh does.
      python3 scripts/firmware_size.py --vars "$elf"
      python3 scripts/stack_estimate.py "$elf"
    } > "$out/size.txt"
  fi
  python3 - "$out/size.txt" "$commit" "$rustc_v" <<'PY' > "$out/size.block.md"
import re, sys
text = open(sys.argv[1]).read()
val = lambda k: int(re.search(rf'^{k}=(\d+)', text, re.M).group(1))
part = lambda label: int(re.search(rf'^{re.escape(label)}\s+(\d+) B', text, re.M).group(1))
flash, ram, stack = val('FLASH'), val('RAM'), val('STACK_ESTIMATE')
b = lambda n: f'{n:,} B ({n / 1024:.1f} KiB)'.replace(',', ' ')
print(f'Measured by `scripts/docs-figures.sh size` at commit `{sys.argv[2]}` (rustc {sys.argv[3]}).')
print()
print('| | used | budget |')
print('|---|---|---|')
print(f'| flash (vector table, code, constants, `.data` image) | {b(flash)} | 256 KiB |')
print(f'| static RAM (`.data`, `.bss`, RTT buffer) | {b(ram)} | |')
print(f'| stack, worst case (estimate) | {b(stack)} | |')
print(f'| RAM in all | {b(ram + stack)} | 48 KiB |')
print()
n = lambda label: f'{part(label):,} B'.replace(',', ' ')
usb = f'the USB interrupt preempting it {n("USB interrupt")}, ' if re.search(r'^USB interrupt', text, re.M) else ''
print(f'Stack estimate by part: thread mode {n("thread mode")}, {usb}the estimator\'s interrupt '
      f'executor preempting it {n("estimator (UART4)")}, one interrupt handler '
      f'{n("HAL interrupt")}, exception frames {n("exception frames")} '
      f'(`python3 scripts/stack_estimate.py target/thumbv7em-none-eabihf/release/firmware` '
      f'prints the deepest chains).')
PY
  replace_block docs/firmware.md size "$out/size.block.md"
}

fig_bench() {
  step "bench: cargo qemu-bench (QEMU netduinoplus2)"
  if [ "$reuse" != 1 ] || [ ! -s "$out/bench.txt" ]; then
    cargo qemu-bench 2>&1 | tee "$out/bench.log" | grep '^budget:' > "$out/bench.txt"
  fi
  python3 - "$out/bench.txt" "$commit" <<'PY' > "$out/bench.block.md"
import re, sys
text = open(sys.argv[1]).read()
fmt = lambda n: f'{int(n):,}'.replace(',', ' ')
def phase(label):
    m = re.search(rf'budget: {re.escape(label)}\s+steps\s+(\d+)\s+mean\s+(\d+)\s+min\s+(\d+)\s+max\s+(\d+)', text)
    return m.groups() if m else None
head = re.search(r'over (\d+) samples of (\S+) \(warm-up ([\d.]+) s\)', text)
print(f'`scripts/docs-figures.sh bench` at commit `{sys.argv[2]}`: release build, `monitor` at '
      f'opt-level 3, {fmt(head.group(1))} samples of `{head.group(2)}` (warm-up {head.group(3)} s).')
print()
print('| | steps | instructions per `Monitor::step`, mean | min | max |')
print('|---|---:|---:|---:|---:|')
for label, name in [('first (bank start)', 'first sample (bank start)'), ('warm-up', 'warm-up'),
                    ('estimating/deciding', 'estimating and deciding'), ('all', '**all**')]:
    g = phase(label)
    if g:
        print(f'| {name} | {fmt(g[0])} | {fmt(g[1])} | {fmt(g[2])} | {fmt(g[3])} |')
print()
for pat in [r'budget: (1 ms at 168 MHz.*)', r'budget: (goal .*)', r'budget: (static RAM .*)',
            r'budget: (stack high-water mark .*)']:
    m = re.search(pat, text)
    if m:
        print(f'- {m.group(1)}')
PY
  replace_block docs/performance.md bench "$out/bench.block.md"
}

producers=("$@")
[ ${#producers[@]} -gt 0 ] || producers=(examples golden throughput eval size)
for p in "${producers[@]}"; do
  case $p in
    examples) fig_examples ;;
    golden) fig_golden ;;
    throughput) fig_throughput ;;
    eval) eval_block dev-quick --set dev --quick ;;
    # A `--quick` set by its `--set` name (host-sim refuses a set it lacks).
    holdout | wide | survey | survey[2-9] | survey[1-9][0-9]) eval_block "$p-quick" --set "$p" --quick ;;
    dev-full) eval_block dev-full --set dev ;;
    size) fig_size ;;
    bench) fig_bench ;;
    *) echo "unknown producer: $p (examples golden throughput eval size bench holdout wide survey surveyN dev-full; surveyN: see host-sim eval --help)"; exit 2 ;;
  esac
done
step "done: review with git diff README.md docs/"

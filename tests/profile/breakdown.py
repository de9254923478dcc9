#!/usr/bin/env python3
"""Where the instructions of one function go: a call tree with inlined
frames, from an insn_profile.so profile of an ELF built with full debug
info (scripts/profile.sh does all of it).

  breakdown.py ELF PROFILE [--root REGEX] [--min PERCENT] [--depth N]

Values are instructions per call of the root function (default:
Monitor::step, or the budget benchmark's monitor_step wrapper when the
compiler has inlined Monitor::step into it). Inclusive costs of call sites are exact (shadow call
stack); the split of a callee's cost among its own inlined frames and
callees is its average over all calls (exact when, as here, a function
costs the same from every call site)."""
import argparse
import collections
import json
import re
import subprocess
import sys


def clean(name):
    name = re.sub(r"nalgebra::base::dimension::Const<(\d+)>", r"\1", name)
    name = re.sub(r"nalgebra::base::array_storage::ArrayStorage<f32, \d+, \d+>", "", name)
    name = re.sub(r"nalgebra::base::matrix::Matrix<f32, (\d+), (\d+), >", r"M\1x\2", name)
    name = re.sub(r"\b(core|monitor|nalgebra|compiler_builtins|libm)::(\w+::)*", lambda m: m.group(1) + "::" if m.group(1) in ("libm",) else "", name)
    name = re.sub(r"::h[0-9a-f]{16}$", "", name)
    return name


OURS = "/monitor/src/"


def symbolize(elf, addrs):
    """Address -> frames, innermost first: (function, file name, line)."""
    text = "\n".join("0x%x" % a for a in addrs) + "\n"
    out = subprocess.run(
        ["llvm-symbolizer", "--obj=" + elf, "--inlining", "--output-style=JSON"],
        input=text, capture_output=True, text=True, check=True).stdout
    frames = {}
    for line in out.splitlines():
        if not line.strip():
            continue
        j = json.loads(line)
        a = int(j["Address"], 16)
        frames[a] = [(clean(s["FunctionName"]) or "?", s["FileName"], s["Line"]) for s in j["Symbol"]]
    return frames


def inline_path(f):
    """Labels of the inlined frames, outermost first, down to the first
    frame outside the monitor crate (library internals are collapsed)."""
    path = []
    for i in range(len(f) - 2, -1, -1):
        path.append(f[i][0])
        if OURS not in f[i][1]:
            break
    return tuple(path)


def site(f):
    """Where a call is made: file:line of the innermost frame of ours."""
    for name, file, line in f:
        if OURS in file:
            return " (%s:%d)" % (file.split("/")[-1], line)
    return ""


def call_targets(elf):
    out = subprocess.run(["llvm-objdump", "-d", "--no-show-raw-insn", elf],
                         capture_output=True, text=True, check=True).stdout
    t = {}
    for m in re.finditer(r"^\s*([0-9a-f]+):\s+(bl|blx)\s+(\S+)", out, re.M):
        pc, op, arg = int(m.group(1), 16), m.group(2), m.group(3)
        t[pc] = int(arg, 16) if arg.startswith("0x") else None
    return t


class Node:
    def __init__(self):
        self.self_ = 0.0
        self.kids = collections.OrderedDict()

    def total(self):
        return self.self_ + sum(k.total() for k in self.kids.values())

    def child(self, label):
        return self.kids.setdefault(label, Node())


# (A label may be a call site, "call F (file.rs:N)": patterns end at " (" too.)
# Stages of one filter's step (first match along the path below the filter).
STAGES = [
    ("predict: mean (Plant::advance)", r"Plant<f32>>::advance"),
    ("predict: Φ (Transition::new)", r"Transition<f32, \d+>>::new( \(|$)"),
    ("predict: covariance (Transition::predict_covariance)", r">::predict_covariance( \(|$)"),
    ("update: 3 scalar Joseph updates (update_state_weighted)", r">::update_state_weighted(::<[^>]*>)?( \(|$)"),
    ("update: readings, weights, NIS (HypothesisFilter::update)", r"HypothesisFilter<f32, \d+>>::update( \(|$)"),
    ("finiteness check (Ekf::check_finite)", r">::check_finite( \(|$)"),
    ("outputs, log-likelihood, leak flows", r""),
]
# Kinds of work across the whole step (first match anywhere on the path).
KINDS = [
    ("memcpy / memset", r"__aeabi_mem"),
    ("software f64 arithmetic (__aeabi_d*)", r"__aeabi_(d|f2d|ui2d|l2d)"),
    ("transcendentals (libm expf/logf, vsqrt)", r"libm::|Real>::(exp|ln|sqrt)$|sqrt_f32"),
    ("plant model (Plant::advance)", r"Plant<f32>>::advance"),
    ("Joseph-form scalar updates", r">::update_state_weighted(::<[^>]*>)?( \(|$)"),
    ("covariance prediction (sparse, in place)", r">::predict_covariance( \(|$)"),
    ("transition Φ (Transition::new)", r"Transition<f32, \d+>>::new( \(|$)"),
    ("finiteness checks (Ekf::check_finite)", r">::check_finite( \(|$)"),
    ("decision layer (Decision::update)", r"Decision<f32>>::update"),
    ("input checks (SampleChecker::check)", r"SampleChecker>::check"),
    ("everything else", r""),
]


def leaf_paths(node, path=()):
    if node.self_:
        yield path, node.self_
    for label, k in node.kids.items():
        yield from leaf_paths(k, path + (label,))


def summaries(tree, total):
    print("\nper filter, by stage (instructions per call of the root):")
    filters = []

    def find(node):
        for label, k in node.kids.items():
            if re.search(r"HypothesisFilter<f32, \d+>>::step", label):
                filters.append((label.replace("call ", ""), k))
            else:
                find(k)

    find(tree)
    for label, node in filters:
        sums = collections.OrderedDict((name, 0.0) for name, _ in STAGES)
        for path, v in leaf_paths(node):
            for name, rx in STAGES:
                if any(re.search(rx, l) for l in path) or not rx:
                    sums[name] += v
                    break
        print("%8.0f %5.1f%%  %s" % (node.total(), 100 * node.total() / total, label))
        for name, v in sums.items():
            print("%8.0f %5.1f%%    %s" % (v, 100 * v / total, name))
    print("\nby kind of work (instructions per call of the root):")
    sums = collections.OrderedDict((name, 0.0) for name, _ in KINDS)
    for path, v in leaf_paths(tree):
        for name, rx in KINDS:
            if not rx or any(re.search(rx, l) for l in path):
                sums[name] += v
                break
    for name, v in sums.items():
        print("%8.0f %5.1f%%  %s" % (v, 100 * v / total, name))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("elf")
    ap.add_argument("profile")
    ap.add_argument("--root", default=None,
                    help="regex of the root function (default: Monitor::step, or the "
                         "budget benchmark's monitor_step if Monitor::step is inlined into it)")
    ap.add_argument("--min", type=float, default=0.5, help="hide nodes below this %% of the root")
    ap.add_argument("--depth", type=int, default=12)
    a = ap.parse_args()

    selfc, calls = {}, {}
    for line in open(a.profile):
        p = line.split()
        if p[0] == "i":
            selfc[int(p[1], 16)] = int(p[2])
        elif p[0] == "c":
            calls[int(p[1], 16)] = (int(p[2]), int(p[3]))
    targets = call_targets(a.elf)
    tgt_addrs = {t for pc, t in targets.items() if pc in calls and t is not None}
    frames = symbolize(a.elf, sorted(set(selfc) | set(calls) | tgt_addrs))

    # Per physical function: (inline path) -> self; call sites.
    phys_self = collections.defaultdict(lambda: collections.defaultdict(float))
    phys_calls = collections.defaultdict(list)
    incl_of = collections.defaultdict(float)  # all inclusive cost spent in calls to F
    calls_of = collections.defaultdict(int)
    ours = {}
    for pc, n in selfc.items():
        f = frames[pc]
        phys_self[f[-1][0]][inline_path(f)] += n
        ours[f[-1][0]] = OURS in f[-1][1]
    for pc, (n, incl) in calls.items():
        f = frames[pc]
        t = targets.get(pc)
        g = frames[t][-1][0] if t is not None else "(indirect call)"
        phys_calls[f[-1][0]].append((inline_path(f), g, n, incl, site(f)))
        incl_of[g] += incl
        calls_of[g] += n
    own = {f: sum(phys_self[f].values()) + sum(c[3] for c in phys_calls[f]) for f in phys_self}

    for rx in [a.root] if a.root else [r"Monitor.*>::step$", r"^budget::monitor_step$"]:
        roots = [f for f in phys_self if re.search(rx, f)]
        if roots:
            break
    if len(roots) != 1:
        sys.exit("root %r matches %s" % (a.root, roots or "nothing"))
    root = roots[0]
    n_root = calls_of[root]
    if not n_root:
        sys.exit("the root function was never called")

    def denom(f):
        # All instructions run in f and its callees: through calls, or more
        # if f is also entered by tail calls (then own > incl_of).
        return max(incl_of[f], own.get(f, 0))

    def expand(node, f, scale, depth):
        for path, n in phys_self[f].items():
            d = node
            for label in path:
                d = d.child(label)
            d.self_ += n * scale
        # Code reached by tail calls (branches into other functions).
        rest = denom(f) - own.get(f, 0)
        if rest > 0:
            node.child("(tail-called code)").self_ += rest * scale
        for path, g, n, incl, where in phys_calls[f]:
            d = node
            for label in path:
                d = d.child(label)
            d = d.child("call " + g + (where if ours.get(g) else ""))
            if g == f or not ours.get(g) or not incl_of[g] or depth > 30:
                d.self_ += incl * scale
            else:
                expand(d, g, scale * incl / denom(g), depth + 1)

    tree = Node()
    expand(tree, root, 1.0 / n_root, 0)
    total = tree.total()
    print("%s: %d calls, %.0f instructions per call (inclusive)\n" % (root, n_root, total))

    def show(node, indent, depth):
        rows = sorted(node.kids.items(), key=lambda kv: -kv[1].total())
        hidden = 0.0
        for label, k in rows:
            t = k.total()
            if 100 * t / total < a.min or depth >= a.depth:
                hidden += t
                continue
            print("%8.0f %5.1f%%  %s%s" % (t, 100 * t / total, "  " * indent, label))
            show(k, indent + 1, depth + 1)
        if node.self_ >= 0.5 and (node.kids or indent == 0):
            print("%8.0f %5.1f%%  %s(self)" % (node.self_, 100 * node.self_ / total, "  " * indent))
        if hidden >= 0.5:
            print("%8.0f %5.1f%%  %s(hidden: smaller or deeper)" % (hidden, 100 * hidden / total, "  " * indent))

    show(tree, 0, 0)

    summaries(tree, total)

    # Flat: by leaf (a monitor function's own code, a library construct
    # inlined into it, or a library call), summed over the whole tree.
    flat = collections.defaultdict(float)

    def leaves(node, label):
        if node.self_:
            flat[label] += node.self_
        for l, k in node.kids.items():
            leaves(k, re.sub(r" \(\w+\.rs:\d+\)$", "", l.replace("call ", "")))

    leaves(tree, root)
    print("\nby leaf (own code, or a library construct or call), per call of the root:")
    for label, v in sorted(flat.items(), key=lambda kv: -kv[1])[:30]:
        print("%8.0f %5.1f%%  %s" % (v, 100 * v / total, label))


if __name__ == "__main__":
    main()

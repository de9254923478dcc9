#!/usr/bin/env python3
"""Worst-case stack estimate of the firmware from its disassembly.

Frame size of every function = its prologue (`push`, `vpush`, `sub sp`;
all `sub sp` in a function are added, which over-counts rather than
under-counts). Call graph = direct calls (`bl`, tail `b.w` to a function
start). Indirect calls (`blx rN`) are resolved for the executors (a task
is polled through a function pointer: every `TaskStorage<F>::poll` is a
possible target) and otherwise reported; they are bounded by adding the
largest frame chain of any function reachable that way (see below).

Worst case = deepest thread-mode path (reset -> main -> thread executor
-> task) + the USB interrupt (OTG_FS, priority 7: above thread mode, below
the estimator) preempting it + the estimator's interrupt executor (UART4,
priority 6) preempting that + one HAL interrupt preempting that (DMA, CAN,
timer: one priority level, they do not nest) + one exception frame with
floating-point state (104 bytes) per preemption.

usage: stack_estimate.py ELF  (needs arm-none-eabi-objdump or llvm-objdump)
"""

import glob
import re
import shutil
import subprocess
import sys
from functools import lru_cache

EXC_FRAME_FP = 104  # 8 core + 18 FP words, lazy stacking reserves them

# Functions that poll tasks through a function pointer (identical code
# may carry either name, depending on the disassembler).
EXECUTOR_POLL = (
    r"embassy_executor::(raw::(Sync)?Executor::poll"
    r"|platform::interrupt::InterruptExecutor::on_interrupt"
    r"|platform::thread::Executor::run)"
)


def objdump():
    """GNU objdump for ARM, else llvm-objdump (PATH, or the rustup
    `llvm-tools` component in the sysroot)."""
    tool = shutil.which("arm-none-eabi-objdump") or shutil.which("llvm-objdump")
    if tool:
        return tool
    try:
        sysroot = subprocess.run(
            ["rustc", "--print", "sysroot"], capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        sysroot = ""
    for tool in glob.glob(f"{sysroot}/lib/rustlib/*/bin/llvm-objdump"):
        return tool
    sys.exit("no objdump: install binutils-arm-none-eabi, or `rustup component add llvm-tools`")


def tidy(name):
    """Names as GNU objdump demangles them (llvm-objdump leaves legacy
    Rust escapes and hashes in)."""
    name = re.sub(r"::h[0-9a-f]{16}$", "", name)
    if "$" in name:
        for esc, ch in (("$LT$", "<"), ("$GT$", ">"), ("$u20$", " "), ("$C$", ","),
                        ("$RF$", "&"), ("$BP$", "*"), ("$u7b$", "{"), ("$u7d$", "}"),
                        ("$u27$", "'"), ("$u5b$", "["), ("$u5d$", "]"), ("$u3b$", ";")):
            name = name.replace(esc, ch)
        name = name.replace("..", "::").lstrip("_")
    return name


def number(text):
    return int(text, 16) if text.startswith("0x") else int(text)


def disassemble(elf):
    tool = objdump()
    out = subprocess.run(
        [tool, "-d", "-C", "--no-show-raw-insn", elf], capture_output=True, text=True, check=True
    ).stdout
    funcs = {}
    cur = None
    for line in out.splitlines():
        m = re.match(r"^([0-9a-f]{8}) <(.*)>:$", line)
        if m:
            cur = int(m.group(1), 16)
            fname = tidy(m.group(2))
            funcs[cur] = {"name": fname, "frame": 0, "calls": set(), "indirect": False, "pushed": False}
            continue
        if cur is None:
            continue
        f = funcs[cur]
        ins = line.split("\t")
        if len(ins) < 2:
            continue
        op = ins[1].strip()
        args = ins[2] if len(ins) > 2 else ""
        if op in ("push", "push.w") and not f["pushed"]:
            regs = re.search(r"\{([^}]*)\}", args)
            if regs:
                f["frame"] += 4 * len(regs.group(1).split(","))
                f["pushed"] = True
        elif op == "vpush":
            regs = re.search(r"\{([^}]*)\}", args)
            if regs:
                size = 0
                for r in (r.strip() for r in regs.group(1).split(",")):
                    width = 8 if r.startswith("d") else 4
                    if "-" in r:
                        a, b = r.split("-")
                        size += (int(b[1:]) - int(a[1:]) + 1) * width
                    else:
                        size += width
                f["frame"] += size
        elif op in ("sub", "sub.w", "subw") and re.match(r"sp, (sp, )?#(0x[0-9a-f]+|\d+)", args):
            f["frame"] += number(re.search(r"#(0x[0-9a-f]+|\d+)", args).group(1))
        elif op in ("bl", "b.w", "b") and "<" in args:
            t = re.match(r"\s*(?:0x)?([0-9a-f]+) <([^>]*)>", args)
            if t and "+0x" not in t.group(2):
                f["calls"].add(int(t.group(1), 16))
        elif op == "blx":
            f["indirect"] = True
    return funcs


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    funcs = disassemble(sys.argv[1])
    name = lambda a: funcs[a]["name"]
    polls = {a for a in funcs if name(a).startswith("embassy_executor::raw::TaskStorage<") and name(a).endswith("::poll")}
    unresolved = set()

    @lru_cache(maxsize=None)
    def depth(addr):
        f = funcs.get(addr)
        if f is None:
            return 0, ()
        if addr in active:
            return 0, ()
        active.add(addr)
        best = (0, ())
        callees = set(f["calls"])
        if f["indirect"]:
            if re.fullmatch(EXECUTOR_POLL, f["name"]):
                callees |= polls
            else:
                unresolved.add(f["name"])
        for c in callees:
            d = depth(c)
            if d[0] > best[0]:
                best = d
        active.discard(addr)
        return f["frame"] + best[0], (f["name"],) + best[1]

    active = set()

    def root(pred):
        cands = [a for a in funcs if pred(name(a))]
        if not cands:
            return 0, ()
        return max(depth(a) for a in cands)

    thread = root(lambda n: n == "main" or n.endswith("__cortex_m_rt_main_trampoline") or n == "Reset")
    estimator = root(lambda n: n == "UART4")
    hal_irqs = [a for a in funcs if re.fullmatch(r"(DMA2_STREAM0|CAN1_TX|CAN1_RX0|CAN1_RX1|CAN1_SCE|TIM2)", name(a))]
    hal = max((depth(n) for n in hal_irqs), default=(0, ()))
    usb = root(lambda n: n == "OTG_FS")
    preemptions = 2 + (1 if usb[1] else 0)
    total = thread[0] + usb[0] + estimator[0] + hal[0] + preemptions * EXC_FRAME_FP
    parts = [("thread mode", thread)]
    if usb[1]:
        parts.append(("USB interrupt", usb))
    parts += [("estimator (UART4)", estimator), ("HAL interrupt", hal)]
    for label, d in parts:
        print(f"{label:<18} {d[0]:>6} B  via {' > '.join(x[:70] for x in d[1][:9])}")
    print(f"exception frames   {preemptions * EXC_FRAME_FP:>6} B")
    print(f"worst case         {total:>6} B")
    if unresolved:
        print("indirect calls not followed in: " + ", ".join(sorted(u[:60] for u in unresolved)[:8]))
    print(f"STACK_ESTIMATE={total}")


if __name__ == "__main__":
    main()

//! The per-millisecond budget on the Cortex-M4F: instructions per
//! `Monitor::step` over a golden recording (exact counts, see
//! `qemu_tests::counter`), static RAM and the stack high-water mark.
//!
//! Fails if the counter is not exact (a known instruction sequence) or if
//! the worst step would not fit 1 ms at 168 MHz (168 000 cycles) at the
//! ≈ 2 cycles per instruction expected for this code on silicon. The goal
//! of ≤ 8 000 instructions per step is reported, not enforced.
#![no_std]
#![no_main]

use core::hint::black_box;
use golden::input::Input;
use golden::params::golden_params;
use monitor::{Monitor, Sample, Status};
use qemu_tests::counter::{self, Counter};
use qemu_tests::{cases, exit, println, stack};

/// Recording to time (a leak that raises alarms, so every decision path runs).
const CASE: &str = "both";
/// 1 ms at 168 MHz.
const BUDGET_CYCLES: u32 = 168_000;
/// Cycles per instruction assumed for the hard limit.
const CPI: u32 = 2;
/// The optimisation goal for a full step, instructions.
const GOAL: u32 = 8_000;

/// Per-phase statistics of instructions per step.
#[derive(Clone, Copy, Default)]
struct Stats {
    n: u32,
    sum: u64,
    min: u32,
    max: u32,
    argmax: u32,
}

impl Stats {
    fn add(&mut self, k: u32, v: u32) {
        if self.n == 0 || v < self.min {
            self.min = v;
        }
        if v > self.max {
            self.max = v;
            self.argmax = k;
        }
        self.n += 1;
        self.sum += v as u64;
    }

    fn mean(&self) -> u32 {
        (self.sum / self.n.max(1) as u64) as u32
    }

    fn print(&self, what: &str) {
        println!(
            "budget: {what:<22} steps {:>5}  mean {:>6}  min {:>6}  max {:>6} (sample {})",
            self.n,
            self.mean(),
            self.min,
            self.max,
            self.argmax
        );
    }
}

/// One `Monitor::step`, kept a real call as in the firmware (where the
/// estimator task calls it), so that the counts include the call as they
/// always have, and `scripts/profile.sh` finds it as its root.
#[inline(never)]
fn monitor_step(monitor: &mut Monitor<f32>, sample: &Sample) -> Status {
    monitor.step(sample)
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let counter = Counter::start();
    let mut passed = true;

    // The counter counts instructions, exactly.
    let (_, nops) = counter.measure(counter::nop64);
    let iterations = |n: u32| counter.measure(|| counter::loop2(black_box(n))).1;
    let (l1, l2) = (iterations(100), iterations(1100));
    println!(
        "budget: counter overhead {} instructions (subtracted); 64 nops -> {}; loop 1000 more iterations -> +{}",
        counter.overhead(),
        nops,
        l2.wrapping_sub(l1)
    );
    if nops != 64 || l2.wrapping_sub(l1) != 2000 {
        println!("FAILED: the instruction counter is not exact (run with -icount shift=0)");
        passed = false;
    }

    let case = cases::by_name(CASE).expect("golden case for the budget");
    let input = Input::parse(case.input).expect("golden input");
    let params = golden_params(input.sample_period_s, input.warm_up_s);
    let warm_up_samples = (input.warm_up_s / input.sample_period_s) as u32;
    let monitor: &'static mut Monitor<f32> = cortex_m::singleton!(
        : Monitor<f32> = Monitor::new(&params).expect("golden parameters")
    )
    .expect("one monitor");

    let painted = stack::paint();
    let sp_caller = stack::sp();
    let [mut first, mut warming, mut running, mut all] = [Stats::default(); 4];
    for (k, s) in input.iter().enumerate() {
        let s = s.expect("golden sample");
        let s = black_box(s);
        let (status, n): (Status, u32) = counter.measure(|| monitor_step(monitor, &s));
        black_box(&status);
        let k = k as u32;
        let phase: &mut Stats = if k == 0 {
            &mut first
        } else if k <= warm_up_samples {
            &mut warming
        } else {
            &mut running
        };
        phase.add(k, n);
        all.add(k, n);
    }
    let lowest = painted.lowest_touched().unwrap_or(sp_caller);
    let step_stack = sp_caller.saturating_sub(lowest);

    println!(
        "budget: Monitor::step over {} samples of {} (warm-up {} s), instructions per step:",
        all.n, input.source, input.warm_up_s
    );
    first.print("first (bank start)");
    warming.print("warm-up");
    running.print("estimating/deciding");
    all.print("all");
    let limit = BUDGET_CYCLES / CPI;
    println!(
        "budget: 1 ms at 168 MHz = {BUDGET_CYCLES} cycles ~ {limit} instructions at {CPI} CPI; worst step uses {}.{:02} % of it",
        all.max as u64 * 100 / limit as u64,
        all.max as u64 * 10_000 / limit as u64 % 100
    );
    println!(
        "budget: goal <= {GOAL} instructions per step: {} (mean {:.2}x, max {:.2}x the goal)",
        if all.max <= GOAL { "met" } else { "NOT met" },
        all.mean() as f32 / GOAL as f32,
        all.max as f32 / GOAL as f32
    );
    if all.max > limit {
        println!("FAILED: the worst step does not fit the 1 ms budget");
        passed = false;
    }

    let [data, bss, uninit] = stack::static_ram();
    println!(
        "budget: static RAM {} B (.data {data}, .bss {bss}, .uninit {uninit}); Monitor<f32> {} B, Status {} B",
        data + bss + uninit,
        core::mem::size_of::<Monitor<f32>>(),
        core::mem::size_of::<Status>()
    );
    println!(
        "budget: stack high-water mark {} B in all (of {} B free after static data); {} B below the bench loop (Monitor::step, its callees and the measuring frame)",
        painted.high_water(),
        painted.high_water() + painted.headroom(),
        step_stack
    );
    exit(passed)
}

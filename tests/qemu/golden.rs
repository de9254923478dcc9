//! Bit-identity on the Cortex-M4F: every golden case (golden/data)
//! replayed through `Monitor::step` must give, sample by sample, exactly
//! the statuses and filter states the host computed on x86-64.
//!
//! A self-test then changes one reading by 1 mbar and checks that the
//! comparison reports the divergence at exactly that sample.
#![no_std]
#![no_main]

use core::fmt::Write;
use golden::expected::{Checker, Divergence, Expected};
use golden::input::Input;
use golden::params::golden_params;
use golden::{canon, describe};
use monitor::{Monitor, Sample};
use qemu_tests::cases::{Case, CASES};
use qemu_tests::{exit, println, Out};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut passed = true;
    for case in CASES {
        passed &= check_case(case);
    }
    let longest = CASES
        .iter()
        .max_by_key(|c| Input::parse(c.input).map_or(0, |i| i.samples))
        .expect("at least one golden case");
    passed &= divergence_is_reported_where_it_happens(longest);
    if passed {
        println!(
            "golden: all {} cases bit-identical with the host",
            CASES.len()
        );
    }
    exit(passed)
}

fn load(case: &Case) -> (Input<'static>, Expected<'static>) {
    let input = match Input::parse(case.input) {
        Ok(i) => i,
        Err(e) => panic!("{}: input: {e}", case.name),
    };
    if let Err(e) = input.verify() {
        panic!("{}: input: {e}", case.name);
    }
    let expected = match Expected::parse(case.expected) {
        Ok(x) => x,
        Err(e) => panic!("{}: expected: {e}", case.name),
    };
    assert!(
        expected.input_hash == input.input_hash,
        "{}: expected outputs belong to another input: regenerate with scripts/golden.sh",
        case.name
    );
    (input, expected)
}

fn new_monitor(input: &Input<'_>) -> Monitor<f32> {
    match Monitor::new(&golden_params(input.sample_period_s, input.warm_up_s)) {
        Ok(m) => m,
        Err(e) => panic!("invalid golden parameters: {}", e.field),
    }
}

/// Replay one case; report and return whether it matched.
fn check_case(case: &Case) -> bool {
    let (input, expected) = load(case);
    let mut monitor = new_monitor(&input);
    let mut checker = Checker::new(&expected);
    let mut first: Option<Divergence> = None;
    let mut out = Out;
    for (k, sample) in input.iter().enumerate() {
        let sample = sample.unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let status = monitor.step(&sample);
        for e in &status.events {
            println!("  {} t={} s: {:?}", case.name, sample.t_s, e);
        }
        if let Some(d) = checker.push(&status, &monitor) {
            first = Some(d);
            let _ = writeln!(
                out,
                "FAILED {}: first differing sample {} (t = {} s): {}{}",
                case.name,
                d.sample,
                sample.t_s,
                if d.status { "status " } else { "" },
                if d.bank { "filter-bank state" } else { "" },
            );
            let _ = writeln!(out, "--- target at sample {k}:");
            let _ = describe::status(&mut out, &status);
            let _ = describe::bank(&mut out, &monitor);
            for e in checker.expected_events_at(d.sample) {
                let _ = writeln!(out, "expected event {e:?}");
            }
            let _ = writeln!(
                out,
                "--- compare with the host: host-sim golden show golden/data/{} --sample {}",
                case.name, d.sample
            );
        }
    }
    let o = checker.finish();
    let verdict = canon::verdict_from_code(expected.final_verdict).map_or("?", |v| v.name());
    if o.passed() {
        println!(
            "golden {}: {} samples of {} bit-identical (status chain {:016x}, bank chain {:016x}); final verdict {}",
            case.name, o.samples, input.source, expected.status_chain, expected.bank_chain, verdict
        );
    } else if first.is_none() {
        println!(
            "FAILED {}: samples {} (want {}), final status chain ok {}, bank chain ok {}, verdict ok {} (want {})",
            case.name,
            o.samples,
            expected.samples,
            o.status_chain_ok,
            o.bank_chain_ok,
            o.verdict_ok,
            verdict
        );
    }
    o.passed()
}

/// The check must be able to fail: nudge one reading and expect the first
/// divergence at exactly that sample, in the filter states. (The case must
/// have more than `AT` samples, or the self-test fails.)
fn divergence_is_reported_where_it_happens(case: &Case) -> bool {
    const AT: u32 = 1500;
    let (input, expected) = load(case);
    let mut monitor = new_monitor(&input);
    let mut checker = Checker::new(&expected);
    let mut first = None;
    for (k, sample) in input.iter().enumerate().take(AT as usize + 100) {
        let mut s: Sample = sample.unwrap_or_else(|e| panic!("{e}"));
        if k as u32 == AT {
            s.p_rod_bar = s.p_rod_bar.map(|p| p + 0.001);
        }
        let status = monitor.step(&s);
        if let Some(d) = checker.push(&status, &monitor) {
            first.get_or_insert(d);
        }
    }
    match first {
        Some(d) if d.sample == AT && d.bank => {
            println!(
                "self-test: +1 mbar on p_rod at sample {AT} of {} detected at sample {} (status {}, bank {})",
                case.name, d.sample, d.status, d.bank
            );
            true
        }
        other => {
            println!(
                "FAILED self-test: +1 mbar on p_rod at sample {AT} gave {:?}",
                other
            );
            false
        }
    }
}

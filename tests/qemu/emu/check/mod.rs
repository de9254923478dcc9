//! The checks of a run on the emulated board, over what it recorded
//! (`super::record`) and the host's reference for the case
//! (`super::case`). Pure functions of the log, so that the self-test
//! (`selftest`) can run them again on a deliberately damaged log and
//! require them to fail.

pub mod device_fault;
mod frames;
mod outputs;
mod reaction;
pub mod selftest;
pub mod sensor_fault;

use core::fmt;

use firmware::app::shared::Shared;
use monitor::protocol::ResetCause;
use qemu_tests::println;

use super::case::EmuCase;
use super::record::Log;

/// What a failed check is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Check {
    /// The board's record is incomplete or the replay went wrong.
    Log,
    /// A frame does not decode (identifier, length, CRC, field values).
    Decode,
    /// A frame's E2E counter does not follow the previous one of its id.
    Counter,
    /// A frame missing, extra, or sent at the wrong sample.
    Schedule,
    /// A frame's contents differ from the host's for the same sample.
    Content,
    /// The announced leak (kind, time) differs from the golden's.
    Verdict,
    /// The relay output.
    Relay,
    /// A heartbeat field.
    Heartbeat,
    /// The reaction to the samples stopping (estimator stalled).
    Stall,
    /// The reaction to the command frames.
    Commands,
    /// Watchdog feeding.
    Watchdog,
    /// The diagnostic readings the supervisor takes (VREFINT, LSI).
    Diagnostics,
    /// The firmware's own counters (samples, CAN, outbox, log).
    Counters,
}

const CHECKS: usize = Check::Counters as usize + 1;

const ALL: [Check; CHECKS] = [
    Check::Log,
    Check::Decode,
    Check::Counter,
    Check::Schedule,
    Check::Content,
    Check::Verdict,
    Check::Relay,
    Check::Heartbeat,
    Check::Stall,
    Check::Commands,
    Check::Watchdog,
    Check::Diagnostics,
    Check::Counters,
];

/// Failed checks, by kind.
#[derive(Clone, Debug)]
pub struct Findings {
    quiet: bool,
    failed: [u32; CHECKS],
}

/// Failures printed per kind (the rest are only counted).
const PRINT_PER_CHECK: u32 = 5;

impl Findings {
    fn new(quiet: bool) -> Self {
        Self {
            quiet,
            failed: [0; CHECKS],
        }
    }

    /// Record a failure of `check`.
    fn fail(&mut self, check: Check, what: fmt::Arguments<'_>) {
        let n = &mut self.failed[check as usize];
        *n += 1;
        if !self.quiet && *n <= PRINT_PER_CHECK {
            println!("FAILED [{:?}]: {}", check, what);
        }
    }

    /// Print a report line (not in quiet runs).
    fn note(&self, what: fmt::Arguments<'_>) {
        if !self.quiet {
            println!("{}", what);
        }
    }

    /// Did every check pass?
    pub fn passed(&self) -> bool {
        self.failed.iter().all(|&n| n == 0)
    }

    /// Did `check` fail?
    pub fn flagged(&self, check: Check) -> bool {
        self.failed[check as usize] > 0
    }

    /// The checks that failed.
    pub fn flagged_list(&self) -> heapless::Vec<Check, CHECKS> {
        ALL.into_iter().filter(|&c| self.flagged(c)).collect()
    }

    /// Failures beyond the printed ones, per check, for the summary.
    fn summary(&self) {
        for c in ALL {
            let n = self.failed[c as usize];
            if n > PRINT_PER_CHECK && !self.quiet {
                println!("FAILED [{:?}]: {} more", c, n - PRINT_PER_CHECK);
            }
        }
    }
}

/// What the run is expected to show beyond the host's reference.
#[derive(Clone, Copy, Debug)]
pub struct Expect {
    /// The reset cause the board reported at boot.
    pub reset_cause: ResetCause,
    /// Command frames the firmware must reject (corrupted, replayed).
    pub rejected_commands: u32,
    /// The identity frame the board booted with.
    pub identity: monitor::protocol::IdentityFrame,
    /// The version frame the board booted with.
    pub version: monitor::protocol::VersionFrame,
}

/// Check the run; print the frame sequence and every failure unless
/// `quiet`.
pub fn run(case: &EmuCase, log: &Log, shared: &Shared, expect: &Expect, quiet: bool) -> Findings {
    let mut f = Findings::new(quiet);
    outputs::replay(case, log, &mut f);
    let frames = frames::check(case, log, expect, &mut f);
    outputs::relay(case, log, &frames, &mut f);
    outputs::verdict(case, &frames, &mut f);
    outputs::commands(case, &frames, shared, expect, &mut f);
    outputs::watchdog(case, log, &frames, &mut f);
    outputs::diagnostics(case, log, &mut f);
    outputs::counters(case, log, shared, &mut f);
    f.summary();
    f
}

//! The LSI measured against the sample clock, for the clock cross-check
//! (`monitor::device::diagnostics::clock`): TIM5 counts its APB1 timer
//! clock (84 MHz, from the 8 MHz crystal through the PLL, like TIM3, which
//! paces the ADC scans and so the 1 kHz sample clock) in a free-running
//! 32-bit counter, and channel 4 captures the counter on every 8th rising
//! edge of the LSI (≈ 32 kHz, the chip's independent RC oscillator, which
//! also clocks the watchdog).
//!
//! RM0090 Rev 21 §7.2.11 ("Internal/external clock measurement using
//! TIM5/TIM11") describes this connection: TI4_RMP = 01 in TIM5_OR
//! (bits 7:6) routes the LSI to TIM5's channel 4 input instead of its pin,
//! so no pin is used. Two consecutive captures give the LSI period in
//! timer ticks, and `clock::lsi_cycles_per_window` turns it into LSI cycles
//! per second of sample time.
//!
//! The captures are polled (no interrupt): CC4IF is set by each capture and
//! cleared by reading CCR4; a capture while CC4IF is still set raises CC4OF
//! (overcapture). A pair is only accepted when CC4OF stayed clear between
//! the two reads, i.e. the second capture is the direct successor of the
//! first, even if the estimator preempted the polling thread meanwhile.
//! A measurement blocks the supervisor for one to two capture periods:
//! 250 µs typically, at most 2 × 470 µs (LSI at 17 kHz), once a second.

use embassy_stm32::pac::timer::regs::SrGp16;
use embassy_stm32::pac::timer::vals::{CcmrInputCcs, FilterValue};
use embassy_stm32::pac::timer::TimGp32;
use embassy_stm32::peripherals::{TIM3, TIM5};
use embassy_stm32::rcc::frequency;
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::Peri;
use embassy_time::{Duration, Instant};
use firmware::app::SAMPLE_PERIOD_US;
use monitor::device::diagnostics::clock::{lsi_cycles_per_window, window_ticks};

/// TIM5_OR.TI4_RMP = 01: the LSI drives TIM5's channel 4 input (RM0090,
/// TIM5 option register, bits 7:6).
const TIM5_OR_TI4_RMP_LSI: u32 = 0b01 << 6;

/// Channel 4 (index 3 of the CCRx/CCxIF/CCxOF/CCxE arrays).
const CH4: usize = 3;

/// IC4PSC = 11: one capture every 8 events; the capture spacing is then
/// 8 LSI periods (≈ 250 µs, 21 000 ticks at 84 MHz).
const CAPTURE_PRESCALER_BITS: u8 = 0b11;
/// LSI cycles between two consecutive captures.
const LSI_CYCLES_PER_CAPTURE: u32 = 8;

/// Longest wait for one capture: four capture periods of the slowest LSI
/// the datasheet allows (17 kHz: 8 cycles = 470 µs). Without an edge by
/// then the LSI is taken as stopped.
const CAPTURE_TIMEOUT: Duration = Duration::from_micros(2000);

/// Pairs tried per measurement before giving up for this window (a pair
/// is rejected when a capture was overwritten before it was read).
const ATTEMPTS: u8 = 3;

/// TIM5 capturing the LSI.
pub struct LsiMeter {
    timer: Timer<'static, TIM5>,
    /// Timer ticks per window of sample time.
    window_ticks: u64,
    /// A capture has happened since start-up, so CCR4 holds one.
    primed: bool,
}

/// One attempt at two consecutive captures.
enum Pair {
    /// The counter at two consecutive captures, ticks.
    Captured(u32, u32),
    /// A capture was overwritten before it was read: try again.
    Missed,
    /// No capture within [`CAPTURE_TIMEOUT`]: the LSI does not run.
    NoEdge,
}

impl LsiMeter {
    /// Start TIM5 capturing the LSI. `sample_period_ticks` is the sample
    /// period on TIM3's clock (PSC, ARR and scans per sample of the ADC
    /// trigger, `AdcSampler::sample_period_ticks`); TIM5 has the same
    /// clock (both on APB1). The LSI itself is already running: embassy's
    /// clock set-up enables it (the default low-speed configuration) and
    /// the started watchdog forces it on.
    pub fn new(tim: Peri<'static, TIM5>, sample_period_ticks: u64) -> Self {
        if frequency::<TIM5>() != frequency::<TIM3>() {
            defmt::panic!("clock check: TIM5 and TIM3 are on different clocks");
        }
        // Clock enabled and the timer reset through RCC.
        let timer = Timer::new(tim);
        let r = timer.regs_gp32();
        r.psc().write_value(0);
        r.arr().write_value(u32::MAX);
        r.or().write_value(TIM5_OR_TI4_RMP_LSI);
        // CC4S = 01 (input, IC4 on TI4; embassy's metapac names the value
        // `TI4`), capture prescaler /8, no filter. Written while CC4E = 0,
        // as RM0090 requires for CC4S.
        r.ccmr_input(1).write(|w| {
            w.set_ccs(1, CcmrInputCcs::TI4);
            w.set_icpsc(1, CAPTURE_PRESCALER_BITS);
            w.set_icf(1, FilterValue::NO_FILTER);
        });
        // Rising edges (CC4P = CC4NP = 0), capture enabled.
        r.ccer().write(|w| w.set_cce(CH4, true));
        // Load PSC, then clear every flag (no interrupt is enabled).
        timer.generate_update_event();
        r.sr().write_value(SrGp16(0));
        timer.start();
        Self {
            timer,
            window_ticks: window_ticks(sample_period_ticks, SAMPLE_PERIOD_US),
            primed: false,
        }
    }

    fn regs(&self) -> TimGp32 {
        self.timer.regs_gp32()
    }

    /// Wait for CC4IF (a capture not yet read); false after
    /// [`CAPTURE_TIMEOUT`] without one.
    fn wait_capture(&self) -> bool {
        let r = self.regs();
        let start = Instant::now();
        while !r.sr().read().ccif(CH4) {
            if start.elapsed() > CAPTURE_TIMEOUT {
                // Once more: a preemption may outlast the deadline.
                return r.sr().read().ccif(CH4);
            }
        }
        true
    }

    /// Read the latest capture (clearing CC4IF) and clear CC4OF, with no
    /// interrupt between the two: afterwards CC4OF is set only by a second
    /// capture after this one.
    fn take_first(&self) -> u32 {
        let r = self.regs();
        cortex_m::interrupt::free(|_| {
            let first = r.ccr(CH4).read();
            // rc_w0: 0 clears CC4OF, 1 leaves every other flag as it is.
            let mut keep = SrGp16(0);
            keep.set_uif(true);
            for ch in 0..4 {
                keep.set_ccif(ch, true);
                keep.set_ccof(ch, ch != CH4);
            }
            keep.set_tif(true);
            r.sr().write_value(keep);
            first
        })
    }

    /// Two consecutive captures: the latest one, and the next.
    fn pair(&self) -> Pair {
        let r = self.regs();
        let first = self.take_first();
        if !self.wait_capture() {
            return Pair::NoEdge;
        }
        let (second, overcapture) =
            cortex_m::interrupt::free(|_| (r.ccr(CH4).read(), r.sr().read().ccof(CH4)));
        if overcapture {
            Pair::Missed
        } else {
            Pair::Captured(first, second)
        }
    }

    /// LSI cycles per window of sample time; `Some(0)` when the LSI shows
    /// no edge; `None` when every attempt lost a capture (the supervisor
    /// tries again at the next window).
    pub fn measure(&mut self) -> Option<u32> {
        if !self.primed {
            // CCR4 holds its reset value until the first capture.
            if !self.wait_capture() {
                return Some(0);
            }
            self.primed = true;
        }
        for _ in 0..ATTEMPTS {
            match self.pair() {
                Pair::Captured(first, second) => {
                    return Some(lsi_cycles_per_window(
                        first,
                        second,
                        LSI_CYCLES_PER_CAPTURE,
                        self.window_ticks,
                    ))
                }
                Pair::NoEdge => return Some(0),
                Pair::Missed => {}
            }
        }
        None
    }
}

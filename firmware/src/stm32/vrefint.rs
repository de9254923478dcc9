//! The internal reference VREFINT (ADC1 channel 17), converted by ADC1's
//! injected group on software request, for the ADC reference check
//! (`monitor::device::diagnostics::reference`).
//!
//! The seven inputs keep their regular scan (TIM3-triggered, DMA'd; see
//! `adc.rs`): the injected group has its own sequence (JSQR), its own data
//! register (JDR1) and its own flags (JEOC, JSTRT), and RM0090 Rev 21
//! describes how the two share the converter:
//!
//! - §13.3.9 "Injected channel management", triggered injection (JAUTO =
//!   0): if JSWSTART is set during the conversion of the regular group,
//!   the current (regular) conversion is reset, the injected sequence is
//!   converted once, and the regular group resumes from the interrupted
//!   conversion (which is converted again: no code lost or doubled). A
//!   regular trigger (TIM3 TRGO) that arrives during the injected
//!   conversion is not lost: the regular sequence is executed at the end
//!   of the injected one. (The rule that such a trigger is ignored,
//!   §13.9.6, is for the multi-ADC modes; ADC1 runs independent here.)
//! - §13.3.8, §13.8.1 and §13.13.1: only regular conversions write ADC_DR,
//!   request the DMA and set EOC; "the data converted from an injected
//!   channel are always stored into the ADC_JDRx registers", and
//!   "injected channel conversions are not impacted by overrun errors".
//!   The DMA ring therefore receives exactly the regular scan's codes, in
//!   order.
//! - Timing: an injected conversion here takes 480 + 12 ADC clocks =
//!   23.4 µs at 21 MHz; a scan of the inputs takes 52 µs of the 250 µs
//!   between triggers (`boards::h405::ADC_SAMPLE_CYCLES`), so even a scan
//!   delayed or interrupted by it ends long before the next trigger, and
//!   the DMA reads each code within one conversion time as before: no
//!   overrun (OVR) can come from it. The inputs after the interruption
//!   are sampled up to 24 µs later than usual, once per 100 ms — far below
//!   the input filter's 16 kHz corner and the 1 kHz sample rate.
//!
//! No ADC interrupt is enabled (EOCIE, JEOCIE, OVRIE stay 0), so the flags
//! are only polled: JEOC and JSTRT are cleared here by writing 0 to them
//! and 1 to every other flag of ADC_SR (rc_w0: writing 1 leaves a flag as
//! it is), so a read-modify-write can never clear a regular flag (EOC,
//! STRT, OVR) that the hardware set in between.
//!
//! The placement of a one-conversion injected sequence follows RM0090
//! §13.13.12: with JL = 0 the ADC converts only JSQ4, and the result of
//! the first (only) conversion is in JDR1 (as ST's HAL and embassy-stm32's
//! own injected driver program it).

use embassy_stm32::pac;
use embassy_stm32::pac::adc::regs::{Jofr, Sr};
use embassy_stm32::pac::adc::vals::{Exten, SampleTime};
use embassy_time::{Duration, Instant};

/// ADC1 channel of VREFINT.
const VREFINT_CHANNEL: u8 = 17;

/// Sample time of VREFINT: 480 ADC clocks = 22.9 µs at 21 MHz; the
/// datasheet (DS8626, "internal reference voltage") requires at least
/// 10 µs.
const VREFINT_SAMPLE_TIME: SampleTime = SampleTime::CYCLES480;

/// Longest wait for the end of an injected conversion: 4 × its 23.4 µs.
const CONVERSION_TIMEOUT: Duration = Duration::from_micros(100);

/// ADC1's injected group, set up for VREFINT.
pub struct Vrefint(());

impl Vrefint {
    /// Enable VREFINT (TSVREFE) and program ADC1's injected group: one
    /// conversion of channel 17, started by software only. Called by the
    /// ADC set-up (`adc.rs`) once the ADC is on and before the regular
    /// scans are triggered.
    pub(super) fn configure() -> Self {
        // VREFINT needs 10 µs to start (DS8626); the first conversion is
        // 100 ms later.
        pac::ADC123_COMMON.ccr().modify(|w| w.set_tsvrefe(true));
        let r = pac::ADC1;
        r.smpr1()
            .modify(|w| w.set_smp(usize::from(VREFINT_CHANNEL - 10), VREFINT_SAMPLE_TIME));
        r.jofr(0).write_value(Jofr(0));
        r.jsqr().write(|w| {
            w.set_jl(0);
            w.set_jsq(3, VREFINT_CHANNEL);
        });
        r.cr1().modify(|w| {
            w.set_jauto(false);
            w.set_jdiscen(false);
            w.set_jeocie(false);
            w.set_jawden(false);
        });
        r.cr2().modify(|w| w.set_jexten(Exten::DISABLED));
        clear_injected_flags();
        Self(())
    }

    /// Convert VREFINT once: the 12-bit code, or 0 when the conversion did
    /// not end within [`CONVERSION_TIMEOUT`] (counted as out of range by
    /// the reference check). Blocks for about 24 µs.
    pub fn convert(&mut self) -> u16 {
        let r = pac::ADC1;
        clear_injected_flags();
        // Nothing else writes CR2 after the set-up; the hardware clears
        // (J)SWSTART itself, so writing back what was read is safe.
        r.cr2().modify(|w| w.set_jswstart(true));
        let start = Instant::now();
        // Checked once more after the deadline: a preemption by the
        // estimator may outlast it while the conversion completes.
        while !r.sr().read().jeoc() {
            if start.elapsed() > CONVERSION_TIMEOUT {
                if r.sr().read().jeoc() {
                    break;
                }
                return 0;
            }
        }
        let code = r.jdr(0).read().jdata();
        clear_injected_flags();
        code
    }
}

/// Clear JEOC and JSTRT, leaving every other flag of ADC1_SR as it is
/// (rc_w0 flags: 0 clears, 1 has no effect; reserved bits written 0).
fn clear_injected_flags() {
    let mut keep = Sr(0);
    keep.set_awd(true);
    keep.set_eoc(true);
    keep.set_strt(true);
    keep.set_ovr(true);
    keep.set_jeoc(false);
    keep.set_jstrt(false);
    pac::ADC1.sr().write_value(keep);
}

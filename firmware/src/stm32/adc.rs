//! The sampling path: TIM3 triggers a scan of ADC1 over the seven inputs
//! at 4 kHz; DMA2 stream 0 writes the codes into a circular buffer of two
//! 1 ms blocks; the estimator reads each block as its half completes. If
//! it falls a whole buffer behind, the ring buffer reports an overrun
//! (counted; the sample clock resynchronises) and restarts aligned to a
//! block, so no sample is ever read twice or out of place.
//!
//! The regular sequence is programmed here through the register block:
//! embassy-stm32 0.6.0's ring-buffered ADC v2 writes every rank into SQR3,
//! which holds only six, and panics for a seventh channel (fixed upstream
//! after 0.6.0, embassy commit 9900d9f0a). Clock, prescaler and power-up
//! stay with the HAL (`Adc::new`), the DMA ring buffer is embassy's.
//!
//! The same ADC converts the internal reference VREFINT in its injected
//! group, which leaves this scan and its DMA untouched (`vrefint.rs`).

use embassy_stm32::adc::{Adc, AnyAdcChannel, Exten, RegularTrigger, RxDma};
use embassy_stm32::dma::{self, ReadableRingBuffer, TransferOptions};
use embassy_stm32::pac;
use embassy_stm32::pac::adc::vals::{Dds, Eocs};
use embassy_stm32::peripherals::{ADC1, DMA2_CH0, TIM3};
use embassy_stm32::rcc::frequency;
use embassy_stm32::timer::low_level::{MasterMode, Timer};
use embassy_stm32::{bind_interrupts, peripherals, triggers, Peri};
use firmware::board::{Overrun, SampleSource};
use monitor::signal::frontend::CHANNELS;
use static_cell::StaticCell;

use super::pins::ADC_SAMPLE_TIME;
use super::vrefint::Vrefint;
use boards::timer::{period_ticks, timer_period};
use firmware::board_map::{BLOCK_LEN, SCANS_PER_SAMPLE, SCAN_RATE_HZ};

bind_interrupts!(struct Irqs {
    DMA2_STREAM0 => dma::InterruptHandler<peripherals::DMA2_CH0>;
});

static DMA_BUF: StaticCell<[u16; 2 * BLOCK_LEN]> = StaticCell::new();

/// The ADC sample source.
pub struct AdcSampler {
    ring: ReadableRingBuffer<'static, u16>,
    _trigger: Timer<'static, TIM3>,
    block: [u16; BLOCK_LEN],
    sample_period_ticks: u64,
}

/// Program ADC1's regular sequence: `channels` in order, scan mode,
/// DMA requests for ever, one scan per rising edge of TIM3 TRGO.
fn configure_scan(channels: &[u8; CHANNELS]) {
    let r = pac::ADC1;
    r.sqr1().modify(|w| w.set_l((CHANNELS - 1) as u8));
    for (rank, &ch) in channels.iter().enumerate() {
        match rank {
            0..=5 => r.sqr3().modify(|w| w.set_sq(rank, ch)),
            6..=11 => r.sqr2().modify(|w| w.set_sq(rank - 6, ch)),
            _ => r.sqr1().modify(|w| w.set_sq(rank - 12, ch)),
        }
        if ch <= 9 {
            r.smpr2()
                .modify(|w| w.set_smp(ch as usize, ADC_SAMPLE_TIME));
        } else {
            r.smpr1()
                .modify(|w| w.set_smp(ch as usize - 10, ADC_SAMPLE_TIME));
        }
    }
    r.sr().modify(|w| {
        w.set_ovr(false);
        w.set_eoc(false);
        w.set_strt(false);
    });
    r.cr1().modify(|w| {
        w.set_scan(true);
        w.set_discen(false);
        w.set_eocie(false);
        w.set_ovrie(false);
    });
    r.cr2().modify(|w| {
        w.set_cont(false);
        w.set_dma(true);
        w.set_dds(Dds::CONTINUOUS);
        w.set_eocs(Eocs::EACH_CONVERSION);
        w.set_extsel(RegularTrigger::<ADC1>::signal(&triggers::TIM3_TRGO));
        w.set_exten(Exten::RISING_EDGE);
    });
}

impl AdcSampler {
    /// Configure TIM3, ADC1 and the DMA, and start sampling; returns the
    /// sampler and ADC1's injected group, set up to convert VREFINT.
    pub fn new(
        adc: Peri<'static, ADC1>,
        dma: Peri<'static, DMA2_CH0>,
        trigger: Peri<'static, TIM3>,
        inputs: [AnyAdcChannel<'static, ADC1>; CHANNELS],
    ) -> (Self, Vrefint) {
        // Clock, prescaler (21 MHz) and ADON from the HAL. The driver is
        // never dropped: dropping it would power the ADC down.
        core::mem::forget(Adc::new(adc));
        let channels = inputs.map(|ch| ch.get_hw_channel());
        configure_scan(&channels);
        // Before the first trigger: nothing is converting yet.
        let vrefint = Vrefint::configure();

        let request = RxDma::<ADC1>::request(&*dma);
        let channel = dma::Channel::new(dma, Irqs);
        let buf = DMA_BUF.init([0; 2 * BLOCK_LEN]);
        // SAFETY: the DMA reads ADC1's data register, which nothing else
        // reads; the buffer is 'static and owned by the ring buffer.
        let mut ring = unsafe {
            ReadableRingBuffer::new(
                channel,
                request,
                pac::ADC1.dr().as_ptr() as *mut u16,
                buf,
                TransferOptions::default(),
            )
        };
        // Reads start on a block (1 ms) boundary, also after an overrun.
        ring.set_alignment(BLOCK_LEN);
        // DMA first, then the trigger: a conversion without the DMA
        // running would overrun the ADC and stop its DMA requests.
        ring.start();

        let trigger = Timer::new(trigger);
        let Some((psc, arr)) = timer_period(frequency::<TIM3>().0, SCAN_RATE_HZ) else {
            defmt::panic!("ADC: TIM3 cannot trigger at {=u32} Hz", SCAN_RATE_HZ);
        };
        let regs = trigger.regs_gp16();
        regs.psc().write_value(psc);
        regs.arr().write(|w| w.set_arr(arr));
        trigger.set_master_mode(MasterMode::UPDATE);
        trigger.generate_update_event();
        trigger.start();
        let sampler = Self {
            ring,
            _trigger: trigger,
            block: [0; BLOCK_LEN],
            sample_period_ticks: period_ticks(psc, arr) * SCANS_PER_SAMPLE as u64,
        };
        (sampler, vrefint)
    }

    /// The sample period in ticks of TIM3's clock: its true length on that
    /// clock (84 000 at 84 MHz), for the LSI cross-check.
    pub fn sample_period_ticks(&self) -> u64 {
        self.sample_period_ticks
    }
}

impl SampleSource for AdcSampler {
    async fn next_block(&mut self) -> Result<&[u16], Overrun> {
        match self.ring.read_exact(&mut self.block).await {
            Ok(_) => Ok(&self.block),
            Err(_) => Err(Overrun),
        }
    }
}

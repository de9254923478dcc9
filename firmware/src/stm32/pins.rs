//! The pins of the selected board (`boards::selected`, the wiring table),
//! taken out of embassy's `Peripherals`.

use embassy_stm32::adc::{AdcChannel, AnyAdcChannel, SampleTime};
use embassy_stm32::peripherals::{
    ADC1, CAN1, DMA2_CH0, FLASH, IWDG, PA11, PA12, PB12, PB13, PB8, PB9, PC12, RNG, TIM3, TIM5,
    USB_OTG_FS,
};
use embassy_stm32::{Peri, Peripherals};
use monitor::signal::frontend::CHANNELS;

/// ADC sample time per channel (`board_map::ADC_SAMPLE_CYCLES`).
pub const ADC_SAMPLE_TIME: SampleTime = SampleTime::CYCLES144;
const _: () = assert!(firmware::board_map::ADC_SAMPLE_CYCLES == 144);

/// The board's peripherals, taken out of embassy's `Peripherals`.
pub struct Board {
    /// ADC1, scanning the inputs.
    pub adc: Peri<'static, ADC1>,
    /// DMA2 stream 0 (ADC1 request).
    pub adc_dma: Peri<'static, DMA2_CH0>,
    /// TIM3, triggering the scans.
    pub adc_trigger: Peri<'static, TIM3>,
    /// The analogue inputs, in `Channel::ALL` order.
    pub inputs: [AnyAdcChannel<'static, ADC1>; CHANNELS],
    /// Relay driver.
    pub relay: Peri<'static, PB12>,
    /// Relay read-back (auxiliary contact).
    pub relay_readback: Peri<'static, PB13>,
    /// Status LED.
    pub led: Peri<'static, PC12>,
    /// CAN1.
    pub can: Peri<'static, CAN1>,
    /// CAN1 RX.
    pub can_rx: Peri<'static, PB8>,
    /// CAN1 TX.
    pub can_tx: Peri<'static, PB9>,
    /// Independent watchdog.
    pub iwdg: Peri<'static, IWDG>,
    /// True random number generator (seeds the acknowledge challenges).
    pub rng: Peri<'static, RNG>,
    /// TIM5, capturing the LSI on channel 4 (internal, no pin) for the
    /// clock cross-check.
    pub lsi_timer: Peri<'static, TIM5>,
    /// USB OTG FS (the commissioning link, CDC-ACM).
    pub usb: Peri<'static, USB_OTG_FS>,
    /// USB OTG FS DM.
    pub usb_dm: Peri<'static, PA11>,
    /// USB OTG FS DP.
    pub usb_dp: Peri<'static, PA12>,
    /// The flash controller (the link's parameter and event storage).
    pub flash: Peri<'static, FLASH>,
}

/// Assign the pins.
pub fn split(p: Peripherals) -> Board {
    Board {
        adc: p.ADC1,
        adc_dma: p.DMA2_CH0,
        adc_trigger: p.TIM3,
        inputs: [
            p.PA0.degrade_adc(),
            p.PA1.degrade_adc(),
            p.PA2.degrade_adc(),
            p.PA3.degrade_adc(),
            p.PC0.degrade_adc(),
            p.PC1.degrade_adc(),
            p.PC2.degrade_adc(),
        ],
        relay: p.PB12,
        relay_readback: p.PB13,
        led: p.PC12,
        can: p.CAN1,
        can_rx: p.PB8,
        can_tx: p.PB9,
        iwdg: p.IWDG,
        rng: p.RNG,
        lsi_timer: p.TIM5,
        usb: p.USB_OTG_FS,
        usb_dm: p.PA11,
        usb_dp: p.PA12,
        flash: p.FLASH,
    }
}

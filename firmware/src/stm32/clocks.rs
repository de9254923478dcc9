//! Clock tree: 8 MHz crystal → PLL → 168 MHz core; APB1 42 MHz (CAN,
//! TIM3 at 84 MHz), APB2 84 MHz (ADC clock 21 MHz), 48 MHz for USB.

use embassy_stm32::rcc::{
    mux, AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllQDiv,
    PllSource, Sysclk,
};
use embassy_stm32::time::Hertz;
use embassy_stm32::Config;

/// Core clock, Hz.
pub const SYSCLK_HZ: u32 = 168_000_000;

/// The HAL configuration.
pub fn config() -> Config {
    let mut c = Config::default();
    c.rcc.hse = Some(Hse {
        freq: Hertz(8_000_000),
        mode: HseMode::Oscillator,
    });
    c.rcc.pll_src = PllSource::HSE;
    c.rcc.pll = Some(Pll {
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL168,
        // 8 MHz / 4 × 168 = 336 MHz VCO; P: / 2 = 168 MHz core.
        divp: Some(PllPDiv::DIV2),
        // Q: 336 MHz / 7 = 48 MHz exactly, the USB OTG FS clock (the
        // driver checks it is within 0.25 %).
        divq: Some(PllQDiv::DIV7),
        divr: None,
    });
    c.rcc.sys = Sysclk::PLL1_P;
    c.rcc.ahb_pre = AHBPrescaler::DIV1;
    c.rcc.apb1_pre = APBPrescaler::DIV4;
    c.rcc.apb2_pre = APBPrescaler::DIV2;
    // The 48 MHz domain (USB OTG FS) from PLL Q.
    c.rcc.mux.clk48sel = mux::Clk48sel::PLL1_Q;
    c
}

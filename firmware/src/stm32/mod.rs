//! The STM32F405 board: the board trait implemented on embassy-stm32.

pub mod adc;
pub mod can;
pub mod clocks;
pub mod diagnostics;
pub mod flash;
pub mod lsi;
mod panic;
pub mod pins;
pub mod relay;
pub mod system;
pub mod usb;
pub mod vrefint;

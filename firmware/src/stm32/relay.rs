//! The fail-safe relay driver on PB12: high = relay energised = healthy.
//! Written through the port's set/reset register, which is a single
//! atomic store: the estimator and the supervisor can both switch it, and
//! the fault handler can switch it off without any driver state.

use core::sync::atomic::{AtomicBool, Ordering};

use embassy_stm32::gpio::{Input, Level, Output, Pin, Pull, Speed};
use embassy_stm32::pac;
use embassy_stm32::peripherals::{PB12, PB13};
use embassy_stm32::Peri;

use firmware::board::RelayOutput;
use firmware::board_map::{RELAY_PIN, RELAY_PORT};

/// GPIO ports A..I of the STM32F405.
const PORTS: [pac::gpio::Gpio; 9] = [
    pac::GPIOA,
    pac::GPIOB,
    pac::GPIOC,
    pac::GPIOD,
    pac::GPIOE,
    pac::GPIOF,
    pac::GPIOG,
    pac::GPIOH,
    pac::GPIOI,
];

/// What the relay was last driven to (the fault handler's `force_off`
/// included).
static COMMANDED: AtomicBool = AtomicBool::new(false);

fn write(energised: bool) {
    COMMANDED.store(energised, Ordering::Relaxed);
    let port = PORTS[RELAY_PORT as usize];
    port.bsrr().write(|w| {
        if energised {
            w.set_bs(RELAY_PIN as usize, true)
        } else {
            w.set_br(RELAY_PIN as usize, true)
        }
    });
}

/// De-energise the relay from any context (fault handlers included).
pub fn force_off() {
    write(false);
}

/// The relay output and its read-back input.
pub struct Relay {
    readback: Input<'static>,
}

impl Relay {
    /// Configure the driver pin as a push-pull output, de-energised, and
    /// the read-back pin as an input (the board has the pull-up).
    pub fn new(pin: Peri<'static, PB12>, readback: Peri<'static, PB13>) -> Self {
        defmt::assert!(pin.port() == RELAY_PORT && pin.pin() == RELAY_PIN);
        // The pin keeps its output configuration for ever; it is switched
        // through BSRR from here on.
        core::mem::forget(Output::new(pin, Level::Low, Speed::Low));
        Self {
            readback: Input::new(readback, Pull::None),
        }
    }
}

impl RelayOutput for Relay {
    fn set_energised(&self, energised: bool) {
        write(energised);
    }

    fn read_back(&self) -> bool {
        // The auxiliary contact closes to ground when energised.
        self.readback.is_low()
    }

    fn commanded(&self) -> bool {
        COMMANDED.load(Ordering::Relaxed)
    }
}

//! Leak monitor firmware (minimal bring-up): runs the monitor on the
//! STM32F405 at 1 kHz. The real sampling, relay, CAN and watchdog tasks
//! replace the synthetic sample source in the firmware issue.
#![no_std]
#![no_main]

use defmt::info;
use embassy_executor::Spawner;
use embassy_time::{Duration, Ticker};
use monitor::{Monitor, Params, Sample};
use {defmt_rtt as _, panic_probe as _};

#[embassy_executor::task]
async fn estimator(mut monitor: Monitor<f32>) {
    let mut ticker = Ticker::every(Duration::from_millis(1));
    let mut k: u32 = 0;
    loop {
        ticker.next().await;
        // Placeholder input: a cylinder at rest (no ADC yet).
        let sample = Sample {
            t_s: k as f64 * 1e-3,
            p_supply_bar: Some(50.0),
            p_piston_bar: Some(26.0),
            p_rod_bar: Some(24.5),
            p_tank_bar: Some(0.6),
            x_piston_m: Some(0.04),
            u_valve: Some(0.0),
            temp_oil_c: None,
        };
        let status = monitor.step(&sample);
        if k % 1000 == 0 {
            info!("t={}s verdict={}", k / 1000, status.verdict);
        }
        k = k.wrapping_add(1);
    }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let _p = embassy_stm32::init(Default::default());
    let monitor = match Monitor::new(&Params::nominal()) {
        Ok(m) => m,
        Err(e) => defmt::panic!("invalid built-in parameters: {}", e.field),
    };
    spawner.spawn(defmt::unwrap!(estimator(monitor)));
}

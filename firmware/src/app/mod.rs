//! The application tasks, generic over the board (see [`crate::board`]).
//! Embassy tasks cannot be generic: a board generates its task wrappers
//! with its own types by [`app_tasks!`](crate::app_tasks).

pub mod can_rx;
pub mod can_tx;
pub mod estimator;
pub mod link;
pub mod shared;
pub mod stream;
pub mod supervisor;

/// Sample period, µs (1 kHz).
pub const SAMPLE_PERIOD_US: u32 = crate::board_map::SAMPLE_PERIOD_US;

/// The application's embassy tasks for one board: a wrapper per `run`
/// function, generated here so the STM32 binary and the emulated board do
/// not each write their own copy. The caller names its board types and its
/// `static` [`shared::Shared`]; the tasks are `estimator`, `supervisor`,
/// `can_tx` and `can_rx`, to spawn on the caller's executors.
#[macro_export]
macro_rules! app_tasks {
    (
        shared: $shared:path,
        sample_source: $source:ty,
        relay: $relay:ty,
        cycle_counter: $cycles:ty,
        watchdog: $watchdog:ty,
        led: $led:ty,
        self_test: $self_test:ty,
        can_tx: $can_tx:ty,
        can_rx: $can_rx:ty $(,)?
    ) => {
        #[embassy_executor::task]
        async fn estimator(
            source: $source,
            relay: &'static $relay,
            cycles: $cycles,
            pipeline: &'static mut ::monitor::device::Estimator<f32>,
            boot: $crate::board::BootInfo,
        ) {
            $crate::app::estimator::run(source, relay, cycles, pipeline, boot, &$shared).await
        }

        #[embassy_executor::task]
        async fn supervisor(
            watchdog: $watchdog,
            relay: &'static $relay,
            led: $led,
            self_test: $self_test,
        ) {
            $crate::app::supervisor::run(watchdog, relay, led, self_test, &$shared).await
        }

        #[embassy_executor::task]
        async fn can_tx(tx: $can_tx, node: ::monitor::protocol::Node) {
            $crate::app::can_tx::run(tx, node, &$shared).await
        }

        #[embassy_executor::task]
        async fn can_rx(rx: $can_rx, node: ::monitor::protocol::Node, challenge_seed: u64) {
            $crate::app::can_rx::run(rx, node, &$shared, challenge_seed).await
        }
    };
}

/// The commissioning link's task (`link`) for one board: its serial port
/// and the flash partitions of the parameters and the events, with the
/// caller's `static` [`shared::Shared`].
#[macro_export]
macro_rules! app_link_task {
    (
        shared: $shared:path,
        serial: $serial:ty,
        params_flash: $params_flash:ty,
        events_flash: $events_flash:ty $(,)?
    ) => {
        #[embassy_executor::task]
        async fn link(
            port: $serial,
            device: &'static mut ::link::Device<$params_flash, $events_flash>,
            node: ::monitor::protocol::Node,
        ) {
            $crate::app::link::run(port, device, node, &$shared).await
        }
    };
}

//! The logging thread: it logs what the real-time thread reports through its event ring.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use hapticd::realtime::LoopEvent;
use hapticd_core::haptic_loop::DeviceState;
use hapticd_core::sync::spsc;

/// Log the events of the loop of device `identity` as they come (the real-time thread must
/// not write itself).
pub fn spawn_event_logger(
    identity: String,
    mut events: spsc::Consumer<LoopEvent>,
    done: &'static AtomicBool,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut overruns = 0u64;
        loop {
            let finished = done.load(Ordering::Acquire);
            while let Some(event) = events.pop() {
                match event {
                    LoopEvent::State { time, state, error } => match (state, error) {
                        (_, Some(e)) => {
                            tracing::error!("{identity}: {time:.3} s: device {state:?}: {e}")
                        }
                        (DeviceState::Running, None) => {
                            tracing::info!("{identity}: {time:.3} s: device {state:?}")
                        }
                        (DeviceState::Uncalibrated, None) => tracing::error!(
                            "{identity}: {time:.3} s: the counts no longer fit the calibration (did the \
                             amplifier lose power?): forces held at zero until it is calibrated \
                             again (Calibrate())"
                        ),
                        (_, None) => {
                            tracing::error!(
                                "{identity}: {time:.3} s: device {state:?}: forces ramped to zero"
                            )
                        }
                    },
                    LoopEvent::Overrun { time, late_ns } => {
                        overruns += 1;
                        // The first few in full; then only every thousandth.
                        if overruns <= 5 || overruns.is_multiple_of(1000) {
                            tracing::warn!(
                                "{identity}: {time:.3} s: tick overran by {:.1} µs ({overruns} so far)",
                                late_ns as f64 / 1e3
                            );
                        }
                    }
                }
            }
            if finished {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    })
}

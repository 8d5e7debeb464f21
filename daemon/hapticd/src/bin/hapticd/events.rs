//! The logging thread: it logs what the real-time thread reports through its event ring.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::time::{Duration, Instant};

use hapticd::realtime::{LoopEvent, thread_faults};
use hapticd_core::haptic_loop::DeviceState;
use hapticd_core::sync::spsc;
use hapticd_service::log_lines::{INTERVAL as FAULT_INTERVAL, LogLines};

/// Log overrun `event` of device `identity`, the `overruns`-th, with the haptic thread's page
/// faults `since` the last one logged (when known).
fn log_overrun(identity: &str, event: &LoopEvent, overruns: u64, since: Option<u64>) {
    let LoopEvent::Overrun {
        time,
        late_ns,
        woke_ns,
        busy_ns,
    } = *event
    else {
        return;
    };
    let faults = since.map_or(String::new(), |n| format!("; {n} page faults since"));
    tracing::warn!(
        "{identity}: {time:.3} s: tick overran by {:.1} µs: woke {:.1} µs late, then busy {:.1} \
         µs{faults} ({overruns} so far)",
        late_ns as f64 / 1e3,
        woke_ns as f64 / 1e3,
        busy_ns as f64 / 1e3
    );
}

/// Log the events of the loop of device `identity` as they come (the real-time thread must
/// not write itself); faults one line per [`FAULT_INTERVAL`] at most, the rest counted. An
/// overrun says the page faults the haptic thread (`thread_id`, once it has started) took
/// since the last one said.
pub fn spawn_event_logger(
    identity: String,
    mut events: spsc::Consumer<LoopEvent>,
    done: &'static AtomicBool,
    thread_id: Arc<AtomicI32>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut overruns = 0u64;
        let mut faulted = None;
        let started = Instant::now();
        let mut faults = LogLines::new(FAULT_INTERVAL);
        // The last fault was only counted, and so is its recovery.
        let mut hushed = false;
        let mut latest = DeviceState::Running;
        loop {
            let finished = done.load(Ordering::Acquire);
            while let Some(event) = events.pop() {
                match event {
                    LoopEvent::State {
                        time,
                        state,
                        error,
                        fault,
                    } => {
                        latest = state;
                        let counted = std::mem::take(&mut hushed);
                        match (state, error) {
                            (_, Some(e)) => {
                                tracing::error!("{identity}: {time:.3} s: device {state:?}: {e}")
                            }
                            (DeviceState::Running, None) if counted => {}
                            (DeviceState::Running, None) => {
                                tracing::info!("{identity}: {time:.3} s: device {state:?}")
                            }
                            (DeviceState::Uncalibrated, None) => tracing::error!(
                                "{identity}: {time:.3} s: the counts no longer fit the calibration \
                                 (did the amplifier lose power?): forces held at zero until it is \
                                 calibrated again (Calibrate())"
                            ),
                            (DeviceState::Fault, None)
                                if !faults.event(started.elapsed().as_secs_f64()) =>
                            {
                                hushed = true;
                            }
                            (DeviceState::Fault, None) => tracing::error!(
                                "{identity}: {time:.3} s: device Fault: {fault}; forces ramped to \
                                 zero"
                            ),
                            (_, None) => {
                                tracing::error!(
                                    "{identity}: {time:.3} s: device {state:?}: forces ramped to zero"
                                )
                            }
                        }
                    }
                    LoopEvent::SceneFault { time, fault } => tracing::error!(
                        "{identity}: {time:.3} s: scene plugin output refused: {fault}; the \
                         plugin is disabled and the forces ramped to zero (switch scenes to load \
                         it again)"
                    ),
                    LoopEvent::Overrun { .. } => {
                        overruns += 1;
                        // The first few in full; then only every thousandth.
                        if overruns <= 5 || overruns.is_multiple_of(1000) {
                            let faults = thread_faults(thread_id.load(Ordering::Acquire));
                            let since = faults.zip(faulted).map(|(now, before)| now - before);
                            faulted = faults;
                            log_overrun(&identity, &event, overruns, since);
                        }
                    }
                }
            }
            // The count so far, at the latest when the daemon stops.
            let now = match finished {
                true => f64::INFINITY,
                false => started.elapsed().as_secs_f64(),
            };
            if let Some(more) = faults.summary(now) {
                tracing::error!(
                    "{identity}: device faulted {more} more times in the last {FAULT_INTERVAL:.0} \
                     s, forces ramped to zero each time; {} now",
                    latest.name()
                );
            }
            if finished {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    })
}

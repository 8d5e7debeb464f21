//! The main thread's watch over a running haptic loop: the systemd watchdog (pinged only
//! while the loop's heartbeat advances), reloads, freeing what the loop retired, following the
//! amplifier across unplugs and arrivals, telemetry for D-Bus at 10 Hz, and a status line on
//! standard output twice a second.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use glam::DVec3;
use hapticd::control::{Daemon, DeviceHandle, Telemetry};
use hapticd::device::hotplug::{Arrivals, Lookup, Reconnector};
use hapticd::runtime::haptic_loop::{DeviceState, Frame, Retired};
use hapticd::runtime::realtime::RealtimeLoop;
use hapticd::runtime::spsc;
use hapticd::sd_notify;

use crate::signals::{RELOAD, STOP};

/// How a run ended well.
pub enum Ending {
    /// Asked to stop, or its time was up.
    Done,
    /// An amplifier was plugged in while simulating: start again, on it.
    Restart,
}

/// What the main thread watches over.
pub struct Supervisor<'a> {
    /// The running loop.
    pub rt: &'a mut RealtimeLoop,
    /// The device it drives, as D-Bus sees it.
    pub device: Arc<DeviceHandle>,
    /// The daemon, for reloads.
    pub daemon: Arc<Daemon>,
    /// Scenes and links the loop stopped using.
    pub retired: spsc::Consumer<Retired>,
    /// Set when the device is a USB amplifier: opens it again after an unplug.
    pub reconnector: Option<Reconnector>,
    /// Set when simulating for want of hardware: notices an amplifier plugged in.
    pub arrivals: Option<Arrivals>,
    /// Stop after this many seconds.
    pub duration: Option<f64>,
}

impl Supervisor<'_> {
    /// Watch until asked to stop, the time is up, or an amplifier arrives.
    pub fn run(mut self) -> Ending {
        let started = Instant::now();
        let watchdog = sd_notify::watchdog_interval().map(|w| w / 2);
        let (mut last_ping, mut last_beat) = (Instant::now(), 0);
        let (mut last_status, mut last_publish) = (Instant::now(), Instant::now());
        while !STOP.load(Ordering::Acquire) {
            if self
                .duration
                .is_some_and(|d| started.elapsed().as_secs_f64() >= d)
            {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
            let beat = self.rt.heartbeat();
            if let Some(interval) = watchdog
                && beat > last_beat
                && last_ping.elapsed() >= interval
            {
                let _ = sd_notify::notify("WATCHDOG=1");
                last_ping = Instant::now();
            }
            last_beat = beat;
            if RELOAD.swap(false, Ordering::AcqRel) {
                match self.daemon.reload() {
                    Ok(()) => tracing::info!("reloaded the configuration and plugins"),
                    Err(e) => tracing::error!("reload refused, nothing changed: {e}"),
                }
            }
            // Freed here, off the real-time thread.
            while self.retired.pop().is_some() {}
            self.follow_the_amplifier();
            if let Some((plugged, model)) =
                self.arrivals.as_mut().and_then(|a| a.poll(Instant::now()))
            {
                tracing::info!(
                    "{plugged} ({}) plugged in: starting again on it",
                    model.name
                );
                return Ending::Restart;
            }
            if last_publish.elapsed() >= Duration::from_millis(100) {
                self.device.publish(Telemetry {
                    frame: *self.rt.frame(),
                    stats: *self.rt.stats(),
                });
                last_publish = Instant::now();
            }
            if last_status.elapsed() >= Duration::from_millis(500) {
                let frame = *self.rt.frame();
                println!("{}", status_line(&frame, self.rt));
                last_status = Instant::now();
            }
        }
        Ending::Done
    }

    /// While the amplifier is missing, look for it and hand it back to the loop.
    fn follow_the_amplifier(&mut self) {
        let Some(reconnector) = self.reconnector.as_mut() else {
            return;
        };
        let missing = self.rt.frame().state == DeviceState::Disconnected;
        let identity = self.device.identity();
        match reconnector.poll(missing, Instant::now()) {
            Lookup::Back(link) => match self.device.reconnect(link) {
                Ok(()) => tracing::info!("{identity} is back: reconnected"),
                Err(e) => tracing::warn!("{identity} is back but not reconnected: {e}"),
            },
            Lookup::Refused(why) => tracing::warn!("{why}"),
            Lookup::Idle | Lookup::Absent => {}
        }
    }
}

/// One line of the state, the first grip's position and force, and the loop's timing.
fn status_line(frame: &Frame, rt: &mut RealtimeLoop) -> String {
    let p = frame.poses[0].position;
    let f = DVec3::new(
        frame.wrenches[0][0],
        frame.wrenches[0][1],
        frame.wrenches[0][2],
    );
    let stats = *rt.stats();
    format!(
        "t={:6.2} s  {:?}  grip ({:+.4}, {:+.4}, {:+.4}) m  force ({:+.2}, {:+.2}, {:+.2}) N  \
         wait p99 {:.0} µs  busy {:.1} µs  overruns {}",
        frame.time,
        frame.state,
        p.x,
        p.y,
        p.z,
        f.x,
        f.y,
        f.z,
        stats.wait_percentile_ns(0.99) as f64 / 1e3,
        stats.busy_mean_ns() as f64 / 1e3,
        stats.overruns
    )
}

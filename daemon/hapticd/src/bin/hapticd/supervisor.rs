//! The main thread's watch over the running haptic loops: the systemd watchdog (pinged only
//! while every loop's heartbeat advances), reloads, freeing what the loops retired, following
//! amplifiers across unplugs and arrivals, telemetry for D-Bus at 10 Hz, and a status line per
//! device on standard output twice a second.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use hapticd::control::{Daemon, Telemetry};
use hapticd::realtime::RealtimeLoop;
use hapticd_core::haptic_loop::Frame;
use hapticd_core::transport::TransportError;
use hapticd_device::guardian::Guardian;
use hapticd_device::hotplug::{Arrivals, Lookup};
use hapticd_service::sd_notify;

use crate::device::Device;
use crate::signals::{RELOAD, STOP};

/// How a run ended well.
pub enum Ending {
    /// Asked to stop, or its time was up.
    Done,
    /// Start again: an amplifier hapticd does not drive was plugged in, or a client asked
    /// (Manager.Restart) to apply what waits for the next start.
    Restart,
}

/// What the main thread watches over.
pub struct Supervisor<'a> {
    /// The running devices.
    pub devices: &'a mut [Device],
    /// The daemon, for reloads.
    pub daemon: Arc<Daemon>,
    /// Set unless told to simulate or replay: notices an amplifier plugged in.
    pub arrivals: Option<Arrivals>,
    /// Stop after this many seconds.
    pub duration: Option<f64>,
    /// The process that zeroes the amplifiers should this one die.
    pub guardian: &'a Guardian,
}

impl Supervisor<'_> {
    /// Watch until asked to stop or to restart, the time is up, or an amplifier arrives.
    pub fn run(mut self) -> Ending {
        let started = Instant::now();
        let watchdog = sd_notify::watchdog_interval().map(|w| w / 2);
        let (mut last_ping, mut last_beats) = (Instant::now(), vec![0; self.devices.len()]);
        let (mut last_status, mut last_publish) = (Instant::now(), Instant::now());
        let quiet = hapticd_service::logging::under_journal();
        while !STOP.load(Ordering::Acquire) {
            if self
                .duration
                .is_some_and(|d| started.elapsed().as_secs_f64() >= d)
            {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
            let mut all_beating = true;
            for (device, last) in self.devices.iter().zip(&mut last_beats) {
                let beat = device.rt.heartbeat();
                all_beating &= beat > *last;
                *last = beat;
            }
            if let Some(interval) = watchdog
                && all_beating
                && last_ping.elapsed() >= interval
            {
                let _ = sd_notify::notify("WATCHDOG=1");
                last_ping = Instant::now();
            }
            if self.daemon.restart_requested() {
                tracing::info!("starting again, as asked: pending changes apply");
                return Ending::Restart;
            }
            if RELOAD.swap(false, Ordering::AcqRel) {
                match self.daemon.reload() {
                    Ok(()) => tracing::info!("reloaded the configuration and plugins"),
                    Err(e) => tracing::error!("reload refused, nothing changed: {e}"),
                }
            }
            for device in self.devices.iter_mut() {
                // Freed here, off the real-time thread.
                while device.retired.pop().is_some() {}
                follow_the_amplifier(device, self.guardian);
                device.report_failed_recordings();
            }
            if let Some(news) = self.guardian.revive() {
                tracing::error!("{news}");
            }
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
                for device in self.devices.iter_mut() {
                    device.handle.publish(Telemetry {
                        frame: *device.rt.frame(),
                        stats: *device.rt.stats(),
                    });
                }
                last_publish = Instant::now();
            }
            // A person at a terminal reads the status; the journal gets events only (the
            // status is on the bus for clients).
            if !quiet && last_status.elapsed() >= Duration::from_millis(500) {
                let several = self.devices.len() > 1;
                for device in self.devices.iter_mut() {
                    let frame = *device.rt.frame();
                    let line = status_line(&frame, &mut device.rt);
                    match several {
                        true => println!("{}: {line}", device.handle.identity()),
                        false => println!("{line}"),
                    }
                }
                last_status = Instant::now();
            }
        }
        Ending::Done
    }
}

/// While `device` is a missing amplifier, look for it and hand it back to its loop (and its
/// new node to the guardian).
fn follow_the_amplifier(device: &mut Device, guardian: &Guardian) {
    let Some((reconnector, protocol)) = device.reconnector.as_mut() else {
        return;
    };
    // Gone from the bus; an amplifier that only times out or fails a transfer is still
    // there, and its link is tried again every tick.
    let missing = device.rt.frame().error == Some(TransportError::Disconnected);
    let identity = device.handle.identity();
    match reconnector.poll(missing, Instant::now()) {
        Lookup::Back(link) => {
            guardian.watch_amplifier(device.slot, *protocol, link.node());
            match device.handle.reconnect(Box::new(link)) {
                Ok(()) => tracing::info!("{identity} is back: reconnected"),
                Err(e) => tracing::warn!("{identity} is back but not reconnected: {e}"),
            }
        }
        Lookup::Refused(why) => tracing::warn!("{why}"),
        Lookup::Idle | Lookup::Absent => {}
    }
}

/// One line of the state, the first grip's position and force, and the loop's timing.
fn status_line(frame: &Frame, rt: &mut RealtimeLoop) -> String {
    let p = frame.poses[0].position;
    let f = frame.wrenches[0].force;
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

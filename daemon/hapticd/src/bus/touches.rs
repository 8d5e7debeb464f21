//! Touches as the bus announces them: the announcing thread follows each device's telemetry
//! ring like any other reader (the haptic thread never knows), and each tick where an
//! effector begins touching a body, stops, or begins to slip along it becomes a `Touch`
//! signal: which effector, what happened, the tick and its time, the body (its id), where
//! and along which normal they touch, and the force displayed. At most
//! [`MOST_PER_ANNOUNCE`] a device each announcement, ten a tenth of a second: a hand
//! trembling on a surface cannot flood the bus (the ring itself keeps every tick's contacts).

use hapticd_core::telemetry::Sample;
use hapticd_ipc::telemetry_share::{Cursor, MappedTelemetry};
pub use hapticd_ipc::touch_events::Touch;
use hapticd_ipc::touch_events::TouchTracker;

use crate::control::DeviceHandle;

/// Most touches one announcement carries for a device; the rest are not sent.
pub const MOST_PER_ANNOUNCE: usize = 10;

/// A device's ring, followed for touches.
pub struct Touches {
    ring: MappedTelemetry,
    cursor: Cursor,
    tracker: TouchTracker,
}

impl Touches {
    /// Follow `device`'s ring from now; None if it has none.
    pub fn of(device: &DeviceHandle) -> Option<Self> {
        let ring = MappedTelemetry::open(&device.open_telemetry().ok()?).ok()?;
        let cursor = ring.from_now();
        Some(Self {
            ring,
            cursor,
            tracker: TouchTracker::new(),
        })
    }

    /// The touches of the ticks written since the last scan, at most
    /// [`MOST_PER_ANNOUNCE`] of them.
    pub fn scan(&mut self) -> Vec<Touch> {
        let mut found = Vec::new();
        let mut sample = Sample::EMPTY;
        while self.ring.next(&mut self.cursor, &mut sample) {
            self.tracker.follow(&sample, |touch| {
                if found.len() < MOST_PER_ANNOUNCE {
                    found.push(touch);
                }
            });
        }
        found
    }
}

//! Touches as the bus announces them: the announcing thread follows each device's telemetry
//! ring like any other reader (the haptic thread never knows), and each tick where an
//! effector starts or stops displaying a force becomes a `Touch` signal: which effector,
//! begun or ended, the tick and its time, where the grip was and the force it felt. At most
//! [`MOST_PER_ANNOUNCE`] a device each announcement, ten a tenth of a second: a hand
//! trembling on a surface cannot flood the bus (the ring itself keeps every tick's contacts).

use hapticd_core::telemetry::Sample;
use hapticd_ipc::telemetry_share::{Cursor, MappedTelemetry};

use crate::control::DeviceHandle;

/// Most touches one announcement carries for a device; the rest are not sent.
pub const MOST_PER_ANNOUNCE: usize = 10;

/// One effector starting or stopping to touch something.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    /// The effector, in the order of `Effectors`.
    pub effector: u32,
    /// Whether it began touching (or stopped).
    pub touching: bool,
    /// The tick it happened at.
    pub tick: u64,
    /// The loop time then, seconds.
    pub time: f64,
    /// Where the grip was, metres.
    pub position: [f64; 3],
    /// The force it displayed, newtons.
    pub force: [f64; 3],
}

/// A device's ring, followed for touches.
pub struct Touches {
    ring: MappedTelemetry,
    cursor: Cursor,
    touching: u32,
}

impl Touches {
    /// Follow `device`'s ring from now; None if it has none.
    pub fn of(device: &DeviceHandle) -> Option<Self> {
        let ring = MappedTelemetry::open(&device.open_telemetry().ok()?).ok()?;
        let cursor = ring.from_now();
        Some(Self {
            ring,
            cursor,
            touching: 0,
        })
    }

    /// The touches of the ticks written since the last scan, at most
    /// [`MOST_PER_ANNOUNCE`] of them.
    pub fn scan(&mut self) -> Vec<Touch> {
        let mut found = Vec::new();
        let mut sample = Sample::EMPTY;
        while self.ring.next(&mut self.cursor, &mut sample) {
            let changed = (sample.contacts ^ self.touching) & mask(sample.effectors);
            self.touching = sample.contacts;
            for k in (0..32).filter(|k| changed & (1 << k) != 0) {
                if found.len() == MOST_PER_ANNOUNCE {
                    break;
                }
                let k = k as usize;
                found.push(Touch {
                    effector: k as u32,
                    touching: sample.contacts & (1 << k) != 0,
                    tick: sample.tick,
                    time: sample.time,
                    position: sample.poses[k].position,
                    force: sample.wrenches[k].force,
                });
            }
        }
        found
    }
}

/// The bits of the first `effectors` effectors.
fn mask(effectors: u32) -> u32 {
    match effectors.min(hapticd_core::kinematics::MAX_EFFECTORS as u32) {
        32.. => u32::MAX,
        n => (1 << n) - 1,
    }
}

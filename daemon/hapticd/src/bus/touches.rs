//! Touches as the bus announces them: the announcing thread follows each device's telemetry
//! ring like any other reader (the haptic thread never knows), and each tick where an
//! effector begins touching a body, stops, or begins to slip along it becomes a `Touch`
//! signal: which effector, what happened, the tick and its time, the body (its id), where
//! and along which normal they touch, and the force displayed. At most
//! [`MOST_PER_ANNOUNCE`] a device each announcement, ten a tenth of a second: a hand
//! trembling on a surface cannot flood the bus (the ring itself keeps every tick's contacts).

use hapticd_core::kinematics::MAX_EFFECTORS;
use hapticd_core::telemetry::Sample;
use hapticd_ipc::telemetry_share::{Cursor, MappedTelemetry};
use hapticd_plugin_api::HAPTICD_NO_BODY;

use crate::control::DeviceHandle;

/// Most touches one announcement carries for a device; the rest are not sent.
pub const MOST_PER_ANNOUNCE: usize = 10;

/// What happened to an effector's touch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// It began touching a body (or another body than before).
    Begin,
    /// It stopped touching it.
    End,
    /// It began to slide along it (dynamic friction) after sticking.
    Slip,
}

impl Event {
    /// The event as the signal names it.
    pub fn name(self) -> &'static str {
        match self {
            Event::Begin => "begin",
            Event::End => "end",
            Event::Slip => "slip",
        }
    }
}

/// One change of an effector's touch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    /// The effector, in the order of `Effectors`.
    pub effector: u32,
    /// What happened.
    pub event: Event,
    /// The tick it happened at.
    pub tick: u64,
    /// The loop time then, seconds.
    pub time: f64,
    /// The body touched (its id), or [`HAPTICD_NO_BODY`] for a solid that is no body.
    pub body: u32,
    /// Where they touch, metres (for an end: where they last touched).
    pub point: [f64; 3],
    /// The outward normal of the surface touched (the force's direction where the scene
    /// cannot say).
    pub normal: [f64; 3],
    /// The force the effector displayed, newtons.
    pub force: [f64; 3],
}

/// What an effector touched at the last tick read.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Held {
    touching: bool,
    body: u32,
    slipping: bool,
    point: [f64; 3],
    normal: [f64; 3],
}

const FREE: Held = Held {
    touching: false,
    body: HAPTICD_NO_BODY,
    slipping: false,
    point: [0.0; 3],
    normal: [0.0; 3],
};

/// A device's ring, followed for touches.
pub struct Touches {
    ring: MappedTelemetry,
    cursor: Cursor,
    held: [Held; MAX_EFFECTORS],
}

/// Effector `k`'s touch in `sample`.
fn held_in(sample: &Sample, k: usize) -> Held {
    let touching = sample.contacts & (1 << k) != 0;
    let force = sample.wrenches[k].force;
    let length = force.iter().map(|f| f * f).sum::<f64>().sqrt();
    let normal = match sample.touch_normals[k] {
        [0.0, 0.0, 0.0] if length > 0.0 => force.map(|f| f / length),
        given => given,
    };
    Held {
        touching,
        body: if touching {
            sample.touched[k]
        } else {
            HAPTICD_NO_BODY
        },
        slipping: touching && sample.slipping & (1 << k) != 0,
        point: sample.touch_points[k],
        normal,
    }
}

impl Touches {
    /// Follow `device`'s ring from now; None if it has none.
    pub fn of(device: &DeviceHandle) -> Option<Self> {
        let ring = MappedTelemetry::open(&device.open_telemetry().ok()?).ok()?;
        let cursor = ring.from_now();
        Some(Self {
            ring,
            cursor,
            held: [FREE; MAX_EFFECTORS],
        })
    }

    /// The touches of the ticks written since the last scan, at most
    /// [`MOST_PER_ANNOUNCE`] of them.
    pub fn scan(&mut self) -> Vec<Touch> {
        let mut found = Vec::new();
        let mut sample = Sample::EMPTY;
        while self.ring.next(&mut self.cursor, &mut sample) {
            let effectors = (sample.effectors as usize).min(MAX_EFFECTORS);
            for k in 0..effectors {
                let (was, now) = (self.held[k], held_in(&sample, k));
                self.held[k] = now;
                let touch = |event: Event, at: &Held| Touch {
                    effector: k as u32,
                    event,
                    tick: sample.tick,
                    time: sample.time,
                    body: at.body,
                    point: at.point,
                    normal: at.normal,
                    force: sample.wrenches[k].force,
                };
                let mut events = [None, None];
                if was.touching && (!now.touching || now.body != was.body) {
                    events[0] = Some(touch(Event::End, &was));
                }
                if now.touching && (!was.touching || now.body != was.body) {
                    events[1] = Some(touch(Event::Begin, &now));
                } else if now.slipping && !was.slipping {
                    events[1] = Some(touch(Event::Slip, &now));
                }
                for event in events.into_iter().flatten() {
                    if found.len() < MOST_PER_ANNOUNCE {
                        found.push(event);
                    }
                }
            }
        }
        found
    }
}

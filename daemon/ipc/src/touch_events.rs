//! Touches found in a device's ticks: each tick where an effector begins touching a body,
//! stops, or begins to slip along it. The bus's `Touch` signal and the network bridge's
//! contact topic both come from here, following the telemetry ring like any reader (the
//! haptic thread never knows).

use hapticd_core::kinematics::MAX_EFFECTORS;
use hapticd_core::telemetry::Sample;
use hapticd_plugin_api::HAPTICD_NO_BODY;

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
    /// The event in one word: `begin`, `end` or `slip`.
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

/// What an effector touched at the last tick seen.
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

/// Each effector's touch from one tick to the next.
#[derive(Debug, Clone)]
pub struct TouchTracker {
    held: [Held; MAX_EFFECTORS],
}

impl Default for TouchTracker {
    fn default() -> Self {
        Self {
            held: [FREE; MAX_EFFECTORS],
        }
    }
}

impl TouchTracker {
    /// Nothing touched yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Hand `found` each change `sample` (the tick after the last one seen) makes: an end
    /// before a begin when an effector moves from one body to another.
    pub fn follow(&mut self, sample: &Sample, mut found: impl FnMut(Touch)) {
        let effectors = (sample.effectors as usize).min(MAX_EFFECTORS);
        for k in 0..effectors {
            let (was, now) = (self.held[k], held_in(sample, k));
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
            if was.touching && (!now.touching || now.body != was.body) {
                found(touch(Event::End, &was));
            }
            if now.touching && (!was.touching || now.body != was.body) {
                found(touch(Event::Begin, &now));
            } else if now.slipping && !was.slipping {
                found(touch(Event::Slip, &now));
            }
        }
    }
}

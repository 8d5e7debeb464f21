//! Shaking a held box (thesis 4.7, Tables 4.1–4.2, Fig. 4.11–4.12): a two-finger hand
//! holds a box in the air and shakes it sideways, with the grasp rendered by the resultant
//! distribution method or by the conventional one.
//!
//! The hand does what 4.3 measured in people: it keeps squeezing with a constant grip effort,
//! and produces the push that moves the object by pressing harder with the finger behind it.
//! Each finger is a small mass the hand drives: along the grasp (x) with the grip effort plus,
//! when the finger lags its place in the moving hand, a push inward (a spring and damper
//! toward the place, never pulling outward); across it (y, z) with a spring and damper to the
//! hand, which is how the fingers carry the object's weight, by friction.

use glam::DVec3;
use hapticd_core::haptics::grasp::{Grasp, GraspSettings, Handheld, Method, Object};
use serde_json::json;

pub use super::Spread;
use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// The set-up of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setup {
    /// Distributed or conventional.
    pub method: Method,
    /// The box's mass, kg.
    pub mass: f64,
    /// Its width along the grasp, metres.
    pub width: f64,
    /// Its height, metres.
    pub height: f64,
    /// Gravity, m/s² (downward).
    pub gravity: f64,
    /// Grip spring, N/m.
    pub grip_stiffness: f64,
    /// Inertia spring, N/m.
    pub inertia_stiffness: f64,
    /// Friction coefficient between the fingers and the box.
    pub friction: f64,
    /// Length of the run, seconds.
    pub seconds: f64,
    /// Each finger's squeeze, newtons.
    pub grip_effort: f64,
    /// Half the sideways travel of a shake (the hand goes 2× this to one side and back), metres.
    pub amplitude: f64,
    /// Shakes per second.
    pub frequency: f64,
    /// Shakes in a row before the hand holds still.
    pub shakes: u32,
    /// How long the hand holds still after each series, seconds.
    pub still: f64,
}

impl Setup {
    /// The thesis' set-up (4.7.1): a 1 kg box 6 cm wide and 10 cm high, g = 2.0 m/s², both
    /// springs 800 N/m, μ = 1.0, shaken sideways about 5 cm eight times, then 2 s still,
    /// for 30 s. The grip effort (2 N) is the subjects' mean grip force (Table 4.1); the pace
    /// (2 shakes a second) is not given in the thesis.
    pub const THESIS: Setup = Setup {
        method: Method::Distributed,
        mass: 1.0,
        width: 0.06,
        height: 0.10,
        gravity: 2.0,
        grip_stiffness: 800.0,
        inertia_stiffness: 800.0,
        friction: 1.0,
        seconds: 30.0,
        grip_effort: 2.0,
        amplitude: 0.025,
        frequency: 2.0,
        shakes: 8,
        still: 2.0,
    };

    /// Seconds of one series of shakes and its still phase.
    fn cycle(&self) -> f64 {
        f64::from(self.shakes) / self.frequency + self.still
    }

    /// Where the hand wants the grasp at `t`, along x, and whether it is holding still.
    fn target(&self, t: f64) -> (f64, bool) {
        let shaking = f64::from(self.shakes) / self.frequency;
        let phase = t % self.cycle();
        if phase < shaking {
            // From rest to rest each shake, so the hand never jerks.
            (
                self.amplitude * ((std::f64::consts::TAU * self.frequency * phase).cos() - 1.0),
                false,
            )
        } else {
            (0.0, true)
        }
    }
}

/// Mass of each finger, kg.
const FINGER_MASS: f64 = 0.05;
/// How hard the hand pushes a finger that lags its place, N/m and N·s/m.
const PUSH_STIFFNESS: f64 = 1000.0;
const PUSH_DAMPING: f64 = 12.0;
/// How the hand holds each finger across the grasp, N/m and N·s/m.
const HOLD_STIFFNESS: f64 = 500.0;
const HOLD_DAMPING: f64 = 10.0;
/// Haptic rate.
const DT: f64 = 0.001;

/// One millisecond of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, seconds.
    pub time: f64,
    /// Grip force (4.2): the smaller of the two fingers' pushes along the grasp, newtons.
    pub grip: f64,
    /// Distance between the fingers, metres.
    pub distance: f64,
    /// The force the fingers give the box along the grasp, newtons.
    pub resultant: f64,
    /// Whether the hand holds still.
    pub still: bool,
}

/// Run `setup`, one sample per millisecond.
pub fn run(setup: &Setup) -> Vec<Sample> {
    let object = Object::at_rest(
        DVec3::new(setup.width, setup.height, setup.width),
        setup.mass,
        DVec3::ZERO,
    );
    let settings = GraspSettings {
        method: setup.method,
        grip_stiffness: setup.grip_stiffness,
        inertia_stiffness: setup.inertia_stiffness,
        // Near critical for the box on the inertia spring.
        inertia_damping: 0.7 * (setup.inertia_stiffness * setup.mass).sqrt(),
        friction: setup.friction,
    };
    let mut grasp = Handheld {
        grasp: Grasp::new(settings),
        object,
        gravity: DVec3::new(0.0, -setup.gravity, 0.0),
    };
    // The fingers start squeezed as the grip effort would hold them.
    let squeeze = setup.grip_effort / setup.grip_stiffness;
    let half = setup.width / 2.0 - squeeze;
    let mut x = [DVec3::new(-half, 0.0, 0.0), DVec3::new(half, 0.0, 0.0)];
    let mut v = [DVec3::ZERO; 2];
    let steps = (setup.seconds / DT).round() as usize;
    let mut samples = Vec::with_capacity(steps);
    for step in 0..steps {
        let time = step as f64 * DT;
        let frame = grasp.step(&x, DT);
        let (f1, f2) = (frame.forces[0].x.abs(), frame.forces[1].x.abs());
        samples.push(Sample {
            time,
            grip: f1.min(f2),
            distance: x[1].x - x[0].x,
            resultant: frame.resultant.x,
            still: setup.target(time).1,
        });
        let (target, _) = setup.target(time);
        for (i, inward) in [1.0, -1.0].into_iter().enumerate() {
            // Along the grasp: the grip effort, and a push inward when the finger lags its
            // place, never a pull: the finger behind the motion pushes, the other keeps its
            // squeeze.
            let lag = PUSH_STIFFNESS * (target - inward * half - x[i].x) - PUSH_DAMPING * v[i].x;
            let along = inward * (setup.grip_effort + (inward * lag).max(0.0));
            let across = HOLD_STIFFNESS * DVec3::new(0.0, -x[i].y, -x[i].z)
                - HOLD_DAMPING * DVec3::new(0.0, v[i].y, v[i].z);
            v[i] += (frame.forces[i] + DVec3::new(along, across.y, across.z)) / FINGER_MASS * DT;
            x[i] += v[i] * DT;
        }
    }
    samples
}

/// The figures of Tables 4.1 and 4.2 for one run, over the whole run and over the still
/// phases (after their first half second, when the box has come to rest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Grip force, newtons, whole run.
    pub grip: Spread,
    /// Finger distance, metres, whole run.
    pub distance: Spread,
    /// Grip force while still.
    pub still_grip: Spread,
    /// Finger distance while still.
    pub still_distance: Spread,
}

impl Summary {
    /// Summarise the samples of `setup`'s run.
    pub fn of(setup: &Setup, samples: &[Sample]) -> Summary {
        let settled =
            |s: &&Sample| s.still && (s.time % setup.cycle()) > setup.cycle() - setup.still + 0.5;
        Summary {
            grip: Spread::of(samples.iter().map(|s| s.grip)),
            distance: Spread::of(samples.iter().map(|s| s.distance)),
            still_grip: Spread::of(samples.iter().filter(settled).map(|s| s.grip)),
            still_distance: Spread::of(samples.iter().filter(settled).map(|s| s.distance)),
        }
    }
}

/// The name of `method` in the tables.
fn method_name(method: Method) -> &'static str {
    match method {
        Method::Distributed => "distributed",
        Method::Conventional => "conventional",
    }
}

/// `setup` run with each of `methods` (its own method ignored): Tables 4.1–4.2 side by side,
/// a result row per method with what (4.10) predicts, and Fig. 4.12's charts.
pub fn report(setup: &Setup, methods: &[Method]) -> Report {
    let runs: Vec<(&str, Setup, Vec<Sample>)> = methods
        .iter()
        .map(|&method| {
            let setup = Setup { method, ..*setup };
            (method_name(method), setup, run(&setup))
        })
        .collect();
    let mut text = String::from(
        "method         grip force [N]     finger distance [mm]   still: grip [N]   distance [mm]\n",
    );
    let mut rows = Vec::new();
    for (name, setup, samples) in &runs {
        let s = Summary::of(setup, samples);
        let mm = 1e3;
        text += &format!(
            "{name:<14} {:5.2} ± {:5.3}      {:6.2} ± {:6.3}        {:5.2} ± {:5.3}    {:6.2} ± {:6.3}\n",
            s.grip.mean,
            s.grip.deviation,
            s.distance.mean * mm,
            s.distance.deviation * mm,
            s.still_grip.mean,
            s.still_grip.deviation,
            s.still_distance.mean * mm,
            s.still_distance.deviation * mm,
        );
        let spread = |x: Spread| json!({"mean": x.mean, "deviation": x.deviation});
        rows.push(json!({
            "method": name,
            "grip": spread(s.grip),
            "distance": spread(s.distance),
            "still_grip": spread(s.still_grip),
            "still_distance": spread(s.still_distance),
            // What (4.10) predicts for the still grasp: l − 2 f_g / k.
            "predicted_still_distance": setup.width - 2.0 * s.still_grip.mean / setup.grip_stiffness,
        }));
    }
    Report {
        text,
        json: json!({ "results": rows }),
        charts: charts(&runs, setup),
    }
}

/// Fig. 4.12 for `runs` of `setup`: forces and finger distance over one series of shakes and
/// its still phase, after the first.
fn charts(runs: &[(&str, Setup, Vec<Sample>)], setup: &Setup) -> Vec<Chart> {
    let cycle = setup.cycle();
    let window = (cycle, (2.0 * cycle).min(setup.seconds));
    let series = |pick: fn(&Sample) -> f64, label: &str| -> Vec<Series> {
        runs.iter()
            .enumerate()
            .map(|(k, (name, _, samples))| Series {
                label: format!("{label}, {name}"),
                points: samples
                    .iter()
                    .filter(|s| (window.0..=window.1).contains(&s.time))
                    .step_by(5)
                    .map(|s| (s.time, pick(s)))
                    .collect(),
                color: PALETTE[k],
            })
            .collect()
    };
    let mut forces = series(|s| s.grip, "grip");
    forces.extend(
        series(|s| s.resultant.abs(), "|resultant|")
            .into_iter()
            .enumerate()
            .map(|(k, s)| Series {
                color: PALETTE[k + 2],
                ..s
            }),
    );
    vec![
        Chart {
            title: "shaking a held box: forces".into(),
            x_label: "time [s]".into(),
            y_label: "force [N]".into(),
            series: forces,
            ..Chart::default()
        },
        Chart {
            title: "finger distance".into(),
            x_label: "time [s]".into(),
            y_label: "distance [mm]".into(),
            series: series(|s| s.distance * 1e3, "distance"),
            ..Chart::default()
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hand_shakes_eight_times_then_holds_still() {
        let s = Setup::THESIS;
        assert_eq!(s.cycle(), 6.0);
        assert!(!s.target(0.1).1 && s.target(4.5).1 && !s.target(6.1).1);
        // From rest 5 cm to one side and back, each quarter second.
        assert!(s.target(0.0).0 == 0.0 && (s.target(0.25).0 + 0.05).abs() < 1e-12);
    }
}

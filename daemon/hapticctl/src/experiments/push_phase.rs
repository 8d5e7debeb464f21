//! Pushing a block once at a low physics rate (thesis 6.4.1–6.4.2, Fig. 6.6): a finger pushes
//! a block across a friction floor, the world on rapier at 20 Hz, the haptic side at 1 kHz
//! with a 2 kN/m proxy spring, for several sampling phases (where the physics clock falls
//! between haptic ticks). Taking the hand's position at each physics step makes where the
//! block stops depend on the phase; handing back the impulse of the force displayed does not.
//!
//! The finger is a mass the arm drives toward a scripted target by a spring and damper (the
//! simulated hand's figures, [`SimParameters`]) and the force displayed pushes back on it,
//! so a finger that strikes a block the physics has not moved yet rebounds as a hand would.

use glam::DVec3;
use hapticd_core::kinematics::Wrench;
use hapticd_device::sim::SimParameters;
use hapticd_physics::scene::{Feedback, RapierScene, SceneFile};
use serde_json::json;

use super::{ExperimentError, Spread};
use crate::multirate::Lockstep;
use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// The shipped scene of the experiment: an 8 kg block on a floor, μ = 0.03, at 20 Hz.
pub const SCENE: &str = include_str!("../../../../config/scenes/push.yaml");

/// The set-up of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setup {
    /// Physics steps per second.
    pub rate: f64,
    /// Haptic ticks per second.
    pub haptic_rate: f64,
    /// Where the finger starts, metres along x (at the block's height).
    pub start: f64,
    /// How far along x the hand reaches before it withdraws, metres.
    pub reach: f64,
    /// The hand's speed toward the block, m/s.
    pub speed: f64,
    /// Seconds simulated.
    pub seconds: f64,
}

impl Setup {
    /// The thesis' rates (20 Hz physics, 1 kHz haptics); the hand strikes the shipped
    /// scene's block: it meets its face at x = 0.03 m at 0.8 m/s, reaches 2 cm past it and
    /// withdraws. (The thesis gives neither mass nor speed. The hand, 0.3 kg, rebounds from
    /// a block the physics has not moved yet as from a wall, so the block gets the momentum
    /// of a collision with an infinitely heavy one: (m + m_hand)/m times too much. A block
    /// some 25 times the hand's mass keeps that within a few percent.)
    pub const THESIS: Setup = Setup {
        rate: 20.0,
        haptic_rate: 1000.0,
        start: -0.01,
        reach: 0.05,
        speed: 0.8,
        seconds: 2.0,
    };

    /// Where the hand wants the finger at `t`, and how fast that moves: still for 0.2 s,
    /// to `reach` at `speed`, back to the start at the same speed, then still.
    fn target(&self, t: f64) -> (f64, f64) {
        let (rest, out) = (0.2, (self.reach - self.start) / self.speed);
        if t < rest {
            (self.start, 0.0)
        } else if t < rest + out {
            (self.start + self.speed * (t - rest), self.speed)
        } else if t < rest + 2.0 * out {
            (self.reach - self.speed * (t - rest - out), -self.speed)
        } else {
            (self.start, 0.0)
        }
    }
}

/// The finger along one axis: a mass the arm drives toward a scripted target by the
/// simulated hand's spring and damper ([`SimParameters`]), the force displayed pushing back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Finger {
    /// Where it is, m.
    pub position: f64,
    /// How fast it moves, m/s.
    pub velocity: f64,
}

impl Finger {
    /// A finger at rest at `position`.
    pub fn at(position: f64) -> Self {
        Self {
            position,
            velocity: 0.0,
        }
    }

    /// One tick of `dt` toward `target` moving at `speed`, `felt` (N along the axis) pushing
    /// back on it.
    pub fn follow(&mut self, (target, speed): (f64, f64), felt: f64, dt: f64) {
        let hand = SimParameters::default();
        let (k, c) = hand.arm;
        let force = k * (target - self.position) + c * (speed - self.velocity) + felt;
        self.velocity += force / hand.hand_mass * dt;
        self.position += self.velocity * dt;
    }
}

/// The block's way along x during a run.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The sampling phase, seconds.
    pub phase: f64,
    /// (time, how far the block has moved along x) at every haptic tick.
    pub block: Vec<(f64, f64)>,
    /// Largest force displayed, newtons.
    pub peak_force: f64,
    /// Fastest the finger moved, m/s.
    pub peak_finger_speed: f64,
    /// Fastest the block moved where it is felt, m/s.
    pub peak_block_speed: f64,
}

impl Run {
    /// How far the block went, metres along x.
    pub fn stop(&self) -> f64 {
        self.block.last().map_or(0.0, |s| s.1)
    }

    /// The fastest the block moved over the fastest the finger moved.
    pub fn speed_ratio(&self) -> f64 {
        self.peak_block_speed / self.peak_finger_speed.max(1e-9)
    }
}

/// The experiment's world from `scene` (a scene file's text) with `feedback` at `setup`'s
/// physics rate.
pub fn world(
    scene: &str,
    setup: &Setup,
    feedback: Feedback,
) -> Result<RapierScene, ExperimentError> {
    match SceneFile::parse(scene, std::path::Path::new("push.yaml"), 1)? {
        SceneFile::Rapier(mut world) => {
            world.rate = setup.rate;
            world.feedback = feedback;
            Ok(*world)
        }
        SceneFile::Penalty(_) => Err(ExperimentError::NotRapier),
    }
}

/// Push once with the physics clock `phase` seconds behind the haptic one; `world` must
/// have a body called `block`.
pub fn run(world: &RapierScene, setup: &Setup, phase: f64) -> Result<Run, ExperimentError> {
    let block = world
        .names
        .iter()
        .position(|n| n == "block")
        .ok_or(ExperimentError::NoBlock)?;
    let (height, origin) = (
        world.bodies[block].position.y,
        world.bodies[block].position.x,
    );
    let mut finger = Finger::at(setup.start);
    let at = |x: f64, v: f64| Lockstep::pointers(&[(DVec3::new(x, height, 0.0), DVec3::X * v)]);
    let mut lockstep = Lockstep::new(world, &at(finger.position, 0.0), setup.haptic_rate, phase);
    let dt = 1.0 / setup.haptic_rate;
    let ticks = (setup.seconds * setup.haptic_rate).round() as usize;
    let mut felt = [Wrench::default()];
    let mut out = Run {
        phase,
        block: Vec::with_capacity(ticks),
        peak_force: 0.0,
        peak_finger_speed: 0.0,
        peak_block_speed: 0.0,
    };
    for _ in 0..ticks {
        let t = lockstep.time();
        lockstep.tick(&at(finger.position, finger.velocity), &mut felt)?;
        finger.follow(setup.target(t), felt[0].force.x, dt);
        out.peak_force = out.peak_force.max(felt[0].force.length());
        out.peak_finger_speed = out.peak_finger_speed.max(finger.velocity.abs());
        out.peak_block_speed = out
            .peak_block_speed
            .max(lockstep.body(block).velocity.length());
        out.block.push((
            lockstep.time(),
            lockstep.world.body(block).position.x - origin,
        ));
    }
    Ok(out)
}

/// `phases` runs with the physics clock behind by 0, 1/phases, 2/phases … of a period.
pub fn sweep(
    world: &RapierScene,
    setup: &Setup,
    phases: usize,
) -> Result<Vec<Run>, ExperimentError> {
    (0..phases)
        .map(|i| run(world, setup, i as f64 / phases as f64 / setup.rate))
        .collect()
}

/// How far the block went over a sweep.
pub fn stops(runs: &[Run]) -> Spread {
    Spread::of(runs.iter().map(Run::stop))
}

/// The block of `scene` struck once per sampling phase (`phases` of them) with impulse and
/// with position feedback, against the same push with the physics at the haptic rate: how far
/// it went, and a chart of its way per feedback (position first).
pub fn report(scene: &str, setup: &Setup, phases: usize) -> Result<Report, ExperimentError> {
    let sweep_with = |feedback: Feedback| -> Result<Vec<Run>, ExperimentError> {
        let world = world(scene, setup, feedback)?;
        sweep(&world, setup, phases)
    };
    let (impulse, position) = (
        sweep_with(Feedback::Impulse)?,
        sweep_with(Feedback::Position)?,
    );
    // The same push with the physics as fast as the haptics: what both methods approximate.
    let fast = Setup {
        rate: setup.haptic_rate,
        ..*setup
    };
    let reference = run(&world(scene, &fast, Feedback::Impulse)?, &fast, 0.0)?.stop();
    let mut text = format!(
        "block struck once, physics {} Hz, haptics {} Hz, {} phases; how far it went [mm]:\n",
        setup.rate, setup.haptic_rate, phases
    );
    let mut rows = Vec::new();
    for (name, runs) in [("impulse", &impulse), ("position", &position)] {
        let s = stops(runs);
        let (low, high) = runs
            .iter()
            .map(Run::stop)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                (l.min(x), h.max(x))
            });
        text += &format!(
            "{name:<9} {:7.2} ± {:6.3} (from {:.2} to {:.2}), peak force {:.2} N\n",
            s.mean * 1e3,
            s.deviation * 1e3,
            low * 1e3,
            high * 1e3,
            runs.iter().map(|r| r.peak_force).fold(0.0, f64::max)
        );
        rows.push(json!({
            "feedback": name,
            "mean": s.mean,
            "deviation": s.deviation,
            "stops": runs.iter().map(Run::stop).collect::<Vec<_>>(),
        }));
    }
    text += &format!(
        "physics at {} Hz: {:7.2}\n",
        setup.haptic_rate,
        reference * 1e3
    );
    let title = |method: &str| format!("{method}, physics {} Hz", setup.rate);
    Ok(Report {
        text,
        json: json!({ "reference": reference, "results": rows }),
        charts: vec![
            way_chart(title("position feedback"), &position),
            way_chart(title("impulse feedback"), &impulse),
        ],
    })
}

/// The block's way over time in each of `runs`, one curve per sampling phase.
fn way_chart(title: String, runs: &[Run]) -> Chart {
    Chart {
        title,
        x_label: "time [s]".into(),
        y_label: "block moved [mm]".into(),
        series: runs
            .iter()
            .enumerate()
            .map(|(k, r)| Series {
                label: format!("phase {:.0} ms", r.phase * 1e3),
                points: r
                    .block
                    .iter()
                    .step_by(5)
                    .map(|&(t, x)| (t, x * 1e3))
                    .collect(),
                color: PALETTE[k % PALETTE.len()],
            })
            .collect(),
        ..Chart::default()
    }
}

//! A door pushed open at its handle by the simulated hand, with the physics at 10, 30 and
//! 60 Hz against the same push with the physics at the haptic rate (thesis 6.5.4 for a
//! jointed body, 7.2): local dynamics moves the door through its hinge (its mobility), so
//! the hand meets the door's moment about the hinge, an effective mass I/r² at the handle,
//! and not the slab's mass.
//!
//! The door is a slab hinged along its left edge (the y axis through the origin), at rest,
//! gravity acting along its vertical hinge and without friction. The finger starts in
//! front of its face at the handle, is driven toward the door at `speed` by the hand's
//! spring and damper (the simulated hand's, as in `push-mass`), reaches `reach` past the
//! face and withdraws; the door swings on.

use glam::{DQuat, DVec3};
use hapticd_core::kinematics::Wrench;
use hapticd_device::sim::SimParameters;
use hapticd_physics::coupling::Grip;
use hapticd_physics::scene::{Feedback, PenaltyScene, RapierScene, SceneFile};
use serde_json::json;

use super::ExperimentError;
use super::push_phase::Finger;
use crate::multirate::{Lockstep, NotFinite};
use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// The physics rates tried, hertz.
pub const RATES: [f64; 3] = [10.0, 30.0, 60.0];

/// The door and the push.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Door {
    /// Width (from the hinge), height and thickness, metres.
    pub size: [f64; 3],
    /// kg/m³.
    pub density: f64,
    /// The handle's distance from the hinge, metres.
    pub handle: f64,
    /// The finger's speed toward the door, m/s.
    pub speed: f64,
    /// How far past the door's face the hand reaches before it withdraws, metres.
    pub reach: f64,
    /// Seconds simulated.
    pub seconds: f64,
    /// The hinge's limits, rad (none: it swings freely).
    pub limits: Option<[f64; 2]>,
}

impl Default for Door {
    /// A 40 × 60 cm, 2 cm board of 500 kg/m³ (2.4 kg), pushed 35 cm from its hinge at
    /// 0.2 m/s, 3 cm on.
    fn default() -> Self {
        Door {
            size: [0.4, 0.6, 0.02],
            density: 500.0,
            handle: 0.35,
            speed: 0.2,
            reach: 0.03,
            seconds: 1.2,
            limits: None,
        }
    }
}

impl Door {
    /// The door's mass, kg.
    pub fn mass(&self) -> f64 {
        self.density * self.size.iter().product::<f64>()
    }

    /// Its moment of inertia about the hinge, kg·m².
    pub fn moment(&self) -> f64 {
        let [w, _, t] = self.size;
        self.mass() * ((w * w + t * t) / 12.0 + w * w / 4.0)
    }

    /// The scene of the door for one pointer, stepped as `stepping` says (its engine, rate
    /// and material keys).
    pub fn file(&self, stepping: &str) -> Result<SceneFile, ExperimentError> {
        let [w, h, t] = self.size;
        let limits = self.limits.map_or(String::new(), |[low, high]| {
            format!(", limits: [{low}, {high}]")
        });
        let text = format!(
            "name: door\n{stepping}\ngravity: [0, -9.81, 0]\nbodies:\n  - {{ name: door, \
             box: [{w}, {h}, {t}], density: {}, position: [{}, 0, 0] }}\njoints:\n  - {{ kind: \
             revolute, bodies: [world, door], anchor: [0, 0, 0], axis: [0, -1, 0]{limits} }}\n",
            self.density,
            w / 2.0
        );
        Ok(SceneFile::parse(
            &text,
            std::path::Path::new("door.yaml"),
            1,
        )?)
    }

    /// The rapier scene at `rate` Hz with `feedback`.
    pub fn scene(&self, rate: f64, feedback: Feedback) -> Result<RapierScene, ExperimentError> {
        let stepping = format!(
            "engine: rapier\nrate: {rate}\nfeedback: {}\nmaterial: {{ static_friction: 0, \
             friction: 0 }}",
            feedback.name()
        );
        match self.file(&stepping)? {
            SceneFile::Rapier(world) => Ok(*world),
            SceneFile::Penalty(_) => Err(ExperimentError::NotRapier),
        }
    }

    /// Where the hand wants the finger along z at `t`, and how fast that moves: still for
    /// 0.1 s, to `reach` past the face at `speed`, then back at the same speed.
    fn target(&self, t: f64) -> (f64, f64) {
        let (start, end) = (self.start(), self.size[2] / 2.0 + self.reach);
        let (rest, out) = (0.1, (end - start) / self.speed);
        if t < rest {
            (start, 0.0)
        } else if t < rest + out {
            (start + self.speed * (t - rest), self.speed)
        } else {
            (
                (end - self.speed * (t - rest - out)).max(start),
                -self.speed,
            )
        }
    }

    /// Where the finger starts along z: 5 mm before the door's face.
    fn start(&self) -> f64 {
        -self.size[2] / 2.0 - 0.005
    }
}

/// How far the door is opened (about −y) where the hand feels it, rad.
fn opened(lockstep: &Lockstep) -> f64 {
    -lockstep.body(0).orientation.to_scaled_axis().y
}

/// One push.
#[derive(Debug, Clone, PartialEq)]
pub struct Swing {
    /// Physics steps per second.
    pub rate: f64,
    /// (time, the door's angle as the hand feels it) at every haptic tick, s and rad.
    pub angles: Vec<(f64, f64)>,
    /// The door's rate in the world at the end, rad/s.
    pub rate_after: f64,
    /// When the hand last pushed, s.
    pub release: f64,
    /// The angular impulse the hand gave the door about its hinge, N·m·s.
    pub impulse: f64,
    /// The largest force the hand felt, N.
    pub peak_force: f64,
}

impl Swing {
    /// The door's moment about its hinge as the hand met it: the angular impulse the hand
    /// gave over the rate it gave, kg·m².
    pub fn felt_moment(&self) -> f64 {
        self.impulse / self.rate_after
    }

    /// The door's angle as the hand felt it at `t`, rad.
    pub fn angle_at(&self, t: f64) -> f64 {
        let i = self.angles.partition_point(|a| a.0 < t);
        self.angles
            .get(i)
            .or(self.angles.last())
            .map_or(0.0, |a| a.1)
    }
}

/// The push on `door` with the physics at `rate` Hz and `feedback`.
pub fn swing(door: &Door, rate: f64, feedback: Feedback) -> Result<Swing, ExperimentError> {
    let scene = door.scene(rate, feedback)?;
    let height = 0.1;
    let mut finger = Finger::at(door.start());
    let at =
        |z: f64, v: f64| Lockstep::pointers(&[(DVec3::new(door.handle, height, z), DVec3::Z * v)]);
    let haptic_rate = 1000.0;
    let dt = 1.0 / haptic_rate;
    let mut lockstep = Lockstep::new(&scene, &at(finger.position, 0.0), haptic_rate, 0.0);
    let mut felt = [Wrench::default()];
    let ticks = (door.seconds * haptic_rate).round() as usize;
    let mut out = Swing {
        rate,
        angles: Vec::with_capacity(ticks),
        rate_after: 0.0,
        release: 0.0,
        impulse: 0.0,
        peak_force: 0.0,
    };
    for _ in 0..ticks {
        let t = lockstep.time();
        lockstep.tick(&at(finger.position, finger.velocity), &mut felt)?;
        // The door is pushed by the opposite of what the hand feels, at the proxy; it opens
        // about −y.
        let lever = lockstep.proxies()[0];
        out.impulse += lever.cross(felt[0].force).y * dt;
        out.peak_force = out.peak_force.max(felt[0].force.length());
        if felt[0].force != DVec3::ZERO {
            out.release = lockstep.time();
        }
        finger.follow(door.target(t), felt[0].force.z, dt);
        out.angles.push((lockstep.time(), opened(&lockstep)));
    }
    out.rate_after = lockstep.world.joint_state(0).velocity;
    Ok(out)
}

/// The push at every rate of [`RATES`] and at the reference (1 kHz physics, impulses): a
/// table of the door's swing and the moment the hand met, and a chart of the door's angle
/// against time per rate.
pub fn report(door: &Door) -> Result<Report, ExperimentError> {
    let reference = swing(door, 1000.0, Feedback::Impulse)?;
    let exact = door.moment();
    let mut text = format!(
        "a {:.2} kg door pushed {:.2} m from its hinge at {} m/s; moment about the hinge \
         {exact:.5} kg·m² (effective mass at the handle {:.3} kg)\n  physics [Hz]  angle at \
         release [rad]  of reference  rate after [rad/s]  of reference  felt moment [kg·m²]  \
         peak force [N]\n",
        door.mass(),
        door.handle,
        door.speed,
        exact / (door.handle * door.handle),
    );
    let mut rows = Vec::new();
    let mut series = Vec::new();
    for (k, run) in std::iter::once(Ok(reference.clone()))
        .chain(RATES.iter().map(|&r| swing(door, r, Feedback::Local)))
        .enumerate()
    {
        let run = run?;
        let (angle, against) = (
            run.angle_at(reference.release),
            reference.angle_at(reference.release),
        );
        text += &format!(
            "  {:12} {:20.4} {:12.3} {:18.4} {:12.3} {:20.5} {:15.2}\n",
            run.rate,
            angle,
            angle / against,
            run.rate_after,
            run.rate_after / reference.rate_after,
            run.felt_moment(),
            run.peak_force
        );
        rows.push(json!({
            "rate": run.rate,
            "release": reference.release,
            "angle_at_release": angle,
            "reference_angle_at_release": against,
            "rate_after": run.rate_after,
            "reference_rate_after": reference.rate_after,
            "felt_moment": run.felt_moment(),
            "moment": exact,
            "peak_force": run.peak_force,
        }));
        series.push(Series {
            label: if k == 0 {
                "physics at 1 kHz (impulses)".into()
            } else {
                format!("physics at {} Hz (local dynamics)", run.rate)
            },
            points: run
                .angles
                .iter()
                .map(|&(t, a)| (t, a.to_degrees()))
                .collect(),
            color: PALETTE[k % PALETTE.len()],
        });
    }
    Ok(Report {
        text,
        json: json!({ "moment": exact, "results": rows }),
        charts: vec![Chart {
            title: "a door pushed at its handle, by physics rate".into(),
            x_label: "time [s]".into(),
            y_label: "door angle [degrees]".into(),
            series,
            ..Chart::default()
        }],
    })
}

/// A door pushed shut against its stop by a steady hand.
#[derive(Debug, Clone, PartialEq)]
pub struct Press {
    /// Farthest the door went past its stop, rad: in the world, and as the hand felt it.
    pub past: (f64, f64),
    /// The force the hand felt along the push at every tick, N.
    pub forces: Vec<f64>,
}

impl Press {
    /// Ticks from `from` on at which the felt force turned back by more than `step` N twice
    /// running (up, then down, or down, then up): a force that alternates.
    pub fn alternations(&self, from: usize, step: f64) -> usize {
        self.forces[from.min(self.forces.len())..]
            .windows(3)
            .filter(|w| {
                let (a, b) = (w[1] - w[0], w[2] - w[1]);
                a * b < 0.0 && a.abs() > step && b.abs() > step
            })
            .count()
    }
}

/// The penalty engine's stepping of the door: 4 kHz, stiff frictionless contacts.
pub const PENALTY: &str = "engine: penalty\ndt: 0.00025\nmaterial: { stiffness: 2.0e7, damping: \
                           1.0e4, static_friction: 0, friction: 0, friction_stiffness: 2.0e7, \
                           friction_damping: 1.0e4, slip_speed: 0.02 }";

/// `door` (which must have limits, its stop at 0) pushed shut at its handle for `seconds`
/// by a hand that pushes with `force` N (its arm's own damper slowing it), stepped as
/// `stepping` says: rapier at its rate under local dynamics, or the penalty engine at the
/// device rate.
pub fn pressed(
    door: &Door,
    stepping: &str,
    force: f64,
    seconds: f64,
) -> Result<Press, ExperimentError> {
    let (_, damper) = SimParameters::default().arm;
    let mass = SimParameters::default().hand_mass;
    let dt = 1e-3;
    let mut finger = (door.start(), 0.0);
    let at = |z: f64| DVec3::new(door.handle, 0.1, z);
    let mut out = Press {
        past: (0.0, 0.0),
        forces: Vec::new(),
    };
    let mut felt = [Wrench::default()];
    let mut world = Stepped::new(door.file(stepping)?, at(finger.0));
    for tick in 0..(seconds / dt).round() as usize {
        world.tick(tick as f64 * dt, (at(finger.0), finger.1), &mut felt)?;
        let push = force - damper * finger.1 + felt[0].force.z;
        finger.1 += push / mass * dt;
        finger.0 += finger.1 * dt;
        out.forces.push(-felt[0].force.z);
        let (there, felt_at) = world.hinge();
        out.past = (out.past.0.max(there), out.past.1.max(felt_at));
    }
    Ok(out)
}

/// The door's world stepped at the device rate with one finger.
enum Stepped {
    /// Rapier with its haptic side.
    Rapier(Box<Lockstep>),
    /// The penalty engine.
    Penalty(Box<PenaltyScene>),
}

impl Stepped {
    /// The world of `file` with its finger at `finger`.
    fn new(file: SceneFile, finger: DVec3) -> Self {
        match file {
            SceneFile::Rapier(spec) => Stepped::Rapier(Box::new(Lockstep::new(
                &spec,
                &Lockstep::pointers(&[(finger, DVec3::ZERO)]),
                1000.0,
                0.0,
            ))),
            SceneFile::Penalty(scene) => Stepped::Penalty(scene),
        }
    }

    /// One millisecond from `t` with the finger at `finger`, moving along z at `speed`;
    /// `felt` gets what the hand feels.
    fn tick(
        &mut self,
        t: f64,
        (finger, speed): (DVec3, f64),
        felt: &mut [Wrench],
    ) -> Result<(), ExperimentError> {
        match self {
            Stepped::Rapier(lockstep) => {
                lockstep.tick(&Lockstep::pointers(&[(finger, DVec3::Z * speed)]), felt)?;
            }
            Stepped::Penalty(scene) => {
                let grip = Grip {
                    position: finger,
                    orientation: DQuat::IDENTITY,
                    velocity: DVec3::Z * speed,
                    spin: DVec3::ZERO,
                };
                if !scene.step_pointers(1e-3, &[grip], felt) {
                    return Err(NotFinite { time: t }.into());
                }
            }
        }
        Ok(())
    }

    /// How far the hinge is opened: in the world, and where the hand feels the door.
    fn hinge(&self) -> (f64, f64) {
        match self {
            Stepped::Rapier(lockstep) => (lockstep.world.joint_state(0).position, opened(lockstep)),
            Stepped::Penalty(scene) => {
                let q = scene.world.joint_state(0).position;
                (q, q)
            }
        }
    }
}

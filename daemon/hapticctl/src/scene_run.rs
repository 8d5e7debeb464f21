//! A physics scene run offline (`hapticctl scene run`): stepped as hapticd steps it, its
//! pointers moved by scripted hands, and traced: a quantity of each moving body (or pointer)
//! over time, the forces felt, and the moving bodies' energy. Each step is offered to a
//! caller's closure (to record it or draw it); what the trace means is the caller's to print.

use glam::{DMat3, DVec3};
use hapticd_core::kinematics::Wrench;
use hapticd_core::scene::Pointer;
use hapticd_device::sim::hand::HandTrack;
use hapticd_physics::body::Body;
use hapticd_physics::coupling::Grip;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::scene::{PenaltyScene, RapierScene};
use hapticd_physics::world::ContactModel;

use crate::multirate::Lockstep;

/// What a trace follows over time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Quantity {
    /// Height of the centroid against gravity, m.
    Height,
    /// Angular momentum about the world z axis, kg·m²/s (thesis Fig. 5.12).
    AngularMomentumZ,
    /// Rate of turn |ω|, rad/s (the spinning top of thesis Fig. 5.16).
    Spin,
    /// Force felt at each pointer, N (with scripted hands).
    PointerForce,
}

/// Why a run stopped before its end.
#[derive(Debug)]
pub enum RunError<E> {
    /// The world stopped being finite at time `t` (bodies too fast, too light or too stiffly
    /// sprung for the step).
    NotFinite {
        /// Simulated time, s.
        t: f64,
    },
    /// The quantity cannot be traced on this engine.
    Unsupported(Quantity),
    /// The caller's closure failed on a step.
    Step(E),
}

impl<E: std::fmt::Display> std::fmt::Display for RunError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RunError::NotFinite { t } => write!(
                f,
                "at t = {t:.4} s the world is no longer finite (bodies too fast, too light or \
                 too stiffly sprung for its step)"
            ),
            RunError::Unsupported(quantity) => {
                write!(f, "{quantity:?} is traced on penalty scenes only")
            }
            RunError::Step(e) => write!(f, "{e}"),
        }
    }
}

impl<E: std::fmt::Debug + std::fmt::Display> std::error::Error for RunError<E> {}

/// Kinetic and gravitational energy of a world's moving bodies over a run, joules (contact
/// springs and the pointers' couplings hold the rest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Energy {
    /// At the start.
    pub start: f64,
    /// At the end.
    pub end: f64,
    /// The highest it reached.
    pub peak: f64,
}

/// Angular momentum of `body` about its centroid, world frame.
pub fn angular_momentum(body: &Body) -> DVec3 {
    let rotation = DMat3::from_quat(body.orientation);
    rotation * body.inertia * rotation.transpose() * body.spin
}

/// ½mv² + ½ωᵀIω − m·g·x summed over the bodies of `scene` listed in `moving`.
pub fn mechanical_energy(scene: &PenaltyScene, moving: &[usize]) -> f64 {
    let g = scene.world.gravity;
    moving
        .iter()
        .map(|&i| {
            let b = &scene.world.bodies[i];
            0.5 * b.mass * b.velocity.length_squared() + 0.5 * b.spin.dot(angular_momentum(b))
                - b.mass * g.dot(b.position)
        })
        .sum()
}

/// The penalty pointers' grips at `t`.
fn grips(hands: &[HandTrack], t: f64) -> Vec<Grip> {
    hands
        .iter()
        .map(|h| {
            let c = h.at(t);
            Grip {
                position: c.target,
                orientation: c.turn,
                velocity: c.velocity,
                spin: c.spin,
            }
        })
        .collect()
}

/// The pointers at `t` as the haptic loop hands them to a scene.
pub fn hand_pointers(hands: &[HandTrack], t: f64) -> Vec<Pointer> {
    let at: Vec<(DVec3, DVec3)> = hands
        .iter()
        .map(|h| {
            let c = h.at(t);
            (c.target, c.velocity)
        })
        .collect();
    Lockstep::pointers(&at)
}

/// One run of a penalty scene, traced.
pub struct PenaltyTrace {
    /// The scene as the run left it.
    pub scene: PenaltyScene,
    /// The contact model's name.
    pub model: &'static str,
    /// The bodies that move.
    pub moving: Vec<usize>,
    /// The bodies whose curves `curves` holds, in order.
    pub plotted: Vec<usize>,
    /// (time, quantity) of each plotted body.
    pub curves: Vec<Vec<(f64, f64)>>,
    /// The last wrench felt at each pointer.
    pub felt: Vec<Wrench>,
    /// Largest force felt at each pointer, N.
    pub peaks: Vec<f64>,
    /// Mechanical energy of the moving bodies.
    pub energy: Energy,
    /// Farthest a moving body went in one step, m.
    pub longest_stride: f64,
}

impl PenaltyTrace {
    /// The thinnest solid of the world, m: a body moving further than half of it in a step
    /// can pass through it without touching.
    pub fn thinnest_solid(&self) -> f64 {
        self.scene
            .world
            .bodies
            .iter()
            .flat_map(|b| &b.pieces)
            .map(Polyhedron::thickness)
            .fold(f64::INFINITY, f64::min)
    }

    /// Energy the moving bodies gained over their start at most, J: with nothing driving
    /// the world, what the integration made.
    pub fn gained(&self) -> f64 {
        self.energy.peak - self.energy.start
    }
}

/// One step of a penalty run, offered to the caller.
pub struct PenaltyStep<'a> {
    /// Simulated time after the step, s.
    pub t: f64,
    /// The scene after the step.
    pub scene: &'a PenaltyScene,
    /// The contact model's name.
    pub model: &'static str,
    /// The bodies that move.
    pub moving: &'a [usize],
}

/// Step `scene` `steps` times by `dt`, its pointers moved by `hands`, tracing `quantity`;
/// `on_step` sees every step.
pub fn trace_penalty<E>(
    mut scene: PenaltyScene,
    quantity: Quantity,
    hands: &[HandTrack],
    (dt, steps): (f64, usize),
    mut on_step: impl FnMut(&PenaltyStep) -> Result<(), E>,
) -> Result<PenaltyTrace, RunError<E>> {
    let up = -scene.world.gravity.normalize_or(DVec3::NEG_Y);
    let moving: Vec<usize> = (0..scene.world.bodies.len())
        .filter(|&i| !scene.world.bodies[i].fixed)
        .collect();
    let plotted: Vec<usize> = match quantity {
        Quantity::PointerForce => (scene.first_pointer..scene.world.bodies.len()).collect(),
        _ => moving.clone(),
    };
    let mut curves = vec![Vec::new(); plotted.len()];
    let mut felt = vec![Wrench::default(); hands.len()];
    let mut peaks = vec![0.0f64; hands.len()];
    let model = match scene.world.material.model {
        ContactModel::Volume => "volume",
        ContactModel::Point => "point",
    };
    scene.dt = dt;
    let start = mechanical_energy(&scene, &moving);
    let mut longest_stride: f64 = 0.0;
    let mut energy = Energy {
        start,
        end: start,
        peak: start,
    };
    for step in 1..=steps {
        let t = step as f64 * dt;
        if !scene.step_pointers(dt, &grips(hands, t - dt), &mut felt) {
            return Err(RunError::NotFinite { t });
        }
        energy.end = mechanical_energy(&scene, &moving);
        energy.peak = energy.peak.max(energy.end);
        for &i in &moving {
            longest_stride = longest_stride.max(scene.world.bodies[i].velocity.length() * dt);
        }
        for (peak, w) in peaks.iter_mut().zip(&felt) {
            *peak = peak.max(w.force.length());
        }
        for (curve, &i) in curves.iter_mut().zip(&plotted) {
            let b = &scene.world.bodies[i];
            let value = match quantity {
                Quantity::Height => b.position.dot(up),
                Quantity::AngularMomentumZ => angular_momentum(b).z,
                Quantity::Spin => b.spin.length(),
                Quantity::PointerForce => felt[i - scene.first_pointer].force.length(),
            };
            curve.push((t, value));
        }
        let step = PenaltyStep {
            t,
            scene: &scene,
            model,
            moving: &moving,
        };
        on_step(&step).map_err(RunError::Step)?;
    }
    Ok(PenaltyTrace {
        scene,
        model,
        moving,
        plotted,
        curves,
        felt,
        peaks,
        energy,
        longest_stride,
    })
}

/// One run of a rapier scene with its haptic side, traced at the haptic rate.
pub struct MultirateTrace {
    /// The bodies that move.
    pub moving: Vec<usize>,
    /// (time, quantity) of each moving body, or of each pointer for
    /// [`Quantity::PointerForce`].
    pub curves: Vec<Vec<(f64, f64)>>,
    /// The last wrench felt at each pointer.
    pub felt: Vec<Wrench>,
    /// Largest force felt at each pointer, N.
    pub peaks: Vec<f64>,
}

/// One haptic tick of a rapier run, offered to the caller.
pub struct MultirateTick<'a> {
    /// Haptic time after the tick, s.
    pub t: f64,
    /// The run, its bodies where graphics show them between physics steps (6.5.2).
    pub run: &'a Lockstep,
    /// The pointers the tick was given.
    pub pointers: &'a [Pointer],
}

/// Tick `run` (of `spec`) `ticks` times at `haptic_rate`, its pointers moved by `hands`,
/// tracing `quantity`; `on_tick` sees every tick.
pub fn trace_multirate<E>(
    spec: &RapierScene,
    run: &mut Lockstep,
    (quantity, hands): (Quantity, &[HandTrack]),
    (haptic_rate, ticks): (f64, usize),
    mut on_tick: impl FnMut(&MultirateTick) -> Result<(), E>,
) -> Result<MultirateTrace, RunError<E>> {
    let moving: Vec<usize> = (0..spec.bodies.len())
        .filter(|&i| !spec.bodies[i].fixed)
        .collect();
    let up = -spec.gravity.normalize_or(DVec3::NEG_Y);
    let plotted = match quantity {
        Quantity::PointerForce => hands.len(),
        _ => moving.len(),
    };
    let mut curves = vec![Vec::new(); plotted];
    let mut felt = vec![Wrench::default(); hands.len()];
    let mut peaks = vec![0.0f64; hands.len()];
    for tick in 0..ticks {
        let pointers = hand_pointers(hands, tick as f64 / haptic_rate);
        run.tick(&pointers, &mut felt)
            .map_err(|e| RunError::NotFinite { t: e.time })?;
        for (peak, w) in peaks.iter_mut().zip(&felt) {
            *peak = peak.max(w.force.length());
        }
        let t = run.time();
        for (k, curve) in curves.iter_mut().enumerate() {
            let value = match quantity {
                Quantity::PointerForce => felt[k].force.length(),
                Quantity::Height => run.body(moving[k]).position.dot(up),
                Quantity::Spin => run.body(moving[k]).spin.length(),
                Quantity::AngularMomentumZ => return Err(RunError::Unsupported(quantity)),
            };
            curve.push((t, value));
        }
        let tick = MultirateTick {
            t,
            run,
            pointers: &pointers,
        };
        on_tick(&tick).map_err(RunError::Step)?;
    }
    Ok(MultirateTrace {
        moving,
        curves,
        felt,
        peaks,
    })
}

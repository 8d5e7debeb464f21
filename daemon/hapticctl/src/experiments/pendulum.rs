//! A physical pendulum (a box hung from the middle of its top edge on a hinge) released from
//! a range of amplitudes: its period against the exact one of a large swing,
//! T = 4·√(I/(m·g·d))·K(sin(θ₀/2)), with I its moment about the hinge, d the hinge's
//! distance from its centre and K the complete elliptic integral of the first kind, in
//! either engine.

use glam::{DMat3, DQuat, DVec3};
use hapticd_physics::joint::JointState;
use hapticd_physics::scene::{PenaltyScene, SceneFile};
use hapticd_rapier::world::RapierWorld;
use serde_json::{Value, json};

use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// The box, m (x, y, z edges; hung from its top edge, swinging about z).
pub const SIZE: [f64; 3] = [0.02, 0.1, 0.02];
/// Its density, kg/m³.
pub const DENSITY: f64 = 1000.0;
/// Gravity, m/s².
const G: f64 = 9.81;

/// The complete elliptic integral of the first kind K(k) (modulus k < 1), by the
/// arithmetic-geometric mean.
pub fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0, ((1.0 - k) * (1.0 + k)).sqrt());
    while (a - b).abs() > 1e-15 * a {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    std::f64::consts::PI / (2.0 * a)
}

/// The exact period, s, of a box `size` of `density` hung from its top edge, swinging from
/// `start` rad.
pub fn exact_period(size: [f64; 3], density: f64, start: f64) -> f64 {
    let m = density * size[0] * size[1] * size[2];
    let d = size[1] / 2.0;
    // About the hinge: the box's own moment about z, moved out by d.
    let moment = m * (size[0] * size[0] + size[1] * size[1]) / 12.0 + m * d * d;
    4.0 * (moment / (m * G * d)).sqrt() * elliptic_k((start / 2.0).sin())
}

/// The scene file of the box hung from the origin, turned `start` rad about z from hanging
/// straight down, stepped at `rate` Hz by `engine` (`rapier` or `penalty`).
pub fn scene(engine: &str, size: [f64; 3], density: f64, start: f64, rate: f64) -> SceneFile {
    let half = size[1] / 2.0;
    let centre = DVec3::new(half * start.sin(), -half * start.cos(), 0.0);
    let turn = DQuat::from_rotation_z(start);
    let stepping = match engine {
        "penalty" => format!(
            "engine: penalty\ndt: {}\nmaterial: {{ stiffness: 2.0e7, damping: 1.0e4, \
             static_friction: 0, friction: 0, friction_stiffness: 2.0e7, friction_damping: \
             1.0e4, slip_speed: 0.02 }}",
            1.0 / rate
        ),
        _ => {
            format!("engine: rapier\nrate: {rate}\nmaterial: {{ static_friction: 0, friction: 0 }}")
        }
    };
    let text = format!(
        "name: pendulum\n{stepping}\ngravity: [0, -{G}, 0]\nbodies:\n  - {{ name: bob, box: \
         {size:?}, density: {density}, position: [{}, {}, 0], orientation: [{}, {}, {}, {}] \
         }}\njoints:\n  - {{ kind: revolute, bodies: [world, bob], anchor: [0, 0, 0], axis: \
         [0, 0, 1] }}\n",
        centre.x, centre.y, turn.w, turn.x, turn.y, turn.z
    );
    SceneFile::parse(&text, std::path::Path::new("pendulum.yaml"), 0)
        .expect("a valid box and hinge")
}

/// The box as it swings: its mass, inertia (about its centre, in its frame at load) and
/// motion now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bob {
    /// kg.
    pub mass: f64,
    /// kg·m².
    pub inertia: DMat3,
    /// Its centre, m.
    pub position: DVec3,
    /// Its turn from where it was placed.
    pub orientation: DQuat,
    /// Its centre's velocity, m/s.
    pub velocity: DVec3,
    /// rad/s.
    pub spin: DVec3,
}

/// A pendulum stepped by either engine.
pub enum Pendulum {
    /// In rapier, with the box's mass and inertia (rapier keeps its own).
    Rapier(Box<RapierWorld>, (f64, DMat3)),
    /// In the penalty engine.
    Penalty(Box<PenaltyScene>),
}

impl Pendulum {
    /// The pendulum of `scene` (see [`scene`]).
    pub fn new(scene: SceneFile) -> Self {
        match scene {
            SceneFile::Rapier(spec) => {
                let bob = (spec.bodies[0].mass, spec.bodies[0].inertia);
                Pendulum::Rapier(Box::new(RapierWorld::new(&spec, 0)), bob)
            }
            SceneFile::Penalty(scene) => Pendulum::Penalty(scene),
        }
    }

    /// One step of `dt`; whether the world is still finite.
    pub fn step(&mut self, dt: f64) -> bool {
        match self {
            Pendulum::Rapier(world, _) => world.advance(dt),
            Pendulum::Penalty(scene) => {
                scene.world.step(dt);
                scene.world.bodies.iter().all(|b| b.velocity.is_finite())
            }
        }
    }

    /// Where its hinge stands.
    pub fn hinge(&self) -> JointState {
        match self {
            Pendulum::Rapier(world, _) => world.joint_state(0),
            Pendulum::Penalty(scene) => scene.world.joint_state(0),
        }
    }

    /// The box now.
    pub fn bob(&self) -> Bob {
        let ((mass, inertia), motion) = match self {
            Pendulum::Rapier(world, bob) => {
                let b = world.body(0);
                (*bob, (b.position, b.orientation, b.velocity, b.spin))
            }
            Pendulum::Penalty(scene) => {
                let b = &scene.world.bodies[0];
                (
                    (b.mass, b.inertia),
                    (b.position, b.orientation, b.velocity, b.spin),
                )
            }
        };
        let (position, orientation, velocity, spin) = motion;
        Bob {
            mass,
            inertia,
            position,
            orientation,
            velocity,
            spin,
        }
    }
}

/// The period, s, of the box `size` of `density` released from `start` rad and stepped by
/// `engine` at `rate` Hz: the mean time between the swing's turning points at the start side
/// (where the hinge's rate crosses zero from above, found between steps by linear
/// interpolation) over five swings.
pub fn measured_period(engine: &str, size: [f64; 3], density: f64, start: f64, rate: f64) -> f64 {
    let mut world = Pendulum::new(scene(engine, size, density, start, rate));
    let dt = 1.0 / rate;
    let steps = (6.0 * exact_period(size, density, start) * rate).ceil() as usize;
    let mut last = world.hinge().velocity;
    let mut turns = Vec::new();
    for k in 1..=steps {
        world.step(dt);
        let now = world.hinge().velocity;
        if last > 0.0 && now <= 0.0 {
            turns.push((k as f64 - 1.0 + last / (last - now)) * dt);
        }
        last = now;
    }
    match turns.as_slice() {
        [first, .., last] => (last - first) / (turns.len() - 1) as f64,
        _ => f64::NAN,
    }
}

/// The figure: the period over the small swing's (2π·√(I/(m·g·d))) against the amplitude,
/// stepped by each of `runs` (engine, rate in Hz), beside the exact curve; amplitudes in
/// degrees.
pub fn report(amplitudes: &[f64], runs: &[(&str, f64)]) -> Report {
    let small = exact_period(SIZE, DENSITY, 0.0);
    let exact: Vec<(f64, f64)> = (0..=170)
        .map(|deg| {
            let start = (deg as f64).to_radians();
            (deg as f64, exact_period(SIZE, DENSITY, start) / small)
        })
        .collect();
    let mut series = vec![Series {
        label: "exact: 4 sqrt(I/(m g d)) K(sin(a/2))".into(),
        points: exact,
        color: PALETTE[0],
    }];
    let (mut text, mut rows, mut errors) = (String::new(), Vec::<Value>::new(), Vec::new());
    for (k, &(engine, rate)) in runs.iter().enumerate() {
        let color = PALETTE[(k + 1) % PALETTE.len()];
        let runs: Vec<(f64, f64, f64)> = amplitudes
            .iter()
            .map(|&deg| {
                let start = deg.to_radians();
                let measured = measured_period(engine, SIZE, DENSITY, start, rate);
                (deg, measured, exact_period(SIZE, DENSITY, start))
            })
            .collect();
        for &(deg, measured, exact) in &runs {
            text += &format!(
                "  {engine} at {rate:>5} Hz from {deg:>5.1}°: {measured:.5} s, exact {exact:.5} s \
                 ({:+.3} %)\n",
                100.0 * (measured / exact - 1.0)
            );
            rows.push(
                json!({"rate": rate, "amplitude_deg": deg, "period": measured, "exact": exact}),
            );
        }
        series.push(Series {
            label: format!("{engine} at {rate} Hz"),
            points: runs.iter().map(|r| (r.0, r.1 / small)).collect(),
            color,
        });
        errors.push(Series {
            label: format!("{engine} at {rate} Hz"),
            points: runs
                .iter()
                .map(|r| (r.0, 100.0 * (r.1 / r.2 - 1.0)))
                .collect(),
            color,
        });
    }
    let charts = vec![
        Chart {
            title: "a hinged box's period against its amplitude".into(),
            x_label: "amplitude [deg]".into(),
            y_label: "period / small swing's".into(),
            series,
            ..Chart::default()
        },
        Chart {
            title: "the period's departure from the exact one".into(),
            x_label: "amplitude [deg]".into(),
            y_label: "period error [%]".into(),
            series: errors,
            y_range: Some((-0.5, 0.5)),
            ..Chart::default()
        },
    ];
    Report {
        text,
        json: json!({ "results": rows }),
        charts,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn k_is_known_where_it_has_a_closed_form() {
        assert_eq!(elliptic_k(0.0), std::f64::consts::FRAC_PI_2);
        // K(sin 45°) = Γ(¼)² / (4√π), Γ(¼) = 3.625609908221908.
        let gamma = 3.625_609_908_221_908_f64;
        let closed = gamma * gamma / (4.0 * std::f64::consts::PI.sqrt());
        assert!((elliptic_k(std::f64::consts::FRAC_PI_4.sin()) - closed).abs() < 1e-14);
    }
}

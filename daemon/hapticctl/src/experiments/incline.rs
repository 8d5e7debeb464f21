//! Static friction on a slope: a block resting on a floor while gravity tilts to some
//! fraction of the friction angle tan⁻¹ μ0, at once or gradually, on the penalty simulator
//! (thesis 5.3.6). Below the angle it must stay put; past it, slide at g(sin θ − μ cos θ).

use glam::{DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::friction::FrictionParameters;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::world::{ContactModel, Material, World};
use serde_json::{Value, json};

use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// Gravity, m/s².
const G: f64 = 9.81;
/// Physics step, seconds.
pub const DT: f64 = 1e-4;
/// Mass of every block, kg.
const MASS: f64 = 1.0;
/// Contact stiffness, N/m³.
const STIFFNESS: f64 = 1e6;
/// Static friction coefficient μ0.
pub const STATIC_FRICTION: f64 = 0.5;
/// Dynamic friction coefficient μ.
pub const FRICTION: f64 = 0.4;

/// A block on the slope.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Incline {
    /// The block's extents, metres.
    pub size: DVec3,
    /// Damping of the friction springs, in multiples of critical (the normal damping is
    /// critical).
    pub damping: f64,
    /// The slope as a fraction of the friction angle.
    pub fraction: f64,
    /// How long the slope takes to tilt to it, seconds (0: at once).
    pub ramp: f64,
}

/// The blocks the tests and the figure use: a cube, a plate and a tall block.
pub const SHAPES: [(&str, DVec3); 3] = [
    ("cube", DVec3::splat(0.2)),
    ("plate", DVec3::new(0.4, 0.1, 0.4)),
    ("tall block", DVec3::new(0.2, 0.3, 0.2)),
];

impl Incline {
    /// The slope, radians.
    pub fn angle(&self) -> f64 {
        self.fraction * STATIC_FRICTION.atan()
    }

    /// The acceleration of a block sliding down the slope, m/s².
    pub fn sliding(&self) -> f64 {
        let angle = self.angle();
        G * (angle.sin() - FRICTION * angle.cos())
    }

    /// The block resting on the floor at the depth that carries it, not yet tilted.
    pub fn world(&self) -> World {
        let size = self.size;
        let area = size.x * size.z;
        let floor = Polyhedron::cuboid(DVec3::new(4.0, 0.5, 4.0))
            .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
        let block = Polyhedron::cuboid(size / 2.0)
            .transformed(DQuat::IDENTITY, DVec3::new(0.0, size.y / 2.0, 0.0));
        let critical = 2.0 * (STIFFNESS * area * MASS).sqrt() / area;
        let mut world = World::new(
            vec![
                Body::new(&floor, 1000.0, true),
                Body::new(&block, MASS / (size.x * size.y * size.z), false),
            ],
            DVec3::new(0.0, -G, 0.0),
            Material {
                stiffness: STIFFNESS,
                damping: critical,
                friction: FrictionParameters {
                    static_coefficient: STATIC_FRICTION,
                    dynamic_coefficient: FRICTION,
                    stiffness: STIFFNESS,
                    damping: self.damping * critical,
                    slip_speed: 1e-3,
                },
                model: ContactModel::Volume,
                scaling: None,
            },
        );
        // Watch it move throughout: a sleeping block would hold by not being stepped.
        world.sleeping = false;
        for _ in 0..3000 {
            world.step(DT);
        }
        world
    }

    /// Tilt the slope and keep it for `seconds` after it has tilted; returns a [`Sample`] of
    /// the block's base at the start and every millisecond, and the world at the end.
    pub fn run(&self, seconds: f64) -> (Vec<Sample>, World) {
        let mut world = self.world();
        let start = base(&world, self.size.y);
        let ramp = (self.ramp / DT).round() as usize;
        let steps = ramp + (seconds / DT).round() as usize;
        let sample = |world: &World, step: usize| {
            let at = base(world, self.size.y);
            Sample {
                time: step as f64 * DT,
                moved: (at - start).x,
                speed: world.bodies[1].velocity_at(at).x,
            }
        };
        let mut samples = Vec::with_capacity(steps / 10 + 1);
        samples.push(sample(&world, 0));
        for step in 1..=steps {
            let tilt = (step as f64 / ramp.max(1) as f64).min(1.0);
            world.gravity = slope(self.angle() * tilt);
            world.step(DT);
            if step % 10 == 0 {
                samples.push(sample(&world, step));
            }
        }
        (samples, world)
    }
}

/// The block's base at one moment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time since the slope began to tilt, seconds.
    pub time: f64,
    /// How far the middle of the base has moved down the slope, metres.
    pub moved: f64,
    /// Its speed down the slope, m/s.
    pub speed: f64,
}

/// Gravity on a slope of `angle` (the floor stays flat; gravity tilts down +x).
fn slope(angle: f64) -> DVec3 {
    G * DVec3::new(angle.sin(), -angle.cos(), 0.0)
}

/// The middle of the block's base.
pub fn base(world: &World, height: f64) -> DVec3 {
    let b = &world.bodies[1];
    b.position + b.orientation * DVec3::new(0.0, -height / 2.0, 0.0)
}

/// The cube of [`SHAPES`] tilted at once to each of `fractions` of the friction angle and
/// kept there for `seconds`: its way down the slope in one chart, and where it ended.
pub fn report(fractions: &[f64], seconds: f64) -> Report {
    let (_, cube) = SHAPES[0];
    let runs: Vec<_> = fractions
        .iter()
        .map(|&fraction| {
            let block = Incline {
                size: cube,
                damping: 1.0,
                fraction,
                ramp: 0.0,
            };
            (fraction, block.run(seconds).0)
        })
        .collect();
    let chart = Chart {
        title: format!("a 0.2 m cube on a slope, μ0 = {STATIC_FRICTION}, μ = {FRICTION}"),
        x_label: "time after the tilt [s]".into(),
        y_label: "way down the slope [mm]".into(),
        series: runs
            .iter()
            .enumerate()
            .map(|(k, (fraction, samples))| Series {
                label: format!("{fraction} of the friction angle"),
                points: samples.iter().map(|s| (s.time, s.moved * 1e3)).collect(),
                color: PALETTE[k % PALETTE.len()],
            })
            .collect(),
        // Creep at the scale of the 1 mm the tests allow; a sliding block leaves the chart.
        y_range: Some((-0.5, 2.0)),
        ..Chart::default()
    };
    let mut text = String::new();
    let mut rows: Vec<Value> = Vec::new();
    for (fraction, samples) in &runs {
        let moved = samples.last().map_or(0.0, |s| s.moved);
        text += &format!(
            "  {fraction} of the friction angle: {:.4} mm\n",
            moved * 1e3
        );
        rows.push(json!({"fraction": fraction, "moved": moved}));
    }
    Report {
        text,
        json: json!({ "results": rows }),
        charts: vec![chart],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shape, friction damped critically and three times over, loaded at once and
    /// over half a second.
    fn cases(fraction: f64) -> impl Iterator<Item = (&'static str, Incline)> {
        SHAPES.into_iter().flat_map(move |(name, size)| {
            [(1.0, 0.0), (1.0, 0.5), (3.0, 0.0), (3.0, 0.5)].map(|(damping, ramp)| {
                let incline = Incline {
                    size,
                    damping,
                    fraction,
                    ramp,
                };
                (name, incline)
            })
        })
    }

    /// The sample `seconds` after the slope has tilted.
    fn after(samples: &[Sample], incline: &Incline, seconds: f64) -> Sample {
        samples[((incline.ramp + seconds) / 0.001).round() as usize]
    }

    #[test]
    fn below_the_friction_angle_a_block_stays_put() {
        let mut failures = Vec::new();
        for fraction in [0.9, 0.95, 0.99] {
            for (name, incline) in cases(fraction) {
                let (samples, world) = incline.run(3.0);
                let creep =
                    after(&samples, &incline, 3.0).moved - after(&samples, &incline, 0.0).moved;
                if creep.abs() >= 1e-3 || !world.is_finite() {
                    failures.push(format!("{name}: {incline:?} crept {creep} m in 3 s"));
                }
            }
        }
        assert!(failures.is_empty(), "{failures:#?}");
    }

    #[test]
    fn past_the_friction_angle_a_block_slides_at_the_kinetic_rate() {
        let mut failures = Vec::new();
        for (name, incline) in cases(1.01) {
            let (samples, _) = incline.run(1.5);
            // It breaks loose within a second (a tall block leans onto its edge first)...
            let tilted = after(&samples, &incline, 0.0).moved;
            let Some(loose) = samples.iter().position(|s| s.moved - tilted >= 5e-3) else {
                failures.push(format!("{name}: {incline:?} held"));
                continue;
            };
            if samples[loose].time > incline.ramp + 1.0 {
                failures.push(format!("{name}: {incline:?} broke loose late"));
                continue;
            }
            // ...and then slides at the kinetic rate.
            let acceleration = (samples[loose + 500].speed - samples[loose].speed) / 0.5;
            let expected = incline.sliding();
            if (acceleration - expected).abs() >= 0.03 * expected {
                failures.push(format!(
                    "{name}: {incline:?} slid at {acceleration} m/s², not {expected}"
                ));
            }
        }
        assert!(failures.is_empty(), "{failures:#?}");
    }
}

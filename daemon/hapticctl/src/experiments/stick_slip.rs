//! Stick-slip (thesis 5.4.4, Fig. 5.13/5.14): a weight on a floor pulled through a spring
//! whose end moves at constant speed, on the penalty simulator.

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
const DT: f64 = 1e-4;

/// The rig; [`Rig::THESIS`] holds the numbers of Fig. 5.13.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rig {
    /// Mass of the weight, kg.
    pub mass: f64,
    /// Stiffness of the pulling spring, N/m.
    pub spring: f64,
    /// Speed of the spring's end, m/s.
    pub speed: f64,
    /// Static friction coefficient μ0 (0: kinetic friction only).
    pub static_friction: f64,
    /// Dynamic friction coefficient μ.
    pub friction: f64,
}

impl Rig {
    /// 2.0 kg wrapped in paper, μ0 = 0.265, μ = 0.160, 400 N/m pulled at 0.0642 m/s.
    pub const THESIS: Rig = Rig {
        mass: 2.0,
        spring: 400.0,
        speed: 0.0642,
        static_friction: 0.265,
        friction: 0.160,
    };

    /// The largest spring force for a rigid stick broken at μ0·m·g and Coulomb slip at
    /// μ·m·g: while the weight catches up with the spring's end the extension swings about
    /// μ·m·g/k with amplitude √(Δ² + v²·m/k), Δ = (μ0 − μ)·m·g/k.
    pub fn peak_pull(&self) -> f64 {
        let weight = self.mass * G;
        let mu0 = self.static_friction.max(self.friction);
        let lead = (mu0 - self.friction) * weight / self.spring;
        let swing = (lead * lead + self.speed * self.speed * self.mass / self.spring).sqrt();
        self.friction * weight + self.spring * swing
    }

    /// Pull for `seconds`; returns (time, spring force, weight's displacement) every
    /// millisecond.
    pub fn run(&self, seconds: f64) -> Vec<(f64, f64, f64)> {
        let size = DVec3::new(0.1, 0.05, 0.1);
        let area = size.x * size.z;
        let stiffness = 1e6;
        let critical = 2.0 * (stiffness * area * self.mass).sqrt() / area;
        let floor = Polyhedron::cuboid(DVec3::new(2.0, 0.5, 2.0))
            .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
        let weight = Polyhedron::cuboid(size / 2.0)
            .transformed(DQuat::IDENTITY, DVec3::new(0.0, size.y / 2.0, 0.0));
        let density = self.mass / (size.x * size.y * size.z);
        let mut world = World::new(
            vec![
                Body::new(&floor, 1000.0, true),
                Body::new(&weight, density, false),
            ],
            DVec3::new(0.0, -G, 0.0),
            Material {
                stiffness,
                damping: critical,
                friction: FrictionParameters {
                    static_coefficient: self.static_friction,
                    dynamic_coefficient: self.friction,
                    stiffness,
                    damping: critical,
                    slip_speed: 1e-3,
                },
                model: ContactModel::Volume,
                scaling: None,
            },
        );
        // Settle on the floor before pulling.
        for _ in 0..2000 {
            world.step(DT);
        }
        let start = world.bodies[1].position.x;
        let mut samples = Vec::new();
        let steps = (seconds / DT).round() as usize;
        for step in 0..steps {
            let t = step as f64 * DT;
            let x = world.bodies[1].position.x - start;
            let pull = self.spring * (self.speed * t - x);
            world.loads[1].force = DVec3::new(pull, 0.0, 0.0);
            world.step(DT);
            if step % 10 == 0 {
                samples.push((t, pull, x));
            }
        }
        samples
    }
}

/// [`Rig::THESIS`] pulled for `seconds` with static and dynamic friction and with kinetic
/// friction alone: the spring force of both in one chart, and each peak against its
/// rigid-stick value.
pub fn report(seconds: f64) -> Report {
    let models = [
        ("static and dynamic friction", Rig::THESIS),
        (
            "kinetic friction only",
            Rig {
                static_friction: 0.0,
                ..Rig::THESIS
            },
        ),
    ];
    let runs: Vec<_> = models
        .iter()
        .map(|(label, rig)| {
            let samples = rig.run(seconds);
            let peak = samples.iter().fold(0.0_f64, |m, s| m.max(s.1));
            (*label, rig.peak_pull(), samples, peak)
        })
        .collect();
    let chart = Chart {
        title: "stick-slip: 2 kg pulled through 400 N/m at 64 mm/s".into(),
        x_label: "time [s]".into(),
        y_label: "spring force [N]".into(),
        series: runs
            .iter()
            .enumerate()
            .map(|(k, (label, _, samples, _))| Series {
                label: (*label).into(),
                points: samples.iter().map(|s| (s.0, s.1)).collect(),
                color: PALETTE[k],
            })
            .collect(),
        // Head room above the curves for the legend.
        y_range: Some((0.0, 1.5 * runs[0].1)),
        ..Chart::default()
    };
    let mut text = String::new();
    for (label, expected, _, peak) in &runs {
        text += &format!("  {label}: peak {peak:.2} N (rigid-stick value {expected:.2} N)\n");
    }
    let rows: Vec<Value> = runs
        .iter()
        .map(|(label, expected, _, peak)| {
            json!({"model": label, "peak": peak, "expected_peak": expected})
        })
        .collect();
    Report {
        text,
        json: json!({ "results": rows }),
        charts: vec![chart],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peak(samples: &[(f64, f64, f64)]) -> f64 {
        samples.iter().fold(0.0_f64, |m, s| m.max(s.1))
    }

    #[test]
    fn the_weight_sticks_and_slips_with_static_friction_but_not_with_kinetic_alone() {
        let rig = Rig::THESIS;
        let samples = rig.run(8.0);
        let expected = rig.peak_pull();
        // Not μ0·m·g = 5.20 N: the spring's end outruns the weight after it breaks loose.
        assert!((expected - 5.885).abs() < 1e-3, "{expected}");
        let simulated = peak(&samples);
        assert!(
            (simulated - expected).abs() < 0.03 * expected,
            "peak {simulated} N vs {expected} N"
        );
        // Every cycle builds up to that peak again and slips: the force falls through the
        // middle between μ0·m·g and μ·m·g.
        let middle = (rig.static_friction + rig.friction) / 2.0 * rig.mass * G;
        let slips = samples
            .windows(2)
            .filter(|w| w[0].1 >= middle && w[1].1 < middle)
            .count();
        assert!(slips >= 10, "{slips} slips in 8 s");
        assert!(
            peak(&samples[samples.len() - 1000..]) > 0.97 * expected,
            "cycles die out"
        );
        // Kinetic friction alone (no static springs hold) never builds up past the swing of
        // its own glide.
        let kinetic = Rig {
            static_friction: 0.0,
            ..rig
        };
        let expected = kinetic.peak_pull();
        let simulated = peak(&kinetic.run(8.0));
        assert!(
            (simulated - expected).abs() < 0.03 * expected,
            "kinetic peak {simulated} N vs {expected} N"
        );
    }
}

//! Thesis 3.5.10 on the simulator: a finger traces a round bar of radius 0.20 m (axis y) on a
//! 0.5 m SPIDAR, pressing on it with a 2 kN/m spring. The bar's section crosses the edge of
//! the complete-presentation region, so the tension method matters: with λ = 0 tensions jump
//! where the region ends and the finger is shaken off the surface; with λ = 0.2 they change
//! continuously and the finger follows the circle.

use std::path::Path;

use glam::DVec3;

use hapticd_core::haptic_loop::LoopSettings;
use hapticd_core::haptics::obstacle::Shape;
use hapticd_core::haptics::passivity::PassivityLimits;
use hapticd_core::haptics::proxy::ProxyParameters;
use hapticd_core::mechanism::{Mechanism, descriptor};
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_device::sim::hand::Script;
use serde_json::{Value, json};

use super::Session;
use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// Radius of the bar, metres.
pub const RADIUS: f64 = 0.2;
/// Half the frame edge, metres.
pub const HALF: f64 = 0.25;
/// Seconds per turn of the hand.
const PERIOD: f64 = 8.0;

/// The 0.5 m four-string SPIDAR of the experiment, its finger starting beside the bar.
pub fn mechanism(lambda: f64) -> Mechanism {
    let corners = [
        [-1.0, 1.0, 1.0],
        [1.0, 1.0, -1.0],
        [-1.0, -1.0, -1.0],
        [1.0, -1.0, 1.0],
    ];
    let mut text =
        String::from("name: spidar-0.5\nend_effectors:\n  - name: grip\n    dof: 3\nstrings:\n");
    for c in corners {
        text += &format!(
            "  - {{ effector: grip, motor: [{}, {}, {}], metres_per_pulse: 2.924e-5, volts_per_newton: 0.3653, tension_min: 0.5, tension_max: 20 }}\n",
            c[0] * HALF,
            c[1] * HALF,
            c[2] * HALF
        );
    }
    text += &format!(
        "calibration:\n  grip: {{ position: [{}, 0, 0] }}\ntension:\n  lambda: {lambda}\n",
        RADIUS + 0.02
    );
    descriptor::parse(&text, Path::new("spidar-0.5.yaml")).expect("a valid mechanism")
}

/// The traced path (x, z) with tension weight `lambda`, one point per tick over one turn.
pub fn trace(lambda: f64, rate: f64) -> Vec<(f64, f64)> {
    let script = Script::parse(
        &format!(
            "hands:\n  grip:\n    - move: {{ to: [{r}, 0, 0], seconds: 0.5 }}\n    - trace: {{ centre: [0, 0, 0], radius: {r}, normal: [0, 1, 0], period: {PERIOD}, seconds: {PERIOD} }}\n",
            r = RADIUS - 0.015
        ),
        std::path::Path::new("cylinder-tracing hand"),
    )
    .expect("a valid script");
    let session = Session {
        mechanism: mechanism(lambda),
        scene: StaticSceneSpec::bare(
            "bar",
            ProxyParameters {
                stiffness: 2000.0,
                damping: 0.0,
                static_friction: 0.0,
                dynamic_friction: 0.0,
            },
            vec![Shape::Cylinder {
                point: DVec3::ZERO,
                axis: DVec3::Y,
                radius: RADIUS,
            }],
        ),
        script,
        rate,
        settings: LoopSettings {
            passivity: PassivityLimits::OFF,
            ..LoopSettings::default()
        },
    };
    let mut path = Vec::new();
    session
        .run(0.5 + PERIOD, |frame| {
            if frame.time > 0.5 {
                let p = frame.poses[0].position;
                path.push((p.x, p.z));
            }
        })
        .expect("the tracing mechanism has four strings, which one board drives");
    path
}

/// How a traced path departs from a circle about the bar's axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deviation {
    /// Mean radius, metres (below [`RADIUS`] by how deep the hand presses).
    pub mean_radius: f64,
    /// Root-mean-square departure from the circle of that mean radius, metres: how far the
    /// traced shape is from round.
    pub roundness: f64,
    /// Root-mean-square departure from the path's own 0.1 s moving average, metres: the
    /// vibration felt while tracing.
    pub roughness: f64,
}

/// Measure a path traced at `rate` Hz.
pub fn deviation(path: &[(f64, f64)], rate: f64) -> Deviation {
    let radii: Vec<f64> = path.iter().map(|(x, z)| x.hypot(*z)).collect();
    let n = radii.len().max(1) as f64;
    let mean_radius = radii.iter().sum::<f64>() / n;
    let roundness = (radii.iter().map(|r| (r - mean_radius).powi(2)).sum::<f64>() / n).sqrt();
    let half = ((0.05 * rate) as usize).max(1);
    let windows: Vec<f64> = (half..radii.len().saturating_sub(half))
        .map(|i| {
            let average = radii[i - half..i + half].iter().sum::<f64>() / (2 * half) as f64;
            (radii[i] - average).powi(2)
        })
        .collect();
    let roughness = (windows.iter().sum::<f64>() / windows.len().max(1) as f64).sqrt();
    Deviation {
        mean_radius,
        roundness,
        roughness,
    }
}

/// Fig. 3.19: the bar traced at `rate` Hz with λ = 0 and λ = 0.2, charted over the bar's
/// surface and the complete region's edge, with how each path departs from a circle.
pub fn report(rate: f64) -> Report {
    let lambdas = [0.0, 0.2];
    let paths: Vec<Vec<(f64, f64)>> = lambdas.iter().map(|&l| trace(l, rate)).collect();
    let deviations: Vec<_> = paths.iter().map(|p| deviation(p, rate)).collect();
    let circle: Vec<(f64, f64)> = (0..=360)
        .map(|d| {
            let a = (d as f64).to_radians();
            (RADIUS * a.cos(), RADIUS * a.sin())
        })
        .collect();
    // At y = 0 the complete region is the square with corners (±h, 0), (0, ±h).
    let h = HALF;
    let region = vec![(h, 0.0), (0.0, h), (-h, 0.0), (0.0, -h), (h, 0.0)];
    let series = vec![
        Series {
            label: "λ = 0".into(),
            points: paths[0].clone(),
            color: PALETTE[1],
        },
        Series {
            label: "λ = 0.2".into(),
            points: paths[1].clone(),
            color: PALETTE[0],
        },
        Series {
            label: "bar surface".into(),
            points: circle,
            color: PALETTE[6],
        },
        Series {
            label: "complete-region edge".into(),
            points: region,
            color: PALETTE[2],
        },
    ];
    let chart = Chart {
        title: "tracing a 0.2 m bar on a 0.5 m SPIDAR, 2 kN/m".into(),
        x_label: "x [m]".into(),
        y_label: "z [m]".into(),
        series,
        x_range: Some((-0.26, 0.26)),
        y_range: Some((-0.26, 0.26)),
        equal_aspect: true,
        ..Chart::default()
    };
    let mut text = String::new();
    for (lambda, d) in lambdas.iter().zip(&deviations) {
        text += &format!(
            "  λ = {lambda}: mean radius {:.4} m, roundness {:.2} mm, roughness {:.3} mm\n",
            d.mean_radius,
            d.roundness * 1e3,
            d.roughness * 1e3
        );
    }
    let rows: Vec<Value> = lambdas
        .iter()
        .zip(&deviations)
        .map(|(l, d)| json!({"lambda": l, "mean_radius": d.mean_radius, "roundness": d.roundness, "roughness": d.roughness}))
        .collect();
    Report {
        text,
        json: json!({ "results": rows }),
        charts: vec![chart],
    }
}

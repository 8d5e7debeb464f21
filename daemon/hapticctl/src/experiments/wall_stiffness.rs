//! Thesis Table 3.4 on the simulator: the stiffest wall a user can hold a finger against
//! without it vibrating, at several loop rates. The simulated hand lowers the grip onto a
//! floor, presses and holds; the wall is stable when, once settled, the grip stays within a
//! fraction of a millimetre. The passivity controller is switched off: this measures the
//! rendering itself, not its safety net.

use hapticd_core::diagnostics::Diagnostics;
use hapticd_core::haptic_loop::{DeviceState, LoopSettings};
use hapticd_core::haptics::obstacle::Shape;
use hapticd_core::haptics::passivity::PassivityLimits;
use hapticd_core::haptics::proxy::ProxyParameters;
use hapticd_core::mechanism::Mechanism;
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_device::sim::hand::Script;
use serde_json::{Value, json};

use super::{ExperimentError, Session};
use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// Height of the floor, metres.
const FLOOR: f64 = -0.05;
/// Largest peak-to-peak motion of a settled grip still called at rest, metres.
const AT_REST: f64 = 3e-4;
/// Largest peak-to-peak force of a settled grip still felt as a steady push, newtons.
const STEADY_FORCE: f64 = 2.0;

/// Lowest and highest of a series.
#[derive(Clone, Copy)]
struct Range {
    low: f64,
    high: f64,
}

impl Default for Range {
    fn default() -> Self {
        Self {
            low: f64::INFINITY,
            high: f64::NEG_INFINITY,
        }
    }
}

impl Range {
    fn add(&mut self, v: f64) {
        (self.low, self.high) = (self.low.min(v), self.high.max(v));
    }

    fn span(&self) -> f64 {
        self.high - self.low
    }
}

/// The hand on the first effector (`grip`): hold, lower to 2 cm below the floor, press and
/// hold; the other effectors rest.
fn press_script(grip: &str) -> Result<Script, Diagnostics> {
    Script::parse(
        &format!(
            "hands:\n  {grip:?}:\n    - hold: {{ seconds: 0.1 }}\n    - move: {{ to: [0, {}, 0], seconds: 0.2 }}\n    - hold: {{ seconds: 2 }}\n",
            FLOOR - 0.02
        ),
        std::path::Path::new("wall-stiffness hand"),
    )
}

/// Whether a floor of `stiffness` N/m and `damping` N·s/m holds the pressing hand still at
/// `rate` Hz on the first effector of `mechanism`; an error for a mechanism the simulated
/// board cannot drive.
pub fn is_stable(
    mechanism: &Mechanism,
    rate: f64,
    stiffness: f64,
    damping: f64,
) -> Result<bool, ExperimentError> {
    let session = Session {
        mechanism: mechanism.clone(),
        scene: StaticSceneSpec::bare(
            "floor",
            ProxyParameters {
                stiffness,
                damping,
                static_friction: 0.0,
                dynamic_friction: 0.0,
            },
            vec![Shape::HalfSpace {
                point: glam::DVec3::new(0.0, FLOOR, 0.0),
                normal: glam::DVec3::Y,
            }],
        ),
        script: press_script(&mechanism.effectors[0].name)?,
        rate,
        settings: LoopSettings {
            passivity: PassivityLimits::OFF,
            ..LoopSettings::default()
        },
    };
    let (mut y, mut force, mut healthy) = (Range::default(), Range::default(), true);
    session.run(1.0, |frame| {
        healthy &= frame.state == DeviceState::Running;
        if frame.time > 0.6 {
            y.add(frame.poses[0].position.y);
            force.add(frame.wrenches[0].force.y);
        }
    })?;
    // At rest on the floor, pressing with a steady force below the limit.
    Ok(healthy
        && y.span() < AT_REST
        && y.high < FLOOR + 0.002
        && force.span() < STEADY_FORCE
        && force.high < 0.9 * session.settings.safety.max_force)
}

/// The largest stable stiffness at `rate`, N/m, searched by bisection (in log scale) between
/// 100 N/m and 1 MN/m, for the best of a few damping values. Returns it with its damping.
pub fn max_stable_stiffness(
    mechanism: &Mechanism,
    rate: f64,
) -> Result<(f64, f64), ExperimentError> {
    let mut best = (0.0, 0.0);
    for damping in [2.0, 10.0, 40.0] {
        let (mut low, mut high) = (100f64.ln(), 1e6f64.ln());
        if !is_stable(mechanism, rate, low.exp(), damping)? {
            continue;
        }
        for _ in 0..12 {
            let mid = 0.5 * (low + high);
            if is_stable(mechanism, rate, mid.exp(), damping)? {
                low = mid;
            } else {
                high = mid;
            }
        }
        if low.exp() > best.0 {
            best = (low.exp(), damping);
        }
    }
    Ok(best)
}

/// Table 3.4 on `mechanism` at each of `rates`: the stiffest stable wall and its damping per
/// rate, charted beside the thesis' hardware.
pub fn report(mechanism: &Mechanism, rates: &[f64]) -> Result<Report, ExperimentError> {
    let results: Vec<(f64, f64, f64)> = rates
        .iter()
        .map(|&rate| {
            let (k, b) = max_stable_stiffness(mechanism, rate)?;
            Ok((rate, k, b))
        })
        .collect::<Result<_, ExperimentError>>()?;
    let thesis = [(1000.0, 7.0), (5000.0, 25.5), (10_000.0, 28.5)];
    let chart = Chart {
        title: format!("{}: stiffest stable wall against loop rate", mechanism.name),
        x_label: "loop rate [kHz]".into(),
        y_label: "stiffness [kN/m]".into(),
        series: vec![
            Series {
                label: "simulated SPIDAR (hapticd)".into(),
                points: results
                    .iter()
                    .map(|(r, k, _)| (r / 1000.0, k / 1000.0))
                    .collect(),
                color: PALETTE[0],
            },
            Series {
                label: "thesis hardware (Table 3.4)".into(),
                points: thesis.iter().map(|(r, k)| (r / 1000.0, *k)).collect(),
                color: PALETTE[1],
            },
        ],
        x_range: Some((0.0, 11.0)),
        // Head room above the curves for the legend.
        y_range: Some((
            0.0,
            1.4 * results
                .iter()
                .map(|(_, k, _)| k / 1000.0)
                .fold(28.5, f64::max),
        )),
        ..Chart::default()
    };
    let mut text = String::new();
    for (rate, k, b) in &results {
        text += &format!(
            "  {rate:>6.0} Hz: {:6.1} kN/m (damping {b} N·s/m)\n",
            k / 1000.0
        );
    }
    let rows: Vec<Value> = results
        .iter()
        .map(|(rate, k, b)| json!({"rate": rate, "stiffness": k, "damping": b}))
        .collect();
    Ok(Report {
        text,
        json: json!({ "results": rows }),
        charts: vec![chart],
    })
}

//! One push on blocks from 0.1 to 10 kg at low physics rates, for the three ways the
//! haptic side gives the hand's effect to the world (thesis 6.5.4): local dynamics,
//! impulses, the hand's position. The reference is the same push with the physics as fast
//! as the haptics (1 kHz, impulses), where none of the three approximations is needed.
//!
//! The finger rests 5 mm before the block's face and pushes it 5 cm at 0.25 m/s, the floor
//! holding it back with μ = 0.3 (the shipped `push` scene's floor and block, their mass
//! and friction changed). Under impulse feedback a light block is met as a wall for a whole
//! period and then thrown; local dynamics moves it with the finger at the haptic rate.

use hapticd_physics::scene::Feedback;
use serde_json::{Value, json};

use super::push_phase::{self, Run, Setup};
use super::{ExperimentError, Spread};
use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;

/// The masses pushed, kilograms.
pub const MASSES: [f64; 5] = [0.1, 0.3, 1.0, 3.0, 10.0];

/// The physics rates tried, hertz.
pub const RATES: [f64; 3] = [10.0, 20.0, 30.0];

/// The methods compared, in the order of the figure.
pub const METHODS: [Feedback; 3] = [Feedback::Local, Feedback::Impulse, Feedback::Position];

/// The push at `rate` Hz physics.
pub fn setup(rate: f64) -> Setup {
    Setup {
        rate,
        haptic_rate: 1000.0,
        start: 0.025,
        reach: 0.08,
        speed: 0.25,
        seconds: 2.0,
    }
}

/// The `push` scene with a block of `mass` kilograms on a floor of friction 0.3.
pub fn scene(mass: f64) -> String {
    // The block is a 10 cm cube: its density is its mass over a litre.
    let density = mass / 1e-3;
    push_phase::SCENE
        .replace("density: 8000", &format!("density: {density}"))
        .replace("static_friction: 0.03", "static_friction: 0.3")
        .replace("friction: 0.03", "friction: 0.3")
}

/// Pushes of one block by one method at one rate.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// The block's mass, kilograms.
    pub mass: f64,
    /// Physics steps per second.
    pub rate: f64,
    /// How the hand's effect went to the world.
    pub feedback: Feedback,
    /// One run per sampling phase.
    pub runs: Vec<Run>,
}

impl Cell {
    /// How far the block went over the phases, metres.
    pub fn travel(&self) -> Spread {
        push_phase::stops(&self.runs)
    }

    /// The fastest the block moved over the fastest the finger moved, over all phases.
    pub fn speed_ratio(&self) -> f64 {
        self.runs.iter().map(Run::speed_ratio).fold(0.0, f64::max)
    }
}

/// The push on a block of `mass` with `feedback` at `rate` Hz, at `phases` sampling phases.
pub fn cell(
    mass: f64,
    rate: f64,
    feedback: Feedback,
    phases: usize,
) -> Result<Cell, ExperimentError> {
    let setup = setup(rate);
    let world = push_phase::world(&scene(mass), &setup, feedback)?;
    Ok(Cell {
        mass,
        rate,
        feedback,
        runs: push_phase::sweep(&world, &setup, phases)?,
    })
}

/// The push on the block of `mass` with the physics at the haptic rate.
pub fn reference(mass: f64) -> Result<Run, ExperimentError> {
    let fast = setup(1000.0);
    let world = push_phase::world(&scene(mass), &fast, Feedback::Impulse)?;
    push_phase::run(&world, &fast, 0.0)
}

/// The experiment at every rate, `phases` sampling phases per mass, rate and method: a table
/// of block travel per rate, a result row per cell and a chart of travel against mass per
/// rate, each against the reference.
pub fn report(phases: usize) -> Result<Report, ExperimentError> {
    let references = MASSES
        .iter()
        .map(|&m| reference(m).map(|run| (run.stop(), run.speed_ratio())))
        .collect::<Result<Vec<_>, _>>()?;
    let mut text = format!(
        "one push, {} phases; block travel [mm] (mean ± spread over phases), peak block speed over finger speed:\n",
        phases
    );
    let mut rows = Vec::new();
    let mut charts = Vec::new();
    for rate in RATES {
        charts.push(at_rate(rate, phases, &references, &mut text, &mut rows)?);
    }
    Ok(Report {
        text,
        json: json!({ "results": rows }),
        charts,
    })
}

/// A travel of `metres` on the charts' axis: thrown blocks go metres, blocks held by
/// friction hardly move, and both must be seen beside the reference.
fn log_travel(metres: f64) -> f64 {
    (metres * 1e3).max(0.1).log10()
}

/// The pushes at physics `rate`: adds its table to `text` and its cells to `rows`, and
/// returns its chart. `references` holds each mass's (travel, speed ratio) at the haptic rate.
fn at_rate(
    rate: f64,
    phases: usize,
    references: &[(f64, f64)],
    text: &mut String,
    rows: &mut Vec<Value>,
) -> Result<Chart, ExperimentError> {
    *text += &format!("physics {rate} Hz\n  mass [kg] {:>17}", "reference");
    for method in METHODS {
        *text += &format!(" {:>22}", method.name());
    }
    *text += "\n";
    let mut series = vec![Series {
        label: "physics at 1 kHz".into(),
        points: MASSES
            .iter()
            .zip(references)
            .map(|(m, r)| (m.log10(), log_travel(r.0)))
            .collect(),
        color: PALETTE[0],
    }];
    let mut lines = vec![String::new(); MASSES.len()];
    for (k, method) in METHODS.into_iter().enumerate() {
        let mut points = Vec::new();
        for (i, (&mass, &(reference, reference_ratio))) in MASSES.iter().zip(references).enumerate()
        {
            let cell = cell(mass, rate, method, phases)?;
            let travel = cell.travel();
            lines[i] += &format!(
                " {:8.2} ± {:5.2} ({:4.2})",
                travel.mean * 1e3,
                travel.deviation * 1e3,
                cell.speed_ratio()
            );
            points.push((mass.log10(), log_travel(travel.mean)));
            rows.push(json!({
                "rate": rate,
                "mass": mass,
                "feedback": method.name(),
                "reference": reference,
                "reference_speed_ratio": reference_ratio,
                "mean": travel.mean,
                "deviation": travel.deviation,
                "speed_ratio": cell.speed_ratio(),
                "travels": cell.runs.iter().map(Run::stop).collect::<Vec<_>>(),
            }));
        }
        series.push(Series {
            label: format!("{} feedback", method.name()),
            points,
            color: PALETTE[(k + 1) % PALETTE.len()],
        });
    }
    for ((line, mass), (reference, ratio)) in lines.iter().zip(MASSES).zip(references) {
        *text += &format!(
            "  {mass:9.1} {:10.2} ({ratio:4.2}){line}\n",
            reference * 1e3
        );
    }
    Ok(Chart {
        title: format!("one push, physics {rate} Hz"),
        x_label: "block mass [log10 kg]".into(),
        y_label: "block travel [log10 mm], 0.1 mm or less at -1".into(),
        series,
        ..Chart::default()
    })
}

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

use super::push_phase::{self, Run, Setup};
use super::{ExperimentError, Spread};

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

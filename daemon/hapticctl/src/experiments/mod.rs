//! The thesis' closed-loop experiments, run on the simulated SPIDAR in simulated time (no
//! real-time thread: a second of haptics takes a few milliseconds), so they can be repeated
//! anywhere and asserted in tests.
//!
//! - [`push_phase`]: a block pushed once at 20 Hz physics, for several sampling phases, with
//!   impulse or position feedback (6.4.1–6.4.2, Fig. 6.6);
//! - [`push_mass`]: one push on blocks of 0.1–10 kg at 10–30 Hz physics, with local
//!   dynamics, impulse or position feedback, against physics at the haptic rate (6.5.4);
//! - [`grasp`]: two fingers shake a held box, the grasp rendered by the resultant
//!   distribution method or the conventional one (4.7, Tables 4.1–4.2);
//! - [`wall_stiffness`]: the stiffest wall that stays stable at a given loop rate (Table 3.4);
//! - [`shape_tracing`]: tracing a cylinder across the edge of the complete region (3.5.10);
//! - [`stack_timing`]: the cost of a penalty step against stacked blocks (Fig. 5.10);
//! - [`stick_slip`]: a weight pulled through a spring sticks and slips (Fig. 5.13/5.14);
//! - [`incline`]: a block on a slope just below and just past the friction angle (5.3.6);
//! - [`effects`]: the periodic haptic effects and a cross-fade, within the force-rate limit;
//! - [`pendulum`]: a hinged box's period against its amplitude, against the exact formula;
//! - [`door`]: a door pushed at its handle at 10–60 Hz physics, with local dynamics through
//!   its hinge, against physics at the haptic rate (6.5.4, 7.2);
//! - [`beam`]: a soft cantilever's sag under its weight against Euler–Bernoulli (7.2);
//! - [`peg_in_hole`]: a held peg put into its hole through the 6-DOF god-object, at
//!   several clearances (7.2).
//!
//! Each module's `report` gives what `hapticctl experiment` prints and draws, as a
//! [`Report`](crate::report::Report).

pub mod beam;
pub mod door;
pub mod effects;
pub mod grasp;
pub mod incline;
pub mod peg_in_hole;
pub mod pendulum;
pub mod push_mass;
pub mod push_phase;
pub mod shape_tracing;
pub mod stack_timing;
pub mod stick_slip;
pub mod wall_stiffness;

use hapticd_core::diagnostics::Diagnostics;
use hapticd_core::haptic_loop::{Frame, HapticLoop, LoopError, LoopSettings};
use hapticd_core::mechanism::Mechanism;
use hapticd_core::scene::Pointer;
use hapticd_core::scene::static_scene::{StaticScene, StaticSceneSpec};
use hapticd_device::sim::hand::Script;
use hapticd_device::sim::{SimParameters, SimulatedBoard, TooManyStrings};
use hapticd_device::transport::Sh4Transport;

use crate::multirate::NotFinite;

/// A closed-loop session on the simulated device.
#[derive(Debug, Clone)]
pub struct Session {
    /// The mechanism simulated and driven.
    pub mechanism: Mechanism,
    /// The scene touched.
    pub scene: StaticSceneSpec,
    /// The simulated hand's script.
    pub script: Script,
    /// Loop rate, hertz.
    pub rate: f64,
    /// Loop settings.
    pub settings: LoopSettings,
}

/// Why an experiment could not run.
#[derive(Debug)]
pub enum ExperimentError {
    /// The simulated board cannot drive the mechanism.
    Board(TooManyStrings),
    /// The haptic loop refuses the mechanism.
    Loop(LoopError),
    /// The experiment's own scene or hand script does not parse.
    Input(Diagnostics),
    /// The push experiments need a rapier scene.
    NotRapier,
    /// The push experiments push a body called `block`.
    NoBlock,
    /// The world stopped being finite.
    NotFinite(NotFinite),
}

impl std::fmt::Display for ExperimentError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ExperimentError::Board(e) => e.fmt(f),
            ExperimentError::Loop(e) => e.fmt(f),
            ExperimentError::Input(e) => e.fmt(f),
            ExperimentError::NotRapier => f.write_str("the push experiment needs a rapier scene"),
            ExperimentError::NoBlock => f.write_str("the scene has no body called block"),
            ExperimentError::NotFinite(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for ExperimentError {}

impl From<TooManyStrings> for ExperimentError {
    fn from(e: TooManyStrings) -> Self {
        ExperimentError::Board(e)
    }
}

impl From<LoopError> for ExperimentError {
    fn from(e: LoopError) -> Self {
        ExperimentError::Loop(e)
    }
}

impl From<Diagnostics> for ExperimentError {
    fn from(e: Diagnostics) -> Self {
        ExperimentError::Input(e)
    }
}

impl From<NotFinite> for ExperimentError {
    fn from(e: NotFinite) -> Self {
        ExperimentError::NotFinite(e)
    }
}

impl Session {
    /// The haptic loop of this session, on a freshly powered simulated board; an error for
    /// a mechanism one board cannot drive.
    pub fn haptic_loop(&self) -> Result<HapticLoop, ExperimentError> {
        let period = 1.0 / self.rate;
        let board = SimulatedBoard::new(
            &self.mechanism,
            period,
            &self.script,
            SimParameters::default(),
        )?;
        let transport = Box::new(Sh4Transport::new(
            board,
            format!("sim:{}", self.mechanism.name),
        ));
        let pointers = Pointer::at_calibration(&self.mechanism);
        let scene = Box::new(StaticScene::new(self.scene.clone(), &pointers));
        Ok(HapticLoop::new(
            self.mechanism.clone(),
            transport,
            scene,
            self.settings,
        )?)
    }

    /// Run for `seconds` of simulated time, handing every frame to `observe`.
    pub fn run(
        &self,
        seconds: f64,
        mut observe: impl FnMut(&Frame),
    ) -> Result<(), ExperimentError> {
        let mut haptic = self.haptic_loop()?;
        let ticks = (seconds * self.rate).round() as usize;
        for _ in 0..ticks {
            observe(haptic.tick(1.0 / self.rate));
        }
        Ok(())
    }
}

/// Mean and standard deviation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Mean.
    pub mean: f64,
    /// Standard deviation.
    pub deviation: f64,
}

impl Spread {
    /// Of `values` (none: zeros).
    pub fn of(values: impl Iterator<Item = f64> + Clone) -> Spread {
        let n = values.clone().count().max(1) as f64;
        let mean = values.clone().sum::<f64>() / n;
        let variance = values.map(|v| (v - mean).powi(2)).sum::<f64>() / n;
        Spread {
            mean,
            deviation: variance.sqrt(),
        }
    }
}

//! `hapticctl scene …`: step a physics scene file headless, to try a scene before feeling
//! it: a penalty scene step by step, a rapier scene with its haptic side in lockstep as
//! hapticd runs it ([`hapticctl::scene_report`]).

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand, ValueEnum};
use glam::DVec3;
use hapticctl::report::Report;
use hapticctl::scene_report::{self, OutputError, Outputs};
use hapticctl::scene_run::{Quantity, RunError};
use hapticd_device::sim::hand::{HandTrack, Script};
use hapticd_ipc::bus::Bus;
use hapticd_physics::scene::{Feedback, PenaltyScene, RapierScene, SceneFile};
use hapticd_physics::world::ContactModel;

use crate::Failure;
use crate::client::{self, Client};
use crate::mechanism::{Output, print, save};
use crate::scene_file;

#[derive(Subcommand)]
pub enum Command {
    /// Step a scene file for a while and report, record or plot the bodies' motion.
    Run(RunArgs),
    /// The scenes the running daemon can switch to, the active one marked.
    List(Output),
    /// Switch the running daemon to a scene: a name from `list` or of an installed scene
    /// plugin, or a scene file of yours (sent to the daemon open, read with your rights).
    Switch {
        /// Scene name or file.
        #[arg(add = crate::completion::scenes())]
        name: String,
    },
}

#[derive(Args)]
pub struct RunArgs {
    /// Scene file (YAML, the physics scenes' format), or the name of an installed scene.
    file: PathBuf,
    /// Simulated time, seconds.
    #[arg(long, default_value_t = 1.0)]
    duration: f64,
    /// Physics step, seconds (default: the scene's `dt`).
    #[arg(long)]
    dt: Option<f64>,
    /// Contact model instead of the scene's; repeat to run the scene once per model and
    /// compare them on one plot. With `point`, the material's stiffness and damping act at
    /// one point (N/m, N·s/m).
    #[arg(long = "model", value_enum)]
    models: Vec<Model>,
    /// Write every step's body states (a soft body taken whole) and joint states to this
    /// CSV file (rapier scenes: every haptic tick's, the bodies moved between physics steps
    /// as graphics show them, thesis 6.5.2).
    #[arg(long)]
    record: Option<PathBuf>,
    /// Plot a quantity of every moving body against time to this PNG file.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// What `--plot` shows.
    #[arg(long, value_enum, default_value_t = Quantity::Height)]
    quantity: Quantity,
    /// Move the scene's pointers by this script (the simulated hand's format, one pointer per
    /// hand, in the order of their names); the forces felt are reported.
    #[arg(long, value_name = "SCRIPT")]
    hand: Option<PathBuf>,
    /// Draw the run into this directory, a PNG per frame at 30 frames per second of
    /// simulated time (frame-00000.png, …), with Vulkan.
    #[arg(long, value_name = "DIR")]
    frames: Option<PathBuf>,
    /// Rapier scenes: how far the physics clock runs behind the haptic one, seconds (the
    /// sampling phase of thesis 6.4.2; taken modulo the physics period).
    #[arg(long, default_value_t = 0.0)]
    phase: f64,
    /// Rapier scenes: what the physics takes back from the hand, instead of the file's
    /// `feedback:`.
    #[arg(long, value_enum)]
    feedback: Option<FeedbackArg>,
    #[command(flatten)]
    output: Output,
}

/// What a rapier world takes back from the hand.
#[derive(Clone, Copy, PartialEq, ValueEnum)]
pub enum FeedbackArg {
    /// Local dynamics: the bodies near the hand move with it between physics steps (6.5.4).
    Local,
    /// The impulse the displayed force gave each body (thesis 6.3).
    Impulse,
    /// The hand's position, sampled at the physics rate (the conventional method).
    Position,
}

impl From<FeedbackArg> for Feedback {
    fn from(f: FeedbackArg) -> Self {
        match f {
            FeedbackArg::Local => Feedback::Local,
            FeedbackArg::Impulse => Feedback::Impulse,
            FeedbackArg::Position => Feedback::Position,
        }
    }
}

/// Contact models.
#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum Model {
    /// Forces integrated over the intersection volume.
    Volume,
    /// The deepest point only.
    Point,
}

/// Run one `scene` subcommand; `list` and `switch` ask the daemon on `bus`.
pub fn run(command: Command, bus: &Bus) -> Result<(), Failure> {
    match command {
        Command::Run(mut args) => {
            args.file = scene_file::resolve(&args.file)?;
            run_scene(&args)
        }
        Command::List(output) => client::scenes(&Client::connect(bus)?, &output),
        Command::Switch { name } => client::switch(&Client::connect(bus)?, &name),
    }
}

fn load(path: &Path, model: Option<Model>, pointers: usize) -> Result<PenaltyScene, Failure> {
    let mut scene = PenaltyScene::load(path, pointers)?;
    match model {
        Some(Model::Volume) => scene.set_model(ContactModel::Volume),
        Some(Model::Point) => scene.set_model(ContactModel::Point),
        None => {}
    }
    Ok(scene)
}

fn run_scene(args: &RunArgs) -> Result<(), Failure> {
    let hands: Vec<HandTrack> = match &args.hand {
        Some(path) => Script::load(path)?
            .hands
            .into_values()
            .map(|steps| HandTrack::new(DVec3::ZERO, steps))
            .collect(),
        None => Vec::new(),
    };
    if args.quantity == Quantity::PointerForce && hands.is_empty() {
        return Err(Failure::usage("--quantity pointer-force needs --hand"));
    }
    if !(args.duration.is_finite() && args.duration > 0.0 && args.duration <= 1e5) {
        return Err(Failure::usage("--duration must be > 0 and at most 10⁵ s"));
    }
    match SceneFile::load(&args.file, hands.len())? {
        SceneFile::Rapier(spec) => run_multirate(args, *spec, &hands),
        SceneFile::Penalty(_) => run_penalty(args, &hands),
    }
}

/// Step a rapier scene with its haptic side as hapticd does, and report like a penalty run.
fn run_multirate(
    args: &RunArgs,
    mut spec: RapierScene,
    hands: &[HandTrack],
) -> Result<(), Failure> {
    if !args.models.is_empty() || args.dt.is_some() {
        return Err(Failure::usage(
            "--model and --dt are for penalty scenes; a rapier scene steps at its rate:",
        ));
    }
    if !args.phase.is_finite() {
        return Err(Failure::usage("--phase must be a number of seconds"));
    }
    for warning in &spec.warnings {
        eprintln!("{warning}");
    }
    if let Some(feedback) = args.feedback {
        spec.feedback = feedback.into();
    }
    let mut outputs = outputs(args)?;
    let report = scene_report::run_multirate(
        &spec,
        hands,
        args.quantity,
        args.phase,
        args.duration,
        &mut outputs,
    )
    .map_err(|e| run_failure(e, &args.file))?;
    finish(args, outputs, &report)?;
    print(&args.output, report.json, report.text);
    Ok(())
}

/// Step a penalty scene, once per contact model asked for, and report the runs.
fn run_penalty(args: &RunArgs, hands: &[HandTrack]) -> Result<(), Failure> {
    if args.feedback.is_some() || args.phase != 0.0 {
        return Err(Failure::usage(
            "--feedback and --phase are for rapier scenes; a penalty scene steps in the tick",
        ));
    }
    let mut models: Vec<Option<Model>> = args.models.iter().copied().map(Some).collect();
    models.dedup();
    if models.is_empty() {
        models.push(None);
    }
    let first = load(&args.file, models[0], hands.len())?;
    for warning in &first.warnings {
        eprintln!("{warning}");
    }
    let dt = args.dt.unwrap_or(first.dt);
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Failure::usage("--dt must be a number > 0"));
    }
    if !(args.duration.is_finite() && args.duration > 0.0 && args.duration / dt <= 1e8) {
        return Err(Failure::usage(
            "--duration must be > 0 and at most 10⁸ steps",
        ));
    }
    let steps = (args.duration / dt).round() as usize;
    if args.frames.is_some() && models.len() > 1 {
        return Err(Failure::usage(
            "--frames draws one run: give at most one --model",
        ));
    }
    let mut outputs = outputs(args)?;
    let mut scenes = vec![first];
    for &model in &models[1..] {
        scenes.push(load(&args.file, model, hands.len())?);
    }
    let (report, warnings) =
        scene_report::run_penalty(scenes, args.quantity, hands, (dt, steps), &mut outputs)
            .map_err(|e| run_failure(e, &args.file))?;
    finish(args, outputs, &report)?;
    for warning in warnings {
        eprintln!("hapticctl: warning: {warning}");
    }
    print(&args.output, report.json, report.text);
    Ok(())
}

/// What the run writes as it goes, as `args` ask.
fn outputs(args: &RunArgs) -> Result<Outputs, Failure> {
    Outputs::create(args.record.as_deref(), args.frames.as_deref()).map_err(Failure::failed)
}

/// Write out the rest of the recording, then the plot, if asked for.
fn finish(args: &RunArgs, outputs: Outputs, report: &Report) -> Result<(), Failure> {
    outputs.finish().map_err(Failure::failed)?;
    match (&args.plot, report.charts.first()) {
        (Some(path), Some(chart)) => save(chart, path),
        _ => Ok(()),
    }
}

/// A run that stopped early, as hapticctl says it.
fn run_failure(error: RunError<OutputError>, file: &Path) -> Failure {
    match error {
        RunError::NotFinite { .. } => Failure::failed(format!("{}: {error}", file.display())),
        RunError::Unsupported(_) => {
            Failure::usage("--quantity angular-momentum-z is for penalty scenes")
        }
        RunError::Step(e) => Failure::failed(e),
    }
}

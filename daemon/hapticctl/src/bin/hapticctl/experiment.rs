//! `hapticctl experiment …`: the thesis' closed-loop experiments on the simulated SPIDAR,
//! with their figures.

use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};
use hapticctl::experiments::{
    beam, door, effects, grasp, incline, peg_in_hole, pendulum, push_mass, push_phase,
    shape_tracing, stack_timing, stick_slip, wall_stiffness,
};
use hapticctl::report::Report;
use hapticd_config::catalog::Catalog;
use hapticd_core::haptics::grasp::Method;
use hapticd_device::sim::hand::Script;
use serde_json::json;

use crate::Failure;
use crate::mechanism::{Numbers, Output, parse_numbers, print, resolve, save_canvas};

#[derive(Subcommand)]
pub enum Command {
    /// Stiffest stable wall against loop rate (thesis Table 3.4).
    Stiffness(StiffnessArgs),
    /// Trace a 0.2 m bar with λ = 0 and λ = 0.2 (thesis 3.5.10, Fig. 3.19).
    Cylinder(CylinderArgs),
    /// Time one penalty physics step against stacked blocks (thesis Fig. 5.10).
    StackTiming(StackTimingArgs),
    /// Pull a 2 kg weight through a spring: stick-slip (thesis Fig. 5.13/5.14).
    StickSlip(StickSlipArgs),
    /// Tilt a block's floor to fractions of the friction angle, at once: it holds below the
    /// angle and slides past it (thesis 5.3.6).
    Incline(InclineArgs),
    /// Two fingers shake a held box: resultant distribution against one spring per finger
    /// (thesis 4.7, Tables 4.1–4.2, Fig. 4.12).
    Grasp(GraspArgs),
    /// Push a block once at 20 Hz physics for several sampling phases, with impulse and with
    /// position feedback (thesis 6.4.1–6.4.2, Fig. 6.6).
    PushPhase(PushPhaseArgs),
    /// Push blocks of 0.1–10 kg at 10, 20 and 30 Hz physics with local dynamics, impulse
    /// and position feedback, against physics at the haptic rate (thesis 6.5.4).
    PushMass(PushMassArgs),
    /// Each periodic effect's force over time through the daemon's effect set, and a
    /// constant force cross-faded: never faster than the force-rate limit.
    Effects(Figure),
    /// Release a hinged box from several amplitudes in the penalty engine and in rapier at
    /// several physics rates: its period against the exact one of a large swing (joints,
    /// thesis 7.2).
    Pendulum(PendulumArgs),
    /// Push a door open at its handle with the physics at 10, 30 and 60 Hz (local dynamics
    /// through its hinge) against 1 kHz: its swing, and the moment about the hinge the hand
    /// met (joints, thesis 6.5.4 and 7.2).
    Door(Figure),
    /// Let a soft cantilever sag under its weight at several Young's moduli, cut into
    /// linear and quadratic elements: its tip's sag against Euler–Bernoulli's (soft bodies,
    /// thesis 7.2).
    Beam(BeamArgs),
    /// Put a held peg into its hole through the 6-DOF god-object, with a hand script
    /// (approach, tilt, wobble, insert), at several clearances: the depth reached, the
    /// deepest the solids went into each other, the peak force and torque, and the tick's
    /// cost (assembly, thesis 7.2).
    PegInHole(PegInHoleArgs),
}

#[derive(Args)]
pub struct PegInHoleArgs {
    /// The hole's width less the peg's, millimetres (less than 0: interference).
    #[arg(long, value_parser = parse_numbers, default_value = "0.2,0.05,-0.2", allow_hyphen_values = true)]
    clearances: Numbers,
    /// Sides of the peg and its hole (4: square; 48: round).
    #[arg(long, default_value_t = 4)]
    sides: usize,
    /// The hand's script (the first hand of it holds the peg); by default the shipped one.
    #[arg(long, value_name = "SCRIPT")]
    hand: Option<PathBuf>,
    /// Coulomb's coefficient of friction at the contacts.
    #[arg(long, default_value_t = 0.0)]
    friction: f64,
    /// Simulated time, seconds.
    #[arg(long, default_value_t = 2.6)]
    duration: f64,
    #[command(flatten)]
    figure: Figure,
}

#[derive(Args)]
pub struct BeamArgs {
    /// Young's moduli, pascals (10⁶ to 10¹¹).
    #[arg(long, value_parser = parse_numbers, default_value = "1e7,1.5e7,2e7,3e7,5e7,7e7,1e8,2e8,5e8,1e9")]
    moduli: Numbers,
    #[command(flatten)]
    figure: Figure,
}

#[derive(Args)]
pub struct PushMassArgs {
    /// Sampling phases per mass, rate and method, spread over one physics period (2–20).
    #[arg(long, default_value_t = 4)]
    phases: usize,
    /// Draw travel against mass, one chart per physics rate, to this PNG file.
    #[arg(long)]
    plot: Option<PathBuf>,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct PushPhaseArgs {
    /// Sampling phases, spread evenly over one physics period (2–100).
    #[arg(long, default_value_t = 10)]
    phases: usize,
    /// Physics steps per second (10–100).
    #[arg(long, default_value_t = push_phase::Setup::THESIS.rate)]
    rate: f64,
    /// The hand's speed toward the block, m/s (0.01–1).
    #[arg(long, default_value_t = push_phase::Setup::THESIS.speed)]
    speed: f64,
    /// How far along x the hand reaches before it withdraws, metres (−0.05–0.2).
    #[arg(long, default_value_t = push_phase::Setup::THESIS.reach, allow_negative_numbers = true)]
    reach: f64,
    /// A rapier scene file with a body called `block` instead of the shipped push scene.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Draw the block's way for every phase, one chart per feedback, to this PNG file.
    #[arg(long)]
    plot: Option<PathBuf>,
    #[command(flatten)]
    output: Output,
}

/// The rendering methods a grasp experiment compares.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum GraspMethod {
    /// Shape shell and resultant distribution (4.5, 4.6).
    Distributed,
    /// One spring per finger to the object (4.4).
    Conventional,
}

#[derive(Args)]
pub struct GraspArgs {
    /// Only this method (default: both, side by side).
    #[arg(long, value_enum)]
    method: Option<GraspMethod>,
    /// The box's mass, kg (0.01–100).
    #[arg(long, default_value_t = grasp::Setup::THESIS.mass)]
    mass: f64,
    /// Its width between the fingers, metres (0.01–0.3).
    #[arg(long, default_value_t = grasp::Setup::THESIS.width)]
    width: f64,
    /// Its height, metres (0.01–0.5).
    #[arg(long, default_value_t = grasp::Setup::THESIS.height)]
    height: f64,
    /// Gravity, m/s² (0–20).
    #[arg(long, default_value_t = grasp::Setup::THESIS.gravity)]
    gravity: f64,
    /// Grip spring, N/m (10–10000).
    #[arg(long, default_value_t = grasp::Setup::THESIS.grip_stiffness)]
    grip_stiffness: f64,
    /// Inertia spring between shell and box, N/m (10–10000).
    #[arg(long, default_value_t = grasp::Setup::THESIS.inertia_stiffness)]
    inertia_stiffness: f64,
    /// Friction coefficient between fingers and box (0–5).
    #[arg(long, default_value_t = grasp::Setup::THESIS.friction)]
    friction: f64,
    /// Length of the run, seconds (1–600).
    #[arg(long, default_value_t = grasp::Setup::THESIS.seconds)]
    seconds: f64,
    /// Write grip force, resultant and finger distance over one series of shakes to this PNG.
    #[arg(long)]
    plot: Option<PathBuf>,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct StickSlipArgs {
    /// Simulated time, seconds.
    #[arg(long, default_value_t = 3.0)]
    duration: f64,
    #[command(flatten)]
    figure: Figure,
}

#[derive(Args)]
pub struct InclineArgs {
    /// Fractions of the friction angle.
    #[arg(long, value_parser = parse_numbers, default_value = "0.9,0.95,0.99,1.01")]
    fractions: Numbers,
    /// Simulated time after the tilt, seconds.
    #[arg(long, default_value_t = 3.0)]
    duration: f64,
    #[command(flatten)]
    figure: Figure,
}

#[derive(Args)]
pub struct StackTimingArgs {
    /// Stack heights, blocks.
    #[arg(long, value_parser = parse_numbers, default_value = "1,2,5,10,20,50,100")]
    blocks: Numbers,
    /// Steps timed per height and model (the median is reported).
    #[arg(long, default_value_t = 200)]
    samples: usize,
    #[command(flatten)]
    figure: Figure,
}

#[derive(Args)]
pub struct StiffnessArgs {
    /// Mechanism; its first effector presses on the wall.
    #[arg(default_value = "spidar")]
    mech: String,
    /// Loop rates to try, hertz.
    #[arg(long, value_parser = parse_numbers, default_value = "1000,2000,5000,10000")]
    rates: Numbers,
    #[command(flatten)]
    figure: Figure,
}

#[derive(Args)]
pub struct CylinderArgs {
    /// Loop rate, hertz.
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    #[command(flatten)]
    figure: Figure,
}

// Where an experiment's figure goes, and how its results are printed. A plain comment: clap
// would take a doc comment for the about text of the subcommands that flatten this.
#[derive(Args)]
pub struct PendulumArgs {
    /// Amplitudes it is released from, degrees (under 180).
    #[arg(long, value_parser = parse_numbers, default_value = "5,20,35,50,65,80,95,110,125,140,155,165")]
    amplitudes: Numbers,
    /// Rapier's physics rates, hertz (the penalty engine steps at 4 kHz beside them).
    #[arg(long, value_parser = parse_numbers, default_value = "1000,60")]
    rates: Numbers,
    #[command(flatten)]
    figure: Figure,
}

#[derive(Args)]
pub struct Figure {
    /// Write the figure to this PNG file.
    #[arg(long)]
    plot: PathBuf,
    #[command(flatten)]
    output: Output,
}

/// Loop rates the simulator can run: 100 Hz to its maximum.
fn check_rate(rate: f64) -> Result<(), Failure> {
    let max = hapticd_core::parameters::MAX_RATE;
    if (100.0..=max).contains(&rate) {
        Ok(())
    } else {
        Err(Failure::usage(format!(
            "rates must be 100–{max} Hz, not {rate}"
        )))
    }
}

/// A usage error for the first of `values` (option, value, allowed range) out of its range.
fn check_ranges(values: &[(&str, f64, RangeInclusive<f64>)]) -> Result<(), Failure> {
    match values
        .iter()
        .find(|(_, value, range)| !range.contains(value))
    {
        Some((name, value, range)) => Err(Failure::usage(format!(
            "{name} must be {}–{}, not {value}",
            range.start(),
            range.end()
        ))),
        None => Ok(()),
    }
}

/// Print `report`, its figure written to `plot` if one is given, said after the text.
fn show(output: &Output, mut report: Report, plot: Option<&Path>) -> Result<(), Failure> {
    if let Some(path) = plot {
        save_canvas(&report.figure(), path)?;
        report.text += &format!("wrote {}\n", path.display());
    }
    report.json["plot"] = json!(plot);
    print(output, report.json, report.text);
    Ok(())
}

/// Write `report`'s figure where `figure` says and print it, said before the text.
fn show_figure(mut report: Report, figure: &Figure) -> Result<(), Failure> {
    save_canvas(&report.figure(), &figure.plot)?;
    let wrote = format!("wrote {}\n", figure.plot.display());
    report.text.insert_str(0, &wrote);
    report.json["plot"] = json!(figure.plot);
    print(&figure.output, report.json, report.text);
    Ok(())
}

/// Run one `experiment` subcommand.
pub fn run(command: Command, catalog: &Catalog) -> Result<(), Failure> {
    match command {
        Command::Stiffness(args) => stiffness(catalog, &args),
        Command::Cylinder(args) => {
            check_rate(args.rate)?;
            show_figure(shape_tracing::report(args.rate), &args.figure)
        }
        Command::StackTiming(args) => stack_timing(&args),
        Command::StickSlip(args) => {
            check_duration(args.duration)?;
            let report = stick_slip::report(args.duration);
            show_figure(report, &args.figure)
        }
        Command::Incline(args) => incline(&args),
        Command::Grasp(args) => grasp(&args),
        Command::PushPhase(args) => push(&args),
        Command::Effects(figure) => show_figure(effects::report(), &figure),
        Command::Pendulum(args) => {
            let swings = |a: &f64| (1.0..=170.0).contains(a);
            let rates = |r: &f64| (10.0..=10_000.0).contains(r);
            if !(args.amplitudes.iter().all(swings) && args.rates.iter().all(rates)) {
                return Err(Failure::usage(
                    "--amplitudes must be 1–170 degrees and --rates 10–10000 Hz",
                ));
            }
            let mut runs = vec![("penalty", 4000.0)];
            runs.extend(args.rates.iter().map(|&r| ("rapier", r)));
            let report = pendulum::report(&args.amplitudes, &runs);
            show_figure(report, &args.figure)
        }
        Command::Beam(args) => {
            if !args.moduli.iter().all(|e| (1e6..=1e11).contains(e)) {
                return Err(Failure::usage("--moduli must be 1e6–1e11 Pa"));
            }
            let report = beam::report(&args.moduli).map_err(Failure::failed)?;
            show_figure(report, &args.figure)
        }
        Command::Door(figure) => {
            let report = door::report(&door::Door::default()).map_err(Failure::failed)?;
            show_figure(report, &figure)
        }
        Command::PegInHole(args) => peg_in_hole(&args),
        Command::PushMass(args) => {
            if !(2..=20).contains(&args.phases) {
                return Err(Failure::usage("--phases must be 2–20"));
            }
            let report = push_mass::report(args.phases).map_err(Failure::failed)?;
            show(&args.output, report, args.plot.as_deref())
        }
    }
}

fn peg_in_hole(args: &PegInHoleArgs) -> Result<(), Failure> {
    let mut values = vec![
        ("--sides", args.sides as f64, 3.0..=64.0),
        ("--duration", args.duration, 0.01..=30.0),
        ("--friction", args.friction, 0.0..=2.0),
    ];
    values.extend(
        args.clearances
            .iter()
            .map(|&c| ("--clearances", c, -2.0..=2.0)),
    );
    check_ranges(&values)?;
    let script = match &args.hand {
        Some(path) => Script::load(path),
        None => peg_in_hole::shipped_script(),
    }
    .map_err(Failure::failed)?;
    let clearances: Vec<f64> = args.clearances.iter().map(|c| c * 1e-3).collect();
    let hand = peg_in_hole::hand(&script);
    let report = peg_in_hole::report(
        args.sides,
        &clearances,
        (&hand, args.duration),
        args.friction,
    );
    show_figure(report, &args.figure)
}

/// Simulated time of the friction experiments: up to a minute.
fn check_duration(duration: f64) -> Result<(), Failure> {
    if duration > 0.0 && duration <= 60.0 {
        Ok(())
    } else {
        Err(Failure::usage("--duration must be 0–60 s"))
    }
}

fn push(args: &PushPhaseArgs) -> Result<(), Failure> {
    if !(2..=100).contains(&args.phases) {
        return Err(Failure::usage("--phases must be 2–100"));
    }
    check_ranges(&[
        ("--rate", args.rate, 10.0..=100.0),
        ("--speed", args.speed, 0.01..=1.0),
        ("--reach", args.reach, -0.05..=0.2),
    ])?;
    let scene = match &args.scene {
        Some(path) => hapticd_core::diagnostics::read_text(&crate::scene_file::resolve(path)?)?,
        None => push_phase::SCENE.to_string(),
    };
    let setup = push_phase::Setup {
        rate: args.rate,
        speed: args.speed,
        reach: args.reach,
        ..push_phase::Setup::THESIS
    };
    let report = push_phase::report(&scene, &setup, args.phases).map_err(Failure::failed)?;
    show(&args.output, report, args.plot.as_deref())
}

fn grasp(args: &GraspArgs) -> Result<(), Failure> {
    check_ranges(&[
        ("--mass", args.mass, 0.01..=100.0),
        ("--width", args.width, 0.01..=0.3),
        ("--height", args.height, 0.01..=0.5),
        ("--gravity", args.gravity, 0.0..=20.0),
        ("--grip-stiffness", args.grip_stiffness, 10.0..=1e4),
        ("--inertia-stiffness", args.inertia_stiffness, 10.0..=1e4),
        ("--friction", args.friction, 0.0..=5.0),
        ("--seconds", args.seconds, 1.0..=600.0),
    ])?;
    let methods = match args.method {
        Some(GraspMethod::Distributed) => vec![Method::Distributed],
        Some(GraspMethod::Conventional) => vec![Method::Conventional],
        None => vec![Method::Distributed, Method::Conventional],
    };
    let setup = grasp::Setup {
        mass: args.mass,
        width: args.width,
        height: args.height,
        gravity: args.gravity,
        grip_stiffness: args.grip_stiffness,
        inertia_stiffness: args.inertia_stiffness,
        friction: args.friction,
        seconds: args.seconds,
        ..grasp::Setup::THESIS
    };
    show(
        &args.output,
        grasp::report(&setup, &methods),
        args.plot.as_deref(),
    )
}

fn incline(args: &InclineArgs) -> Result<(), Failure> {
    check_duration(args.duration)?;
    if args.fractions.is_empty() || args.fractions.iter().any(|f| !(0.0..=2.0).contains(f)) {
        return Err(Failure::usage("--fractions must be 0–2"));
    }
    let report = incline::report(&args.fractions, args.duration);
    show_figure(report, &args.figure)
}

fn stack_timing(args: &StackTimingArgs) -> Result<(), Failure> {
    let whole = |n: &f64| (1.0..=1000.0).contains(n) && n.fract() == 0.0;
    if args.samples == 0 || args.blocks.is_empty() || !args.blocks.iter().all(whole) {
        return Err(Failure::usage(
            "--blocks must be whole numbers 1–1000 and --samples > 0",
        ));
    }
    let heights: Vec<usize> = args.blocks.iter().map(|&n| n as usize).collect();
    show_figure(stack_timing::report(&heights, args.samples), &args.figure)
}

fn stiffness(catalog: &Catalog, args: &StiffnessArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    if m.effectors.len() != 1 || m.effectors[0].dof.count() != 3 {
        return Err(Failure::usage(format!(
            "{} is not a single point grip",
            m.name
        )));
    }
    for &rate in args.rates.iter() {
        check_rate(rate)?;
    }
    let report = wall_stiffness::report(&m, &args.rates).map_err(Failure::failed)?;
    show_figure(report, &args.figure)
}

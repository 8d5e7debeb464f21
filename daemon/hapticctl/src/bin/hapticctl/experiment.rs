//! `hapticctl experiment …`: the thesis' closed-loop experiments on the simulated SPIDAR,
//! with their figures.

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};
use hapticctl::experiments::stick_slip::Rig;
use hapticctl::experiments::{
    grasp, incline, push_mass, push_phase, shape_tracing, stack_timing, wall_stiffness,
};
use hapticctl::plot::{Canvas, Chart, PALETTE, Series};
use hapticd_config::catalog::Catalog;
use hapticd_core::haptics::grasp::Method;
use hapticd_physics::scene::Feedback;
use serde_json::{Value, json};

use crate::Failure;
use crate::mechanism::{Numbers, Output, parse_numbers, print, resolve, save, save_canvas};

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
    /// Write the figure to this PNG file.
    #[arg(long)]
    plot: PathBuf,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct InclineArgs {
    /// Fractions of the friction angle.
    #[arg(long, value_parser = parse_numbers, default_value = "0.9,0.95,0.99,1.01")]
    fractions: Numbers,
    /// Simulated time after the tilt, seconds.
    #[arg(long, default_value_t = 3.0)]
    duration: f64,
    /// Write the figure to this PNG file.
    #[arg(long)]
    plot: PathBuf,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct StackTimingArgs {
    /// Stack heights, blocks.
    #[arg(long, value_parser = parse_numbers, default_value = "1,2,5,10,20,50,100")]
    blocks: Numbers,
    /// Steps timed per height and model (the median is reported).
    #[arg(long, default_value_t = 200)]
    samples: usize,
    /// Write the figure to this PNG file.
    #[arg(long)]
    plot: PathBuf,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct StiffnessArgs {
    /// Mechanism; its first effector presses on the wall.
    #[arg(default_value = "spidar")]
    mech: String,
    /// Loop rates to try, hertz.
    #[arg(long, value_parser = parse_numbers, default_value = "1000,2000,5000,10000")]
    rates: Numbers,
    /// Write the figure to this PNG file.
    #[arg(long)]
    plot: PathBuf,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct CylinderArgs {
    /// Loop rate, hertz.
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
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

/// Run one `experiment` subcommand.
pub fn run(command: Command, catalog: &Catalog) -> Result<(), Failure> {
    match command {
        Command::Stiffness(args) => stiffness(catalog, &args),
        Command::Cylinder(args) => cylinder(&args),
        Command::StackTiming(args) => stack_timing(&args),
        Command::StickSlip(args) => stick_slip(&args),
        Command::Incline(args) => incline(&args),
        Command::Grasp(args) => grasp(&args),
        Command::PushPhase(args) => push(&args),
        Command::PushMass(args) => push_masses(&args),
    }
}

/// A travel of `metres` on the push-mass charts' axis: thrown blocks go metres, blocks held
/// by friction hardly move, and both must be seen beside the reference.
fn log_travel(metres: f64) -> f64 {
    (metres * 1e3).max(0.1).log10()
}

fn push_masses(args: &PushMassArgs) -> Result<(), Failure> {
    if !(2..=20).contains(&args.phases) {
        return Err(Failure::usage("--phases must be 2–20"));
    }
    let references = push_mass::MASSES
        .iter()
        .map(|&m| push_mass::reference(m).map(|run| (run.stop(), run.speed_ratio())))
        .collect::<Result<Vec<_>, _>>()
        .map_err(Failure::failed)?;
    let mut text = format!(
        "one push, {} phases; block travel [mm] (mean ± spread over phases), peak block speed over finger speed:\n",
        args.phases
    );
    let mut rows = Vec::new();
    let mut charts = Vec::new();
    for rate in push_mass::RATES {
        text += &format!("physics {rate} Hz\n  mass [kg] {:>17}", "reference");
        for method in push_mass::METHODS {
            text += &format!(" {:>22}", method.name());
        }
        text += "\n";
        let mut series: Vec<Series> = Vec::new();
        series.push(Series {
            label: "physics at 1 kHz".into(),
            points: push_mass::MASSES
                .iter()
                .zip(&references)
                .map(|(m, r)| (m.log10(), log_travel(r.0)))
                .collect(),
            color: PALETTE[0],
        });
        let mut lines = vec![String::new(); push_mass::MASSES.len()];
        for (k, method) in push_mass::METHODS.into_iter().enumerate() {
            let mut points = Vec::new();
            for (i, (&mass, &(reference, reference_ratio))) in
                push_mass::MASSES.iter().zip(&references).enumerate()
            {
                let cell =
                    push_mass::cell(mass, rate, method, args.phases).map_err(Failure::failed)?;
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
                    "travels": cell.runs.iter().map(push_phase::Run::stop).collect::<Vec<_>>(),
                }));
            }
            series.push(Series {
                label: format!("{} feedback", method.name()),
                points,
                color: PALETTE[(k + 1) % PALETTE.len()],
            });
        }
        for ((line, mass), (reference, ratio)) in
            lines.iter().zip(push_mass::MASSES).zip(&references)
        {
            text += &format!(
                "  {mass:9.1} {:10.2} ({ratio:4.2}){line}\n",
                reference * 1e3
            );
        }
        charts.push(Chart {
            title: format!("one push, physics {rate} Hz"),
            x_label: "block mass [log10 kg]".into(),
            y_label: "block travel [log10 mm], 0.1 mm or less at -1".into(),
            series,
            ..Chart::default()
        });
    }
    if let Some(path) = &args.plot {
        let rendered: Vec<_> = charts.iter().map(Chart::render).collect();
        save_canvas(&Canvas::stacked(&rendered), path)?;
        text += &format!("wrote {}\n", path.display());
    }
    print(
        &args.output,
        json!({"plot": args.plot, "results": rows}),
        text,
    );
    Ok(())
}

fn push(args: &PushPhaseArgs) -> Result<(), Failure> {
    if !(2..=100).contains(&args.phases) {
        return Err(Failure::usage("--phases must be 2–100"));
    }
    for (name, value, range) in [
        ("--rate", args.rate, 10.0..=100.0),
        ("--speed", args.speed, 0.01..=1.0),
        ("--reach", args.reach, -0.05..=0.2),
    ] {
        if !range.contains(&value) {
            return Err(Failure::usage(format!(
                "{name} must be {}–{}, not {value}",
                range.start(),
                range.end()
            )));
        }
    }
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
    let sweep = |feedback| -> Result<Vec<push_phase::Run>, Failure> {
        let world = push_phase::world(&scene, &setup, feedback).map_err(Failure::failed)?;
        push_phase::sweep(&world, &setup, args.phases).map_err(Failure::failed)
    };
    let (impulse, position) = (sweep(Feedback::Impulse)?, sweep(Feedback::Position)?);
    // The same push with the physics as fast as the haptics: what both methods approximate.
    let fast = push_phase::Setup {
        rate: setup.haptic_rate,
        ..setup
    };
    let reference = push_phase::world(&scene, &fast, Feedback::Impulse)
        .and_then(|w| push_phase::run(&w, &fast, 0.0))
        .map_err(Failure::failed)?
        .stop();
    let mut text = format!(
        "block struck once, physics {} Hz, haptics {} Hz, {} phases; how far it went [mm]:\n",
        setup.rate, setup.haptic_rate, args.phases
    );
    let mut rows = Vec::new();
    for (name, runs) in [("impulse", &impulse), ("position", &position)] {
        let s = push_phase::stops(runs);
        let (low, high) = runs
            .iter()
            .map(push_phase::Run::stop)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                (l.min(x), h.max(x))
            });
        text += &format!(
            "{name:<9} {:7.2} ± {:6.3} (from {:.2} to {:.2}), peak force {:.2} N\n",
            s.mean * 1e3,
            s.deviation * 1e3,
            low * 1e3,
            high * 1e3,
            runs.iter().map(|r| r.peak_force).fold(0.0, f64::max)
        );
        rows.push(json!({
            "feedback": name,
            "mean": s.mean,
            "deviation": s.deviation,
            "stops": runs.iter().map(push_phase::Run::stop).collect::<Vec<_>>(),
        }));
    }
    text += &format!(
        "physics at {} Hz: {:7.2}\n",
        setup.haptic_rate,
        reference * 1e3
    );
    if let Some(path) = &args.plot {
        let chart = |title: &str, runs: &[push_phase::Run]| {
            Chart {
                title: title.into(),
                x_label: "time [s]".into(),
                y_label: "block moved [mm]".into(),
                series: runs
                    .iter()
                    .enumerate()
                    .map(|(k, r)| Series {
                        label: format!("phase {:.0} ms", r.phase * 1e3),
                        points: r
                            .block
                            .iter()
                            .step_by(5)
                            .map(|&(t, x)| (t, x * 1e3))
                            .collect(),
                        color: PALETTE[k % PALETTE.len()],
                    })
                    .collect(),
                ..Chart::default()
            }
            .render()
        };
        let title = |method: &str| format!("{method}, physics {} Hz", setup.rate);
        let canvas = Canvas::stacked(&[
            chart(&title("position feedback"), &position),
            chart(&title("impulse feedback"), &impulse),
        ]);
        save_canvas(&canvas, path)?;
        text += &format!("wrote {}\n", path.display());
    }
    print(
        &args.output,
        json!({"plot": args.plot, "reference": reference, "results": rows}),
        text,
    );
    Ok(())
}

fn grasp(args: &GraspArgs) -> Result<(), Failure> {
    for (name, value, range) in [
        ("--mass", args.mass, 0.01..=100.0),
        ("--width", args.width, 0.01..=0.3),
        ("--height", args.height, 0.01..=0.5),
        ("--gravity", args.gravity, 0.0..=20.0),
        ("--grip-stiffness", args.grip_stiffness, 10.0..=10000.0),
        (
            "--inertia-stiffness",
            args.inertia_stiffness,
            10.0..=10000.0,
        ),
        ("--friction", args.friction, 0.0..=5.0),
        ("--seconds", args.seconds, 1.0..=600.0),
    ] {
        if !range.contains(&value) {
            return Err(Failure::usage(format!(
                "{name} must be {}–{}, not {value}",
                range.start(),
                range.end()
            )));
        }
    }
    let methods: Vec<(&str, Method)> = [
        (GraspMethod::Distributed, "distributed", Method::Distributed),
        (
            GraspMethod::Conventional,
            "conventional",
            Method::Conventional,
        ),
    ]
    .into_iter()
    .filter(|(m, _, _)| args.method.is_none_or(|only| only == *m))
    .map(|(_, name, method)| (name, method))
    .collect();
    let runs: Vec<(&str, grasp::Setup, Vec<grasp::Sample>)> = methods
        .iter()
        .map(|&(name, method)| {
            let setup = grasp::Setup {
                method,
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
            (name, setup, grasp::run(&setup))
        })
        .collect();
    let mut text = String::from(
        "method         grip force [N]     finger distance [mm]   still: grip [N]   distance [mm]\n",
    );
    let mut rows = Vec::new();
    for (name, setup, samples) in &runs {
        let s = grasp::Summary::of(setup, samples);
        let mm = 1e3;
        text += &format!(
            "{name:<14} {:5.2} ± {:5.3}      {:6.2} ± {:6.3}        {:5.2} ± {:5.3}    {:6.2} ± {:6.3}\n",
            s.grip.mean,
            s.grip.deviation,
            s.distance.mean * mm,
            s.distance.deviation * mm,
            s.still_grip.mean,
            s.still_grip.deviation,
            s.still_distance.mean * mm,
            s.still_distance.deviation * mm,
        );
        let spread = |x: grasp::Spread| json!({"mean": x.mean, "deviation": x.deviation});
        rows.push(json!({
            "method": name,
            "grip": spread(s.grip),
            "distance": spread(s.distance),
            "still_grip": spread(s.still_grip),
            "still_distance": spread(s.still_distance),
            // What (4.10) predicts for the still grasp: l − 2 f_g / k.
            "predicted_still_distance": setup.width - 2.0 * s.still_grip.mean / setup.grip_stiffness,
        }));
    }
    if let Some(path) = &args.plot {
        // One series of shakes and its still phase, after the first (Fig. 4.12's window).
        let cycle = f64::from(grasp::Setup::THESIS.shakes) / grasp::Setup::THESIS.frequency
            + grasp::Setup::THESIS.still;
        let window = (cycle, (2.0 * cycle).min(args.seconds));
        let series = |pick: fn(&grasp::Sample) -> f64, label: &str| -> Vec<Series> {
            runs.iter()
                .enumerate()
                .map(|(k, (name, _, samples))| Series {
                    label: format!("{label}, {name}"),
                    points: samples
                        .iter()
                        .filter(|s| (window.0..=window.1).contains(&s.time))
                        .step_by(5)
                        .map(|s| (s.time, pick(s)))
                        .collect(),
                    color: PALETTE[k],
                })
                .collect()
        };
        let mut forces = series(|s| s.grip, "grip");
        forces.extend(
            series(|s| s.resultant.abs(), "|resultant|")
                .into_iter()
                .enumerate()
                .map(|(k, s)| Series {
                    color: PALETTE[k + 2],
                    ..s
                }),
        );
        let charts = [
            Chart {
                title: "shaking a held box: forces".into(),
                x_label: "time [s]".into(),
                y_label: "force [N]".into(),
                series: forces,
                ..Chart::default()
            },
            Chart {
                title: "finger distance".into(),
                x_label: "time [s]".into(),
                y_label: "distance [mm]".into(),
                series: series(|s| s.distance * 1e3, "distance"),
                ..Chart::default()
            },
        ];
        let canvas = Canvas::stacked(&charts.map(|c| c.render()));
        save_canvas(&canvas, path)?;
        text += &format!("wrote {}\n", path.display());
    }
    print(
        &args.output,
        json!({"plot": args.plot, "results": rows}),
        text,
    );
    Ok(())
}

fn stick_slip(args: &StickSlipArgs) -> Result<(), Failure> {
    if !(args.duration > 0.0 && args.duration <= 60.0) {
        return Err(Failure::usage("--duration must be 0–60 s"));
    }
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
            let samples = rig.run(args.duration);
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
    save(&chart, &args.plot)?;
    let mut text = format!("wrote {}\n", args.plot.display());
    for (label, expected, _, peak) in &runs {
        text += &format!("  {label}: peak {peak:.2} N (rigid-stick value {expected:.2} N)\n");
    }
    let rows = runs.iter().map(|(label, expected, _, peak)| {
        json!({"model": label, "peak": peak, "expected_peak": expected})
    });
    report(&args.output, &args.plot, rows, text);
    Ok(())
}

fn incline(args: &InclineArgs) -> Result<(), Failure> {
    if !(args.duration > 0.0 && args.duration <= 60.0) {
        return Err(Failure::usage("--duration must be 0–60 s"));
    }
    if args.fractions.is_empty() || args.fractions.iter().any(|f| !(0.0..=2.0).contains(f)) {
        return Err(Failure::usage("--fractions must be 0–2"));
    }
    let (_, cube) = incline::SHAPES[0];
    let runs: Vec<_> = args
        .fractions
        .iter()
        .map(|&fraction| {
            let block = incline::Incline {
                size: cube,
                damping: 1.0,
                fraction,
                ramp: 0.0,
            };
            (fraction, block.run(args.duration).0)
        })
        .collect();
    let chart = Chart {
        title: format!(
            "a 0.2 m cube on a slope, μ0 = {}, μ = {}",
            incline::STATIC_FRICTION,
            incline::FRICTION
        ),
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
    save(&chart, &args.plot)?;
    let mut text = format!("wrote {}\n", args.plot.display());
    for (fraction, samples) in &runs {
        let moved = samples.last().map_or(0.0, |s| s.moved);
        text += &format!(
            "  {fraction} of the friction angle: {:.4} mm\n",
            moved * 1e3
        );
    }
    let rows = runs.iter().map(|(fraction, samples)| {
        json!({"fraction": fraction, "moved": samples.last().map_or(0.0, |s| s.moved)})
    });
    report(&args.output, &args.plot, rows, text);
    Ok(())
}

fn stack_timing(args: &StackTimingArgs) -> Result<(), Failure> {
    let heights: Vec<usize> = args.blocks.iter().map(|&n| n as usize).collect();
    if args.samples == 0
        || heights.is_empty()
        || args
            .blocks
            .iter()
            .any(|&n| !(1.0..=1000.0).contains(&n) || n.fract() != 0.0)
    {
        return Err(Failure::usage(
            "--blocks must be whole numbers 1–1000 and --samples > 0",
        ));
    }
    let results: Vec<(usize, f64, f64)> = heights
        .iter()
        .map(|&n| {
            let (volume, point) = stack_timing::step_times(n, args.samples);
            (n, volume * 1e6, point * 1e6)
        })
        .collect();
    let curve = |pick: fn(&(usize, f64, f64)) -> f64| -> Vec<(f64, f64)> {
        results.iter().map(|r| (r.0 as f64, pick(r))).collect()
    };
    let chart = Chart {
        title: "time of one physics step against stacked blocks".into(),
        x_label: "blocks".into(),
        y_label: "time per step [us]".into(),
        series: vec![
            Series {
                label: "contact-volume penalty".into(),
                points: curve(|r| r.1),
                color: PALETTE[0],
            },
            Series {
                label: "deepest-point penalty".into(),
                points: curve(|r| r.2),
                color: PALETTE[1],
            },
        ],
        // Head room above the curves for the legend.
        y_range: Some((
            0.0,
            1.4 * results.iter().fold(0.0_f64, |m, r| m.max(r.1).max(r.2)),
        )),
        ..Chart::default()
    };
    save(&chart, &args.plot)?;
    let mut text = format!("wrote {}\n", args.plot.display());
    for (n, volume, point) in &results {
        text += &format!("  {n:>4} blocks: volume {volume:8.1} us, point {point:8.1} us\n");
    }
    let rows = results
        .iter()
        .map(|(n, v, p)| json!({"blocks": n, "volume_us": v, "point_us": p}));
    report(&args.output, &args.plot, rows, text);
    Ok(())
}

/// Print an experiment's result rows and the figure written, as JSON or as `text`.
fn report(output: &Output, plot: &Path, rows: impl Iterator<Item = Value>, text: String) {
    let rows: Vec<Value> = rows.collect();
    print(output, json!({"plot": plot, "results": rows}), text);
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
    let results: Vec<(f64, f64, f64)> = args
        .rates
        .iter()
        .map(|&rate| {
            let (k, b) = wall_stiffness::max_stable_stiffness(&m, rate).map_err(Failure::failed)?;
            Ok((rate, k, b))
        })
        .collect::<Result<_, Failure>>()?;
    let thesis = [(1000.0, 7.0), (5000.0, 25.5), (10_000.0, 28.5)];
    let chart = Chart {
        title: format!("{}: stiffest stable wall against loop rate", m.name),
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
    save(&chart, &args.plot)?;
    let mut text = format!("wrote {}\n", args.plot.display());
    for (rate, k, b) in &results {
        text += &format!(
            "  {rate:>6.0} Hz: {:6.1} kN/m (damping {b} N·s/m)\n",
            k / 1000.0
        );
    }
    let rows = results
        .iter()
        .map(|(rate, k, b)| json!({"rate": rate, "stiffness": k, "damping": b}));
    report(&args.output, &args.plot, rows, text);
    Ok(())
}

fn cylinder(args: &CylinderArgs) -> Result<(), Failure> {
    check_rate(args.rate)?;
    let lambdas = [0.0, 0.2];
    let paths: Vec<Vec<(f64, f64)>> = lambdas
        .iter()
        .map(|&l| shape_tracing::trace(l, args.rate))
        .collect();
    let deviations: Vec<_> = paths
        .iter()
        .map(|p| shape_tracing::deviation(p, args.rate))
        .collect();
    let circle: Vec<(f64, f64)> = (0..=360)
        .map(|d| {
            let a = (d as f64).to_radians();
            (
                shape_tracing::RADIUS * a.cos(),
                shape_tracing::RADIUS * a.sin(),
            )
        })
        .collect();
    // At y = 0 the complete region is the square with corners (±h, 0), (0, ±h).
    let h = shape_tracing::HALF;
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
    save(&chart, &args.plot)?;
    let mut text = format!("wrote {}\n", args.plot.display());
    for (lambda, d) in lambdas.iter().zip(&deviations) {
        text += &format!(
            "  λ = {lambda}: mean radius {:.4} m, roundness {:.2} mm, roughness {:.3} mm\n",
            d.mean_radius,
            d.roundness * 1e3,
            d.roughness * 1e3
        );
    }
    let rows: Vec<_> = lambdas
        .iter()
        .zip(&deviations)
        .map(|(l, d)| json!({"lambda": l, "mean_radius": d.mean_radius, "roundness": d.roundness, "roughness": d.roughness}))
        .collect();
    print(
        &args.output,
        json!({"plot": args.plot, "results": rows}),
        text,
    );
    Ok(())
}

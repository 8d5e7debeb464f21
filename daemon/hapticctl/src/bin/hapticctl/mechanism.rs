//! `hapticctl mechanism …`: list, inspect, pose, tension, workspace and sweep.

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand, ValueEnum};
use glam::{DQuat, DVec3};
use hapticctl::mechanism_report::{self, PoseError, TensionSweep, effector_index};
use hapticctl::plot::{Canvas, Chart};
use hapticctl::report::Report;
use hapticd_config::catalog::Catalog;
use hapticd_core::diagnostics::Diagnostics;
use hapticd_core::kinematics::{Dof, Pose, Wrench, quat_from_wxyz};
use hapticd_core::mechanism::Mechanism;
use hapticd_core::parameters::Name;
use serde_json::{Value, json};

use crate::Failure;

#[derive(Subcommand)]
pub enum Command {
    /// List installed mechanisms.
    List(Output),
    /// Summarise a mechanism and report its validation result.
    Inspect(Inspect),
    /// Solve effector poses from string lengths.
    Pose(PoseArgs),
    /// Solve string tensions for a wrench at a pose.
    Tension(TensionArgs),
    /// Plot a slice of the complete-presentation (force-closure) region.
    Workspace(WorkspaceArgs),
    /// Plot tensions along a path for several λ (thesis Fig. 3.15).
    Sweep(SweepArgs),
}

#[derive(Args)]
pub struct Output {
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct Inspect {
    /// Installed mechanism name, or path to a .yaml descriptor or .so plugin.
    mech: String,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct PoseArgs {
    /// Installed mechanism name, or path to a .yaml descriptor or .so plugin.
    mech: String,
    /// Measured length of every string, metres, in mechanism order.
    #[arg(long, value_name = "L1,...,LM", value_parser = parse_numbers, allow_hyphen_values = true)]
    lengths: Numbers,
    /// Start pose x,y,z[,w,x,y,z]: once for all effectors or once per effector, in order
    /// (default: each effector's calibration pose).
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    from: Vec<Numbers>,
    /// Most Gauss–Newton iterations per effector.
    #[arg(long, default_value_t = 10)]
    iterations: usize,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct TensionArgs {
    /// Installed mechanism name, or path to a .yaml descriptor or .so plugin.
    mech: String,
    /// End effector (default: the first).
    #[arg(long)]
    effector: Option<String>,
    /// Grip position x,y,z, metres.
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    position: Numbers,
    /// Grip orientation w,x,y,z (6-DOF effectors; default identity).
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    orientation: Option<Numbers>,
    /// Force to present fx,fy,fz, newtons.
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    force: Numbers,
    /// Torque to present tx,ty,tz, newton-metres (6-DOF effectors; default zero).
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    torque: Option<Numbers>,
    /// Solve eq. 3.16 exactly as written with this λ, every wrench component weighted 1
    /// (default: the mechanism's own settings).
    #[arg(long, value_parser = parse_number, allow_hyphen_values = true)]
    lambda: Option<f64>,
    #[command(flatten)]
    output: Output,
}

#[derive(Clone, Copy, ValueEnum)]
enum Plane {
    Xy,
    Xz,
    Yz,
}

#[derive(Args)]
pub struct WorkspaceArgs {
    /// Installed mechanism name, or path to a .yaml descriptor or .so plugin.
    mech: String,
    /// Write the plot to this PNG file.
    #[arg(long)]
    plot: PathBuf,
    /// End effector (default: the first).
    #[arg(long)]
    effector: Option<String>,
    /// Plane of the slice.
    #[arg(long, value_enum, default_value = "xz")]
    plane: Plane,
    /// A point of the slice x,y,z (default: the calibration position).
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    at: Option<Numbers>,
    /// Cells along each side.
    #[arg(long, default_value_t = 160)]
    resolution: usize,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct SweepArgs {
    /// Installed mechanism name, or path to a .yaml descriptor or .so plugin.
    mech: String,
    /// Write the plot to this PNG file.
    #[arg(long)]
    plot: PathBuf,
    /// End effector (default: the first).
    #[arg(long)]
    effector: Option<String>,
    /// Force presented along the path fx,fy,fz, newtons.
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true, default_value = "5,5,5")]
    force: Numbers,
    /// λ values to compare.
    #[arg(long, value_parser = parse_numbers, default_value = "0,0.01,0.05,0.2")]
    lambdas: Numbers,
    /// Path start x,y,z (default: the frame's lower diagonal corner, slightly outside).
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    from: Option<Numbers>,
    /// Path end x,y,z (default: the opposite corner).
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true)]
    to: Option<Numbers>,
    /// Samples along the path.
    #[arg(long, default_value_t = 541)]
    samples: usize,
    /// String whose tension to plot (default: the one that changes most at the first λ).
    #[arg(long)]
    string: Option<usize>,
    #[command(flatten)]
    output: Output,
}

/// A comma-separated list of finite numbers, as one argument.
#[derive(Debug, Clone)]
pub struct Numbers(Vec<f64>);

impl std::ops::Deref for Numbers {
    type Target = [f64];

    fn deref(&self) -> &[f64] {
        &self.0
    }
}

pub fn parse_numbers(text: &str) -> Result<Numbers, String> {
    text.split(',')
        .map(parse_number)
        .collect::<Result<_, _>>()
        .map(Numbers)
}

fn parse_number(text: &str) -> Result<f64, String> {
    let value: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{:?} is not a number", text.trim()))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(format!("{:?} is not a finite number", text.trim()))
    }
}

/// Three numbers as a vector; a usage error naming `what` otherwise.
pub fn vec3(values: &[f64], what: &str) -> Result<DVec3, Failure> {
    match values {
        [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(Failure::usage(format!(
            "{what} needs 3 numbers x,y,z, got {}",
            values.len()
        ))),
    }
}

fn quat(values: &[f64], what: &str) -> Result<DQuat, Failure> {
    let [w, x, y, z] = values else {
        return Err(Failure::usage(format!(
            "{what} needs 4 numbers w,x,y,z, got {}",
            values.len()
        )));
    };
    let q = quat_from_wxyz([*w, *x, *y, *z]);
    if !q.is_finite() || (q.length() - 1.0).abs() > 1e-6 {
        return Err(Failure::usage(format!(
            "{what} must be a unit quaternion; its norm is {}",
            q.length()
        )));
    }
    Ok(q.normalize())
}

pub fn resolve(catalog: &Catalog, mech: &str) -> Result<Mechanism, Failure> {
    catalog.resolve(mech).map_err(|e| load_failure(mech, &e))
}

/// A name that matches no installed mechanism is a usage error (2); a file that exists but
/// does not load is a failure (1).
fn load_failure(mech: &str, error: &Diagnostics) -> Failure {
    Failure::diagnostics(if Catalog::is_name(mech) { 2 } else { 1 }, error)
}

pub fn print(output: &Output, value: Value, text: String) {
    if output.json {
        println!("{value}");
    } else {
        print!("{text}");
    }
}

/// Run one `mechanism` subcommand.
pub fn run(command: Command, catalog: &Catalog) -> Result<(), Failure> {
    match command {
        Command::List(output) => list(catalog, &output),
        Command::Inspect(args) => inspect(catalog, &args),
        Command::Pose(args) => pose(catalog, &args),
        Command::Tension(args) => tension(catalog, &args),
        Command::Workspace(args) => workspace(catalog, &args),
        Command::Sweep(args) => sweep(catalog, &args),
    }
}

fn list(catalog: &Catalog, output: &Output) -> Result<(), Failure> {
    let entries = catalog.entries();
    for error in entries.iter().filter_map(|e| e.mechanism.as_ref().err()) {
        eprintln!("{error}");
    }
    let report = mechanism_report::list(&entries);
    print(output, report.json, report.text);
    Ok(())
}

fn inspect(catalog: &Catalog, args: &Inspect) -> Result<(), Failure> {
    let mechanism = catalog.resolve(&args.mech).map_err(|e| {
        if args.output.json {
            let errors: Vec<_> = e.diagnostics.iter().map(|d| d.to_string()).collect();
            println!("{}", json!({"valid": false, "diagnostics": errors}));
        }
        load_failure(&args.mech, &e)
    })?;
    let report = mechanism_report::inspect(&mechanism);
    print(&args.output, report.json, report.text);
    Ok(())
}

fn pose(catalog: &Catalog, args: &PoseArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    if !args.from.is_empty() && args.from.len() != 1 && args.from.len() != m.effectors.len() {
        return Err(Failure::usage(format!(
            "--from must be given once, or once per effector ({})",
            m.effectors.len()
        )));
    }
    let once = args.from.first().filter(|_| args.from.len() == 1);
    let starts = m
        .effectors
        .iter()
        .enumerate()
        .map(|(index, e)| start_pose(e.calibration, args.from.get(index).or(once)))
        .collect::<Result<Vec<_>, _>>()?;
    let report = mechanism_report::pose(&m, &args.lengths, &starts, args.iterations).map_err(
        |e| match e {
            PoseError::NoFit(_) => Failure::failed(e),
            _ => Failure::usage(e),
        },
    )?;
    print(&args.output, report.json, report.text);
    Ok(())
}

/// Where a pose search starts: `start` (a calibration pose), moved to `from` if given.
fn start_pose(mut start: Pose, from: Option<&Numbers>) -> Result<Pose, Failure> {
    let Some(from) = from else { return Ok(start) };
    match from.len() {
        3 => start.position = vec3(from, "--from")?,
        7 => {
            start.position = vec3(&from[..3], "--from")?;
            start.orientation = quat(&from[3..], "--from orientation")?;
        }
        n => {
            return Err(Failure::usage(format!(
                "--from needs x,y,z or x,y,z,w,x,y,z, got {n} numbers"
            )));
        }
    }
    Ok(start)
}

fn tension(catalog: &Catalog, args: &TensionArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    let index = effector_index(&m, args.effector.as_deref()).map_err(Failure::usage)?;
    let effector = &m.effectors[index];
    let position = vec3(&args.position, "--position")?;
    let force = vec3(&args.force, "--force")?;
    if effector.dof == Dof::Three && (args.orientation.is_some() || args.torque.is_some()) {
        return Err(Failure::usage(format!(
            "effector {} is a point grip (3 DOF): --orientation and --torque do not apply",
            effector.name
        )));
    }
    let orientation = match &args.orientation {
        Some(q) => quat(q, "--orientation")?,
        None => DQuat::IDENTITY,
    };
    let torque = match &args.torque {
        Some(t) => vec3(t, "--torque")?,
        None => DVec3::ZERO,
    };
    if let Some(e) = args.lambda.and_then(|l| Name::Lambda.check(l).err()) {
        return Err(Failure::usage(format!("--lambda: {e}")));
    }
    let pose = Pose {
        position,
        orientation,
    };
    let wrench = Wrench { force, torque };
    let report = mechanism_report::tension(&m, index, &pose, &wrench, args.lambda);
    print(&args.output, report.json, report.text);
    Ok(())
}

fn workspace(catalog: &Catalog, args: &WorkspaceArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    let index = effector_index(&m, args.effector.as_deref()).map_err(Failure::usage)?;
    if !(2..=2000).contains(&args.resolution) {
        return Err(Failure::usage("--resolution must be between 2 and 2000"));
    }
    let mut centre = m.effectors[index].calibration;
    if let Some(at) = &args.at {
        centre.position = vec3(at, "--at")?;
    }
    let axes = match args.plane {
        Plane::Xy => (0, 1),
        Plane::Xz => (0, 2),
        Plane::Yz => (1, 2),
    };
    let report = mechanism_report::workspace(&m, index, centre, axes, args.resolution);
    show(&args.output, report, &args.plot)
}

fn sweep(catalog: &Catalog, args: &SweepArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    let index = effector_index(&m, args.effector.as_deref()).map_err(Failure::usage)?;
    let force = vec3(&args.force, "--force")?;
    // The tensions of every sample for every λ are held and plotted.
    if args.lambdas.is_empty() || args.lambdas.len() > 16 {
        return Err(Failure::usage("--lambdas takes one to 16 values"));
    }
    if let Some(e) = args
        .lambdas
        .iter()
        .find_map(|&l| Name::Lambda.check(l).err())
    {
        return Err(Failure::usage(format!("--lambdas: {e}")));
    }
    if !(2..=100_000).contains(&args.samples) {
        return Err(Failure::usage("--samples must be between 2 and 100000"));
    }
    let from = args
        .from
        .as_deref()
        .map(|v| vec3(v, "--from"))
        .transpose()?;
    let to = args.to.as_deref().map(|v| vec3(v, "--to")).transpose()?;
    let count = m.kinematics(index).count();
    if let Some(s) = args.string.filter(|&s| s >= count) {
        return Err(Failure::usage(format!(
            "--string {s}: the effector has strings 0..{}",
            count - 1
        )));
    }
    let request = TensionSweep {
        force,
        lambdas: &args.lambdas,
        from,
        to,
        samples: args.samples,
        string: args.string,
    };
    let report = mechanism_report::sweep(&m, index, &request);
    show(&args.output, report, &args.plot)
}

/// Write `report`'s figure to `plot` and print it, the text after the line's "wrote PATH: ".
fn show(output: &Output, mut report: Report, plot: &Path) -> Result<(), Failure> {
    save_canvas(&report.figure(), plot)?;
    report.json["plot"] = json!(plot);
    let text = format!("wrote {}: {}", plot.display(), report.text);
    print(output, report.json, text);
    Ok(())
}

/// Draw `chart` to `path` as PNG.
pub fn save(chart: &Chart, path: &Path) -> Result<(), Failure> {
    save_canvas(&chart.render(), path)
}

/// Write `canvas` to `path` as PNG.
pub fn save_canvas(canvas: &Canvas, path: &Path) -> Result<(), Failure> {
    canvas
        .save_png(path)
        .map_err(|e| Failure::failed(format!("cannot write {}: {e}", path.display())))
}

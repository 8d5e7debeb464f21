//! `hapticctl mechanism …`: list, inspect, pose, tension, workspace and sweep.

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand, ValueEnum};
use glam::{DQuat, DVec3};
use hapticctl::plot::{Canvas, Cells, Chart, PALETTE, Series};
use hapticd_config::catalog::Catalog;
use hapticd_core::diagnostics::Diagnostics;
use hapticd_core::diagnostics::Number;
use hapticd_core::kinematics::{Dof, Pose, Wrench, quat_from_wxyz, quat_to_wxyz};
use hapticd_core::mechanism::analysis::{region_slice, tension_sweep};
use hapticd_core::mechanism::{MAX_EXTENT, Mechanism};
use hapticd_core::parameters::Name;
use hapticd_core::solver::closure::is_force_closed;
use hapticd_core::solver::geometry::StringGeometry;
use hapticd_core::solver::pose::PoseSolver;
use hapticd_core::solver::tension::TensionSettings;
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

fn effector_index(mechanism: &Mechanism, name: Option<&str>) -> Result<usize, Failure> {
    let Some(name) = name else { return Ok(0) };
    mechanism.effector_index(name).ok_or_else(|| {
        let names: Vec<_> = mechanism
            .effectors
            .iter()
            .map(|e| e.name.as_str())
            .collect();
        Failure::usage(format!(
            "mechanism {} has no effector {name:?} (effectors: {})",
            mechanism.name,
            names.join(", ")
        ))
    })
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

fn kind(mechanism: &Mechanism) -> &'static str {
    if mechanism.source.extension().is_some_and(|e| e == "so") {
        "plugin"
    } else {
        "descriptor"
    }
}

fn summary_json(m: &Mechanism) -> Value {
    json!({
        "name": m.name,
        "description": m.description,
        "path": m.source,
        "kind": kind(m),
        "effectors": m.effectors.iter().map(|e| json!({
            "name": e.name,
            "dof": e.dof.count(),
            "strings": e.strings.len(),
        })).collect::<Vec<_>>(),
        "strings": m.strings.len(),
    })
}

fn list(catalog: &Catalog, output: &Output) -> Result<(), Failure> {
    let entries = catalog.entries();
    let mut rows = Vec::new();
    let mut text = String::new();
    for entry in &entries {
        match &entry.mechanism {
            Ok(m) => {
                let mut row = summary_json(m);
                row["shadowed"] = json!(entry.shadowed);
                rows.push(row);
                let effectors: Vec<_> = m
                    .effectors
                    .iter()
                    .map(|e| format!("{}({}dof,{}s)", e.name, e.dof.count(), e.strings.len()))
                    .collect();
                text += &format!(
                    "{:<16} {:<10} {:<28} {}{}\n",
                    m.name,
                    kind(m),
                    effectors.join(" "),
                    m.source.display(),
                    if entry.shadowed { " (shadowed)" } else { "" }
                );
            }
            Err(e) => {
                rows.push(json!({"path": entry.path, "error": e.to_string()}));
                eprintln!("{e}");
            }
        }
    }
    print(output, Value::Array(rows), text);
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
    let m = &mechanism;
    let mut value = summary_json(m);
    value["valid"] = json!(true);
    value["lambda"] = json!(m.tension.lambda);
    value["torque_weight"] = json!(m.tension.torque_weight);
    value["warnings"] = json!(m.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>());
    let mut text = format!(
        "{} ({}): {}\n  source: {}\n  tension: λ = {}, torque weight = {}\n",
        m.name,
        kind(m),
        m.description,
        m.source.display(),
        m.tension.lambda,
        m.tension.torque_weight
    );
    let mut effectors = Vec::new();
    for (index, e) in m.effectors.iter().enumerate() {
        let geometry = StringGeometry::at(&m.kinematics(index), &e.calibration);
        let closed = is_force_closed(&geometry);
        text += &format!(
            "  effector {}: {} DOF, {} strings; calibration at {:?}, {}\n",
            e.name,
            e.dof.count(),
            e.strings.len(),
            e.calibration.position.to_array(),
            if closed {
                "inside the complete region"
            } else {
                "outside the complete region"
            }
        );
        let strings: Vec<_> = e
            .strings
            .iter()
            .map(|&s| {
                let s = &m.strings[s];
                text += &format!(
                    "    string: motor {:?} knot {:?}  {:.4e} m/pulse  {} V/N  {}–{} N\n",
                    s.motor.to_array(),
                    s.knot.to_array(),
                    s.metres_per_pulse,
                    s.volts_per_newton,
                    s.tension_min,
                    s.tension_max
                );
                json!({
                    "motor": s.motor.to_array(),
                    "knot": s.knot.to_array(),
                    "metres_per_pulse": s.metres_per_pulse,
                    "volts_per_newton": s.volts_per_newton,
                    "tension_min": s.tension_min,
                    "tension_max": s.tension_max,
                })
            })
            .collect();
        effectors.push(json!({
            "name": e.name,
            "dof": e.dof.count(),
            "calibration": {
                "position": e.calibration.position.to_array(),
                "orientation": quat_to_wxyz(e.calibration.orientation),
            },
            "force_closed_at_calibration": closed,
            "strings": strings,
        }));
    }
    value["effectors"] = Value::Array(effectors);
    for w in &m.warnings {
        text += &format!("{w}\n");
    }
    text += "  valid\n";
    print(&args.output, value, text);
    Ok(())
}

fn pose(catalog: &Catalog, args: &PoseArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    if args.lengths.len() != m.strings.len() {
        return Err(Failure::usage(format!(
            "mechanism {} has {} strings, but {} lengths were given",
            m.name,
            m.strings.len(),
            args.lengths.len()
        )));
    }
    // No string of a frame within 10 m of its centre is longer than its diagonal.
    let longest = 2.0 * MAX_EXTENT * 3f64.sqrt();
    if let Some(bad) = args.lengths.iter().find(|l| !(0.0..=longest).contains(*l)) {
        return Err(Failure::usage(format!(
            "string lengths must be between 0 and {longest:.1} m, not {}",
            Number(*bad)
        )));
    }
    if !args.from.is_empty() && args.from.len() != 1 && args.from.len() != m.effectors.len() {
        return Err(Failure::usage(format!(
            "--from must be given once, or once per effector ({})",
            m.effectors.len()
        )));
    }
    let mut results = Vec::new();
    let (mut squared, mut iterations) = (0.0, 0);
    let mut text = String::new();
    for (index, effector) in m.effectors.iter().enumerate() {
        let mut start = effector.calibration;
        if let Some(from) = args
            .from
            .get(index)
            .or(args.from.first().filter(|_| args.from.len() == 1))
        {
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
        }
        let measured: Vec<f64> = effector.strings.iter().map(|&s| args.lengths[s]).collect();
        let mut solver = PoseSolver::new(m.kinematics(index), start);
        let estimate = solver.solve(&measured, args.iterations);
        let pose = estimate.pose;
        if !(pose.position.is_finite() && pose.orientation.is_normalized()) {
            return Err(Failure::failed(format!(
                "{}: these lengths fit no pose (the search left the frame)",
                effector.name
            )));
        }
        squared += estimate.residual.powi(2) * measured.len() as f64;
        iterations = iterations.max(estimate.iterations);
        let orientation = quat_to_wxyz(estimate.pose.orientation);
        text += &format!(
            "{}: position {:?} m, orientation (w,x,y,z) {:?}\n",
            effector.name,
            estimate.pose.position.to_array(),
            orientation
        );
        results.push(json!({
            "name": effector.name,
            "position": estimate.pose.position.to_array(),
            "orientation": orientation,
        }));
    }
    let residual = (squared / m.strings.len() as f64).sqrt();
    text += &format!("iterations: {iterations}, residual: {residual:.3e} m (rms)\n");
    print(
        &args.output,
        json!({"effectors": results, "iterations": iterations, "residual": residual}),
        text,
    );
    Ok(())
}

fn tension(catalog: &Catalog, args: &TensionArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    let index = effector_index(&m, args.effector.as_deref())?;
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
    let geometry = StringGeometry::at(
        &m.kinematics(index),
        &Pose {
            position,
            orientation,
        },
    );
    let mut solver = m.tension_solver(index);
    if let Some(lambda) = args.lambda {
        if let Err(e) = Name::Lambda.check(lambda) {
            return Err(Failure::usage(format!("--lambda: {e}")));
        }
        solver.set_settings(TensionSettings {
            lambda,
            torque_weight: 1.0,
        });
    }
    let solution = solver.solve(&geometry, &Wrench { force, torque });
    let wrench = &solution.wrench.to_array()[..effector.dof.count()];
    let mut text = String::new();
    for (i, t) in solution.tensions().iter().enumerate() {
        text += &format!("string {i}: {t:.6} N\n");
    }
    text += &format!("wrench: {wrench:?}\n");
    print(
        &args.output,
        json!({"tensions": solution.tensions(), "wrench": wrench, "force_closed": is_force_closed(&geometry)}),
        text,
    );
    Ok(())
}

fn axis_name(axis: usize) -> &'static str {
    ["x", "y", "z"][axis]
}

fn workspace(catalog: &Catalog, args: &WorkspaceArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    let index = effector_index(&m, args.effector.as_deref())?;
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
    let slice = region_slice(&m, index, centre, axes, args.resolution);
    let complete = [170, 210, 240];
    let partial = [235, 235, 235];
    let mut motors = Vec::new();
    let arm = slice.cell * 3.0;
    for motor in m.kinematics(index).motors() {
        let (u, v) = (motor[axes.0], motor[axes.1]);
        motors.extend([(u - arm, v - arm), (u + arm, v + arm), (f64::NAN, f64::NAN)]);
        motors.extend([(u - arm, v + arm), (u + arm, v - arm), (f64::NAN, f64::NAN)]);
    }
    let fixed = 3 - axes.0 - axes.1;
    let chart = Chart {
        title: format!(
            "{}: complete-presentation region, {} = {:.3} m",
            m.name,
            axis_name(fixed),
            centre.position[fixed]
        ),
        x_label: format!("{} [m]", axis_name(axes.0)),
        y_label: format!("{} [m]", axis_name(axes.1)),
        series: vec![Series {
            label: "motors (projected)".into(),
            points: motors,
            color: PALETTE[1],
        }],
        cells: Some(Cells {
            x: (slice.origin.0, slice.cell),
            y: (slice.origin.1, slice.cell),
            columns: slice.columns,
            colors: slice
                .closed
                .iter()
                .map(|&c| if c { complete } else { partial })
                .collect(),
            legend: vec![
                ("complete (force closure)".into(), complete),
                ("partial".into(), partial),
            ],
        }),
        equal_aspect: true,
        ..Chart::default()
    };
    save(&chart, &args.plot)?;
    let fraction = slice.closed_fraction();
    print(
        &args.output,
        json!({"plot": args.plot, "complete_fraction": fraction}),
        format!(
            "wrote {}: {:.1} % of the slice is in the complete region\n",
            args.plot.display(),
            100.0 * fraction
        ),
    );
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

fn sweep(catalog: &Catalog, args: &SweepArgs) -> Result<(), Failure> {
    let m = resolve(catalog, &args.mech)?;
    let index = effector_index(&m, args.effector.as_deref())?;
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
    let kinematics = m.kinematics(index);
    let corner = kinematics
        .motors()
        .iter()
        .fold(DVec3::ZERO, |acc, m| acc.max(m.abs()))
        * 1.02;
    let from = match &args.from {
        Some(v) => vec3(v, "--from")?,
        None => -corner,
    };
    let to = match &args.to {
        Some(v) => vec3(v, "--to")?,
        None => corner,
    };
    let orientation = m.effectors[index].calibration.orientation;
    let wrench = Wrench::force(force);
    let result = tension_sweep(
        &m,
        index,
        (from, to),
        orientation,
        &wrench,
        &args.lambdas,
        args.samples,
    );
    let count = kinematics.count();
    let string = match args.string {
        Some(s) if s < count => s,
        Some(s) => {
            return Err(Failure::usage(format!(
                "--string {s}: the effector has strings 0..{}",
                count - 1
            )));
        }
        None => (0..count)
            .max_by(|&a, &b| {
                let range = |i: usize| {
                    let t = result.tensions[0].iter().map(|s| s[i]);
                    t.clone().fold(f64::MIN, f64::max) - t.fold(f64::MAX, f64::min)
                };
                range(a).total_cmp(&range(b))
            })
            .unwrap_or(0),
    };
    // Abscissa: the first coordinate that changes along the path (x for the diagonal).
    let axis = (0..3)
        .find(|&a| (to[a] - from[a]).abs() > 1e-12)
        .unwrap_or(0);
    let xs: Vec<f64> = result.positions.iter().map(|p| p[axis]).collect();
    let tmax = m.effectors[index]
        .strings
        .iter()
        .map(|&s| m.strings[s].tension_max)
        .fold(0.0, f64::max);
    let series = result
        .tensions
        .iter()
        .zip(args.lambdas.iter())
        .enumerate()
        .map(|(i, (per_sample, lambda))| Series {
            label: format!("λ = {lambda}"),
            points: xs
                .iter()
                .zip(per_sample)
                .map(|(&x, t)| (x, t[string]))
                .collect(),
            color: PALETTE[i % PALETTE.len()],
        })
        .collect();
    let step = (xs[xs.len() - 1] - xs[0]) / (xs.len() - 1) as f64;
    let band = [215, 232, 245];
    let chart = Chart {
        title: format!(
            "{}: tension of string {string} for f = ({}, {}, {}) N",
            m.name, force.x, force.y, force.z
        ),
        x_label: format!(
            "grip {} along the path [m] (shaded: complete region)",
            axis_name(axis)
        ),
        y_label: "tension [N]".into(),
        series,
        cells: Some(Cells {
            x: (xs[0] - step / 2.0, step),
            y: (0.0, tmax * 1.05),
            columns: xs.len(),
            colors: result
                .closed
                .iter()
                .map(|&c| if c { band } else { [255, 255, 255] })
                .collect(),
            legend: Vec::new(),
        }),
        y_range: Some((0.0, tmax * 1.05)),
        ..Chart::default()
    };
    save(&chart, &args.plot)?;
    let jumps = result.largest_jumps();
    let mut text = format!("wrote {}: string {string}\n", args.plot.display());
    for (lambda, jump) in args.lambdas.iter().zip(&jumps) {
        text += &format!("  λ = {lambda}: largest tension step between samples {jump:.3} N\n");
    }
    print(
        &args.output,
        json!({
            "plot": args.plot,
            "string": string,
            "lambdas": &*args.lambdas,
            "largest_jump": jumps,
            "samples": args.samples,
        }),
        text,
    );
    Ok(())
}

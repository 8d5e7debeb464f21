//! Studies of mechanisms (`hapticctl mechanism …`), each as a [`Report`]: the installed
//! mechanisms, one mechanism's summary, the poses that fit measured string lengths, the
//! tensions that present a wrench, a slice of the complete-presentation region and the
//! tensions along a path for several λ (thesis Fig. 3.15).

use glam::DVec3;
use hapticd_config::catalog::Entry;
use hapticd_core::diagnostics::Number;
use hapticd_core::kinematics::{Pose, Wrench, quat_to_wxyz};
use hapticd_core::mechanism::analysis::{Sweep, region_slice, tension_sweep};
use hapticd_core::mechanism::{MAX_EXTENT, Mechanism};
use hapticd_core::solver::closure::is_force_closed;
use hapticd_core::solver::geometry::StringGeometry;
use hapticd_core::solver::pose::PoseSolver;
use hapticd_core::solver::tension::TensionSettings;
use serde_json::{Value, json};

use crate::plot::{Cells, Chart, PALETTE, Series};
use crate::report::Report;

/// No effector of a mechanism has the name asked for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NoEffector {
    /// The mechanism's name.
    pub mechanism: String,
    /// The name asked for.
    pub name: String,
    /// Its effectors' names.
    pub effectors: Vec<String>,
}

impl std::fmt::Display for NoEffector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "mechanism {} has no effector {:?} (effectors: {})",
            self.mechanism,
            self.name,
            self.effectors.join(", ")
        )
    }
}

impl std::error::Error for NoEffector {}

/// Why string lengths gave no pose.
#[derive(Debug, Clone, PartialEq)]
pub enum PoseError {
    /// Not one length per string of the mechanism.
    Count {
        /// The mechanism's name.
        mechanism: String,
        /// Its strings.
        strings: usize,
        /// The lengths given.
        lengths: usize,
    },
    /// A length that is negative or longer than the diagonal of the largest frame allowed.
    Length(f64),
    /// The search of the named effector left the frame: no pose fits.
    NoFit(String),
}

impl std::fmt::Display for PoseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PoseError::Count {
                mechanism,
                strings,
                lengths,
            } => write!(
                f,
                "mechanism {mechanism} has {strings} strings, but {lengths} lengths were given"
            ),
            PoseError::Length(length) => write!(
                f,
                "string lengths must be between 0 and {:.1} m, not {}",
                longest(),
                Number(*length)
            ),
            PoseError::NoFit(effector) => write!(
                f,
                "{effector}: these lengths fit no pose (the search left the frame)"
            ),
        }
    }
}

impl std::error::Error for PoseError {}

/// The longest a string can be, metres: no string of a frame within [`MAX_EXTENT`] of its
/// centre is longer than its diagonal.
fn longest() -> f64 {
    2.0 * MAX_EXTENT * 3f64.sqrt()
}

/// What a tension sweep covers and shows (thesis Fig. 3.15).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TensionSweep<'a> {
    /// Force presented along the path, newtons.
    pub force: DVec3,
    /// λ values compared, one curve each.
    pub lambdas: &'a [f64],
    /// Path start (`None`: the frame's lower diagonal corner, slightly outside).
    pub from: Option<DVec3>,
    /// Path end (`None`: the opposite corner).
    pub to: Option<DVec3>,
    /// Samples along the path.
    pub samples: usize,
    /// String whose tension is drawn (`None`: the one that changes most at the first λ).
    pub string: Option<usize>,
}

/// Whether `mechanism` came from a plugin or a descriptor.
fn kind(mechanism: &Mechanism) -> &'static str {
    if mechanism.source.extension().is_some_and(|e| e == "so") {
        "plugin"
    } else {
        "descriptor"
    }
}

/// What `list` and `inspect` both say of `m`, as JSON.
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

/// The name of coordinate `axis` (0, 1 or 2).
fn axis_name(axis: usize) -> &'static str {
    ["x", "y", "z"][axis]
}

/// The index of `m`'s effector called `name`; without a name, its first.
pub fn effector_index(m: &Mechanism, name: Option<&str>) -> Result<usize, NoEffector> {
    let Some(name) = name else { return Ok(0) };
    m.effector_index(name).ok_or_else(|| NoEffector {
        mechanism: m.name.clone(),
        name: name.to_string(),
        effectors: m.effectors.iter().map(|e| e.name.clone()).collect(),
    })
}

/// The catalog's `entries`, a line and a row each; an entry that does not load has a row
/// with its error and no line (its error is the caller's to show).
pub fn list(entries: &[Entry]) -> Report {
    let mut rows = Vec::new();
    let mut text = String::new();
    for entry in entries {
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
            Err(e) => rows.push(json!({"path": entry.path, "error": e.to_string()})),
        }
    }
    Report {
        text,
        json: Value::Array(rows),
        charts: Vec::new(),
    }
}

/// `m`'s summary: its tension settings, every effector with its strings and whether its
/// calibration pose is force-closed, and its warnings.
pub fn inspect(m: &Mechanism) -> Report {
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
    let effectors: Vec<Value> = (0..m.effectors.len())
        .map(|index| inspect_effector(m, index, &mut text))
        .collect();
    value["effectors"] = Value::Array(effectors);
    for w in &m.warnings {
        text += &format!("{w}\n");
    }
    text += "  valid\n";
    Report {
        text,
        json: value,
        charts: Vec::new(),
    }
}

/// Effector `index` of `m`: its lines added to `text`, its JSON returned.
fn inspect_effector(m: &Mechanism, index: usize, text: &mut String) -> Value {
    let e = &m.effectors[index];
    let geometry = StringGeometry::at(&m.kinematics(index), &e.calibration);
    let closed = is_force_closed(&geometry);
    *text += &format!(
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
            *text += &format!(
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
    json!({
        "name": e.name,
        "dof": e.dof.count(),
        "calibration": {
            "position": e.calibration.position.to_array(),
            "orientation": quat_to_wxyz(e.calibration.orientation),
        },
        "force_closed_at_calibration": closed,
        "strings": strings,
    })
}

/// The pose of every effector of `m` that fits `lengths` (one per string, in mechanism
/// order), each search starting from its effector's entry in `starts` and taking at most
/// `iterations` Gauss–Newton steps, with the rms residual over all strings.
pub fn pose(
    m: &Mechanism,
    lengths: &[f64],
    starts: &[Pose],
    iterations: usize,
) -> Result<Report, PoseError> {
    if lengths.len() != m.strings.len() {
        return Err(PoseError::Count {
            mechanism: m.name.clone(),
            strings: m.strings.len(),
            lengths: lengths.len(),
        });
    }
    if let Some(&bad) = lengths.iter().find(|l| !(0.0..=longest()).contains(*l)) {
        return Err(PoseError::Length(bad));
    }
    let mut results = Vec::new();
    let (mut squared, mut taken) = (0.0, 0);
    let mut text = String::new();
    for (index, (effector, start)) in m.effectors.iter().zip(starts).enumerate() {
        let measured: Vec<f64> = effector.strings.iter().map(|&s| lengths[s]).collect();
        let mut solver = PoseSolver::new(m.kinematics(index), *start);
        let estimate = solver.solve(&measured, iterations);
        let pose = estimate.pose;
        if !(pose.position.is_finite() && pose.orientation.is_normalized()) {
            return Err(PoseError::NoFit(effector.name.clone()));
        }
        squared += estimate.residual.powi(2) * measured.len() as f64;
        taken = taken.max(estimate.iterations);
        let orientation = quat_to_wxyz(pose.orientation);
        text += &format!(
            "{}: position {:?} m, orientation (w,x,y,z) {:?}\n",
            effector.name,
            pose.position.to_array(),
            orientation
        );
        results.push(json!({
            "name": effector.name,
            "position": pose.position.to_array(),
            "orientation": orientation,
        }));
    }
    let residual = (squared / m.strings.len() as f64).sqrt();
    text += &format!("iterations: {taken}, residual: {residual:.3e} m (rms)\n");
    Ok(Report {
        text,
        json: json!({"effectors": results, "iterations": taken, "residual": residual}),
        charts: Vec::new(),
    })
}

/// The tensions of effector `index`'s strings that present `wrench` at `pose`, solved with
/// `m`'s own settings or, given `lambda`, eq. 3.16 as written with every wrench component
/// weighted 1; with the wrench they make and whether `pose` is force-closed.
pub fn tension(
    m: &Mechanism,
    index: usize,
    pose: &Pose,
    wrench: &Wrench,
    lambda: Option<f64>,
) -> Report {
    let geometry = StringGeometry::at(&m.kinematics(index), pose);
    let mut solver = m.tension_solver(index);
    if let Some(lambda) = lambda {
        solver.set_settings(TensionSettings {
            lambda,
            torque_weight: 1.0,
        });
    }
    let solution = solver.solve(&geometry, wrench);
    let made = &solution.wrench.to_array()[..m.effectors[index].dof.count()];
    let mut text = String::new();
    for (i, t) in solution.tensions().iter().enumerate() {
        text += &format!("string {i}: {t:.6} N\n");
    }
    text += &format!("wrench: {made:?}\n");
    Report {
        text,
        json: json!({"tensions": solution.tensions(), "wrench": made, "force_closed": is_force_closed(&geometry)}),
        charts: Vec::new(),
    }
}

/// The slice through `centre` spanned by `axes` (0 = x, 1 = y, 2 = z; horizontal, then
/// vertical) of effector `index`'s complete-presentation region, `resolution` cells a side:
/// a map with the motors projected onto it, and the fraction of the slice in the region.
pub fn workspace(
    m: &Mechanism,
    index: usize,
    centre: Pose,
    axes: (usize, usize),
    resolution: usize,
) -> Report {
    let slice = region_slice(m, index, centre, axes, resolution);
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
    let fraction = slice.closed_fraction();
    Report {
        text: format!(
            "{:.1} % of the slice is in the complete region\n",
            100.0 * fraction
        ),
        json: json!({ "complete_fraction": fraction }),
        charts: vec![chart],
    }
}

/// The tensions of effector `index`'s strings along the path of `request`, for each of its
/// λ, with the grip at its calibration orientation: one string's tension in a chart, the
/// complete region shaded, and the largest step between samples per λ.
pub fn sweep(m: &Mechanism, index: usize, request: &TensionSweep<'_>) -> Report {
    let kinematics = m.kinematics(index);
    let corner = kinematics
        .motors()
        .iter()
        .fold(DVec3::ZERO, |acc, motor| acc.max(motor.abs()))
        * 1.02;
    let path = (
        request.from.unwrap_or(-corner),
        request.to.unwrap_or(corner),
    );
    let result = tension_sweep(
        m,
        index,
        path,
        m.effectors[index].calibration.orientation,
        &Wrench::force(request.force),
        request.lambdas,
        request.samples,
    );
    let string = request
        .string
        .unwrap_or_else(|| busiest_string(&result, kinematics.count()));
    let chart = sweep_chart(m, index, request, &result, string, path);
    let jumps = result.largest_jumps();
    let mut text = format!("string {string}\n");
    for (lambda, jump) in request.lambdas.iter().zip(&jumps) {
        text += &format!("  λ = {lambda}: largest tension step between samples {jump:.3} N\n");
    }
    Report {
        text,
        json: json!({
            "string": string,
            "lambdas": request.lambdas,
            "largest_jump": jumps,
            "samples": request.samples,
        }),
        charts: vec![chart],
    }
}

/// Of strings `0..count`, the one whose tension changes most along `sweep` at its first λ.
fn busiest_string(sweep: &Sweep, count: usize) -> usize {
    (0..count)
        .max_by(|&a, &b| {
            let range = |i: usize| {
                let t = sweep.tensions[0].iter().map(|s| s[i]);
                t.clone().fold(f64::MIN, f64::max) - t.fold(f64::MAX, f64::min)
            };
            range(a).total_cmp(&range(b))
        })
        .unwrap_or(0)
}

/// String `string`'s tension in `result` for each λ of `request`, over the grip's first
/// coordinate that changes along `(from, to)` (x for the diagonal), the complete region
/// shaded, up to the effector's largest tension limit.
fn sweep_chart(
    m: &Mechanism,
    index: usize,
    request: &TensionSweep<'_>,
    result: &Sweep,
    string: usize,
    (from, to): (DVec3, DVec3),
) -> Chart {
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
        .zip(request.lambdas)
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
    let force = request.force;
    Chart {
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
    }
}

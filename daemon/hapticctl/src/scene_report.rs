//! A scene file run offline (`hapticctl scene run`), reported: the runs of
//! [`crate::scene_run`] with what they write as they go (every step's bodies to a CSV file,
//! frames to PNG files), then the bodies where the runs left them, the forces felt, the
//! energy of a penalty world, and a chart of the quantity traced.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3};
use hapticd_core::kinematics::{Wrench, quat_to_wxyz};
use hapticd_device::sim::hand::HandTrack;
use hapticd_physics::joint::JointState;
use hapticd_physics::scene::{PenaltyScene, RapierScene};
use hapticd_physics::soft::SoftPart;
use hapticd_physics::world::World;
use hapticd_rapier::world::RapierWorld;
use hapticd_render::scenery::Scenery;
use hapticd_render::shading::Shaded;
use serde_json::{Value, json};

use crate::multirate::Lockstep;
use crate::plot::{Chart, PALETTE, Series};
use crate::report::Report;
use crate::scene_run::{
    MultirateTick, MultirateTrace, PenaltyStep, PenaltyTrace, Quantity, RunError, angular_momentum,
    hand_pointers, trace_multirate, trace_penalty,
};
use crate::scenery::{DrawError, Frames};

/// Haptic ticks per second of a rapier scene's run: hapticd's default loop rate.
pub const HAPTIC_RATE: f64 = 1000.0;

/// Why what a run writes as it goes could not be written.
#[derive(Debug)]
pub enum OutputError {
    /// The CSV file cannot be created.
    Create {
        /// The file.
        path: PathBuf,
        /// Why not.
        error: std::io::Error,
    },
    /// A row cannot be written to the CSV file.
    Write {
        /// The file.
        path: PathBuf,
        /// Why not.
        error: std::io::Error,
    },
    /// A frame cannot be drawn or written.
    Frame(DrawError),
}

impl std::fmt::Display for OutputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OutputError::Create { path, error } => {
                write!(f, "cannot create {}: {error}", path.display())
            }
            OutputError::Write { path, error } => {
                write!(f, "cannot write {}: {error}", path.display())
            }
            OutputError::Frame(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for OutputError {}

impl From<DrawError> for OutputError {
    fn from(e: DrawError) -> Self {
        OutputError::Frame(e)
    }
}

/// A CSV file written row by row as the run goes, so a failing disk is reported at once
/// and a long run needs no memory for its rows.
struct Recording {
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
}

impl Recording {
    fn create(path: &Path) -> Result<Self, OutputError> {
        let file = std::fs::File::create(path).map_err(|error| OutputError::Create {
            path: path.to_path_buf(),
            error,
        })?;
        let mut recording = Self {
            path: path.to_path_buf(),
            out: std::io::BufWriter::new(file),
        };
        recording.row(format_args!(
            "t,model,body,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz,joint,position,rate"
        ))?;
        Ok(recording)
    }

    /// The row of body `name` at `t` under `model`: position, orientation, velocity, spin.
    fn body(
        &mut self,
        t: f64,
        model: &str,
        name: &str,
        (p, orientation, v, w): (DVec3, DQuat, DVec3, DVec3),
    ) -> Result<(), OutputError> {
        let [qw, qx, qy, qz] = quat_to_wxyz(orientation);
        self.row(format_args!(
            "{t},{model},{name},{},{},{},{qw},{qx},{qy},{qz},{},{},{},{},{},{},,,",
            p.x, p.y, p.z, v.x, v.y, v.z, w.x, w.y, w.z
        ))
    }

    /// The row of joint `name` at `t` under `model`: its coordinate and rate (the body's
    /// columns empty).
    fn joint(
        &mut self,
        t: f64,
        model: &str,
        name: &str,
        state: JointState,
    ) -> Result<(), OutputError> {
        self.row(format_args!(
            "{t},{model},,,,,,,,,,,,,,,{name},{},{}",
            state.position, state.velocity
        ))
    }

    fn row(&mut self, row: std::fmt::Arguments) -> Result<(), OutputError> {
        writeln!(self.out, "{row}").map_err(|e| self.failed(e))
    }

    fn finish(mut self) -> Result<(), OutputError> {
        self.out.flush().map_err(|e| self.failed(e))
    }

    fn failed(&self, error: std::io::Error) -> OutputError {
        OutputError::Write {
            path: self.path.clone(),
            error,
        }
    }
}

/// What a run writes as it goes: every step's bodies to a CSV file, and frames to PNG files.
pub struct Outputs {
    record: Option<Recording>,
    frames: Option<Frames>,
}

impl Outputs {
    /// Rows into the CSV file `record`, frames into the directory `frames`, each if given.
    pub fn create(record: Option<&Path>, frames: Option<&Path>) -> Result<Self, OutputError> {
        let record = record.map(Recording::create).transpose()?;
        let frames = frames.map(Frames::create).transpose()?;
        Ok(Self { record, frames })
    }

    /// Write out what the CSV file still holds back.
    pub fn finish(self) -> Result<(), OutputError> {
        self.record.map_or(Ok(()), Recording::finish)
    }

    /// Write a penalty run's `step`; its frame too, drawn with `geometry`, if given.
    fn penalty_step(
        &mut self,
        step: &PenaltyStep,
        geometry: Option<&Shaded>,
    ) -> Result<(), OutputError> {
        if let (Some(frames), Some(geometry)) = (self.frames.as_mut(), geometry) {
            frames.offer(step.t, || {
                Scenery::of_geometry(geometry, &step.scene.poses(), &step.scene.all_corners())
            })?;
        }
        if let Some(record) = self.record.as_mut() {
            for &i in step.moving {
                let b = &step.scene.world.bodies[i];
                let state = (b.position, b.orientation, b.velocity, b.spin);
                record.body(step.t, step.model, &step.scene.names[i], state)?;
            }
            for part in &step.scene.soft {
                record.body(step.t, step.model, &part.name, soft_state(part))?;
            }
            for (name, state) in penalty_joints(&step.scene.world) {
                record.joint(step.t, step.model, name, state)?;
            }
        }
        Ok(())
    }

    /// Write a haptic tick of a run of `spec`, its frame drawn with `geometry`: the bodies
    /// where graphics show them between physics steps (6.5.2).
    fn multirate_tick(
        &mut self,
        spec: &RapierScene,
        geometry: &Shaded,
        tick: &MultirateTick,
    ) -> Result<(), OutputError> {
        let (t, run) = (tick.t, tick.run);
        if let Some(frames) = self.frames.as_mut() {
            frames.offer(t, || {
                let poses: Vec<_> = (0..spec.bodies.len()).map(|i| run.body(i).pose()).collect();
                let mut scenery = Scenery::of_geometry(geometry, &poses, &[]);
                let grips: Vec<DVec3> = tick.pointers.iter().map(|p| p.pose.position).collect();
                scenery.add_pointers(&run.proxies(), &grips);
                scenery
            })?;
        }
        if let Some(record) = self.record.as_mut() {
            for (i, name) in spec.names.iter().enumerate() {
                if !spec.bodies[i].fixed {
                    let b = run.body(i);
                    let state = (b.position, b.orientation, b.velocity, b.spin);
                    record.body(t, "rapier", name, state)?;
                }
            }
            for part in run.world.soft_bodies() {
                record.body(t, "rapier", &part.name, soft_state(part))?;
            }
            for (name, state) in rapier_joints(&run.world) {
                record.joint(t, "rapier", name, state)?;
            }
        }
        Ok(())
    }
}

/// Step the rapier scene `spec` for `duration` seconds with its haptic side at
/// [`HAPTIC_RATE`] as hapticd does, the physics clock `phase` seconds behind, its pointers
/// moved by `hands`, tracing `quantity` and writing every tick to `outputs`. The chart and
/// the rows follow the bodies between physics steps (6.5.2); the report gives where the
/// physics left them.
pub fn run_multirate(
    spec: &RapierScene,
    hands: &[HandTrack],
    quantity: Quantity,
    phase: f64,
    duration: f64,
    outputs: &mut Outputs,
) -> Result<Report, RunError<OutputError>> {
    let pointers = hand_pointers(hands, 0.0);
    let mut run = Lockstep::new(spec, &pointers, HAPTIC_RATE, phase);
    let geometry = Shaded::new(spec.geometry());
    let ticks = (duration * HAPTIC_RATE).round() as usize;
    let trace = trace_multirate(
        spec,
        &mut run,
        (quantity, hands),
        (HAPTIC_RATE, ticks),
        |tick| outputs.multirate_tick(spec, &geometry, tick),
    )?;
    Ok(multirate_report(spec, &run, trace, quantity, phase, ticks))
}

/// The report of `run` (of `spec`), traced as `trace` over `ticks` haptic ticks.
fn multirate_report(
    spec: &RapierScene,
    run: &Lockstep,
    trace: MultirateTrace,
    quantity: Quantity,
    phase: f64,
    ticks: usize,
) -> Report {
    let MultirateTrace {
        moving,
        curves,
        felt,
        peaks,
    } = trace;
    let series = curves
        .into_iter()
        .enumerate()
        .map(|(k, points)| Series {
            label: match quantity {
                Quantity::PointerForce => format!("pointer {}", k + 1),
                _ => spec.names[moving[k]].clone(),
            },
            points,
            color: PALETTE[k % PALETTE.len()],
        })
        .collect();
    let mut text = format!(
        "{} (rapier, {} Hz, {} feedback, phase {} s): {ticks} haptic ticks at {HAPTIC_RATE} Hz\n",
        spec.name,
        spec.rate,
        run.world.feedback().name(),
        phase
    );
    let mut bodies = Vec::new();
    for &i in &moving {
        let b = run.world.body(i);
        bodies.push(report_body(
            &mut text,
            &spec.names[i],
            b.position,
            b.orientation,
            b.velocity,
            b.spin,
        ));
    }
    bodies.extend(
        run.world
            .soft_bodies()
            .iter()
            .map(|p| report_soft(&mut text, p)),
    );
    let joints = report_joints(&mut text, rapier_joints(&run.world));
    let pointers = report_pointers(&mut text, &felt, &peaks);
    Report {
        text,
        json: json!({"scene": spec.name, "steps": ticks, "dt": 1.0 / HAPTIC_RATE, "runs": [{
            "model": "rapier",
            "rate": spec.rate,
            "phase": phase,
            "bodies": bodies,
            "joints": joints,
            "pointers": pointers,
        }]}),
        charts: vec![chart(&spec.name, quantity, series)],
    }
}

/// Step each of `scenes` (one scene file loaded once per contact model compared) `steps`
/// times by `dt`, its pointers moved by `hands`, tracing `quantity` and writing every step
/// to `outputs` (the frames of the first run alone: one picture per frame). The report
/// compares the runs; the warnings (to print before it) say where a run's step was too long
/// for its bodies or, with nothing driving the world, made energy.
pub fn run_penalty(
    scenes: Vec<PenaltyScene>,
    quantity: Quantity,
    hands: &[HandTrack],
    (dt, steps): (f64, usize),
    outputs: &mut Outputs,
) -> Result<(Report, Vec<String>), RunError<OutputError>> {
    let geometry = scenes.first().map(|s| Shaded::new(s.geometry()));
    let mut traces = Vec::with_capacity(scenes.len());
    for (k, scene) in scenes.into_iter().enumerate() {
        let drawn = geometry.as_ref().filter(|_| k == 0);
        let trace = trace_penalty(scene, quantity, hands, (dt, steps), |step| {
            outputs.penalty_step(step, drawn)
        })?;
        traces.push(trace);
    }
    Ok(penalty_report(
        &traces,
        quantity,
        hands.is_empty(),
        (dt, steps),
    ))
}

/// The report of the penalty runs `traces` of `steps` steps of `dt`, and its warnings;
/// `undriven` when no hand moved the pointers.
fn penalty_report(
    traces: &[PenaltyTrace],
    quantity: Quantity,
    undriven: bool,
    (dt, steps): (f64, usize),
) -> (Report, Vec<String>) {
    let name = traces
        .first()
        .map_or_else(String::new, |t| t.scene.name.clone());
    let mut series = Vec::new();
    for t in traces {
        for (points, &i) in t.curves.iter().zip(&t.plotted) {
            series.push(Series {
                label: format!("{} ({})", t.scene.names[i], t.model),
                points: points.clone(),
                color: PALETTE[series.len() % PALETTE.len()],
            });
        }
    }
    let mut text = String::new();
    let mut warnings = Vec::new();
    let mut runs = Vec::new();
    for t in traces {
        let _ = writeln!(
            text,
            "{name} ({} contact): {steps} steps of {dt} s",
            t.model
        );
        warnings.extend(penalty_warnings(t, &name, undriven, dt));
        runs.push(penalty_run(&mut text, t));
    }
    let report = Report {
        text,
        json: json!({"scene": name, "steps": steps, "dt": dt, "runs": runs}),
        charts: vec![chart(&name, quantity, series)],
    };
    (report, warnings)
}

/// What run `t` of scene `name` warns of: a body that moved far enough in a step of `dt` to
/// pass through a solid; energy made, with nothing driving the world (`undriven`), by the
/// integration.
fn penalty_warnings(t: &PenaltyTrace, name: &str, undriven: bool, dt: f64) -> Vec<String> {
    let model = t.model;
    let mut warnings = Vec::new();
    let thinnest = t.thinnest_solid();
    if t.longest_stride > 0.5 * thinnest {
        warnings.push(format!(
            "{name} ({model} contact): a body moved {:.4} m in one step, more than half the \
             thinnest solid ({thinnest:.4} m): it can pass through without touching; use a \
             shorter step",
            t.longest_stride
        ));
    }
    let gained = t.gained();
    if undriven && gained > 1e-3 * t.energy.start.abs().max(1e-6) {
        warnings.push(format!(
            "{name} ({model} contact) gained {gained:.6} J with nothing driving it: the \
             material is too stiff or too lightly damped for a step of {dt} s"
        ));
    }
    warnings
}

/// Run `t`'s lines of the report after its first (energy, bodies, pointers), and its JSON.
fn penalty_run(text: &mut String, t: &PenaltyTrace) -> Value {
    let energy = t.energy;
    let _ = writeln!(
        text,
        "  energy {:.6} J at the start, {:.6} J at the end, {:.6} J at most",
        energy.start, energy.end, energy.peak
    );
    let mut bodies = Vec::new();
    for &i in &t.moving {
        let b = &t.scene.world.bodies[i];
        let mut body = report_body(
            text,
            &t.scene.names[i],
            b.position,
            b.orientation,
            b.velocity,
            b.spin,
        );
        body["angular_momentum"] = json!(angular_momentum(b).to_array());
        bodies.push(body);
    }
    bodies.extend(t.scene.soft.iter().map(|p| report_soft(text, p)));
    let joints = report_joints(text, penalty_joints(&t.scene.world));
    let pointers = report_pointers(text, &t.felt, &t.peaks);
    json!({
        "model": t.model,
        "bodies": bodies,
        "joints": joints,
        "pointers": pointers,
        "energy": {"start": energy.start, "end": energy.end, "peak": energy.peak},
    })
}

/// The chart of `quantity` for scene `name`.
fn chart(name: &str, quantity: Quantity, series: Vec<Series>) -> Chart {
    let (label, title) = match quantity {
        Quantity::Height => ("height, m", "height"),
        Quantity::AngularMomentumZ => ("angular momentum about z, kg m^2/s", "spin"),
        Quantity::Spin => ("rate of turn, rad/s", "spin"),
        Quantity::PointerForce => ("force felt, N", "force felt"),
    };
    Chart {
        title: format!("{name}: {title}"),
        x_label: "time, s".into(),
        y_label: label.into(),
        series,
        ..Chart::default()
    }
}

/// Each of `joints` (name, where it is now): a line of `text`, and an entry of the report.
fn report_joints<'a>(
    text: &mut String,
    joints: impl Iterator<Item = (&'a str, JointState)>,
) -> Vec<Value> {
    joints
        .map(|(name, state)| {
            let _ = writeln!(
                text,
                "  joint {name:<12} at {:>9.5}, moving {:.5} a second",
                state.position, state.velocity
            );
            json!({"name": name, "position": state.position, "velocity": state.velocity})
        })
        .collect()
}

/// The joints of a rapier `world`, by name, where each is now.
fn rapier_joints(world: &RapierWorld) -> impl Iterator<Item = (&str, JointState)> {
    let joints = world.joints();
    (0..joints.len()).map(move |k| (joints.name(k), world.joint_state(k)))
}

/// The joints of a penalty `world`, by name, where each is now.
fn penalty_joints(world: &World) -> impl Iterator<Item = (&str, JointState)> {
    (world.joints.iter()).map(move |l| (l.joint.name.as_str(), l.state(&world.bodies)))
}

/// A soft body taken whole, as a rigid body's row is: its centre of mass, the turn that best
/// carries its rest shape onto it, its momentum and angular momentum as velocity and spin.
fn soft_state(part: &SoftPart) -> (DVec3, DQuat, DVec3, DVec3) {
    let b = &part.body;
    (b.centre(), b.turn(), b.velocity(), b.spin())
}

/// A soft body's lines of the report (taken whole as a body is; its cut, its volume against
/// its rest volume and its energies), and its JSON.
fn report_soft(text: &mut String, part: &SoftPart) -> Value {
    let (position, orientation, velocity, spin) = soft_state(part);
    let mut entry = report_body(text, &part.name, position, orientation, velocity, spin);
    let b = &part.body;
    let (nodes, elements) = (b.positions.len(), b.mesh.element_count());
    let volume = b.volume() / b.rest_volume();
    let (elastic, kinetic) = (b.elastic_energy(), b.kinetic_energy());
    let _ = writeln!(
        text,
        "  {:<12} soft: {nodes} nodes, {elements} elements, volume {:.3} % of its rest, \
         elastic energy {elastic:.6} J, kinetic {kinetic:.6} J",
        "",
        100.0 * volume
    );
    entry["soft"] = json!({
        "nodes": nodes,
        "elements": elements,
        "volume": volume,
        "elastic_energy": elastic,
        "kinetic_energy": kinetic,
    });
    entry
}

/// One body's line of the report, and its JSON.
fn report_body(
    text: &mut String,
    name: &str,
    position: DVec3,
    orientation: DQuat,
    velocity: DVec3,
    spin: DVec3,
) -> Value {
    let _ = writeln!(
        text,
        "  {name:<12} at {:>8.4} {:>8.4} {:>8.4} m, speed {:.4} m/s, spin {:.4} rad/s",
        position.x,
        position.y,
        position.z,
        velocity.length(),
        spin.length()
    );
    json!({
        "name": name,
        "position": position.to_array(),
        "orientation": quat_to_wxyz(orientation),
        "velocity": velocity.to_array(),
        "spin": spin.to_array(),
    })
}

/// The pointers' lines of the report (last and largest force felt), and their JSON.
fn report_pointers(text: &mut String, felt: &[Wrench], peaks: &[f64]) -> Vec<Value> {
    let mut pointers = Vec::new();
    for (k, (w, peak)) in felt.iter().zip(peaks).enumerate() {
        let f = w.force;
        let _ = writeln!(
            text,
            "  pointer {} feels {:>8.3} {:>8.3} {:>8.3} N (at most {peak:.3} N)",
            k + 1,
            f.x,
            f.y,
            f.z
        );
        pointers.push(json!({
            "force": f.to_array(),
            "torque": w.torque.to_array(),
            "peak_force": peak,
        }));
    }
    pointers
}

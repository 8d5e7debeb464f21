//! `hapticctl scene …`: step a physics scene file headless, to try a scene before feeling
//! it: a penalty scene step by step, a rapier scene with its haptic side in lockstep as
//! hapticd runs it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::{Args, Subcommand, ValueEnum};
use glam::{DQuat, DVec3};
use hapticctl::multirate::Lockstep;
use hapticctl::plot::{Chart, PALETTE, Series};
use hapticctl::scene_run::{
    MultirateTrace, PenaltyStep, Quantity, RunError, angular_momentum, hand_pointers,
    trace_multirate, trace_penalty,
};
use hapticd_core::kinematics::{Wrench, quat_to_wxyz};
use hapticd_device::sim::hand::{HandTrack, Script};
use hapticd_physics::scene::{Feedback, PenaltyScene, RapierScene, SceneFile};
use hapticd_physics::world::ContactModel;
use serde_json::json;

use crate::Failure;
use crate::client::{self, Client};
use crate::mechanism::{Output, print, save};
use crate::render::Frames;
use crate::scene_file;
use hapticd_ipc::bus::Bus;
use hapticd_render::scenery::Scenery;
use hapticd_render::shading::Shaded;

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
    /// Write every step's body states to this CSV file (rapier scenes: every haptic tick's,
    /// the bodies moved between physics steps as graphics show them, thesis 6.5.2).
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

/// Haptic ticks per second of a rapier scene's run: hapticd's default loop rate.
const HAPTIC_RATE: f64 = 1000.0;

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

/// A CSV file written row by row as the run goes, so a failing disk is reported at once
/// and a long run needs no memory for its rows.
struct Recording {
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
}

impl Recording {
    fn create(path: &Path) -> Result<Self, Failure> {
        let file = std::fs::File::create(path)
            .map_err(|e| Failure::failed(format!("cannot create {}: {e}", path.display())))?;
        let mut recording = Self {
            path: path.to_path_buf(),
            out: std::io::BufWriter::new(file),
        };
        recording.row(format_args!(
            "t,model,body,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz"
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
    ) -> Result<(), Failure> {
        let [qw, qx, qy, qz] = quat_to_wxyz(orientation);
        self.row(format_args!(
            "{t},{model},{name},{},{},{},{qw},{qx},{qy},{qz},{},{},{},{},{},{}",
            p.x, p.y, p.z, v.x, v.y, v.z, w.x, w.y, w.z
        ))
    }

    fn row(&mut self, row: std::fmt::Arguments) -> Result<(), Failure> {
        use std::io::Write;
        writeln!(self.out, "{row}").map_err(|e| self.failed(e))
    }

    fn finish(mut self) -> Result<(), Failure> {
        use std::io::Write;
        self.out.flush().map_err(|e| self.failed(e))
    }

    fn failed(&self, e: std::io::Error) -> Failure {
        Failure::failed(format!("cannot write {}: {e}", self.path.display()))
    }
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

/// Step a rapier scene with its haptic side as hapticd does, and report like a penalty run:
/// curves and records follow the bodies between physics steps (6.5.2), the report gives
/// where the physics left them.
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
    let pointers = hand_pointers(hands, 0.0);
    let mut run = Lockstep::new(&spec, &pointers, HAPTIC_RATE, args.phase);
    let geometry = Shaded::new(spec.geometry());
    let ticks = (args.duration * HAPTIC_RATE).round() as usize;
    let mut record = args.record.as_deref().map(Recording::create).transpose()?;
    let mut frames = args.frames.as_deref().map(Frames::create).transpose()?;
    let traced = trace_multirate(
        &spec,
        &mut run,
        (args.quantity, hands),
        (HAPTIC_RATE, ticks),
        |tick| {
            let (t, run) = (tick.t, tick.run);
            if let Some(frames) = frames.as_mut() {
                frames.offer(t, || {
                    let poses: Vec<_> =
                        (0..spec.bodies.len()).map(|i| run.body(i).pose()).collect();
                    let mut scenery = Scenery::of_geometry(&geometry, &poses);
                    let grips: Vec<DVec3> = tick.pointers.iter().map(|p| p.pose.position).collect();
                    scenery.add_pointers(&run.proxies(), &grips);
                    scenery
                })?;
            }
            if let Some(record) = record.as_mut() {
                for (i, name) in spec.names.iter().enumerate() {
                    if !spec.bodies[i].fixed {
                        let b = run.body(i);
                        let state = (b.position, b.orientation, b.velocity, b.spin);
                        record.body(t, "rapier", name, state)?;
                    }
                }
            }
            Ok(())
        },
    )
    .map_err(|e| run_failure(e, &args.file))?;
    let MultirateTrace {
        moving,
        curves,
        felt,
        peaks,
    } = traced;
    if let Some(record) = record {
        record.finish()?;
    }
    if let Some(path) = &args.plot {
        let series = curves
            .into_iter()
            .enumerate()
            .map(|(k, points)| Series {
                label: match args.quantity {
                    Quantity::PointerForce => format!("pointer {}", k + 1),
                    _ => spec.names[moving[k]].clone(),
                },
                points,
                color: PALETTE[k % PALETTE.len()],
            })
            .collect();
        save(&chart(&spec.name, args.quantity, series), path)?;
    }
    let mut text = format!(
        "{} (rapier, {} Hz, {} feedback, phase {} s): {ticks} haptic ticks at {HAPTIC_RATE} Hz\n",
        spec.name,
        spec.rate,
        run.world.feedback().name(),
        args.phase
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
    let pointers = report_pointers(&mut text, &felt, &peaks);
    print(
        &args.output,
        json!({"scene": spec.name, "steps": ticks, "dt": 1.0 / HAPTIC_RATE, "runs": [{
            "model": "rapier",
            "rate": spec.rate,
            "phase": args.phase,
            "bodies": bodies,
            "pointers": pointers,
        }]}),
        text,
    );
    Ok(())
}

/// A run that stopped early, as hapticctl says it.
fn run_failure(error: RunError<Failure>, file: &Path) -> Failure {
    match error {
        RunError::NotFinite { t } => Failure::failed(format!(
            "{}: at t = {t:.4} s the world is no longer finite (bodies too fast, too light or \
             too stiffly sprung for its step)",
            file.display()
        )),
        RunError::Unsupported(_) => {
            Failure::usage("--quantity angular-momentum-z is for penalty scenes")
        }
        RunError::Step(failure) => failure,
    }
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

/// One body's line of the report, and its JSON.
fn report_body(
    text: &mut String,
    name: &str,
    position: DVec3,
    orientation: DQuat,
    velocity: DVec3,
    spin: DVec3,
) -> serde_json::Value {
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
fn report_pointers(text: &mut String, felt: &[Wrench], peaks: &[f64]) -> Vec<serde_json::Value> {
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
    let mut record = args.record.as_deref().map(Recording::create).transpose()?;
    let mut frames = args.frames.as_deref().map(Frames::create).transpose()?;
    let geometry = Shaded::new(first.geometry());
    let mut offered = |step: &PenaltyStep, drawn: bool| -> Result<(), Failure> {
        if drawn && let Some(frames) = frames.as_mut() {
            frames.offer(step.t, || {
                Scenery::of_geometry(&geometry, &step.scene.poses())
            })?;
        }
        if let Some(record) = record.as_mut() {
            for &i in step.moving {
                let b = &step.scene.world.bodies[i];
                let state = (b.position, b.orientation, b.velocity, b.spin);
                record.body(step.t, step.model, &step.scene.names[i], state)?;
            }
        }
        Ok(())
    };
    let run = |scene, offered: &mut dyn FnMut(&PenaltyStep) -> Result<(), Failure>| {
        trace_penalty(scene, args.quantity, hands, (dt, steps), offered)
            .map_err(|e| run_failure(e, &args.file))
    };
    // Only the first run is drawn: one picture per frame.
    let mut traces = vec![run(first, &mut |step| offered(step, true))?];
    for &model in &models[1..] {
        let scene = load(&args.file, model, hands.len())?;
        traces.push(run(scene, &mut |step| offered(step, false))?);
    }
    if let Some(record) = record {
        record.finish()?;
    }
    let name = traces[0].scene.name.clone();
    if let Some(path) = &args.plot {
        let mut series = Vec::new();
        for t in &traces {
            for (points, &i) in t.curves.iter().zip(&t.plotted) {
                series.push(Series {
                    label: format!("{} ({})", t.scene.names[i], t.model),
                    points: points.clone(),
                    color: PALETTE[series.len() % PALETTE.len()],
                });
            }
        }
        save(&chart(&name, args.quantity, series), path)?;
    }
    let mut text = String::new();
    let mut runs = Vec::new();
    for t in &traces {
        let (world, model, energy) = (&t.scene.world, t.model, t.energy);
        let _ = writeln!(text, "{name} ({model} contact): {steps} steps of {dt} s");
        let _ = writeln!(
            text,
            "  energy {:.6} J at the start, {:.6} J at the end, {:.6} J at most",
            energy.start, energy.end, energy.peak
        );
        let thinnest = t.thinnest_solid();
        if t.longest_stride > 0.5 * thinnest {
            eprintln!(
                "hapticctl: warning: {name} ({model} contact): a body moved {:.4} m in one step, \
                 more than half the thinnest solid ({thinnest:.4} m): it can pass through \
                 without touching; use a shorter step",
                t.longest_stride
            );
        }
        // Nothing drives a world without hands: energy it gains comes from the integration.
        let gained = t.gained();
        if hands.is_empty() && gained > 1e-3 * energy.start.abs().max(1e-6) {
            eprintln!(
                "hapticctl: warning: {name} ({model} contact) gained {gained:.6} J with nothing \
                 driving it: the material is too stiff or too lightly damped for a step of {dt} s"
            );
        }
        let mut bodies = Vec::new();
        for &i in &t.moving {
            let b = &world.bodies[i];
            let mut body = report_body(
                &mut text,
                &t.scene.names[i],
                b.position,
                b.orientation,
                b.velocity,
                b.spin,
            );
            body["angular_momentum"] = json!(angular_momentum(b).to_array());
            bodies.push(body);
        }
        let pointers = report_pointers(&mut text, &t.felt, &t.peaks);
        runs.push(json!({
            "model": model,
            "bodies": bodies,
            "pointers": pointers,
            "energy": {"start": energy.start, "end": energy.end, "peak": energy.peak},
        }));
    }
    print(
        &args.output,
        json!({"scene": name, "steps": steps, "dt": dt, "runs": runs}),
        text,
    );
    Ok(())
}

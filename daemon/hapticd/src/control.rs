//! The control plane behind the D-Bus service: what a request does to a running device, and
//! what is remembered. Every change is checked first, then persisted, then handed to the
//! real-time thread through its command ring, so a refused or failed request changes nothing.
//!
//! The daemon's main thread copies the real-time snapshot into each [`DeviceHandle`] at
//! 10 Hz; requests that must see the loop act (a calibration, a scene swap) wait for that
//! snapshot to show it.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::scenes::OpenError;
use crate::state::{Calibration, DeviceRecord, StateDir};
use hapticd_config::Config;
use hapticd_config::catalog::{Catalog, Entry};
use hapticd_core::diagnostics::{Diagnostic, Diagnostics};
use hapticd_core::haptic_loop::{DeviceState, Frame, LoopCommand};
use hapticd_core::parameters::{self, Name, ParameterError, Parameters};
pub use hapticd_core::scene::control::Body;
use hapticd_core::scene::control::{CommandError, SceneControl};
use hapticd_core::scene::{Pointer, Scene};
use hapticd_core::stats::LoopStats;
use hapticd_core::sync::spsc;
use hapticd_core::transport::Link;
use hapticd_ipc::geometry_share::SceneGeometryFile;
use hapticd_ipc::telemetry_share::SharedTelemetryFile;
use hapticd_ipc::world_link_share::{WorldLink, WorldLinkFile};
use hapticd_ipc::world_share::SharedWorldFile;
use hapticd_plugin_api::{
    HAPTICD_COMMAND_QUERY, HAPTICD_COMMAND_SET_FORCE, HAPTICD_COMMAND_SET_FRICTION,
    HAPTICD_COMMAND_SET_MASS, HAPTICD_COMMAND_SET_POSE, HAPTICD_COMMAND_SET_VELOCITY,
    HapticdBodyState, HapticdSceneCommand,
};

/// Errors of the control plane, typed as the layers below gave them; the bus names each
/// (`org.hapticd.Hapticd1.Error.*`) at its edge, in `bus::error`.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// A value that is NaN or infinite.
    NotFinite(String),
    /// A value outside its range, or inconsistent with another one.
    OutOfRange(String),
    /// The scene could not be opened; the running one stays.
    Scene(OpenError),
    /// A scene file sent by descriptor could not be read or kept.
    SceneNotKept(Diagnostics),
    /// No installed mechanism of that name.
    UnknownMechanism(String),
    /// A configuration file or descriptor is malformed; nothing was changed.
    InvalidConfiguration(Diagnostics),
    /// The state could not be written; nothing was changed.
    NotSaved(String),
    /// The device is not answering.
    Disconnected(String),
    /// The real-time loop did not act on the request in time.
    Timeout(String),
    /// A fault that a reset does not clear.
    StillFaulted(String),
    /// Something this request needs is not there (and the daemon runs without it).
    Unavailable(String),
    /// A path where only a name is taken (files come by descriptor).
    NameExpected(String),
    /// The scene's meshes are being cut into convex pieces; the running scene stays.
    Preparing(String),
    /// A change to the running world was not carried out.
    Command(CommandError),
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Scene(e) => e.fmt(f),
            Error::Command(e) => e.fmt(f),
            Error::SceneNotKept(findings) | Error::InvalidConfiguration(findings) => {
                findings.fmt(f)
            }
            Error::NotFinite(m)
            | Error::OutOfRange(m)
            | Error::UnknownMechanism(m)
            | Error::NotSaved(m)
            | Error::Disconnected(m)
            | Error::Timeout(m)
            | Error::StillFaulted(m)
            | Error::Unavailable(m)
            | Error::NameExpected(m)
            | Error::Preparing(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Error {}

impl Error {
    /// The error with the daemon's copy of a scene (`kept`, in a directory of its own)
    /// named as its caller knows it (`shown`): where the daemon keeps files means nothing
    /// to a caller, and is not theirs to know.
    fn naming(self, kept: &Path, shown: &Path) -> Error {
        let (kept_text, shown_text) = (kept.display().to_string(), shown.display().to_string());
        let rename = |m: String| m.replace(&kept_text, &shown_text);
        match self {
            Error::Scene(OpenError::Invalid(mut findings)) => {
                for finding in &mut findings.diagnostics {
                    if finding.file == kept {
                        finding.file = shown.to_path_buf();
                    }
                    finding.message = rename(std::mem::take(&mut finding.message));
                }
                Error::Scene(OpenError::Invalid(findings))
            }
            Error::Scene(OpenError::Refused(m)) => Error::Scene(OpenError::Refused(rename(m))),
            Error::Scene(OpenError::NotFound(m)) => Error::Scene(OpenError::NotFound(rename(m))),
            Error::Preparing(m) => Error::Preparing(rename(m)),
            Error::Unavailable(m) => Error::Unavailable(rename(m)),
            other => other,
        }
    }
}

impl From<ParameterError> for Error {
    fn from(e: ParameterError) -> Self {
        match e {
            ParameterError::NotFinite(m) => Error::NotFinite(m),
            ParameterError::OutOfRange(m) => Error::OutOfRange(m),
        }
    }
}

fn not_taking_commands() -> Error {
    Error::Timeout("the haptic loop is not taking commands".into())
}

/// What the loop last published: its frame and statistics.
#[derive(Debug, Clone, Copy, Default)]
pub struct Telemetry {
    /// The latest frame.
    pub frame: Frame,
    /// The latest loop statistics.
    pub stats: LoopStats,
}

/// How long a request waits for the loop to act.
const ACT_TIMEOUT: Duration = Duration::from_secs(3);

/// One running device as the control plane sees it.
pub struct DeviceHandle {
    identity: String,
    mechanism: String,
    effectors: Vec<String>,
    pointers: Vec<Pointer>,
    rate: f64,
    scheduling: String,
    state_dir: Option<StateDir>,
    world: Option<SharedWorldFile>,
    /// The running scene's solids, as pictures show them.
    geometry: Mutex<Option<SceneGeometryFile>>,
    ring: Option<SharedTelemetryFile>,
    world_link: Option<WorldLinkFile>,
    fixed: Fixed,
    commands: Mutex<spsc::Producer<LoopCommand>>,
    telemetry: Mutex<Telemetry>,
    /// The control of the running scene's world (None: it cannot be changed from outside).
    control: Mutex<Option<SceneControl>>,
    /// What is remembered, under one lock so that concurrent requests persist in the order
    /// they take effect.
    remembered: Mutex<Remembered>,
}

/// A device's persisted record and the defaults its parameter overrides apply to.
struct Remembered {
    record: DeviceRecord,
    defaults: Parameters,
}

/// Lock `m`; a panicked holder cannot leave these values half-written (each is replaced
/// whole), so a poisoned lock is used as it is.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// What a [`DeviceHandle`] is made from.
pub struct DeviceSetup {
    /// The transport's identity (the key of the persisted state).
    pub identity: String,
    /// The mechanism's name.
    pub mechanism: String,
    /// The mechanism's end effectors by name, in its order.
    pub effectors: Vec<String>,
    /// One pointer per effector, at the calibration pose.
    pub pointers: Vec<Pointer>,
    /// Running tick rate, Hz.
    pub rate: f64,
    /// What the scheduler granted, in words.
    pub scheduling: String,
    /// Where state is persisted (none: nothing survives a restart).
    pub state_dir: Option<StateDir>,
    /// The record loaded at start.
    pub record: DeviceRecord,
    /// Defaults of the parameters (scene, mechanism, configuration).
    pub defaults: Parameters,
    /// The memory the loop draws its world into, if it could be made.
    pub world: Option<SharedWorldFile>,
    /// The first scene's solids, if they could be shared (see [`scene_geometry`]).
    pub geometry: Option<SceneGeometryFile>,
    /// The ring the loop writes every tick into, if it could be made.
    pub telemetry: Option<SharedTelemetryFile>,
    /// The link its remote scenes reach their world through, if it could be made.
    pub world_link: Option<WorldLinkFile>,
    /// What the command line fixes for every start, whatever is bound or saved.
    pub fixed: Fixed,
    /// The control of the first scene's world, if it can be changed from outside.
    pub control: Option<SceneControl>,
}

/// The solids of `geometry`, the scene of a device `identity` that its frames count as
/// `scene_switches`, shared for pictures; without them the loop runs as well, only pictures
/// miss the scene (said in the log).
pub fn scene_geometry(
    identity: &str,
    scene_switches: u32,
    geometry: &hapticd_plugin_api::Geometry,
) -> Option<SceneGeometryFile> {
    SceneGeometryFile::create(scene_switches, geometry)
        .inspect_err(|e| tracing::warn!("{identity}: the scene's solids are not shared: {e}"))
        .ok()
}

/// What hapticd's command line fixes for every start (`--sim MECH`, `--rate`): a binding or
/// a saved rate waits behind it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Fixed {
    /// The mechanism.
    pub mechanism: bool,
    /// The tick rate.
    pub rate: bool,
}

impl DeviceHandle {
    /// A handle sending commands through `commands`; the loop should already render with
    /// the record's parameters over the defaults.
    pub fn new(setup: DeviceSetup, commands: spsc::Producer<LoopCommand>) -> Self {
        Self {
            identity: setup.identity,
            mechanism: setup.mechanism,
            effectors: setup.effectors,
            pointers: setup.pointers,
            rate: setup.rate,
            scheduling: setup.scheduling,
            state_dir: setup.state_dir,
            world: setup.world,
            geometry: Mutex::new(setup.geometry),
            ring: setup.telemetry,
            world_link: setup.world_link,
            fixed: setup.fixed,
            commands: Mutex::new(commands),
            telemetry: Mutex::new(Telemetry::default()),
            control: Mutex::new(setup.control),
            remembered: Mutex::new(Remembered {
                record: setup.record,
                defaults: setup.defaults,
            }),
        }
    }

    /// The transport's identity.
    pub fn identity(&self) -> &str {
        &self.identity
    }

    /// The mechanism's end effectors by name.
    pub fn effectors(&self) -> &[String] {
        &self.effectors
    }

    /// The mechanism driven.
    pub fn mechanism(&self) -> &str {
        &self.mechanism
    }

    /// What the next start changes: `mechanism` and `rate` with the values they will have,
    /// when they differ from the running ones (and the command line does not fix them).
    pub fn pending(&self) -> Vec<(String, String)> {
        let mut pending = Vec::new();
        if let Some(bound) = self.bound_mechanism()
            && !self.fixed.mechanism
            && bound != self.mechanism
        {
            pending.push(("mechanism".to_string(), bound));
        }
        let rate = self.parameter(Name::Rate);
        if !self.fixed.rate && rate != self.rate {
            pending.push(("rate".to_string(), rate.to_string()));
        }
        pending
    }

    /// The mechanism the user bound for the next start, if any.
    pub fn bound_mechanism(&self) -> Option<String> {
        lock(&self.remembered).record.mechanism.clone()
    }

    /// A descriptor of the memory the loop draws its world into (read-only for others).
    pub fn open_world(&self) -> Result<std::os::fd::OwnedFd, Error> {
        let world = self.world.as_ref().ok_or_else(|| {
            Error::Unavailable(format!("{}: no shared world (see the log)", self.identity))
        })?;
        world
            .share()
            .map_err(|e| Error::Unavailable(format!("{}: {e}", self.identity)))
    }

    /// A descriptor of the running scene's solids (read-only for others), and the frames'
    /// `scene_switches` of that scene.
    pub fn open_geometry(&self) -> Result<(std::os::fd::OwnedFd, u32), Error> {
        let geometry = lock(&self.geometry);
        let geometry = geometry.as_ref().ok_or_else(|| {
            Error::Unavailable(format!(
                "{}: the scene's solids are not shared (see the log)",
                self.identity
            ))
        })?;
        let fd = geometry
            .share()
            .map_err(|e| Error::Unavailable(format!("{}: {e}", self.identity)))?;
        Ok((fd, geometry.scene_switches()))
    }

    /// A descriptor of the ring the loop writes every tick into (read-only for others).
    pub fn open_telemetry(&self) -> Result<std::os::fd::OwnedFd, Error> {
        let ring = self.ring.as_ref().ok_or_else(|| {
            Error::Unavailable(format!(
                "{}: no telemetry ring (see the log)",
                self.identity
            ))
        })?;
        ring.share()
            .map_err(|e| Error::Unavailable(format!("{}: {e}", self.identity)))
    }

    /// A descriptor of the link through which the device's remote scenes reach their world
    /// (read and write, for the network bridge).
    pub fn open_world_link(&self) -> Result<std::os::fd::OwnedFd, Error> {
        let link = self.world_link.as_ref().ok_or_else(|| {
            Error::Unavailable(format!("{}: no world link (see the log)", self.identity))
        })?;
        link.share()
            .map_err(|e| Error::Unavailable(format!("{}: {e}", self.identity)))
    }

    /// The link its remote scenes use, if it has one.
    pub fn world_link(&self) -> Option<&Arc<WorldLink>> {
        self.world_link.as_ref().map(WorldLinkFile::link)
    }

    /// A new block of wrenches for the loop to add to the displayed ones, and the descriptor
    /// its writer maps (read and write); the block read before is no longer read.
    pub fn open_wrench_input(&self) -> Result<std::os::fd::OwnedFd, Error> {
        let (file, fd) = hapticd_ipc::wrench_share::WrenchInputFile::create()
            .map_err(|e| Error::Unavailable(format!("{}: {e}", self.identity)))?;
        self.send(LoopCommand::CommandWrenches(Box::new(file)))?;
        Ok(fd)
    }

    /// Running tick rate, Hz.
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// What the scheduler granted.
    pub fn scheduling(&self) -> &str {
        &self.scheduling
    }

    /// [main] Store the loop's latest snapshot.
    pub fn publish(&self, telemetry: Telemetry) {
        *lock(&self.telemetry) = telemetry;
    }

    /// The latest snapshot.
    pub fn telemetry(&self) -> Telemetry {
        *lock(&self.telemetry)
    }

    /// The value of `name` in force (the configured rate for [`Name::Rate`]).
    pub fn parameter(&self, name: Name) -> f64 {
        let guard = lock(&self.remembered);
        let overrides = &guard.record.parameters;
        parameters::value(&overrides.resolve(&guard.defaults), name)
            .unwrap_or_else(|| overrides.rate().unwrap_or(self.rate))
    }

    fn send(&self, command: LoopCommand) -> Result<(), Error> {
        lock(&self.commands)
            .try_push(command)
            .map_err(|_| not_taking_commands())
    }

    /// Save `record` (when there is a state directory).
    fn save(&self, record: &DeviceRecord) -> Result<(), Error> {
        match &self.state_dir {
            Some(dir) => dir
                .save(&self.identity, record)
                .map_err(|e| Error::NotSaved(e.to_string())),
            None => Ok(()),
        }
    }

    /// Save `record`, and only once it is saved hand the loop `command`. A full command ring
    /// is found before saving (only this handle fills it), so what is saved is also applied
    /// and what failed to save is not.
    fn save_then_send(&self, record: &DeviceRecord, command: LoopCommand) -> Result<(), Error> {
        let mut commands = lock(&self.commands);
        if !commands.has_room() {
            return Err(not_taking_commands());
        }
        self.save(record)?;
        commands
            .try_push(command)
            .map_err(|_| not_taking_commands())
    }

    /// Change the record by `change`, save it, and only then keep it.
    fn remember(&self, change: impl FnOnce(&mut DeviceRecord)) -> Result<(), Error> {
        let mut guard = lock(&self.remembered);
        let mut next = guard.record.clone();
        change(&mut next);
        self.save(&next)?;
        guard.record = next;
        Ok(())
    }

    /// Check, persist and apply `value` for `name`. The rate applies at the next start.
    pub fn set_parameter(&self, name: Name, value: f64) -> Result<(), Error> {
        let mut guard = lock(&self.remembered);
        let Remembered { record, defaults } = &mut *guard;
        let overrides = record.parameters.with(name, value, defaults)?;
        let next = DeviceRecord {
            parameters: overrides,
            ..record.clone()
        };
        if name == Name::Rate {
            self.save(&next)?;
        } else {
            self.save_then_send(&next, LoopCommand::Tune(overrides.resolve(defaults)))?;
        }
        *record = next;
        Ok(())
    }

    /// Wait until the loop's snapshot satisfies `done`.
    fn wait_for(&self, what: &str, done: impl Fn(&Frame) -> bool) -> Result<Frame, Error> {
        let started = Instant::now();
        loop {
            let frame = self.telemetry().frame;
            if done(&frame) {
                return Ok(frame);
            }
            if started.elapsed() > ACT_TIMEOUT {
                return Err(Error::Timeout(format!(
                    "the haptic loop did not {what} within {} s",
                    ACT_TIMEOUT.as_secs()
                )));
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Hand the loop `link`, the device opened again after it came back; the loop retires
    /// the dead one.
    pub fn reconnect(&self, link: Box<dyn Link>) -> Result<(), Error> {
        self.send(LoopCommand::Reconnect(link))
    }

    /// Take the counter offsets now (the grips must be at their calibration poses), persist
    /// them, and only then use them: offsets that could not be saved are not used (without
    /// a state directory they are used for this run only).
    pub fn calibrate(&self) -> Result<(), Error> {
        let before = self.telemetry().frame;
        if before.state == DeviceState::Disconnected {
            return Err(Error::Disconnected(format!(
                "{} is not answering; calibrate once it is back",
                self.identity
            )));
        }
        self.send(LoopCommand::MeasureOffsets)?;
        let measured = self.wait_for("measure the offsets", |f| {
            f.measurements > before.measurements
        })?;
        let mut guard = lock(&self.remembered);
        let next = DeviceRecord {
            calibration: Some(Calibration {
                mechanism: self.mechanism.clone(),
                offsets: measured.measured[..measured.strings].to_vec(),
            }),
            ..guard.record.clone()
        };
        self.save_then_send(&next, LoopCommand::UseOffsets(measured.measured))?;
        guard.record = next;
        drop(guard);
        self.wait_for("calibrate", |f| f.calibrations > before.calibrations)?;
        Ok(())
    }

    /// Forget the scene's contact state and let forces come back; an error when the device
    /// is still faulted afterwards (a failed plugin scene stays failed until replaced).
    pub fn reset_fault(&self) -> Result<(), Error> {
        self.send(LoopCommand::ResetFault)?;
        // Long enough for a scene that still fails to fault the device again.
        std::thread::sleep(Duration::from_millis(300));
        match self.telemetry().frame.state {
            DeviceState::Fault => Err(Error::StillFaulted(
                "the scene keeps failing; switch to another scene".into(),
            )),
            DeviceState::Uncalibrated => Err(Error::StillFaulted(
                "the counts no longer fit the calibration; calibrate (Calibrate())".into(),
            )),
            _ => Ok(()),
        }
    }

    /// Swap in `scene` with a force ramp; its proxy parameters become the defaults that the
    /// user's overrides apply to.
    pub fn switch_scene(&self, scene: Box<dyn Scene>) -> Result<(), Error> {
        self.switch_scene_carrying(scene, &[])
    }

    /// Swap in `scene` as [`DeviceHandle::switch_scene`] does, `carried` (changes to bodies
    /// by name) waiting for its world's first steps.
    fn switch_scene_carrying(
        &self,
        mut scene: Box<dyn Scene>,
        carried: &[(String, HapticdSceneCommand)],
    ) -> Result<(), Error> {
        let before = self.telemetry().frame.scene_switches;
        // Switches are one at a time (the daemon's lock), so this scene is the next counted.
        let geometry = scene_geometry(&self.identity, before.wrapping_add(1), scene.geometry());
        let mut control = scene.take_control();
        if let Some(control) = &mut control {
            for (name, command) in carried {
                if let Ok(body) = control.find(name) {
                    control
                        .enqueue(HapticdSceneCommand { body, ..*command })
                        .map_err(Error::Command)?;
                }
            }
        }
        let mut guard = lock(&self.remembered);
        let mut defaults = guard.defaults;
        if let Some(proxy) = scene.proxy() {
            defaults.proxy = proxy;
        }
        let parameters = guard.record.parameters.resolve(&defaults);
        // Its solids are shared before the loop counts it, so that a reader who sees the
        // count finds them; the last scene's come back if the swap fails.
        let previous = std::mem::replace(&mut *lock(&self.geometry), geometry);
        if let Err(e) = self.send(LoopCommand::SwitchScene(scene)) {
            *lock(&self.geometry) = previous;
            return Err(e);
        }
        self.send(LoopCommand::Tune(parameters))?;
        guard.defaults = defaults;
        drop(guard);
        self.wait_for("swap the scene", |f| f.scene_switches > before)?;
        *lock(&self.control) = control;
        Ok(())
    }

    /// The running world's bodies as changes, by name, that put a world built anew from the
    /// same file where they are: pose, and for those that move their velocities, mass and
    /// held force; friction.
    fn carried(&self) -> Result<Vec<(String, HapticdSceneCommand)>, Error> {
        let mut carried = Vec::new();
        for body in self.bodies() {
            let query = HapticdSceneCommand::new(HAPTICD_COMMAND_QUERY, 0);
            let state = self.drive(&body.name, query)?;
            let mut carry = |kind: u32, fill: &dyn Fn(&mut HapticdSceneCommand)| {
                let mut command = HapticdSceneCommand::new(kind, 0);
                fill(&mut command);
                carried.push((body.name.clone(), command));
            };
            carry(HAPTICD_COMMAND_SET_POSE, &|c| {
                (c.position, c.orientation) = (state.position, state.orientation)
            });
            carry(HAPTICD_COMMAND_SET_FRICTION, &|c| c.value = state.friction);
            if !body.fixed {
                carry(HAPTICD_COMMAND_SET_MASS, &|c| c.value = state.mass);
                carry(HAPTICD_COMMAND_SET_FORCE, &|c| c.vector = state.force);
                carry(HAPTICD_COMMAND_SET_VELOCITY, &|c| {
                    (c.vector, c.spin) = (state.velocity, state.spin)
                });
            }
        }
        Ok(carried)
    }

    /// The bodies of the running world (none when it cannot be changed from outside).
    pub fn bodies(&self) -> Vec<Body> {
        lock(&self.control)
            .as_ref()
            .map_or_else(Vec::new, |c| c.bodies().to_vec())
    }

    /// Carry out `command` on `body` (a name, or an id) of the running world between two of
    /// its steps; the body's state after it.
    pub fn drive(
        &self,
        body: &str,
        mut command: HapticdSceneCommand,
    ) -> Result<HapticdBodyState, Error> {
        if command.kind == HAPTICD_COMMAND_SET_MASS
            && command.value > 0.0
            && command.value.is_finite()
        {
            self.pushable(body, command.value)?;
        }
        let mut control = lock(&self.control);
        let control = control.as_mut().ok_or_else(|| {
            Error::Unavailable(
                "the running scene cannot be changed from outside (its plugin offers no \
                 hapticd.scene.control/1)"
                    .into(),
            )
        })?;
        command.body = control.find(body).map_err(Error::Command)?;
        control.send(command).map_err(Error::Command)
    }

    /// Refuse a mass the hand would fling: the proxy's spring of stiffness k pushes a body
    /// the haptic tick (and local dynamics) integrates explicitly, stable only while
    /// √(k/m)·dt < 2, as a scene file's contact springs.
    fn pushable(&self, body: &str, mass: f64) -> Result<(), Error> {
        let stiffness = self.parameter(Name::Stiffness);
        let dt = 1.0 / self.rate;
        let lightest = stiffness * dt * dt / 4.0;
        if mass > lightest {
            return Ok(());
        }
        Err(Error::Command(CommandError::OutOfRange(format!(
            "a mass of {mass} kg for {body} is too light for the hand to push stably: at a \
             stiffness of {stiffness} N/m and {} Hz a body must weigh more than {lightest:.3e} kg",
            self.rate
        ))))
    }

    /// Bind `mechanism` to this device from its next start.
    pub fn bind_mechanism(&self, mechanism: String) -> Result<(), Error> {
        self.remember(|record| record.mechanism = Some(mechanism))
    }

    /// Pointers of this device at rest, for building scenes.
    pub fn pointers(&self) -> &[Pointer] {
        &self.pointers
    }
}

/// The daemon as the control plane sees it: configuration, installed mechanisms and scenes,
/// and the devices.
pub struct Daemon {
    config_path: Option<PathBuf>,
    /// Mechanism directories given on the command line (they win over the configuration).
    mechanism_dirs: Option<Vec<PathBuf>>,
    inner: Mutex<Installed>,
    devices: Vec<Arc<DeviceHandle>>,
    /// One scene switch at a time: the haptic loop holds a single scene in waiting.
    switching: Mutex<()>,
    /// Where scene files callers send are kept.
    received: crate::received::Received,
    /// The scenes of the scene directories, each file read once until it changes.
    scene_list: crate::scene_list::SceneList,
    /// Meshes' convex pieces cut off the switch.
    preparation: crate::preparation::Preparation,
    /// Set by [`Daemon::request_restart`]; the supervisor starts hapticd again.
    restart: AtomicBool,
}

struct Installed {
    config: Config,
    mechanisms: Vec<String>,
    active_scene: String,
    active_file: Option<PathBuf>,
}

/// The catalog `config` (or the command line) names.
pub fn catalog(config: &Config, mechanism_dirs: Option<&[PathBuf]>) -> Catalog {
    match (mechanism_dirs, &config.mechanism_dirs) {
        (Some(dirs), _) => Catalog::new(dirs.to_vec()),
        (None, Some(dirs)) => Catalog::new(dirs.clone()),
        (None, None) => Catalog::from_env(),
    }
}

/// Names of the mechanisms among `entries` (what a catalog found), and why each file that
/// failed did.
fn scan_mechanisms(entries: &[Entry]) -> (Vec<String>, Vec<Diagnostic>) {
    let mut names = Vec::new();
    let mut problems = Vec::new();
    for entry in entries {
        match &entry.mechanism {
            Ok(m) if !entry.shadowed => names.push(m.name.clone()),
            Ok(_) => {}
            Err(e) => problems.extend(e.diagnostics.iter().cloned()),
        }
    }
    (names, problems)
}

impl Daemon {
    /// The daemon running `devices` with `config` (read from `config_path`, when given),
    /// rendering `active_scene` (from `active_file`, if it has one); `entries` are what the
    /// catalog found at start.
    pub fn new(
        config: Config,
        (config_path, mechanism_dirs): (Option<PathBuf>, Option<Vec<PathBuf>>),
        entries: &[Entry],
        (active_scene, active_file): (String, Option<PathBuf>),
        devices: Vec<Arc<DeviceHandle>>,
    ) -> Self {
        // At start a broken file only hides its own mechanism (the daemon runs regardless).
        let (mechanisms, problems) = scan_mechanisms(entries);
        for problem in problems {
            tracing::warn!("{problem}");
        }
        Self {
            config_path,
            mechanism_dirs,
            inner: Mutex::new(Installed {
                config,
                mechanisms,
                active_scene,
                active_file,
            }),
            devices,
            switching: Mutex::new(()),
            received: crate::received::Received::from_environment(),
            scene_list: crate::scene_list::SceneList::new(),
            preparation: crate::preparation::Preparation::from_environment(),
            restart: AtomicBool::new(false),
        }
    }

    /// The devices.
    pub fn devices(&self) -> &[Arc<DeviceHandle>] {
        &self.devices
    }

    /// Installed mechanisms, as of the last reload.
    pub fn mechanisms(&self) -> Vec<String> {
        lock(&self.inner).mechanisms.clone()
    }

    /// Names of the scenes in the scene directories, each file's head read again if it
    /// changed.
    pub fn scenes(&self) -> Vec<String> {
        let config = lock(&self.inner).config.clone();
        self.scene_list.names(Self::scene_places(&config))
    }

    /// The scenes as last listed, if nothing may have changed since ([`SceneList::unchanged`]):
    /// a few `stat` calls, for the bus thread.
    ///
    /// [`SceneList::unchanged`]: crate::scene_list::SceneList::unchanged
    pub fn scenes_unchanged(&self) -> Option<Vec<String>> {
        let config = lock(&self.inner).config.clone();
        self.scene_list.unchanged(Self::scene_places(&config))
    }

    fn scene_places(config: &Config) -> crate::scenes::Places<'_> {
        crate::scenes::Places {
            dirs: &config.scene_dirs,
            plugin_dirs: &config.scene_plugin_dirs,
            world_link: None,
        }
    }

    /// The scene rendered.
    pub fn active_scene(&self) -> String {
        lock(&self.inner).active_scene.clone()
    }

    /// The file the scene rendered comes from, if any.
    pub fn active_scene_file(&self) -> Option<PathBuf> {
        lock(&self.inner).active_file.clone()
    }

    /// Load the scene called `name` (a scene file of the scene directories, or a scene
    /// plugin of the scene plugin directories) for every device, off the real-time thread,
    /// and swap it in; on any failure the running scene stays. A path is refused: a caller's
    /// own file comes by descriptor ([`Daemon::switch_scene_file`]).
    pub fn switch_scene(&self, name: &str) -> Result<(), Error> {
        if !hapticd_config::scene_name::is_name(name) {
            return Err(Error::NameExpected(format!(
                "{name:?} is not a scene name: switch to a name from Scenes or a scene plugin \
                 of the scene plugin directories, or send your file (hapticctl scene switch \
                 ./FILE.yaml sends it)"
            )));
        }
        let scene_dirs = lock(&self.inner).config.scene_dirs.clone();
        let file = crate::scenes::file_of(name, None, &scene_dirs);
        self.swap_in(name, file)
    }

    /// Load the scene file a caller sent as `fd`, calling it `name`, and swap it in as
    /// [`Daemon::switch_scene`] does. Only the descriptor is read, never a path.
    pub fn switch_scene_file(&self, fd: std::os::fd::OwnedFd, name: &str) -> Result<(), Error> {
        if !hapticd_config::scene_name::is_name(name) {
            return Err(Error::NameExpected(format!(
                "{name:?} cannot name a scene: a file name without its directory and extension"
            )));
        }
        let kept = self.received.keep(fd, name).map_err(Error::SceneNotKept)?;
        let shown = PathBuf::from(format!("{name}.yaml"));
        self.swap_in(&kept.display().to_string(), Some(kept.clone()))
            .map_err(|e| e.naming(&kept, &shown))
    }

    /// Load `scene` (a name, or a path the daemon chose) for every device and swap it in;
    /// pictures come from `file` from then on.
    fn swap_in(&self, scene: &str, file: Option<PathBuf>) -> Result<(), Error> {
        let _one_at_a_time = lock(&self.switching);
        self.swap_in_now(scene, file, false)
    }

    /// [`Daemon::swap_in`], the switch already ours; with `carry`, each device's new world
    /// takes its bodies' states from the running one, by name.
    fn swap_in_now(&self, scene: &str, file: Option<PathBuf>, carry: bool) -> Result<(), Error> {
        if let Some(file) = &file {
            self.preparation
                .ready(file)
                .map_err(|e| Error::Preparing(e.to_string()))?;
        }
        let config = lock(&self.inner).config.clone();
        let mut scenes = Vec::new();
        for device in &self.devices {
            let places = crate::scenes::Places {
                dirs: &config.scene_dirs,
                plugin_dirs: &config.scene_plugin_dirs,
                world_link: device.world_link(),
            };
            scenes.push(
                crate::scenes::open(scene, None, places, device.pointers(), device.rate())
                    .map_err(Error::Scene)?,
            );
        }
        let loaded = scenes.first().map(|s| s.name().to_string());
        for (device, scene) in self.devices.iter().zip(scenes) {
            let carried = if carry { device.carried()? } else { Vec::new() };
            device.switch_scene_carrying(scene, &carried)?;
        }
        let mut inner = lock(&self.inner);
        inner.active_scene = loaded.unwrap_or_else(|| scene.to_string());
        inner.active_file = file;
        Ok(())
    }

    /// Add `body` (one entry of a scene file's `bodies:`, as YAML, with a name no body of the
    /// world has) to the running world; its id. See [`Daemon::rebuild`].
    pub fn add_body(&self, body: &str) -> Result<u32, Error> {
        let value: serde_json::Value = serde_saphyr::from_str(body).map_err(|e| {
            Error::OutOfRange(format!(
                "the body is no YAML of the scene format's bodies: {e}"
            ))
        })?;
        let name = value
            .get("name")
            .and_then(serde_json::Value::as_str)
            .filter(|n| !n.is_empty())
            .ok_or_else(|| Error::OutOfRange("a body added needs a name".into()))?
            .to_string();
        self.rebuild(|bodies| {
            if bodies
                .iter()
                .any(|b| b.get("name").and_then(|n| n.as_str()) == Some(&name))
            {
                return Err(Error::OutOfRange(format!(
                    "a body named {name:?} is in the world already"
                )));
            }
            bodies.push(value);
            Ok(())
        })?;
        let id = self.bodies().iter().position(|b| b.name == name);
        Ok(id.unwrap_or_default() as u32)
    }

    /// Remove `body` (a name, or an id) from the running world; the ids after it move down
    /// by one. See [`Daemon::rebuild`].
    pub fn remove_body(&self, body: &str) -> Result<(), Error> {
        let bodies = self.bodies();
        let found = bodies
            .iter()
            .position(|b| b.name == body)
            .or_else(|| body.parse::<usize>().ok().filter(|&i| i < bodies.len()))
            .ok_or_else(|| {
                Error::Command(CommandError::UnknownBody(format!(
                    "no body {body:?} in this world"
                )))
            })?;
        let name = bodies[found].name.clone();
        self.rebuild(|bodies| {
            bodies.retain(|b| b.get("name").and_then(|n| n.as_str()) != Some(&name));
            Ok(())
        })
    }

    /// Build the running world again from its scene file with `change` made to its
    /// `bodies:`, every body kept where it is and as it moves (by name), and swap it in with
    /// the forces ramped down and up as for a scene switch. The changed file is kept beside
    /// those callers send. Only a scene of a file whose bodies name no mesh can be rebuilt
    /// (a mesh is read beside its file).
    fn rebuild(
        &self,
        change: impl FnOnce(&mut Vec<serde_json::Value>) -> Result<(), Error>,
    ) -> Result<(), Error> {
        let _one_at_a_time = lock(&self.switching);
        let file = lock(&self.inner).active_file.clone().ok_or_else(|| {
            Error::Unavailable("the running scene comes from no scene file to add bodies to".into())
        })?;
        let unreadable = |e: String| {
            Error::Unavailable(format!(
                "cannot read the running scene {}: {e}",
                file.display()
            ))
        };
        let text = std::fs::read_to_string(&file).map_err(|e| unreadable(e.to_string()))?;
        let mut scene: serde_json::Value =
            serde_saphyr::from_str(&text).map_err(|e| unreadable(e.to_string()))?;
        let bodies = scene
            .get_mut("bodies")
            .and_then(serde_json::Value::as_array_mut)
            .ok_or_else(|| Error::Unavailable("the running scene has no bodies: list".into()))?;
        change(bodies)?;
        if bodies.iter().any(|b| b.get("mesh").is_some()) {
            return Err(Error::Unavailable(
                "a world with a body of a mesh is not built again (its file is read beside the \
                 scene's)"
                    .into(),
            ));
        }
        let name = file
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("scene")
            .to_string();
        // JSON is YAML: the scene format reads it as it is.
        let changed = serde_json::to_string_pretty(&scene).expect("a JSON value serialises");
        let kept = self
            .received
            .keep_text(&changed, &name)
            .map_err(Error::SceneNotKept)?;
        let shown = PathBuf::from(format!("{name}.yaml"));
        let swapped = self
            .swap_in_now(&kept.display().to_string(), Some(kept.clone()), true)
            .map_err(|e| e.naming(&kept, &shown));
        // A change the scene refused leaves the file the running world came from as it was.
        if swapped.is_err() && kept == file {
            self.received
                .keep_text(&text, &name)
                .map_err(Error::SceneNotKept)?;
        }
        swapped
    }

    /// The bodies of the running world, as every device runs it.
    pub fn bodies(&self) -> Vec<Body> {
        self.devices.first().map_or_else(Vec::new, |d| d.bodies())
    }

    /// Carry out `command` on `body` (a name, or an id) in every device's world (each runs
    /// the scene); the body's state after it in the first.
    pub fn drive(
        &self,
        body: &str,
        command: HapticdSceneCommand,
    ) -> Result<HapticdBodyState, Error> {
        let mut first = None;
        for device in &self.devices {
            let state = device.drive(body, command)?;
            first.get_or_insert(state);
        }
        first.ok_or_else(|| Error::Unavailable("no device runs a world".into()))
    }

    /// Re-read the configuration file and rescan the mechanism directories, as a start
    /// would: a malformed configuration (or a default scene that is nowhere) is reported with
    /// its place and nothing changes; a broken mechanism file only hides its own mechanism,
    /// with a warning. A changed `scene:` is switched to.
    pub fn reload(&self) -> Result<(), Error> {
        let config = match &self.config_path {
            Some(path) => Config::load(path).map_err(Error::InvalidConfiguration)?,
            None => lock(&self.inner).config.clone(),
        };
        // The default scene must be there: the next start would fail on it.
        if let Err(e) = hapticd_config::scene_name::locate(&config.scene, &config.scene_dirs) {
            let file = self
                .config_path
                .as_deref()
                .unwrap_or(Path::new("configuration"));
            return Err(Error::InvalidConfiguration(Diagnostics::at(
                file,
                None,
                "scene",
                e.to_string(),
            )));
        }
        let (mechanisms, problems) =
            scan_mechanisms(&catalog(&config, self.mechanism_dirs.as_deref()).entries());
        for problem in problems {
            tracing::warn!("{problem}");
        }
        let changed = config.scene != lock(&self.inner).config.scene;
        let switch_to = changed.then(|| {
            let file = crate::scenes::file_of(&config.scene, None, &config.scene_dirs);
            (config.scene.clone(), file)
        });
        {
            let mut inner = lock(&self.inner);
            inner.config = config;
            inner.mechanisms = mechanisms;
        }
        match switch_to {
            Some((scene, file)) => self.swap_in(&scene, file),
            None => Ok(()),
        }
    }

    /// Ask for every device's loop to start again (motors ramped to zero, the program run
    /// anew under the same name), which applies what waits for the next start: a bound
    /// mechanism, a changed Rate.
    pub fn request_restart(&self) {
        self.restart.store(true, Ordering::Release);
    }

    /// Whether a restart was asked for.
    pub fn restart_requested(&self) -> bool {
        self.restart.load(Ordering::Acquire)
    }

    /// Bind installed mechanism `name` to `device` from its next start.
    pub fn bind_mechanism(&self, device: &DeviceHandle, name: &str) -> Result<(), Error> {
        if !lock(&self.inner).mechanisms.iter().any(|m| m == name) {
            return Err(Error::UnknownMechanism(format!(
                "no installed mechanism {name:?} (call ReloadPlugins after adding one)"
            )));
        }
        device.bind_mechanism(name.to_string())
    }
}

//! One device as the control plane holds it: its parameters, calibration and scene, each
//! change checked, persisted, then handed to the real-time thread.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::state::{Calibration, DeviceRecord, StateDir};
use hapticd_core::haptic_loop::{DeviceState, Frame, LoopCommand};
use hapticd_core::parameters::{self, Name, Parameters};
use hapticd_core::scene::control::{Body, Joint};
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
    HAPTICD_COMMAND_PIN, HAPTICD_COMMAND_QUERY, HAPTICD_COMMAND_RELEASE, HAPTICD_COMMAND_SET_FORCE,
    HAPTICD_COMMAND_SET_FRICTION, HAPTICD_COMMAND_SET_MASS, HAPTICD_COMMAND_SET_MATERIAL,
    HAPTICD_COMMAND_SET_POSE, HAPTICD_COMMAND_SET_VELOCITY, HapticdBodyState, HapticdJointCommand,
    HapticdJointState, HapticdSceneCommand,
};

use super::{Error, not_taking_commands};

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
    /// The effects it renders.
    pub(super) effects: Mutex<Effects>,
    /// The changes made to the running world's soft bodies (material, pins), by name, in
    /// their order: a soft body is built anew at rest, so a world rebuilt around it takes
    /// them again.
    soft_changes: Mutex<Vec<(String, HapticdSceneCommand)>>,
}

/// The most pins and releases of one soft body kept for a rebuilt world; beyond them the
/// oldest are forgotten (a script that pins and lets go in a loop keeps its last ones).
const MOST_PIN_CHANGES: usize = 64;

/// The effects a device renders (see `control::effects`).
#[derive(Debug, Default)]
pub(super) struct Effects {
    /// The id the next effect gets.
    pub(super) next: u32,
    /// Each effect held.
    pub(super) held: Vec<Held>,
}

/// One effect held.
#[derive(Debug, Clone)]
pub(super) struct Held {
    /// Its id.
    pub(super) id: u32,
    /// As written.
    pub(super) text: String,
    /// It came with the scene's file.
    pub(super) of_scene: bool,
}

/// A device's persisted record and the defaults its parameter overrides apply to.
struct Remembered {
    record: DeviceRecord,
    defaults: Parameters,
}

/// Lock `m`; a panicked holder cannot leave these values half-written (each is replaced
/// whole), so a poisoned lock is used as it is.
pub(super) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
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
            effects: Mutex::default(),
            soft_changes: Mutex::default(),
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

    pub(super) fn send(&self, command: LoopCommand) -> Result<(), Error> {
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
        self.switch_scene_carrying(scene, &[])?;
        lock(&self.soft_changes).clear();
        Ok(())
    }

    /// Swap in `scene` as [`DeviceHandle::switch_scene`] does, `carried` (changes to bodies
    /// by name) waiting for its world's first steps.
    pub(super) fn switch_scene_carrying(
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
        // A soft body removed takes its changes along (one added again of its name starts
        // as its file says).
        lock(&self.soft_changes)
            .retain(|(name, _)| control.as_ref().is_some_and(|c| c.find(name).is_ok()));
        *lock(&self.control) = control;
        Ok(())
    }

    /// The running world's bodies as changes, by name, that put a world built anew from the
    /// same file where they are: pose, and for those that move their velocities, mass and
    /// held force; friction; and the soft bodies' materials and pins as they were set.
    pub(super) fn carried(&self) -> Result<Vec<(String, HapticdSceneCommand)>, Error> {
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
        carried.extend(lock(&self.soft_changes).iter().cloned());
        Ok(carried)
    }

    /// Keep `command`, carried out on soft body `name`, for a world rebuilt around it: a
    /// material replaces the one set before, pins and releases follow each other.
    fn remember_soft_change(&self, name: &str, command: HapticdSceneCommand) {
        let mut changes = lock(&self.soft_changes);
        let same = |(n, c): &(String, HapticdSceneCommand), pins: bool| {
            n == name && (c.kind == HAPTICD_COMMAND_SET_MATERIAL) != pins
        };
        let pins = command.kind != HAPTICD_COMMAND_SET_MATERIAL;
        if !pins {
            changes.retain(|c| !same(c, false));
        } else if changes.iter().filter(|c| same(c, true)).count() >= MOST_PIN_CHANGES {
            let oldest = changes.iter().position(|c| same(c, true));
            changes.remove(oldest.unwrap_or_default());
        }
        changes.push((name.to_string(), command));
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
        let (state, name) = self.with_control(|control| {
            command.body = control.find(body)?;
            let state = control.send(command)?;
            Ok((state, control.bodies()[command.body as usize].name.clone()))
        })?;
        if [
            HAPTICD_COMMAND_SET_MATERIAL,
            HAPTICD_COMMAND_PIN,
            HAPTICD_COMMAND_RELEASE,
        ]
        .contains(&command.kind)
        {
            self.remember_soft_change(&name, command);
        }
        Ok(state)
    }

    /// `change` done with the running world's control: Unavailable when its plugin offers
    /// none.
    fn with_control<R>(
        &self,
        change: impl FnOnce(&mut SceneControl) -> Result<R, CommandError>,
    ) -> Result<R, Error> {
        let mut control = lock(&self.control);
        let control = control.as_mut().ok_or_else(|| {
            Error::Unavailable(
                "the running scene cannot be changed from outside (its plugin offers no \
                 hapticd.scene.control/1)"
                    .into(),
            )
        })?;
        change(control).map_err(Error::Command)
    }

    /// The running world's joints (none when it cannot be changed from outside).
    pub fn joints(&self) -> Vec<Joint> {
        lock(&self.control)
            .as_ref()
            .map_or_else(Vec::new, |c| c.joints().to_vec())
    }

    /// Where each joint of the running world stands, by name, read between two steps.
    pub fn joint_states(&self) -> Result<Vec<(String, HapticdJointState)>, Error> {
        let mut control = lock(&self.control);
        let Some(control) = control.as_mut() else {
            return Ok(Vec::new());
        };
        let states = control.joint_states().map_err(Error::Command)?;
        Ok(control
            .joints()
            .iter()
            .map(|j| j.name.clone())
            .zip(states)
            .collect())
    }

    /// Carry out `command` on joint `joint` (its name) of the running world between two of
    /// its steps; the joint's state after it.
    pub fn drive_joint(
        &self,
        joint: &str,
        mut command: HapticdJointCommand,
    ) -> Result<HapticdJointState, Error> {
        self.with_control(|control| {
            command.joint = control.find_joint(joint)?;
            control.drive(command)
        })
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

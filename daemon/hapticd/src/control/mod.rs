//! The control plane behind the D-Bus service: what a request does to a running device, and
//! what is remembered. Every change is checked first, then persisted, then handed to the
//! real-time thread through its command ring, so a refused or failed request changes nothing.
//!
//! The daemon's main thread copies the real-time snapshot into each [`DeviceHandle`] at
//! 10 Hz; requests that must see the loop act (a calibration, a scene swap) wait for that
//! snapshot to show it.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use crate::scenes::OpenError;
use hapticd_config::Config;
use hapticd_config::catalog::{Catalog, Entry};
use hapticd_core::diagnostics::{Diagnostic, Diagnostics};
use hapticd_core::parameters::ParameterError;
use hapticd_core::scene::control::CommandError;
pub use hapticd_core::scene::control::{Body, Joint};
use hapticd_plugin_api::{
    HapticdBodyState, HapticdJointCommand, HapticdJointState, HapticdSceneCommand,
};

mod device;
mod effects;

use device::lock;
pub use device::{DeviceHandle, DeviceSetup, Fixed, Telemetry, scene_geometry};

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
    /// An effect's text is malformed or asks what the device cannot do: every finding.
    InvalidEffect(Diagnostics),
    /// No effect has that id.
    UnknownEffect(String),
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Scene(e) => e.fmt(f),
            Error::Command(e) => e.fmt(f),
            Error::SceneNotKept(findings)
            | Error::InvalidConfiguration(findings)
            | Error::InvalidEffect(findings) => findings.fmt(f),
            Error::NotFinite(m)
            | Error::OutOfRange(m)
            | Error::UnknownMechanism(m)
            | Error::NotSaved(m)
            | Error::Disconnected(m)
            | Error::Timeout(m)
            | Error::StillFaulted(m)
            | Error::Unavailable(m)
            | Error::NameExpected(m)
            | Error::UnknownEffect(m)
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
        let renamed = |mut findings: Diagnostics| {
            for finding in &mut findings.diagnostics {
                if finding.file == kept {
                    finding.file = shown.to_path_buf();
                }
                finding.message = rename(std::mem::take(&mut finding.message));
            }
            findings
        };
        match self {
            Error::Scene(OpenError::Invalid(findings)) => {
                Error::Scene(OpenError::Invalid(renamed(findings)))
            }
            Error::InvalidEffect(findings) => Error::InvalidEffect(renamed(findings)),
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
        // The scene file's effects, checked for every device before anything changes.
        let effects = self
            .devices
            .iter()
            .map(|device| device.scene_effects(file.as_deref()))
            .collect::<Result<Vec<_>, _>>()?;
        let loaded = scenes.first().map(|s| s.name().to_string());
        for ((device, scene), effects) in self.devices.iter().zip(scenes).zip(effects) {
            let carried = if carry { device.carried()? } else { Vec::new() };
            device.switch_scene_carrying(scene, &carried)?;
            device.replace_scene_effects(effects)?;
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
        self.in_every_world(|device| device.drive(body, command))
    }

    /// `change` done in every device's world (each runs the scene); its answer in the first.
    fn in_every_world<R>(
        &self,
        change: impl Fn(&DeviceHandle) -> Result<R, Error>,
    ) -> Result<R, Error> {
        let mut first = None;
        for device in &self.devices {
            let answer = change(device)?;
            first.get_or_insert(answer);
        }
        first.ok_or_else(|| Error::Unavailable("no device runs a world".into()))
    }

    /// The running world's joints (as the first device's world has them).
    pub fn joints(&self) -> Vec<Joint> {
        self.devices.first().map_or_else(Vec::new, |d| d.joints())
    }

    /// Where each joint of the running world stands (in the first device's world).
    pub fn joint_states(&self) -> Result<Vec<(String, HapticdJointState)>, Error> {
        self.devices
            .first()
            .map_or_else(|| Ok(Vec::new()), |d| d.joint_states())
    }

    /// Carry out `command` on joint `joint` (its name) in every device's world; the joint's
    /// state after it in the first.
    pub fn drive_joint(
        &self,
        joint: &str,
        command: HapticdJointCommand,
    ) -> Result<HapticdJointState, Error> {
        self.in_every_world(|device| device.drive_joint(joint, command))
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

//! `org.hapticd.Hapticd1.Manager` at `/org/hapticd/Hapticd1`.

use std::sync::Arc;

use hapticd_ipc::{API_VERSION, device_path};
use hapticd_service::Workers;
use zbus::interface;
use zbus::message::Header;
use zbus::object_server::SignalEmitter;

use super::BusError;
use super::{audit, caller, report};
use crate::control::{self, Daemon};

/// The daemon as a whole: its devices, scenes and mechanisms.
pub struct ManagerInterface {
    daemon: Arc<Daemon>,
    workers: Arc<Workers>,
}

impl ManagerInterface {
    /// The manager of `daemon`, running blocking requests on `workers`.
    pub fn new(daemon: Arc<Daemon>, workers: Arc<Workers>) -> Self {
        Self { daemon, workers }
    }
}

/// The hapticd daemon: its devices, the scenes it can render and the mechanisms installed.
#[interface(name = "org.hapticd.Hapticd1.Manager")]
impl ManagerInterface {
    /// Version of this D-Bus API; raised only when a change would break existing clients.
    #[zbus(property(emits_changed_signal = "const"))]
    fn api_version(&self) -> u32 {
        API_VERSION
    }

    /// Version of the hapticd daemon.
    #[zbus(property(emits_changed_signal = "const"))]
    fn version(&self) -> String {
        env!("CARGO_PKG_VERSION").to_string()
    }

    /// Object paths of the devices, each with the org.hapticd.Hapticd1.Device interface.
    #[zbus(property(emits_changed_signal = "const"))]
    fn devices(&self) -> Vec<zbus::OwnedObjectPath> {
        (0..self.daemon.devices().len())
            .filter_map(|i| zbus::OwnedObjectPath::try_from(device_path(i)).ok())
            .collect()
    }

    /// Names of the scenes found in the scene directories, for SwitchScene: each file's
    /// head read once until it changes (off the bus thread), its meshes never.
    #[zbus(property)]
    async fn scenes(&self) -> Vec<String> {
        if let Some(names) = self.daemon.scenes_unchanged() {
            return names;
        }
        let daemon = self.daemon.clone();
        self.workers.run(move || daemon.scenes()).await
    }

    /// Name of the scene being rendered.
    #[zbus(property)]
    fn active_scene(&self) -> String {
        self.daemon.active_scene()
    }

    /// Absolute path of the file the active scene comes from (what the renderer draws its
    /// solids from), or empty when it has none (a scene plugin run without a file).
    #[zbus(property)]
    fn active_scene_file(&self) -> String {
        self.daemon
            .active_scene_file()
            .map(|p| p.display().to_string())
            .unwrap_or_default()
    }

    /// Names of the installed mechanisms, as of the last ReloadPlugins.
    #[zbus(property)]
    fn mechanisms(&self) -> Vec<String> {
        self.daemon.mechanisms()
    }

    /// Render another scene: a name from Scenes, or the name of a scene plugin in the scene
    /// plugin directories (never a path: a file of the caller's comes by SwitchSceneFile).
    /// It is loaded off the haptic thread, then swapped in between ticks while the forces
    /// ramp down and back up. A scene that fails to load leaves the running one in place.
    async fn switch_scene(
        &self,
        scene: String,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let daemon = self.daemon.clone();
        let what = format!("switch to scene {scene:?}");
        let result = self.workers.run(move || daemon.switch_scene(&scene)).await;
        self.switched(what, result, &emitter, connection, &header)
            .await
    }

    /// Render the scene file the caller opened and sends as `file`, calling it `name` (its
    /// file name without the extension): the daemon reads only from the descriptor, so a
    /// caller's files are read with the caller's rights. Loaded and swapped in as by
    /// SwitchScene.
    async fn switch_scene_file(
        &self,
        file: zbus::OwnedFd,
        name: String,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let daemon = self.daemon.clone();
        let what = format!("switch to the scene file {name:?} it sent");
        let fd = std::os::fd::OwnedFd::from(file);
        let result = self
            .workers
            .run(move || daemon.switch_scene_file(fd, &name))
            .await;
        self.switched(what, result, &emitter, connection, &header)
            .await
    }

    /// Re-read hapticd.yaml and look again for mechanism plugins, descriptors and scenes. A
    /// malformed file is reported with file:line:column and nothing changes.
    async fn reload_plugins(
        &self,
        #[zbus(signal_emitter)] emitter: SignalEmitter<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let daemon = self.daemon.clone();
        let result = self.workers.run(move || daemon.reload()).await;
        audit(
            "reload the configuration and plugins",
            &caller(connection, Some(&header)).await,
            &result,
        );
        result?;
        report(self.mechanisms_changed(&emitter).await);
        report(self.scenes_changed(&emitter).await);
        Ok(())
    }

    /// Start every device's loop again, to apply what waits for the next start (a mechanism
    /// bound with BindMechanism, a changed Rate): the forces ramp to zero, hapticd runs
    /// anew under the same name within a few seconds, and its calibration and parameters
    /// are restored.
    async fn restart(
        &self,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) {
        let who = caller(connection, Some(&header)).await;
        tracing::info!("restart the haptic loops, for {who}");
        self.daemon.request_restart();
    }
}

impl ManagerInterface {
    /// Audit a scene switch (`what`) and, once it is done, announce the new scene.
    async fn switched(
        &self,
        what: String,
        result: Result<(), control::Error>,
        emitter: &SignalEmitter<'_>,
        connection: &zbus::Connection,
        header: &Header<'_>,
    ) -> Result<(), BusError> {
        audit(&what, &caller(connection, Some(header)).await, &result);
        result?;
        report(self.active_scene_changed(emitter).await);
        report(self.active_scene_file_changed(emitter).await);
        Ok(())
    }
}

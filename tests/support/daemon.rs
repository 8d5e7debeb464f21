//! hapticd started the way every end-to-end test starts it: with a configuration of the
//! test's own and on a bus of the test's own (or on an address where none listens), so that a
//! test neither meets nor disturbs a hapticd, a bus, a journal or an `/etc/hapticd` of the
//! machine it runs on. A hapticd built in the workspace reads `/etc/hapticd/hapticd.yaml` by
//! default (see `hapticd_config::layout`), and without `--bus` it serves on the system bus, where an
//! installed hapticd makes it refuse to start.

use std::path::{Path, PathBuf};
use std::process::Command;

use super::bus::PrivateBus;
use super::haptic_cpu::Turn;
use super::{artifact, profile_dir, repo_dir};

/// Where one test's hapticd runs: a directory, a configuration and a bus, all its own.
/// Dropping it stops the bus and removes the directory.
pub struct Isolated {
    dir: PathBuf,
    config: PathBuf,
    address: String,
    bus: Option<PrivateBus>,
    /// Its turn on the machine: beside the other tests', unless taken [`Isolated::alone`].
    turn: Option<Turn>,
}

impl Isolated {
    /// A private `dbus-daemon` with the shipped policy in `dir` (made afresh), and a
    /// configuration that finds mechanisms only in `mechanisms`.
    pub fn on_private_bus(dir: &Path, mechanisms: &Path) -> Self {
        let config = Self::prepare(dir, mechanisms);
        let bus = PrivateBus::start(
            &dir.join("bus"),
            &repo_dir().join("config/dbus/org.hapticd.Hapticd1.conf"),
        );
        Self {
            dir: dir.to_path_buf(),
            config,
            address: bus.address.clone(),
            bus: Some(bus),
            turn: Some(Turn::shared()),
        }
    }

    /// The same, its daemons running with no other test's: for a test that runs haptic
    /// loops on every CPU.
    pub fn alone(mut self) -> Self {
        // The shared turn ends before the lone one is waited for.
        self.turn = None;
        self.turn = Some(Turn::alone());
        self
    }

    /// No bus at all: an address in `dir` where nothing listens, for a hapticd that must stop
    /// before it serves (one that got as far would refuse to start: the bus was asked for).
    pub fn without_bus(dir: &Path, mechanisms: &Path) -> Self {
        let config = Self::prepare(dir, mechanisms);
        Self {
            dir: dir.to_path_buf(),
            config,
            address: format!("unix:path={}", dir.join("no-bus").display()),
            bus: None,
            turn: Some(Turn::shared()),
        }
    }

    /// `dir` made empty, with a configuration that names every directory hapticd searches.
    fn prepare(dir: &Path, mechanisms: &Path) -> PathBuf {
        let _ = std::fs::remove_dir_all(dir);
        std::fs::create_dir_all(dir.join("bus")).unwrap();
        let config = dir.join("hapticd.yaml");
        std::fs::write(
            &config,
            format!(
                "mechanism_dirs: [{}]\nscene_dirs: [{}]\nscene_plugin_dirs: [{}]\nscene: static\n",
                mechanisms.display(),
                repo_dir().join("config/scenes").display(),
                profile_dir().display(),
            ),
        )
        .unwrap();
        config
    }

    /// The D-Bus address hapticd serves on.
    pub fn address(&self) -> &str {
        &self.address
    }

    /// The configuration file hapticd reads.
    pub fn config(&self) -> &Path {
        &self.config
    }

    /// Whether a `dbus-daemon` listens at [`Isolated::address`].
    pub fn has_bus(&self) -> bool {
        self.bus.is_some()
    }

    /// `hapticd --config … --bus …` of this test, followed by `args` ([`command`]).
    pub fn hapticd(&self, args: &[&str]) -> Command {
        let mut command = command(&self.config, &self.address);
        command.args(args);
        command
    }
}

/// `hapticd --config CONFIG --bus=ADDRESS`, the one way tests start hapticd (more arguments
/// follow). Its environment names no bus, journal, notification socket, state directory,
/// cache or mechanism path of the host: the buses a library could fall back on are
/// `address` too, and meshes are cut into the tests' own cache.
pub fn command(config: &Path, address: &str) -> Command {
    let mut command = Command::new(artifact("hapticd"));
    command
        .arg("--config")
        .arg(config)
        .arg(format!("--bus={address}"))
        .env("DBUS_SYSTEM_BUS_ADDRESS", address)
        .env("DBUS_SESSION_BUS_ADDRESS", address)
        .env_remove("NOTIFY_SOCKET")
        .env_remove("JOURNAL_STREAM")
        .env_remove("STATE_DIRECTORY")
        .env_remove("HAPTICD_MECHANISM_PATH")
        .env("CACHE_DIRECTORY", super::mesh_cache());
    command
}

impl Drop for Isolated {
    fn drop(&mut self) {
        drop(self.bus.take());
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

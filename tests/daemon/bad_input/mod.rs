//! Bad input never reaches the motors: a corpus of hostile files and arguments, each refused
//! with a located, clear message or run safely; and a property test that no accepted
//! mechanism, whatever the scene asks and the counts say, gets a D/A command past its
//! string's `tension_max × volts_per_newton`.

use crate::support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::DVec3;
use hapticd_config::Config;
use hapticd_core::diagnostics::{Diagnostics, Position};
use hapticd_core::haptic_loop::{DeviceState, HapticLoop, LoopCommand, LoopSettings};
use hapticd_core::kinematics::Wrench;
use hapticd_core::mechanism::{Mechanism, descriptor};
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_core::scene::{Pointer, Scene};
use hapticd_core::transport::{
    AMPLIFIER_MAX_VOLTS, CHANNELS, DAC_DIGITS_PER_VOLT, Reading, Transport, TransportError,
};
use hapticd_device::sim::hand::Script;
use hapticd_physics::scene::PenaltyScene;
use hapticd_plugin_api::{HapticdEffector, HapticdString, MechanismSpec};
use support::bus::{NAME, PrivateBus};
use support::{Killed, Rng, artifact, plugin_path, repo_dir};

mod files;
mod programs;
mod saved_state;
mod string_limits;

fn shipped_text(relative: &str) -> String {
    std::fs::read_to_string(repo_dir().join(relative)).unwrap()
}

/// `text` with `from` replaced once; the corpus entry must change the file.
fn mutated(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from:?} is not in the file");
    text.replacen(from, to, 1)
}

/// Every finding of `result` must be located, and one must contain `expected`.
fn assert_refused<T>(result: Result<T, Diagnostics>, expected: &str, case: &str) {
    let Err(e) = result else {
        panic!("{case}: accepted");
    };
    let shown = e.to_string();
    assert!(
        e.diagnostics.iter().all(|d| d.position.is_some()),
        "{case}: an unlocated finding in\n{shown}"
    );
    assert!(
        shown.contains(expected),
        "{case}: {expected:?} not in\n{shown}"
    );
}

/// The SPIDAR-G plugin and `extra` descriptors staged as an install would have them.
fn mechanisms(name: &str, extra: &[(&str, &str)]) -> PathBuf {
    let dir = support::scratch("bad-input", name);
    let from = plugin_path("hapticd-spidar-g");
    std::fs::copy(&from, dir.join(from.file_name().unwrap())).unwrap();
    for (file, text) in extra {
        std::fs::write(dir.join(file), text).unwrap();
    }
    dir
}

fn run(program: &str, args: &[&str]) -> Output {
    Command::new(artifact(program))
        .args(args)
        .env_remove("NOTIFY_SOCKET")
        .env_remove("HAPTICD_MECHANISM_PATH")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

/// Refused cleanly: exit status 1 (not a panic's 101), with `expected` said on stderr.
fn assert_exit_1(out: &Output, expected: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(expected), "{expected:?} not in\n{stderr}");
}

/// `command` run to its end, which must come within `seconds` (a reader stuck on a FIFO
/// never ends: it is killed and the test fails).
fn finished_within(mut command: Command, seconds: u64) -> Output {
    let child = command
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let started = Instant::now();
    let mut child = Some(child);
    loop {
        if child.as_mut().unwrap().try_wait().unwrap().is_some() {
            return child.take().unwrap().wait_with_output().unwrap();
        }
        if started.elapsed() > Duration::from_secs(seconds) {
            let mut stuck = child.take().unwrap();
            let _ = stuck.kill();
            let out = stuck.wait_with_output().unwrap();
            panic!(
                "{command:?} (pid {pid}) still ran after {seconds} s: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A FIFO at `path`, which no one will ever write.
fn fifo(path: &Path) -> PathBuf {
    nix::unistd::mkfifo(path, nix::sys::stat::Mode::from_bits_truncate(0o600)).unwrap();
    path.to_path_buf()
}

/// `hapticd` on the simulated SPIDAR-G (the plugin staged in `mechanisms`), with a
/// configuration of its own in `dir`, serving on `address`, never the machine's buses.
fn hapticd_command(dir: &Path, mechanisms: &Path, address: &str, args: &[&str]) -> Command {
    let config = dir.join("hapticd.yaml");
    std::fs::write(
        &config,
        format!(
            "mechanism_dirs: [{}]\nscene_dirs: [{}]\nscene: static\n",
            mechanisms.display(),
            repo_dir().join("config/scenes").display()
        ),
    )
    .unwrap();
    let mut command = support::daemon::command(&config, address);
    command.args(["--sim", "spidar-g"]).args(args);
    command
}

/// A private bus in `dir`/bus with the shipped policy.
fn private_bus(dir: &Path) -> PrivateBus {
    let at = dir.join("bus");
    std::fs::create_dir_all(&at).unwrap();
    PrivateBus::start(
        &at,
        &repo_dir().join("config/dbus/org.hapticd.Hapticd1.conf"),
    )
}

const DEVICE: [&str; 3] = [
    NAME,
    "/org/hapticd/Hapticd1/device/0",
    "org.hapticd.Hapticd1.Device",
];

/// Taken by each test that runs a hapticd on a bus: one at a time, so that on a small
/// machine a start is not slowed by another test's haptic thread on the same CPU.
static ONE_DAEMON: Mutex<()> = Mutex::new(());

/// A running hapticd on a private bus; killed when dropped.
struct Served {
    bus: PrivateBus,
    daemon: Option<Killed>,
    log: PathBuf,
}

impl Served {
    /// hapticd started in `dir` with `args`, once its device runs; it must get there within
    /// 60 s whatever its state directory holds (a FIFO held it for 12 minutes).
    fn start(dir: &Path, args: &[&str]) -> Served {
        let mechanisms = dir.join("mechanisms");
        std::fs::create_dir_all(&mechanisms).unwrap();
        let plugin = plugin_path("hapticd-spidar-g");
        std::fs::copy(&plugin, mechanisms.join(plugin.file_name().unwrap())).unwrap();
        let bus = private_bus(dir);
        let log = dir.join("hapticd.log");
        let mut command = hapticd_command(dir, &mechanisms, &bus.address, args);
        command
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap());
        let mut served = Served {
            daemon: Some(Killed(command.spawn().unwrap())),
            bus,
            log,
        };
        let started = Instant::now();
        loop {
            let state = served.busctl(&["get-property", DEVICE[0], DEVICE[1], DEVICE[2], "State"]);
            if state == Ok("s \"running\"".into()) {
                break;
            }
            if let Some(status) = served.daemon.as_mut().unwrap().0.try_wait().unwrap() {
                panic!("hapticd exited ({status}): {}", served.log());
            }
            assert!(
                started.elapsed() < Duration::from_secs(60),
                "hapticd not running after 60 s ({state:?}): {}",
                served.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        served
    }

    /// What `busctl` printed, or its error.
    fn busctl(&self, args: &[&str]) -> Result<String, String> {
        let out = Command::new("busctl")
            .arg(format!("--address={}", self.bus.address))
            .args(args)
            .output()
            .expect("busctl (package systemd) is installed by `make check`");
        let text = |b: &[u8]| String::from_utf8_lossy(b).trim().to_string();
        match out.status.success() {
            true => Ok(text(&out.stdout)),
            false => Err(text(&out.stderr)),
        }
    }

    fn get(&self, property: &str) -> String {
        let got = self.busctl(&["get-property", DEVICE[0], DEVICE[1], DEVICE[2], property]);
        got.unwrap_or_else(|e| panic!("{property}: {e}"))
    }

    /// The numbers of a property such as `ad 3 1 2 3`.
    fn numbers(&self, property: &str) -> Vec<f64> {
        let value = self.get(property);
        let mut words = value.split_whitespace().skip(1);
        if value.starts_with('a') {
            words.next();
        }
        words.map(|w| w.parse().unwrap()).collect()
    }

    fn calibrate(&self) -> Result<String, String> {
        self.busctl(&["call", DEVICE[0], DEVICE[1], DEVICE[2], "Calibrate"])
    }

    fn set(&self, property: &str, value: &str) -> Result<String, String> {
        let [name, path, interface] = DEVICE;
        self.busctl(&["set-property", name, path, interface, property, "d", value])
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Stop hapticd with SIGTERM, which it must obey within 5 s.
    fn stop(mut self) {
        let mut daemon = self.daemon.take().unwrap();
        let pid = nix::unistd::Pid::from_raw(daemon.0.id() as i32);
        nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM).unwrap();
        let started = Instant::now();
        while daemon.0.try_wait().unwrap().is_none() {
            assert!(
                started.elapsed() < Duration::from_secs(5),
                "SIGTERM ignored: {}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

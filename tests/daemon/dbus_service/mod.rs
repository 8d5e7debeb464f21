//! hapticd's D-Bus service, used the way docs/bus-api.md tells users to: a private `dbus-daemon`
//! with the system bus's default policy and the shipped policy file, the real `hapticd` on the
//! simulated SPIDAR-G, and real `busctl` as the client.

use crate::support;

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use glam::DVec3;
use hapticd_render::picture::Picture;
use hapticd_ros2::messages::{Header, JointState, Message, StringMessage, Time, WrenchStamped};
use support::bus::{NAME, PrivateBus, RENDERER};
use support::haptic_cpu::Turn;
use support::{artifact, hapticctl, is_root, plugin_path, repo_dir};

mod access;
mod clients;
mod effects;
mod materials;
mod persistence;
mod properties;
mod ramps;
mod renderer;
mod scene_switching;
mod telemetry;
mod two_devices;
mod world_control;
mod zenoh;

const MANAGER: [&str; 3] = [
    NAME,
    "/org/hapticd/Hapticd1",
    "org.hapticd.Hapticd1.Manager",
];

const DEVICE: [&str; 3] = [
    NAME,
    "/org/hapticd/Hapticd1/device/0",
    "org.hapticd.Hapticd1.Device",
];

const SCENE: [&str; 3] = [
    NAME,
    "/org/hapticd/Hapticd1/scene",
    "org.hapticd.Hapticd1.Scene",
];

const PICTURES: [&str; 3] = [RENDERER, "/org/hapticd/Renderer1", "org.hapticd.Renderer1"];

/// A private bus with the system bus's default policy plus the shipped hapticd policy.
struct Bus {
    address: String,
    _private: PrivateBus,
    _turn: Turn,
}

impl Bus {
    /// `hapticctl ARGS` on this bus, to its end.
    fn ctl(&self, args: &[&str]) -> Output {
        hapticctl()
            .arg(format!("--bus={}", self.address))
            .args(args)
            .output()
            .unwrap()
    }

    /// A bus for a test that runs beside the others.
    fn start(dir: &Path) -> Bus {
        Bus::start_in_turn(dir, Turn::shared())
    }

    /// A bus for a test that measures timing, or runs haptic loops on every CPU: no other
    /// test's daemons or clients run.
    fn start_alone(dir: &Path) -> Bus {
        Bus::start_in_turn(dir, Turn::alone())
    }

    fn start_in_turn(dir: &Path, turn: Turn) -> Bus {
        let private = PrivateBus::with_policies(
            dir,
            &[
                &repo_dir().join("config/dbus/org.hapticd.Hapticd1.conf"),
                &repo_dir().join("config/dbus/org.hapticd.Renderer1.conf"),
            ],
        );
        Bus {
            address: private.address.clone(),
            _private: private,
            _turn: turn,
        }
    }

    /// `busctl` on this bus with `args`.
    fn busctl(&self, args: &[&str]) -> Output {
        Command::new("busctl")
            .arg(format!("--address={}", self.address))
            .args(args)
            .output()
            .expect("busctl (package systemd) is installed by `make check`")
    }

    /// `busctl` that must succeed; its output.
    fn ok(&self, args: &[&str]) -> String {
        let out = self.busctl(args);
        assert!(
            out.status.success(),
            "busctl {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).trim().to_string()
    }

    /// The D-Bus error name and message of a call that must fail. busctl prints only the
    /// message, so this asks dbus-send, which prints both.
    fn error(&self, path: &str, method: &str, args: &[&str]) -> (String, String) {
        dbus_send_error(
            Command::new("dbus-send"),
            &self.address,
            NAME,
            path,
            method,
            args,
        )
    }

    /// [`Bus::error`] of setting `property` of the device to dbus-send's `variant`.
    fn set_error(&self, property: &str, variant: &str) -> (String, String) {
        self.error(
            DEVICE[1],
            "org.freedesktop.DBus.Properties.Set",
            &[
                &format!("string:{}", DEVICE[2]),
                &format!("string:{property}"),
                &format!("variant:{variant}"),
            ],
        )
    }

    fn get(&self, object: [&str; 3], property: &str) -> String {
        self.ok(&["get-property", object[0], object[1], object[2], property])
    }

    fn set(&self, property: &str, signature: &str, value: &str) -> Output {
        self.busctl(&[
            "set-property",
            DEVICE[0],
            DEVICE[1],
            DEVICE[2],
            property,
            signature,
            value,
        ])
    }

    fn call(&self, object: [&str; 3], method: &str, args: &[&str]) -> Output {
        let mut all = vec!["call", object[0], object[1], object[2], method];
        all.extend(args);
        self.busctl(&all)
    }
}

/// Run `dbus_send` (a `dbus-send` command, perhaps behind `setpriv`) for a call that must
/// fail; its error name and message.
fn dbus_send_error(
    mut dbus_send: Command,
    address: &str,
    destination: &str,
    path: &str,
    method: &str,
    args: &[&str],
) -> (String, String) {
    let out = dbus_send
        .arg(format!("--bus={address}"))
        .arg("--print-reply")
        .arg(format!("--dest={destination}"))
        .arg(path)
        .arg(method)
        .args(args)
        .output()
        .expect("dbus-send (package dbus-bin) comes with dbus-daemon");
    assert!(!out.status.success(), "{method} {args:?} succeeded");
    let text = String::from_utf8_lossy(&out.stderr);
    let rest = text
        .trim()
        .strip_prefix("Error ")
        .unwrap_or_else(|| panic!("not a D-Bus error: {text}"));
    let (name, message) = rest.split_once(": ").unwrap_or((rest, ""));
    (name.to_string(), message.to_string())
}

/// Where one test's daemon keeps its files.
struct Setup {
    mechanisms: PathBuf,
    state: PathBuf,
    cache: PathBuf,
    config: PathBuf,
    log: PathBuf,
}

impl Setup {
    fn new(dir: &Path) -> Setup {
        let mechanisms = dir.join("mechanisms");
        std::fs::create_dir_all(&mechanisms).unwrap();
        let plugin = plugin_path("hapticd-spidar-g");
        std::fs::copy(&plugin, mechanisms.join(plugin.file_name().unwrap())).unwrap();
        let config = dir.join("hapticd.yaml");
        std::fs::write(&config, default_config()).unwrap();
        Setup {
            mechanisms,
            state: dir.join("state"),
            cache: dir.join("cache"),
            config,
            log: dir.join("hapticd.log"),
        }
    }
}

/// The physics engines' scene plugins, staged once as an install would have them (inside
/// target/, not the system's temporary directory: each run's copy weighs tens of megabytes).
fn scene_plugins() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = support::scratch_root().join(format!("scene-plugins-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for engine in [
            "hapticd-scene-penalty",
            "hapticd-scene-rapier",
            "hapticd-scene-floor",
        ] {
            let plugin = plugin_path(engine);
            std::fs::copy(&plugin, dir.join(plugin.file_name().unwrap())).unwrap();
        }
        dir
    })
    .clone()
}

fn default_config() -> String {
    format!(
        "scene_dirs: [{}]\nscene_plugin_dirs: [{}]\nscene: static\n",
        repo_dir().join("config/scenes").display(),
        scene_plugins().display()
    )
}

/// A running hapticd on `bus`, stopped with SIGTERM when dropped.
struct Hapticd {
    child: Option<Child>,
    log: PathBuf,
}

impl Hapticd {
    fn start(bus: &Bus, setup: &Setup, extra: &[&str]) -> Hapticd {
        let log = std::fs::File::create(&setup.log).unwrap();
        let child = support::daemon::command(&setup.config, &bus.address)
            .arg("--mechanism-dir")
            .arg(&setup.mechanisms)
            .arg("--state-dir")
            .arg(&setup.state)
            .args(extra)
            .env("CACHE_DIRECTORY", &setup.cache)
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .unwrap();
        let mut daemon = Hapticd {
            child: Some(child),
            log: setup.log.clone(),
        };
        let started = Instant::now();
        while !bus
            .busctl(&[
                "get-property",
                MANAGER[0],
                MANAGER[1],
                MANAGER[2],
                "ApiVersion",
            ])
            .status
            .success()
        {
            if let Some(status) = daemon.child.as_mut().unwrap().try_wait().unwrap() {
                panic!("hapticd exited ({status}): {}", daemon.log());
            }
            assert!(
                started.elapsed() < Duration::from_secs(30),
                "{}",
                daemon.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        // Ready once the first reading has calibrated the device (published at 10 Hz).
        while bus.get(DEVICE, "State") == "s \"calibrating\"" {
            assert!(
                started.elapsed() < Duration::from_secs(30),
                "never calibrated"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        daemon
    }

    /// Wait (up to 10 s) until the device's `State` is `state`.
    fn wait_for_state(&self, bus: &Bus, state: &str) {
        let (started, wanted) = (Instant::now(), format!("s \"{state}\""));
        while bus.get(DEVICE, "State") != wanted {
            assert!(
                started.elapsed() < Duration::from_secs(10),
                "never {state}: {}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The daemon's process id.
    fn pid(&self) -> u32 {
        self.child.as_ref().expect("running").id()
    }

    fn log(&self) -> String {
        let mut text = String::new();
        if let Ok(mut f) = std::fs::File::open(&self.log) {
            let _ = f.read_to_string(&mut text);
        }
        text
    }

    fn signal(&mut self, signal: nix::sys::signal::Signal) {
        if let Some(mut child) = self.child.take() {
            // It may have exited already: then there is only the status to collect.
            let pid = nix::unistd::Pid::from_raw(child.id() as i32);
            let _ = nix::sys::signal::kill(pid, signal);
            let _ = child.wait();
        }
    }

    fn stop(mut self) {
        self.signal(nix::sys::signal::Signal::SIGTERM);
    }
}

impl Drop for Hapticd {
    fn drop(&mut self) {
        self.signal(nix::sys::signal::Signal::SIGTERM);
    }
}

/// The numbers of a busctl value such as `ad 3 1 2 3` or `d 2000`.
fn numbers(value: &str) -> Vec<f64> {
    let mut words = value.split_whitespace().skip(1);
    if value.starts_with('a') {
        words.next();
    }
    words.map(|w| w.parse().unwrap()).collect()
}

fn number(value: &str) -> f64 {
    numbers(value)[0]
}

/// The value of `key` in a busctl `a{sd}` value.
fn entry(value: &str, key: &str) -> f64 {
    let words: Vec<&str> = value.split_whitespace().collect();
    let at = words
        .iter()
        .position(|w| *w == format!("\"{key}\""))
        .unwrap();
    words[at + 1].parse().unwrap()
}

/// The loop's own overruns so far: those whose tick woke on time and computed too long. On
/// this shared 2-CPU machine every other overrun, alone or beside readers, woke 0.1-14 ms
/// late and then computed 4-30 µs, with no page fault (hapticd logs each): the host stalling
/// the haptic CPU, more often while the other CPU is busy, which nothing kept off the
/// haptic CPU can cause through the loop (cyclictest's wakes are as late).
fn own_overruns(bus: &Bus) -> f64 {
    let stats = bus.get(DEVICE, "Statistics");
    entry(&stats, "overruns") - entry(&stats, "overruns_woken_late")
}

const PARAMETERS: [(&str, f64); 8] = [
    ("Stiffness", 3000.0),
    ("Damping", 7.5),
    ("StaticFriction", 0.5),
    ("DynamicFriction", 0.25),
    ("Lambda", 0.2),
    ("MaxForce", 8.0),
    ("MaxTorque", 0.2),
    ("Rate", 2000.0),
];

impl Bus {
    /// Scene method `method` with busctl's `signature` and words `args`; the body's state it
    /// answers with, as `(key, numbers)` (one number for `mass` and `friction`).
    fn drive(&self, method: &str, signature: &str, args: &[&str]) -> Result<BodyState, String> {
        let mut all = vec![
            "--json=short",
            "--",
            "call",
            SCENE[0],
            SCENE[1],
            SCENE[2],
            method,
        ];
        all.push(signature);
        all.extend(args);
        let out = self.busctl(&all);
        if !out.status.success() {
            return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
        }
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let map = &json["data"][0];
        let numbers = |key: &str| -> Vec<f64> {
            match &map[key]["data"] {
                serde_json::Value::Array(v) => v.iter().map(|x| x.as_f64().unwrap()).collect(),
                other => vec![other.as_f64().unwrap_or(f64::INFINITY)],
            }
        };
        Ok(BodyState {
            position: DVec3::from_slice(&numbers("position")),
            velocity: DVec3::from_slice(&numbers("velocity")),
            mass: numbers("mass")[0],
            friction: numbers("friction")[0],
            force: DVec3::from_slice(&numbers("force")),
        })
    }

    /// The D-Bus error name of Scene method `method` with dbus-send's `args`.
    fn drive_error(&self, method: &str, args: &[&str]) -> String {
        let method = format!("{}.{method}", SCENE[2]);
        self.error(SCENE[1], &method, args).0
    }
}

/// The bytes a hex string spells.
fn hex_bytes(hex: &str) -> Vec<u8> {
    (0..hex.len())
        .step_by(2)
        .map(|k| u8::from_str_radix(&hex[k..k + 2], 16).unwrap())
        .collect()
}

/// Switch to scene `name`, again while the daemon says its meshes are being cut (as
/// `hapticctl scene switch` does); whether it said so first.
fn switch_when_prepared(bus: &Bus, name: &str) -> bool {
    let started = Instant::now();
    let mut prepared = false;
    loop {
        let switched = bus.call(MANAGER, "SwitchScene", &["s", name]);
        if switched.status.success() {
            return prepared;
        }
        let said = String::from_utf8_lossy(&switched.stderr).into_owned();
        assert!(
            said.contains("being cut into convex pieces"),
            "{name}: {said}"
        );
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "{name}: {said}"
        );
        prepared = true;
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// One client: its own connection to the bus, getting the statistics and setting the
/// damping `rounds` times; the damping values it set.
async fn client(address: &str, id: usize, rounds: usize) -> zbus::Result<Vec<f64>> {
    let connection = zbus::connection::Builder::address(address).build().await?;
    let mut set = Vec::new();
    for round in 0..rounds {
        let properties = Some("org.freedesktop.DBus.Properties");
        connection
            .call_method(
                Some(NAME),
                DEVICE[1],
                properties,
                "Get",
                &(DEVICE[2], "Statistics"),
            )
            .await?;
        let value = 1.0 + (id * rounds + round) as f64 / 100.0;
        connection
            .call_method(
                Some(NAME),
                DEVICE[1],
                properties,
                "Set",
                &(DEVICE[2], "Damping", zbus::Variant::from(value)),
            )
            .await?;
        set.push(value);
    }
    Ok(set)
}

/// A stream of 30 frames a second opened with the renderer on `bus`: the viewer's connection
/// (the stream lasts while it is open) and the stream's ring.
fn stream_frames(bus: &Bus) -> (zbus::Connection, hapticd_ipc::frame_ring::FrameRingReader) {
    let viewer = bus.connect();
    let options = std::collections::HashMap::from([("rate", zbus::Variant::from(30.0))]);
    let stream = zbus::block_on(viewer.call_method(
        Some(RENDERER),
        PICTURES[1],
        Some(PICTURES[2]),
        "OpenFrameStream",
        &(options,),
    ));
    let ring: zbus::OwnedFd = stream.unwrap().body().deserialize().unwrap();
    let ring = hapticd_ipc::frame_ring::FrameRingReader::open(&ring.into()).unwrap();
    (viewer, ring)
}

/// A running `hapticd-zenoh` on its own port with a configuration file of the test's
/// (never the host's), as user `uid` (None: the test's own), in network namespace `inside`
/// (None: the test's own).
fn zenoh_bridge(
    bus: &Bus,
    dir: &Path,
    config: &str,
    uid: Option<u32>,
    inside: Option<&support::netns::Namespace>,
) -> (Child, String) {
    let (endpoint, port) = support::loopback_endpoint();
    let config = format!("listen: [{endpoint}]\n{config}");
    (
        zenoh_bridge_on(bus, dir, &config, port, uid, inside),
        endpoint,
    )
}

/// A running `hapticd-zenoh` with `config` for its network.yaml, which listens on `port`.
fn zenoh_bridge_on(
    bus: &Bus,
    dir: &Path,
    config: &str,
    port: u16,
    uid: Option<u32>,
    inside: Option<&support::netns::Namespace>,
) -> Child {
    let file = dir.join(format!("network-{port}.yaml"));
    std::fs::write(&file, config).unwrap();
    let mut command = match uid {
        Some(uid) => {
            let mut c = Command::new("setpriv");
            c.arg(format!("--reuid={uid}"))
                .arg(format!("--regid={uid}"))
                .arg("--clear-groups")
                .arg(artifact("hapticd-zenoh"));
            c
        }
        None => Command::new(artifact("hapticd-zenoh")),
    };
    // Started as its unit starts it, Type=notify: used once it says it is ready, that is
    // once every device's topics, commands and status are declared.
    command
        .arg("--config")
        .arg(&file)
        .args(["--bus", &bus.address, "--duration", "60"]);
    if let Some(namespace) = inside {
        namespace.enter(&mut command);
    }
    spawn_ready(command, &dir.join(format!("notify-{port}")))
}

/// `command` spawned as a unit of Type=notify starts it, with a notification socket at
/// `socket`; returned once it says READY=1 (within 30 s).
fn spawn_ready(mut command: Command, socket: &Path) -> Child {
    let notified = std::os::unix::net::UnixDatagram::bind(socket).unwrap();
    std::fs::set_permissions(socket, std::os::unix::fs::PermissionsExt::from_mode(0o777)).unwrap();
    notified
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let child = command.env("NOTIFY_SOCKET", socket).spawn().unwrap();
    let mut said = [0u8; 64];
    let n = notified
        .recv(&mut said)
        .unwrap_or_else(|e| panic!("{command:?} says READY=1: {e}"));
    assert_eq!(&said[..n], b"READY=1");
    child
}

/// The real Zenoh Python client running `script` against `endpoint` (`sys.argv[1]`, `args`
/// after it) from network namespace `inside`: what it printed, as JSON.
fn zenoh_client(
    script: &str,
    endpoint: &str,
    args: &[String],
    inside: Option<&support::netns::Namespace>,
) -> serde_json::Value {
    zenoh_client_with(script, endpoint, args, inside, &serde_json::json!({}))
}

/// [`zenoh_client`] with more of its Zenoh configuration (`settings`: key path → value); a
/// client that cannot open its session prints `{"unreachable": why}`.
fn zenoh_client_with(
    script: &str,
    endpoint: &str,
    args: &[String],
    inside: Option<&support::netns::Namespace>,
    settings: &serde_json::Value,
) -> serde_json::Value {
    let prelude = "import json, os, struct, sys, time, zenoh\n\
        conf = zenoh.Config()\n\
        conf.insert_json5('mode', '\"client\"')\n\
        conf.insert_json5('connect/endpoints', json.dumps([sys.argv[1]]))\n\
        for key, value in json.loads(os.environ['ZENOH_SETTINGS']).items():\n\
        \x20   conf.insert_json5(key, json.dumps(value))\n\
        try:\n\
        \x20   session = zenoh.open(conf)\n\
        except Exception as e:\n\
        \x20   print(json.dumps({'unreachable': str(e)}))\n\
        \x20   sys.exit(0)\n\
        def ask(key, payload):\n\
        \x20   replies = list(session.get(key, payload=payload, timeout=3.0))\n\
        \x20   return [r.ok.payload.to_string() if r.ok else 'error: ' + r.err.payload.to_string() for r in replies]\n";
    let mut command = Command::new("/usr/bin/python3");
    command
        .args(["-c", &format!("{prelude}{script}"), endpoint])
        .args(args)
        .env(
            "PYTHONPATH",
            std::env::join_paths([
                support::python_package("eclipse-zenoh"),
                // xxHash's own Python binding: what rmw_zenoh's GIDs are checked against.
                support::python_package("xxhash"),
            ])
            .unwrap(),
        )
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("ZENOH_SETTINGS", settings.to_string());
    if let Some(namespace) = inside {
        namespace.enter(&mut command);
    }
    let out = command.output().unwrap();
    assert!(out.status.success(), "{out:?}");
    serde_json::from_slice(&out.stdout).unwrap()
}

/// A running hapticd-render on `bus`, started as its unit starts it; killed when dropped.
struct Renderer {
    child: Child,
    log: PathBuf,
}

impl Renderer {
    /// Start the renderer with `env` added, and wait until it answers on the bus.
    fn start(bus: &Bus, dir: &Path, env: &[(&str, &str)]) -> Renderer {
        static STARTED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = STARTED.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let log = dir.join(format!("render-{n}.log"));
        let child = Command::new(artifact("hapticd-render"))
            .arg(format!("--bus={}", bus.address))
            .envs(env.iter().copied())
            .env_remove("NOTIFY_SOCKET")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap();
        let mut renderer = Renderer { child, log };
        let started = Instant::now();
        while !bus
            .busctl(&[
                "get-property",
                PICTURES[0],
                PICTURES[1],
                PICTURES[2],
                "Available",
            ])
            .status
            .success()
        {
            if let Some(status) = renderer.child.try_wait().unwrap() {
                panic!("hapticd-render exited ({status}): {}", renderer.log());
            }
            assert!(
                started.elapsed() < Duration::from_secs(30),
                "{}",
                renderer.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        renderer
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Kill it as a driver crash would: SIGKILL, no chance to tidy up.
    fn kill_9(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        self.kill_9();
    }
}

impl Bus {
    /// A Snapshot with `options` (busctl's `a{sv}` words after the count).
    fn snapshot(&self, options: &[&str]) -> Result<Picture, String> {
        let count = (options.len() / 3).to_string();
        let mut args = vec![
            "--json=short",
            "call",
            PICTURES[0],
            PICTURES[1],
            PICTURES[2],
        ];
        args.extend(["Snapshot", "a{sv}", &count]);
        args.extend(options);
        let out = self.busctl(&args);
        if !out.status.success() {
            return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
        }
        support::bus::snapshot_of_busctl_json(&out.stdout)
    }

    /// A client connection of the test's own.
    fn connect(&self) -> zbus::Connection {
        zbus::block_on(zbus::connection::Builder::address(self.address.as_str()).build()).unwrap()
    }

    /// The D-Bus error name and message of a Snapshot with `options` that must fail.
    fn snapshot_error(&self, options: &[(&str, zbus::Variant<'_>)]) -> (String, String) {
        let options: std::collections::HashMap<&str, &zbus::Variant<'_>> =
            options.iter().map(|(k, v)| (*k, v)).collect();
        let reply = zbus::block_on(self.connect().call_method(
            Some(RENDERER),
            PICTURES[1],
            Some(PICTURES[2]),
            "Snapshot",
            &(options,),
        ));
        match reply {
            Err(zbus::Error::MethodError(name, message, _)) => {
                (name.to_string(), message.unwrap_or_default())
            }
            other => panic!("not refused with a method error: {other:?}"),
        }
    }
}

/// A body's state as the Scene interface answers it.
#[derive(Debug, Clone, Copy)]
struct BodyState {
    position: DVec3,
    velocity: DVec3,
    mass: f64,
    friction: f64,
    force: DVec3,
}

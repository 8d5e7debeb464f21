//! hapticd's D-Bus service, used the way the README tells users to: a private `dbus-daemon`
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
use support::{artifact, hapticctl, is_root, plugin_path, repo_dir};

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

/// Taken shared by every test's bus, and exclusively by the one that measures the loop's
/// timing.
static EXCLUSIVE: std::sync::RwLock<()> = std::sync::RwLock::new(());

/// A private bus with the system bus's default policy plus the shipped hapticd policy.
struct Bus {
    address: String,
    _private: PrivateBus,
    _turn: Turn,
}

/// A test's turn on the machine: shared with the other tests, or alone.
enum Turn {
    Shared {
        _guard: std::sync::RwLockReadGuard<'static, ()>,
    },
    Alone {
        _guard: std::sync::RwLockWriteGuard<'static, ()>,
    },
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
        Bus::start_in_turn(
            dir,
            Turn::Shared {
                _guard: EXCLUSIVE.read().unwrap_or_else(|p| p.into_inner()),
            },
        )
    }

    /// A bus for a test that measures timing: no other test's daemons or clients run.
    fn start_alone(dir: &Path) -> Bus {
        Bus::start_in_turn(
            dir,
            Turn::Alone {
                _guard: EXCLUSIVE.write().unwrap_or_else(|p| p.into_inner()),
            },
        )
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
        let child = Command::new(artifact("hapticd"))
            .arg("--config")
            .arg(&setup.config)
            .arg("--mechanism-dir")
            .arg(&setup.mechanisms)
            .arg("--state-dir")
            .arg(&setup.state)
            .arg(format!("--bus={}", bus.address))
            .args(extra)
            .env_remove("NOTIFY_SOCKET")
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

#[test]
fn every_property_and_method_answers_as_the_readme_shows() {
    let dir = support::shared_scratch("dbus", "all");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    assert_eq!(bus.get(MANAGER, "ApiVersion"), "u 1");
    assert_eq!(
        bus.get(MANAGER, "Devices"),
        "ao 1 \"/org/hapticd/Hapticd1/device/0\""
    );
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"static\"");
    assert!(bus.get(MANAGER, "Scenes").contains("\"static\""));
    assert_eq!(bus.get(MANAGER, "Mechanisms"), "as 1 \"spidar-g\"");
    assert_eq!(bus.get(DEVICE, "Identity"), "s \"sim\"");
    assert_eq!(bus.get(DEVICE, "Mechanism"), "s \"spidar-g\"");
    assert_eq!(bus.get(DEVICE, "Effectors"), "as 1 \"grip\"");
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
    assert_eq!(bus.get(DEVICE, "StateReason"), "s \"\"");
    assert_eq!(bus.get(DEVICE, "Calibrated"), "b true");
    assert_eq!(numbers(&bus.get(DEVICE, "CalibrationOffsets")).len(), 8);
    assert_eq!(numbers(&bus.get(DEVICE, "Pose")).len(), 7);
    assert_eq!(numbers(&bus.get(DEVICE, "Force")).len(), 6);
    assert_eq!(numbers(&bus.get(DEVICE, "Tensions")).len(), 8);
    assert_eq!(number(&bus.get(DEVICE, "LoopRate")), 1000.0);
    let stats = bus.get(DEVICE, "Statistics");
    assert!(entry(&stats, "ticks") > 0.0, "{stats}");
    assert!(entry(&stats, "wait_p99_us") >= entry(&stats, "wait_p50_us"));
    assert!(bus.get(DEVICE, "Scheduling").starts_with("s \"SCHED_"));
    // The scene's proxy values are the defaults.
    assert_eq!(number(&bus.get(DEVICE, "Stiffness")), 2000.0);
    for (name, value) in PARAMETERS {
        let out = bus.set(name, "d", &value.to_string());
        assert!(out.status.success(), "{name}: {out:?}");
        assert_eq!(number(&bus.get(DEVICE, name)), value, "{name}");
    }
    assert!(bus.call(DEVICE, "Calibrate", &[]).status.success());
    assert!(bus.call(DEVICE, "ResetFault", &[]).status.success());
    assert!(
        bus.call(MANAGER, "SwitchScene", &["s", "static"])
            .status
            .success()
    );
    assert!(bus.call(MANAGER, "ReloadPlugins", &[]).status.success());
    assert!(
        bus.call(DEVICE, "BindMechanism", &["s", "spidar-g"])
            .status
            .success()
    );
    assert_eq!(bus.get(DEVICE, "BoundMechanism"), "s \"spidar-g\"");
    // Everything changed is on disk, and nothing else.
    let saved: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(setup.state.join("device-sim.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(saved["parameters"]["stiffness"], 3000.0);
    assert_eq!(saved["parameters"]["rate"], 2000.0);
    assert_eq!(saved["calibration"]["offsets"].as_array().unwrap().len(), 8);
    // Every change leaves a trace in the log, with who asked for it.
    let uid = nix::unistd::getuid();
    let log = daemon.log();
    for done in [
        "set Stiffness of sim to 3000".to_string(),
        "set Rate of sim to 2000".to_string(),
        "calibrate sim".to_string(),
        "reset the fault of sim".to_string(),
        "switch to scene \"static\"".to_string(),
        "reload the configuration and plugins".to_string(),
        "bind sim to mechanism \"spidar-g\"".to_string(),
    ] {
        assert!(
            log.contains(&format!("{done}, for uid {uid}")),
            "{done}: {log}"
        );
    }
    daemon.stop();
}

/// hapticd-ipc's typed clients, as an outside program uses them, against the real daemon
/// and renderer: what they read is what busctl reads, what they change busctl sees changed,
/// and the descriptors they are handed map as the world and a frame ring.
#[test]
fn the_ipc_proxies_read_change_and_map_what_busctl_sees() {
    use hapticd_ipc::frame_ring::FrameRingReader;
    use hapticd_ipc::proxies::{DeviceProxy, ManagerProxy, RendererProxy};
    use hapticd_ipc::world_share::MappedWorld;
    use std::collections::HashMap;
    use zbus::proxy::CacheProperties;

    let dir = support::shared_scratch("dbus", "proxies");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let _renderer = Renderer::start(&bus, &dir, &[]);
    let scene = dir.join("sent.yaml");
    std::fs::copy(repo_dir().join("config/scenes/static.yaml"), &scene).unwrap();
    let address = hapticd_ipc::bus::Bus::Address(bus.address.clone());
    zbus::block_on(async {
        let connection = address.connection().await.unwrap();
        let manager = ManagerProxy::builder(&connection)
            .cache_properties(CacheProperties::No)
            .build()
            .await
            .unwrap();
        assert_eq!(
            manager.api_version().await.unwrap(),
            hapticd_ipc::API_VERSION
        );
        let devices = manager.devices().await.unwrap();
        assert_eq!(devices.len(), 1);
        assert_eq!(devices[0].as_str(), hapticd_ipc::device_path(0));
        assert_eq!(manager.mechanisms().await.unwrap(), ["spidar-g"]);
        assert!(
            manager
                .scenes()
                .await
                .unwrap()
                .contains(&"static".to_string())
        );
        assert_eq!(manager.active_scene().await.unwrap(), "static");
        let device = DeviceProxy::builder(&connection)
            .path(devices[0].clone())
            .cache_properties(CacheProperties::No)
            .build()
            .await
            .unwrap();
        assert_eq!(device.identity().await.unwrap(), "sim");
        assert_eq!(device.effectors().await.unwrap(), ["grip"]);
        assert_eq!(device.state().await.unwrap(), "running");
        assert_eq!(device.tensions().await.unwrap().len(), 8);
        assert_eq!(device.loop_rate().await.unwrap(), 1000.0);
        assert!(device.statistics().await.unwrap()["ticks"] > 0.0);
        device.set_stiffness(2500.0).await.unwrap();
        assert_eq!(number(&bus.get(DEVICE, "Stiffness")), 2500.0);
        // A refusal comes back as the daemon's named error.
        match device.set_damping(f64::NAN).await {
            Err(zbus::Error::MethodError(name, _, _)) => assert_eq!(
                hapticd_ipc::names::error_name(name.as_str()),
                Some("NotFinite")
            ),
            other => panic!("NaN damping: {other:?}"),
        }
        device.calibrate().await.unwrap();
        device.reset_fault().await.unwrap();
        device.bind_mechanism("spidar-g").await.unwrap();
        assert_eq!(bus.get(DEVICE, "BoundMechanism"), "s \"spidar-g\"");
        // What anyone is handed to read is open for reading alone, as the README says.
        for handed in [
            device.open_world().await.unwrap(),
            device.open_geometry().await.unwrap().0,
            device.open_telemetry(HashMap::new()).await.unwrap(),
        ] {
            let handed: std::os::fd::OwnedFd = handed.into();
            let flags = nix::fcntl::fcntl(&handed, nix::fcntl::FcntlArg::F_GETFL).unwrap();
            let mode = nix::fcntl::OFlag::from_bits_truncate(flags) & nix::fcntl::OFlag::O_ACCMODE;
            assert_eq!(mode, nix::fcntl::OFlag::O_RDONLY);
        }
        let world = MappedWorld::open(&device.open_world().await.unwrap().into()).unwrap();
        let mut frame = Box::new(hapticd_core::world_state::WorldFrame::empty());
        assert!(
            world.read(&mut frame).is_some(),
            "no whole frame in the world"
        );
        assert_eq!((frame.effectors, frame.strings), (1, 8));
        let file = std::fs::File::open(&scene).unwrap();
        manager
            .switch_scene_file(zbus::Fd::from(&file), "sent")
            .await
            .unwrap();
        // The daemon runs its own copy of what it was sent.
        let copy = manager.active_scene_file().await.unwrap();
        assert_ne!(Path::new(&copy), scene);
        assert_eq!(
            std::fs::read(&copy).unwrap(),
            std::fs::read(&scene).unwrap()
        );
        manager.switch_scene("static").await.unwrap();
        manager.reload_plugins().await.unwrap();

        let renderer = RendererProxy::builder(&connection)
            .cache_properties(CacheProperties::No)
            .build()
            .await
            .unwrap();
        assert!(renderer.available().await.unwrap());
        assert!(renderer.limits().await.unwrap().contains_key("max-streams"));
        let size = HashMap::from([
            ("width", zbus::Variant::U32(64)),
            ("height", zbus::Variant::U32(48)),
        ]);
        let png = renderer.snapshot(size.clone()).await.unwrap();
        let picture = Picture::from_png(&png).unwrap();
        assert_eq!((picture.width, picture.height), (64, 48));
        let ring =
            FrameRingReader::open(&renderer.open_frame_stream(size).await.unwrap().into()).unwrap();
        assert_eq!(ring.size(), (64, 48));
    });
    daemon.stop();
}

#[test]
fn a_second_hapticd_refuses_to_take_the_name_of_a_running_one() {
    let dir = support::shared_scratch("dbus", "second");
    let bus = Bus::start(&dir);
    let first = Hapticd::start(&bus, &Setup::new(&dir), &["--sim", "spidar-g"]);
    let other = dir.join("other");
    std::fs::create_dir_all(&other).unwrap();
    let setup = Setup::new(&other);
    let second = Command::new(artifact("hapticd"))
        .arg("--config")
        .arg(&setup.config)
        .arg("--mechanism-dir")
        .arg(&setup.mechanisms)
        .args(["--sim", "spidar-g", "--duration", "2"])
        .arg(format!("--bus={}", bus.address))
        .env_remove("NOTIFY_SOCKET")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("org.hapticd.Hapticd1 is already owned")
            && stderr.contains("will not take its place"),
        "{stderr}"
    );
    // The first one still owns the name and answers for its device.
    assert_eq!(bus.get(MANAGER, "ApiVersion"), "u 1");
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
    first.stop();
}

#[test]
fn hapticctl_reaches_the_running_daemon_for_status_parameters_calibration_and_scenes() {
    let dir = support::shared_scratch("dbus", "client");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let ctl = |args: &[&str]| bus.ctl(args);
    let said = |out: &Output| String::from_utf8_lossy(&out.stdout).into_owned();
    let out = ctl(&["status"]);
    assert!(out.status.success(), "{out:?}");
    assert!(
        said(&out).contains("sim: running, spidar-g at 1000 Hz"),
        "{}",
        said(&out)
    );
    let status: serde_json::Value =
        serde_json::from_slice(&ctl(&["status", "--json"]).stdout).unwrap();
    assert_eq!(status["manager"]["ActiveScene"], "static");
    assert_eq!(status["devices"][0]["State"], "running");
    assert_eq!(status["devices"][0]["Mechanism"], "spidar-g");
    // Parameters: set, read back from the bus and from hapticctl.
    assert!(ctl(&["set", "Stiffness", "3000"]).status.success());
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 3000");
    assert_eq!(
        said(&ctl(&["get", "Stiffness", "--device", "sim"])),
        "3000\n"
    );
    // Refusals carry the daemon's reason and exit 1; a wrong device is a usage error.
    let out = ctl(&["set", "MaxForce", "500"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("OutOfRange: MaxForce must be in (0, 50], not 500"),
        "{stderr}"
    );
    let out = ctl(&["get", "Stiffness", "--device", "7"]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("no device \"7\": hapticd drives 0 (sim)"),
        "{stderr}"
    );
    // A name that is no parameter: the parameters are listed, a property is read-only.
    for (args, said) in [
        (
            ["set", "Bogus", "1"],
            "no parameter \"Bogus\": the parameters are Stiffness",
        ),
        (
            ["set", "State", "running"],
            "State is read-only: the parameters are Stiffness",
        ),
    ] {
        let out = ctl(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(said), "{stderr}");
    }
    // Calibration, scenes, reload and binding.
    assert!(ctl(&["calibrate"]).status.success());
    assert!(said(&ctl(&["scene", "list"])).contains("* static"));
    assert!(ctl(&["scene", "switch", "static"]).status.success());
    assert!(ctl(&["reload"]).status.success());
    assert!(ctl(&["bind", "spidar-g"]).status.success());
    assert_eq!(bus.get(DEVICE, "BoundMechanism"), "s \"spidar-g\"");
    // top, refreshed twice into a pipe: two frames, each with the device's line.
    let frames = said(&ctl(&["top", "--count", "2", "--interval", "0.2"]));
    assert_eq!(frames.matches("WAIT p99/max").count(), 2, "{frames}");
    assert!(frames.lines().all(|l| l.chars().count() <= 80), "{frames}");
    assert_eq!(
        frames.matches(" force ").count(),
        2,
        "one effector: {frames}"
    );
    assert_eq!(
        frames.lines().filter(|l| l.starts_with("sim ")).count(),
        2,
        "{frames}"
    );
    // Tab completion asks the daemon on the bus the line names for its names.
    let bus_option = format!("--bus={}", bus.address);
    let complete = |words: &[&str]| -> Vec<String> {
        let out = hapticctl()
            .env("COMPLETE", "fish")
            .args(["--", "hapticctl", &bus_option])
            .args(words)
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        said(&out)
            .lines()
            .map(|l| l.split('\t').next().unwrap().to_string())
            .collect()
    };
    assert_eq!(complete(&["set", "Stat"]), ["StaticFriction"]);
    let scenes = complete(&["scene", "switch", ""]);
    for name in ["static", "blocks", "top", "push"] {
        assert!(scenes.iter().any(|s| s == name), "{scenes:?}");
    }
    assert_eq!(complete(&["bind", "spidar-"]), ["spidar-g"]);
    assert_eq!(complete(&["calibrate", "--device", ""]), ["0", "sim"]);
    daemon.stop();
    // Without a daemon there is nothing to offer, and no error either.
    assert!(complete(&["bind", "spidar-"]).is_empty());
    // No daemon on the bus: said plainly.
    let out = ctl(&["status"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("hapticd is not running on the"), "{stderr}");
}

/// What waits for the next start is shown, and `hapticctl restart` applies it: a bound
/// mechanism and a changed rate are pending in `status` (text and JSON) until the restart
/// starts the loops again with them; a `--sim` on the command line fixes the mechanism, so a
/// binding is not pending then.
#[test]
fn pending_changes_are_shown_until_a_restart_applies_them() {
    let dir = support::shared_scratch("dbus", "pending");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let spidar_ii = plugin_path("hapticd-spidar-ii");
    std::fs::copy(
        &spidar_ii,
        setup.mechanisms.join(spidar_ii.file_name().unwrap()),
    )
    .unwrap();
    let said = |args: &[&str]| {
        let out = bus.ctl(args);
        assert!(out.status.success(), "{args:?}: {out:?}");
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let daemon = Hapticd::start(&bus, &setup, &[]);
    let status = said(&["status"]);
    assert!(!status.contains("pending"), "{status}");
    assert!(status.contains("renderer: not running"), "{status}");
    said(&["bind", "spidar-ii"]);
    said(&["set", "Rate", "2000"]);
    let status = said(&["status"]);
    assert!(
        status.contains(
            "pending until the next start: mechanism spidar-g -> spidar-ii, rate 1000 -> 2000"
        ),
        "{status}"
    );
    let json: serde_json::Value = serde_json::from_str(&said(&["status", "--json"])).unwrap();
    // The flag may come first, as the global ones do.
    let first: serde_json::Value = serde_json::from_str(&said(&["--json", "status"])).unwrap();
    assert_eq!(
        first["devices"][0]["Pending"],
        json["devices"][0]["Pending"]
    );
    let pending = &json["devices"][0]["Pending"];
    assert_eq!(pending["mechanism"]["next"], "spidar-ii", "{json}");
    assert_eq!(pending["rate"]["now"], "1000", "{json}");
    let restarted = said(&["restart"]);
    assert!(
        restarted.contains("sim: spidar-ii at 2000 Hz"),
        "{restarted}"
    );
    assert_eq!(bus.get(DEVICE, "Mechanism"), "s \"spidar-ii\"");
    assert!(!said(&["status"]).contains("pending"));
    daemon.stop();
    // The command line's mechanism wins over the binding: nothing waits for a restart.
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    assert_eq!(bus.get(DEVICE, "Mechanism"), "s \"spidar-g\"");
    assert!(!said(&["status"]).contains("pending"));
    daemon.stop();
}

/// hapticctl never has the bus start hapticd or its renderer: on a bus that could activate
/// both (activation files such as an older install left, whose program leaves a mark), every
/// command, reading or writing, says the daemon is not running, in the same words as on a
/// bus that could not, and nothing was started.
#[test]
fn hapticctl_never_starts_a_stopped_daemon_even_where_the_bus_could() {
    use std::os::unix::fs::PermissionsExt;
    let dir = support::shared_scratch("dbus", "no-activation");
    let services = dir.join("services");
    std::fs::create_dir_all(&services).unwrap();
    let mark = dir.join("started");
    let program = dir.join("activate");
    std::fs::write(
        &program,
        format!("#!/bin/sh\necho \"$0\" >> {}\n", mark.display()),
    )
    .unwrap();
    std::fs::set_permissions(&program, std::fs::Permissions::from_mode(0o755)).unwrap();
    for name in [NAME, RENDERER] {
        let file = format!("[D-BUS Service]\nName={name}\nExec={}\n", program.display());
        std::fs::write(services.join(format!("{name}.service")), file).unwrap();
    }
    let activation = dir.join("activation.conf");
    std::fs::write(
        &activation,
        format!(
            "<!DOCTYPE busconfig PUBLIC \"-//freedesktop//DTD D-BUS Bus Configuration 1.0//EN\" \
             \"http://www.freedesktop.org/standards/dbus/1.0/busconfig.dtd\">\n\
             <busconfig><servicedir>{}</servicedir></busconfig>\n",
            services.display()
        ),
    )
    .unwrap();
    let private = PrivateBus::with_policies(
        &dir,
        &[
            &repo_dir().join("config/dbus/org.hapticd.Hapticd1.conf"),
            &repo_dir().join("config/dbus/org.hapticd.Renderer1.conf"),
            &activation,
        ],
    );
    let address = format!("--address={}", private.address);
    // The bus can activate: a plain call starts the program (which never takes the name).
    let called = Command::new("busctl")
        .args([
            &address,
            "call",
            NAME,
            "/",
            "org.freedesktop.DBus.Peer",
            "Ping",
        ])
        .output()
        .unwrap();
    assert!(!called.status.success());
    assert!(mark.exists(), "the bus did not activate: {called:?}");
    std::fs::remove_file(&mark).unwrap();
    let picture = dir.join("picture.png");
    let csv = dir.join("record.csv");
    let commands: [&[&str]; 10] = [
        &["status"],
        &["get", "State"],
        &["top", "--count", "1"],
        &["monitor", "--count", "1"],
        &["record", "--duration", "1", csv.to_str().unwrap()],
        &["scene", "list"],
        &["set", "Stiffness", "2000"],
        &["calibrate"],
        &["reload"],
        &["snapshot", picture.to_str().unwrap()],
    ];
    for args in commands {
        let out = hapticctl()
            .arg(format!("--bus={}", private.address))
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        let said = if args[0] == "snapshot" {
            "hapticd-render is not running"
        } else {
            "hapticd is not running on the unix:path="
        };
        assert!(stderr.contains(said), "{args:?}: {stderr}");
        assert!(
            !mark.exists(),
            "{args:?} started {}",
            std::fs::read_to_string(&mark).unwrap()
        );
    }
}

/// Every scene `Scenes` lists can be switched to, in turn, and runs (a scene that names no
/// pointer solid gives each pointer a fingertip).
fn assert_every_listed_scene_switches(bus: &Bus, daemon: &Hapticd) {
    let listed = bus.get(MANAGER, "Scenes");
    let names: Vec<&str> = listed.split('"').skip(1).step_by(2).collect();
    assert!(
        names.contains(&"cube-drop") && names.contains(&"push"),
        "{listed}"
    );
    for name in names {
        switch_when_prepared(bus, name);
        assert_eq!(bus.get(MANAGER, "ActiveScene"), format!("s \"{name}\""));
        daemon.wait_for_state(bus, "running");
    }
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

#[test]
fn a_switch_to_a_mesh_scene_not_yet_cut_says_so_at_once_and_succeeds_once_cut() {
    let dir = support::shared_scratch("dbus", "preparing");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // The mug takes seconds to cut in a debug build, more than a switch waits.
    let (name, message) = bus.error(
        MANAGER[1],
        "org.hapticd.Hapticd1.Manager.SwitchScene",
        &["string:mug"],
    );
    assert_eq!(name, "org.hapticd.Hapticd1.Error.Preparing", "{message}");
    assert!(
        message.contains("meshes/mug.obj are now being cut"),
        "{message}"
    );
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"static\"");
    daemon.wait_for_state(&bus, "running");
    // Asked again while cutting: still being cut, not cut twice.
    let (name, message) = bus.error(
        MANAGER[1],
        "org.hapticd.Hapticd1.Manager.SwitchScene",
        &["string:mug"],
    );
    assert_eq!(name, "org.hapticd.Hapticd1.Error.Preparing", "{message}");
    assert!(message.contains("are still being cut"), "{message}");
    switch_when_prepared(&bus, "mug");
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"mug\"");
    daemon.wait_for_state(&bus, "running");
    let kept: Vec<_> = std::fs::read_dir(setup.cache.join("meshes"))
        .unwrap()
        .collect();
    assert_eq!(kept.len(), 1, "{kept:?}");
    // Cached, it switches at once: the rapier scene's movable mug is the same mesh, and its
    // fixed bracket is its own triangles, cut never.
    assert!(!switch_when_prepared(&bus, "bracket"));
    assert_eq!(
        std::fs::read_dir(setup.cache.join("meshes"))
            .unwrap()
            .count(),
        1
    );
    daemon.stop();
}

#[test]
fn a_mesh_scene_switches_when_its_pieces_cannot_be_kept() {
    let dir = support::shared_scratch("dbus", "unkept");
    let bus = Bus::start(&dir);
    let mut setup = Setup::new(&dir);
    // A cache under a regular file: nothing can be kept there.
    std::fs::write(dir.join("not-a-directory"), "").unwrap();
    setup.cache = dir.join("not-a-directory/cache");
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // Said to be cut at first; once cut and not kept, the plugin cuts them as it loads, and
    // the switch is done rather than promised again.
    assert!(switch_when_prepared(&bus, "mug"));
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"mug\"");
    assert!(
        daemon.log().contains("the cache cannot keep them"),
        "{}",
        daemon.log()
    );
    daemon.stop();
}

#[test]
fn physics_scenes_are_listed_switched_to_by_name_and_run_on_their_engine() {
    let dir = support::shared_scratch("dbus", "physics");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let scenes = bus.get(MANAGER, "Scenes");
    for name in ["static", "blocks", "stack", "top", "push", "balls"] {
        assert!(scenes.contains(&format!("\"{name}\"")), "{scenes}");
    }
    // Penalty to rapier and back, as any switch.
    for name in ["blocks", "balls", "blocks"] {
        assert!(
            bus.call(MANAGER, "SwitchScene", &["s", name])
                .status
                .success()
        );
        assert_eq!(bus.get(MANAGER, "ActiveScene"), format!("s \"{name}\""));
        daemon.wait_for_state(&bus, "running");
    }
    assert_every_listed_scene_switches(&bus, &daemon);
    // An engine's plugin by name, without a file: what is missing is said.
    let (name, message) = bus.error(
        MANAGER[1],
        "org.hapticd.Hapticd1.Manager.SwitchScene",
        &["string:penalty"],
    );
    assert_eq!(name, "org.hapticd.Hapticd1.Error.SceneFailed");
    assert!(
        message.contains("runs scene files and was given none"),
        "{message}"
    );
    daemon.stop();
    // Two effectors (a thumb and a finger): every listed scene takes two pointers as well.
    let spidar_ii = plugin_path("hapticd-spidar-ii");
    std::fs::copy(
        &spidar_ii,
        setup.mechanisms.join(spidar_ii.file_name().unwrap()),
    )
    .unwrap();
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-ii"]);
    assert_every_listed_scene_switches(&bus, &daemon);
    daemon.stop();
    // A physics scene as the configured default, as an installed daemon starts.
    let config = default_config().replace("scene: static", "scene: blocks");
    std::fs::write(&setup.config, config).unwrap();
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"blocks\"");
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
    daemon.stop();
}

#[test]
fn hapticctl_monitor_prints_each_change_as_it_happens() {
    use std::io::BufRead;
    let dir = support::shared_scratch("dbus", "monitor");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // Changes are announced ten times a second, after a Get already shows them: the start's
    // own (calibrating → running) is out before the monitor watches.
    std::thread::sleep(Duration::from_millis(300));
    let mut monitor = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["monitor", "--duration", "3"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(monitor.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    assert!(first.starts_with("watching hapticd on the"), "{first}");
    // A parameter changed, then a calibration: its offsets, and the state it passes through.
    assert!(bus.set("Stiffness", "d", "2500").status.success());
    assert!(bus.call(DEVICE, "Calibrate", &[]).status.success());
    let stamped: Vec<String> = lines.map(Result::unwrap).collect();
    assert!(monitor.wait().unwrap().success());
    // Each line is stamped with the time of day, HH:MM:SS.mmm.
    let events: Vec<String> = stamped
        .iter()
        .map(|line| {
            let (time, event) = line.split_once(' ').unwrap();
            assert!(
                time.len() == 12 && time.as_bytes()[2] == b':' && time.as_bytes()[8] == b'.',
                "{line}"
            );
            event.to_string()
        })
        .collect();
    let device = "/org/hapticd/Hapticd1/device/0";
    assert_eq!(
        events[0],
        format!("{device}: Stiffness = 2500"),
        "{events:?}"
    );
    // Telemetry (Pose, Force, Tensions, Statistics) is not an event.
    assert!(!events.iter().any(|e| e.contains(": Pose =")), "{events:?}");
    // Each change once, though the request and the periodic announcement both signal it.
    let calibrated = format!("{device}: Calibrated = true");
    assert_eq!(
        events.iter().filter(|e| **e == calibrated).count(),
        1,
        "{events:?}"
    );
    let offsets = format!("{device}: CalibrationOffsets = ");
    assert_eq!(
        events.iter().filter(|e| e.starts_with(&offsets)).count(),
        1,
        "{events:?}"
    );
    daemon.stop();
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

/// The ticks of 10 s that `hapticctl record` and the Python iterator each read from a daemon
/// at `rate` (every one, in order), while the renderer streams and a hundred clients read
/// properties; and the loop's overruns in those 10 s and in the 10 s just before, with the
/// stream and the clients but without the readers.
struct EveryTick {
    rows: Vec<String>,
    python: String,
    overruns: (f64, f64),
    frames: u64,
    /// Whether the haptic thread ran under SCHED_FIFO (else the readers compete with it for
    /// the CPUs, and its overruns say nothing of them).
    realtime: bool,
}

fn every_tick(rate: &str) -> EveryTick {
    let dir = support::shared_scratch("dbus", &format!("record-{rate}"));
    // Alone: its overruns are compared across 20 s.
    let bus = Bus::start_alone(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g", "--rate", rate]);
    let _renderer = Renderer::start(&bus, &dir, &[]);
    let overruns = || entry(&bus.get(DEVICE, "Statistics"), "overruns");
    let realtime = bus.get(DEVICE, "Scheduling").contains("SCHED_FIFO");
    while entry(&bus.get(DEVICE, "Statistics"), "ticks") < 1000.0 {
        std::thread::sleep(Duration::from_millis(50));
    }
    let (_viewer, ring) = stream_frames(&bus);
    let first_frame = ring.latest();
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let readers: Vec<_> = (0..100)
        .map(|_| {
            let (address, done) = (bus.address.clone(), done.clone());
            std::thread::spawn(move || {
                let connection =
                    zbus::block_on(zbus::connection::Builder::address(address.as_str()).build())
                        .unwrap();
                while !done.load(std::sync::atomic::Ordering::Acquire) {
                    zbus::block_on(connection.call_method(
                        Some(NAME),
                        DEVICE[1],
                        Some("org.freedesktop.DBus.Properties"),
                        "GetAll",
                        &(DEVICE[2],),
                    ))
                    .unwrap();
                    std::thread::sleep(Duration::from_millis(100));
                }
            })
        })
        .collect();
    // 10 s with the stream and the clients and no reader of the ring, then 10 s with them.
    let before = overruns();
    std::thread::sleep(Duration::from_secs(10));
    let alone = overruns() - before;
    let before = overruns();
    let csv = dir.join("telemetry.csv");
    let record = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["record", "--duration", "10"])
        .arg(&csv)
        .spawn()
        .unwrap();
    let follow = "import sys, hapticd\n\
                  ticks = [s.tick for s in hapticd.connect(sys.argv[1]).devices[0].telemetry(seconds=10)]\n\
                  gaps = sum(1 for a, b in zip(ticks, ticks[1:]) if b != a + 1)\n\
                  print(f'{len(ticks)} ticks, {gaps} gaps')\n";
    let python = Command::new("/usr/bin/python3")
        .args(["-c", follow, &bus.address])
        .env("PYTHONPATH", repo_dir().join("daemon/python"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .unwrap();
    let recorded = record.wait_with_output().unwrap();
    let during = overruns() - before;
    done.store(true, std::sync::atomic::Ordering::Release);
    for reader in readers {
        reader.join().unwrap();
    }
    assert!(recorded.status.success(), "{recorded:?}");
    assert!(python.status.success(), "{python:?}");
    let frames = ring.latest() - first_frame;
    daemon.stop();
    EveryTick {
        rows: std::fs::read_to_string(&csv)
            .unwrap()
            .lines()
            .map(String::from)
            .collect(),
        python: String::from_utf8_lossy(&python.stdout).trim().to_string(),
        overruns: (alone, during),
        frames,
        realtime,
    }
}

/// The issue's check: at 1 and 10 kHz, `hapticctl record` and the Python iterator each get
/// every tick of 10 s while the renderer streams and 100 clients read properties, and the
/// loop overruns no more than in the 10 s before without the readers (the stream and the
/// clients already there).
#[test]
fn every_tick_reaches_hapticctl_and_python_at_1_and_10_khz_beside_a_stream_and_100_readers() {
    for (rate, ticks) in [("1000", 10_000), ("10000", 100_000)] {
        // Every tick in every round; the overruns within bounds in one of three (a shared
        // two-core machine's host steals ticks in bursts, while readers that disturbed the
        // loop would cost ticks in every round).
        let mut rounds = Vec::new();
        let rows = loop {
            let EveryTick {
                rows,
                python,
                overruns: (alone, during),
                frames,
                realtime,
            } = every_tick(rate);
            let said = format!(
                "{rate} Hz: overruns {alone} without the readers, {during} beside them (the \
                 renderer streaming and 100 clients reading all the while); {frames} frames \
                 streamed; python: {python}; SCHED_FIFO: {realtime}"
            );
            println!("{said}");
            assert_eq!(python, format!("{ticks} ticks, 0 gaps"), "{said}");
            assert!(frames >= 30, "{said}");
            rounds.push(said);
            if !realtime || during <= 2.0 * alone + 10.0 {
                break rows;
            }
            assert!(rounds.len() < 3, "overruns in every round: {rounds:?}");
        };
        let header: Vec<&str> = rows[0].split(',').collect();
        assert_eq!(
            header[..32],
            [
                "tick",
                "time",
                "state",
                "pose_x",
                "pose_y",
                "pose_z",
                "pose_qw",
                "pose_qx",
                "pose_qy",
                "pose_qz",
                "velocity_x",
                "velocity_y",
                "velocity_z",
                "angular_velocity_x",
                "angular_velocity_y",
                "angular_velocity_z",
                "force_x",
                "force_y",
                "force_z",
                "torque_x",
                "torque_y",
                "torque_z",
                "contact",
                "contact_body",
                "slip",
                "contact_x",
                "contact_y",
                "contact_z",
                "normal_x",
                "normal_y",
                "normal_z",
                "tension_1"
            ]
        );
        // SPIDAR-G: eight strings, a tension and a D/A value each.
        assert_eq!(header.len(), 31 + 16, "{}", rows[0]);
        assert_eq!(rows.len() - 1, ticks, "{rate} Hz");
        let mut previous: Option<(u64, f64)> = None;
        for row in &rows[1..] {
            let fields: Vec<&str> = row.split(',').collect();
            assert_eq!(fields.len(), header.len(), "{row}");
            let (tick, time): (u64, f64) = (fields[0].parse().unwrap(), fields[1].parse().unwrap());
            // Every tick, in order, none lost, a period apart.
            if let Some((t, s)) = previous {
                assert_eq!(tick, t + 1, "{rate} Hz: {row}");
                let period = 1.0 / rate.parse::<f64>().unwrap();
                assert!((time - s - period).abs() < 1e-6, "{rate} Hz: {row}");
            }
            previous = Some((tick, time));
            assert_eq!(fields[2], "running", "{row}");
            let q: f64 = fields[6..10]
                .iter()
                .map(|x| x.parse::<f64>().unwrap().powi(2))
                .sum();
            assert!((q - 1.0).abs() < 1e-6, "{row}");
        }
    }
}

#[test]
fn bad_inputs_return_named_errors_and_change_nothing() {
    let dir = support::shared_scratch("dbus", "bad");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let before = bus.get(DEVICE, "Stiffness");
    let set = |property: &str, variant: &str| bus.set_error(property, variant);
    let error = |prefix: &str, reason: &str| format!("{prefix}.{reason}");
    let ours = |reason| error("org.hapticd.Hapticd1.Error", reason);
    let fdo = |reason| error("org.freedesktop.DBus.Error", reason);
    assert_eq!(set("Stiffness", "string:stiff").0, fdo("InvalidArgs"));
    for value in ["nan", "inf", "-inf"] {
        let (name, message) = set("Stiffness", &format!("double:{value}"));
        assert_eq!(name, ours("NotFinite"), "{value}");
        assert!(
            message.contains("Stiffness must be a finite number"),
            "{message}"
        );
    }
    let (name, message) = set("Stiffness", "double:1e9");
    assert_eq!(name, ours("OutOfRange"));
    assert!(message.contains("(0, 100000]"), "{message}");
    assert_eq!(set("MaxForce", "double:-1").0, ours("OutOfRange"));
    assert_eq!(set("DynamicFriction", "double:0.9").0, ours("OutOfRange"));
    assert_eq!(set("Rate", "double:50").0, ours("OutOfRange"));
    assert_eq!(set("Stiffnes", "double:1").0, fdo("UnknownProperty"));
    // zbus answers a write to a read-only property as to an unknown one.
    let (name, message) = set("State", "string:fault");
    assert_eq!(name, fdo("UnknownProperty"));
    assert!(message.contains("State"), "{message}");
    let call = |object: [&str; 3], method: &str, args: &[&str]| {
        bus.error(object[1], &format!("{}.{method}", object[2]), args)
    };
    assert_eq!(
        call(MANAGER, "SwitchScene", &["string:nowhere"]).0,
        ours("UnknownScene")
    );
    // A file of the caller's goes by descriptor; its mistakes come back with their places.
    let broken = dir.join("broken.yaml");
    std::fs::write(&broken, "name: broken\nshapes:\n  - floor: { hieght: 0 }\n").unwrap();
    let out = bus.ctl(&["scene", "switch", broken.to_str().unwrap()]);
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        message.contains("SceneFailed: broken.yaml:3:") && message.contains("hieght"),
        "{message}"
    );
    // A path over the bus is no scene name.
    let (name, _) = call(
        MANAGER,
        "SwitchScene",
        &[&format!("string:{}", broken.display())],
    );
    assert_eq!(name, ours("NameExpected"));
    assert_eq!(
        call(DEVICE, "BindMechanism", &["string:no-such"]).0,
        ours("UnknownMechanism")
    );
    let elsewhere = [DEVICE[0], "/org/hapticd/Hapticd1/device/7", DEVICE[2]];
    assert_eq!(call(elsewhere, "Calibrate", &[]).0, fdo("UnknownObject"));
    assert_eq!(
        call(DEVICE, "Calibrate", &["string:x"]).0,
        fdo("InvalidArgs")
    );
    // Nothing changed, in the daemon or on disk.
    assert_eq!(bus.get(DEVICE, "Stiffness"), before);
    assert_eq!(bus.get(DEVICE, "DynamicFriction"), "d 0.2");
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"static\"");
    assert_eq!(bus.get(DEVICE, "BoundMechanism"), "s \"\"");
    assert!(!setup.state.join("device-sim.json").exists());
    // The refusals are in the log too, with who asked.
    let log = daemon.log();
    let uid = nix::unistd::getuid();
    for refused in [
        "refused to set MaxForce of sim to -1".to_string(),
        "refused to switch to scene \"nowhere\"".to_string(),
        "refused to bind sim to mechanism \"no-such\"".to_string(),
    ] {
        assert!(
            log.contains(&format!("{refused}, for uid {uid}")),
            "{refused}: {log}"
        );
    }
}

#[test]
fn an_unprivileged_client_may_read_but_not_change() {
    if !is_root() {
        eprintln!("skipped: switching to an unprivileged uid needs root");
        return;
    }
    let dir = support::shared_scratch("dbus", "unprivileged");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let as_nobody = |args: &[&str]| {
        Command::new("setpriv")
            .args(["--reuid=65534", "--regid=65534", "--clear-groups", "busctl"])
            .arg(format!("--address={}", bus.address))
            .args(args)
            .output()
            .unwrap()
    };
    let read = as_nobody(&["get-property", DEVICE[0], DEVICE[1], DEVICE[2], "Stiffness"]);
    assert!(read.status.success(), "{read:?}");
    assert_eq!(String::from_utf8_lossy(&read.stdout).trim(), "d 2000");
    let denied = |object: [&str; 3], method: &str, args: &[&str]| {
        let mut setpriv = Command::new("setpriv");
        setpriv.args([
            "--reuid=65534",
            "--regid=65534",
            "--clear-groups",
            "dbus-send",
        ]);
        let (name, _) = dbus_send_error(setpriv, &bus.address, NAME, object[1], method, args);
        assert_eq!(name, "org.freedesktop.DBus.Error.AccessDenied", "{method}");
    };
    let set = [
        "string:org.hapticd.Hapticd1.Device",
        "string:Stiffness",
        "variant:double:10",
    ];
    denied(DEVICE, "org.freedesktop.DBus.Properties.Set", &set);
    denied(DEVICE, "org.hapticd.Hapticd1.Device.Calibrate", &[]);
    denied(DEVICE, "org.hapticd.Hapticd1.Device.ResetFault", &[]);
    // Nor may it push on the hand, by a commanded wrench or by a world of its own.
    for method in ["OpenWrenchInput", "OpenWorldLink"] {
        let opened = as_nobody(&[
            "call", DEVICE[0], DEVICE[1], DEVICE[2], method, "a{sv}", "0",
        ]);
        assert!(
            !opened.status.success()
                && String::from_utf8_lossy(&opened.stderr).contains("Access denied"),
            "{method}: {opened:?}"
        );
    }
    denied(
        MANAGER,
        "org.hapticd.Hapticd1.Manager.SwitchScene",
        &["string:static"],
    );
    denied(MANAGER, "org.hapticd.Hapticd1.Manager.ReloadPlugins", &[]);
    denied(MANAGER, "org.hapticd.Hapticd1.Manager.Restart", &[]);
    for method in ["SetMass", "SetFriction"] {
        denied(
            SCENE,
            &format!("org.hapticd.Hapticd1.Scene.{method}"),
            &["string:block", "double:1"],
        );
    }
    denied(
        SCENE,
        "org.hapticd.Hapticd1.Scene.SetForce",
        &["string:block", "array:double:0,1,0"],
    );
    // Where a body is may be read by anyone: the daemon itself answers (no bodies here).
    let mut setpriv = Command::new("setpriv");
    setpriv.args([
        "--reuid=65534",
        "--regid=65534",
        "--clear-groups",
        "dbus-send",
    ]);
    let method = "org.hapticd.Hapticd1.Scene.Body";
    let (name, _) = dbus_send_error(
        setpriv,
        &bus.address,
        NAME,
        SCENE[1],
        method,
        &["string:block"],
    );
    assert_eq!(name, "org.hapticd.Hapticd1.Error.Unavailable");
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000");
}

/// Ten read loops of `Scenes` as `nobody` for `seconds`, each over a connection of its own
/// (Python and jeepney, as a script would): the reads they made.
fn unprivileged_scene_readers(bus: &Bus, seconds: f64) -> Child {
    const LOOPS: &str = r#"
import sys, threading, time
from jeepney import DBusAddress, Properties
from jeepney.io.blocking import open_dbus_connection
address, seconds = sys.argv[1], float(sys.argv[2])
manager = DBusAddress("/org/hapticd/Hapticd1", bus_name="org.hapticd.Hapticd1",
                      interface="org.hapticd.Hapticd1.Manager")
reads = [0] * 10
def loop(k):
    connection = open_dbus_connection(address)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        reply = connection.send_and_get_reply(Properties(manager).get("Scenes"))
        assert "big" in reply.body[0][1], reply.body
        reads[k] += 1
threads = [threading.Thread(target=loop, args=(k,)) for k in range(10)]
for t in threads: t.start()
for t in threads: t.join()
print(sum(reads))
"#;
    Command::new("setpriv")
        .args([
            "--reuid=65534",
            "--regid=65534",
            "--clear-groups",
            "/usr/bin/python3",
            "-c",
            LOOPS,
        ])
        .arg(&bus.address)
        .arg(seconds.to_string())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Listing scenes reads no meshes: with a scene of a 490 000-triangle mesh installed (each
/// read took 0.45 s, and ten unprivileged read loops delayed root's requests by seconds),
/// `Scenes` answers in milliseconds, lists the scene, and the loops delay nothing.
/// A private bus (made by `bus`, shared or alone) and a daemon's set-up in `dir` whose one
/// scene directory holds the shipped `static` scene and `name`: a floor and a binary STL of
/// `triangles` triangles (`corners` of each by its number), in millimetres times `scale`.
fn mesh_scene(
    bus: fn(&Path) -> Bus,
    dir: &Path,
    name: &str,
    triangles: u32,
    scale: f64,
    corners: impl Fn(u32) -> [[f32; 3]; 3],
) -> (Bus, Setup) {
    let scenes = dir.join("scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::copy(
        repo_dir().join("config/scenes/static.yaml"),
        scenes.join("static.yaml"),
    )
    .unwrap();
    let mut stl = vec![0u8; 80];
    stl.extend(triangles.to_le_bytes());
    for t in 0..triangles {
        // The face normal is not read: the corners' order gives the face.
        stl.extend([0f32; 3].iter().flat_map(|v| v.to_le_bytes()));
        for corner in corners(t) {
            stl.extend(corner.iter().flat_map(|v| v.to_le_bytes()));
        }
        stl.extend([0u8; 2]);
    }
    std::fs::write(scenes.join(format!("{name}.stl")), &stl).unwrap();
    std::fs::write(
        scenes.join(format!("{name}.yaml")),
        format!(
            "name: {name}\nshapes:\n  - floor: {{ height: -0.05 }}\n  - mesh: {{ file: {name}.stl, scale: {scale} }}\n"
        ),
    )
    .unwrap();
    let bus = bus(dir);
    let setup = Setup::new(dir);
    std::fs::write(
        &setup.config,
        default_config().replace(
            &repo_dir().join("config/scenes").display().to_string(),
            &scenes.display().to_string(),
        ),
    )
    .unwrap();
    (bus, setup)
}

/// A scene's solids are shared whole, however many triangles its meshes have (the world's
/// block once kept the first 16 384), labelled with the frames' count of the scene they are,
/// and shared anew when a scene is switched to.
#[test]
fn the_running_scene_s_solids_are_shared_whole_and_anew_at_each_switch() {
    let dir = support::shared_scratch("dbus", "geometry");
    // A strip of 40 000 thin slivers 1 mm apart.
    let triangles = 40_000u32;
    let (bus, setup) = mesh_scene(Bus::start, &dir, "strip", triangles, 0.005, |t| {
        let x = t as f32 * 0.001;
        [[x, 0.0, 0.0], [x + 0.001, 0.0, 0.0], [x, 0.001, 0.0]]
    });
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g", "--scene", "strip"]);
    let connection = bus.connect();
    zbus::block_on(async {
        use hapticd_ipc::proxies::{DeviceProxy, ManagerProxy};
        use hapticd_ipc::world_share::MappedWorld;
        let device = DeviceProxy::builder(&connection)
            .path(hapticd_ipc::device_path(0))
            .build()
            .await
            .unwrap();
        let world = MappedWorld::open(&device.open_world().await.unwrap().into()).unwrap();
        let mut frame = Box::new(hapticd_core::world_state::WorldFrame::empty());
        let (fd, switches) = device.open_geometry().await.unwrap();
        let (written, geometry) = hapticd_ipc::geometry_share::read(&fd.into()).unwrap();
        world.read(&mut frame).unwrap();
        assert_eq!(
            (written, switches),
            (frame.scene_switches, frame.scene_switches)
        );
        assert_eq!(geometry.triangles.len(), triangles as usize);
        let mesh = geometry
            .solids
            .iter()
            .find(|s| s.triangle_count > 0)
            .unwrap();
        assert_eq!(mesh.triangle_count, triangles);
        // The strip reaches as far as the file's last sliver, times the scale.
        let reach = geometry
            .triangles
            .iter()
            .flat_map(|t| t.corners)
            .map(|c| c[0])
            .fold(f64::MIN, f64::max);
        assert!(
            (reach - 0.005 * 0.001 * f64::from(triangles)).abs() < 1e-6,
            "{reach}"
        );
        let manager = ManagerProxy::new(&connection).await.unwrap();
        manager.switch_scene("static").await.unwrap();
        let (fd, after) = device.open_geometry().await.unwrap();
        let (_, geometry) = hapticd_ipc::geometry_share::read(&fd.into()).unwrap();
        world.read(&mut frame).unwrap();
        assert_eq!(after, switches + 1);
        assert_eq!(after, frame.scene_switches);
        assert!(geometry.triangles.is_empty() && !geometry.solids.is_empty());
    });
}

#[test]
fn scenes_are_listed_without_reading_their_meshes_whoever_asks_how_often() {
    if !is_root() {
        eprintln!("skipped: switching to an unprivileged uid needs root");
        return;
    }
    let dir = support::shared_scratch("dbus", "listing");
    // 490 000 small triangles in a 5 cm cube; the delays measured with no other test's
    // daemon beside.
    let (bus, setup) = mesh_scene(Bus::start_alone, &dir, "big", 490_000, 0.001, |t| {
        let corner = |k: u32| {
            let n = t.wrapping_mul(2_654_435_761).wrapping_add(k * 97);
            [n % 50, (n / 50) % 50, (n / 2500) % 50].map(|c| c as f32)
        };
        [corner(0), corner(1), corner(2)]
    });
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let connection = bus.connect();
    let get = |interface: &str, property: &str| {
        let started = Instant::now();
        let reply = zbus::block_on(connection.call_method(
            Some(NAME),
            MANAGER[1],
            Some("org.freedesktop.DBus.Properties"),
            "Get",
            &(interface, property),
        ))
        .unwrap();
        let value: zbus::OwnedVariant = reply.body().deserialize().unwrap();
        (started.elapsed(), value)
    };
    let mut times: Vec<Duration> = (0..20)
        .map(|_| {
            let (took, value) = get(MANAGER[2], "Scenes");
            let names: Vec<String> = value.try_into().unwrap();
            assert_eq!(names, ["big", "static"]);
            took
        })
        .collect();
    times.sort();
    assert!(times[10] < Duration::from_millis(5), "{times:?}");
    // Root's Set and `hapticctl status`, alone and beside the loops.
    let set = |value: f64| {
        let started = Instant::now();
        let reply = zbus::block_on(connection.call_method(
            Some(NAME),
            DEVICE[1],
            Some("org.freedesktop.DBus.Properties"),
            "Set",
            &(DEVICE[2], "Stiffness", zbus::Variant::from(value)),
        ));
        assert!(reply.is_ok(), "{reply:?}");
        started.elapsed()
    };
    let status = || {
        let started = Instant::now();
        assert!(bus.ctl(&["status"]).status.success());
        started.elapsed()
    };
    let median = |mut t: Vec<Duration>| {
        t.sort();
        t[t.len() / 2]
    };
    let alone = (
        median((0..10).map(|k| set(1000.0 + f64::from(k))).collect()),
        median((0..5).map(|_| status()).collect()),
    );
    let loops = unprivileged_scene_readers(&bus, 4.0);
    std::thread::sleep(Duration::from_millis(500));
    let mut beside = (Duration::ZERO, Duration::ZERO);
    for k in 0..10 {
        beside.0 = beside.0.max(set(1500.0 + f64::from(k)));
        if k % 2 == 0 {
            beside.1 = beside.1.max(status());
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    let reads = loops.wait_with_output().unwrap();
    assert!(reads.status.success(), "{reads:?}");
    let reads: u64 = String::from_utf8_lossy(&reads.stdout)
        .trim()
        .parse()
        .unwrap();
    assert!(reads > 1000, "the loops read {reads} times");
    eprintln!(
        "Scenes: median {:?}; Set alone {:?}, beside the loops at most {:?}; status alone \
         {:?}, beside at most {:?}; the loops read {reads} times",
        times[10], alone.0, beside.0, alone.1, beside.1
    );
    let late = Duration::from_millis(50);
    assert!(
        beside.0 < alone.0 + late,
        "Set: {alone:?} alone, {beside:?} beside"
    );
    assert!(
        beside.1 < alone.1 + late,
        "status: {alone:?} alone, {beside:?} beside"
    );
    daemon.stop();
    // The mesh weighs 24.5 MB: not left in the temporary directory.
    std::fs::remove_file(dir.join("scenes/big.stl")).unwrap();
}

#[test]
fn a_caller_names_scenes_and_sends_its_files_but_no_path_it_gives_is_opened() {
    let dir = support::shared_scratch("dbus", "hostile-scenes");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let pid = daemon.child.as_ref().unwrap().id();
    let maps = || std::fs::read_to_string(format!("/proc/{pid}/maps")).unwrap();
    // A valid scene plugin, a system library and files through `..`: each is a path, and
    // none reaches dlopen or a read.
    let plugin = plugin_path("hapticd-test-stalling-scene");
    let secret = dir.join("secret.yaml");
    std::fs::write(&secret, "root:*:19000:0:99999:7:::\n").unwrap();
    let escape = format!(
        "{}/../{}",
        dir.display(),
        secret.file_name().unwrap().to_str().unwrap()
    );
    for path in [
        plugin.to_str().unwrap(),
        "/usr/lib/x86_64-linux-gnu/libz.so.1",
        &escape,
        "../../../../etc/passwd",
        "static.yaml",
    ] {
        let (name, message) = bus.error(
            MANAGER[1],
            "org.hapticd.Hapticd1.Manager.SwitchScene",
            &[&format!("string:{path}")],
        );
        assert_eq!(name, "org.hapticd.Hapticd1.Error.NameExpected", "{path}");
        assert!(!message.contains("root:*"), "{message}");
    }
    assert!(!maps().contains("stalling_scene") && !maps().contains("libz.so"));
    assert!(!daemon.log().contains("root:*"), "{}", daemon.log());
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"static\"");
    // A scene plugin of the scene plugin directories is switched to by its name.
    let out = bus.call(MANAGER, "SwitchScene", &["s", "floor"]);
    assert!(out.status.success(), "{out:?}");
    assert!(maps().contains("libhapticd_scene_floor.so"));
    // A file of the caller's comes open: a pipe or a directory is refused as such, and an
    // unprivileged user cannot send what it cannot open.
    let pipe = dir.join("pipe.yaml");
    nix::unistd::mkfifo(&pipe, nix::sys::stat::Mode::from_bits_truncate(0o644)).unwrap();
    let ctl = |args: &[&str]| bus.ctl(args);
    let out = ctl(&["scene", "switch", pipe.to_str().unwrap()]);
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("SceneFailed: pipe.yaml: error: not a regular file"),
        "{out:?}"
    );
    let sent = dir.join("mine.yaml");
    std::fs::copy(repo_dir().join("config/scenes/static.yaml"), &sent).unwrap();
    let out = ctl(&["scene", "switch", sent.to_str().unwrap()]);
    assert!(out.status.success(), "{out:?}");
    // Pictures come from the daemon's copy, which the renderer's user can read.
    let active = bus.get(MANAGER, "ActiveSceneFile");
    let copy = PathBuf::from(active.trim_start_matches("s ").trim_matches('"'));
    assert_ne!(copy, sent);
    assert_eq!(std::fs::read(&copy).unwrap(), std::fs::read(&sent).unwrap());
    use std::os::unix::fs::PermissionsExt;
    assert_eq!(copy.metadata().unwrap().permissions().mode() & 0o777, 0o644);
    if is_root() {
        std::fs::set_permissions(&secret, std::fs::Permissions::from_mode(0o600)).unwrap();
        let out = Command::new("setpriv")
            .args(["--reuid=65534", "--regid=65534", "--clear-groups"])
            .arg(artifact("hapticctl"))
            .arg(format!("--bus={}", bus.address))
            .args(["scene", "switch", secret.to_str().unwrap()])
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            said.contains("Permission denied") && !said.contains("root:*"),
            "{said}"
        );
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

#[test]
fn a_hundred_clients_at_once_and_a_telemetry_reader_are_served_without_overruns() {
    // Alone: other tests' daemons and process launches would compete for the same 2 cores.
    let dir = support::shared_scratch("dbus", "hundred");
    let bus = Bus::start_alone(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let overruns = || entry(&bus.get(DEVICE, "Statistics"), "overruns");
    let realtime = bus.get(DEVICE, "Scheduling").contains("SCHED_FIFO");
    // Statistics lag the loop by up to 0.2 s: count from well after start-up (locking and
    // faulting in memory) has been published.
    while entry(&bus.get(DEVICE, "Statistics"), "ticks") < 1000.0 {
        std::thread::sleep(Duration::from_millis(50));
    }
    // The best of three rounds, each a quiet time beside a burst of clients: on a shared
    // two-core virtual machine the host steals ticks in bursts (from none to dozens in 2.5 s
    // on the same machine and code, more while the clients keep both cores busy), while a
    // request path that disturbs the loop costs ticks in every round, one or more for each
    // of the 500 requests.
    let mut rounds = Vec::new();
    for _ in 0..3 {
        let quiet_from = overruns();
        std::thread::sleep(Duration::from_millis(2500));
        let quiet = overruns() - quiet_from;
        let before = overruns();
        let started = Instant::now();
        // A reader follows every tick all the while, from the telemetry ring.
        let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let reader = {
            let (address, done) = (bus.address.clone(), done.clone());
            std::thread::spawn(move || follow_until(&address, &done))
        };
        clients_set_the_damping(&bus, &setup);
        std::thread::sleep(Duration::from_millis(300));
        done.store(true, std::sync::atomic::Ordering::Release);
        let (read, missed) = reader.join().unwrap();
        assert!(
            read > 300 && missed == 0,
            "{read} ticks read, {missed} missed"
        );
        let during = overruns() - before;
        let alone = quiet * started.elapsed().as_secs_f64() / 2.5;
        if !realtime || during <= 2.0 * alone + 10.0 {
            return;
        }
        rounds.push(format!("{during} ({alone:.0} without them)"));
    }
    panic!("the clients made the haptic loop overrun in every round: {rounds:?}");
}

/// Follow the first device's telemetry on the bus at `address` until `done`: the ticks read
/// (each the one after the last) and those missed.
fn follow_until(address: &str, done: &std::sync::atomic::AtomicBool) -> (u64, u64) {
    use hapticd_core::telemetry::Sample;
    let client =
        hapticd_ipc::client::Hapticd::connect(&hapticd_ipc::bus::Bus::Address(address.into()))
            .unwrap();
    let ring = client.devices().unwrap()[0].open_telemetry().unwrap();
    let mut cursor = ring.from_now();
    let (mut sample, mut read, mut last) = (Sample::EMPTY, 0, None);
    while !done.load(std::sync::atomic::Ordering::Acquire) {
        while ring.next(&mut cursor, &mut sample) {
            assert!(
                last.is_none_or(|t| sample.tick == t + 1),
                "a gap after {last:?}"
            );
            last = Some(sample.tick);
            read += 1;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    (read, cursor.missed)
}

/// A hundred clients with connections of their own, all at once, each setting the damping
/// five times: all are answered, and the value in force is one that was set and the one
/// persisted.
fn clients_set_the_damping(bus: &Bus, setup: &Setup) {
    let all_set: Vec<f64> = std::thread::scope(|s| {
        let clients: Vec<_> = (0..100)
            .map(|id| {
                let address = bus.address.as_str();
                s.spawn(move || zbus::block_on(client(address, id, 5)))
            })
            .collect();
        clients
            .into_iter()
            .enumerate()
            .flat_map(|(id, c)| {
                c.join()
                    .unwrap()
                    .unwrap_or_else(|e| panic!("client {id} was not answered: {e}"))
            })
            .collect()
    });
    assert_eq!(all_set.len(), 500);
    // busctl prints six significant digits, these values need three.
    let damping = number(&bus.get(DEVICE, "Damping"));
    let same = |a: f64, b: f64| (a - b).abs() < 1e-12;
    assert!(all_set.iter().any(|v| same(*v, damping)), "{damping}");
    let saved: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(setup.state.join("device-sim.json")).unwrap(),
    )
    .unwrap();
    let persisted = saved["parameters"]["damping"].as_f64().unwrap();
    assert!(
        same(persisted, damping),
        "{persisted} persisted, {damping} in force"
    );
}

#[test]
fn kill_9_during_saves_leaves_a_whole_file_and_a_restart_restores_it() {
    let dir = support::shared_scratch("dbus", "kill");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let file = setup.state.join("device-sim.json");
    for round in 0..3u64 {
        let mut daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
        assert!(bus.call(DEVICE, "Calibrate", &[]).status.success());
        let offsets = bus.get(DEVICE, "CalibrationOffsets");
        let sent = std::sync::Mutex::new(Vec::new());
        let answered = std::sync::atomic::AtomicUsize::new(0);
        std::thread::scope(|s| {
            s.spawn(|| {
                for i in 0..400 {
                    let value = 1000.0 + (round * 1000 + i) as f64;
                    sent.lock().unwrap().push(value);
                    if !bus
                        .set("Stiffness", "d", &value.to_string())
                        .status
                        .success()
                    {
                        return;
                    }
                    answered.fetch_add(1, std::sync::atomic::Ordering::Release);
                }
            });
            // Killed while saves go on, after the first (a loaded machine may take longer
            // than the whole wait below to answer one).
            let started = Instant::now();
            while answered.load(std::sync::atomic::Ordering::Acquire) == 0 {
                assert!(
                    started.elapsed() < Duration::from_secs(30),
                    "no Set answered"
                );
                std::thread::sleep(Duration::from_millis(5));
            }
            std::thread::sleep(Duration::from_millis(300 + 170 * round));
            daemon.signal(nix::sys::signal::Signal::SIGKILL);
        });
        let text = std::fs::read_to_string(&file).unwrap();
        let saved: serde_json::Value =
            serde_json::from_str(&text).unwrap_or_else(|e| panic!("torn file ({e}): {text}"));
        let stiffness = saved["parameters"]["stiffness"].as_f64().unwrap();
        assert!(sent.lock().unwrap().contains(&stiffness), "{stiffness}");
        let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
        assert_eq!(number(&bus.get(DEVICE, "Stiffness")), stiffness);
        assert_eq!(bus.get(DEVICE, "CalibrationOffsets"), offsets);
        assert!(daemon.log().contains("restored the calibration of sim"));
        let leftovers: Vec<_> = std::fs::read_dir(&setup.state)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
        daemon.stop();
    }
}

#[test]
fn reload_finds_new_descriptors_and_refuses_malformed_files_with_their_place() {
    let dir = support::shared_scratch("dbus", "reload");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // A descriptor dropped in shows up after ReloadPlugins and can be bound to the device.
    let six = std::fs::read_to_string(repo_dir().join("config/mechanisms/spidar-6s.yaml"))
        .unwrap()
        .replace("name: spidar-6s", "name: lab-rig");
    assert!(six.contains("name: lab-rig"));
    std::fs::write(setup.mechanisms.join("lab-rig.yaml"), six).unwrap();
    assert_eq!(bus.get(MANAGER, "Mechanisms"), "as 1 \"spidar-g\"");
    assert!(bus.call(MANAGER, "ReloadPlugins", &[]).status.success());
    assert_eq!(
        bus.get(MANAGER, "Mechanisms"),
        "as 2 \"lab-rig\" \"spidar-g\""
    );
    assert!(
        bus.call(DEVICE, "BindMechanism", &["s", "lab-rig"])
            .status
            .success()
    );
    // A malformed descriptor, as at start: it hides only itself, its place in the log.
    let bad = setup.mechanisms.join("zz-bad.yaml");
    std::fs::write(&bad, "name: bad\nstrings: [\n").unwrap();
    assert!(bus.call(MANAGER, "ReloadPlugins", &[]).status.success());
    assert_eq!(
        bus.get(MANAGER, "Mechanisms"),
        "as 2 \"lab-rig\" \"spidar-g\""
    );
    assert!(daemon.log().contains("zz-bad.yaml:"), "{}", daemon.log());
    std::fs::remove_file(&bad).unwrap();
    // A changed default scene is switched to.
    let blocks = default_config().replace("scene: static", "scene: blocks");
    std::fs::write(&setup.config, blocks).unwrap();
    assert!(bus.call(MANAGER, "ReloadPlugins", &[]).status.success());
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"blocks\"");
    // A malformed configuration: file:line:column, and the running one stays.
    std::fs::write(&setup.config, default_config() + "realtime:\n  rat: 5\n").unwrap();
    let (name, message) = bus.error(
        MANAGER[1],
        "org.hapticd.Hapticd1.Manager.ReloadPlugins",
        &[],
    );
    assert_eq!(name, "org.hapticd.Hapticd1.Error.InvalidConfiguration");
    let place = format!("{}:5:3:", setup.config.display());
    assert!(
        message.contains(&place) && message.contains("rat"),
        "{message}"
    );
    assert!(bus.get(MANAGER, "Scenes").contains("\"static\""));
    // A default scene that is nowhere would break the next start: refused now.
    let nowhere = default_config().replace("scene: static", "scene: nosuch");
    std::fs::write(&setup.config, nowhere).unwrap();
    let (name, message) = bus.error(
        MANAGER[1],
        "org.hapticd.Hapticd1.Manager.ReloadPlugins",
        &[],
    );
    assert_eq!(name, "org.hapticd.Hapticd1.Error.InvalidConfiguration");
    assert!(
        message.contains("scene: no scene named \"nosuch\""),
        "{message}"
    );
    std::fs::write(&setup.config, default_config()).unwrap();
    daemon.stop();
    // Without --sim the bound mechanism drives the device from the next start.
    let daemon = Hapticd::start(&bus, &setup, &[]);
    assert_eq!(bus.get(DEVICE, "Mechanism"), "s \"lab-rig\"");
    assert_eq!(numbers(&bus.get(DEVICE, "Tensions")).len(), 6);
    daemon.stop();
}

#[test]
fn switching_scenes_ramps_the_force_down_and_back_up() {
    let dir = support::shared_scratch("dbus", "switch");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    // The same scene with a floor 5 mm higher.
    let lower = dir.join("lower.yaml");
    let scene = std::fs::read_to_string(repo_dir().join("config/scenes/static.yaml"))
        .unwrap()
        .replace("name: static", "name: lower")
        .replace("floor: { height: -0.03 }", "floor: { height: -0.025 }");
    assert!(scene.contains("-0.025"));
    std::fs::write(&lower, scene).unwrap();
    // The hand pushes the grip 15 mm into the floor (y = -0.03) and holds it there.
    let (daemon, csv) = pressing(&bus, &setup, &dir, [0.0, -0.045, 0.0]);
    let out = bus.ctl(&["scene", "switch", lower.to_str().unwrap()]);
    assert!(out.status.success(), "{out:?}");
    assert_eq!(bus.get(MANAGER, "ActiveScene"), "s \"lower\"");
    std::thread::sleep(Duration::from_millis(1000));
    daemon.stop();
    ramps_through_zero(&grip_force(&csv), 1.2);
}

/// A daemon whose simulated hand moves the grip to `to` and holds it there, recording every
/// tick; it has pressed for a second. The daemon and its recording's path.
fn pressing(bus: &Bus, setup: &Setup, dir: &Path, to: [f64; 3]) -> (Hapticd, PathBuf) {
    let hand = dir.join("press.yaml");
    let [x, y, z] = to;
    std::fs::write(
        &hand,
        format!(
            "hands:\n  grip:\n    - hold: {{ seconds: 0.3 }}\n    - move: {{ to: [{x}, {y}, {z}], \
             seconds: 0.3 }}\n    - hold: {{ seconds: 60 }}\n"
        ),
    )
    .unwrap();
    let csv = dir.join("run.csv");
    let daemon = Hapticd::start(
        bus,
        setup,
        &[
            "--sim",
            "spidar-g",
            "--hand",
            hand.to_str().unwrap(),
            "--record",
            csv.to_str().unwrap(),
        ],
    );
    std::thread::sleep(Duration::from_millis(1500));
    (daemon, csv)
}

/// (time, upward grip force) of every tick a daemon's `--record` wrote to `csv`.
fn grip_force(csv: &Path) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t, fy) = (column("time"), column("grip_fy"));
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (v[t].parse().unwrap(), v[fy].parse().unwrap())
        })
        .collect()
}

/// Check that the force of `rows`, pressing at 1 s, reached zero after `from` seconds
/// without a jump and came back slowly to more than it was (the surface is now higher).
fn ramps_through_zero(rows: &[(f64, f64)], from: f64) {
    let pressing = rows.iter().find(|r| r.0 > 1.0).unwrap().1;
    assert!(pressing > 2.0, "the surface pushes back: {pressing} N");
    let zero = rows
        .iter()
        .position(|r| r.0 > from && r.1.abs() < 1e-9)
        .expect("forces ramped to zero for the change");
    let step = rows[zero - 10..zero]
        .windows(2)
        .map(|w| (w[1].1 - w[0].1).abs())
        .fold(0.0, f64::max);
    assert!(step < 0.35 * pressing, "a jump of {step} N on the way down");
    let after = |seconds: f64| rows[zero + (seconds * 1000.0) as usize].1;
    let settled = after(0.8);
    assert!(
        settled > 1.1 * pressing,
        "the higher surface pushes more: {settled} N against {pressing} N"
    );
    assert!(after(0.02) < 0.3 * settled, "forces came back at once");
}

#[test]
fn a_body_put_under_a_pressing_finger_is_felt_through_a_ramp_not_a_jump() {
    let dir = support::shared_scratch("dbus", "pose-ramp");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    std::fs::write(
        &setup.config,
        default_config().replace("scene: static", "scene: blocks"),
    )
    .unwrap();
    // The grip's 1 cm cube pressed into the table, clear of every block.
    let (daemon, csv) = pressing(&bus, &setup, &dir, [-0.03, -0.036, 0.07]);
    // The table raised 3 mm, into the cube.
    let raised = bus
        .drive(
            "SetPose",
            "sadad",
            &["table", "3", "0", "-0.047", "0", "4", "1", "0", "0", "0"],
        )
        .unwrap();
    assert!((raised.position.y + 0.047).abs() < 1e-12);
    std::thread::sleep(Duration::from_millis(1000));
    daemon.stop();
    ramps_through_zero(&grip_force(&csv), 1.2);
}

/// The interface XML installed for D-Bus tools: what the daemon introspects, interface by
/// interface. `HAPTICD_UPDATE_INTERFACES=1` rewrites the files.
#[test]
fn the_interface_files_are_what_the_daemon_introspects() {
    let dir = support::shared_scratch("dbus", "xml");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let _renderer = Renderer::start(&bus, &dir, &[]);
    for [name, path, interface] in [MANAGER, DEVICE, SCENE, PICTURES] {
        let xml = bus.ok(&["introspect", "--xml-interface", name, path]);
        let start = xml
            .find(&format!("<interface name=\"{interface}\">"))
            .unwrap();
        let end = start + xml[start..].find("</interface>").unwrap() + "</interface>".len();
        let live = format!(
            "<!DOCTYPE node PUBLIC \"-//freedesktop//DTD D-BUS Object Introspection 1.0//EN\"\n \
             \"http://www.freedesktop.org/standards/dbus/1.0/introspect.dtd\">\n<node>\n {}\n</node>\n",
            &xml[start..end]
        );
        let file = repo_dir().join(format!("config/dbus/{interface}.xml"));
        if std::env::var_os("HAPTICD_UPDATE_INTERFACES").is_some() {
            std::fs::write(&file, &live).unwrap();
        }
        let shipped = std::fs::read_to_string(&file).unwrap_or_default();
        assert!(
            shipped == live,
            "{} is out of date: run HAPTICD_UPDATE_INTERFACES=1 cargo test -p hapticd-e2e \
             --test daemon",
            file.display()
        );
        assert!(live.contains("<!--\n     Version of this D-Bus API") || interface != MANAGER[2]);
        assert!(live.contains("Take the counter offsets now") || interface != DEVICE[2]);
        assert!(live.contains("One picture of the world now") || interface != PICTURES[2]);
        assert!(live.contains("Give `body` the momentum") || interface != SCENE[2]);
    }
}

#[test]
fn a_damaged_state_file_is_kept_aside_and_the_device_starts_afresh() {
    let dir = support::shared_scratch("dbus", "damaged");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    std::fs::create_dir_all(&setup.state).unwrap();
    let file = setup.state.join("device-sim.json");
    let aside = setup.state.join("device-sim.json.corrupt");
    for damaged in [
        "{\"parameters\": {\"stiffness\": 3000",
        "{\"parameters\": {\"stiffness\": 1e12}}",
    ] {
        std::fs::write(&file, damaged).unwrap();
        let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
        assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000", "{damaged}");
        assert_eq!(std::fs::read_to_string(&aside).unwrap(), damaged);
        assert!(!file.exists());
        assert!(daemon.log().contains("starting afresh"), "{}", daemon.log());
        daemon.stop();
    }
}

#[test]
fn a_bound_mechanism_since_removed_falls_back_to_the_configured_one() {
    let dir = support::shared_scratch("dbus", "unbound");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    std::fs::create_dir_all(&setup.state).unwrap();
    let file = setup.state.join("device-sim.json");
    std::fs::write(&file, r#"{"mechanism": "spidar-gone"}"#).unwrap();
    // As the unit starts it: no --sim; with no amplifier plugged in, the simulated SPIDAR.
    let daemon = Hapticd::start(&bus, &setup, &[]);
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
    assert_eq!(bus.get(DEVICE, "Mechanism"), "s \"spidar-g\"");
    // The binding is kept for when the mechanism comes back, and the log says where it is.
    assert_eq!(bus.get(DEVICE, "BoundMechanism"), "s \"spidar-gone\"");
    let log = daemon.log();
    assert!(
        log.contains(&format!("\"spidar-gone\" bound in {}", file.display()))
            && log.contains("\"spidar-g\" drives it until it can"),
        "{log}"
    );
    daemon.stop();
}

#[test]
fn saved_offsets_that_fit_no_pose_leave_the_device_uncalibrated_until_calibrated() {
    let dir = support::shared_scratch("dbus", "misfit");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let file = setup.state.join("device-sim.json");
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    assert!(bus.call(DEVICE, "Calibrate", &[]).status.success());
    daemon.stop();
    // The saved offsets, each moved by a different 2·(i + 1) cm: no pose of the grip has
    // those string lengths.
    let mut saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    for (i, offset) in saved["calibration"]["offsets"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .enumerate()
    {
        *offset = (offset.as_f64().unwrap() + 0.02 * (i as f64 + 1.0)).into();
    }
    std::fs::write(&file, saved.to_string()).unwrap();
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    daemon.wait_for_state(&bus, "uncalibrated");
    assert_eq!(bus.get(DEVICE, "Calibrated"), "b false");
    for property in ["Force", "Tensions"] {
        let values = numbers(&bus.get(DEVICE, property));
        assert!(values.iter().all(|v| *v == 0.0), "{property}: {values:?}");
    }
    assert!(
        daemon.log().contains("no longer fit the calibration"),
        "{}",
        daemon.log()
    );
    let (name, message) = bus.error(DEVICE[1], &format!("{}.ResetFault", DEVICE[2]), &[]);
    assert_eq!(name, "org.hapticd.Hapticd1.Error.StillFaulted", "{message}");
    assert!(message.contains("calibrate"), "{message}");
    // Calibrating trusts the counts again, and saves offsets that fit.
    assert!(bus.call(DEVICE, "Calibrate", &[]).status.success());
    daemon.wait_for_state(&bus, "running");
    assert_eq!(bus.get(DEVICE, "Calibrated"), "b true");
    daemon.stop();
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

/// Share of `picture`'s pixels that are not the sky it is drawn over.
fn drawn_share(picture: &Picture) -> f64 {
    let sky = [237, 242, 250];
    let drawn = picture
        .rgba
        .chunks(4)
        .filter(|p| {
            p[..3]
                .iter()
                .zip(sky)
                .any(|(&c, s): (&u8, i32)| (i32::from(c) - s).abs() > 8)
        })
        .count();
    drawn as f64 / (picture.rgba.len() / 4) as f64
}

#[test]
fn a_snapshot_is_a_picture_of_the_running_scene_and_bad_options_are_refused() {
    let dir = support::shared_scratch("dbus", "snapshot");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g", "--scene", "blocks"]);
    let _renderer = Renderer::start(&bus, &dir, &[]);
    assert_eq!(bus.get(PICTURES, "Available"), "b true");
    assert!(bus.get(PICTURES, "Driver").len() > 4);
    assert_eq!(bus.get(PICTURES, "UnavailableReason"), "s \"\"");
    assert!(
        bus.get(MANAGER, "ActiveSceneFile")
            .ends_with("config/scenes/blocks.yaml\""),
        "{}",
        bus.get(MANAGER, "ActiveSceneFile")
    );
    let picture = bus
        .snapshot(&["width", "u", "320", "height", "u", "240"])
        .unwrap();
    assert_eq!((picture.width, picture.height), (320, 240));
    let drawn = drawn_share(&picture);
    assert!((0.2..0.95).contains(&drawn), "{drawn} of the picture drawn");
    // Seen from the other side the scene is another picture; the defaults are 640 × 480.
    let behind = bus.snapshot(&["azimuth", "d", "3.6"]).unwrap();
    assert_eq!((behind.width, behind.height), (640, 480));
    // hapticctl asks the same renderer.
    let file = dir.join("snapshot.png");
    let out = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["snapshot", "--width", "200", "--height", "100"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let written = Picture::read_png(&file).unwrap();
    assert_eq!((written.width, written.height), (200, 100));
    use zbus::Variant;
    for (key, value, error) in [
        ("width", Variant::from(0u32), "OutOfRange"),
        ("height", Variant::from(100_000u32), "OutOfRange"),
        ("distance", Variant::from(f64::NAN), "NotFinite"),
        ("azimuth", Variant::from(f64::INFINITY), "NotFinite"),
        (
            "target",
            Variant::from(vec![0.0, f64::NAN, 0.0]),
            "NotFinite",
        ),
        ("zoom", Variant::from(2.0), "InvalidOption"),
        ("width", Variant::from("wide"), "InvalidOption"),
    ] {
        let (name, message) = bus.snapshot_error(&[(key, value)]);
        assert_eq!(
            name,
            format!("org.hapticd.Renderer1.Error.{error}"),
            "{key}: {message}"
        );
        assert!(message.contains(key), "{message}");
    }
    // A camera aimed far off sees sky; a target of two numbers is refused by the renderer.
    let aimed = dir.join("aimed.png");
    let out = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args([
            "snapshot", "--width", "200", "--height", "100", "--target", "0,60,-60",
        ])
        .arg(&aimed)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let (here, away) = (
        drawn_share(&written),
        drawn_share(&Picture::read_png(&aimed).unwrap()),
    );
    assert!(
        away < 0.5 * here,
        "drawn {here} at the scene, {away} aimed away"
    );
    let two = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["snapshot", "--target", "1,2"])
        .arg(dir.join("none.png"))
        .output()
        .unwrap();
    assert_eq!(two.status.code(), Some(2), "{two:?}");
    assert!(String::from_utf8_lossy(&two.stderr).contains("target is three numbers"));
    for args in [&["--width", "0"][..], &["--distance", "-1"]] {
        let refused = hapticctl()
            .arg(format!("--bus={}", bus.address))
            .arg("snapshot")
            .args(args)
            .arg(dir.join("none.png"))
            .output()
            .unwrap();
        assert_eq!(refused.status.code(), Some(2), "{refused:?}");
        // The renderer's reason, not the argument parser's.
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(stderr.contains("OutOfRange"), "{args:?}: {stderr}");
        assert!(!dir.join("none.png").exists());
    }
}

#[test]
fn a_renderer_killed_comes_back_and_the_haptic_loop_never_notices() {
    let unit = std::fs::read_to_string(repo_dir().join("systemd/hapticd-render.service")).unwrap();
    assert!(
        unit.contains("\nRestart=always\n"),
        "systemd brings it back"
    );
    let dir = support::shared_scratch("dbus", "kill-renderer");
    // It counts overruns: no other test's daemons run meanwhile.
    let bus = Bus::start_alone(&dir);
    let setup = Setup::new(&dir);
    // The static scene: a debug build's tick leaves room for the machine's own hiccups.
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let overruns = || entry(&bus.get(DEVICE, "Statistics"), "overruns");
    let ticks = || entry(&bus.get(DEVICE, "Statistics"), "ticks");
    let mut renderer = Renderer::start(&bus, &dir, &[]);
    // A viewer's stream keeps the renderer drawing when it is killed.
    let (_viewer, ring) = stream_frames(&bus);
    let started = Instant::now();
    while ring.latest() < 10 {
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "no frames drawn"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    bus.snapshot(&[]).unwrap();
    // Statistics reach the bus at 10 Hz: count from a snapshot no older than this moment.
    std::thread::sleep(Duration::from_millis(300));
    // What the machine alone costs the loop in a window as long as the kill's (a virtual
    // machine's host steals ticks now and then, in bursts): the worst of several windows,
    // before the kill and after it.
    const WINDOW: Duration = Duration::from_millis(350);
    let window = || {
        let from = overruns();
        std::thread::sleep(WINDOW);
        overruns() - from
    };
    let mut worst = (0..4).map(|_| window()).fold(0.0, f64::max);
    let (before, ticked) = (overruns(), ticks());
    let force = bus.get(DEVICE, "Force");
    renderer.kill_9();
    let error = bus.snapshot(&[]).unwrap_err();
    assert!(error.contains("org.hapticd.Renderer1"), "{error}");
    std::thread::sleep(WINDOW);
    assert!(ticks() > ticked, "the loop stopped");
    let during = overruns() - before;
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
    assert_eq!(bus.get(DEVICE, "Force"), force, "the force changed");
    worst = (0..3).map(|_| window()).fold(worst, f64::max);
    assert!(
        during <= 2.0 * worst + 2.0,
        "{during} overruns while the renderer died, at most {worst} in a window without: {}",
        daemon.log()
    );
    // Started again as systemd's Restart= does: it finds hapticd's world by itself.
    let _again = Renderer::start(&bus, &dir, &[]);
    let picture = bus
        .snapshot(&["width", "u", "64", "height", "u", "48"])
        .unwrap();
    assert_eq!((picture.width, picture.height), (64, 48));
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
}

#[test]
fn without_a_vulkan_driver_the_renderer_says_why_once_and_hapticd_runs_on() {
    let dir = support::shared_scratch("dbus", "no-driver");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let none = "/nonexistent/icd.json";
    let renderer = Renderer::start(
        &bus,
        &dir,
        &[("VK_DRIVER_FILES", none), ("VK_ICD_FILENAMES", none)],
    );
    assert_eq!(bus.get(PICTURES, "Available"), "b false");
    assert_eq!(bus.get(PICTURES, "Driver"), "s \"\"");
    assert!(bus.get(PICTURES, "UnavailableReason").len() > 10);
    for _ in 0..3 {
        let (name, _) = bus.snapshot_error(&[]);
        assert_eq!(name, "org.hapticd.Renderer1.Error.Unavailable");
    }
    let log = renderer.log();
    assert_eq!(
        log.matches("no pictures on this machine").count(),
        1,
        "{log}"
    );
    assert_eq!(bus.get(DEVICE, "State"), "s \"running\"");
}

/// An X server without a screen (Xvfb) whose framebuffer is a file to read screenshots
/// from; stopped when dropped.
struct Xvfb {
    child: Child,
    display: String,
    framebuffer: PathBuf,
}

impl Xvfb {
    /// A `width × height` screen.
    fn start(dir: &Path, width: u32, height: u32) -> Xvfb {
        let fbdir = dir.join("xvfb");
        std::fs::create_dir_all(&fbdir).unwrap();
        // A display number of this process's own (a few, for its tests at once), clear of a
        // desktop's :0 and :1.
        static STARTED: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let nth = STARTED.fetch_add(1, std::sync::atomic::Ordering::Relaxed) % 8;
        let display = format!(":{}", 100 + (std::process::id() % 5_000) * 8 + nth);
        let child = Command::new("Xvfb")
            .arg(&display)
            .args([
                "-screen",
                "0",
                &format!("{width}x{height}x24"),
                "-nolisten",
                "tcp",
            ])
            .arg("-fbdir")
            .arg(&fbdir)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb (package xvfb) is installed by `make check`");
        let framebuffer = fbdir.join("Xvfb_screen0");
        // Xvfb makes the file before it writes the XWD header into it: wait for the header's
        // bits per pixel (its twelfth word), not for the file alone.
        let written = |file: &Path| {
            std::fs::read(file)
                .is_ok_and(|bytes| bytes.len() >= 48 && bytes[44..48] != [0, 0, 0, 0])
        };
        let started = Instant::now();
        while !written(&framebuffer) {
            assert!(
                started.elapsed() < Duration::from_secs(10),
                "Xvfb did not start"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        Xvfb {
            child,
            display,
            framebuffer,
        }
    }

    /// The screen now, from the XWD file Xvfb keeps it in (32-bit pixels, masks in the
    /// header).
    fn screenshot(&self) -> Picture {
        let file = std::fs::read(&self.framebuffer).unwrap();
        let word = |k: usize| u32::from_be_bytes(file[4 * k..4 * k + 4].try_into().unwrap());
        let (header, width, height) = (word(0) as usize, word(4), word(5));
        let (little_endian, bits, stride) = (word(7) == 0, word(11), word(12) as usize);
        let masks = [word(14), word(15), word(16)];
        let colours = word(19) as usize;
        assert_eq!(bits, 32, "a 24-bit screen keeps 32-bit pixels");
        let pixels = &file[header + 12 * colours..];
        let mut rgba = Vec::with_capacity((width * height * 4) as usize);
        for y in 0..height as usize {
            for x in 0..width as usize {
                let bytes: [u8; 4] = pixels[y * stride + 4 * x..][..4].try_into().unwrap();
                let value = if little_endian {
                    u32::from_le_bytes(bytes)
                } else {
                    u32::from_be_bytes(bytes)
                };
                for mask in masks {
                    rgba.push(((value & mask) >> mask.trailing_zeros()) as u8);
                }
                rgba.push(255);
            }
        }
        Picture {
            width,
            height,
            rgba,
        }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `view --fullscreen` fills the screen even where no window manager runs (a kiosk's bare X
/// server): the frames, scaled, reach its far corner.
#[test]
fn hapticctl_view_fills_a_screen_without_a_window_manager() {
    let dir = support::shared_scratch("dbus", "view-fullscreen");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let _renderer = Renderer::start(&bus, &dir, &[]);
    let screen = Xvfb::start(&dir, 640, 480);
    let mut viewer = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["view", "--fullscreen", "--width", "160", "--height", "120"])
        .env("DISPLAY", &screen.display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Share of the bottom-right quarter of the screen (outside a window of the frames' own
    // size) that is still the bare screen's black.
    let black_corner = |shot: &Picture| {
        let (w, h) = (shot.width as usize, shot.height as usize);
        let corner: Vec<&[u8]> = shot
            .rgba
            .chunks(4)
            .enumerate()
            .filter(|(i, _)| i % w >= w / 2 && i / w >= h / 2)
            .map(|(_, p)| p)
            .collect();
        let black = corner.iter().filter(|p| p[..3] == [0, 0, 0]).count();
        black as f64 / corner.len() as f64
    };
    let started = Instant::now();
    while black_corner(&screen.screenshot()) > 0.5 {
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the window never reached the screen's far corner"
        );
        assert!(
            viewer.try_wait().unwrap().is_none(),
            "hapticctl view exited"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = viewer.kill();
    let _ = viewer.wait();
}

#[test]
fn hapticctl_view_shows_the_daemons_frames_in_an_x11_window() {
    let dir = support::shared_scratch("dbus", "view");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    // The static scene with the grip at rest: every frame is the same but for the clock.
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let mut renderer = Renderer::start(&bus, &dir, &[]);
    let (width, height) = (320, 240);
    let screen = Xvfb::start(&dir, width, height);
    let mut viewer = hapticctl()
        .arg(format!("--bus={}", bus.address))
        .args(["view", "--width", "320", "--height", "240"])
        .env("DISPLAY", &screen.display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let mut shot = screen.screenshot();
    while !(0.2..0.95).contains(&drawn_share(&shot)) {
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the window never showed the scene ({} drawn)",
            drawn_share(&shot)
        );
        assert!(
            viewer.try_wait().unwrap().is_none(),
            "hapticctl view exited"
        );
        std::thread::sleep(Duration::from_millis(100));
        shot = screen.screenshot();
    }
    let snapshot = bus
        .snapshot(&["width", "u", "320", "height", "u", "240"])
        .unwrap();
    // Above the status line (whose clock moves on) the window shows what Snapshot draws.
    let band = 15 * width as usize * 4;
    let above = shot.rgba.len() - band;
    let worst = |shot: &Picture, expected: &dyn Fn(u8) -> u8, rows: std::ops::Range<usize>| {
        // Colours only: the window has no alpha to show.
        shot.rgba[rows.clone()]
            .chunks(4)
            .zip(snapshot.rgba[rows].chunks(4))
            .flat_map(|(a, b)| (0..3).map(move |k| a[k].abs_diff(expected(b[k]))))
            .max()
            .unwrap()
    };
    let same = worst(&shot, &|c| c, 0..above);
    assert!(same <= 2, "the window differs from Snapshot by {same} LSB");
    // SPIDAR-G's eight strings, at their least tension, are drawn in the tension palette's
    // blue, which nothing else in the static scene is.
    let blue = snapshot
        .rgba
        .chunks(4)
        .filter(|p| {
            i32::from(p[2]) > i32::from(p[0]) + 80 && i32::from(p[2]) > i32::from(p[1]) + 60
        })
        .count();
    assert!(blue > 50, "the strings are not drawn ({blue} blue pixels)");
    // With the renderer gone, the last frame stays, dimmed, its age written over it.
    let _ = renderer.child.kill();
    let _ = renderer.child.wait();
    std::thread::sleep(Duration::from_millis(1500));
    let stale = screen.screenshot();
    let _ = viewer.kill();
    let _ = viewer.wait();
    let dimmed = worst(&stale, &|c| c / 2 + 64, band..above);
    assert!(
        dimmed <= 2,
        "the stale frame is not dimmed ({dimmed} LSB off)"
    );
    let letters = stale.rgba[..band]
        .chunks(4)
        .filter(|p| p[..3] == [255, 255, 255])
        .count();
    assert!(letters > 50, "no note over the stale frame");
    let line = |p: &Picture| {
        drawn_share(&Picture {
            width,
            height: 13,
            rgba: p.rgba[above..].to_vec(),
        })
    };
    assert!(line(&shot) > 0.3, "no status line in the window");
}

/// The Python package (`daemon/python`) against a running daemon: its pytest suite, run by
/// Debian's python3 with jeepney and pytest (`make deps`), on this test's private bus.
#[test]
fn the_python_client_reads_sets_switches_and_follows_every_tick() {
    let dir = support::shared_scratch("dbus", "python");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let package = repo_dir().join("daemon/python");
    let out = Command::new("/usr/bin/python3")
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(package.join("tests"))
        .env("PYTHONPATH", &package)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("HAPTICD_TEST_BUS", &bus.address)
        .output()
        .unwrap();
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{said}");
    assert!(said.contains("35 passed"), "{said}");
    daemon.stop();
    // `pip install PATH` makes a package that imports from where it went, typed (from a
    // copy: pip leaves its build files beside the source).
    let source = dir.join("source");
    let copied = Command::new("cp")
        .arg("-r")
        .arg(&package)
        .arg(&source)
        .status()
        .unwrap();
    assert!(copied.success());
    let target = dir.join("site");
    let installed = Command::new("/usr/bin/python3")
        .args([
            "-m",
            "pip",
            "install",
            "-q",
            "--no-build-isolation",
            "--no-deps",
            "--no-index",
        ])
        .arg("--target")
        .arg(&target)
        .arg(&source)
        .output()
        .unwrap();
    assert!(installed.status.success(), "{installed:?}");
    assert!(target.join("hapticd/py.typed").is_file());
    let imported = Command::new("/usr/bin/python3")
        .args([
            "-c",
            "import hapticd, hapticd.telemetry; print(hapticd.__file__)",
        ])
        .env("PYTHONPATH", &target)
        .current_dir(&dir)
        .output()
        .unwrap();
    let from = String::from_utf8_lossy(&imported.stdout);
    assert!(
        from.trim().starts_with(target.to_str().unwrap()),
        "{imported:?}"
    );
}

/// The README's staircase example (`daemon/python/examples/staircase.py`) on the simulated
/// device, a hand pressing the static scene's floor throughout: it converges on the
/// reference wall and records every tick of every trial.
#[test]
fn the_staircase_example_finds_the_reference_wall_and_records_every_tick() {
    let dir = support::shared_scratch("dbus", "staircase");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let hand = dir.join("press.yaml");
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - move: { to: [0, -0.05, 0], seconds: 0.5 }\n    - hold: { seconds: 600 }\n",
    )
    .unwrap();
    let daemon = Hapticd::start(
        &bus,
        &setup,
        &["--sim", "spidar-g", "--hand", hand.to_str().unwrap()],
    );
    std::thread::sleep(Duration::from_millis(800));
    let csv = dir.join("ticks.csv");
    let csv_arg = csv.to_str().unwrap();
    let said = python_example(
        "staircase.py",
        &["--bus", &bus.address, "--trials", "10", "--out", csv_arg],
    );
    let estimate: f64 = said
        .split("threshold estimate: ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{said}"));
    println!("{said}");
    assert!((estimate - 2000.0).abs() <= 300.0, "{said}");
    // Every trial: 400 ticks of 1 ms, none lost.
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 10 * 400);
    for trial in rows.chunks(400) {
        let ticks: Vec<u64> = trial.iter().map(|r| r[2].parse().unwrap()).collect();
        assert!(
            ticks.windows(2).all(|w| w[1] == w[0] + 1),
            "{:?}",
            &ticks[..3]
        );
    }
    daemon.stop();
}

#[test]
fn bodies_are_added_and_removed_under_both_engines_the_others_kept_as_they_are() {
    let dir = support::shared_scratch("dbus", "add-remove");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let call = |method: &str, signature: &str, args: &[&str]| {
        let mut all = vec![
            "--", "call", SCENE[0], SCENE[1], SCENE[2], method, signature,
        ];
        all.extend(args);
        bus.busctl(&all)
    };
    for (scene, tolerance) in [("blocks", 1e-6), ("push", 1e-3)] {
        switch_when_prepared(&bus, scene);
        // A body of the world changed from outside: lighter, and put somewhere to rest.
        bus.drive("SetMass", "sd", &["block", "0.3"]).unwrap();
        bus.drive(
            "SetPose",
            "sadad",
            &[
                "block", "3", "0.04", "0.02", "0.03", "4", "1", "0", "0", "0",
            ],
        )
        .unwrap();
        std::thread::sleep(Duration::from_millis(1500));
        let resting = bus.drive("Body", "s", &["block"]).unwrap();
        let cube =
            "{ name: cube, box: [0.02, 0.02, 0.02], position: [-0.1, 0.2, -0.1], density: 500 }";
        let added = call("AddBody", "s", &[cube]);
        assert!(added.status.success(), "{scene}: {added:?}");
        let bodies = bus.get(SCENE, "Bodies");
        let count = bodies.matches('"').count() / 2;
        assert_eq!(
            String::from_utf8_lossy(&added.stdout).trim(),
            format!("u {}", count - 1),
            "{bodies}"
        );
        assert!(bodies.ends_with("\"cube\" false"), "{bodies}");
        // The block is where it rested, as heavy as it was made.
        let kept = bus.drive("Body", "s", &["block"]).unwrap();
        assert!(
            (kept.position - resting.position).length() < 1e-3,
            "{scene}: {:?} then {:?}",
            resting.position,
            kept.position
        );
        assert!((kept.mass - 0.3).abs() < tolerance, "{scene}: {kept:?}");
        let cube_now = bus.drive("Body", "s", &["cube"]).unwrap();
        assert!(
            (cube_now.mass - 0.02_f64.powi(3) * 500.0).abs() < 1e-6 * 4.0,
            "{cube_now:?}"
        );
        // Names taken, unnamed bodies and what is not YAML are refused, by name.
        let error = |method: &str, args: &[&str]| bus.drive_error(method, args);
        let named = |short: &str| format!("org.hapticd.Hapticd1.Error.{short}");
        assert_eq!(
            error("AddBody", &[&format!("string:{cube}")]),
            named("OutOfRange")
        );
        assert_eq!(
            error(
                "AddBody",
                &["string:{ box: [1, 1, 1], position: [0, 0, 0] }"]
            ),
            named("OutOfRange")
        );
        assert_eq!(error("AddBody", &["string:[unclosed"]), named("OutOfRange"));
        assert_eq!(
            error(
                "AddBody",
                &["string:{ name: bad, box: [0.02, 0.02], position: [0, 0, 0] }"]
            ),
            named("SceneFailed")
        );
        // Said of the scene the caller knows, not of the daemon's copy of it.
        let failed = call(
            "AddBody",
            "s",
            &["{ name: bad, box: [0.02, 0.02], position: [0, 0, 0] }"],
        );
        let said = String::from_utf8_lossy(&failed.stderr);
        assert!(
            said.contains(&format!("{scene}.yaml")) && !said.contains("hapticd-scenes-"),
            "{said}"
        );
        assert_eq!(
            error("RemoveBody", &["string:no-such-body"]),
            named("UnknownBody")
        );
        let removed = call("RemoveBody", "s", &["cube"]);
        assert!(removed.status.success(), "{removed:?}");
        let left = bus.get(SCENE, "Bodies");
        assert!(!left.contains("\"cube\""), "{left}");
        let after = bus.drive("Body", "s", &["block"]).unwrap();
        assert!(
            (after.position - resting.position).length() < 2e-3,
            "{scene}: {after:?}"
        );
    }
    // hapticctl adds and removes too.
    let out = bus.ctl(&[
        "body",
        "add",
        "{ name: ball, sphere: 0.01, position: [0, 0.1, 0] }",
    ]);
    assert!(out.status.success(), "{out:?}");
    assert!(
        String::from_utf8_lossy(&out.stdout).starts_with("added as body "),
        "{out:?}"
    );
    let out = bus.ctl(&["body", "remove", "ball"]);
    assert!(out.status.success(), "{out:?}");
    // A scene of no file has nothing to build again from.
    switch_when_prepared(&bus, "static");
    assert_eq!(
        bus.drive_error(
            "AddBody",
            &["string:{ name: x, sphere: 0.01, position: [0, 0, 0] }"]
        ),
        "org.hapticd.Hapticd1.Error.Unavailable"
    );
}

/// Run the Python package's example `name` with `args`, the package from the tree; what it
/// printed, once it has succeeded.
fn python_example(name: &str, args: &[&str]) -> String {
    let out = Command::new("/usr/bin/python3")
        .arg(repo_dir().join("daemon/python/examples").join(name))
        .args(args)
        .env("PYTHONPATH", repo_dir().join("daemon/python"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{name}: {said}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    said
}

/// The README's second example (`daemon/python/examples/push.py`): the world drawn from the
/// device's picture of it, and a block pushed from outside sliding as Coulomb friction has it.
#[test]
fn the_push_example_draws_the_world_and_the_block_slides_as_friction_says() {
    let dir = support::shared_scratch("dbus", "push-example");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let picture = dir.join("push.svg");
    let said = python_example(
        "push.py",
        &[
            "--bus",
            &bus.address,
            "--speed",
            "0.3",
            "--out",
            picture.to_str().unwrap(),
        ],
    );
    println!("{said}");
    let went: f64 = said
        .split("went ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{said}"));
    // A block sliding at v on the table stops after v²/(2μg) (μ = 0.4 in blocks.yaml).
    let coulomb = 0.3_f64.powi(2) / (2.0 * 0.4 * 9.81) * 1000.0;
    assert!(
        (went - coulomb).abs() < 0.3 * coulomb,
        "{went} mm vs {coulomb:.1} mm"
    );
    let svg = std::fs::read_to_string(&picture).unwrap();
    // Seven bodies of boxes, each drawn face by face, and the block's path.
    assert!(svg.matches("<polygon").count() >= 7 * 12, "{}", &svg[..200]);
    assert_eq!(svg.matches("<polyline").count(), 1);
    daemon.stop();
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
        .env("PYTHONPATH", support::python_package("eclipse-zenoh"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("ZENOH_SETTINGS", settings.to_string());
    if let Some(namespace) = inside {
        namespace.enter(&mut command);
    }
    let out = command.output().unwrap();
    assert!(out.status.success(), "{out:?}");
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The ROS 2 side of the bridge, as the real Zenoh client sees it: every tick of the pose
/// topic for 10 s at 1 kHz, in rmw_zenoh's keys and CDR; the twist (the angular velocity
/// of the hand's slow turn) and string topics; the node and its publishers announced by
/// liveliness tokens; the status answered, also to
/// `hapticctl --remote`, which records every tick through the bridge; a command refused by a
/// bridge that takes none.
#[test]
fn the_zenoh_bridge_publishes_every_tick_for_a_zenoh_client_and_answers_its_status() {
    let dir = support::shared_scratch("dbus", "zenoh");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    // The wrist turns the grip slowly about the vertical (at most 2 rad in all).
    let hand = dir.join("turn.yaml");
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - hold: { seconds: 0.5 }\n    - turn: { rate: [0, 0.1, 0], seconds: 20 }\n",
    )
    .unwrap();
    let daemon = Hapticd::start(
        &bus,
        &setup,
        &["--sim", "spidar-g", "--hand", hand.to_str().unwrap()],
    );
    let (mut bridge, endpoint) = zenoh_bridge(&bus, &dir, "rate: 1000\n", None, None);
    let follow = "samples = {}\n\
        def taken(sample):\n\
        \x20   tick = int.from_bytes(sample.attachment.to_bytes()[:8], 'little')\n\
        \x20   kind = str(sample.key_expr).split('/')[4 if '/grip/' in str(sample.key_expr) else 3]\n\
        \x20   samples.setdefault(kind, []).append((str(sample.key_expr), tick, sample.payload.to_bytes()))\n\
        subscriber = session.declare_subscriber('0/hapticd/sim/**', taken)\n\
        time.sleep(10)\n\
        subscriber.undeclare()\n\
        status = ask('hapticd/sim/status', None)\n\
        tokens = sorted(str(r.ok.key_expr) for r in session.liveliness().get('@ros2_lv/0/**') if r.ok)\n\
        refused = ask('hapticd/sim/set/Stiffness', '1500')\n\
        ticks = [t for _, t, _ in samples['pose']]\n\
        gaps = sum(1 for a, b in zip(ticks, ticks[1:]) if b != a + 1)\n\
        key, _, payload = samples['pose'][-1]\n\
        twists = [struct.unpack_from('<3d', p, len(p) - 24) for _, _, p in samples['twist'][-3000:]]\n\
        angular = [sum(w[i] for w in twists) / len(twists) for i in range(3)]\n\
        print(json.dumps({'count': len(ticks), 'gaps': gaps, 'key': key, \
        'kinds': {k: len(v) for k, v in samples.items()}, 'twist': samples['twist'][-1][0], \
        'angular': angular, \
        'header': payload[:4].hex(), 'position': struct.unpack_from('<3d', payload, 28), \
        'strings': samples['strings'][-1][2].hex(), 'state': samples['state'][-1][2].hex(), \
        'status': json.loads(status[0]), 'tokens': tokens, 'refused': refused}))\n";
    let said = zenoh_client(follow, &endpoint, &[], None);
    // hapticctl reaches the same daemon through the bridge alone: its status, and 2 s of
    // its ticks in the CSV a local `record` writes.
    let remote = |args: &[&str]| {
        let out = hapticctl()
            .args(["--bus", "unix:path=/nonexistent", "--remote", &endpoint])
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "{args:?}: {out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let status = remote(&["status"]);
    assert!(status.contains("sim: running, 1000 Hz, tick "), "{status}");
    let statuses: serde_json::Value = serde_json::from_str(&remote(&["status", "--json"])).unwrap();
    assert_eq!(statuses[0]["identity"], "sim");
    let csv = dir.join("remote.csv");
    remote(&["record", "--duration", "2", csv.to_str().unwrap()]);
    let recorded = std::fs::read_to_string(&csv).unwrap();
    let mut lines = recorded.lines();
    assert!(lines.next().unwrap().starts_with("tick,time,state,pose_x,"));
    let ticks: Vec<u64> = lines
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(ticks.len() > 1900, "{} rows", ticks.len());
    assert!(
        ticks.windows(2).all(|w| w[1] == w[0] + 1),
        "every tick, in order"
    );
    let refused = hapticctl()
        .args(["--remote", &endpoint, "set", "Stiffness", "1"])
        .output()
        .unwrap();
    assert_eq!(refused.status.code(), Some(2), "{refused:?}");
    let _ = bridge.kill();
    let _ = bridge.wait();
    println!("{said}");
    // Ten seconds at 1 kHz, every tick in order (a loop that a loaded machine slows makes
    // fewer ticks; the bridge must still publish each one).
    let count = said["count"].as_u64().unwrap();
    assert!(count > 5000, "{said}");
    assert_eq!(said["gaps"], 0, "{said}");
    let key = said["key"].as_str().unwrap();
    assert!(
        key.starts_with("0/hapticd/sim/grip/pose/geometry_msgs::msg::dds_::PoseStamped_/RIHS01_"),
        "{key}"
    );
    assert!(
        said["twist"]
            .as_str()
            .unwrap()
            .starts_with("0/hapticd/sim/grip/twist/geometry_msgs::msg::dds_::TwistStamped_/")
    );
    for kind in ["pose", "twist", "wrench", "strings"] {
        assert!(said["kinds"][kind].as_u64().unwrap() + 2 >= count, "{said}");
    }
    // The twist's angular part, the last 24 bytes, over its last three seconds: the turn.
    let angular: Vec<f64> = said["angular"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(
        angular[0].abs() < 0.01 && (angular[1] - 0.1).abs() < 0.01 && angular[2].abs() < 0.01,
        "{angular:?}"
    );
    // The world's bodies (none in the static scene) as often as its picture: 60 a second.
    let bodies = said["kinds"]["bodies"].as_u64().unwrap();
    assert!((500..=650).contains(&bodies), "{said}");
    // The state once a second and when it changes.
    assert!(
        (9..=12).contains(&said["kinds"]["state"].as_u64().unwrap()),
        "{said}"
    );
    assert_eq!(said["header"], "00010000", "little-endian CDR");
    // The simulated grip turns where it was calibrated, at the frame's centre.
    let position: Vec<f64> = said["position"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(position.iter().all(|x| x.abs() < 1e-3), "{position:?}");
    // SPIDAR-G's eight strings by name, in a JointState; "running" in a String.
    let strings = hex_bytes(said["strings"].as_str().unwrap());
    let decoded = JointState::decode(&strings).unwrap();
    assert_eq!(decoded.name.len(), 8);
    assert_eq!(decoded.name[7], "string7");
    assert_eq!(decoded.effort.len(), 8);
    assert!(decoded.effort.iter().all(|t| t.is_finite() && *t >= 0.0));
    let state = StringMessage::decode(&hex_bytes(said["state"].as_str().unwrap())).unwrap();
    assert_eq!(state.data, "running");
    let status = &said["status"];
    assert_eq!(status["identity"], "sim");
    assert_eq!(status["state"], "running");
    assert_eq!(status["rate"], 1000.0);
    assert_eq!(status["commands"], false);
    // `ros2 node list` and `ros2 topic list` find the node and its seven publishers.
    let tokens: Vec<&str> = said["tokens"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    assert_eq!(tokens.len(), 8, "{tokens:?}");
    assert!(
        tokens
            .iter()
            .any(|t| t.contains("/NN/%/%/hapticd_sim") && t.ends_with("hapticd_sim")),
        "{tokens:?}"
    );
    assert!(
        tokens.iter().any(|t| t.contains(
            "/MP/%/%/hapticd_sim/%hapticd%sim%grip%pose/geometry_msgs::msg::dds_::PoseStamped_/"
        ) && t.ends_with("/::,:,:,:,,")),
        "{tokens:?}"
    );
    let refused = said["refused"][0].as_str().unwrap();
    assert!(refused.starts_with("error: refused"), "{refused}");
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000", "nothing changed");
    daemon.stop();
}

/// `openssl ARGS` in `dir`, which must succeed.
fn openssl(dir: &Path, args: &[&str]) {
    let out = Command::new("openssl")
        .current_dir(dir)
        .args(args)
        .output()
        .expect("openssl is installed by `make check`");
    assert!(out.status.success(), "openssl {args:?}: {out:?}");
}

/// A certificate authority `ca` (ca.pem, ca.key) in `dir`, and a certificate of it for each of
/// `holders` (NAME.pem, NAME.key) naming 127.0.0.1: P-256 keys, valid for a day.
fn certificates(dir: &Path, ca: &str, holders: &[&str]) {
    let key = [
        "-newkey",
        "ec",
        "-pkeyopt",
        "ec_paramgen_curve:P-256",
        "-nodes",
    ];
    let (ca_pem, ca_key) = (format!("{ca}.pem"), format!("{ca}.key"));
    let subject = format!("/CN={ca}");
    openssl(
        dir,
        &[
            &["req", "-x509"][..],
            &key,
            &[
                "-keyout", &ca_key, "-out", &ca_pem, "-days", "1", "-subj", &subject,
            ],
        ]
        .concat(),
    );
    std::fs::write(dir.join("holder.ext"), "subjectAltName=IP:127.0.0.1\n").unwrap();
    for holder in holders {
        let (pem, private, request) = (
            format!("{holder}.pem"),
            format!("{holder}.key"),
            format!("{holder}.csr"),
        );
        let subject = format!("/CN={holder}");
        openssl(
            dir,
            &[
                &["req"][..],
                &key,
                &["-keyout", &private, "-out", &request, "-subj", &subject],
            ]
            .concat(),
        );
        openssl(
            dir,
            &[
                "x509",
                "-req",
                "-in",
                &request,
                "-CA",
                &ca_pem,
                "-CAkey",
                &ca_key,
                "-CAcreateserial",
                "-out",
                &pem,
                "-days",
                "1",
                "-extfile",
                "holder.ext",
            ],
        );
    }
}

/// The bridge over mutual TLS, configured by the README's own `zenoh` file: a client holding
/// a certificate of the administrator's CA reads the status, and so does `hapticctl --remote`
/// given the same certificate in its `--remote-config`; one holding another CA's certificate,
/// one speaking plain TCP to the same port, and hapticctl without the file get no session.
#[test]
fn the_zenoh_bridge_over_tls_answers_only_holders_of_its_certificates() {
    let dir = support::shared_scratch("dbus", "zenoh-tls");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let tls = dir.join("tls");
    std::fs::create_dir_all(&tls).unwrap();
    certificates(&tls, "ca", &["bridge", "operator"]);
    certificates(&tls, "stranger-ca", &["stranger"]);
    let readme = std::fs::read_to_string(repo_dir().join("README.md")).unwrap();
    let tls_text = readme
        .split("```json5\n")
        .filter_map(|block| block.split("```").next())
        .find(|block| block.contains("tls:"))
        .expect("README shows a zenoh file for TLS");
    let credentials = "/run/credentials/hapticd-zenoh.service/";
    assert!(tls_text.contains(credentials), "{tls_text}");
    let zenoh_file = dir.join("tls.json5");
    std::fs::write(
        &zenoh_file,
        tls_text.replace(credentials, &format!("{}/", tls.display())),
    )
    .unwrap();
    let (_, port) = support::loopback_endpoint();
    let endpoint = format!("tls/127.0.0.1:{port}");
    let config = format!("listen: [{endpoint}]\nzenoh: {}\n", zenoh_file.display());
    let mut bridge = zenoh_bridge_on(&bus, &dir, &config, port, None, None);
    let client = |endpoint: &str, holder: Option<(&str, &str)>| {
        let mut settings = serde_json::json!({ "transport/unicast/open_timeout": 3000 });
        if let Some((ca, holder)) = holder {
            let at = |file: String| tls.join(file).display().to_string();
            settings["transport/link/tls/root_ca_certificate"] = at(format!("{ca}.pem")).into();
            settings["transport/link/tls/connect_certificate"] = at(format!("{holder}.pem")).into();
            settings["transport/link/tls/connect_private_key"] = at(format!("{holder}.key")).into();
            settings["transport/link/tls/enable_mtls"] = true.into();
        }
        zenoh_client_with(
            "print(json.dumps({'status': ask('hapticd/sim/status', None)}))\n",
            endpoint,
            &[],
            None,
            &settings,
        )
    };
    let operator = client(&endpoint, Some(("ca", "operator")));
    // Another CA's holder trusts the bridge's certificate (it has the CA), but the bridge
    // does not trust the holder's.
    let stranger = client(&endpoint, Some(("ca", "stranger")));
    let plain = client(&format!("tcp/127.0.0.1:{port}"), None);
    // hapticctl --remote, with the operator's certificates in a Zenoh file of its own.
    let operator_file = dir.join("operator.json5");
    let at = |file: &str| tls.join(file).display().to_string();
    std::fs::write(
        &operator_file,
        serde_json::json!({ "transport": { "link": { "tls": {
            "root_ca_certificate": at("ca.pem"),
            "connect_certificate": at("operator.pem"),
            "connect_private_key": at("operator.key"),
            "enable_mtls": true,
        } } } })
        .to_string(),
    )
    .unwrap();
    let remote_status = |file: Option<&Path>| {
        let mut command = support::hapticctl();
        command.args(["--remote", &endpoint]);
        if let Some(file) = file {
            command.arg("--remote-config").arg(file);
        }
        command.arg("status").output().unwrap()
    };
    let (ctl, ctl_without) = (remote_status(Some(&operator_file)), remote_status(None));
    let _ = bridge.kill();
    let _ = bridge.wait();
    eprintln!("operator: {operator}\nstranger: {stranger}\nplain TCP: {plain}");
    let status: serde_json::Value =
        serde_json::from_str(operator["status"][0].as_str().unwrap()).unwrap();
    assert_eq!(status["identity"], "sim", "{operator}");
    assert_eq!(status["state"], "running", "{operator}");
    for refused in [&stranger, &plain] {
        assert!(refused["unreachable"].is_string(), "{refused}");
    }
    let said = String::from_utf8_lossy(&ctl.stdout);
    assert!(ctl.status.success(), "{ctl:?}");
    assert!(said.contains("sim: running, 1000 Hz"), "{said}");
    let refused = String::from_utf8_lossy(&ctl_without.stderr);
    assert_eq!(ctl_without.status.code(), Some(1), "{ctl_without:?}");
    assert!(refused.contains("cannot reach"), "{refused}");
    daemon.stop();
}

/// Commands through a bridge that takes them: refused by the bus for a bridge whose user has
/// no rights, kept from the bridge by Zenoh's access control as the README configures it,
/// and carried out (parameters checked as the bus checks them, a push felt, bounded, ramped
/// and let go when no command comes) by a bridge with the rights.
#[test]
fn the_zenoh_bridge_takes_commands_only_as_far_as_it_is_allowed() {
    let dir = support::shared_scratch("dbus", "zenoh-commands");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // Each command also pushes on the grip through its wrench_command topic: 2 N up for a
    // second, then a million newtons for half a second, then nothing; the displayed wrench
    // topic says what the hand felt, tick by tick.
    let command = "print(json.dumps({'set': ask('hapticd/sim/set/Stiffness', '1500'), \
        'bad': ask('hapticd/sim/set/Stiffness', 'nan'), \
        'malformed': ask('hapticd/scene/body/x/pose', '[1]'), 'felt': push()}))\n";
    let push = "def push():\n\
        \x20   shown = []\n\
        \x20   def displayed(sample):\n\
        \x20       b = sample.payload.to_bytes()\n\
        \x20       n = int.from_bytes(b[12:16], 'little')\n\
        \x20       at = 4 + -(-(12 + n) // 8) * 8\n\
        \x20       shown.append((time.monotonic(), struct.unpack_from('<d', b, at + 8)[0]))\n\
        \x20   sub = session.declare_subscriber('0/hapticd/sim/grip/wrench/**', displayed)\n\
        \x20   pub = session.declare_publisher(sys.argv[2])\n\
        \x20   phases = {}\n\
        \x20   for name, payload, seconds in [('push', sys.argv[3], 1.0), ('huge', sys.argv[4], 0.5), ('quiet', None, 0.6)]:\n\
        \x20       start = phases[name] = time.monotonic()\n\
        \x20       while time.monotonic() - start < seconds:\n\
        \x20           if payload:\n\
        \x20               pub.put(bytes.fromhex(payload))\n\
        \x20           time.sleep(0.005)\n\
        \x20   sub.undeclare()\n\
        \x20   ends = {'push': phases['huge'], 'huge': phases['quiet'], 'quiet': phases['quiet'] + 0.6}\n\
        \x20   def during(name, after=0.0, until=None):\n\
        \x20       end = ends[name] if until is None else phases[name] + until\n\
        \x20       return [f for t, f in shown if phases[name] + after <= t < end]\n\
        \x20   rising = [f for f in during('push') if f > 1e-9]\n\
        \x20   return {'first': rising[:3], 'push_end': during('push', 0.5), 'huge_max': max(during('huge') or [0]), \
        'held': during('quiet', 0.0, 0.05), 'gone': during('quiet', 0.3)}\n";
    let key = hapticd_ros2::keys::topic_key::<WrenchStamped>(0, "/hapticd/sim/grip/wrench_command");
    let wrench = |newtons: f64| {
        let message = WrenchStamped {
            header: Header {
                stamp: Time::from_nanos(1),
                frame_id: "remote".into(),
            },
            force: [0.0, newtons, 0.0],
            torque: [0.0; 3],
        };
        message
            .encode()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    };
    let args = [key, wrench(2.0), wrench(1e6)];
    let script = format!("{push}{command}");
    if is_root() {
        let (mut bridge, endpoint) =
            zenoh_bridge(&bus, &dir, "commands: true\n", Some(65534), None);
        let said = zenoh_client(&script, &endpoint, &args, None);
        let _ = bridge.kill();
        let _ = bridge.wait();
        let denied = said["set"][0].as_str().unwrap();
        assert!(
            denied.contains("org.freedesktop.DBus.Error.AccessDenied"),
            "{said}"
        );
        assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000", "nothing changed");
        // Without the rights, the wrench input is not opened: nothing pushes on the hand.
        assert_eq!(said["felt"]["first"], serde_json::json!([]), "{said}");
        assert_eq!(bus.get(DEVICE, "WrenchCommand"), "s \"none\"");
    }
    // Commands on, and Zenoh's access control as the README shows it: the status is
    // answered; no command, parameter or push reaches the bridge.
    let readme = std::fs::read_to_string(repo_dir().join("README.md")).unwrap();
    let acl_text = readme
        .split("```json5\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .unwrap();
    let acl = dir.join("acl.json5");
    std::fs::write(&acl, acl_text).unwrap();
    let guarded = format!("commands: true\nzenoh: {}\n", acl.display());
    let (mut bridge, endpoint) = zenoh_bridge(&bus, &dir, &guarded, None, None);
    let said = zenoh_client(
        &format!(
            "{push}print(json.dumps({{'status': ask('hapticd/sim/status', None), \
         'set': ask('hapticd/sim/set/Stiffness', '1500'), 'felt': push()}}))\n"
        ),
        &endpoint,
        &args,
        None,
    );
    let _ = bridge.kill();
    let _ = bridge.wait();
    assert!(
        said["status"][0]
            .as_str()
            .unwrap()
            .contains("\"commands\":true"),
        "{said}"
    );
    assert_eq!(said["set"], serde_json::json!([]), "{said}");
    // The displayed wrench came through all along, and stayed zero.
    let shown = said["felt"]["push_end"].as_array().unwrap();
    assert!(
        !shown.is_empty() && shown.iter().all(|f| f.as_f64() == Some(0.0)),
        "{said}"
    );
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000", "nothing changed");
    let (mut bridge, endpoint) = zenoh_bridge(&bus, &dir, "commands: true\n", None, None);
    let said = zenoh_client(&script, &endpoint, &args, None);
    let _ = bridge.kill();
    let _ = bridge.wait();
    println!("{said}");
    assert_eq!(
        said["set"][0].as_str().unwrap(),
        r#"{"set":"Stiffness","value":1500.0}"#,
        "{said}"
    );
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 1500");
    assert!(
        said["bad"][0]
            .as_str()
            .unwrap()
            .contains("org.hapticd.Hapticd1.Error.NotFinite"),
        "{said}"
    );
    assert!(
        said["malformed"][0]
            .as_str()
            .unwrap()
            .starts_with("error: ")
    );
    // The push ramps in (the first samples felt are a fraction of it), then is felt whole;
    // the million newtons are MaxForce; once nothing comes, it is held for 0.1 s (a late
    // packet is no fault) and then ramped out.
    let felt = &said["felt"];
    let numbers = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let first = numbers(&felt["first"]);
    assert!(!first.is_empty() && first[0] < 1.0, "{felt}");
    let whole = numbers(&felt["push_end"]);
    assert!(
        !whole.is_empty() && whole.iter().all(|f| (f - 2.0).abs() < 1e-6),
        "{felt}"
    );
    let huge = felt["huge_max"].as_f64().unwrap();
    assert!((huge - 10.0).abs() < 1e-6, "MaxForce, not {huge}");
    let gone = numbers(&felt["gone"]);
    assert!(
        !gone.is_empty() && gone.iter().all(|f| f.abs() < 1e-9),
        "{felt}"
    );
    assert!(numbers(&felt["held"]).iter().any(|f| *f > 1.0), "{felt}");
    assert_eq!(bus.get(DEVICE, "WrenchCommand"), "s \"stale\"");
    daemon.stop();
}

/// The bytes a hex string spells.
fn hex_bytes(hex: &str) -> Vec<u8> {
    (0..hex.len())
        .step_by(2)
        .map(|k| u8::from_str_radix(&hex[k..k + 2], 16).unwrap())
        .collect()
}

/// The Rust client library (`hapticd_ipc::client`) against a running daemon.
#[test]
fn the_rust_client_reads_sets_switches_and_follows_every_tick() {
    use hapticd_ipc::bus::Bus as Address;
    use hapticd_ipc::client::{ClientError, Hapticd as Client};
    let dir = support::shared_scratch("dbus", "rust-client");
    let bus = Bus::start(&dir);
    let at = Address::Address(bus.address.clone());
    assert!(matches!(Client::connect(&at), Err(ClientError::NotRunning)));
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let hapticd = Client::connect(&at).unwrap();
    let devices = hapticd.devices().unwrap();
    let device = &devices[0];
    assert_eq!(device.identity().unwrap(), "sim");
    assert_eq!(device.mechanism().unwrap(), "spidar-g");
    assert_eq!(device.state().unwrap(), "running");
    device.set("Stiffness", 1500.0).unwrap();
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 1500");
    for (value, reason) in [(f64::NAN, "NotFinite"), (1e12, "OutOfRange")] {
        match device.set("Stiffness", value) {
            Err(ClientError::Refused { name, .. }) => {
                assert_eq!(name, format!("org.hapticd.Hapticd1.Error.{reason}"))
            }
            other => panic!("{value}: {other:?}"),
        }
    }
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 1500");
    let ticks: Vec<u64> = device.telemetry(0.5).unwrap().map(|s| s.tick).collect();
    assert_eq!(ticks.len(), 500);
    assert!(ticks.windows(2).all(|w| w[1] == w[0] + 1));
    let mut waited = 0;
    hapticd
        .switch_scene("blocks", Duration::from_secs(60), &mut |_| waited += 1)
        .unwrap();
    assert_eq!(hapticd.active_scene().unwrap(), "blocks");
    assert_eq!(waited, 0, "no mesh to cut, nothing to wait for");
    match hapticd.switch_scene("no-such-scene", Duration::ZERO, &mut |_| {}) {
        Err(ClientError::Refused { name, .. }) => {
            assert_eq!(name, "org.hapticd.Hapticd1.Error.UnknownScene")
        }
        other => panic!("{other:?}"),
    }
    assert!(hapticd.scenes().unwrap().contains(&"static".to_string()));
    // The running world through the client: its bodies, a push and a refusal.
    let scene = hapticd.scene().unwrap();
    let bodies = scene.bodies().unwrap();
    assert_eq!((bodies[0].name.as_str(), bodies[0].fixed), ("table", true));
    let block = scene.body("block").unwrap();
    let pushed = scene
        .apply_impulse("block", [0.0, 0.0, 0.1 * block.mass], None)
        .unwrap();
    assert!((pushed.velocity[2] - block.velocity[2] - 0.1).abs() < 1e-9);
    let turned = (0..3)
        .map(|k| (pushed.spin[k] - block.spin[k]).abs())
        .fold(0.0, f64::max);
    // The block rests on the table between the two readings, and its contacts may turn it
    // by a hair; the same push 0.1 m off its centre would turn it at about 1 rad/s.
    assert!(
        turned < 1e-4,
        "through its centre: no turn ({turned} rad/s)"
    );
    match scene.set_velocity("table", [0.1, 0.0, 0.0], [0.0; 3]) {
        Err(ClientError::Refused { name, .. }) => {
            assert_eq!(name, "org.hapticd.Hapticd1.Error.FixedBody")
        }
        other => panic!("{other:?}"),
    }
    // Its picture of the world shows the scene's bodies.
    let world = device.open_world().unwrap();
    let mut frame = hapticd_core::world_state::WorldFrame::empty();
    assert!(world.read(&mut frame).is_some());
    assert_eq!(
        frame.body_count as usize,
        bodies.len() + 1,
        "the pointer's too"
    );
    daemon.stop();
}

/// The `Touch` signals of device 0 while a daemon rendering `scene` runs
/// `config/hands/press-floor.yaml` (the grip lowered onto y = -0.03, pressed, slid and
/// lifted off), through the Rust client, up to the first end of a touch.
fn touches_of_the_press(scene: &str) -> Vec<hapticd_ipc::client::Touch> {
    use hapticd_ipc::bus::Bus as Address;
    use hapticd_ipc::client::Hapticd as Client;
    let dir = support::shared_scratch("dbus", &format!("touch-{scene}"));
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    std::fs::write(
        &setup.config,
        default_config().replace("scene: static", &format!("scene: {scene}")),
    )
    .unwrap();
    let hand = repo_dir().join("config/hands/press-floor.yaml");
    // The daemon starts lowering the hand at once: its touches are followed from a start
    // with no hand, then the hand is given by a second start (same bus name and path).
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let device = Client::connect(&Address::Address(bus.address.clone()))
        .unwrap()
        .devices()
        .unwrap()
        .remove(0);
    let (sender, touches) = std::sync::mpsc::channel();
    let mut following = device.touches().unwrap();
    std::thread::spawn(move || {
        while let Some(Ok(touch)) = following.next() {
            if sender.send(touch).is_err() {
                return;
            }
        }
    });
    daemon.stop();
    let daemon = Hapticd::start(
        &bus,
        &setup,
        &["--sim", "spidar-g", "--hand", hand.to_str().unwrap()],
    );
    let mut seen = Vec::new();
    while seen.last().is_none_or(|t: &hapticd_ipc::client::Touch| {
        t.event != hapticd_ipc::client::TouchEvent::End
    }) {
        seen.push(touches.recv_timeout(Duration::from_secs(10)).unwrap());
    }
    daemon.stop();
    seen
}

/// `Touch` signals on the static scene's floor (a solid of no body): one begin where the
/// floor is, a slip when the hand slides, one end when it lifts off.
#[test]
fn a_touch_begins_on_the_floor_slips_with_the_hand_and_ends_when_it_lifts() {
    use hapticd_ipc::client::TouchEvent;
    let seen = touches_of_the_press("static");
    assert!(seen.iter().all(|t| t.effector == 0), "{seen:?}");
    // Between the begin and the end the finger may stick and slip again (stick-slip).
    let (begun, slid, ended) = (&seen[0], &seen[1], &seen[seen.len() - 1]);
    assert_eq!(begun.event, TouchEvent::Begin, "{seen:?}");
    assert!(
        seen[1..seen.len() - 1]
            .iter()
            .all(|t| t.event == TouchEvent::Slip)
            && seen.len() > 2,
        "{seen:?}"
    );
    assert_eq!(begun.body, None, "the floor is no body");
    // The floor of the static scene is at y = -0.03: the proxy rests on it there.
    assert!((begun.point[1] + 0.03).abs() < 2e-3, "{begun:?}");
    // Where the scene does not say, the normal is the force's direction: up.
    assert!(begun.normal[1] > 0.99, "{begun:?}");
    assert!(
        slid.tick > begun.tick + 1000,
        "slides after a second's press: {seen:?}"
    );
    assert!(ended.tick > slid.tick, "{seen:?}");
}

/// On the penalty engine's table, the touch names its body, and the normal is the contact's.
#[test]
fn a_touch_on_a_body_names_it_and_its_contact_normal() {
    use hapticd_ipc::client::TouchEvent;
    let seen = touches_of_the_press("blocks");
    let begun = &seen[0];
    assert_eq!(begun.event, TouchEvent::Begin, "{seen:?}");
    assert_eq!(begun.body, Some((0, "table".to_string())), "{begun:?}");
    assert!(begun.normal[1] > 0.999, "{begun:?}");
    assert!((begun.point[1] + 0.03).abs() < 5e-3, "{begun:?}");
}

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

/// A body's state as the Scene interface answers it.
#[derive(Debug, Clone, Copy)]
struct BodyState {
    position: DVec3,
    velocity: DVec3,
    mass: f64,
    friction: f64,
    force: DVec3,
}

#[test]
fn the_running_world_is_driven_from_outside_under_both_engines_and_hostile_values_are_named() {
    let dir = support::shared_scratch("dbus", "drive");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // The static scene has no bodies to drive.
    assert_eq!(bus.get(SCENE, "Bodies"), "a(sb) 0");
    assert_eq!(
        bus.drive_error("Body", &["string:block"]),
        "org.hapticd.Hapticd1.Error.Unavailable"
    );
    // Penalty (f64, in the haptic tick) and rapier (f32, in the physics thread).
    for (scene, tolerance) in [("blocks", 1e-9), ("push", 1e-5)] {
        switch_when_prepared(&bus, scene);
        let bodies = bus.get(SCENE, "Bodies");
        assert!(
            bodies.contains("\"block\" false") && bodies.contains("true"),
            "{bodies}"
        );
        // Once the world has settled from its start, an impulse through the centre changes
        // momentum by J: the state answered is the body's right after it, before the world
        // steps on.
        std::thread::sleep(Duration::from_millis(500));
        let before = bus.drive("Body", "s", &["block"]).unwrap();
        let j = DVec3::new(0.4, 0.0, 0.15) * before.mass;
        let pushed = bus
            .drive(
                "ApplyImpulse",
                "sadad",
                &["block", "3", &j.x.to_string(), "0", &j.z.to_string(), "0"],
            )
            .unwrap();
        let momentum = (pushed.velocity - before.velocity) * before.mass;
        assert!(
            (momentum - j).length() < 0.01 * j.length(),
            "{scene}: {momentum} vs {j}"
        );
        // A pose is there when answered (the forces ramped to zero and back around it).
        let to = DVec3::new(0.05, 0.08, -0.02);
        let placed = bus
            .drive(
                "SetPose",
                "sadad",
                &[
                    "block", "3", "0.05", "0.08", "-0.02", "4", "1", "0", "0", "0",
                ],
            )
            .unwrap();
        assert!(
            (placed.position - to).length() < tolerance,
            "{scene}: {placed:?}"
        );
        // By id as by name; mass, friction and a held force are answered as set.
        let id = bodies
            .split('"')
            .skip(1)
            .step_by(2)
            .position(|n| n == "block")
            .unwrap()
            .to_string();
        let lighter = bus.drive("SetMass", "sd", &[&id, "0.5"]).unwrap();
        assert!(
            (lighter.mass - 0.5).abs() < tolerance,
            "{scene}: {lighter:?}"
        );
        let slippery = bus.drive("SetFriction", "sd", &["block", "0.1"]).unwrap();
        assert!((slippery.friction - 0.1).abs() < tolerance);
        let held = bus
            .drive("SetForce", "sad", &["block", "3", "0", "4.905", "0"])
            .unwrap();
        assert!((held.force - DVec3::new(0.0, 4.905, 0.0)).length() < tolerance);
        // Hostile callers get a named error and change nothing.
        let error = |method: &str, args: &[&str]| bus.drive_error(method, args);
        let named = |short: &str| format!("org.hapticd.Hapticd1.Error.{short}");
        assert_eq!(
            error("Body", &["string:no-such-body"]),
            named("UnknownBody")
        );
        assert_eq!(
            error("SetMass", &["string:99", "double:1"]),
            named("UnknownBody")
        );
        assert_eq!(
            error("SetMass", &["string:block", "double:nan"]),
            named("NotFinite")
        );
        assert_eq!(
            error("SetMass", &["string:block", "double:-1"]),
            named("OutOfRange")
        );
        assert_eq!(
            error("SetMass", &["string:block", "double:1e300"]),
            named("OutOfRange")
        );
        // Light enough to be flung kilometres by a pressing finger (1 µg), or to fault the
        // device (1e-300 kg): refused as a scene file's body would be, in either engine.
        for light in ["double:1e-6", "double:1e-300"] {
            assert_eq!(
                error("SetMass", &["string:block", light]),
                named("OutOfRange"),
                "{scene}: {light}"
            );
        }
        assert_eq!(
            error(
                "SetVelocity",
                &["string:block", "array:double:1e9,0,0", "array:double:0,0,0"]
            ),
            named("OutOfRange")
        );
        assert_eq!(
            error(
                "SetPose",
                &[
                    "string:block",
                    "array:double:0,inf,0",
                    "array:double:1,0,0,0"
                ]
            ),
            named("NotFinite")
        );
        assert_eq!(
            error(
                "SetPose",
                &["string:block", "array:double:0,0", "array:double:1,0,0,0"]
            ),
            named("OutOfRange")
        );
        assert_eq!(
            error(
                "SetPose",
                &["string:block", "array:double:0,0,0", "array:double:0,0,0,0"]
            ),
            named("OutOfRange")
        );
        assert_eq!(
            error(
                "ApplyImpulse",
                &["string:block", "array:double:1e6,0,0", "array:double:"]
            ),
            named("OutOfRange")
        );
        let fixed = if scene == "blocks" { "table" } else { "floor" };
        assert_eq!(
            error(
                "SetForce",
                &[&format!("string:{fixed}"), "array:double:0,1,0"]
            ),
            named("FixedBody")
        );
        let after = bus.drive("Body", "s", &["block"]).unwrap();
        assert!((after.mass - 0.5).abs() < tolerance && (after.friction - 0.1).abs() < tolerance);
    }
    assert!(
        !bus.get(DEVICE, "State").contains("fault"),
        "{}",
        bus.get(DEVICE, "State")
    );
    // hapticctl body, on the client library: the rapier world's bodies, a push, refusals.
    let said = |args: &[&str]| {
        let out = bus.ctl(args);
        let text = String::from_utf8_lossy(&out.stdout).into_owned()
            + &String::from_utf8_lossy(&out.stderr);
        (out.status.code(), text)
    };
    let (code, listed) = said(&["body", "list"]);
    assert_eq!(code, Some(0), "{listed}");
    assert!(
        listed.contains("0  floor") && listed.contains("fixed"),
        "{listed}"
    );
    let (code, pushed) = said(&["body", "push", "block", "--json", "0", "0", "-0.5"]);
    assert_eq!(code, Some(0), "{pushed}");
    let state: serde_json::Value = serde_json::from_str(&pushed).unwrap();
    assert!(
        (state["mass"].as_f64().unwrap() - 0.5).abs() < 1e-5,
        "{pushed}"
    );
    let (code, refused) = said(&["body", "show", "no-such-body"]);
    assert_eq!(code, Some(1));
    assert!(
        refused.contains("UnknownBody: no body \"no-such-body\""),
        "{refused}"
    );
    let (code, refused) = said(&["body", "mass", "floor", "3"]);
    assert_eq!(code, Some(1));
    assert!(refused.contains("FixedBody"), "{refused}");
    let (code, _) = said(&["body", "pose", "block", "0", "0"]);
    assert_eq!(code, Some(2), "two numbers for three");
}

/// The shared world of the two-host test: a light block (0.1 kg: what a constraint engine
/// used to fling) on a floor, stepped by rapier at 60 Hz with local dynamics.
const SHARED_WORLD: &str = "name: shared
engine: rapier
rate: 60
feedback: local
material: { static_friction: 0.3, friction: 0.3 }
bodies:
  - { name: floor, box: [0.4, 0.02, 0.4], position: [0, -0.05, 0], fixed: true }
  - { name: block, box: [0.04, 0.04, 0.04], position: [0, -0.02, 0], density: 1562.5 }
pointer:
  sphere: 0.005
";

/// A finger at height -0.02 and depth `z`, held clear of the block (its near face at
/// x = -0.02) while the hosts find the world, then in to the face and pushing it 3 cm along
/// +x at 1.5 cm/s, then pressing on with 0.1 N more.
fn pushing_hand(z: f64) -> String {
    format!(
        "hands:
  grip:
    - hold: {{ at: [-0.06, -0.02, {z}], seconds: 4 }}
    - move: {{ to: [-0.027, -0.02, {z}], seconds: 1 }}
    - move: {{ to: [0.003, -0.02, {z}], seconds: 2 }}
    - push: {{ force: [0.1, 0, 0], seconds: 30 }}
"
    )
}

/// What one host of the shared world saw of it: the energy its device gave the hand
/// (∫ F·v dt; negative: the hand put it in), the ticks it pushed with more than 0.1 N, and at
/// the end its picture of the block and where its proxy rests.
struct HostView {
    given: f64,
    pushing: usize,
    block: DVec3,
    proxy: DVec3,
}

/// Follow host `address`'s first device for `seconds`: its ticks, then its picture.
fn follow_host(address: &str, seconds: f64) -> HostView {
    use hapticd_core::telemetry::Sample;
    use hapticd_core::world_state::WorldFrame;
    let client =
        hapticd_ipc::client::Hapticd::connect(&hapticd_ipc::bus::Bus::Address(address.into()))
            .unwrap();
    let device = &client.devices().unwrap()[0];
    let ring = device.open_telemetry().unwrap();
    let dt = 1.0 / ring.rate();
    let mut cursor = ring.from_now();
    let (mut sample, mut given, mut pushing) = (Sample::EMPTY, 0.0, 0);
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    while Instant::now() < end {
        while ring.next(&mut cursor, &mut sample) {
            let force = DVec3::from(sample.wrenches[0].force);
            given += force.dot(DVec3::from(sample.velocities[0])) * dt;
            pushing += usize::from(force.x < -0.1);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let world = device.open_world().unwrap();
    let mut frame = WorldFrame::empty();
    while world.read(&mut frame).is_none() {}
    assert_eq!(frame.has_proxies, 1, "a remote scene shows its proxies");
    HostView {
        given,
        pushing,
        block: DVec3::from(frame.bodies[1].position),
        proxy: DVec3::from(frame.proxies[0]),
    }
}

/// Thesis Fig. 6.13 over a network: one rapier world on a world host (`hapticd-world`),
/// touched by the simulated devices of two hapticd, each rendering it locally through a
/// remote scene. The world host is in a network namespace of its own, the two bridges in
/// another, joined by a veth pair; relays on the bridges' side delay every byte (this machine
/// has no `tc netem`) for a round trip of 20 ms, then of 100 ms. Both fingers
/// push the same light block along the floor: each feels it, the block moves as one for
/// both (its picture on each host within 1 mm of the world's, both proxies on its face within
/// 1 mm of each other), no device gives the hand energy, and the block is never flung.
#[test]
fn two_hosts_push_one_block_of_a_world_on_a_third_over_a_slow_network() {
    for round_trip in [0.02, 0.1] {
        let dir = support::shared_scratch(
            "dbus",
            &format!("shared-world-{}", (round_trip * 1e3) as u32),
        );
        std::fs::create_dir_all(&dir).unwrap();
        let scene = dir.join("shared.yaml");
        std::fs::write(&scene, SHARED_WORLD).unwrap();
        let remote = dir.join("far.yaml");
        std::fs::write(&remote, "engine: remote\nrate: 60\n").unwrap();
        // The world host on one side of a veth pair, the haptic hosts' bridges on the other
        // (where this process may not make namespaces: all on the loopback).
        let network = support::netns::Pair::create();
        let hosts_side = network.as_ref().map(|pair| &pair.far);
        let (world_endpoint, upstream) = match &network {
            Some(pair) => (
                format!("tcp/{}:7447", pair.near.address),
                format!("{}:7447", pair.near.address),
            ),
            None => {
                let (endpoint, port) = support::loopback_endpoint();
                (endpoint, format!("127.0.0.1:{port}"))
            }
        };
        let mut world_command = Command::new(artifact("hapticd-world"));
        world_command
            .args(["--config", "/dev/null", "--listen", &world_endpoint])
            .args(["--name", "shared", "--duration", "40"])
            .arg(&scene)
            .stderr(std::fs::File::create(dir.join("world.log")).unwrap());
        if let Some(pair) = &network {
            pair.near.enter(&mut world_command);
        }
        let mut world = spawn_ready(world_command, &dir.join("world.notify"));
        // Both daemons at once, so that their hands' scripts run together.
        let places: Vec<(Bus, PathBuf)> = (0..2)
            .map(|k| {
                let at = dir.join(format!("host{k}"));
                std::fs::create_dir_all(&at).unwrap();
                (Bus::start(&at), at)
            })
            .collect();
        let started = Instant::now();
        let daemons: Vec<(&Bus, Hapticd, &PathBuf)> = std::thread::scope(|scope| {
            let starting: Vec<_> = places
                .iter()
                .zip([-0.01, 0.01])
                .map(|((bus, at), z)| {
                    let remote = &remote;
                    scope.spawn(move || {
                        let hand = at.join("hand.yaml");
                        std::fs::write(&hand, pushing_hand(z)).unwrap();
                        let args = [
                            "--sim",
                            "spidar-g",
                            "--hand",
                            hand.to_str().unwrap(),
                            "--scene",
                            remote.to_str().unwrap(),
                        ];
                        (bus, Hapticd::start(bus, &Setup::new(at), &args), at)
                    })
                })
                .collect();
            starting.into_iter().map(|s| s.join().unwrap()).collect()
        });
        let bridges: Vec<Child> = daemons
            .iter()
            .map(|(bus, _, at)| {
                let relay = support::relay::delaying(
                    &upstream,
                    Duration::from_secs_f64(round_trip / 2.0),
                    hosts_side,
                );
                zenoh_bridge(
                    bus,
                    at,
                    &format!("connect: [{relay}]\nworld: shared\n"),
                    None,
                    hosts_side,
                )
                .0
            })
            .collect();
        // Until a second and a half after the pushes end (the scripts' 7 s).
        let seconds = 8.5 - started.elapsed().as_secs_f64();
        assert!(
            seconds > 4.0,
            "the hosts took {:?} to start",
            started.elapsed()
        );
        let views: Vec<HostView> = std::thread::scope(|scope| {
            let followers: Vec<_> = daemons
                .iter()
                .map(|(bus, _, _)| scope.spawn(|| follow_host(&bus.address, seconds)))
                .collect();
            followers.into_iter().map(|f| f.join().unwrap()).collect()
        });
        let status = zenoh_client(
            "print(ask('hapticd/world/shared/status', None)[0])",
            &world_endpoint,
            &[],
            hosts_side,
        );
        let pressing: Vec<f64> = daemons
            .iter()
            .map(|(bus, _, _)| -numbers(&bus.get(DEVICE, "Force"))[0])
            .collect();
        world.kill().ok();
        world.wait().ok();
        let killed = Instant::now();
        let block = &status["bodies"][1];
        let at = |v: &serde_json::Value| {
            DVec3::from_array(std::array::from_fn(|i| v[i].as_f64().unwrap()))
        };
        let (position, mass) = (at(&block["position"]), block["mass"].as_f64().unwrap());
        let peak = status["peak_kinetic_energy"].as_f64().unwrap();
        eprintln!(
            "round trip {:.0} ms over {}: block at {position:.4} ({mass} kg), peak {peak:.2e} J; \
             hosts gave {:.2e} and {:.2e} J, pushed {} and {} ticks, saw the block at {:.4} and \
             {:.4}, proxies at {:.4} and {:.4}",
            round_trip * 1e3,
            if network.is_some() {
                "a veth pair between two network namespaces"
            } else {
                "the loopback"
            },
            views[0].given,
            views[1].given,
            views[0].pushing,
            views[1].pushing,
            views[0].block,
            views[1].block,
            views[0].proxy,
            views[1].proxy,
        );
        assert_eq!(status["hosts"].as_array().unwrap().len(), 2, "{status}");
        assert!((mass - 0.1).abs() < 1e-6, "{mass}");
        // Pushed by both some 3 cm along the floor, and nowhere else.
        assert!((0.015..0.06).contains(&position.x), "{position}");
        assert!(
            position.y.abs() < 0.025 && position.z.abs() < 0.005,
            "{position}"
        );
        // Never flung: the most kinetic energy the block had is that of a block moving at a few
        // times the hands' 1.5 cm/s, not metres a second.
        let bound = 0.5 * mass * 0.1f64.powi(2);
        assert!(peak < bound, "peak {peak} J against {bound} J");
        for view in &views {
            assert!(
                view.pushing > 300,
                "each feels the block: {} ticks",
                view.pushing
            );
            assert!(view.given < 0.005, "the hand got {} J", view.given);
            assert!(
                (view.block - position).length() < 1e-3,
                "a host sees the block at {} where the world has it at {position}",
                view.block
            );
        }
        assert!(
            (views[0].proxy.x - views[1].proxy.x).abs() < 1e-3,
            "both rest on the same face: {} and {}",
            views[0].proxy,
            views[1].proxy
        );
        // The world gone, each host's world goes stale and its force fades out.
        // (Which of the two still presses at the end depends on how far apart the hosts
        // started: the one a little ahead carries the block off the other's finger.)
        assert!(
            pressing.iter().any(|f| *f > 0.05),
            "a finger presses the block: {pressing:?} N"
        );
        for (bus, _, _) in &daemons {
            let client = hapticd_ipc::client::Hapticd::connect(&hapticd_ipc::bus::Bus::Address(
                bus.address.clone(),
            ))
            .unwrap();
            let world = client.devices().unwrap()[0].open_world().unwrap();
            let mut frame = hapticd_core::world_state::WorldFrame::empty();
            while world.read(&mut frame).is_none()
                || DVec3::from(frame.wrenches[0].force).length() > 0.0
            {
                assert!(
                    killed.elapsed() < Duration::from_secs(2),
                    "still {:?} N after the world went",
                    frame.wrenches[0].force
                );
                std::thread::sleep(Duration::from_millis(10));
            }
            eprintln!(
                "the force faded {:?} after the world went",
                killed.elapsed()
            );
        }
        for mut bridge in bridges {
            bridge.kill().ok();
            bridge.wait().ok();
        }
        drop(daemons);
        drop(places);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

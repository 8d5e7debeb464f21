//! Every property and method as the bus and hapticctl see them: the proxies, one daemon per
//! name, pending changes, and a client that never starts a daemon.

use super::*;

#[test]
fn every_property_and_method_answers_as_the_bus_chapter_shows() {
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
    assert_eq!(bus.get(DEVICE, "Identity"), "s \"sim-spidar-g-1\"");
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
        &std::fs::read_to_string(setup.state.join("device-sim-spidar-g-1.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(saved["parameters"]["stiffness"], 3000.0);
    assert_eq!(saved["parameters"]["rate"], 2000.0);
    assert_eq!(saved["calibration"]["offsets"].as_array().unwrap().len(), 8);
    // Every change leaves a trace in the log, with who asked for it.
    let uid = nix::unistd::getuid();
    let log = daemon.log();
    for done in [
        "set Stiffness of sim-spidar-g-1 to 3000".to_string(),
        "set Rate of sim-spidar-g-1 to 2000".to_string(),
        "calibrate sim-spidar-g-1".to_string(),
        "reset the fault of sim-spidar-g-1".to_string(),
        "switch to scene \"static\"".to_string(),
        "reload the configuration and plugins".to_string(),
        "bind sim-spidar-g-1 to mechanism \"spidar-g\"".to_string(),
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
        assert_eq!(device.identity().await.unwrap(), "sim-spidar-g-1");
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
        // What anyone is handed to read is open for reading alone, as docs/bus-api.md says.
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
    let second = support::daemon::command(&setup.config, &bus.address)
        .arg("--mechanism-dir")
        .arg(&setup.mechanisms)
        .args(["--sim", "spidar-g", "--duration", "2"])
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
        said(&out).contains("sim-spidar-g-1: running, spidar-g at 1000 Hz"),
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
        said(&ctl(&["get", "Stiffness", "--device", "sim-spidar-g-1"])),
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
        stderr.contains("no device \"7\": hapticd drives 0 (sim-spidar-g-1)"),
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
        frames
            .lines()
            .filter(|l| l.starts_with("sim-spidar-g-1 "))
            .count(),
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
    assert_eq!(
        complete(&["calibrate", "--device", ""]),
        ["0", "sim-spidar-g-1"]
    );
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
        restarted.contains("sim-spidar-g-1: spidar-ii at 2000 Hz"),
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

//! What the daemon keeps across restarts: saves a kill cannot tear, reloads, damaged or
//! stale state, and the interface files it introspects.

use super::*;

#[test]
fn kill_9_during_saves_leaves_a_whole_file_and_a_restart_restores_it() {
    let dir = support::shared_scratch("dbus", "kill");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let file = setup.state.join("device-sim-spidar-g-1.json");
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
        assert!(
            daemon
                .log()
                .contains("restored the calibration of sim-spidar-g-1")
        );
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
    let file = setup.state.join("device-sim-spidar-g-1.json");
    let aside = setup.state.join("device-sim-spidar-g-1.json.corrupt");
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
    let file = setup.state.join("device-sim-spidar-g-1.json");
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
    let file = setup.state.join("device-sim-spidar-g-1.json");
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

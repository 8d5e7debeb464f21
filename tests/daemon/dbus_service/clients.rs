//! The Python and Rust clients and the shipped examples, and touch events.

use super::*;

/// The Python package (`daemon/python`) against a running daemon: its pytest suite, run by
/// Debian's python3 with jeepney, pytest and numpy (`make deps`), on this test's private bus.
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
    assert!(said.contains("47 passed"), "{said}");
    daemon.stop();
    // With hapticd gone, `connect` says so itself, by type, rather than leaving the first
    // call to fail with the bus's words.
    let gone = "import sys, time, hapticd\n\
                for attempt in range(200):\n\
                \x20   try:\n\
                \x20       with hapticd.connect(sys.argv[1]) as daemon:\n\
                \x20           daemon.version\n\
                \x20   except hapticd.NotRunning as e:\n\
                \x20       print(type(e).__name__, e.name, e.message)\n\
                \x20       break\n\
                \x20   time.sleep(0.05)\n";
    let out = Command::new("/usr/bin/python3")
        .args(["-c", gone, &bus.address])
        .env("PYTHONPATH", &package)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        format!(
            "NotRunning org.hapticd.Hapticd1.Python.NotRunning hapticd is not running on the {} bus",
            bus.address
        ),
        "{out:?}"
    );
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

/// The bus chapter's staircase example (`daemon/python/examples/staircase.py`) on the simulated
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

/// The bus chapter's second example (`daemon/python/examples/push.py`): the world drawn from the
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
    assert_eq!(device.identity().unwrap(), "sim-spidar-g-1");
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
    // A push through the centre of a falling block: in the air, nothing else turns it, so
    // any turn is the push's (a centre read a tick before the push is a fall of a tick
    // behind the body, and that arm turns it).
    let placed = scene
        .set_pose("block", [0.0, 0.3, 0.0], [1.0, 0.0, 0.0, 0.0])
        .unwrap();
    let falling = scene.set_velocity("block", [0.0; 3], [0.0; 3]).unwrap();
    let pushed = scene
        .apply_impulse("block", [0.0, 0.0, 0.1 * placed.mass], None)
        .unwrap();
    assert!(pushed.position[1] > 0.1, "still in the air: {pushed:?}");
    assert!((pushed.velocity[2] - falling.velocity[2] - 0.1).abs() < 1e-9);
    assert_eq!(pushed.spin, [0.0; 3], "through its centre: no turn");
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

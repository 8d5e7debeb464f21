//! State and files the daemon is given or keeps: a state file that is no record, a save that
//! fails, files named on the command line.

use super::*;

#[test]
fn a_state_file_that_is_no_record_is_left_as_it_is_and_the_device_runs_without_it() {
    let _one = ONE_DAEMON.lock().unwrap_or_else(|p| p.into_inner());
    let dir = support::scratch("bad-input", "unusable-state");
    let state = dir.join("state");
    let outside = dir.join("elsewhere.json");
    // A record that would change the stiffness, were it read through the link.
    std::fs::write(&outside, r#"{"parameters": {"stiffness": 3000}}"#).unwrap();
    let file = state.join("device-sim-spidar-g-1.json");
    type Make<'a> = &'a dyn Fn();
    let cases: [(&str, Make, &str); 4] = [
        ("a FIFO", &|| drop(fifo(&file)), "not a regular file"),
        (
            "a link to /dev/zero",
            &|| std::os::unix::fs::symlink("/dev/zero", &file).unwrap(),
            "a link to /dev/zero, outside",
        ),
        (
            "a link out of the state directory",
            &|| std::os::unix::fs::symlink(&outside, &file).unwrap(),
            &format!("a link to {}, outside", outside.display()),
        ),
        (
            "a sparse file of 20 GB",
            &|| {
                let f = std::fs::File::create(&file).unwrap();
                f.set_len(20 << 30).unwrap();
            },
            "21474836480 bytes is more than the 16777216",
        ),
    ];
    let shape = || {
        let meta = std::fs::symlink_metadata(&file).unwrap();
        let target = std::fs::read_link(&file).ok();
        (meta.file_type(), meta.len(), target)
    };
    for (case, make, expected) in cases {
        std::fs::create_dir_all(&state).unwrap();
        make();
        let before = shape();
        let daemon = Served::start(&dir, &["--state-dir", state.to_str().unwrap()]);
        let log = daemon.log();
        assert!(
            log.contains(&format!("{}: error: {expected}", file.display()))
                && log.contains("left as it is"),
            "{case}: {log}"
        );
        assert_eq!(daemon.get("Stiffness"), "d 2000", "{case}: the scene's own");
        // Nothing replaces it: a save is refused, and refused changes nothing.
        let e = daemon.calibrate().unwrap_err();
        assert!(
            e.contains(expected) && e.contains("remove it to save"),
            "{case}: {e}"
        );
        let e = daemon.set("Stiffness", "2500").unwrap_err();
        assert!(e.contains("remove it to save"), "{case}: {e}");
        assert_eq!(daemon.get("Stiffness"), "d 2000", "{case}");
        daemon.stop();
        assert_eq!(shape(), before, "{case}: the file was touched");
        std::fs::remove_dir_all(&state).unwrap();
    }
    assert_eq!(
        std::fs::read_to_string(&outside).unwrap(),
        r#"{"parameters": {"stiffness": 3000}}"#
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A hand that takes the grip 3 cm above its calibration pose and holds it there.
const HAND_UP_3CM: &str = "hands:\n  grip:\n    - hold: { seconds: 0.2 }\n    - move: { to: [0, 0.03, 0], seconds: 0.5 }\n    - hold: { seconds: 600 }\n";

/// Where the grip is, metres.
fn grip(daemon: &Served) -> DVec3 {
    let pose = daemon.numbers("Pose");
    DVec3::new(pose[0], pose[1], pose[2])
}

/// Wait until the grip has been carried up by [`HAND_UP_3CM`].
fn wait_until_up(daemon: &Served) -> DVec3 {
    let started = Instant::now();
    loop {
        let at = grip(daemon);
        if (at.y - 0.03).abs() < 0.003 {
            // Settled: the hand holds it.
            std::thread::sleep(Duration::from_millis(300));
            return grip(daemon);
        }
        assert!(started.elapsed() < Duration::from_secs(10), "grip at {at}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_calibration_or_parameter_that_cannot_be_saved_is_refused_and_not_used() {
    let _one = ONE_DAEMON.lock().unwrap_or_else(|p| p.into_inner());
    let dir = support::scratch("bad-input", "unsaved");
    let hand = dir.join("up.yaml");
    std::fs::write(&hand, HAND_UP_3CM).unwrap();
    let state = dir.join("state");
    let daemon = Served::start(
        &dir,
        &[
            "--state-dir",
            state.to_str().unwrap(),
            "--hand",
            hand.to_str().unwrap(),
        ],
    );
    let up = wait_until_up(&daemon);
    let offsets = daemon.get("CalibrationOffsets");
    // The state directory replaced by a file: as root too, nothing can be written in it.
    std::fs::create_dir_all(&state).unwrap();
    std::fs::remove_dir(&state).unwrap();
    std::fs::write(&state, "not a directory").unwrap();
    let e = daemon.calibrate().unwrap_err();
    assert!(e.contains("cannot create its directory"), "{e}");
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(daemon.get("CalibrationOffsets"), offsets);
    let still = grip(&daemon);
    assert!(
        (still - up).length() < 1e-3,
        "the grip moved from {up} to {still}"
    );
    let e = daemon.set("Stiffness", "2500").unwrap_err();
    assert!(e.contains("cannot create its directory"), "{e}");
    assert_eq!(daemon.get("Stiffness"), "d 2000");
    // Once it can be saved, the calibration is taken here: the grip is at its calibration
    // pose now (as the test could have seen above, had the refused one been used).
    std::fs::remove_file(&state).unwrap();
    daemon.calibrate().unwrap();
    // Within the few millimetres the hand still settles by between measure and use.
    assert!(grip(&daemon).length() < 3e-3, "{}", grip(&daemon));
    assert_ne!(daemon.get("CalibrationOffsets"), offsets);
    let saved = std::fs::read_to_string(state.join("device-sim-spidar-g-1.json")).unwrap();
    assert!(saved.contains("\"offsets\""), "{saved}");
    daemon.stop();

    // Without a state directory a calibration holds for this run, as the start says.
    let daemon = Served::start(&dir, &["--hand", hand.to_str().unwrap()]);
    assert!(
        daemon.log().contains("no state directory"),
        "{}",
        daemon.log()
    );
    wait_until_up(&daemon);
    daemon.calibrate().unwrap();
    assert!(grip(&daemon).length() < 3e-3, "{}", grip(&daemon));
    daemon.stop();
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn files_named_on_the_command_line_are_read_only_if_regular_and_named_when_refused() {
    let dir = support::scratch("bad-input", "named-files");
    let pipe = fifo(&dir.join("pipe.yaml"));
    let pipe_csv = fifo(&dir.join("pipe.csv"));
    let zero = PathBuf::from("/dev/zero");
    let refused = |out: Output, file: &Path, what: &str| {
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{what}: {stderr}");
        let expected = format!("{}: error: not a regular file", file.display());
        assert!(
            stderr.contains(&expected),
            "{what}: {expected:?} not in\n{stderr}"
        );
    };
    for file in [&pipe, &zero] {
        let f = file.to_str().unwrap();
        let hapticctl = |args: &[&str]| {
            let mut command = support::hapticctl();
            command.args(args);
            finished_within(command, 20)
        };
        let out = hapticctl(&["experiment", "push-phase", "--scene", f]);
        refused(out, file, "push-phase --scene");
        let png = dir.join("out.png");
        let out = hapticctl(&["render", f, "--out", png.to_str().unwrap()]);
        refused(out, file, "render");
        let scene = repo_dir().join("config/scenes/cube-drop.yaml");
        let out = hapticctl(&["scene", "run", scene.to_str().unwrap(), "--hand", f]);
        refused(out, file, "scene run --hand");
        let out = hapticctl(&["scene", "run", f]);
        refused(out, file, "scene run");
    }
    // A hand script following a recorded path that is a FIFO.
    let follows = dir.join("follow.yaml");
    std::fs::write(
        &follows,
        format!(
            "hands:\n  grip:\n    - path: {{ file: {} }}\n",
            pipe_csv.display()
        ),
    )
    .unwrap();
    let mut command = support::hapticctl();
    let scene = repo_dir().join("config/scenes/cube-drop.yaml");
    command.args(["scene", "run", scene.to_str().unwrap(), "--hand"]);
    command.arg(&follows);
    refused(
        finished_within(command, 20),
        &pipe_csv,
        "a path step's recording",
    );

    // hapticd: a hand script, a recorded path and a traffic recording, each a FIFO.
    let _one = ONE_DAEMON.lock().unwrap_or_else(|p| p.into_inner());
    let mechanisms = dir.join("mechanisms");
    std::fs::create_dir_all(&mechanisms).unwrap();
    let plugin = plugin_path("hapticd-spidar-g");
    std::fs::copy(&plugin, mechanisms.join(plugin.file_name().unwrap())).unwrap();
    let bus = private_bus(&dir);
    let traffic = fifo(&dir.join("traffic.bin"));
    for (args, file) in [
        (["--hand", pipe.to_str().unwrap()], &pipe),
        (["--hand", follows.to_str().unwrap()], &pipe_csv),
        (["--replay", traffic.to_str().unwrap()], &traffic),
    ] {
        let mut command = hapticd_command(&dir, &mechanisms, &bus.address, &args);
        command.args(["--duration", "0.5"]);
        refused(
            finished_within(command, 20),
            file,
            &format!("hapticd {args:?}"),
        );
    }
    drop(bus);
    std::fs::remove_dir_all(&dir).ok();
}

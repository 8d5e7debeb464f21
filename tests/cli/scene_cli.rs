//! `hapticctl scene run` on the shipped scene files: the real binary stepping the penalty
//! physics headless, checked against the thesis' experiments (5.4.2, 5.4.3).

use crate::support;

use std::process::Output;

use glam::{DVec2, DVec3};
use serde_json::Value;
use support::{hapticctl, repo_dir};

fn run(args: &[&str]) -> Output {
    hapticctl()
        .args(["scene", "run"])
        .args(args)
        .output()
        .expect("hapticctl runs")
}

fn scene(name: &str) -> String {
    repo_dir()
        .join("config/scenes")
        .join(name)
        .display()
        .to_string()
}

/// The final states of the moving bodies, from `--json`.
fn bodies(output: &Output) -> Vec<Value> {
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let report: Value = serde_json::from_slice(&output.stdout).unwrap();
    report["runs"][0]["bodies"].as_array().unwrap().clone()
}

fn vector(value: &Value) -> [f64; 3] {
    let v: Vec<f64> = value
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    [v[0], v[1], v[2]]
}

fn length(v: [f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The result rows of `hapticctl experiment NAME ARGS… --json --plot FILE`, once it has
/// drawn its figure.
fn experiment(name: &str, args: &[&str]) -> Vec<Value> {
    let dir = support::scratch_root().join(format!("hapticd-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("figure.png");
    let output = hapticctl()
        .args(["experiment", name])
        .args(args)
        .args(["--json", "--plot"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        std::fs::read(&png)
            .unwrap()
            .starts_with(b"\x89PNG\r\n\x1a\n")
    );
    std::fs::remove_dir_all(&dir).unwrap();
    let report: Value = serde_json::from_slice(&output.stdout).unwrap();
    report["results"].as_array().unwrap().clone()
}

/// The JSON report of `hapticctl scene run` on shipped scene `file` with shipped hand
/// script `hand` and `args`, once it has succeeded.
fn run_with_hand(file: &str, hand: &str, args: &[&str]) -> Value {
    let hand = repo_dir().join("config/hands").join(hand);
    let scene = scene(file);
    let mut all = vec![scene.as_str(), "--hand", hand.to_str().unwrap(), "--json"];
    all.extend(args);
    let output = run(&all);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).unwrap()
}

/// The exit code of `hapticctl experiment NAME ARGS… --plot FILE`.
fn refused(name: &str, args: &[&str]) -> Option<i32> {
    let png = support::scratch_root().join(format!("hapticd-refused-{}.png", std::process::id()));
    let output = hapticctl()
        .args(["experiment", name])
        .args(args)
        .arg("--plot")
        .arg(&png)
        .output()
        .unwrap();
    output.status.code()
}

#[test]
fn the_dropped_cube_comes_to_rest_flat_on_the_floor_and_is_recorded_and_plotted() {
    let dir = support::scratch_root().join(format!("hapticd-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, png) = (dir.join("drop.csv"), dir.join("drop.png"));
    let output = run(&[
        &scene("cube-drop.yaml"),
        "--duration",
        "2",
        "--record",
        csv.to_str().unwrap(),
        "--plot",
        png.to_str().unwrap(),
        "--quantity",
        "angular-momentum-z",
        "--json",
    ]);
    let cube = &bodies(&output)[0];
    // Flat on a face of 4 m², sunk by m·g/(k·A) = 9.8/4000 m.
    let (height, depth) = (vector(&cube["position"])[1], 9.8 / 4000.0);
    assert!((height - (1.0 - depth)).abs() < 0.01 * depth, "{height}");
    assert!(length(vector(&cube["velocity"])) < 1e-3);
    assert!(length(vector(&cube["angular_momentum"])) < 1e-3);
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(rows.lines().count(), 1 + 200);
    assert!(rows.lines().nth(200).unwrap().starts_with("2,volume,cube,"));
    assert!(
        std::fs::read(&png)
            .unwrap()
            .starts_with(b"\x89PNG\r\n\x1a\n")
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn on_its_deepest_point_alone_the_dropped_cube_keeps_rocking() {
    let cube = &bodies(&run(&[
        &scene("cube-drop.yaml"),
        "--duration",
        "4",
        "--model",
        "point",
        "--json",
    ]))[0];
    assert!(length(vector(&cube["angular_momentum"])) > 1e-2);
}

#[test]
fn a_stack_of_thirteen_blocks_stands_for_ten_seconds() {
    let blocks = bodies(&run(&[&scene("stack.yaml"), "--duration", "10", "--json"]));
    assert_eq!(blocks.len(), 13);
    // Each contact below block n carries 13 − n + 1 blocks of 1 kg on 10⁶ N/m.
    let mut sunk = 0.0;
    for (n, block) in blocks.iter().enumerate() {
        sunk += (13 - n) as f64 * 9.81 / 1e6;
        let [x, y, z] = vector(&block["position"]);
        let expected = 0.05 + 0.1 * n as f64 - sunk;
        assert!(x.hypot(z) < 1e-6, "block {} drifted to {x}, {z}", n + 1);
        assert!(
            (y - expected).abs() < 1e-5,
            "block {}: {y} vs {expected}",
            n + 1
        );
        assert!(length(vector(&block["spin"])) < 1e-6);
    }
}

#[test]
fn a_scene_file_with_an_unknown_key_is_refused_with_its_line_and_column() {
    let dir = support::scratch_root().join(format!("hapticd-bad-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad.yaml");
    let text = std::fs::read_to_string(scene("cube-drop.yaml")).unwrap();
    std::fs::write(&file, text.replacen("dt: 0.01", "dt: 0.01\nspeed: 3", 1)).unwrap();
    let output = run(&[file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1));
    let message = String::from_utf8_lossy(&output.stderr);
    assert!(
        message.starts_with(&format!(
            "{}:8:1: error: speed: unknown key",
            file.display()
        )),
        "{message}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_step_time_experiment_plots_both_contact_models() {
    let rows = experiment("stack-timing", &["--blocks", "1,3", "--samples", "5"]);
    let blocks: Vec<u64> = rows.iter().map(|r| r["blocks"].as_u64().unwrap()).collect();
    assert_eq!(blocks, [1, 3]);
    for r in &rows {
        assert!(r["volume_us"].as_f64().unwrap() > 0.0 && r["point_us"].as_f64().unwrap() > 0.0);
    }
    assert_eq!(refused("stack-timing", &["--blocks", "2.5"]), Some(2));
}

#[test]
fn the_stick_slip_experiment_reaches_the_exact_peaks_and_plots_them() {
    let rows = experiment("stick-slip", &["--duration", "1"]);
    assert_eq!(rows.len(), 2);
    for r in rows {
        let (peak, expected) = (
            r["peak"].as_f64().unwrap(),
            r["expected_peak"].as_f64().unwrap(),
        );
        assert!((peak - expected).abs() < 0.03 * expected, "{r}");
    }
}

#[test]
fn the_incline_experiment_holds_below_the_friction_angle_and_slides_past_it() {
    let rows = experiment("incline", &["--fractions", "0.99,1.01", "--duration", "1"]);
    let moved: Vec<f64> = rows.iter().map(|r| r["moved"].as_f64().unwrap()).collect();
    // Held (the elastic contact gives a fraction of a millimetre), then slid a metre and more.
    assert!(moved[0].abs() < 1e-3 && moved[1] > 0.3, "{moved:?}");
    for bad in ["--fractions=-1", "--duration=0"] {
        assert_eq!(refused("incline", &[bad]), Some(2), "{bad}");
    }
}

/// A held peg put into its hole by the shipped hand script (tilted onto the rim, wobbled,
/// upright, in) through the god-object: with 0.2 mm clearance it reaches the hole's floor
/// 15 mm down, with 0.2 mm interference it stays on the rim; neither solid goes 0.1 mm into
/// the other by their exact formulas, no tick keeps its pose for finding too much, and the
/// most the hand feels is the god-object's 2 000 N/m spring stretched by how far the hand
/// ends past where the peg stops (5 mm past the floor, 20 mm past the rim) and its damper's
/// 5 N·s/m at the hand's 28 mm/s.
#[test]
fn the_peg_in_hole_experiment_inserts_with_clearance_and_stops_at_the_rim_with_interference() {
    let rows = experiment("peg-in-hole", &["--clearances", "0.2,-0.2"]);
    let get = |r: &Value, key: &str| r[key].as_f64().unwrap();
    assert_eq!(rows.len(), 2);
    assert!(
        (get(&rows[0], "reached") - 0.015).abs() < 1e-5,
        "{}",
        rows[0]
    );
    assert!(get(&rows[1], "reached").abs() < 1e-5, "{}", rows[1]);
    for (r, past) in rows.iter().zip([0.005, 0.020]) {
        assert!(get(r, "deepest") <= 1e-4, "{r}");
        assert_eq!(r["held_back"], 0, "{r}");
        let spring = 2000.0 * past + 5.0 * 0.017 / 0.6;
        assert!((get(r, "peak_force") - spring).abs() < 0.05, "{r}");
        assert!(r["tick_us"]["p999"].as_f64().unwrap() > 0.0, "{r}");
        // Leaning on the rim, the torque felt follows the hand's wobble without chattering:
        // the contacts' pushes are solved exactly (measured 0.00029 and 0.00019 N·m a tick
        // on the mean; 0.00064 with Gauss–Seidel sweeps, which crawl over the rim's nearly
        // parallel rows).
        assert!(get(r, "rim_chatter") < 4e-4, "{r}");
    }
    for bad in [
        "--clearances=nan",
        "--clearances=5",
        "--sides=2",
        "--duration=0",
        "--friction=nan",
        "--friction=-1",
    ] {
        assert_eq!(refused("peg-in-hole", &[bad]), Some(2), "{bad}");
    }
    assert_eq!(
        refused("peg-in-hole", &["--hand", "/nonexistent/hand.yaml"]),
        Some(1)
    );
}

/// The shipped peg-in-hole scene run with the shipped hand: the penalty engine's held peg
/// (a mesh against the block's mesh) ends on the hole's floor, the hand 5 mm past it
/// feeling the god-object's spring of that straight up.
#[test]
fn the_shipped_peg_goes_to_the_floor_of_its_hole_in_its_scene() {
    let report = run_with_hand(
        "peg-in-hole.yaml",
        "peg-in-hole.yaml",
        &["--quantity", "pointer-force", "--duration", "2.6"],
    );
    let force: Vec<f64> = report["runs"][0]["pointers"][0]["force"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(
        force[0].abs() < 1e-3 && (force[1] - 10.0).abs() < 1e-2 && force[2].abs() < 1e-3,
        "{force:?}"
    );
}

#[test]
fn the_stick_slip_scene_file_pulls_its_coupled_pointer_to_the_exact_peak() {
    // The rig as a scene: the weight is a pointer on a 400 N/m virtual coupling, the
    // spring's end a scripted grip.
    let report = run_with_hand(
        "stick-slip.yaml",
        "stick-slip-pull.yaml",
        &["--duration", "2"],
    );
    let peak = report["runs"][0]["pointers"][0]["peak_force"]
        .as_f64()
        .unwrap();
    let expected = hapticctl::experiments::stick_slip::Rig::THESIS.peak_pull();
    assert!(
        (peak - expected).abs() < 0.03 * expected,
        "peak {peak} N, rigid-stick value {expected} N"
    );
    // Without a hand there is nothing to hold the pointer.
    let refused = run(&[&scene("stick-slip.yaml"), "--quantity", "pointer-force"]);
    assert!(!refused.status.success());
}

/// Thesis 6.4.3: a finger stirs twelve balls in a walled tray, the world at 10 Hz and the
/// haptics at 1 kHz as hapticd runs them. The balls the finger's path reaches move, none
/// leaves the tray or sinks into the floor (continuous collision detection at 10 Hz), none
/// is thrown faster than the finger moves (one was thrown at 4.6 m/s by the spring of a
/// finger pinned deep against it), and the force felt stays that of the 2 kN/m proxy spring
/// within the width of a ball and the finger together (the scripted finger, unlike a hand,
/// goes where its script says, even into a ball held against another for a period: 58.5 N
/// at most in this run, 29 mm deep, since a ball is no longer thrown out of the way).
///
/// Felt as they move, the balls go as fast as when the same hand stirs the same world
/// stepped at 1 kHz, within 20 % (each ball's fastest, the fastest of all and their mean).
#[test]
fn a_finger_stirs_twelve_balls_at_10_hz_and_none_escapes_or_is_thrown() {
    let hand = repo_dir().join("config/hands/stir-balls.yaml");
    let stir = |file: &str, record: &std::path::Path| {
        run(&[
            file,
            "--hand",
            hand.to_str().unwrap(),
            "--duration",
            "7.5",
            "--record",
            record.to_str().unwrap(),
            "--json",
        ])
    };
    let record = support::scratch_root().join(format!("balls-{}.csv", std::process::id()));
    let output = stir(&scene("balls.yaml"), &record);
    let fast = support::scratch_root().join(format!("balls-1k-{}.yaml", std::process::id()));
    let file = std::fs::read_to_string(scene("balls.yaml")).unwrap();
    assert!(file.contains("\nrate: 10\n"));
    std::fs::write(&fast, file.replace("\nrate: 10\n", "\nrate: 1000\n")).unwrap();
    let reference = support::scratch_root().join(format!("balls-1k-{}.csv", std::process::id()));
    assert!(stir(fast.to_str().unwrap(), &reference).status.success());
    let (slow, quick) = (peak_speeds(&record), peak_speeds(&reference));
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let most = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    for (what, at_10, at_1k) in [
        ("fastest", most(&slow), most(&quick)),
        ("mean of each ball's fastest", mean(&slow), mean(&quick)),
    ] {
        assert!(
            (at_10 / at_1k - 1.0).abs() <= 0.2,
            "{what}: {at_10} m/s at 10 Hz, {at_1k} m/s at 1 kHz"
        );
    }
    std::fs::remove_file(&fast).unwrap();
    std::fs::remove_file(&reference).unwrap();
    let balls = bodies(&output);
    assert_eq!(balls.len(), 12);
    let report: Value = serde_json::from_slice(&output.stdout).unwrap();
    let peak = report["runs"][0]["pointers"][0]["peak_force"]
        .as_f64()
        .unwrap();
    assert!(
        (1.0..2000.0 * (0.024 + 0.010)).contains(&peak),
        "peak force {peak} N"
    );
    for (k, ball) in balls.iter().enumerate() {
        let [x, y, z] = vector(&ball["position"]);
        // Inner faces of the walls at ±0.1 m, the floor's top at −0.03 m; radius 12 mm
        // (rapier's contacts, soft at a 100 ms step, let a ball sink up to a millimetre).
        assert!(
            x.abs() <= 0.1 - 0.0119 && z.abs() <= 0.1 - 0.0119,
            "ball {k}: {x}, {z}"
        );
        assert!((-0.03 + 0.011..0.05).contains(&y), "ball {k}: y = {y}");
        // The finger (5 mm) traces circles of 3 and 6.5 cm about the tray's centre: a ball
        // (12 mm) whose centre is within 14 mm of either is in its way (3 mm to spare).
        let start = DVec2::new(-0.06 + 0.04 * (k / 3) as f64, -0.04 + 0.04 * (k % 3) as f64);
        let in_the_way = [0.03, 0.065]
            .iter()
            .any(|r| (start.length() - r).abs() < 0.005 + 0.012 - 0.003);
        // It is pushed out of the path: at least the 3 mm it overlapped it.
        if in_the_way {
            let moved = DVec2::new(x, z).distance(start);
            assert!(
                moved > 0.003,
                "ball {k} in the finger's way moved {moved} m"
            );
        }
    }
    // The finger's fastest is 2π · 6.5 cm / 3 s = 0.136 m/s; what it pushes may also take up
    // the depth the finger reached while the ball was held. The same stir with the physics
    // at 1 kHz, where no ball is held long, peaked at 0.20 m/s. Speeds are a ball's travel
    // over a physics period (100 ticks): what is recorded each tick is the body as shown,
    // which a new step's state may move by a jump, and rapier's contacts at a 100 ms step
    // leave a resting ball a period's fall of velocity now and then, going nowhere.
    let csv = std::fs::read_to_string(&record).unwrap();
    let mut tracks: std::collections::BTreeMap<&str, Vec<DVec3>> = Default::default();
    for line in csv.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let at: Vec<f64> = cells[3..6].iter().map(|c| c.parse().unwrap()).collect();
        tracks
            .entry(cells[2])
            .or_default()
            .push(DVec3::new(at[0], at[1], at[2]));
    }
    for (ball, track) in &tracks {
        let fastest = track
            .windows(101)
            .map(|w| w[0].distance(w[100]) / 0.1)
            .fold(0.0, f64::max);
        assert!(fastest < 0.20, "{ball} was thrown at {fastest} m/s");
    }
    std::fs::remove_file(&record).unwrap();
}

/// Each body's fastest speed over a `--record`ing, as recorded, in the order of their
/// names.
fn peak_speeds(record: &std::path::Path) -> Vec<f64> {
    let csv = std::fs::read_to_string(record).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let vx = header.iter().position(|h| *h == "vx").unwrap();
    let mut peaks: std::collections::BTreeMap<String, f64> = Default::default();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let v: Vec<f64> = cells[vx..vx + 3]
            .iter()
            .map(|c| c.parse().unwrap())
            .collect();
        let peak = peaks.entry(cells[2].to_string()).or_default();
        *peak = peak.max(DVec3::new(v[0], v[1], v[2]).length());
    }
    peaks.into_values().collect()
}

/// `--feedback` and `--phase` override a rapier scene's file, and only a rapier scene's.
#[test]
fn a_rapier_scene_runs_with_the_feedback_and_phase_asked_for() {
    let hand = repo_dir().join("config/hands/push-once.yaml");
    let hand = hand.to_str().unwrap();
    let moved = |extra: &[&str]| {
        let mut args = vec![scene("push.yaml")];
        args.extend(["--hand", hand, "--duration", "1.5", "--json"].map(String::from));
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        vector(&bodies(&run(&args))[0]["position"])[0] - 0.08
    };
    // The scripted finger is not thrown back as a hand would be: it pushes the block on.
    let impulse = moved(&["--feedback", "impulse"]);
    assert!(impulse > 0.005, "{impulse}");
    assert_eq!(moved(&["--feedback", "impulse", "--phase", "0"]), impulse);
    // The file's own (local dynamics) is not the impulse's.
    assert_ne!(moved(&[]), impulse);
    let by_position = [
        moved(&["--feedback", "position", "--phase", "0.01"]),
        moved(&["--feedback", "position", "--phase", "0.04"]),
    ];
    assert_ne!(
        by_position[0], by_position[1],
        "the sampling phase changed nothing"
    );
    for wrong in [
        vec![scene("cube-drop.yaml"), "--phase".into(), "0.01".into()],
        vec![scene("push.yaml"), "--dt".into(), "0.01".into()],
        vec![scene("push.yaml"), "--feedback".into(), "telepathy".into()],
    ] {
        let args: Vec<&str> = wrong.iter().map(String::as_str).collect();
        let out = run(&args);
        assert_eq!(out.status.code(), Some(2), "{wrong:?}");
    }
}

/// `--frames DIR` draws the run, 30 pictures a second of simulated time: the dropped cube
/// moves from one to the next; and one run only.
#[test]
fn a_run_is_drawn_thirty_frames_a_second() {
    use hapticd_render::picture::Picture;
    let dir = support::scratch_root().join(format!("frames-{}", std::process::id()));
    let output = run(&[
        &scene("cube-drop.yaml"),
        "--duration",
        "0.5",
        "--frames",
        dir.to_str().unwrap(),
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    // Frames at 0, 1/30, …, 15/30 s.
    assert_eq!(names.len(), 16, "{names:?}");
    assert_eq!(names[0], "frame-00000.png");
    let first = Picture::read_png(&dir.join(&names[0])).unwrap();
    let last = Picture::read_png(&dir.join(&names[15])).unwrap();
    assert_eq!((first.width, first.height), (640, 480));
    assert_ne!(first.rgba, last.rgba, "the cube did not move");
    // A rapier run draws each pointer: its proxy solid yellow, the grip faint. The same
    // frame without a hand (the finger touches nothing yet) has fewer yellow pixels.
    let yellow = |hand: bool| {
        let out = dir.join(format!("balls-{hand}"));
        let script = repo_dir().join("config/hands/stir-balls.yaml");
        let mut args = vec![scene("balls.yaml"), "--duration".into(), "0.1".into()];
        if hand {
            args.extend(["--hand".into(), script.display().to_string()]);
        }
        args.extend(["--frames".into(), out.display().to_string()]);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let output = run(&args);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let frame = Picture::read_png(&out.join("frame-00003.png")).unwrap();
        frame
            .rgba
            .chunks(4)
            .filter(|p| p[0] > 150 && f32::from(p[1]) > 0.82 * f32::from(p[0]) && p[2] < 80)
            .count()
    };
    let (with, without) = (yellow(true), yellow(false));
    assert!(
        with > without + 20,
        "{with} yellow pixels with the hand, {without} without"
    );
    let both = run(&[
        &scene("cube-drop.yaml"),
        "--model",
        "volume",
        "--model",
        "point",
        "--frames",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(both.status.code(), Some(2));
    std::fs::remove_dir_all(dir).ok();
}

/// Issue: a grip that starts inside a solid (a scene switched to, a calibration pose inside a
/// body) could only be pushed out through a face. Every shipped scene leaves every shipped
/// device's calibration pose free.
#[test]
fn no_shipped_scene_has_a_solid_at_a_calibration_pose() {
    use hapticd_physics::scene::SceneFile;
    let dir = repo_dir().join("config/scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    files.sort();
    assert!(files.len() >= 9, "{files:?}");
    let mut inside = Vec::new();
    for mechanism in support::shipped_mechanisms() {
        let poses: Vec<_> = mechanism
            .effectors
            .iter()
            .map(|e| e.calibration.position)
            .collect();
        for file in &files {
            let text = std::fs::read_to_string(file).unwrap();
            let bodies = match SceneFile::parse(&text, file, poses.len()) {
                // The held body is the pointer's own solid, where the grip holds it.
                Ok(SceneFile::Rapier(world)) => {
                    let held = world.held.map(|h| h.body as usize);
                    let others = world.bodies.iter().enumerate();
                    others
                        .filter(|(i, _)| Some(*i) != held)
                        .map(|(_, b)| b.clone())
                        .collect()
                }
                Ok(SceneFile::Penalty(scene)) => scene.world.bodies[..scene.first_pointer].to_vec(),
                // A scene made for another number of fingers is not this device's.
                Err(_) => continue,
            };
            for body in &bodies {
                for at in &poses {
                    let local = body.orientation.inverse() * (*at - body.position);
                    // On a surface is touching it, not inside.
                    if body.pieces.iter().any(|p| p.contains(local, -1e-6)) {
                        inside.push(format!(
                            "{}: {} calibrates at {at}, inside a body",
                            file.display(),
                            mechanism.name
                        ));
                    }
                }
            }
        }
    }
    assert!(inside.is_empty(), "{inside:#?}");
}

/// The Stanford bunny (closed, 7 cm and 39 g, from the public corpus) on a rapier floor at
/// 20 Hz under `feedback`, its scene file written in scratch directory `name`: the directory,
/// the scene file, and the bunny's points about its centre of volume, as the poses place them.
fn bunny_scene(name: &str, feedback: &str) -> (std::path::PathBuf, std::path::PathBuf, Vec<DVec3>) {
    let dir = support::dir_with_mesh(name, "tests/corpus/bunny.obj", "bunny.obj");
    let scene = dir.join("bunny.yaml");
    std::fs::write(
        &scene,
        format!(
            "name: bunny\nengine: rapier\nrate: 20\nfeedback: {feedback}\n\
             gravity: [0, -9.81, 0]\nmaterial: {{ static_friction: 0.5, friction: 0.4 }}\n\
             bodies:\n\
             \x20 - {{ name: floor, box: [0.4, 0.02, 0.4], position: [0, -0.04, 0], fixed: true }}\n\
             \x20 - {{ name: bunny, mesh: bunny.obj, scale: 0.00707, position: [0, -0.03, 0], density: 800 }}\n\
             pointer: {{ sphere: 0.005 }}\n"
        ),
    )
    .unwrap();
    let mesh = hapticd_mesh::load(
        &dir.join("bunny.obj"),
        0.00707,
        hapticd_mesh::Limits::DEFAULT,
        None,
    )
    .unwrap();
    let centre = hapticd_mesh::properties::mass_properties(&mesh).centre;
    let points = mesh.vertices.iter().map(|v| *v - centre).collect();
    (dir, scene, points)
}

/// Where the bunny's finger presses it from above (x, z), metres.
const BUNNY_PRESSES: [(f64, f64); 6] = [
    (0.0, 0.005),
    (-0.015, 0.005),
    (0.015, 0.005),
    (0.0, -0.01),
    (-0.02, 0.01),
    (0.02, 0.0),
];

/// The height of the lowest of `points` (about the centre) with the centre at `at`, turned by
/// `turn`.
fn lowest(points: &[DVec3], at: DVec3, turn: glam::DQuat) -> f64 {
    points
        .iter()
        .map(|p| (at + turn * *p).y)
        .fold(f64::INFINITY, f64::min)
}

/// A public model nobody here made (the Stanford bunny, closed, 7 cm and 39 g) on a rapier
/// floor at 20 Hz, pressed 14 mm or more from above at six places by a finger coming down at
/// 0.16 m/s, under impulse feedback: handed back whole, a period's impulse threw it at 28 m/s
/// through the floor. Bounded by how fast the finger pushed, the bunny travels no faster than
/// the finger and what its proxy catches up over a period (0.16 + 0.014/0.05 = 0.44 m/s), and
/// stays on the floor.
#[test]
fn a_public_mesh_pressed_from_above_is_pushed_no_faster_than_the_finger() {
    let (dir, scene, points) = bunny_scene("bunny", "impulse");
    for (x, z) in BUNNY_PRESSES {
        std::fs::write(
            dir.join("press.yaml"),
            format!(
                "hands:\n  grip:\n    - hold: {{ at: [{x}, 0.08, {z}], seconds: 0.2 }}\n\
                 \x20   - move: {{ to: [{x}, 0.0, {z}], seconds: 0.5 }}\n\
                 \x20   - hold: {{ seconds: 1.0 }}\n\
                 \x20   - move: {{ to: [{x}, 0.08, {z}], seconds: 0.3 }}\n"
            ),
        )
        .unwrap();
        let record = dir.join("run.csv");
        let out = run(&[
            scene.to_str().unwrap(),
            "--hand",
            dir.join("press.yaml").to_str().unwrap(),
            "--duration",
            "2",
            "--record",
            record.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let poses: Vec<(DVec3, glam::DQuat)> = std::fs::read_to_string(&record)
            .unwrap()
            .lines()
            .skip(1)
            .map(|line| {
                let c: Vec<f64> = line
                    .split(',')
                    .skip(3)
                    .take(7)
                    .map(|c| c.parse().unwrap())
                    .collect();
                (
                    DVec3::new(c[0], c[1], c[2]),
                    glam::DQuat::from_xyzw(c[4], c[5], c[6], c[3]),
                )
            })
            .collect();
        // A physics period's travel (50 ticks), as the balls' test measures it.
        let fastest = poses
            .windows(51)
            .map(|w| w[0].0.distance(w[50].0) / 0.05)
            .fold(0.0, f64::max);
        assert!(fastest < 0.44, "pressed at ({x}, {z}): {fastest} m/s");
        // The floor is 2 cm thick, its top at y = -0.03. Rapier's contacts, soft at a 50 ms
        // step, let the pressed bunny sink into it for a moment (6.7 mm at most over these
        // presses), never through; once the finger has gone it rests on the top.
        let lowest_at = |(at, turn): &(DVec3, glam::DQuat)| lowest(&points, *at, *turn);
        let deepest = poses
            .iter()
            .step_by(10)
            .map(lowest_at)
            .fold(f64::INFINITY, f64::min);
        assert!(
            deepest > -0.03 - 0.01,
            "pressed at ({x}, {z}): down to y = {deepest}"
        );
        let resting = lowest_at(poses.last().unwrap());
        assert!(
            (resting + 0.03).abs() < 1e-3,
            "pressed at ({x}, {z}): rests at y = {resting}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The same presses under local dynamics, held a second and lifted, stepped as hapticd steps
/// them (`Lockstep`): the world moves the bunny no faster than the finger and what its proxy
/// catches up over a period (0.44 m/s; 0.57 m/s before the bound on every point of a pushed
/// body), what is shown stays within a period's reach of the world (6 cm apart before the
/// physics said which changes it left out), and it comes to rest on the floor.
#[test]
fn a_public_mesh_pressed_under_local_dynamics_moves_no_faster_than_the_finger() {
    use hapticctl::multirate::Lockstep;
    use hapticd_core::kinematics::Wrench;
    let (dir, scene, points) = bunny_scene("bunny-local", "local");
    let text = std::fs::read_to_string(&scene).unwrap();
    let hapticd_physics::scene::SceneFile::Rapier(spec) =
        hapticd_physics::scene::SceneFile::parse(&text, &scene, 1).unwrap()
    else {
        panic!("a rapier scene");
    };
    for (x, z) in BUNNY_PRESSES {
        let above = DVec3::new(x, 0.08, z);
        let mut lockstep = Lockstep::new(
            &spec,
            &Lockstep::pointers(&[(above, DVec3::ZERO)]),
            1000.0,
            0.0,
        );
        let mut felt = [Wrench::ZERO];
        let (mut apart, mut fastest): (f64, f64) = (0.0, 0.0);
        let mut last = lockstep.world.body(1).position;
        for tick in 1..=3000 {
            let t = tick as f64 * 1e-3;
            // Held above, down at 0.16 m/s to y = 0, held a second, lifted in 0.3 s.
            let (y, v) = match t {
                t if t < 0.2 => (0.08, 0.0),
                t if t < 0.7 => (0.08 - 0.16 * (t - 0.2), -0.16),
                t if t < 1.7 => (0.0, 0.0),
                t if t < 2.0 => (0.08 * (t - 1.7) / 0.3, 0.08 / 0.3),
                _ => (0.08, 0.0),
            };
            let grip = DVec3::new(x, y, z);
            lockstep
                .tick(&Lockstep::pointers(&[(grip, DVec3::Y * v)]), &mut felt)
                .unwrap();
            let world = lockstep.world.body(1);
            apart = apart.max(lockstep.body(1).position.distance(world.position));
            if tick % 50 == 0 {
                fastest = fastest.max(world.position.distance(last) / 0.05);
                last = world.position;
            }
        }
        eprintln!("pressed at ({x}, {z}): {fastest:.3} m/s at most, shown {apart:.4} m apart");
        assert!(fastest < 0.44, "pressed at ({x}, {z}): {fastest} m/s");
        // A period at the finger's bound and a period's fall: 0.44 × 0.05 + g × 0.05² / 2.
        assert!(
            apart < 0.034,
            "pressed at ({x}, {z}): shown {apart} m from the world"
        );
        let rest = lockstep.world.body(1);
        let resting = lowest(&points, rest.position, rest.orientation);
        assert!(
            (resting + 0.03).abs() < 1e-3,
            "pressed at ({x}, {z}): rests at y = {resting}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An open public mesh (the Utah teapot: 64 open edges) is a fixed body under rapier, which
/// takes its triangles as they are: a ball dropped on its lid lands on it. As a movable body,
/// or under the penalty engine (which touches through convex pieces), it is refused, and the
/// error says how to make it usable.
#[test]
fn an_open_mesh_is_a_fixed_surface_under_rapier_and_refused_where_a_volume_is_needed() {
    let dir = support::dir_with_mesh("teapot", "tests/corpus/teapot.obj", "teapot.obj");
    // The teapot is 15.75 units tall about its origin: at 3 mm a unit, its bottom on the
    // floor's top (y = -0.03) and its knob at y = 0.0173.
    let scene = |engine: &str, fixed: bool| {
        let path = dir.join(format!("{engine}-{fixed}.yaml"));
        let head = match engine {
            "rapier" => {
                "engine: rapier\nrate: 100\nmaterial: { static_friction: 0.5, friction: 0.4 }\n"
            }
            _ => {
                "dt: 0.0005\nmaterial: { stiffness: 2.0e7, damping: 1.0e4, static_friction: 0.5, friction: 0.4, friction_stiffness: 2.0e7, friction_damping: 1.0e4, slip_speed: 0.02 }\n"
            }
        };
        std::fs::write(
            &path,
            format!(
                "name: teapot\n{head}gravity: [0, -9.81, 0]\nbodies:\n\
                 \x20 - {{ name: floor, box: [0.4, 0.02, 0.4], position: [0, -0.04, 0], fixed: true }}\n\
                 \x20 - {{ name: pot, mesh: teapot.obj, scale: 0.003, position: [0, -0.00637, 0], fixed: {fixed} }}\n\
                 \x20 - {{ name: ball, sphere: 0.005, position: [0, 0.06, 0], density: 1000 }}\n"
            ),
        )
        .unwrap();
        path
    };
    // Falling from 6 cm it meets the knob after 88 ms; at 0.2 s it is rolling off the lid,
    // where falling freely it would have hit the floor.
    let rested = bodies(&run(&[
        scene("rapier", true).to_str().unwrap(),
        "--duration",
        "0.2",
        "--json",
    ]));
    let ball = rested
        .iter()
        .find(|b| b["name"] == "ball")
        .unwrap_or_else(|| panic!("{rested:?}"));
    let [_, y, _] = vector(&ball["position"]);
    assert!(
        (0.0..0.0173 + 0.0051).contains(&y),
        "the ball is at y = {y}"
    );
    for (engine, fixed) in [("rapier", false), ("penalty", true)] {
        let refused = run(&[scene(engine, fixed).to_str().unwrap(), "--duration", "0.1"]);
        assert!(!refused.status.success(), "{engine}, fixed: {fixed}");
        let said = String::from_utf8_lossy(&refused.stderr);
        assert!(
            said.contains("not a closed surface") && said.contains("fixed: true"),
            "{engine}: {said}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The shipped scene of joints run for 2 s with nothing touching it: `--json` reports every
/// joint, the crank turned by its motor at 1 rad/s (2 rad, but for the first step's start)
/// and the rest where the file placed them; `--record` has each joint's coordinate and rate
/// every tick, the crank's rising at its speed.
#[test]
fn the_joints_scene_reports_and_records_each_joint() {
    let record = support::scratch_root().join(format!("joints-{}.csv", std::process::id()));
    let output = run(&[
        &scene("joints.yaml"),
        "--duration",
        "2",
        "--record",
        record.to_str().unwrap(),
        "--json",
    ]);
    bodies(&output);
    let report: Value = serde_json::from_slice(&output.stdout).unwrap();
    let joints = report["runs"][0]["joints"].as_array().unwrap();
    assert_eq!(joints.len(), 12);
    for joint in joints {
        let (name, at) = (
            joint["name"].as_str().unwrap(),
            joint["position"].as_f64().unwrap(),
        );
        let rate = joint["velocity"].as_f64().unwrap();
        if name == "crank" {
            assert!(
                (at - 2.0).abs() < 0.02 && (rate - 1.0).abs() < 1e-3,
                "{joint}"
            );
        } else {
            assert!(at.abs() < 1e-3 && rate.abs() < 1e-3, "{joint}");
        }
    }
    let csv = std::fs::read_to_string(&record).unwrap();
    assert!(
        csv.lines()
            .next()
            .unwrap()
            .ends_with(",joint,position,rate")
    );
    let crank: Vec<(f64, f64)> = csv
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            (cells[16] == "crank").then(|| (cells[0].parse().unwrap(), cells[17].parse().unwrap()))
        })
        .collect();
    assert_eq!(crank.len(), 2000);
    // Shown between physics steps, the crank is where 1 rad/s has it within a step's turn.
    for (t, at) in &crank {
        assert!((at - t).abs() < 1.0 / 60.0 + 0.01, "{at} rad at {t} s");
    }
    std::fs::remove_file(&record).unwrap();
}

/// A soft cube (4 cm, E = 5 kPa, ν = 0, 1 g/cm³) set on a table settles in both engines, and
/// `scene run` reports it as a body with its cut, volume and energies, and records it every
/// tick: its centre sinks ρ·g·h²/(3E) and its volume shrinks by ρ·g·h/(2E), as a column
/// squeezed by its own weight does (ν = 0: no spread for the table's friction to hold).
#[test]
fn a_soft_cube_settles_on_a_table_as_its_weight_squeezes_it_in_both_engines() {
    let (rho, g, h, young) = (1000.0, 9.81, 0.04, 5.0e3);
    let sinks = rho * g * h * h / (3.0 * young);
    let kept = 1.0 - rho * g * h / (2.0 * young);
    let dir = support::scratch_root().join(format!("hapticd-settle-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (engine, head) in [
        (
            "penalty",
            "dt: 0.00025\nmaterial: { stiffness: 2.0e7, damping: 1.0e4, static_friction: 0.4, \
             friction: 0.3, friction_stiffness: 2.0e7, friction_damping: 1.0e4, slip_speed: \
             0.001 }",
        ),
        (
            "rapier",
            "rate: 60\nmaterial: { static_friction: 0.4, friction: 0.3 }",
        ),
    ] {
        let (path, record) = (
            dir.join(format!("{engine}.yaml")),
            dir.join(format!("{engine}.csv")),
        );
        std::fs::write(
            &path,
            format!(
                "name: settle\nengine: {engine}\n{head}\ngravity: [0, -{g}, 0]\nbodies:\n\
                 \x20 - {{ name: table, box: [0.1, 0.02, 0.1], position: [0, -0.01, 0], fixed: true }}\n\
                 \x20 - name: cube\n    box: [{h}, {h}, {h}]\n    position: [0, {}, 0]\n\
                 \x20   density: {rho}\n\
                 \x20   soft: {{ young: {young}, poisson: 0.0, damping: 0.01, resolution: 0.01 }}\n",
                h / 2.0
            ),
        )
        .unwrap();
        let output = run(&[
            path.to_str().unwrap(),
            "--duration",
            "2",
            "--record",
            record.to_str().unwrap(),
            "--json",
        ]);
        let reported = bodies(&output);
        assert_eq!(reported.len(), 1, "{engine}: {reported:?}");
        let (cube, soft) = (&reported[0], &reported[0]["soft"]);
        assert_eq!(cube["name"], "cube");
        // Four lattice cubes a side, six tetrahedra each.
        assert_eq!(soft["nodes"], 125, "{engine}");
        assert_eq!(soft["elements"], 384, "{engine}");
        let volume = soft["volume"].as_f64().unwrap();
        let text =
            String::from_utf8_lossy(&run(&[path.to_str().unwrap(), "--duration", "0.01"]).stdout)
                .into_owned();
        assert!(
            text.contains("soft: 125 nodes, 384 elements"),
            "{engine}: {text}"
        );
        // Its height every tick of the last second, recorded.
        let csv = std::fs::read_to_string(&record).unwrap();
        let heights: Vec<f64> = csv
            .lines()
            .filter_map(|l| {
                let cells: Vec<&str> = l.split(',').collect();
                (cells[2] == "cube" && cells[0].parse::<f64>().unwrap() > 1.0)
                    .then(|| cells[4].parse().unwrap())
            })
            .collect();
        let ticks_a_second = if engine == "penalty" { 4000 } else { 1000 };
        assert!(
            heights.len() >= ticks_a_second,
            "{engine}: {} rows",
            heights.len()
        );
        let sunk = h / 2.0 - heights.iter().sum::<f64>() / heights.len() as f64;
        println!(
            "{engine}: sunk {:.4} mm (ρgh²/3E {:.4} mm), volume {:.5} (1 − ρgh/2E {kept:.5})",
            sunk * 1e3,
            sinks * 1e3,
            volume
        );
        // Measured: 1.2 % (penalty) and 1.4 % (rapier) short, each of the lattice's four
        // layers strained evenly where the stress grows through it; the penalty
        // engine's cube rocks on the table's friction by ±0.035 mm, so its mean is taken.
        assert!((sunk / sinks - 1.0).abs() < 0.03, "{engine}: {sunk} m");
        assert!((volume / kept - 1.0).abs() < 0.005, "{engine}: {volume}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The shipped tray pushed along its table by the simulated fingertip (8 mm, from 6 cm left
/// of the middle to 3 cm, 1 cm above the table): the tray slides on, as far as the finger
/// went past where it first touched (13 mm) less what the proxy's spring holds (about a
/// millimetre), and the jelly held on it goes with it to a tenth of a millimetre, its
/// volume kept.
#[test]
fn the_shipped_tray_carries_its_jelly_where_the_finger_pushes_it() {
    let hand = support::scratch_root().join(format!("push-tray-{}.yaml", std::process::id()));
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - move: { to: [-0.06, 0.0, 0], seconds: 0.2 }\n    - move: { to: \
         [-0.06, -0.0255, 0], seconds: 0.3 }\n    - move: { to: [-0.03, -0.0255, 0], seconds: \
         1.0 }\n    - hold: { seconds: 0.5 }\n",
    )
    .unwrap();
    let moved = bodies(&run(&[
        &scene("tray.yaml"),
        "--hand",
        hand.to_str().unwrap(),
        "--duration",
        "2",
        "--json",
    ]));
    std::fs::remove_file(&hand).unwrap();
    let at = |name: &str| {
        let body = moved.iter().find(|b| b["name"] == name).unwrap();
        (vector(&body["position"]), body["soft"]["volume"].as_f64())
    };
    let ((tray, _), (jelly, volume)) = (at("tray"), at("jelly"));
    println!(
        "tray moved {:.4} mm, jelly {:.4} mm",
        tray[0] * 1e3,
        jelly[0] * 1e3
    );
    assert!((0.010..0.013).contains(&tray[0]), "{tray:?}");
    assert!((tray[1] + 0.0295).abs() < 1e-4, "on the table: {tray:?}");
    assert!((jelly[0] - tray[0]).abs() < 1e-4, "{jelly:?} {tray:?}");
    assert!((volume.unwrap() - 1.0).abs() < 0.005, "{volume:?}");
}

/// The shipped weight (a brass plate of 22 g on the jelly, over three by three of its
/// nodes) comes to rest on the jelly, level, sunk into it by its weight; the simulated
/// fingertip pressing on it from above pushes it further in, and the jelly keeps its
/// volume.
#[test]
fn the_shipped_weight_rests_on_its_jelly_and_sinks_where_the_finger_presses_it() {
    let placed = -0.0129;
    let at_rest = bodies(&run(&[&scene("weight.yaml"), "--duration", "1", "--json"]));
    let weight = at_rest.iter().find(|b| b["name"] == "weight").unwrap();
    let (rest, moving) = (
        vector(&weight["position"]),
        glam::DVec3::from(vector(&weight["velocity"])),
    );
    let hand = support::scratch_root().join(format!("press-weight-{}.yaml", std::process::id()));
    // Down onto its middle, the fingertip's bottom 1 mm below where its top rests.
    let pressed_to = rest[1] + 0.003 + 0.008 - 0.001;
    std::fs::write(
        &hand,
        format!(
            "hands:\n  grip:\n    - move: {{ to: [{x}, 0.01, 0], seconds: 0.2 }}\n    - move: {{ \
             to: [{x}, {pressed_to}, 0], seconds: 0.5 }}\n    - hold: {{ seconds: 0.8 }}\n",
            x = rest[0]
        ),
    )
    .unwrap();
    let pressed = bodies(&run(&[
        &scene("weight.yaml"),
        "--hand",
        hand.to_str().unwrap(),
        "--duration",
        "1.5",
        "--json",
    ]));
    std::fs::remove_file(&hand).unwrap();
    let at = |name: &str| pressed.iter().find(|b| b["name"] == name).unwrap();
    let down = vector(&at("weight")["position"]);
    let volume = at("jelly")["soft"]["volume"].as_f64().unwrap();
    println!(
        "the weight sinks {:.4} mm under itself, {:.4} mm pressed; resting it moves at {:.4} \
         mm/s",
        (placed - rest[1]) * 1e3,
        (placed - down[1]) * 1e3,
        moving.length() * 1e3
    );
    // Its weight, 0.22 N over 4.4 cm²: a few tenths of a millimetre into a jelly of 30 kPa.
    assert!((0.0001..0.001).contains(&(placed - rest[1])), "{rest:?}");
    // Level: turned less than 0.01 rad (its orientation's w first).
    let w = weight["orientation"][0].as_f64().unwrap();
    assert!(w.abs() > 0.005f64.cos(), "{}", weight["orientation"]);
    // At rest, to the jelly's solve (each node within 0.1 mm/s of its tick's solution;
    // measured 0.007 mm/s).
    assert!(moving.length() < 1e-4, "{moving:?}");
    assert!(
        rest[1] - down[1] > 1e-4,
        "pressed {down:?}, resting {rest:?}"
    );
    assert!((volume - 1.0).abs() < 0.005, "{volume}");
}

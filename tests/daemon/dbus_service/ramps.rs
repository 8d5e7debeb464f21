//! Force ramps when scenes switch and bodies appear under a pressing finger.

use super::*;

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
    let (t, fy) = (column("time"), column("force_y"));
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

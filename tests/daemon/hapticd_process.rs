//! `hapticd` as a process on the simulated SPIDAR-G: it runs for a set time, records, stops
//! on SIGTERM with zero currents as the last bytes written, replays a recording exactly,
//! refuses a bad configuration with its place, and its haptic thread makes no system call
//! but its sleep.

use crate::support;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use hapticd_device::replay::{Direction, Recording};
use hapticd_device::sh4;
use support::daemon::Isolated;
use support::{plugin_path, repo_dir, scratch_root, shipped};

/// The plugins staged as an install would have them.
fn mechanisms() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = scratch_root().join(format!("hapticd-process-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for plugin in ["hapticd-spidar-g", "hapticd-spidar-ii"] {
            let from = plugin_path(plugin);
            std::fs::copy(&from, dir.join(from.file_name().unwrap())).unwrap();
        }
        dir
    })
    .clone()
}

fn static_scene() -> PathBuf {
    repo_dir().join("config/scenes/static.yaml")
}

/// A private bus and a configuration of test `name`'s own for its hapticd.
fn on_bus(name: &str) -> Isolated {
    Isolated::on_private_bus(&scratch_file(&format!("{name}.daemon")), &mechanisms())
}

fn hapticd(at: &Isolated, args: &[&str]) -> Command {
    hapticd_with_scene(at, &static_scene(), args)
}

fn hapticd_with_scene(at: &Isolated, scene: &Path, args: &[&str]) -> Command {
    let mut c = at.hapticd(&["--scene", scene.to_str().unwrap()]);
    c.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

/// A file of this process's called `name`, in cargo's scratch directory.
fn scratch_file(name: &str) -> PathBuf {
    scratch_root().join(format!("{}-{name}", std::process::id()))
}

fn press() -> String {
    repo_dir()
        .join("config/hands/press-floor.yaml")
        .display()
        .to_string()
}

/// Run hapticd to the end on the simulated SPIDAR-G on a bus of its own, touching `scene`,
/// with the hand pressing on the floor for `seconds`, recording to `csv`, plus `extra`
/// arguments.
fn pressed(scene: &Path, seconds: &str, csv: &Path, extra: &[&str]) -> Output {
    let hand = press();
    let mut args = vec!["--sim", "spidar-g", "--hand", &hand, "--duration", seconds];
    args.extend(["--record", csv.to_str().unwrap()]);
    args.extend(extra);
    let at = on_bus(csv.file_name().unwrap().to_str().unwrap());
    finish(hapticd_with_scene(&at, scene, &args).spawn().unwrap())
}

fn finish(child: Child) -> Output {
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "hapticd failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The named columns of a recording, row by row.
fn columns(path: &Path, names: &[&str]) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let index: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).unwrap())
        .collect();
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            index.iter().map(|&c| v[c].to_string()).collect()
        })
        .collect()
}

/// CSV rows as (time, grip y, force y).
fn recorded(path: &Path) -> Vec<(f64, f64, f64)> {
    columns(path, &["time", "grip_y", "grip_fy"])
        .iter()
        .map(|r| {
            (
                r[0].parse().unwrap(),
                r[1].parse().unwrap(),
                r[2].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn runs_for_its_duration_and_records_the_grip_held_on_the_floor() {
    let csv = scratch_file("run.csv");
    let out = pressed(&static_scene(), "1.6", &csv, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("motors at zero"), "{stderr}");
    let rows = recorded(&csv);
    assert!(rows.len() > 1400, "{} rows", rows.len());
    // The hand lowers the grip onto the floor (y = −0.03) between 0.5 and 1 s, then presses.
    for &(t, y, fy) in rows.iter().filter(|r| (1.3..1.5).contains(&r.0)) {
        assert!((-0.036..-0.030).contains(&y), "t = {t}: y = {y}");
        assert!(fy > 3.0, "t = {t}: fy = {fy}");
    }
    std::fs::remove_file(csv).ok();
}

#[test]
fn sigterm_while_pushing_leaves_zero_currents_as_the_last_command() {
    let traffic = scratch_file("sigterm.traffic");
    let at = on_bus("sigterm");
    let child = hapticd(
        &at,
        &[
            "--sim",
            "spidar-g",
            "--hand",
            &press(),
            "--record-traffic",
            traffic.to_str().unwrap(),
        ],
    )
    .spawn()
    .unwrap();
    // Wait until the grip presses on the floor (from 1 s on), then ask it to stop.
    std::thread::sleep(Duration::from_millis(1500));
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let started = Instant::now();
    finish(child);
    assert!(started.elapsed() < Duration::from_secs(2), "slow to stop");
    let outs: Vec<[i16; 8]> = Recording::read(&traffic)
        .unwrap()
        .transfers()
        .filter(|(direction, _)| *direction == Direction::Out)
        .map(|(_, bytes)| sh4::Command::decode(bytes).unwrap().dac)
        .collect();
    let pushing = outs[outs.len() - 2];
    assert!(
        pushing.iter().any(|&d| d > 100),
        "not pushing before the signal: {pushing:?}"
    );
    assert_eq!(*outs.last().unwrap(), [0; 8]);
    std::fs::remove_file(traffic).ok();
}

#[test]
fn a_replayed_recording_reproduces_the_session() {
    let (traffic, first, second) = (
        scratch_file("replay.traffic"),
        scratch_file("first.csv"),
        scratch_file("second.csv"),
    );
    pressed(
        &static_scene(),
        "1.2",
        &first,
        &["--record-traffic", traffic.to_str().unwrap()],
    );
    let at = on_bus("replay");
    finish(
        hapticd(
            &at,
            &[
                "--sim",
                "spidar-g",
                "--replay",
                traffic.to_str().unwrap(),
                "--duration",
                "0.8",
                "--record",
                second.to_str().unwrap(),
            ],
        )
        .spawn()
        .unwrap(),
    );
    let (a, b) = (recorded(&first), recorded(&second));
    assert!(b.len() > 700);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x, y);
    }
    for f in [traffic, first, second] {
        std::fs::remove_file(f).ok();
    }
}

#[test]
fn under_systemd_the_journal_gets_no_status_lines() {
    let at = on_bus("journal");
    let run = |journal: bool| {
        let mut command = hapticd(&at, &["--sim", "spidar-g", "--duration", "1.2"]);
        if journal {
            // What systemd sets when the streams go to the journal.
            command.env("JOURNAL_STREAM", "8:12345");
        }
        let out = finish(command.spawn().unwrap());
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.starts_with("t="))
            .count()
    };
    assert!(run(false) >= 2, "a terminal gets the status twice a second");
    assert_eq!(run(true), 0, "the journal got status lines");
}

#[test]
fn a_bad_configuration_is_refused_with_its_place() {
    // Refused before it serves: an address where no bus listens is all it needs.
    let at = Isolated::without_bus(&scratch_file("bad.daemon"), &mechanisms());
    let config = at.config();
    std::fs::write(config, "realtime:\n  rate: 1000\n  speed: 3\n").unwrap();
    let out = hapticd(&at, &["--duration", "0.1"]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains(&format!(
            "{}:3:3: error: realtime.speed: unknown key",
            config.display()
        )),
        "{stderr}"
    );
}

/// CSV rows as (time, state, force y).
fn states(path: &Path) -> Vec<(f64, String, f64)> {
    columns(path, &["time", "state", "grip_fy"])
        .iter()
        .map(|r| (r[0].parse().unwrap(), r[1].clone(), r[2].parse().unwrap()))
        .collect()
}

#[test]
fn a_panicking_scene_plugin_is_disabled_and_the_daemon_lives_on() {
    let csv = scratch_file("panic.csv");
    let scene = plugin_path("hapticd-test-panicking-scene");
    let out = pressed(&scene, "1.4", &csv, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("panicked") && stderr.contains("the floor gave way"),
        "{stderr}"
    );
    let rows = states(&csv);
    // Pressing on the plugin's floor before the panic (its 900th tick)...
    assert!(
        rows.iter()
            .filter(|r| (0.84..0.895).contains(&r.0))
            .all(|r| r.2 > 1.0 && r.1 == "running")
    );
    // ...and zero force within 10 ms of it, for good; the loop keeps running to the end.
    for (t, state, fy) in rows.iter().filter(|r| r.0 >= 0.91) {
        assert_eq!((state.as_str(), *fy), ("fault", 0.0), "t = {t}");
    }
    assert!(rows.last().unwrap().0 > 1.3);
    std::fs::remove_file(csv).ok();
}

#[test]
fn a_multi_rate_scene_that_stops_publishing_fades_out_and_back() {
    let csv = scratch_file("stall.csv");
    let scene = plugin_path("hapticd-test-stalling-scene");
    pressed(&scene, "3", &csv, &[]);
    let rows = states(&csv);
    // The physics (50 Hz) hangs 0.4 s after the grip reaches its floor (at 0.8 s), from about
    // 1.2 s to 2.2 s. Before: the floor pushes back.
    assert!(
        rows.iter()
            .filter(|r| (1.0..1.15).contains(&r.0))
            .all(|r| r.2 > 1.0),
        "no push before the stall"
    );
    // Planes three periods (60 ms) old are stale: from then on no force, until it returns.
    let stalled: Vec<_> = rows.iter().filter(|r| (1.35..2.1).contains(&r.0)).collect();
    assert!(
        stalled.iter().all(|r| r.1 == "fault" && r.2 == 0.0),
        "force during the stall"
    );
    assert!(
        rows.iter()
            .filter(|r| (2.7..2.95).contains(&r.0))
            .all(|r| r.1 == "running" && r.2 > 1.0),
        "no recovery"
    );
    std::fs::remove_file(csv).ok();
}

/// Run the bad-output fixture in `mode` on the simulated SPIDAR-G pressing on its floor for
/// 1.7 s (a loop started late on a loaded machine still runs 0.3 s past the fault); the rows
/// as (time, state, force x, y, z) and hapticd's stderr.
fn bad_output(mode: &str) -> (Vec<(f64, String, [f64; 3])>, String) {
    let file = scratch_file(&format!("{mode}-output.scene"));
    std::fs::write(&file, mode).unwrap();
    let csv = scratch_file(&format!("{mode}-output.csv"));
    let plugin = plugin_path("hapticd-test-bad-output-scene");
    let out = pressed(
        &plugin,
        "1.7",
        &csv,
        &["--scene-file", file.to_str().unwrap()],
    );
    let names = ["time", "state", "grip_fx", "grip_fy", "grip_fz"];
    let rows = columns(&csv, &names)
        .iter()
        .map(|r| {
            let f = |i: usize| r[i].parse::<f64>().unwrap();
            (f(0), r[1].clone(), [f(2), f(3), f(4)])
        })
        .collect();
    std::fs::remove_file(csv).ok();
    std::fs::remove_file(file).ok();
    (rows, String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The fixture's floor pushes back while its output is good (the grip reaches it at 0.8 s;
/// it turns bad 0.2 s later); from 1.1 s to the end the device is in fault with no force,
/// and the log says why, once.
fn faults_for_bad_output(mode: &str, why: &str) {
    let (rows, stderr) = bad_output(mode);
    let pushing = rows.iter().filter(|r| (0.85..0.95).contains(&r.0));
    for (t, state, f) in pushing {
        assert!(
            state == "running" && f[1] > 1.0,
            "{mode}: t = {t}: {state} {f:?}"
        );
    }
    let after: Vec<_> = rows.iter().filter(|r| r.0 >= 1.1).collect();
    assert!(
        after.len() > 250,
        "{mode}: ran on for {} ticks",
        after.len()
    );
    for (t, state, f) in after {
        assert_eq!((state.as_str(), *f), ("fault", [0.0; 3]), "{mode}: t = {t}");
    }
    let said = stderr.matches("scene plugin output refused").count();
    assert!(
        said == 1 && stderr.contains(why),
        "{mode}: {said} times: {stderr}"
    );
    // The device's fault says why too, as the bus's StateReason does.
    let fault = stderr.lines().find(|l| l.contains("device Fault: "));
    assert!(
        fault.is_some_and(|l| l.contains("output was refused (") && l.contains(why)),
        "{mode}: {stderr}"
    );
}

/// Over the bus too: once the fixture's output turns bad, `Device.State` is fault and
/// `StateReason` says what was refused, in the log's words.
#[test]
fn state_reason_says_why_a_device_is_in_fault() {
    let file = scratch_file("reason-output.scene");
    std::fs::write(&file, "nan").unwrap();
    let hand = press();
    let at = on_bus("reason");
    let plugin = plugin_path("hapticd-test-bad-output-scene");
    let args = [
        "--sim",
        "spidar-g",
        "--hand",
        &hand,
        "--duration",
        "4",
        "--scene-file",
        file.to_str().unwrap(),
    ];
    let child = hapticd_with_scene(&at, &plugin, &args).spawn().unwrap();
    let get = |property: &str| {
        let out = Command::new("busctl")
            .arg(format!("--address={}", at.address()))
            .args([
                "get-property",
                "org.hapticd.Hapticd1",
                "/org/hapticd/Hapticd1/device/0",
                "org.hapticd.Hapticd1.Device",
                property,
            ])
            .output()
            .unwrap();
        String::from_utf8_lossy(&out.stdout).trim().to_string()
    };
    let started = std::time::Instant::now();
    let mut reason = String::new();
    while started.elapsed() < std::time::Duration::from_secs(3) {
        if get("State") == "s \"fault\"" {
            reason = get("StateReason");
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    finish(child);
    assert!(
        reason.contains("output was refused (pointer 0: its wrench is not finite)"),
        "{reason:?}"
    );
    std::fs::remove_file(file).ok();
}

#[test]
fn a_direct_scene_whose_wrenches_no_world_gives_is_a_fault_that_says_why() {
    faults_for_bad_output("huge", "pointer 0: a force of 1.000e30 N, beyond 1000 N");
    faults_for_bad_output("alternating", "pointer 0: its force x reversed by 9.0");
    faults_for_bad_output("nan", "pointer 0: its wrench is not finite");
}

#[test]
fn a_multi_rate_scene_whose_planes_no_world_publishes_is_a_fault_that_says_why() {
    faults_for_bad_output("velocity", "plane 0: its surface moves at 1.000e300 m/s");
    faults_for_bad_output("duplicate", "pointer 0: two planes of object 7");
    faults_for_bad_output("normal", "plane 0: its normal is 2.000000 long");
    faults_for_bad_output("point", "plane 0: its point is not finite");
    faults_for_bad_output("count", "pointer 0: 9 planes, more than the 8 allowed");
    faults_for_bad_output("body", "local body 0: it moves at 1.000e300 m/s");
}

/// The simulated SPIDAR-II's two fingers pick up the 1 kg box of the grasp scene (thesis
/// 4.7.1, g = 2 m/s²), hold it 3 cm up, shake it 5 cm to the side eight times, hold it still,
/// and put it down: held, the fingers carry its weight between them by friction; they keep it
/// through the shaking; and still again, they stand as far apart as the grip alone says
/// (4.10).
#[test]
fn two_simulated_fingers_pick_up_shake_and_put_down_a_box() {
    let csv = scratch_file("grasp.csv");
    let scene = plugin_path("hapticd-scene-penalty");
    let file = repo_dir().join("config/scenes/grasp.yaml");
    let hand = repo_dir().join("config/hands/grasp-shake.yaml");
    let at = on_bus("grasp");
    finish(
        hapticd_with_scene(
            &at,
            &scene,
            &["--scene-file", file.to_str().unwrap(), "--sim", "spidar-ii"],
        )
        .arg("--hand")
        .arg(&hand)
        .args(["--duration", "10.5"])
        .arg("--record")
        .arg(&csv)
        .spawn()
        .unwrap(),
    );
    let names = [
        "time", "index_x", "index_y", "index_fx", "index_fy", "thumb_x", "thumb_fx", "thumb_fy",
    ];
    let rows: Vec<Vec<f64>> = columns(&csv, &names)
        .iter()
        .map(|r| r.iter().map(|v| v.parse().unwrap()).collect())
        .collect();
    let during = |from: f64, to: f64| rows.iter().filter(move |r| (from..to).contains(&r[0]));
    let grip = |r: &Vec<f64>| r[3].abs().min(r[6].abs());
    // Lifted and held: 3 cm up (its middle was at y = −0.1), the weight between the fingers
    // (on average: the box still sways a little on its lightly damped inertia spring).
    let held: Vec<_> = during(2.6, 3.0).collect();
    for r in &held {
        assert!((-0.076..-0.07).contains(&r[2]), "t = {}: y {}", r[0], r[2]);
    }
    let weight = -held.iter().map(|r| r[4] + r[7]).sum::<f64>() / held.len() as f64;
    assert!((weight - 2.0).abs() < 0.2, "carrying {weight} N");
    // Shaken: both fingers keep hold of it nearly all the time.
    let shaken: Vec<_> = during(3.0, 7.0).collect();
    let holding = shaken.iter().filter(|r| grip(r) > 0.0).count();
    assert!(
        holding * 100 > 95 * shaken.len(),
        "{holding} of {}",
        shaken.len()
    );
    // Still again: (4.10) with the fingers' 5 mm pointer cubes, l + 1 cm − 2 f_g / k.
    for r in during(8.0, 9.0) {
        let (t, distance) = (r[0], r[1] - r[5]);
        let predicted = 0.07 - 2.0 * grip(r) / 800.0;
        assert!(
            grip(r) > 1.0 && (distance - predicted).abs() < 5e-4,
            "t = {t}: {distance} vs {predicted}"
        );
    }
    // Put down and let go: nothing pulls on the fingers.
    for r in during(10.1, 11.0) {
        assert!(
            r[3] == 0.0 && r[4] == 0.0 && r[6] == 0.0 && r[7] == 0.0,
            "{r:?}"
        );
    }
    std::fs::remove_file(csv).ok();
}

/// The smallest Rust scene plugin (plugins/scene-floor), with a scene file that lowers its
/// floor: the pressing hand rests on the floor where the file puts it.
#[test]
fn the_minimal_rust_scene_plugin_holds_the_hand_on_the_floor_its_file_sets() {
    let csv = scratch_file("floor.csv");
    let file = scratch_file("floor.yaml");
    std::fs::write(&file, "floor_y: -0.035   # half a centimetre lower\n").unwrap();
    let scene = plugin_path("hapticd-scene-floor");
    pressed(
        &scene,
        "1.6",
        &csv,
        &["--scene-file", file.to_str().unwrap()],
    );
    let held: Vec<(f64, f64, f64)> = recorded(&csv)
        .into_iter()
        .filter(|r| (1.3..1.6).contains(&r.0))
        .collect();
    assert!(!held.is_empty());
    for (t, y, fy) in held {
        // The proxy rests on the plane; the spring between it and the grip pushes up.
        assert!(
            (-0.045..-0.035).contains(&y) && fy > 1.0,
            "t = {t}: y {y}, fy {fy}"
        );
    }
    std::fs::remove_file(csv).ok();
}

#[test]
fn the_penalty_scene_holds_the_hand_on_its_table_with_friction() {
    let csv = scratch_file("penalty.csv");
    let scene = plugin_path("hapticd-scene-penalty");
    let blocks = repo_dir().join("config/scenes/blocks.yaml");
    pressed(
        &scene,
        "3",
        &csv,
        &["--scene-file", blocks.to_str().unwrap()],
    );
    let rows: Vec<(f64, f64, f64, f64)> = columns(&csv, &["time", "grip_y", "grip_fx", "grip_fy"])
        .iter()
        .map(|r| {
            (
                r[0].parse().unwrap(),
                r[1].parse().unwrap(),
                r[2].parse().unwrap(),
                r[3].parse().unwrap(),
            )
        })
        .collect();
    // Pressing: the 1 cm pointer rests on the table top (y = −0.03), its centre above it.
    for &(t, y, _, fy) in rows.iter().filter(|r| (1.3..1.5).contains(&r.0)) {
        assert!(
            (-0.031..-0.026).contains(&y) && (4.0..8.0).contains(&fy),
            "t = {t}: y {y}, fy {fy}"
        );
    }
    // Dragged toward −x along the table: friction pushes back toward +x, sticking up to about
    // μ0·N = 3 N and sliding at μ·N = 2.4 N. The grip's spin, differentiated from the strings
    // at each tick, now and then turns the sliding direction under the pointer for a tick.
    let dragged: Vec<f64> = rows
        .iter()
        .filter(|r| (2.6..2.9).contains(&r.0))
        .map(|r| r.2)
        .collect();
    let mean = dragged.iter().sum::<f64>() / dragged.len() as f64;
    let peak = dragged.iter().copied().fold(0.0, f64::max);
    let back = dragged.iter().filter(|f| **f > 0.0).count();
    assert!(
        back * 100 >= dragged.len() * 97 && mean > 1.5,
        "{back} of {} push back, mean friction {mean}",
        dragged.len()
    );
    assert!((2.5..3.3).contains(&peak), "peak friction {peak}");
    std::fs::remove_file(csv).ok();
}

/// Run hapticd to the end on the simulated SPIDAR-G on a bus of test `name`'s own, the rapier
/// plugin stepping `scene_file` while the hand script `hand` moves the grip for `seconds`,
/// recording to `csv`.
fn run_rapier(name: &str, scene_file: &Path, hand: &Path, seconds: &str, csv: &Path) {
    let args = [
        "--sim",
        "spidar-g",
        "--hand",
        hand.to_str().unwrap(),
        "--duration",
        seconds,
        "--record",
        csv.to_str().unwrap(),
        "--scene-file",
        scene_file.to_str().unwrap(),
    ];
    let scene = plugin_path("hapticd-scene-rapier");
    finish(
        hapticd_with_scene(&on_bus(name), &scene, &args)
            .spawn()
            .unwrap(),
    );
}

/// Thesis 6.4.3 through the daemon: the simulated hand stirs the twelve balls of the rapier
/// scene, the world at 10 Hz in the physics thread and the haptics at 1 kHz. The loop runs
/// throughout (never stale, never failed), the balls push back, and no string pulls harder
/// than its limit.
#[test]
fn the_simulated_hand_stirs_the_balls_of_a_rapier_scene() {
    let csv = scratch_file("balls.csv");
    let balls = repo_dir().join("config/scenes/balls.yaml");
    let stir = repo_dir().join("config/hands/stir-balls.yaml");
    run_rapier("balls", &balls, &stir, "7.5", &csv);
    let rows = columns(&csv, &["time", "state", "grip_fx", "grip_fy", "grip_fz"]);
    assert!(rows.len() > 7000, "{} rows", rows.len());
    assert!(rows.iter().all(|r| r[1] == "running"), "the scene faulted");
    let force = |r: &Vec<String>| {
        (2..5)
            .map(|c| r[c].parse::<f64>().unwrap().powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let stirring = rows
        .iter()
        .filter(|r| (1.0..6.5).contains(&r[0].parse::<f64>().unwrap()));
    // Moved with the finger (local dynamics), a 56 g ball pushes back with about what it
    // takes to roll it on: tenths of a newton, not a wall's newtons.
    let pushed = stirring.clone().filter(|r| force(r) > 0.2).count();
    assert!(pushed > 100, "the balls pushed back in {pushed} ticks");
    let limit = shipped("spidar-g")
        .strings
        .iter()
        .map(|s| s.tension_max)
        .fold(0.0, f64::max);
    let tensions: Vec<String> = (0..8).map(|k| format!("tension_{k}")).collect();
    let names: Vec<&str> = tensions.iter().map(String::as_str).collect();
    for row in columns(&csv, &names) {
        for t in row {
            assert!(t.parse::<f64>().unwrap() <= limit + 1e-9, "{t} N");
        }
    }
    std::fs::remove_file(csv).ok();
}

/// A 4 mm plate (x < 0) and a 2 cm floor (x > 0), both with their tops at y = 0.02, felt
/// through the rapier engine at 20 Hz; the calibration pose lies between them.
const PLATES: &str = "name: plates
engine: rapier
rate: 20
material: { static_friction: 0.3, friction: 0.3 }
bodies:
  - { name: plate, box: [0.06, 0.004, 0.06], position: [-0.04, 0.018, 0], fixed: true }
  - { name: floor, box: [0.06, 0.02, 0.06], position: [0.04, 0.01, 0], fixed: true }
pointer:
  sphere: 0.005
";

/// The simulated hand, raised from the calibration pose (between the two) and lowered onto
/// the plate, then onto the floor, its arm aiming `aim` metres below their tops, each time
/// held and drawn back out; the recording as (time, grip x, grip y, force y).
fn press_plates(name: &str, aim: f64) -> Vec<(f64, f64, f64, f64)> {
    let (scene_file, hand, csv) = (
        scratch_file(&format!("{name}.yaml")),
        scratch_file(&format!("{name}-hand.yaml")),
        scratch_file(&format!("{name}.csv")),
    );
    std::fs::write(&scene_file, PLATES).unwrap();
    let low = 0.02 - aim;
    std::fs::write(
        &hand,
        format!(
            "hands:
  grip:
    - hold: {{ at: [0, 0.04, 0], seconds: 0.5 }}
    - move: {{ to: [-0.04, 0.04, 0], seconds: 0.3 }}
    - move: {{ to: [-0.04, {low}, 0], seconds: 1.0 }}
    - hold: {{ seconds: 0.5 }}
    - move: {{ to: [-0.04, 0.04, 0], seconds: 1.0 }}
    - move: {{ to: [0.04, 0.04, 0], seconds: 0.6 }}
    - move: {{ to: [0.04, {low}, 0], seconds: 1.0 }}
    - hold: {{ seconds: 0.5 }}
    - move: {{ to: [0.04, 0.04, 0], seconds: 1.0 }}
    - hold: {{ seconds: 0.3 }}
"
        ),
    )
    .unwrap();
    run_rapier(name, &scene_file, &hand, "6.7", &csv);
    let rows = columns(&csv, &["time", "state", "grip_x", "grip_y", "grip_fy"]);
    assert!(rows.iter().all(|r| r[1] == "running"), "the scene faulted");
    for path in [scene_file, hand, csv] {
        std::fs::remove_file(path).ok();
    }
    rows.iter()
        .map(|r| {
            let v = |k: usize| r[k].parse::<f64>().unwrap();
            (v(0), v(2), v(3), v(4))
        })
        .collect()
}

/// Issue: a finger pressed a little too hard fell through a rapier scene's surfaces and,
/// coming back up inside, was pulled further in. Pressed through a 4 mm plate and deep into
/// a floor (the proxy spring's 20 N and 40 N, twice and four times what the loop displays),
/// the force never points into the surface and keeps holding the finger up, and drawing
/// the finger back out is smooth all the way.
#[test]
fn a_finger_pressed_through_a_plate_or_into_a_floor_in_hapticd_is_held_on_top() {
    // The arm's 300 N/m aims below the surface by the depth plus what holds it there.
    for (name, depth) in [("press20", 0.01), ("press40", 0.02)] {
        let rows = press_plates(name, depth + 0.033);
        let top = 0.02;
        let deepest = rows.iter().map(|r| top - r.2).fold(f64::MIN, f64::max);
        assert!(
            deepest > 0.004 + 0.002,
            "{name}: the grip went only {deepest} m deep: not through the plate"
        );
        for pair in rows.windows(2) {
            let ((t, x, y, f), (_, _, _, g)) = (pair[0], pair[1]);
            // From the calibration pose the hand rises between the two; from 0.8 s it is
            // over them.
            if t < 0.8 {
                continue;
            }
            assert!(f > -0.05, "{name}: t = {t}: {f} N points into the surface");
            if top - y > 0.002 && x.abs() > 0.015 {
                assert!(
                    f > 1.0,
                    "{name}: t = {t} at {y}: the finger is not held ({f} N)"
                );
            }
            assert!(
                (g - f).abs() < 1.0,
                "{name}: t = {t}: {f} → {g} N in a tick"
            );
            if y > top + 0.005 {
                assert!(f.abs() < 0.05, "{name}: t = {t}: {f} N out of contact");
            }
        }
    }
}

#[test]
fn the_haptic_thread_makes_no_system_call_but_its_sleep() {
    // strace sees every system call of every thread; the haptic thread names itself first.
    let (trace, csv, hand) = (
        scratch_file("rt.strace"),
        scratch_file("strace.csv"),
        press(),
    );
    let at = on_bus("strace");
    let daemon = hapticd(
        &at,
        &["--sim", "spidar-g", "--hand", &hand, "--duration", "1.5"],
    );
    let mut strace = Command::new("strace");
    strace
        .args(["-f", "-qq", "-o"])
        .arg(&trace)
        .arg(daemon.get_program())
        .args(daemon.get_args())
        .arg("--record")
        .arg(&csv);
    for (name, value) in daemon.get_envs() {
        match value {
            Some(value) => strace.env(name, value),
            None => strace.env_remove(name),
        };
    }
    let out = strace
        .output()
        .expect("strace is installed (Debian package strace; `make check` installs it)");
    support::succeeded(out);
    let trace = std::fs::read_to_string(&trace).unwrap();
    let thread = trace
        .lines()
        .find(|l| l.contains("PR_SET_NAME, \"hapticd-rt\""))
        .and_then(|l| l.split_whitespace().next())
        .expect("the haptic thread names itself");
    // The thread's calls in order; "<... resumed>" lines only finish a call already counted,
    // and a sleep that the tracer interrupted goes on as `restart_syscall`.
    let calls: Vec<&str> = trace
        .lines()
        .filter_map(|l| l.strip_prefix(thread)?.strip_prefix(' '))
        .map(str::trim_start)
        .filter(|l| !l.starts_with("<...") && !l.starts_with("---") && !l.starts_with("+++"))
        .map(
            |l| match l.contains("resuming interrupted clock_nanosleep") {
                true => "clock_nanosleep",
                false => l.split('(').next().unwrap(),
            },
        )
        .collect();
    let first = calls.iter().position(|c| *c == "clock_nanosleep").unwrap();
    let last = calls.iter().rposition(|c| *c == "clock_nanosleep").unwrap();
    // Between its first sleep and its last, through 1.5 s of pressing on the floor while
    // every frame is recorded: nothing but sleeps (the clock is read through the vDSO).
    let ticking = &calls[first..=last];
    assert!(ticking.len() > 500, "{} sleeps", ticking.len());
    let mut others = std::collections::BTreeMap::new();
    for call in ticking.iter().filter(|c| **c != "clock_nanosleep") {
        *others.entry(*call).or_insert(0) += 1;
    }
    assert!(
        others.is_empty(),
        "the haptic thread called (times): {others:?}"
    );
    std::fs::remove_file(csv).ok();
}

/// The CPUs thread `tid` of process `pid` may run on, and its name.
/// A thread's name, the CPUs it may run on, and its scheduling policy (1: SCHED_FIFO).
fn thread_cpus(pid: u32, tid: &str) -> (String, Vec<usize>, u32) {
    let status = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/status")).unwrap();
    // Field 41 of stat, counted after the parenthesised name (which may hold spaces).
    let stat = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/stat")).unwrap();
    let after_name = &stat[stat.rfind(')').unwrap() + 2..];
    let policy = after_name.split(' ').nth(38).unwrap().parse().unwrap();
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .unwrap()
            .trim()
            .to_string()
    };
    let mut cpus = Vec::new();
    for range in field("Cpus_allowed_list:").split(',') {
        let (a, b) = range.split_once('-').unwrap_or((range, range));
        cpus.extend(a.parse::<usize>().unwrap()..=b.parse::<usize>().unwrap());
    }
    (field("Name:"), cpus, policy)
}

#[test]
fn the_haptic_thread_has_a_cpu_the_daemon_keeps_off() {
    let allowed = hapticd_service::cpus::allowed().unwrap();
    // A multi-rate scene: its physics thread keeps off the haptic CPU too.
    let balls = repo_dir().join("config/scenes/balls.yaml");
    let at = on_bus("cpus");
    let child = hapticd_with_scene(
        &at,
        &plugin_path("hapticd-scene-rapier"),
        &[
            "--sim",
            "spidar-g",
            "--duration",
            "3",
            "--scene-file",
            balls.to_str().unwrap(),
        ],
    )
    .spawn()
    .unwrap();
    let pid = child.id();
    // Once started, list every thread's CPUs.
    let started = std::time::Instant::now();
    let threads = loop {
        let threads: Vec<(String, Vec<usize>, u32)> =
            std::fs::read_dir(format!("/proc/{pid}/task"))
                .unwrap()
                .filter_map(|t| t.ok())
                .map(|t| thread_cpus(pid, &t.file_name().to_string_lossy()))
                .collect();
        let named = |n: &str| threads.iter().any(|t| t.0 == n);
        // The physics thread turns real-time after its first steps: wait for that, a while.
        let physics_fifo = threads.iter().any(|t| t.0 == "hapticd-physics" && t.2 == 1);
        let waited = started.elapsed().as_secs_f64() > 1.5;
        if named("hapticd-rt") && named("hapticd-physics") && (physics_fifo || waited) {
            break threads;
        }
        assert!(started.elapsed().as_secs() < 10, "no haptic thread");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let out = finish(child);
    if allowed.len() < 2 {
        return; // One CPU: nothing to set apart.
    }
    let haptic = *allowed.last().unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    for (name, cpus, policy) in &threads {
        if name == "hapticd-rt" {
            assert_eq!(cpus, &[haptic]);
        } else {
            assert!(!cpus.contains(&haptic), "{name} may run on CPU {haptic}");
        }
        // Where real-time scheduling is allowed, the physics thread has it too, lowest.
        if name == "hapticd-physics" && log.contains("SCHED_FIFO 80") {
            assert_eq!(*policy, 1, "the physics thread is not SCHED_FIFO");
        }
    }
    assert!(
        log.contains(&format!("runs on CPU {haptic} alone")),
        "{log}"
    );
}

/// Every place a test starts hapticd names the bus it serves on: one started without `--bus`
/// serves on the system bus, where the machine's own hapticd makes it refuse to start (and
/// with none there, it takes the name the machine's would). The block around each start
/// must say `--bus`; `support::daemon::Isolated` does, with a configuration of the test's own.
#[test]
fn every_test_starts_hapticd_on_a_bus_of_its_own() {
    let binary = "\"hapticd\"";
    let starts = [format!("artifact({binary})"), format!("run({binary}")];
    let mut unbound = Vec::new();
    for dir in ["tests", "tests/support"] {
        for entry in std::fs::read_dir(repo_dir().join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            for start in &starts {
                for (at, _) in text.match_indices(start.as_str()) {
                    let rest = &text[at + start.len()..];
                    // Where the binary lies, not a run of it.
                    if rest.starts_with(".parent()") || rest.starts_with(".display()") {
                        continue;
                    }
                    // A bus given by hand, or a private bus the function starts for it
                    // (its arguments name it).
                    let function = text[..at].rfind("\nfn ").unwrap_or(0);
                    let block =
                        &text[function..at + start.len() + enclosing_block_rest(rest).len()];
                    if !block.contains("--bus") && !block.contains("private_bus(") {
                        let line = text[..at].lines().count();
                        unbound.push(format!("{}:{line}", path.display()));
                    }
                }
            }
        }
    }
    assert!(
        unbound.is_empty(),
        "hapticd started without --bus (start it through support::daemon::Isolated): {unbound:?}"
    );
}

/// `text` up to the brace that closes the block it starts in.
fn enclosing_block_rest(text: &str) -> &str {
    let mut depth = 0;
    for (i, c) in text.char_indices() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => return &text[..i],
            '}' => depth -= 1,
            _ => {}
        }
    }
    text
}

//! A run's length, its recording, SIGTERM's last bytes, a replay, the journal and a bad
//! configuration.

use super::*;

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

/// A recording is written in the columns of every recording, its ticks numbered without a
/// gap from 0, and a simulated hand can follow it: a second run's grip retraces the first's.
#[test]
fn a_recording_numbers_every_tick_and_a_simulated_hand_retraces_it() {
    let first = scratch_file("retraced.csv");
    pressed(&static_scene(), "1.6", &first, &[]);
    let ticks = columns(&first, &["tick"]);
    assert!(ticks.len() > 1500, "{} rows", ticks.len());
    for (k, tick) in ticks.iter().enumerate() {
        assert_eq!(tick[0], k.to_string(), "row {k}");
    }
    let hand = scratch_file("retrace.yaml");
    std::fs::write(
        &hand,
        format!(
            "hands:\n  grip:\n    - path: {{ file: {} }}\n",
            first.display()
        ),
    )
    .unwrap();
    let second = scratch_file("retracing.csv");
    handled(&static_scene(), &hand, "1.6", &second, &[]);
    let pose = |path: &Path| -> Vec<(f64, glam::DVec3)> {
        columns(path, &["time", "pose_x", "pose_y", "pose_z"])
            .iter()
            .map(|r| {
                let v: Vec<f64> = r.iter().map(|x| x.parse().unwrap()).collect();
                (v[0], glam::DVec3::new(v[1], v[2], v[3]))
            })
            .collect()
    };
    let (was, now) = (pose(&first), pose(&second));
    // The hand reaches the path's first point within its first 0.3 s, then follows it: a
    // mass on springs lags its target by a little, and the floor holds both grips alike.
    let worst = was
        .iter()
        .zip(&now)
        .filter(|(w, _)| (0.3..1.5).contains(&w.0))
        .map(|(w, n)| (w.1 - n.1).length())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.003,
        "the second grip strays {worst} m from the first"
    );
    for file in [first, second, hand] {
        std::fs::remove_file(file).ok();
    }
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

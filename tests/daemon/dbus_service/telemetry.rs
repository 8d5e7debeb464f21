//! Telemetry as clients follow it: the monitor, every tick at 1 and 10 kHz beside many
//! readers, and a hundred clients at once.

use super::*;

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

/// The ticks of 10 s that `hapticctl record` and the Python iterator each read from a daemon
/// at `rate` (every one, in order), while the renderer streams and a hundred clients read
/// properties; and the loop's own overruns ([`own_overruns`]) in those 10 s and in the 10 s
/// just before, with the stream and the clients but without the readers.
struct EveryTick {
    rows: Vec<String>,
    python: String,
    overruns: (f64, f64),
    frames: u64,
    /// The longest time (s) the stream went without a new frame while the clients read.
    stall: f64,
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
    // Everything this test starts from here on keeps off the haptic CPU.
    let _off = support::haptic_cpu::KeptOff::new();
    let _renderer = Renderer::start(&bus, &dir, &[]);
    let overruns = || own_overruns(&bus);
    let realtime = bus.get(DEVICE, "Scheduling").contains("SCHED_FIFO");
    while entry(&bus.get(DEVICE, "Statistics"), "ticks") < 1000.0 {
        std::thread::sleep(Duration::from_millis(50));
    }
    // 10 s of the loop alone (the renderer idle), then 10 s beside the stream, the clients
    // and the readers of every tick.
    let before = overruns();
    std::thread::sleep(Duration::from_secs(10));
    let alone = overruns() - before;
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
    let mut python = Command::new("/usr/bin/python3")
        .args(["-c", follow, &bus.address])
        .env("PYTHONPATH", repo_dir().join("daemon/python"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    // The stream is watched while the clients read: the longest wait for a new frame.
    let (mut last, mut since, mut stall) = (first_frame, std::time::Instant::now(), 0.0f64);
    while python.try_wait().unwrap().is_none() {
        std::thread::sleep(Duration::from_millis(20));
        if ring.latest() != last {
            last = ring.latest();
            since = std::time::Instant::now();
        }
        stall = stall.max(since.elapsed().as_secs_f64());
    }
    let python = python.wait_with_output().unwrap();
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
        stall,
        realtime,
    }
}

/// The longest wait (s) for a frame that still counts as a stream going on while the
/// clients read: 0.72 to 1.11 s measured here over four rounds (19 to 32 frames in 10 s);
/// a stream that stopped waits the whole 10 s.
const STALL: f64 = 3.0;

/// The check: at 1 and 10 kHz, `hapticctl record` and the Python iterator each get
/// every tick of 10 s while the renderer streams and 100 clients read properties, and the
/// loop overruns no more beside all of them than in the 10 s before, alone.
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
                stall,
                realtime,
            } = every_tick(rate);
            let said = format!(
                "{rate} Hz: overruns {alone} alone, {during} beside the readers, the renderer \
                 streaming and 100 clients reading; {frames} frames streamed, at most \
                 {stall:.2} s apart; python: {python}; SCHED_FIFO: {realtime}"
            );
            println!("{said}");
            assert_eq!(python, format!("{ticks} ticks, 0 gaps"), "{said}");
            // The renderer shares the one CPU left to the test's load with the clients and
            // readers, so how many frames it draws is the host's (19 to 45 in 10 s measured):
            // what matters is that the stream goes on.
            assert!(frames > 0 && stall < STALL, "{said}");
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
fn a_hundred_clients_at_once_and_a_telemetry_reader_are_served_without_overruns() {
    // Alone: other tests' daemons and process launches would compete for the same 2 cores.
    let dir = support::shared_scratch("dbus", "hundred");
    let bus = Bus::start_alone(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // The clients, their bus and the reader keep off the haptic CPU, as programs beside
    // hapticd should.
    let _off = support::haptic_cpu::KeptOff::new();
    let overruns = || own_overruns(&bus);
    let realtime = bus.get(DEVICE, "Scheduling").contains("SCHED_FIFO");
    // Statistics lag the loop by up to 0.2 s: count from well after start-up (locking and
    // faulting in memory) has been published.
    while entry(&bus.get(DEVICE, "Statistics"), "ticks") < 1000.0 {
        std::thread::sleep(Duration::from_millis(50));
    }
    // The best of three rounds, each a quiet time beside a burst of clients: on a shared
    // two-core virtual machine the host steals ticks in bursts (from none to dozens in 2.5 s
    // on the same machine and code), while a request path that disturbs the loop costs
    // ticks in every round, one or more for each of the 500 requests.
    let daemon_threads = || {
        std::fs::read_dir(format!("/proc/{}/task", daemon.pid()))
            .unwrap()
            .count()
    };
    let mut rounds = Vec::new();
    for _ in 0..3 {
        let threads = daemon_threads();
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
        // Served by the daemon's own few workers: a thread started for a request would have
        // its stack locked in memory (mlockall's MCL_FUTURE) while the loop runs, and the
        // page faults that takes stall the loop.
        assert_eq!(daemon_threads(), threads, "threads started for the clients");
        std::thread::sleep(Duration::from_millis(300));
        done.store(true, std::sync::atomic::Ordering::Release);
        let (read, missed) = reader.join().unwrap();
        assert!(
            read > 300 && missed == 0,
            "{read} ticks read, {missed} missed"
        );
        let during = overruns() - before;
        let alone = quiet * started.elapsed().as_secs_f64() / 2.5;
        println!("{during} overruns beside the clients, {alone:.1} in as long alone");
        // Measured with the test's load off the haptic CPU: 1 and 2 beside the clients, 0 to
        // 0.9 alone (three runs).
        if !realtime || during <= 5.0 {
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
        &std::fs::read_to_string(setup.state.join("device-sim-spidar-g-1.json")).unwrap(),
    )
    .unwrap();
    let persisted = saved["parameters"]["damping"].as_f64().unwrap();
    assert!(
        same(persisted, damping),
        "{persisted} persisted, {damping} in force"
    );
}

//! Wake-up latency of hapticd's real-time thread against `cyclictest` (Debian rt-tests) at
//! the same rate and priority, on the same machine, one after the other in one run; and with
//! a world of 2000 bodies stepped by rapier at 60 Hz in the physics thread against the static
//! scene (thesis Ch. 6 at scale); and with hapticd-render drawing the blocks scene at 60
//! frames a second (1280 × 720, for a viewer's stream) against no renderer; and with
//! hapticd-zenoh publishing every tick to a Zenoh subscriber against no bridge, in pairs of
//! runs taken alternately (the bridge's share is below this machine's noise in one pair).
//! Then at 10 kHz, the thesis' own rate: hapticd alone, cyclictest, and hapticd with the
//! renderer drawing, the bridge publishing and two telemetry readers recording every tick,
//! their overruns and worst wakes side by side.
//!
//! Run: `make latency` (needs the right to use SCHED_FIFO, e.g. root); `cargo bench -p
//! hapticd-e2e --bench latency -- fast` runs the 10 kHz part alone.

#[path = "../support/mod.rs"]
mod support;

use std::process::Command;

const SECONDS: u32 = 10;
const RATE: u32 = 1000;
/// The thesis' own rate, for textures and transients.
const FAST: u32 = 10_000;
const PRIORITY: u32 = 80;

/// (p50, p99, max) in microseconds.
type Latency = (f64, f64, f64);

/// A run's latency, its overruns, and how many of them woke late (from outside the loop).
type Timing = (Latency, u64, u64);

/// Bodies of the large world, and its physics rate.
const WORLD: (usize, f64) = (2000, 60.0);

/// hapticd's latency with `scene` (and more arguments) at 1 kHz.
fn hapticd(scene: &[&std::ffi::OsStr]) -> Latency {
    hapticd_beside("alone", RATE, scene, |_, _| ()).0
}

/// hapticd's latency and overruns with `scene` (and more arguments) at `rate` Hz, in
/// scratch directory `name` on a private bus of its own (never the host's, nor the host's
/// configuration), with whatever `beside` starts on that bus once hapticd is running kept
/// running until it ends.
fn hapticd_beside<T>(
    name: &str,
    rate: u32,
    scene: &[&std::ffi::OsStr],
    beside: impl FnOnce(&str, &std::path::Path) -> T,
) -> Timing {
    let dir = support::scratch("latency", name);
    let repo = support::repo_dir();
    let bus = support::bus::PrivateBus::with_policies(
        &dir,
        &[
            &repo.join("config/dbus/org.hapticd.Hapticd1.conf"),
            &repo.join("config/dbus/org.hapticd.Renderer1.conf"),
        ],
    );
    let (mechanisms, plugins) = (dir.join("mechanisms"), dir.join("scene-plugins"));
    for (into, krate) in [
        (&mechanisms, "hapticd-spidar-g"),
        (&plugins, "hapticd-scene-penalty"),
    ] {
        std::fs::create_dir_all(into).unwrap();
        let plugin = support::plugin_path(krate);
        std::fs::copy(&plugin, into.join(plugin.file_name().unwrap())).unwrap();
    }
    let config = dir.join("hapticd.yaml");
    std::fs::write(
        &config,
        format!(
            "mechanism_dirs: [{}]\nscene_plugin_dirs: [{}]\n",
            mechanisms.display(),
            plugins.display()
        ),
    )
    .unwrap();
    let child = support::daemon::command(&config, &bus.address)
        .arg("--scene")
        .args(scene)
        .args([
            "--sim",
            "spidar-g",
            "--rate",
            &rate.to_string(),
            "--duration",
            &SECONDS.to_string(),
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("hapticd runs");
    let kept = beside(&bus.address, &dir);
    let out = child.wait_with_output().unwrap();
    drop(kept);
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(
        log.contains("SCHED_FIFO"),
        "hapticd did not get real-time scheduling:\n{log}"
    );
    let line = log
        .lines()
        .find(|l| l.contains("wake latency"))
        .expect("hapticd's final statistics");
    let number = |key: &str| -> f64 {
        let rest = &line[line.find(key).expect(key) + key.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    // "…; N overruns, M of them woken late".
    let counts: Vec<u64> = line[line.rfind(';').expect("the overruns close the line")..]
        .split_whitespace()
        .filter_map(|w| w.trim_matches(',').parse().ok())
        .collect();
    (
        (number("p50"), number("p99"), number("max")),
        counts[0],
        counts[1],
    )
}

/// cyclictest's latency at `rate` Hz.
fn cyclictest(rate: u32) -> Latency {
    let out = Command::new("cyclictest")
        .args(["-q", "-m", "-t", "1", "-h", "2000"])
        .args(["-p", &PRIORITY.to_string()])
        .args(["-i", &(1_000_000 / rate).to_string()])
        .args(["-D", &format!("{SECONDS}s")])
        .output()
        .expect("cyclictest is installed (Debian package rt-tests)");
    let text = String::from_utf8_lossy(&out.stdout);
    let mut histogram = Vec::new();
    let mut max = 0.0;
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("# Max Latencies:") {
            max = rest.trim().parse().unwrap();
        } else if !line.starts_with('#') {
            let mut fields = line.split_whitespace();
            if let (Some(us), Some(count)) = (fields.next(), fields.next()) {
                histogram.push((us.parse::<f64>().unwrap(), count.parse::<u64>().unwrap()));
            }
        }
    }
    let total: u64 = histogram.iter().map(|h| h.1).sum();
    let percentile = |p: f64| {
        let mut seen = 0;
        for &(us, count) in &histogram {
            seen += count;
            if seen as f64 >= p * total as f64 {
                // Same convention as hapticd's histogram: the bucket's upper edge.
                return us + 1.0;
            }
        }
        max
    };
    (percentile(0.5), percentile(0.99), max)
}

/// hapticd with the static scene.
fn static_scene() -> Latency {
    hapticd(&[support::repo_dir()
        .join("config/scenes/static.yaml")
        .as_os_str()])
}

/// hapticd with a pile of boxes and balls on rapier in its physics thread, stirred by the
/// simulated hand so that the bodies never fall asleep.
fn large_world() -> Latency {
    let (n, rate) = WORLD;
    let file = support::scratch_root().join(format!("pile-{n}.yaml"));
    std::fs::write(&file, support::pile::scene(n, rate, 0)).unwrap();
    let plugin = support::plugin_path("hapticd-scene-rapier");
    let stir = support::repo_dir().join("config/hands/stir-balls.yaml");
    hapticd(&[
        plugin.as_os_str(),
        "--scene-file".as_ref(),
        file.as_os_str(),
        "--hand".as_ref(),
        stir.as_os_str(),
    ])
}

/// What runs beside hapticd in the blocks rows.
#[derive(Clone, Copy, PartialEq)]
enum Beside {
    /// Nothing.
    Nothing,
    /// hapticd-render drawing for a viewer at 60 frames a second.
    Drawn,
    /// hapticd-zenoh publishing every tick, and a Zenoh subscriber taking them.
    Bridged,
}

/// hapticd with the blocks scene, with `beside` beside it.
fn blocks(beside: Beside) -> Latency {
    let blocks = support::repo_dir().join("config/scenes/blocks.yaml");
    hapticd_beside(
        &format!("blocks-{}", beside as u8),
        RATE,
        &[blocks.as_os_str()],
        |address, dir| -> Option<Box<dyn std::any::Any>> {
            match beside {
                Beside::Nothing => None,
                Beside::Drawn => Some(Box::new(draw(address))),
                Beside::Bridged => Some(Box::new(bridge(address, dir, RATE))),
            }
        },
    )
    .0
}

/// hapticd with the static scene at [`FAST`] Hz, alone or (`loaded`) with the renderer
/// drawing, the bridge publishing every tick and two readers recording every tick.
fn fast(loaded: bool) -> Timing {
    let scene = support::repo_dir().join("config/scenes/static.yaml");
    hapticd_beside(
        if loaded { "fast-loaded" } else { "fast" },
        FAST,
        &[scene.as_os_str()],
        |address, dir| -> Option<Box<dyn std::any::Any>> {
            loaded.then(|| -> Box<dyn std::any::Any> {
                Box::new((
                    draw(address),
                    bridge(address, dir, FAST),
                    readers(address, dir),
                ))
            })
        },
    )
}

/// Two `hapticctl record`s on `address`, each writing every tick to a CSV file in `dir`.
fn readers(address: &str, dir: &std::path::Path) -> Vec<support::Killed> {
    (0..2)
        .map(|k| {
            support::Killed(
                Command::new(support::artifact("hapticctl"))
                    .args(["record", "--bus", address, "--duration"])
                    .arg((SECONDS - 2).to_string())
                    .arg(dir.join(format!("ticks-{k}.csv")))
                    .stdout(std::process::Stdio::null())
                    .stderr(std::process::Stdio::null())
                    .spawn()
                    .unwrap(),
            )
        })
        .collect()
}

/// hapticd-zenoh on `address` publishing every tick at `rate`, once hapticd is there, and
/// the Zenoh client for Python subscribed to every topic: the two, to stop when done.
fn bridge(address: &str, dir: &std::path::Path, rate: u32) -> (support::Killed, support::Killed) {
    let connection = zbus::block_on(zbus::connection::Builder::address(address).build()).unwrap();
    let dbus = zbus::block_on(zbus::fdo::DBusProxy::new(&connection)).unwrap();
    let started = std::time::Instant::now();
    while !zbus::block_on(dbus.name_has_owner("org.hapticd.Hapticd1".try_into().unwrap()))
        .unwrap_or(false)
    {
        assert!(started.elapsed().as_secs() < 20, "hapticd did not come up");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let (endpoint, _) = support::loopback_endpoint();
    let file = dir.join("network.yaml");
    std::fs::write(&file, format!("listen: [{endpoint}]\nrate: {rate}\n")).unwrap();
    let bridge = support::Killed(
        Command::new(support::artifact("hapticd-zenoh"))
            .arg("--config")
            .arg(&file)
            .arg(format!("--bus={address}"))
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    let subscribe = "import json, sys, time, zenoh\n\
        conf = zenoh.Config()\n\
        conf.insert_json5('mode', '\"client\"')\n\
        conf.insert_json5('connect/endpoints', json.dumps([sys.argv[1]]))\n\
        for attempt in range(50):\n\
        \x20   try:\n\
        \x20       session = zenoh.open(conf)\n\
        \x20       break\n\
        \x20   except Exception:\n\
        \x20       time.sleep(0.1)\n\
        taken = []\n\
        subscriber = session.declare_subscriber('0/hapticd/**', lambda s: taken.append(1))\n\
        time.sleep(3600)\n";
    // Kept off the haptic CPU, as every reader of hapticd's own keeps itself.
    let subscriber = support::Killed(
        support::haptic_cpu::keep_off(&mut Command::new("/usr/bin/python3"))
            .args(["-c", subscribe, &endpoint])
            .env("PYTHONPATH", support::python_package("eclipse-zenoh"))
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    (bridge, subscriber)
}

/// hapticd-render on `address`, drawing 60 frames a second for a stream kept open: the
/// renderer and the viewer's connection, to drop when done.
fn draw(address: &str) -> (support::Killed, zbus::Connection) {
    let connection = zbus::block_on(zbus::connection::Builder::address(address).build()).unwrap();
    let renderer = support::Killed(
        Command::new(support::artifact("hapticd-render"))
            .arg(format!("--bus={address}"))
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    let options = std::collections::HashMap::from([
        ("rate", zbus::Variant::from(60.0)),
        ("width", zbus::Variant::from(1280u32)),
        ("height", zbus::Variant::from(720u32)),
    ]);
    let started = std::time::Instant::now();
    loop {
        let reply = zbus::block_on(connection.call_method(
            Some("org.hapticd.Renderer1"),
            "/org/hapticd/Renderer1",
            Some("org.hapticd.Renderer1"),
            "OpenFrameStream",
            &(&options,),
        ));
        if reply.is_ok() {
            return (renderer, connection);
        }
        assert!(started.elapsed().as_secs() < 20, "no stream: {reply:?}");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// One row of the table: a label and three figures (latencies, or ratios).
fn row(label: &str, (p50, p99, max): Latency, digits: usize) {
    println!("{label:<26}{p50:7.digits$}  {p99:7.digits$}  {max:7.digits$}");
}

/// The ratios of `a` to `b`, figure by figure.
fn ratio(a: Latency, b: Latency) -> Latency {
    (a.0 / b.0, a.1 / b.1, a.2 / b.2)
}

fn main() {
    fast_rounds();
    if std::env::args().any(|a| a == "fast") {
        return;
    }
    println!();
    let ours = static_scene();
    let reference = cyclictest(RATE);
    let world = large_world();
    let (plain, drawn) = (blocks(Beside::Nothing), blocks(Beside::Drawn));
    // The bridge's share is small beside this machine's noise: runs without and with it
    // alternate, and each pair gives a ratio.
    let mut pairs = vec![(plain, blocks(Beside::Bridged))];
    while pairs.len() < BRIDGE_PAIRS {
        pairs.push((blocks(Beside::Nothing), blocks(Beside::Bridged)));
    }
    let bridged = median(pairs.iter().map(|p| p.1).collect());
    let ratios: Vec<Latency> = pairs.iter().map(|(p, b)| ratio(*b, *p)).collect();
    let (n, rate) = WORLD;
    println!("wake latency at {RATE} Hz, SCHED_FIFO {PRIORITY}, {SECONDS} s each (µs):");
    println!("{:<26}    p50      p99      max", "");
    row("hapticd", ours, 1);
    row("cyclictest", reference, 1);
    row("ratio", ratio(ours, reference), 2);
    row(&format!("hapticd, {n} bodies, {rate} Hz"), world, 1);
    row("ratio to the static scene", ratio(world, ours), 2);
    row("hapticd, blocks", plain, 1);
    row("blocks, drawn at 60 fps", drawn, 1);
    row("ratio drawn / not drawn", ratio(drawn, plain), 2);
    row(&format!("blocks, bridged at {RATE} Hz"), bridged, 1);
    for (k, r) in ratios.iter().enumerate() {
        row(&format!("ratio bridged / not, {}", k + 1), *r, 2);
    }
    row(
        &format!("  median of the {BRIDGE_PAIRS}"),
        median(ratios),
        2,
    );
}

/// Rounds of the 10 kHz runs: a shared machine's host stalls its guest in bursts, so one
/// round says little.
const FAST_ROUNDS: usize = 3;

/// At [`FAST`] Hz, rounds of hapticd alone, cyclictest and hapticd beside the renderer, the
/// bridge and two readers, one after the other; each round's figures, and their medians.
fn fast_rounds() {
    println!(
        "at {FAST} Hz, SCHED_FIFO {PRIORITY}, {SECONDS} s each (µs; overruns, and the loop's \
         own: those that did not wake late):"
    );
    println!("{:<30}    p50      p99      max  overruns  own", "");
    let show = |label: &str, (p50, p99, max): Latency, overruns: Option<(u64, u64)>| {
        let overruns = overruns.map_or("-".to_string(), |(all, own)| format!("{all:>8}  {own:>3}"));
        println!("{label:<30}{p50:7.1}  {p99:7.1}  {max:7.1}  {overruns:>8}");
    };
    let counts = |t: &Timing| Some((t.1, t.1 - t.2));
    let mut rounds = Vec::new();
    for k in 1..=FAST_ROUNDS {
        let (alone, reference, loaded) = (fast(false), cyclictest(FAST), fast(true));
        show(&format!("{k}: hapticd alone"), alone.0, counts(&alone));
        show(&format!("{k}: cyclictest"), reference, None);
        show(
            &format!("{k}: drawn, bridged, 2 readers"),
            loaded.0,
            counts(&loaded),
        );
        rounds.push((alone, reference, loaded));
    }
    let overruns = |pick: fn(&(Timing, Latency, Timing)) -> &Timing| {
        let middle = |mut v: Vec<u64>| {
            v.sort_unstable();
            v[v.len() / 2]
        };
        let all = middle(rounds.iter().map(|r| pick(r).1).collect());
        let own = middle(rounds.iter().map(|r| pick(r).1 - pick(r).2).collect());
        Some((all, own))
    };
    let alone = median(rounds.iter().map(|r| r.0.0).collect());
    let reference = median(rounds.iter().map(|r| r.1).collect());
    let loaded = median(rounds.iter().map(|r| r.2.0).collect());
    show("median: hapticd alone", alone, overruns(|r| &r.0));
    show("median: cyclictest", reference, None);
    show("median: loaded", loaded, overruns(|r| &r.2));
    row(
        "median ratio loaded / cyclictest",
        ratio(loaded, reference),
        2,
    );
}

/// Pairs of runs without and with the bridge.
const BRIDGE_PAIRS: usize = 5;

/// The median of each figure of `runs`.
fn median(runs: Vec<Latency>) -> Latency {
    let of = |pick: fn(&Latency) -> f64| {
        let mut v: Vec<f64> = runs.iter().map(pick).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    (of(|l| l.0), of(|l| l.1), of(|l| l.2))
}

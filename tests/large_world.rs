//! A world too large for its rate, in hapticd on the simulated SPIDAR-G: 3 000 boxes at
//! 1 kHz (a step takes tens of milliseconds). Its physics thread must not starve the CPU it
//! shares with the daemon's helpers (an ordinary thread there keeps at least half its rate,
//! the bus answers), the device must not flap between Fault and Running, and the log says
//! once that the world is too large for its rate.
//!
//! Alone in its test binary: no other test of the same run shares the CPUs it measures.

mod support;

use std::fmt::Write as _;
use std::io::{BufRead, BufReader};
use std::process::Stdio;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use support::daemon::Isolated;
use support::{plugin_path, scratch_root};

/// `n` boxes 2 cm across in a lattice 3 cm apart, resting on a floor at `rate` Hz, well
/// behind the grip (z < −0.2 m) so that nothing but their number matters.
fn boxes(n: usize, rate: f64) -> String {
    const SPACING: f64 = 0.03;
    let side = 16;
    let width = side as f64 * SPACING + 0.1;
    let centre_z = -0.25 - width / 2.0;
    let mut text = format!(
        "name: boxes-{n}\nengine: rapier\nrate: {rate}\n\
         material: {{ static_friction: 0.5, friction: 0.5 }}\nbodies:\n  \
         - {{ name: floor, box: [{width:.3}, 0.1, {width:.3}], position: [0, -0.08, \
         {centre_z:.3}], fixed: true }}\n"
    );
    for k in 0..n {
        let (layer, cell) = (k / (side * side), k % (side * side));
        let x = (cell % side) as f64 * SPACING - side as f64 * SPACING / 2.0;
        let z = (cell / side) as f64 * SPACING - side as f64 * SPACING / 2.0 + centre_z;
        let y = -0.02 + layer as f64 * SPACING;
        let _ = writeln!(
            text,
            "  - {{ box: [0.02, 0.02, 0.02], position: [{x:.3}, {y:.3}, {z:.3}], density: 500 }}"
        );
    }
    text.push_str("pointer:\n  sphere: 0.005\n");
    text
}

/// An ordinary thread spinning on one CPU, counting its rounds of work.
struct Busy {
    rounds: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Busy {
    fn on(cpu: usize) -> Self {
        let (rounds, stop) = (
            Arc::new(AtomicU64::new(0)),
            Arc::new(AtomicBool::new(false)),
        );
        let (count, stopped) = (rounds.clone(), stop.clone());
        let thread = std::thread::spawn(move || {
            hapticd_service::cpus::pin(0, &[cpu]).unwrap();
            let mut x = 1u64;
            while !stopped.load(Ordering::Relaxed) {
                for _ in 0..1000 {
                    x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
                }
                count.fetch_add(1, Ordering::Relaxed);
            }
        });
        Self {
            rounds,
            stop,
            thread: Some(thread),
        }
    }

    /// Rounds per second over the next `window`.
    fn rate(&self, window: Duration) -> f64 {
        let (start, before) = (Instant::now(), self.rounds.load(Ordering::Relaxed));
        std::thread::sleep(window);
        let after = self.rounds.load(Ordering::Relaxed);
        (after - before) as f64 / start.elapsed().as_secs_f64()
    }
}

impl Drop for Busy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The largest of `rates`.
fn best(rates: &[f64]) -> f64 {
    rates.iter().copied().fold(0.0, f64::max)
}

/// Seconds `hapticctl status` took to answer on `at`'s bus, or what it said instead.
fn status_seconds(at: &Isolated) -> Result<f64, String> {
    let started = Instant::now();
    let out = support::hapticctl()
        .arg(format!("--bus={}", at.address()))
        .arg("status")
        .output()
        .unwrap();
    match out.status.success() {
        true => Ok(started.elapsed().as_secs_f64()),
        false => Err(String::from_utf8_lossy(&out.stderr).into_owned()),
    }
}

const TOO_LARGE: &str = "the world is too large for its rate";

#[test]
fn a_world_too_large_for_its_rate_leaves_the_machine_usable_and_the_device_steady() {
    let allowed = hapticd_service::cpus::allowed().unwrap();
    if allowed.len() < 2 {
        eprintln!("one CPU: the physics thread has no CPU apart from the haptic one");
        return;
    }
    // The haptic thread takes the last CPU; the physics thread and every helper the others.
    let shared = allowed[0];
    let dir = scratch_root().join(format!("hapticd-large-world-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mechanisms = dir.join("mechanisms");
    std::fs::create_dir_all(&mechanisms).unwrap();
    let spidar_g = plugin_path("hapticd-spidar-g");
    std::fs::copy(&spidar_g, mechanisms.join(spidar_g.file_name().unwrap())).unwrap();
    let scene_file = dir.join("boxes.yaml");
    std::fs::write(&scene_file, boxes(3000, 1000.0)).unwrap();
    let csv = dir.join("run.csv");
    let at = Isolated::on_private_bus(&dir.join("daemon"), &mechanisms);

    let busy = Busy::on(shared);
    let window = Duration::from_millis(700);
    let mut quiet: Vec<f64> = (0..3).map(|_| busy.rate(window)).collect();

    let seconds = 16.0;
    let duration = seconds.to_string();
    let scene = plugin_path("hapticd-scene-rapier");
    let mut daemon = at.hapticd(&[
        "--scene",
        scene.to_str().unwrap(),
        "--scene-file",
        scene_file.to_str().unwrap(),
        "--sim",
        "spidar-g",
        "--duration",
        &duration,
        "--record",
        csv.to_str().unwrap(),
    ]);
    let mut child = daemon
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let log = Arc::new(Mutex::new(String::new()));
    let reader = {
        let (log, stderr) = (log.clone(), child.stderr.take().unwrap());
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let mut log = log.lock().unwrap();
                log.push_str(&line);
                log.push('\n');
            }
        })
    };
    // The world is judged within its first steps; without a judgement (the old code), the
    // rounds below are taken all the same, a while into the run.
    while !log.lock().unwrap().contains(TOO_LARGE) && started.elapsed().as_secs_f64() < 8.0 {
        std::thread::sleep(Duration::from_millis(50));
    }
    let judged = started.elapsed().as_secs_f64();
    std::thread::sleep(Duration::from_millis(500));
    // Rounds that ended with hapticd still running ran beside the world throughout.
    let running = |child: &mut std::process::Child| child.try_wait().unwrap().is_none();
    let mut loaded = Vec::new();
    for _ in 0..5 {
        let rate = busy.rate(window);
        if running(&mut child) {
            loaded.push(rate);
        }
    }
    let mut answers = Vec::new();
    for _ in 0..3 {
        if running(&mut child) {
            answers.push(status_seconds(&at));
        }
    }
    let status = child.wait().unwrap();
    reader.join().unwrap();
    quiet.extend((0..3).map(|_| busy.rate(window)));
    drop(busy);
    let log = log.lock().unwrap().clone();

    // The device's state at every tick: in Fault at most once (until the first planes come),
    // then running at the pace the world keeps, never back and forth.
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = header.iter().position(|h| *h == "state").unwrap();
    let states: Vec<&str> = lines.map(|l| l.split(',').nth(column).unwrap()).collect();
    let changes = states.windows(2).filter(|w| w[0] != w[1]).count();
    let turns: Vec<(usize, &str)> = (1..states.len())
        .filter(|&k| states[k] != states[k - 1])
        .map(|k| (k, states[k]))
        .collect();
    let faults = states
        .windows(2)
        .filter(|w| w[0] != "fault" && w[1] == "fault")
        .count()
        + (states.first() == Some(&"fault")) as usize;
    let share = best(&loaded) / best(&quiet);
    eprintln!(
        "busy thread on CPU {shared}: quiet {quiet:.0?} rounds/s, beside the world {loaded:.0?} \
         rounds/s: {:.0} % (best of each; judged {judged:.1} s in); hapticctl status: {answers:.3?} s; {} ticks, \
         {changes} state changes {turns:?} (tick, new state), {faults} into fault",
        100.0 * share,
        states.len()
    );
    for line in log.lines().filter(|l| l.contains(TOO_LARGE)) {
        eprintln!("{line}");
    }
    assert!(status.success(), "hapticd failed: {log}");
    assert!(
        loaded.len() >= 3 && !answers.is_empty(),
        "hapticd ended before the rounds beside it did"
    );
    assert!(states.len() > 5000, "{} ticks recorded", states.len());
    assert!(
        share >= 0.5,
        "an ordinary thread beside the world kept {:.0} % of its rate",
        100.0 * share
    );
    assert!(
        faults <= 1 && changes <= 2,
        "the device flapped: {changes} changes"
    );
    assert_eq!(states.last(), Some(&"running"), "the world is not rendered");
    assert_eq!(log.matches(TOO_LARGE).count(), 1, "{log}");
    let fault_lines = log.lines().filter(|l| l.contains("device Fault")).count();
    assert!(fault_lines <= 1, "{fault_lines} fault lines: {log}");
    let answered: Result<Vec<f64>, String> = answers.into_iter().collect();
    let fastest = answered.map(|a| a.into_iter().fold(f64::INFINITY, f64::min));
    assert!(
        fastest.as_ref().is_ok_and(|&s| s < 2.0),
        "hapticctl status: {fastest:?}"
    );
    drop(at);
    let _ = std::fs::remove_dir_all(&dir);
}

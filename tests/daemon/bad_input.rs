//! Bad input never reaches the motors: a corpus of hostile files and arguments, each refused
//! with a located, clear message or run safely; and a property test that no accepted
//! mechanism, whatever the scene asks and the counts say, gets a D/A command past its
//! string's `tension_max × volts_per_newton`.

use crate::support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::DVec3;
use hapticd_config::Config;
use hapticd_core::diagnostics::{Diagnostics, Position};
use hapticd_core::haptic_loop::{DeviceState, HapticLoop, LoopCommand, LoopSettings};
use hapticd_core::kinematics::Wrench;
use hapticd_core::mechanism::{Mechanism, descriptor};
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_core::scene::{Pointer, Scene};
use hapticd_core::transport::{
    AMPLIFIER_MAX_VOLTS, CHANNELS, DAC_DIGITS_PER_VOLT, Reading, Transport, TransportError,
};
use hapticd_device::sim::hand::Script;
use hapticd_physics::scene::PenaltyScene;
use hapticd_plugin_api::{HapticdEffector, HapticdString, MechanismSpec};
use support::bus::{NAME, PrivateBus};
use support::{Killed, Rng, artifact, plugin_path, repo_dir};

fn shipped_text(relative: &str) -> String {
    std::fs::read_to_string(repo_dir().join(relative)).unwrap()
}

/// `text` with `from` replaced once; the corpus entry must change the file.
fn mutated(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from:?} is not in the file");
    text.replacen(from, to, 1)
}

/// Every finding of `result` must be located, and one must contain `expected`.
fn assert_refused<T>(result: Result<T, Diagnostics>, expected: &str, case: &str) {
    let Err(e) = result else {
        panic!("{case}: accepted");
    };
    let shown = e.to_string();
    assert!(
        e.diagnostics.iter().all(|d| d.position.is_some()),
        "{case}: an unlocated finding in\n{shown}"
    );
    assert!(
        shown.contains(expected),
        "{case}: {expected:?} not in\n{shown}"
    );
}

#[test]
fn descriptors_absurd_for_the_amplifier_or_the_bus_are_refused_at_their_place() {
    let good = shipped_text("config/mechanisms/spidar-6s.yaml");
    let corpus = [
        (
            "volts_per_newton: 0.3653",
            "volts_per_newton: 1.0e308",
            "volts_per_newton: must be a finite number of size",
        ),
        (
            "tension_max: 20.0",
            "tension_max: 1.0e308",
            "asks the amplifier for",
        ),
        (
            "tension_min: 0.5",
            "tension_min: 1.0e308",
            "exceeds tension_max",
        ),
        // The plausible typo: 100 N of pretension on a 120 N string is 43.8 V.
        (
            "tension_min: 0.5\n    tension_max: 20.0",
            "tension_min: 100\n    tension_max: 120",
            "its current drive cannot be commanded above 24 V",
        ),
        (
            "volts_per_newton: 0.3653",
            "volts_per_newton: 2.0",
            "asks the amplifier for 40.0 V",
        ),
        (
            "metres_per_pulse: 2.924e-5",
            "metres_per_pulse: 1.0e300",
            "metres_per_pulse: must be a finite number of size",
        ),
        (
            "metres_per_pulse: 2.924e-5",
            "metres_per_pulse: 0",
            "metres_per_pulse: must be a finite number of size",
        ),
        (
            "motor: [0.2, 0.2, 0.0]",
            "motor: [1.0e17, 0.2, 0.0]",
            "within ±10 m",
        ),
        (
            "name: spidar-6s",
            "name: \"spidar\\0six\"",
            "is not a usable name",
        ),
        (
            "description: Six-string 6-DOF test mechanism of the thesis (Fig. 3.23 c)",
            "description: \"Six strings\\u0007\"",
            "without control characters",
        ),
        (
            "  - name: grip\n",
            "  - name: \"gr\\0ip\"\n",
            "effector names are at most 31 bytes, without NUL",
        ),
        ("name: spidar-6s", "name: \"\"", "is not a usable name"),
    ];
    for (from, to, expected) in corpus {
        let text = mutated(&good, from, to);
        assert_refused(descriptor::parse(&text, Path::new("m.yaml")), expected, to);
    }
}

#[test]
fn descriptors_others_could_have_written_are_refused_like_plugins() {
    use std::os::unix::fs::PermissionsExt;
    let dir = support::scratch("bad-input", "writable");
    let file = dir.join("spidar-6s.yaml");
    std::fs::write(&file, shipped_text("config/mechanisms/spidar-6s.yaml")).unwrap();
    std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o644)).unwrap();
    assert!(hapticd_config::catalog::load(&file).is_ok());
    std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o666)).unwrap();
    let e = hapticd_config::catalog::load(&file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("writable by group or others (mode 0666)"), "{e}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn physics_scenes_that_cannot_run_safely_are_refused_at_their_place() {
    let blocks = shipped_text("config/scenes/blocks.yaml");
    let drop = shipped_text("config/scenes/cube-drop.yaml");
    let corpus = [
        (
            &blocks,
            "dt: 0.00025",
            "dt: 1.0e-12",
            "dt: must be a number from 1e-6 to 0.1 s",
        ),
        (
            &blocks,
            "gravity: [0, -9.81, 0]",
            "gravity: [.nan, 0, 0]",
            "gravity: must be a finite number",
        ),
        (
            &blocks,
            "gravity: [0, -9.81, 0]",
            "gravity: [0, -1.0e6, 0]",
            "gravity: must be at most",
        ),
        (
            &drop,
            "box: [2, 2, 2]",
            "box: [2, 1.0e-300, 2]",
            "box[1]: must be a number from 0.0001 to 1000 m",
        ),
        (
            &drop,
            "density: 0.125",
            "density: 1.0e308",
            "density: must be a number from 0.001",
        ),
        (
            &drop,
            "position: [0, 2, 0]",
            "position: [1.0e17, 2, 0]",
            "position: must be finite, each within ±1000 m",
        ),
        (
            &drop,
            "position: [0, 2, 0]",
            "position: [0, 2, 0]\n    velocity: [0, -1.0e9, 0]",
            "velocity: must be finite",
        ),
        (
            &drop,
            "stiffness: 1000 ",
            "stiffness: 1.0e10 ",
            "material.stiffness: too stiff",
        ),
        (
            &drop,
            "box: [2, 2, 2]",
            "hull: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1.0e-6]]",
            "thin",
        ),
        (
            &drop,
            "name: cube-drop",
            "name: \"cube\\0drop\"",
            "is not a usable name",
        ),
    ];
    for (good, from, to, expected) in corpus {
        let text = mutated(good, from, to);
        let parsed = PenaltyScene::parse(&text, Path::new("s.yaml"), 0);
        assert_refused(parsed, expected, to);
    }
    // A hull of too many points is refused before its cubic construction starts.
    let points: Vec<String> = (0..1000)
        .map(|k| {
            let a = k as f64 * 0.1;
            format!("[{}, {}, {}]", a.cos(), a.sin(), (k % 7) as f64 * 0.1)
        })
        .collect();
    let text = mutated(
        &drop,
        "box: [2, 2, 2]",
        &format!("hull: [{}]", points.join(", ")),
    );
    assert_refused(
        PenaltyScene::parse(&text, Path::new("s.yaml"), 0),
        "a hull takes at most 64",
        "1000-point hull",
    );
    // Ten thousand bodies: refused before the pair tables are laid out.
    let many: String = (0..10_000)
        .map(|k| {
            format!(
                "  - {{ box: [0.1, 0.1, 0.1], position: [{}, 1, 0] }}\n",
                k as f64 * 0.2
            )
        })
        .collect();
    let text = format!("{}bodies:\n{many}", drop.split("bodies:").next().unwrap());
    assert_refused(
        PenaltyScene::parse(&text, Path::new("s.yaml"), 0),
        "a world holds at most 256",
        "10 000 bodies",
    );
}

#[test]
fn static_scenes_hand_scripts_and_configurations_are_checked_to_their_place() {
    let scene = shipped_text("config/scenes/static.yaml");
    for (from, to, expected) in [
        (
            "stiffness: 2000",
            "stiffness: 1.0e160",
            "Stiffness must be in (0, 100000]",
        ),
        (
            "radius: 0.015",
            "radius: 1.0e-300",
            "radius: must be a number from 0.0001",
        ),
        (
            "name: static",
            "name: \"sta\\0tic\"",
            "is not a usable name",
        ),
        ("height: -0.03", "height: 1.0e17", "within ±1000 m"),
    ] {
        let text = mutated(&scene, from, to);
        assert_refused(
            StaticSceneSpec::parse(&text, Path::new("s.yaml")),
            expected,
            to,
        );
    }
    let hand = shipped_text("config/hands/press-floor.yaml");
    for (from, to, expected) in [
        ("to: [0, -0.05, 0]", "to: [.nan, 0, 0]", "must be finite"),
        (
            "- hold: { seconds: 0.5 }",
            "- trace: { centre: [0, 0, 0], radius: 0.1, normal: [0, 0, 0], period: 0, seconds: 1 }",
            "normal: must not be zero",
        ),
        (
            "- hold: { seconds: 0.5 }",
            "- shake: { amplitude: [0.01, 0, 0], frequency: 1.0e308, seconds: 1 }",
            "frequency: must be a number from 0 to 1000 Hz, not 1e308",
        ),
        (
            "- hold: { seconds: 0.5 }",
            "- hold: { seconds: 0.5, colour: red }",
            "colour: unknown key",
        ),
        (
            "- hold: { seconds: 0.5 }",
            "- push: { force: [0, -1.0e9, 0], seconds: 1 }",
            "within ±1000 N",
        ),
    ] {
        let text = mutated(&hand, from, to);
        assert_refused(Script::parse(&text, Path::new("h.yaml")), expected, to);
    }
    let config = shipped_text("config/hapticd.yaml");
    for (from, to, expected) in [
        (
            "max_force: 10 ",
            "max_force: 500 ",
            "MaxForce must be in (0, 50]",
        ),
        ("rate: 1000 ", "rate: 50 ", "Rate must be in [100, 10000]"),
        ("priority: 80 ", "priority: 0 ", "must be 1–99"),
    ] {
        let text = mutated(&config, from, to);
        assert_refused(Config::parse(&text, Path::new("c.yaml")), expected, to);
    }
    // The rate the bus accepts, the configuration accepts.
    let text = mutated(&config, "rate: 1000 ", "rate: 100 ");
    assert!(Config::parse(&text, Path::new("c.yaml")).is_ok());
}

/// A board whose counts are whatever the test says (changed between ticks).
struct Board(Arc<Mutex<[i64; CHANNELS]>>);

impl Transport for Board {
    fn update(
        &mut self,
        _dac: &[i16; CHANNELS],
        reading: &mut Reading,
    ) -> Result<(), TransportError> {
        reading.counts = *self.0.lock().unwrap();
        Ok(())
    }

    fn reset(&mut self) -> Result<(), TransportError> {
        Ok(())
    }

    fn identity(&self) -> &str {
        "test board"
    }
}

/// A scene that asks for whatever wrench the test sets: huge, infinite, NaN.
struct Asking(Wrench);

impl Scene for Asking {
    fn name(&self) -> &str {
        "asking"
    }

    fn render(&mut self, _pointers: &[Pointer], _dt: f64, wrenches: &mut [Wrench]) -> bool {
        wrenches.fill(self.0);
        true
    }

    fn reset(&mut self, _pointers: &[Pointer]) {}
}

/// A random value spread over many orders of magnitude, `lo` to `hi`.
fn log_uniform(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    (rng.range(lo.ln(), hi.ln())).exp()
}

/// One of `sane` mostly, one of `wild` sometimes: a value spread over orders of magnitude.
fn spread(rng: &mut Rng, sane: (f64, f64), wild: (f64, f64)) -> f64 {
    let (lo, hi) = if rng.range(0.0, 1.0) < 0.8 {
        sane
    } else {
        wild
    };
    log_uniform(rng, lo, hi)
}

/// A random mechanism specification: mostly plausible, often at or past the limits.
fn random_spec(rng: &mut Rng) -> MechanismSpec {
    let six = rng.range(0.0, 1.0) < 0.5;
    let count = (if six { 7 } else { 4 }) + (rng.next_u64() % 2) as usize;
    let effector = HapticdEffector::new("grip", if six { 6 } else { 3 });
    let strings = (0..count)
        .map(|_| {
            let motor = rng.unit() * spread(rng, (0.1, 1.0), (0.01, 20.0));
            let knot = if six { rng.unit() * 0.02 } else { DVec3::ZERO };
            let sign = if rng.range(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
            let tension_max = spread(rng, (1.0, 60.0), (1e-3, 1e6));
            HapticdString {
                effector: 0,
                motor: motor.to_array(),
                knot: knot.to_array(),
                metres_per_pulse: sign * spread(rng, (1e-6, 1e-4), (1e-10, 1.0)),
                volts_per_newton: sign * spread(rng, (0.05, 1.0), (1e-7, 1e4)),
                tension_min: tension_max * rng.range(0.0, 1.05),
                tension_max,
            }
        })
        .collect();
    MechanismSpec {
        lambda: log_uniform(rng, 1e-4, 1.0),
        torque_weight: 1.0,
        effectors: vec![effector],
        strings,
    }
}

#[test]
fn no_accepted_mechanism_gets_a_dac_command_past_its_string_limit() {
    let mut rng = Rng::new(16);
    let hostile = [
        Wrench::force(DVec3::new(0.0, -5.0, 0.0)),
        Wrench::from_array([1e300, -1e300, 1e300, 1e300, 0.0, -1e300]),
        Wrench::from_array([f64::MAX; 6]),
        Wrench::force(DVec3::new(f64::INFINITY, 0.0, 0.0)),
        Wrench::from_array([f64::NAN; 6]),
        Wrench::force(DVec3::new(1e-300, 0.0, 0.0)),
    ];
    let (mut accepted, mut ticks) = (0, 0);
    for case in 0..1000 {
        let spec = random_spec(&mut rng);
        let locate = |_: &str| None::<Position>;
        let Ok(m) = Mechanism::from_spec("random", "", Path::new("random"), &spec, &locate) else {
            continue;
        };
        accepted += 1;
        let limit: Vec<f64> = m
            .strings
            .iter()
            .map(|s| (s.tension_max * s.volts_per_newton.abs()).min(AMPLIFIER_MAX_VOLTS))
            .collect();
        let board = Box::new(Board(Arc::default()));
        let scene = Box::new(Asking(hostile[case % hostile.len()]));
        let Ok(mut haptic) = HapticLoop::new(m.clone(), board, scene, LoopSettings::default())
        else {
            continue;
        };
        for tick in 0..300 {
            match tick % 50 {
                48 => haptic.command(LoopCommand::MeasureOffsets),
                49 => haptic.command(LoopCommand::UseOffsets(haptic.frame().measured)),
                _ => {}
            }
            let frame = *haptic.tick(1e-3);
            ticks += 1;
            for (i, &dac) in frame.dac[..m.strings.len()].iter().enumerate() {
                let volts = f64::from(dac).abs() / DAC_DIGITS_PER_VOLT;
                assert!(
                    volts <= limit[i] + 1e-12,
                    "case {case}, tick {tick}, string {i}: {volts} V past {} V ({:?})",
                    limit[i],
                    m.strings[i]
                );
                assert!(frame.tensions[i] <= m.strings[i].tension_max);
            }
        }
    }
    eprintln!("{accepted} of 1000 random mechanisms accepted, {ticks} hostile ticks checked");
    assert!(
        accepted >= 50,
        "only {accepted} of 1000 random mechanisms were accepted"
    );
    assert!(ticks >= 50 * 300);
}

#[test]
fn counts_that_stop_fitting_any_pose_mid_run_fault_to_zero_force() {
    let m = support::shipped("spidar-g");
    let counts = Arc::new(Mutex::new([0; CHANNELS]));
    let board = Box::new(Board(counts.clone()));
    let calibration = m.effectors[0].calibration.position;
    let scene = Box::new(Asking(Wrench::force(DVec3::new(0.0, -3.0, 0.0))));
    let mut haptic = HapticLoop::new(m, board, scene, LoopSettings::default()).unwrap();
    for _ in 0..500 {
        assert_eq!(haptic.tick(1e-3).state, DeviceState::Running);
    }
    assert!(haptic.frame().dac.iter().any(|&d| d != 0));
    // One encoder jumps by a metre's worth of counts: no pose fits the lengths any more.
    counts.lock().unwrap()[3] += 40_000;
    let mut zero_after = None;
    for tick in 0..20 {
        let frame = *haptic.tick(1e-3);
        assert_eq!(frame.state, DeviceState::Uncalibrated, "tick {tick}");
        if zero_after.is_none() && frame.dac.iter().all(|&d| d == 0) {
            zero_after = Some(tick);
        }
    }
    assert!(zero_after.is_some_and(|t| t <= 6), "{zero_after:?}");
    // Calibrating again (the grip held at its calibration pose) brings the forces back.
    haptic.command(LoopCommand::MeasureOffsets);
    haptic.tick(1e-3);
    haptic.command(LoopCommand::UseOffsets(haptic.frame().measured));
    for _ in 0..300 {
        haptic.tick(1e-3);
    }
    assert_eq!(haptic.frame().state, DeviceState::Running);
    assert!((haptic.frame().poses[0].position - calibration).length() < 1e-6);
}

/// The SPIDAR-G plugin and `extra` descriptors staged as an install would have them.
fn mechanisms(name: &str, extra: &[(&str, &str)]) -> PathBuf {
    let dir = support::scratch("bad-input", name);
    let from = plugin_path("hapticd-spidar-g");
    std::fs::copy(&from, dir.join(from.file_name().unwrap())).unwrap();
    for (file, text) in extra {
        std::fs::write(dir.join(file), text).unwrap();
    }
    dir
}

fn run(program: &str, args: &[&str]) -> Output {
    Command::new(artifact(program))
        .args(args)
        .env_remove("NOTIFY_SOCKET")
        .env_remove("HAPTICD_MECHANISM_PATH")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

/// Refused cleanly: exit status 1 (not a panic's 101), with `expected` said on stderr.
fn assert_exit_1(out: &Output, expected: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(expected), "{expected:?} not in\n{stderr}");
}

#[test]
fn programs_refuse_what_one_board_or_one_tick_cannot_do_without_panicking() {
    // Ten strings on one point grip: a valid mechanism that no single amplifier board drives.
    let motors = [
        [1, 1, 1],
        [1, 1, -1],
        [1, -1, 1],
        [1, -1, -1],
        [-1, 1, 1],
        [-1, 1, -1],
        [-1, -1, 1],
        [-1, -1, -1],
        [0, 1, 0],
        [0, -1, 0],
    ];
    let strings: String = motors
        .iter()
        .map(|[x, y, z]| {
            format!(
                "  - {{ effector: grip, motor: [{}, {}, {}], metres_per_pulse: 2.5e-5, \
                 volts_per_newton: 0.3653, tension_min: 0.5, tension_max: 20 }}\n",
                0.2 * f64::from(*x),
                0.2 * f64::from(*y),
                0.2 * f64::from(*z)
            )
        })
        .collect();
    let ten = format!(
        "name: spidar-10s\nend_effectors:\n  - {{ name: grip, dof: 3 }}\nstrings:\n{strings}"
    );
    let dir = mechanisms("ten", &[("spidar-10s.yaml", &ten)]);
    let dir_arg = dir.to_str().unwrap();
    let scene = repo_dir().join("config/scenes/static.yaml");
    let scene_arg = scene.to_str().unwrap();
    // hapticd on the simulated `mechanism` of `dir`, for a moment, on a bus of its own.
    let isolated = support::daemon::Isolated::on_private_bus(
        &support::scratch("bad-input", "ten-daemon"),
        &dir,
    );
    let simulate = |mechanism: &str, args: &[&str]| {
        let common = ["--sim", mechanism, "--duration", "0.3"];
        isolated
            .hapticd(&[&common[..], args].concat())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .output()
            .unwrap()
    };
    let out = simulate("spidar-10s", &["--scene", scene_arg]);
    assert_exit_1(&out, "one amplifier board drives at most 8");
    let out = run(
        "hapticctl",
        &[
            "--mechanism-dir",
            dir_arg,
            "experiment",
            "stiffness",
            "spidar-10s",
            "--rates",
            "1000",
            "--plot",
            dir.join("stiffness.png").to_str().unwrap(),
        ],
    );
    assert_exit_1(&out, "one amplifier board drives at most 8");

    // A penalty scene whose step makes a tick take far longer than the tick.
    let slow = mutated(
        &shipped_text("config/scenes/blocks.yaml"),
        "dt: 0.00025",
        "dt: 2.0e-6",
    );
    let slow_file = dir.join("slow.yaml");
    std::fs::write(&slow_file, slow).unwrap();
    let plugin = dir.join("libhapticd_scene_penalty.so");
    std::fs::copy(plugin_path("hapticd-scene-penalty"), &plugin).unwrap();
    let out = simulate(
        "spidar-g",
        &[
            "--scene",
            plugin.to_str().unwrap(),
            "--scene-file",
            slow_file.to_str().unwrap(),
        ],
    );
    assert_exit_1(
        &out,
        "to compute a tick, more than half of the 1000 µs tick",
    );

    // A hand script with a NaN target, refused at its place before anything runs.
    let hand = mutated(
        &shipped_text("config/hands/press-floor.yaml"),
        "to: [0, -0.05, 0]",
        "to: [.nan, 0, 0]",
    );
    let hand_file = dir.join("nan-hand.yaml");
    std::fs::write(&hand_file, hand).unwrap();
    let out = simulate(
        "spidar-g",
        &["--scene", scene_arg, "--hand", hand_file.to_str().unwrap()],
    );
    assert_exit_1(
        &out,
        &format!(
            "{}:6:19: error: hands.grip[1].move.to: must be finite",
            hand_file.display()
        ),
    );

    // A material too stiff for its step never runs to NaN with success.
    let stiff = mutated(
        &shipped_text("config/scenes/cube-drop.yaml"),
        "stiffness: 1000 ",
        "stiffness: 1.0e10 ",
    );
    let stiff_file = dir.join("stiff.yaml");
    std::fs::write(&stiff_file, stiff).unwrap();
    let out = run("hapticctl", &["scene", "run", stiff_file.to_str().unwrap()]);
    assert_exit_1(&out, "material.stiffness: too stiff");
    std::fs::remove_dir_all(dir).ok();
}

/// `command` run to its end, which must come within `seconds` (a reader stuck on a FIFO
/// never ends: it is killed and the test fails).
fn finished_within(mut command: Command, seconds: u64) -> Output {
    let child = command
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let started = Instant::now();
    let mut child = Some(child);
    loop {
        if child.as_mut().unwrap().try_wait().unwrap().is_some() {
            return child.take().unwrap().wait_with_output().unwrap();
        }
        if started.elapsed() > Duration::from_secs(seconds) {
            let mut stuck = child.take().unwrap();
            let _ = stuck.kill();
            let out = stuck.wait_with_output().unwrap();
            panic!(
                "{command:?} (pid {pid}) still ran after {seconds} s: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A FIFO at `path`, which no one will ever write.
fn fifo(path: &Path) -> PathBuf {
    nix::unistd::mkfifo(path, nix::sys::stat::Mode::from_bits_truncate(0o600)).unwrap();
    path.to_path_buf()
}

/// `hapticd` on the simulated SPIDAR-G (the plugin staged in `mechanisms`), with a
/// configuration of its own in `dir`, serving on `address`, never the machine's buses.
fn hapticd_command(dir: &Path, mechanisms: &Path, address: &str, args: &[&str]) -> Command {
    let config = dir.join("hapticd.yaml");
    std::fs::write(
        &config,
        format!(
            "mechanism_dirs: [{}]\nscene_dirs: [{}]\nscene: static\n",
            mechanisms.display(),
            repo_dir().join("config/scenes").display()
        ),
    )
    .unwrap();
    let mut command = Command::new(artifact("hapticd"));
    command
        .arg("--config")
        .arg(&config)
        .args(["--sim", "spidar-g", &format!("--bus={address}")])
        .args(args)
        .env("DBUS_SYSTEM_BUS_ADDRESS", address)
        .env("DBUS_SESSION_BUS_ADDRESS", address)
        .env_remove("NOTIFY_SOCKET")
        .env_remove("JOURNAL_STREAM")
        .env_remove("STATE_DIRECTORY")
        .env_remove("HAPTICD_MECHANISM_PATH");
    command
}

/// A private bus in `dir`/bus with the shipped policy.
fn private_bus(dir: &Path) -> PrivateBus {
    let at = dir.join("bus");
    std::fs::create_dir_all(&at).unwrap();
    PrivateBus::start(
        &at,
        &repo_dir().join("config/dbus/org.hapticd.Hapticd1.conf"),
    )
}

const DEVICE: [&str; 3] = [
    NAME,
    "/org/hapticd/Hapticd1/device/0",
    "org.hapticd.Hapticd1.Device",
];

/// Taken by each test that runs a hapticd on a bus: one at a time, so that on a small
/// machine a start is not slowed by another test's haptic thread on the same CPU.
static ONE_DAEMON: Mutex<()> = Mutex::new(());

/// A running hapticd on a private bus; killed when dropped.
struct Served {
    bus: PrivateBus,
    daemon: Option<Killed>,
    log: PathBuf,
}

impl Served {
    /// hapticd started in `dir` with `args`, once its device runs; it must get there within
    /// 60 s whatever its state directory holds (a FIFO held it for 12 minutes).
    fn start(dir: &Path, args: &[&str]) -> Served {
        let mechanisms = dir.join("mechanisms");
        std::fs::create_dir_all(&mechanisms).unwrap();
        let plugin = plugin_path("hapticd-spidar-g");
        std::fs::copy(&plugin, mechanisms.join(plugin.file_name().unwrap())).unwrap();
        let bus = private_bus(dir);
        let log = dir.join("hapticd.log");
        let mut command = hapticd_command(dir, &mechanisms, &bus.address, args);
        command
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap());
        let mut served = Served {
            daemon: Some(Killed(command.spawn().unwrap())),
            bus,
            log,
        };
        let started = Instant::now();
        loop {
            let state = served.busctl(&["get-property", DEVICE[0], DEVICE[1], DEVICE[2], "State"]);
            if state == Ok("s \"running\"".into()) {
                break;
            }
            if let Some(status) = served.daemon.as_mut().unwrap().0.try_wait().unwrap() {
                panic!("hapticd exited ({status}): {}", served.log());
            }
            assert!(
                started.elapsed() < Duration::from_secs(60),
                "hapticd not running after 60 s ({state:?}): {}",
                served.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        served
    }

    /// What `busctl` printed, or its error.
    fn busctl(&self, args: &[&str]) -> Result<String, String> {
        let out = Command::new("busctl")
            .arg(format!("--address={}", self.bus.address))
            .args(args)
            .output()
            .expect("busctl (package systemd) is installed by `make check`");
        let text = |b: &[u8]| String::from_utf8_lossy(b).trim().to_string();
        match out.status.success() {
            true => Ok(text(&out.stdout)),
            false => Err(text(&out.stderr)),
        }
    }

    fn get(&self, property: &str) -> String {
        let got = self.busctl(&["get-property", DEVICE[0], DEVICE[1], DEVICE[2], property]);
        got.unwrap_or_else(|e| panic!("{property}: {e}"))
    }

    /// The numbers of a property such as `ad 3 1 2 3`.
    fn numbers(&self, property: &str) -> Vec<f64> {
        let value = self.get(property);
        let mut words = value.split_whitespace().skip(1);
        if value.starts_with('a') {
            words.next();
        }
        words.map(|w| w.parse().unwrap()).collect()
    }

    fn calibrate(&self) -> Result<String, String> {
        self.busctl(&["call", DEVICE[0], DEVICE[1], DEVICE[2], "Calibrate"])
    }

    fn set(&self, property: &str, value: &str) -> Result<String, String> {
        let [name, path, interface] = DEVICE;
        self.busctl(&["set-property", name, path, interface, property, "d", value])
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Stop hapticd with SIGTERM, which it must obey within 5 s.
    fn stop(mut self) {
        let mut daemon = self.daemon.take().unwrap();
        let pid = nix::unistd::Pid::from_raw(daemon.0.id() as i32);
        nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM).unwrap();
        let started = Instant::now();
        while daemon.0.try_wait().unwrap().is_none() {
            assert!(
                started.elapsed() < Duration::from_secs(5),
                "SIGTERM ignored: {}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

#[test]
fn a_state_file_that_is_no_record_is_left_as_it_is_and_the_device_runs_without_it() {
    let _one = ONE_DAEMON.lock().unwrap_or_else(|p| p.into_inner());
    let dir = support::scratch("bad-input", "unusable-state");
    let state = dir.join("state");
    let outside = dir.join("elsewhere.json");
    // A record that would change the stiffness, were it read through the link.
    std::fs::write(&outside, r#"{"parameters": {"stiffness": 3000}}"#).unwrap();
    let file = state.join("device-sim.json");
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
    let saved = std::fs::read_to_string(state.join("device-sim.json")).unwrap();
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

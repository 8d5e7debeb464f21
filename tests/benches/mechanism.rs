//! Per-solve cost of the base part on every shipped mechanism, and of a general-purpose QP
//! solver (Clarabel) on the same tension problems, in one run.
//!
//! Run: `make bench` (builds the plugins in release first).

#[path = "../support/mod.rs"]
mod support;

use clarabel::solver::DefaultSettingsBuilder;
use divan::Bencher;
use glam::DQuat;
use hapticd_core::kinematics::{MAX_STRINGS_PER_EFFECTOR, Pose, Wrench};
use hapticd_core::mechanism::Mechanism;
use hapticd_core::solver::geometry::StringGeometry;
use hapticd_core::solver::pose::PoseSolver;
use support::qp::clarabel_tensions;
use support::shipped;

const MECHANISMS: [&str; 4] = ["spidar", "spidar-g", "spidar-ii", "spidar-6s"];
const CASES: usize = 256;

fn main() {
    divan::main();
}

/// The grip pose at sample `i` of a closed path through the workspace, the same one
/// for both benchmarks, so each problem is close to the previous one as in the haptic loop.
fn path_pose(m: &Mechanism, i: usize) -> Pose {
    let t = i as f64 / CASES as f64 * std::f64::consts::TAU;
    let half = support::frame_half(m, 0);
    let calibration = m.effectors[0].calibration;
    let turn = if m.effectors[0].dof.count() == 6 {
        DQuat::from_axis_angle(glam::DVec3::new(1.0, 2.0, 3.0).normalize(), 0.2 * t.sin())
    } else {
        DQuat::IDENTITY
    };
    Pose {
        position: calibration.position
            + glam::DVec3::new(t.cos(), (2.0 * t).sin(), t.sin()) * 0.2 * half,
        orientation: turn * calibration.orientation,
    }
}

/// String lengths along the path.
fn pose_cases(m: &Mechanism) -> Vec<[f64; MAX_STRINGS_PER_EFFECTOR]> {
    let k = m.kinematics(0);
    (0..CASES)
        .map(|i| {
            let mut lengths = [0.0; MAX_STRINGS_PER_EFFECTOR];
            k.lengths(&path_pose(m, i), &mut lengths);
            lengths
        })
        .collect()
}

/// Tension problems along the path with a turning force.
fn tension_cases(m: &Mechanism) -> Vec<(StringGeometry, Wrench)> {
    let k = m.kinematics(0);
    (0..CASES)
        .map(|i| {
            let t = i as f64 / CASES as f64 * std::f64::consts::TAU;
            let pose = path_pose(m, i);
            let force = glam::DVec3::new((3.0 * t).cos(), 0.5, (3.0 * t).sin()) * 4.0;
            let torque = glam::DVec3::new(t.sin(), t.cos(), 0.0) * 0.05;
            (StringGeometry::at(&k, &pose), Wrench { force, torque })
        })
        .collect()
}

#[divan::bench(args = MECHANISMS)]
fn pose_two_iterations(bencher: Bencher, name: &str) {
    let m = shipped(name);
    let cases = pose_cases(&m);
    let count = m.kinematics(0).count();
    let mut solver = PoseSolver::new(m.kinematics(0), path_pose(&m, 0));
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) % CASES;
        solver.solve(divan::black_box(&cases[i][..count]), 2)
    });
}

#[divan::bench(args = MECHANISMS)]
fn tension_active_set(bencher: Bencher, name: &str) {
    let m = shipped(name);
    let cases = tension_cases(&m);
    let mut solver = m.tension_solver(0);
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) % CASES;
        let (geometry, wrench) = &cases[i];
        solver.solve(divan::black_box(geometry), wrench)
    });
}

#[divan::bench(args = MECHANISMS)]
fn tension_clarabel(bencher: Bencher, name: &str) {
    let m = shipped(name);
    let cases = tension_cases(&m);
    let (lo, hi): (Vec<f64>, Vec<f64>) = m.effectors[0]
        .strings
        .iter()
        .map(|&s| (m.strings[s].tension_min, m.strings[s].tension_max))
        .unzip();
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .build()
        .expect("valid settings");
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) % CASES;
        let (g, f) = &cases[i];
        clarabel_tensions(
            divan::black_box(g),
            &f.to_array(),
            m.tension.lambda,
            (&lo, &hi),
            settings.clone(),
        )
    });
}

/// A transport without I/O: the counters read zero at power-on (calibration), then the
/// counts of `pressed` forever, so a tick costs only its computation.
struct StillTransport {
    calibrated: bool,
    pressed: [i64; 8],
}

impl hapticd_core::transport::Transport for StillTransport {
    fn update(
        &mut self,
        _dac: &[i16; 8],
        reading: &mut hapticd_core::transport::Reading,
    ) -> Result<(), hapticd_core::transport::TransportError> {
        reading.counts = if std::mem::replace(&mut self.calibrated, true) {
            self.pressed
        } else {
            [0; 8]
        };
        Ok(())
    }

    fn reset(&mut self) -> Result<(), hapticd_core::transport::TransportError> {
        Ok(())
    }

    fn identity(&self) -> &str {
        "still"
    }
}

/// One haptic tick (pose, proxy against the static scene, passivity, safety, tensions) with
/// every grip pressed 2 mm into the floor; device I/O excluded.
#[divan::bench(args = MECHANISMS)]
fn haptic_tick(bencher: Bencher, name: &str) {
    use hapticd_core::haptic_loop::{HapticLoop, LoopSettings};
    use hapticd_core::scene::Pointer;
    use hapticd_core::scene::static_scene::{StaticScene, StaticSceneSpec};

    let m = shipped(name);
    let mut pressed = [0i64; 8];
    for (i, s) in m.strings.iter().enumerate() {
        let rest = m.effectors[s.effector].calibration;
        let mut pose = rest;
        pose.position.y = -0.032;
        let length = |p: &Pose| (s.motor - p.transform_point(s.knot)).length();
        pressed[i] = ((length(&pose) - length(&rest)) / s.metres_per_pulse).round() as i64;
    }
    let spec =
        StaticSceneSpec::load(&support::repo_dir().join("config/scenes/static.yaml")).unwrap();
    let pointers = Pointer::at_calibration(&m);
    let scene = Box::new(StaticScene::new(spec, &pointers));
    let transport = Box::new(StillTransport {
        calibrated: false,
        pressed,
    });
    let mut haptic = HapticLoop::new(m, transport, scene, LoopSettings::default()).unwrap();
    bencher.bench_local(|| *haptic.tick(1e-3));
}

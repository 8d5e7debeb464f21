//! The per-tick computations never touch the heap: a counting allocator watches this
//! thread while pose, tension, calibration and closure run for every shipped mechanism.

mod support;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use glam::DVec3;
use hapticd::haptics::proxy::ProxyParameters;
use hapticd::mechanism::{MAX_STRINGS_PER_EFFECTOR, Pose};
use hapticd::parameters::Parameters;
use hapticd::runtime::haptic_loop::{LoopCommand, Retired};
use hapticd::scene::Scene;
use hapticd::scene::static_scene::{StaticScene, StaticSceneSpec};
use hapticd::sim::hand::Script;
use hapticd::sim::{SimParameters, SimulatedBoard};
use hapticd::solver::calibration::{lengths_from_counts, offsets};
use hapticd::solver::closure::is_force_closed;
use hapticd::solver::pose::PoseSolver;
use hapticd::solver::tension::TensionSolver;
use support::{Rng, pose_inside, shipped_mechanisms, simulated_loop};

struct Counting;

thread_local! {
    // Per thread, so tests running in parallel do not count each other's allocations.
    static WATCHING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count_if_watching() {
    if WATCHING.with(Cell::get) {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
    }
}

// SAFETY: forwards to the system allocator unchanged; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_if_watching();
        // SAFETY: same contract as ours.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as ours.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_if_watching();
        // SAFETY: same contract as ours.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `f` on this thread.
fn allocations_in(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.with(Cell::get);
    WATCHING.with(|w| w.set(true));
    f();
    WATCHING.with(|w| w.set(false));
    ALLOCATIONS.with(Cell::get) - before
}

#[test]
fn the_counter_sees_allocations() {
    assert!(allocations_in(|| drop(std::hint::black_box(vec![1u8; 64]))) >= 1);
}

#[test]
fn pose_tension_calibration_and_closure_do_not_allocate() {
    let mut rng = Rng::new(20);
    for m in shipped_mechanisms() {
        let counts: Vec<i64> = (0..m.strings.len() as i64)
            .map(|i| 1000 * i - 3000)
            .collect();
        let offsets = offsets(&m, &counts);
        for index in 0..m.effectors.len() {
            let poses: Vec<Pose> = (0..200).map(|_| pose_inside(&m, index, &mut rng)).collect();
            let mut pose_solver =
                PoseSolver::new(m.kinematics(index), m.effectors[index].calibration);
            let mut tension_solver = TensionSolver::for_effector(&m, index);
            let kinematics = m.kinematics(index);
            let mut lengths = [0.0; MAX_STRINGS_PER_EFFECTOR];
            let mut all_lengths = [0.0; 2 * MAX_STRINGS_PER_EFFECTOR];
            let n = allocations_in(|| {
                for (k, pose) in poses.iter().enumerate() {
                    lengths_from_counts(&m.strings, &offsets, &counts, &mut all_lengths);
                    kinematics.lengths(pose, &mut lengths);
                    let estimate = pose_solver.solve(&lengths[..kinematics.count()], 2);
                    let force = DVec3::new(1.0, -2.0, 3.0) * (k as f64 * 0.01);
                    let wrench = [force.x, force.y, force.z, 0.01, 0.0, -0.01];
                    let solution = tension_solver.solve(pose_solver.geometry(), &wrench);
                    std::hint::black_box((
                        estimate,
                        solution,
                        is_force_closed(pose_solver.geometry()),
                    ));
                }
            });
            assert_eq!(n, 0, "{} effector {index}: {n} allocations", m.name);
        }
    }
}

#[test]
fn a_haptic_loop_tick_does_not_allocate() {
    for m in shipped_mechanisms() {
        let script = "hands:\n  grip:\n    - move: { to: [0.01, -0.05, 0.01], seconds: 0.3 }\n    - shake: { amplitude: [0.01, 0, 0], frequency: 3, seconds: 1 }\n";
        let mut haptic = simulated_loop(&m, script, 1e-3);
        // Calibration (first tick), contact, sliding and release all happen in here.
        let n = allocations_in(|| {
            for _ in 0..1500 {
                std::hint::black_box(haptic.tick(1e-3));
            }
        });
        assert_eq!(n, 0, "{}: {n} allocations in 1500 ticks", m.name);
    }
}

#[test]
fn commands_between_ticks_do_not_allocate() {
    let m = support::shipped("spidar-g");
    let script = "hands:\n  grip:\n    - move: { to: [0, -0.05, 0], seconds: 0.3 }\n    - hold: { seconds: 2 }\n";
    let mut haptic = simulated_loop(&m, script, 1e-3);
    let spec =
        StaticSceneSpec::load(&support::repo_dir().join("config/scenes/static.yaml")).unwrap();
    // Everything a command carries is made before it reaches the loop, as the daemon does.
    let incoming: Box<dyn Scene> = Box::new(StaticScene::new(
        spec,
        &hapticd::scene::Pointer::at_calibration(&m),
    ));
    let tune = LoopCommand::Tune(Parameters {
        proxy: ProxyParameters {
            stiffness: 1500.0,
            ..ProxyParameters::default()
        },
        lambda: 0.1,
        max_force: 5.0,
        max_torque: 0.2,
    });
    let mut commands = vec![
        tune,
        LoopCommand::Calibrate,
        LoopCommand::ResetFault,
        LoopCommand::SwitchScene(incoming),
        LoopCommand::Reconnect(Box::new(SimulatedBoard::new(
            &m,
            1e-3,
            &Script::default(),
            SimParameters::default(),
        ))),
    ];
    let mut retired = Vec::with_capacity(4);
    let n = allocations_in(|| {
        for tick in 0..1000 {
            if tick % 100 == 50
                && let Some(command) = commands.pop()
            {
                haptic.command(command);
            }
            std::hint::black_box(haptic.tick(1e-3));
            while let Some(old) = haptic.take_retired() {
                retired.push(old);
            }
        }
    });
    assert_eq!(n, 0, "{n} allocations");
    let frame = haptic.frame();
    assert_eq!(frame.scene_switches, 1);
    assert_eq!(frame.calibrations, 2, "the first reading, then the command");
    // The simulated board's transport cannot take another link: the one sent comes back.
    assert!(matches!(retired[..], [Retired::Link(_), Retired::Scene(_)]));
}

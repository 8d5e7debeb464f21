//! The per-tick computations never touch the heap: a counting allocator watches this
//! thread while pose, tension, calibration and closure run for every shipped mechanism, while
//! whole haptic-loop ticks run on the simulated board and on an emulated USB amplifier,
//! while commands reach the loop between ticks, and while a plugin's output is checked and
//! refused.

use crate::support;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use glam::DVec3;
use hapticctl::experiments::Session;
use hapticd_core::haptic_loop::{DeviceState, HapticLoop, LoopCommand, LoopSettings, Retired};
use hapticd_core::haptics::proxy::ProxyParameters;
use hapticd_core::haptics::wrench_command::CommandState;
use hapticd_core::kinematics::{MAX_STRINGS_PER_EFFECTOR, Pose, Wrench};
use hapticd_core::parameters::Parameters;
use hapticd_core::scene::Pointer;
use hapticd_core::scene::Scene;
use hapticd_core::scene::output_check::OutputFault;
use hapticd_core::scene::static_scene::{StaticScene, StaticSceneSpec};
use hapticd_core::solver::calibration::lengths_from_counts;
use hapticd_core::solver::closure::is_force_closed;
use hapticd_core::solver::pose::PoseSolver;
use hapticd_device::sim::hand::Script;
use hapticd_device::sim::{SimParameters, SimulatedBoard};
use hapticd_device::transport::Sh4Transport;
use hapticd_ipc::wrench_share::{MappedWrenchInput, WrenchInputFile};
use hapticd_plugin_api::HapticdBodyPose;
use support::amplifier::{
    SH4, emulated_amplifier_with, resting_dac, resting_session, umockdev_run,
};
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
        let offsets = m.offsets(&counts);
        let metres_per_pulse = m.metres_per_pulse();
        for index in 0..m.effectors.len() {
            let poses: Vec<Pose> = (0..200).map(|_| pose_inside(&m, index, &mut rng)).collect();
            let mut pose_solver =
                PoseSolver::new(m.kinematics(index), m.effectors[index].calibration);
            let mut tension_solver = m.tension_solver(index);
            let kinematics = m.kinematics(index);
            let mut lengths = [0.0; MAX_STRINGS_PER_EFFECTOR];
            let mut all_lengths = [0.0; 2 * MAX_STRINGS_PER_EFFECTOR];
            let n = allocations_in(|| {
                for (k, pose) in poses.iter().enumerate() {
                    lengths_from_counts(&offsets, &metres_per_pulse, &counts, &mut all_lengths);
                    kinematics.lengths(pose, &mut lengths);
                    let estimate = pose_solver.solve(&lengths[..kinematics.count()], 2);
                    let force = DVec3::new(1.0, -2.0, 3.0) * (k as f64 * 0.01);
                    let wrench = Wrench {
                        force,
                        torque: glam::DVec3::new(0.01, 0.0, -0.01),
                    };
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
fn a_grasp_step_does_not_allocate() {
    use glam::DVec3;
    use hapticd_core::haptics::grasp::{Grasp, GraspSettings, Handheld, Method, Object};
    for method in [Method::Distributed, Method::Conventional] {
        let settings = GraspSettings::thesis(method);
        let mut grasp = Handheld {
            grasp: Grasp::new(settings),
            object: Object::at_rest(DVec3::new(0.06, 0.1, 0.06), 1.0, DVec3::ZERO),
            gravity: DVec3::new(0.0, -2.0, 0.0),
        };
        // Touch, grasp, shake, and let go.
        let n = allocations_in(|| {
            for step in 0..2000 {
                let t = step as f64 * 1e-3;
                let gap = if step < 1500 { 0.055 } else { 0.08 };
                let c = 0.02 * (10.0 * t).sin();
                let fingers = [
                    DVec3::new(c - gap / 2.0, 0.0, 0.0),
                    DVec3::new(c + gap / 2.0, 0.0, 0.0),
                ];
                std::hint::black_box(grasp.step(&fingers, 1e-3));
            }
        });
        assert_eq!(n, 0, "{method:?}: {n} allocations in 2000 steps");
    }
}

#[test]
fn every_shipped_penalty_scene_steps_without_allocating_from_its_first_tick() {
    use glam::{DQuat, DVec3};
    use hapticd_core::kinematics::Wrench;
    use hapticd_mesh::cache::Cache;
    use hapticd_physics::coupling::Grip;
    use hapticd_physics::scene::SceneFile;
    for (name, pointers) in [
        ("blocks", 2),
        ("cube-drop", 0),
        ("stack", 0),
        ("top", 0),
        ("stick-slip", 1),
        ("mug", 1),
        ("hinges", 1),
        ("jelly", 1),
        ("tray", 1),
        ("weight", 1),
        ("peg-in-hole", 1),
        ("bolt", 1),
        ("gears", 1),
        ("mug-hook", 1),
    ] {
        let path = support::repo_dir().join(format!("config/scenes/{name}.yaml"));
        let text = std::fs::read_to_string(&path).unwrap();
        let cache = Cache::at(support::mesh_cache());
        let Ok(SceneFile::Penalty(mut scene)) =
            SceneFile::parse_cached(&text, &path, pointers, &cache)
        else {
            panic!("{name} is a penalty scene");
        };
        let mut felt = [Wrench::default(); 2];
        // Pointers pressing down into whatever is below them.
        let grips: Vec<Grip> = (0..pointers)
            .map(|k| Grip {
                position: DVec3::new(0.035 - 0.07 * k as f64, -0.01, 0.0),
                orientation: DQuat::IDENTITY,
                velocity: DVec3::new(0.0, -0.01, 0.0),
                spin: DVec3::ZERO,
            })
            .collect();
        let n = allocations_in(|| {
            for _ in 0..500 {
                std::hint::black_box(scene.step_pointers(1e-3, &grips, &mut felt[..pointers]));
            }
        });
        assert_eq!(n, 0, "{name}: {n} allocations in 500 ticks");
    }
}

#[test]
fn a_penalty_scene_step_with_a_held_body_does_not_allocate() {
    use glam::{DQuat, DVec3};
    use hapticd_core::kinematics::Wrench;
    use hapticd_physics::coupling::Grip;
    use hapticd_physics::scene::PenaltyScene;
    // A held cube pressed on a fixed slab and slid along it, a free cube in its way: the
    // god-object's contacts, the world's push on the free cube, both felt.
    let text = "name: held
dt: 0.0001
material: { stiffness: 1.0e7, damping: 2.0e4, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e7, friction_damping: 2.0e4, slip_speed: 0.001 }
bodies:
  - { name: slab, box: [0.2, 0.01, 0.2], position: [0, -0.005, 0], fixed: true }
  - { name: part, box: [0.02, 0.02, 0.02], position: [0, 0.01, 0] }
  - { name: free, box: [0.01, 0.01, 0.01], position: [0.03, 0.005, 0], density: 500 }
pointer:
  holds: part
";
    let mut scene = PenaltyScene::parse(text, std::path::Path::new("held.yaml"), 1).unwrap();
    let grip = |tick: usize| Grip {
        position: DVec3::new(0.03 * tick as f64 / 1000.0, 0.009, 0.0),
        orientation: DQuat::IDENTITY,
        velocity: DVec3::ZERO,
        spin: DVec3::ZERO,
    };
    let mut felt = [Wrench::default()];
    scene.step_pointers(1e-3, &[grip(0)], &mut felt);
    let mut most = 0.0f64;
    let n = allocations_in(|| {
        for tick in 1..1000 {
            assert!(scene.step_pointers(1e-3, &[grip(tick)], &mut felt));
            most = most.max(felt[0].force.length());
        }
    });
    assert_eq!(n, 0, "{n} allocations in 1 000 ticks");
    // It pressed on the slab: the spring's 2 000 N/m over the millimetre felt.
    assert!(most > 1.0, "{most} N");
}

#[test]
fn a_penalty_scene_step_with_two_fingers_grasping_does_not_allocate() {
    use glam::{DQuat, DVec3};
    use hapticd_core::kinematics::Wrench;
    use hapticd_physics::coupling::Grip;
    use hapticd_physics::scene::PenaltyScene;
    let path = support::repo_dir().join("config/scenes/grasp.yaml");
    let mut scene = PenaltyScene::load(&path, 2).unwrap();
    let mut felt = [Wrench::default(); 2];
    // Close on the box, lift it, let go: first contacts, grasp and release all happen in
    // here, from the scene's first step.
    let n = allocations_in(|| {
        for step in 0..1500 {
            let t = step as f64 * 1e-3;
            let gap = if t < 1.2 {
                0.09 - 0.025 * (t / 0.3).min(1.0)
            } else {
                0.09
            };
            let y = -0.1 + 0.03 * ((t - 0.5) / 0.5).clamp(0.0, 1.0);
            let grips = [-1.0, 1.0].map(|side| Grip {
                position: DVec3::new(side * gap / 2.0, y, 0.0),
                orientation: DQuat::IDENTITY,
                velocity: DVec3::ZERO,
                spin: DVec3::ZERO,
            });
            assert!(scene.step_pointers(1e-3, &grips, &mut felt));
        }
    });
    assert_eq!(n, 0, "{n} allocations in 1500 ticks");
}

/// A soft ball pinned to a floor, pressed by a finger and let go, its first contacts and
/// releases all in here, from the scene's first tick, its surface's corners read for
/// pictures every tick, its material changed while pressed and its nodes let go and pinned
/// again, and the factor its helper makes of them taken in: nothing allocated.
#[test]
fn a_penalty_scene_with_a_soft_body_pressed_and_let_go_does_not_allocate() {
    use glam::{DQuat, DVec3};
    use hapticd_core::kinematics::Wrench;
    use hapticd_physics::coupling::Grip;
    use hapticd_physics::scene::PenaltyScene;
    use hapticd_plugin_api::*;
    let text = "name: soft\ndt: 0.00025\nmaterial: { stiffness: 2.0e7, damping: 1.0e4, \
                static_friction: 0.4, friction: 0.3, friction_stiffness: 2.0e7, \
                friction_damping: 1.0e4, slip_speed: 0.001 }\nbodies:\n  - { name: floor, box: \
                [0.2, 0.02, 0.2], position: [0, -0.01, 0], fixed: true }\n  - { name: ball, \
                sphere: 0.03, position: [0, 0.029, 0], density: 1100, soft: { young: 5.0e4, \
                poisson: 0.4, damping: 0.002, resolution: 0.01 }, pinned: { body: floor } }\n";
    let mut scene = PenaltyScene::parse(text, std::path::Path::new("soft.yaml"), 1).unwrap();
    let mut felt = [Wrench::default()];
    let mut most: f64 = 0.0;
    let mut corners = vec![[0.0f32; 3]; 8192];
    let mut lowest = f32::INFINITY;
    let command = |kind: u32, vector: [f64; 3], value: f64| HapticdSceneCommand {
        vector,
        value,
        ..HapticdSceneCommand::new(kind, 1)
    };
    let changes = [
        (
            150,
            command(HAPTICD_COMMAND_SET_MATERIAL, [2e4, 0.45, 0.001], 0.0),
        ),
        (450, command(HAPTICD_COMMAND_RELEASE, [0.0, 1.0, 0.0], 1.0)),
        (451, command(HAPTICD_COMMAND_PIN, [0.0, 1.0, 0.0], 0.0)),
    ];
    let n = allocations_in(|| {
        for step in 0..600 {
            for (at, change) in &changes {
                if step == *at {
                    assert!(scene.apply(change).is_some());
                }
            }
            let t = step as f64 * 1e-3;
            // Down 1 cm into the ball's top over 0.3 s, and back up.
            let depth = 0.01 * (1.0 - ((t - 0.3) / 0.3).abs()).max(0.0);
            let grip = Grip {
                position: DVec3::new(0.003, 0.068 - depth, 0.0),
                orientation: DQuat::IDENTITY,
                velocity: DVec3::ZERO,
                spin: DVec3::ZERO,
            };
            assert!(scene.step_pointers(1e-3, &[grip], &mut felt));
            most = most.max(felt[0].force.y);
            let count = scene.corners(&mut corners);
            lowest = corners[..count].iter().map(|c| c[1]).fold(lowest, f32::min);
        }
        // Its helper's factor of the new material and pins taken in, in a tick too.
        let asked = std::time::Instant::now();
        while !scene.soft[0].factored_for(1e-3) && asked.elapsed().as_secs() < 10 {
            std::thread::sleep(std::time::Duration::from_millis(1));
            let grip = Grip {
                position: DVec3::new(0.003, 0.068, 0.0),
                orientation: DQuat::IDENTITY,
                velocity: DVec3::ZERO,
                spin: DVec3::ZERO,
            };
            assert!(scene.step_pointers(1e-3, &[grip], &mut felt));
        }
    });
    assert_eq!(n, 0, "{n} allocations in 600 ticks and the factor's swap");
    assert!(scene.soft[0].factored_for(1e-3));
    // It was pressed: the finger felt the ball push back; and the corners were read, down
    // to the ball's bottom pinned at y = -0.001.
    assert!(most > 0.1, "{most} N");
    assert!((lowest + 0.001).abs() < 1e-6, "{lowest}");
}

#[test]
fn a_static_scene_touching_a_large_mesh_does_not_allocate() {
    // A floor, and a ball of 99 600 triangles, its top at y = 0.
    let mut shapes = vec![hapticd_core::haptics::obstacle::Shape::HalfSpace {
        point: DVec3::new(0.0, -0.2, 0.0),
        normal: DVec3::Y,
    }];
    let centre = DVec3::new(0.0, -0.05, 0.0);
    shapes.extend(support::ball_mesh::ball_faces(centre, 0.05, 250, 200));
    let spec = StaticSceneSpec::bare("ball", ProxyParameters::default(), shapes);
    let start = [Pointer {
        pose: Pose {
            position: DVec3::new(0.0, 0.02, 0.0),
            ..Pose::IDENTITY
        },
        velocity: DVec3::ZERO,
    }];
    let mut scene = StaticScene::new(spec, &start);
    let mut wrenches = [Wrench::default()];
    let mut pressed = 0.0;
    let n = allocations_in(|| {
        // Down onto the top, then round the side, pressed 5 mm in.
        for k in 0..1000 {
            let angle = (k as f64 / 1000.0) * 1.2;
            let reach = if k < 100 {
                0.02 - 0.0007 * k as f64
            } else {
                -0.05
            };
            let grip = if k < 100 {
                DVec3::new(0.0, reach, 0.0)
            } else {
                centre + 0.045 * DVec3::new(angle.sin(), angle.cos(), 0.0)
            };
            let pointers = [Pointer {
                pose: Pose {
                    position: grip,
                    ..Pose::IDENTITY
                },
                velocity: DVec3::ZERO,
            }];
            assert!(scene.render(&pointers, 1e-3, &mut wrenches));
            pressed += wrenches[0].force.length();
        }
    });
    assert_eq!(n, 0, "{n} allocations in 1000 ticks");
    assert!(pressed > 1000.0, "the ball was pressed: {pressed}");
}

#[test]
fn writing_every_tick_to_the_telemetry_ring_does_not_allocate() {
    let m = shipped_mechanisms().remove(0);
    let script = "hands:\n  grip:\n    - move: { to: [0.01, -0.05, 0.01], seconds: 0.3 }\n";
    let mut haptic = simulated_loop(&m, script, 1e-3);
    let (_file, mut ring) =
        hapticd_ipc::telemetry_share::SharedTelemetryFile::create(1000.0).unwrap();
    // More ticks than the ring has slots: it wraps in here.
    let n = allocations_in(|| {
        for _ in 0..10_000 {
            let frame = *haptic.tick(1e-3);
            ring.write(std::hint::black_box(&frame));
        }
    });
    assert_eq!(n, 0, "{n} allocations in 10 000 ticks");
}

#[test]
fn a_haptic_loop_tick_does_not_allocate() {
    for m in shipped_mechanisms() {
        let script = "hands:\n  grip:\n    - move: { to: [0.01, -0.05, 0.01], seconds: 0.3 }\n    - shake: { amplitude: [0.01, 0, 0], frequency: 3, seconds: 0.9 }\n    - unplug: { seconds: 0.1 }\n";
        let mut haptic = simulated_loop(&m, script, 1e-3);
        // Calibration (first tick), contact, sliding, release, an unplug and the search for
        // the grip when the device returns all happen in here.
        let n = allocations_in(|| {
            for _ in 0..1500 {
                std::hint::black_box(haptic.tick(1e-3));
            }
        });
        assert_eq!(n, 0, "{}: {n} allocations in 1500 ticks", m.name);
    }
}

/// Every kind of effect added, changed and removed between ticks, and ticks rendering all
/// of them with a hand shaking through them, on every shipped mechanism: nothing allocated.
#[test]
fn effects_of_every_kind_added_changed_and_rendered_do_not_allocate() {
    use hapticd_core::haptics::effects::EffectCommand;
    use hapticd_core::haptics::effects::spec::{EffectSpec, Limits};
    let kinds = [
        "{kind: constant, force: [0, 1, 0], torque: [0, 0, 0.01]}",
        "{kind: ramp, force: [0, 0, 0], to: [1, 0, 0], over: 0.5}",
        "{kind: triangle, direction: [0, 1, 0], frequency: 40, amplitude: 1}",
        "{kind: saw_down, direction: [1, 0, 0], frequency: 5, amplitude: 0.5, attack: 0.1}",
        "{kind: spring, anchor: [0, 0, 0], normal: [0, 1, 0], stiffness: 100, dead_band: 0.002}",
        "{kind: damper, damping: 2, region: {box: [0.1, 0.1, 0.1]}}",
        "{kind: inertia, mass: 0.05}",
        "{kind: friction, friction: 0.5, stiffness: 800}",
        "{kind: fixture, shape: {capsule: [[0, 0, 0], [0, 0.1, 0]], radius: 0.02}, keep: in, stiffness: 500}",
        "{kind: shape, shape: {cone: 30, height: 0.05}, stiffness: 2000, width: 0.003, easing: smooth}",
        "{kind: magnet, shape: {plane: [0, 1, 0], point: [0, -0.04, 0]}, reach: 0.02, friction: 1}",
        "{kind: rotational_spring, orientation: [1, 0, 0, 0], stiffness: 0.5, saturation: 0.1}",
        "{kind: waveform, samples: [0, 1, -0.5, 0.2], rate: 200, direction: [0, 0, 1]}",
        "{kind: stick_slip, friction: 0.8, stiffness: 600}",
    ];
    for m in shipped_mechanisms() {
        let effectors: Vec<String> = m.effectors.iter().map(|e| e.name.clone()).collect();
        let limits = Limits {
            effectors: &effectors,
            max_force: 10.0,
            rate: 1000.0,
            bodies: &[],
        };
        // Made before they reach the loop, as the daemon makes them.
        let effects: Vec<_> = kinds
            .iter()
            .map(|text| {
                let path = std::path::Path::new("effect");
                let spec: EffectSpec = hapticd_core::diagnostics::parse_yaml(text, path)
                    .unwrap()
                    .value;
                let mut f = hapticd_core::diagnostics::Findings::new(path, &|_| None);
                spec.check("", &limits, &mut f).expect(text)
            })
            .collect();
        let script = "hands:\n  grip:\n    - shake: { amplitude: [0.02, 0.01, 0], frequency: 3, seconds: 2 }\n";
        let mut haptic = simulated_loop(&m, script, 1e-3);
        let n = allocations_in(|| {
            for (k, effect) in effects.iter().enumerate() {
                haptic.command(LoopCommand::Effect(EffectCommand::Add(k as u32, *effect)));
                std::hint::black_box(haptic.tick(1e-3));
            }
            for _ in 0..500 {
                std::hint::black_box(haptic.tick(1e-3));
            }
            haptic.command(LoopCommand::Effect(EffectCommand::Change(2, effects[3])));
            haptic.command(LoopCommand::Effect(EffectCommand::Remove(0)));
            for _ in 0..500 {
                std::hint::black_box(haptic.tick(1e-3));
            }
            haptic.command(LoopCommand::Effect(EffectCommand::Clear));
            for _ in 0..100 {
                std::hint::black_box(haptic.tick(1e-3));
            }
        });
        assert_eq!(n, 0, "{}: {n} allocations", m.name);
        assert_eq!(haptic.frame().effects, 0, "{}: all faded out", m.name);
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
        &hapticd_core::scene::Pointer::at_calibration(&m),
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
    // Two blocks of commanded wrenches, the second replacing the first, both written
    // every tick.
    let (first, first_fd) = WrenchInputFile::create().unwrap();
    let (second, second_fd) = WrenchInputFile::create().unwrap();
    let writers = [first_fd, second_fd].map(|fd| MappedWrenchInput::open(&fd).unwrap());
    let push = [Wrench::force(DVec3::new(0.0, 0.5, 0.0))];
    let mut commands = vec![
        LoopCommand::CommandWrenches(Box::new(second)),
        LoopCommand::CommandWrenches(Box::new(first)),
        tune,
        LoopCommand::MeasureOffsets,
        LoopCommand::ResetFault,
        LoopCommand::SwitchScene(incoming),
        LoopCommand::Reconnect(Box::new(
            SimulatedBoard::new(&m, 1e-3, &Script::default(), SimParameters::default()).unwrap(),
        )),
    ];
    let mut retired = Vec::with_capacity(4);
    let n = allocations_in(|| {
        for tick in 0..1000 {
            if tick % 100 == 50
                && let Some(command) = commands.pop()
            {
                haptic.command(command);
            }
            // After every command above: calibrate with the offsets measured.
            if tick == 750 {
                haptic.command(LoopCommand::UseOffsets(haptic.frame().measured));
            }
            for w in &writers {
                w.write(&push);
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
    assert_eq!(frame.measurements, 1);
    assert_eq!(frame.calibrations, 2, "the first reading, then the command");
    // The simulated board's transport cannot take another link: the one sent comes back.
    assert!(matches!(
        retired[..],
        [
            Retired::Link(_),
            Retired::Scene(_),
            Retired::WrenchSource(_)
        ]
    ));
    assert_eq!(frame.command, CommandState::Active);
}

/// Set in the copy of this test binary that runs under umockdev.
const UNDER_UMOCKDEV: &str = "HAPTICD_TEST_UNDER_UMOCKDEV";

#[test]
fn a_haptic_loop_tick_on_a_usb_amplifier_does_not_allocate() {
    // As the test harness names it: by its path below the crate.
    const NAME: &str = "no_allocation::a_haptic_loop_tick_on_a_usb_amplifier_does_not_allocate";
    let dac = resting_dac();
    if std::env::var_os(UNDER_UMOCKDEV).is_none() {
        // Only a process started under umockdev sees the emulated amplifier: this test runs
        // again in such a copy of this binary, which takes the other branch.
        let script = resting_session(400);
        let (device, ioctl) = emulated_amplifier_with("no-allocation", SH4, &script);
        let out = umockdev_run(&device, &ioctl, &std::env::current_exe().unwrap())
            .args(["--exact", NAME, "--nocapture"])
            .env(UNDER_UMOCKDEV, "1")
            .output()
            .expect("umockdev-run is installed (Debian package umockdev)");
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert!(out.status.success(), "{stdout}{stderr}");
        assert!(stdout.contains("1 passed"), "{stdout}");
        return;
    }
    let (mut found, problems) = hapticd_device::usb::find_devices().unwrap();
    assert!(problems.is_empty(), "{problems:?}");
    let amplifier = found.pop().expect("the emulated amplifier");
    let m = support::shipped("spidar-g");
    let transport = Box::new(Sh4Transport::new(amplifier.link, amplifier.identity));
    let spec =
        StaticSceneSpec::load(&support::repo_dir().join("config/scenes/static.yaml")).unwrap();
    let scene = Box::new(StaticScene::new(spec, &Pointer::at_calibration(&m)));
    let mut haptic = HapticLoop::new(m, transport, scene, LoopSettings::default()).unwrap();
    let mut states = [DeviceState::Disconnected; 300];
    // From the first update (calibration, power-on zeros) on: libusb only found the device;
    // every transfer of these ticks goes through usbfs.
    let n = allocations_in(|| {
        for state in &mut states {
            *state = haptic.tick(1e-3).state;
        }
    });
    assert_eq!(n, 0, "{n} allocations in 300 ticks on USB");
    assert!(states.iter().all(|s| *s == DeviceState::Running));
    assert_eq!(haptic.frame().dac, dac);
}

/// The haptic side of the rapier plugin's scene (thesis Ch. 6), loaded as hapticd loads it:
/// ticks that take new planes, render them, carry the proxy and hand impulses back to the
/// physics thread allocate nothing on the haptic thread (the physics thread may).
#[test]
fn a_haptic_tick_of_a_rapier_scene_does_not_allocate() {
    // Handing back impulses, and moving the block here under the finger (local dynamics).
    for feedback in ["impulse", "local"] {
        let shipped =
            std::fs::read_to_string(support::repo_dir().join("config/scenes/push.yaml")).unwrap();
        let path = support::scratch_root().join(format!(
            "no-allocation-{}-push-{feedback}.yaml",
            std::process::id()
        ));
        std::fs::write(
            &path,
            shipped.replace("feedback: local", &format!("feedback: {feedback}")),
        )
        .unwrap();
        rapier_ticks(&path, feedback);
        std::fs::remove_file(&path).unwrap();
    }
}

/// The held peg of the rapier plugin's `peg-and-blocks` scene, loaded as hapticd loads it,
/// pushing a block along the table: the god-object's ticks against every body's surface,
/// the block moved here under the peg's contacts, its change handed back and the world's
/// picture taken, allocate nothing on the haptic thread.
#[test]
fn a_haptic_tick_of_a_part_held_in_rapiers_world_does_not_allocate() {
    use hapticd::plugin_scene;
    let path = support::repo_dir().join("config/scenes/peg-and-blocks.yaml");
    let at = |x: f64, y: f64| resting_at(DVec3::new(x, y, 0.0));
    let mut scene = plugin_scene::load(
        &support::plugin_path("hapticd-scene-rapier"),
        Some(&path),
        &at(0.0, 0.0),
    )
    .unwrap();
    let mut wrenches = [Wrench::ZERO];
    let tick = std::time::Duration::from_millis(1);
    // Beside the holed block (the peg's face 2 mm short of the near block's, at x = 0.03),
    // and down to 5 mm over the table, uncounted: the first planes come with the physics
    // thread's first step.
    let ways = (0..300).map(|k| (0.022 * k as f64 / 300.0, 0.0));
    for (x, y) in ways.chain((0..300).map(|k| (0.022, -0.04 * k as f64 / 300.0))) {
        scene.render(&at(x, y), 1e-3, &mut wrenches);
        std::thread::sleep(tick);
    }
    let mut bodies = [HapticdBodyPose::default(); 5];
    let mut pushed = 0.0f64;
    let first = std::time::Instant::now();
    // Then along x at 0.05 m/s for 400 ms, pushing the near block 18 mm on.
    let n = allocations_in(|| {
        for k in 1..=400u32 {
            let x = 0.022 + 0.05 * f64::from(k) * 1e-3;
            assert!(scene.render(&at(x, -0.04), 1e-3, &mut wrenches));
            pushed = pushed.max(-wrenches[0].force.x);
            assert_eq!(scene.write_bodies(&mut bodies), 5);
            let deadline = first + tick * k;
            if let Some(rest) = deadline.checked_duration_since(std::time::Instant::now()) {
                std::thread::sleep(rest);
            }
        }
    });
    assert_eq!(n, 0, "{n} allocations in 400 ticks");
    let moved = bodies[2].position[0] - 0.04;
    assert!(moved > 0.01, "the near block moved {moved} m");
    assert!(pushed > 0.0, "the hand felt {pushed} N against the push");
}

/// Four hundred ticks of a finger pushing the `push` block at `path` without allocating.
fn rapier_ticks(path: &std::path::Path, feedback: &str) {
    use hapticd::plugin_scene;
    // The finger comes to the block's near face (x = 0.03) and is pressed 5 mm into it,
    // pushing it (a grip that starts inside a solid feels nothing until it is out).
    let outside = resting_at(DVec3::new(0.02, 0.02, 0.0));
    let pointers = [Pointer {
        pose: Pose {
            position: DVec3::new(0.035, 0.02, 0.0),
            ..Pose::default()
        },
        velocity: DVec3::new(0.05, 0.0, 0.0),
    }];
    let mut scene = plugin_scene::load(
        &support::plugin_path("hapticd-scene-rapier"),
        Some(path),
        &outside,
    )
    .unwrap();
    let mut wrenches = [Wrench::ZERO];
    let tick = std::time::Duration::from_millis(1);
    // The first planes come with the physics thread's first step.
    let started = std::time::Instant::now();
    while !scene.render(&outside, 1e-3, &mut wrenches) {
        assert!(started.elapsed().as_secs() < 10, "no planes");
        std::thread::sleep(tick);
    }
    let mut pushed = 0.0f64;
    let mut bodies = [HapticdBodyPose::default(); 4];
    let mut proxies = [DVec3::ZERO; 1];
    let mut block_x = Vec::with_capacity(400);
    let mut proxy_x = f64::INFINITY;
    // 400 ms at 20 Hz: eight sets of planes taken and eight impulses handed back; the world's
    // picture taken every tick, as the haptic thread takes it for the renderer. Ticks keep
    // to absolute deadlines, as the real-time thread's do: a sleep that overshoots on a busy
    // machine is made up by the ticks after it, so haptic time keeps up with the physics
    // thread's clock (each tick counting 1 ms however long it slept, the picture fell behind
    // the physics and jumped when the next step came).
    let first = std::time::Instant::now();
    let n = allocations_in(|| {
        for k in 1..=400u32 {
            assert!(scene.render(&pointers, 1e-3, &mut wrenches));
            pushed = pushed.max(-wrenches[0].force.x);
            assert_eq!(
                scene.write_bodies(&mut bodies),
                2,
                "the floor and the block"
            );
            assert!(scene.write_proxies(&mut proxies));
            block_x.push(bodies[1].position[0]);
            proxy_x = proxy_x.min(proxies[0].x);
            let deadline = first + tick * k;
            if let Some(rest) = deadline.checked_duration_since(std::time::Instant::now()) {
                std::thread::sleep(rest);
            }
        }
    });
    assert_eq!(n, 0, "{feedback}: {n} allocations in 400 ticks");
    assert!(
        pushed > 1.0,
        "{feedback}: the block did not push back: {pushed} N"
    );
    // Pushed along +x, the block is seen moving between physics steps (6.5.2), not in eight
    // jumps of an eighth of its travel: far more places than steps, and no jump as large.
    let mut places = block_x.clone();
    places.dedup();
    assert!(places.len() > 50, "{} places in 400 ticks", places.len());
    let travel = block_x[399] - block_x[0];
    let jumps: Vec<f64> = block_x
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|&step| step >= travel / 16.0)
        .collect();
    // The grip, 5 mm into the face, pushes it on until it is clear of it.
    assert!(travel > 0.005, "{feedback}: the block moved {travel} m");
    // Unsmoothed, each of the eight steps is a jump of about an eighth of the travel. The
    // physics thread keeps to the wall clock, and on a busy machine a step can come early
    // after one that came late: the picture then leaves the older interpolation part-way.
    // Measured: none in three runs of this binary alone; one (0.6 and 0.75 of a step) in
    // each of two runs while a compiler took the other core. So a jump or two, never the
    // steps themselves.
    println!("{feedback}: jumps of a sixteenth of the travel or more: {jumps:?} in {travel} m");
    assert!(
        jumps.len() <= 2,
        "{feedback}: {} jumps of a sixteenth of the travel or more ({jumps:?} in {travel} m)",
        jumps.len()
    );
    // While the block pushed back, the proxy rested on its face, short of the finger.
    assert!(proxy_x < pointers[0].pose.position.x - 1e-3, "{proxy_x}");
}

/// Two devices' haptic threads in one world (the shipped `two-hands` scene, stepped by the
/// daemon's world thread), each pressing the block from its side: their ticks take the
/// world's updates, render the block under their finger and hand back what their hand did
/// without allocating, both at once.
#[test]
fn two_haptic_threads_ticking_one_shared_world_do_not_allocate() {
    use hapticd::shared_scene::{self, Host};
    let path = support::repo_dir().join("config/scenes/two-hands.yaml");
    let world = hapticd::plugin_scene::load_world(
        &support::plugin_path("hapticd-scene-rapier"),
        Some(&path),
        2,
    )
    .unwrap()
    .expect("a multi-rate world");
    // Each finger starts outside the block (faces at x = ±0.03) and is pressed 5 mm in,
    // moving in (the world looks for surfaces as far around a finger as it moves).
    let sides = [-1.0, 1.0];
    let outside = sides.map(|side| resting_at(DVec3::new(side * 0.04, 0.0, 0.1)));
    let hosts = [
        Host {
            name: "left",
            pointers: &outside[0],
            rate: 1000.0,
        },
        Host {
            name: "right",
            pointers: &outside[1],
            rate: 1000.0,
        },
    ];
    let (scenes, world) = shared_scene::start(world, &hosts).unwrap();
    let results: Vec<(usize, f64)> = std::thread::scope(|scope| {
        let threads: Vec<_> = scenes
            .into_iter()
            .zip(sides)
            .zip(&outside)
            .map(|((mut scene, side), outside)| {
                scope.spawn(move || {
                    let pressing = [Pointer {
                        pose: Pose {
                            position: DVec3::new(side * 0.025, 0.0, 0.1),
                            ..Pose::default()
                        },
                        velocity: DVec3::new(-side * 0.05, 0.0, 0.0),
                    }];
                    let mut wrenches = [Wrench::ZERO];
                    let tick = std::time::Duration::from_millis(1);
                    // The world's first update reaches the scene through its link.
                    let started = std::time::Instant::now();
                    while !scene.render(outside, 1e-3, &mut wrenches) {
                        assert!(started.elapsed().as_secs() < 10, "no world");
                        std::thread::sleep(tick);
                    }
                    let mut bodies = [HapticdBodyPose::default(); 4];
                    let mut felt = 0.0f64;
                    let first = std::time::Instant::now();
                    let n = allocations_in(|| {
                        for k in 1..=400u32 {
                            assert!(scene.render(&pressing, 1e-3, &mut wrenches));
                            scene.write_bodies(&mut bodies);
                            felt = felt.max(side * wrenches[0].force.x);
                            let deadline = first + tick * k;
                            if let Some(rest) =
                                deadline.checked_duration_since(std::time::Instant::now())
                            {
                                std::thread::sleep(rest);
                            }
                        }
                    });
                    (n, felt)
                })
            })
            .collect();
        threads.into_iter().map(|t| t.join().unwrap()).collect()
    });
    drop(world);
    for (side, (n, felt)) in ["left", "right"].iter().zip(&results) {
        assert_eq!(*n, 0, "{side}: {n} allocations in 400 ticks");
        // Pressed 5 mm into the block, each finger is pushed back out of it.
        assert!(
            *felt > 1.0,
            "{side}: the block pushed back {felt} N at most"
        );
    }
}

/// One pointer resting at `position`.
fn resting_at(position: DVec3) -> [Pointer; 1] {
    [Pointer {
        pose: Pose {
            position,
            ..Pose::default()
        },
        velocity: DVec3::ZERO,
    }]
}

/// The shipped blocks scene on the penalty plugin, through the real loader, for `pointers`.
fn penalty_blocks(pointers: &[Pointer]) -> Box<dyn Scene> {
    hapticd::plugin_scene::load(
        &support::plugin_path("hapticd-scene-penalty"),
        Some(&support::repo_dir().join("config/scenes/blocks.yaml")),
        pointers,
    )
    .unwrap()
}

/// A direct scene's picture through the real loader: the penalty plugin writes its bodies'
/// poses, the pointer's solid last, without allocating.
#[test]
fn the_bodies_of_a_penalty_plugin_are_pictured_without_allocating() {
    let pointers = resting_at(DVec3::new(0.0, 0.05, 0.0));
    let mut scene = penalty_blocks(&pointers);
    let mut wrenches = [Wrench::ZERO];
    let mut bodies = [HapticdBodyPose::default(); 16];
    let mut count = 0;
    let n = allocations_in(|| {
        for _ in 0..100 {
            assert!(scene.render(&pointers, 1e-3, &mut wrenches));
            count = scene.write_bodies(&mut bodies);
        }
    });
    assert_eq!(n, 0, "{n} allocations in 100 ticks");
    // Seven bodies in the file, then the pointer's solid, at the grip.
    assert_eq!(count, 8);
    assert_eq!(bodies[0].position, [0.0, -0.05, 0.0], "the fixed table");
    assert!((DVec3::from(bodies[7].position) - pointers[0].pose.position).length() < 1e-9);
    // Only as many as asked for are written.
    let mut two = [HapticdBodyPose::default(); 2];
    assert_eq!(scene.write_bodies(&mut two), 8);
    assert_eq!(two[1], bodies[1]);
}

/// Changes from outside and contact events through the real loader: the haptic thread
/// carries out every kind of scene command (a pose only once "quiet") and says what the
/// pointer touches, allocating nothing, while another thread sends the commands.
#[test]
fn scene_commands_and_touches_of_a_penalty_plugin_do_not_allocate() {
    use hapticd_plugin_api::*;
    // The pointer's cube pressed 2 mm into the table, clear of the blocks.
    let pointers = resting_at(DVec3::new(0.0, -0.027, -0.1));
    let mut scene = penalty_blocks(&pointers);
    let mut control = scene.take_control().expect("the penalty plugin is driven");
    let sender = std::thread::spawn(move || {
        let mut command = |kind, fill: &dyn Fn(&mut HapticdSceneCommand)| {
            let mut c = HapticdSceneCommand::new(kind, 1);
            fill(&mut c);
            control.send(c).unwrap()
        };
        command(HAPTICD_COMMAND_QUERY, &|_| {});
        command(HAPTICD_COMMAND_SET_VELOCITY, &|c| {
            c.vector = [0.01, 0.0, 0.0]
        });
        command(HAPTICD_COMMAND_IMPULSE, &|c| c.vector = [0.0, 0.001, 0.0]);
        command(HAPTICD_COMMAND_SET_FORCE, &|c| c.vector = [0.0, 0.1, 0.0]);
        command(HAPTICD_COMMAND_SET_MASS, &|c| c.value = 0.02);
        command(HAPTICD_COMMAND_SET_FRICTION, &|c| c.value = 0.2);
        command(HAPTICD_COMMAND_SET_POSE, &|c| {
            c.position = [0.035, 0.0, 0.0]
        })
    });
    let mut wrenches = [Wrench::ZERO];
    let mut touches = [hapticd_core::scene::Touch::NONE];
    let mut quiets = 0;
    let n = allocations_in(|| {
        for _ in 0..2000 {
            if scene.needs_quiet() {
                scene.quiet();
                quiets += 1;
            }
            scene.render(&pointers, 1e-3, &mut wrenches);
            scene.write_touches(&mut touches);
            std::thread::sleep(std::time::Duration::from_micros(200));
        }
    });
    let placed = sender.join().unwrap();
    assert_eq!(n, 0, "{n} allocations in 2000 ticks");
    assert_eq!(quiets, 1, "the pose, and it alone, waited for quiet");
    assert_eq!(placed.position, [0.035, 0.0, 0.0]);
    assert_eq!(placed.mass, 0.02);
    assert!(touches[0].touching && touches[0].body == 0, "{touches:?}");
}

/// The bad-output fixture in `mode`, loaded for one pointer pressed 1 cm into its floor:
/// ticks of 1 ms (slept, so a physics thread keeps its pace) until its output has been
/// refused; the ticks that rendered, the fault and the allocations on this thread.
fn refused_output(mode: &str) -> (usize, Option<OutputFault>, usize) {
    let path =
        support::scratch_root().join(format!("no-allocation-{}-{mode}.scene", std::process::id()));
    std::fs::write(&path, mode).unwrap();
    let pointers = resting_at(DVec3::new(0.0, -0.04, 0.0));
    let mut scene = hapticd::plugin_scene::load(
        &support::plugin_path("hapticd-test-bad-output-scene"),
        Some(&path),
        &pointers,
    )
    .unwrap();
    std::fs::remove_file(&path).unwrap();
    let mut wrenches = [Wrench::ZERO];
    let mut rendered = 0;
    let n = allocations_in(|| {
        // The bad output comes 0.2 s after the press: 2 s is ample.
        for _ in 0..2000 {
            if scene.fault().is_some() {
                break;
            }
            rendered += usize::from(scene.render(&pointers, 1e-3, &mut wrenches));
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    });
    (rendered, scene.fault(), n)
}

#[test]
fn a_plugins_output_is_checked_and_refused_without_allocating() {
    // Direct: the wrench checker every tick, then ±9 N each tick refused after 20.
    let (rendered, fault, n) = refused_output("alternating");
    assert!(
        matches!(fault, Some(OutputFault::ZigZag { axis: 0, .. })),
        "{fault:?}"
    );
    assert_eq!((rendered, n), (219, 0), "ticks rendered, allocations");
    // Multi-rate: the planes are checked in the physics thread; the haptic side takes the
    // reason with the failure.
    let (rendered, fault, n) = refused_output("velocity");
    assert!(
        matches!(fault, Some(OutputFault::SurfaceTooFast { .. })),
        "{fault:?}"
    );
    assert!(rendered > 100, "rendered {rendered} ticks");
    assert_eq!(n, 0, "{n} allocations");
}

/// Surfaces of every material (roughness with a transient, a grating, a height map, a
/// smoothly shaded mesh) touched, slid on and tapped, tick after tick: nothing allocated.
#[test]
fn surface_materials_of_every_kind_rendered_do_not_allocate() {
    let dir = support::shared_scratch("core", "materials-alloc");
    std::fs::copy(
        support::repo_dir().join("config/scenes/meshes/bracket.obj"),
        dir.join("bracket.obj"),
    )
    .unwrap();
    // A 2 × 2 grey picture, written as a PNG by hand is more than this needs: the encoder.
    let picture = std::fs::File::create(dir.join("bumps.png")).unwrap();
    let mut encoder = png::Encoder::new(picture, 2, 2);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(&[0, 255, 128, 64]).unwrap();
    writer.finish().unwrap();
    let text = "name: materials\nshapes:\n  - floor: { height: -0.03 }\n    texture: { kind: \
                roughness, amplitude: 0.5, shortest: 0.0005, longest: 0.01 }\n    transient: { \
                gain: 15, frequency: 300, decay: 0.01 }\n  - box: { centre: [0.03, -0.02, 0], \
                size: [0.02, 0.02, 0.02] }\n    texture: { kind: grating, period: 0.002, \
                amplitude: 0.4 }\n  - sphere: { centre: [-0.03, -0.02, 0], radius: 0.012 }\n    \
                texture: { kind: height_map, file: bumps.png, size: [0.004, 0.004], amplitude: \
                0.3 }\n  - mesh: { file: bracket.obj, centre: [0, -0.02, 0.04], scale: 0.001, \
                shading: smooth }\n";
    let scene = StaticSceneSpec::parse_with_files(
        text,
        &dir.join("materials.yaml"),
        hapticd_mesh::scene_files(),
    )
    .unwrap();
    for m in shipped_mechanisms() {
        let script = format!(
            "hands:\n  {}:\n    - move: {{ to: [-0.04, -0.04, 0], seconds: 0.3 }}\n    \
             - move: {{ to: [0.05, -0.04, 0.05], seconds: 0.8 }}\n    \
             - shake: {{ amplitude: [0, 0.015, 0], frequency: 6, seconds: 0.6 }}\n",
            m.effectors[0].name
        );
        let mut haptic = Session {
            mechanism: m.clone(),
            scene: scene.clone(),
            script: Script::parse(&script, std::path::Path::new("hand.yaml")).unwrap(),
            rate: 1000.0,
            settings: LoopSettings::default(),
        }
        .haptic_loop()
        .unwrap();
        let mut touched = 0;
        let n = allocations_in(|| {
            for _ in 0..1700 {
                touched += usize::from(haptic.tick(1e-3).touches[0].touching);
            }
        });
        assert_eq!(n, 0, "{}: {n} allocations in 1700 ticks", m.name);
        assert!(touched > 300, "{}: touched in {touched} ticks", m.name);
    }
}

/// A physics body's smoothly shaded mesh (the shipped bracket, 1 mm to the unit) looked up
/// and blended where a pointer touches it, beside every face, in a body turned and moved:
/// nothing allocated.
#[test]
fn shading_a_body_of_a_mesh_does_not_allocate() {
    use hapticd_core::haptics::shading::SmoothMesh;
    use hapticd_core::scene::Touch;
    let file = support::repo_dir().join("config/scenes/meshes/bracket.obj");
    let mesh = hapticd_mesh::load(&file, 0.001, hapticd_mesh::Limits::DEFAULT, None).unwrap();
    let vertex = |i: u32| mesh.vertices[i as usize];
    let triangles: Vec<[DVec3; 3]> = mesh.triangles.iter().map(|t| t.map(vertex)).collect();
    let shaded = SmoothMesh::new(&triangles).unwrap();
    let body = Pose {
        position: DVec3::new(0.01, -0.02, 0.03),
        orientation: glam::DQuat::from_rotation_y(0.7),
    };
    let mut turned = 0;
    let n = allocations_in(|| {
        for k in 0..20_000 {
            // Beside a face's corner, off it by up to a few millimetres either way.
            let [a, b, c] = triangles[k % triangles.len()];
            let t = k as f64 * 0.01;
            let normal = (b - a).cross(c - a).normalize_or(DVec3::Y);
            let local = a * 0.8 + b * 0.15 + c * 0.05 + normal * 0.004 * t.sin();
            let touch = Touch {
                touching: true,
                point: body.transform_point(local),
                normal: body.orientation * normal,
                ..Touch::NONE
            };
            let force = touch.normal * 2.0;
            turned += usize::from(shaded.shade(force, &touch, &body) != force);
        }
    });
    assert_eq!(n, 0, "{n} allocations in 20 000 lookups");
    assert!(
        turned > 100,
        "a lookup near a face turns the push: {turned} did"
    );
}

#[test]
fn a_held_parts_god_object_does_not_allocate() {
    use glam::DQuat;
    use hapticctl::parts::{MM, square_peg_and_block};
    use hapticd_core::haptics::god_object::{GodObject, GodObjectParameters, Obstacle};
    // A square peg put into its hole, wobbled there and pulled out: contacts found, solved,
    // warm-started and let go, tick after tick.
    let (peg, _, block) = square_peg_and_block();
    let block = block.mesh();
    let obstacles = [Obstacle {
        mesh: &block,
        position: DVec3::ZERO,
        orientation: DQuat::IDENTITY,
    }];
    let start = DVec3::new(0.0, 15.0 * MM, 0.0);
    let mut god = GodObject::new(peg, start, DQuat::IDENTITY, GodObjectParameters::default());
    // On the clock, as on the haptic thread: its looks at the clock allocate nothing either.
    god.keep_to_the_clock();
    let grip = |tick: usize| {
        let t = tick as f64 * 1e-3;
        let depth = 25.0 * MM * (std::f64::consts::PI * t).sin();
        let wobble = DQuat::from_rotation_z(0.02 * (20.0 * t).sin());
        (start - DVec3::Y * depth, wobble)
    };
    god.update(grip(0), 1e-3, obstacles);
    let (mut lowest, mut touched) = (f64::INFINITY, 0);
    let allocations = allocations_in(|| {
        for tick in 1..1000 {
            god.update(grip(tick), 1e-3, obstacles);
            lowest = lowest.min(god.pose().0.y);
            touched = touched.max(god.contacts().len());
        }
    });
    assert_eq!(allocations, 0);
    // It went into the hole and touched its walls.
    assert!(
        lowest < 0.0 && touched > 0,
        "{lowest} m, {touched} contacts"
    );
}

//! One tick of a device's effects on one effector: one effect, and 64 at once (every kind,
//! over and over), each with the grip moving through them. The bounds: 0.1 µs for
//! one, 5 µs for 64.
//!
//! Run: `make bench`.

use divan::Bencher;
use glam::DVec3;
use hapticd_core::haptics::effects::spec::{EffectSpec, Limits};
use hapticd_core::haptics::effects::{EffectCommand, EffectSet, Grip, MAX_EFFECTS};
use hapticd_core::kinematics::Pose;

fn main() {
    divan::main();
}

/// One of each kind, as a scene file writes them.
const KINDS: [&str; 12] = [
    "{kind: constant, force: [0, 1, 0]}",
    "{kind: ramp, force: [0, 0, 0], to: [1, 0, 0], over: 10}",
    "{kind: sine, direction: [0, 1, 0], frequency: 40, amplitude: 1}",
    "{kind: square, direction: [1, 0, 0], frequency: 5, amplitude: 0.5}",
    "{kind: spring, anchor: [0, 0, 0], axis: [0, 1, 0], stiffness: 100, dead_band: 0.002, saturation: 3}",
    "{kind: damper, damping: 2, region: {sphere: 0.05}}",
    "{kind: inertia, mass: 0.1}",
    "{kind: friction, friction: 0.5, stiffness: 800}",
    "{kind: fixture, shape: {cylinder: [[0, 0, 0], [0, 0.1, 0]], radius: 0.02}, stiffness: 500}",
    "{kind: shape, shape: {box: [0.04, 0.04, 0.04], radius: 0.005}, stiffness: 2000, width: 0.003, easing: smooth}",
    "{kind: magnet, shape: {sphere: 0.02, center: [0.03, 0, 0]}, reach: 0.02, friction: 1}",
    "{kind: rotational_spring, orientation: [1, 0, 0, 0], stiffness: 0.5}",
];

/// A set holding `n` effects, the kinds in turn.
fn set_of(n: usize) -> EffectSet {
    let effectors = ["grip".to_string()];
    let limits = Limits {
        effectors: &effectors,
        max_force: 10.0,
        rate: 1000.0,
        bodies: &[],
    };
    let mut set = EffectSet::new(10.0, 5000.0);
    for k in 0..n {
        let text = KINDS[k % KINDS.len()];
        let path = std::path::Path::new("bench");
        let spec: EffectSpec = hapticd_core::diagnostics::parse_yaml(text, path)
            .unwrap()
            .value;
        let mut f = hapticd_core::diagnostics::Findings::new(path, &|_| None);
        let effect = spec.check("", &limits, &mut f).expect(text);
        set.command(EffectCommand::Add(k as u32, effect)).unwrap();
    }
    // Past every attack.
    for _ in 0..100 {
        set.advance(1e-3);
    }
    set
}

/// One tick of `n` effects with the grip moving (along a circle of 1 cm, laid out first).
fn tick(bencher: Bencher, n: usize) {
    let mut set = set_of(n);
    let grips: Vec<Grip> = (0..1000)
        .map(|k| {
            let t = k as f64 * std::f64::consts::TAU / 1000.0;
            Grip {
                pose: Pose {
                    position: DVec3::new(0.01 * t.sin(), 0.01 * t.cos(), 0.0),
                    ..Pose::default()
                },
                velocity: DVec3::new(0.01 * t.cos(), -0.01 * t.sin(), 0.0),
            }
        })
        .collect();
    let mut k = 0;
    bencher.bench_local(|| {
        k = (k + 1) % grips.len();
        set.advance(1e-3);
        divan::black_box(set.wrenches(0, &grips[k], 1e-3, DVec3::ZERO, &[]))
    });
}

#[divan::bench]
fn one_effect(bencher: Bencher) {
    tick(bencher, 1);
}

#[divan::bench]
fn sixty_four_effects(bencher: Bencher) {
    tick(bencher, MAX_EFFECTS);
}

//! One physics step of a stack of n blocks on a floor (thesis 5.4.2, Fig. 5.10), for the
//! contact-volume penalty method, the deepest-point penalty method and rapier3d (a
//! constraint-based engine), in one run; and one step of the shipped `blocks` scene with two
//! pointers pressing on it (thesis 5.4.7); and one step of a two-finger grasp of a box with
//! the resultant distribution method and the conventional one (thesis 4.5–4.6).
//!
//! Run: `make bench`.

use divan::Bencher;
use glam::{DQuat, DVec3};
use hapticctl::experiments::stack_timing::{DENSITY, DT, SIDE, as_point_contacts, stack};
use hapticd_physics::scene::PenaltyScene;
use rapier3d::prelude::{ColliderBuilder, PhysicsWorld, RigidBodyBuilder, Vector};

#[path = "../support/mod.rs"]
mod support;

const HEIGHTS: [usize; 7] = [1, 2, 5, 10, 20, 50, 100];

fn main() {
    divan::main();
}

/// The stack at rest: it stands until its bodies sleep (half a second still), as rapier's
/// below stand until theirs do.
#[divan::bench(args = HEIGHTS)]
fn volume_penalty(bencher: Bencher, n: usize) {
    let mut world = stack(n);
    for _ in 0..(2.0 / DT) as usize {
        if (1..=n).all(|i| world.is_asleep(i)) {
            break;
        }
        world.step(DT);
    }
    bencher.bench_local(|| world.step(DT));
}

/// The same stack with sleeping turned off: every step computes every contact.
#[divan::bench(args = HEIGHTS)]
fn volume_penalty_awake(bencher: Bencher, n: usize) {
    let mut world = stack(n);
    world.sleeping = false;
    bencher.bench_local(|| world.step(DT));
}

/// Each step starts again from a stack settled on volume contacts (see
/// [`as_point_contacts`]).
#[divan::bench(args = HEIGHTS)]
fn point_penalty(bencher: Bencher, n: usize) {
    let settled = as_point_contacts(&stack(n));
    bencher
        .with_inputs(|| settled.clone())
        .bench_local_refs(|world| world.step(DT));
}

/// rapier's stack of the same blocks, at rest: it stands 2.5 s, past the 2 s its bodies
/// must be still before they sleep.
#[divan::bench(args = HEIGHTS)]
fn rapier3d(bencher: Bencher, n: usize) {
    let mut world = rapier_stack(n, true);
    for _ in 0..(2.5 / DT) as usize {
        world.step();
    }
    bencher.bench_local(|| world.step());
}

/// rapier's stack with sleeping turned off.
#[divan::bench(args = HEIGHTS)]
fn rapier3d_awake(bencher: Bencher, n: usize) {
    let mut world = rapier_stack(n, false);
    for _ in 0..200 {
        world.step();
    }
    bencher.bench_local(|| world.step());
}

/// A rapier world of `n` blocks stacked on a floor, stepped at [`DT`].
fn rapier_stack(n: usize, sleeping: bool) -> PhysicsWorld {
    let mut world = PhysicsWorld::new();
    world.integration_parameters.dt = DT as f32;
    world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(0.0, -0.1, 0.0)),
        ColliderBuilder::cuboid(1.0, 0.1, 1.0),
    );
    let half = (SIDE / 2.0) as f32;
    for i in 0..n {
        world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, half * (1 + 2 * i) as f32, 0.0))
                .can_sleep(sleeping),
            ColliderBuilder::cuboid(half, half, half).density(DENSITY as f32),
        );
    }
    world
}

/// Thesis 5.4.7: six blocks and a table, one pointer pressing on a block and one on the table.
#[divan::bench]
fn blocks_scene_two_pointers(bencher: Bencher) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../config/scenes/blocks.yaml");
    let mut scene =
        PenaltyScene::load(std::path::Path::new(path), 2).expect("the shipped scene parses");
    let k = scene.first_pointer;
    // 1 cm pointer cubes, 2 mm into the 3 cm block (top at y = 0) and into the table.
    for (pointer, at) in [
        (k, DVec3::new(0.035, 0.003, 0.0)),
        (k + 1, DVec3::new(0.0, -0.027, -0.1)),
    ] {
        scene.world.bodies[pointer].place(at, DQuat::IDENTITY, DVec3::ZERO, DVec3::ZERO);
    }
    // A second of pressing: the blocks no finger reaches come to rest and sleep.
    for _ in 0..(1.0 / scene.dt) as usize {
        scene.world.step(scene.dt);
    }
    bencher.bench_local(|| scene.world.step(scene.dt));
}

/// A 1 kg box held between two fingers, pushed sideways as the fingers move: one grasp step.
#[divan::bench(args = ["distributed", "conventional"])]
fn grasp_two_fingers(bencher: Bencher, method: &str) {
    use hapticd_core::haptics::grasp::{Grasp, GraspSettings, Handheld, Method, Object};
    let settings = GraspSettings::thesis(if method == "distributed" {
        Method::Distributed
    } else {
        Method::Conventional
    });
    let mut grasp = Handheld {
        grasp: Grasp::new(settings),
        object: Object::at_rest(DVec3::new(0.06, 0.1, 0.06), 1.0, DVec3::ZERO),
        gravity: DVec3::new(0.0, -2.0, 0.0),
    };
    let mut t = 0.0f64;
    bencher.bench_local(|| {
        t += 1e-3;
        let c = 0.01 * (6.0 * t).sin();
        let fingers = [
            DVec3::new(c - 0.0275, 0.0, 0.0),
            DVec3::new(c + 0.0275, 0.0, 0.0),
        ];
        grasp.step(&fingers, 1e-3)
    });
}

/// Bodies in the rapier benchmarks: boxes and balls falling into a pile.
const WORLDS: [usize; 6] = [10, 100, 1000, 2000, 5000, 10_000];

/// The rapier world the scene plugin steps (`hapticd_rapier::world::RapierWorld`, which the
/// plugin wraps), of `text`.
fn rapier_world(text: &str) -> hapticd_rapier::world::RapierWorld {
    use hapticd_physics::scene::SceneFile;
    match SceneFile::parse(text, std::path::Path::new("pile.yaml"), 1).unwrap() {
        SceneFile::Rapier(spec) => hapticd_rapier::world::RapierWorld::new(&spec, 1),
        SceneFile::Penalty(_) => unreachable!("a rapier scene"),
    }
}

/// One 60 Hz physics step of a multi-rate scene (thesis Ch. 6) against its number of bodies,
/// a third of a second into their fall into a pile, the pointer's planes included.
#[divan::bench(args = WORLDS, sample_count = 20, sample_size = 1)]
fn rapier_scene_step(bencher: Bencher, n: usize) {
    use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
    use hapticd_plugin_api::{
        HAPTICD_MAX_LOCAL_BODIES, HapticdLocalBody, HapticdPlanes, HapticdPointer,
    };
    let mut world = rapier_world(&support::pile::scene(n, 60.0, 0));
    let pointer = [HapticdPointer {
        position: [0.0, 0.02, 0.0],
        ..HapticdPointer::default()
    }];
    let mut planes = [HapticdPlanes::default()];
    let mut bodies = [HapticdLocalBody::default(); HAPTICD_MAX_LOCAL_BODIES];
    let mut step = || {
        world.step(
            &PhysicsInput {
                dt: 1.0 / 60.0,
                pointers: &pointer,
                proxies: &pointer,
                impulses: &[],
                locals: &[],
            },
            &mut PhysicsOutput {
                planes: &mut planes,
                bodies: &mut bodies,
                body_count: &mut 0,
            },
        )
    };
    for _ in 0..20 {
        step();
    }
    bencher.bench_local(step);
}

/// The intermediate representation (6.3.1) of one pointer at a corner of one layer of
/// bodies on a floor: the same few bodies are within reach however many lie beyond.
#[divan::bench(args = WORLDS)]
fn intermediate_representation(bencher: Bencher, n: usize) {
    use glam::DVec3;
    use hapticd_plugin_api::HapticdPlanes;
    let mut world = rapier_world(&support::pile::scene(n, 60.0, 1));
    let mut planes = HapticdPlanes::default();
    // One step builds the broad phase's tree; the bodies have not moved yet.
    world.advance(1.0 / 60.0);
    let side = (n as f64).sqrt().ceil();
    let corner = DVec3::new(-side * 0.015, 0.0, -side * 0.015);
    world.surfaces_near(corner, &mut planes);
    assert!(planes.count > 0, "nothing near the corner");
    bencher.bench_local(|| world.surfaces_near(corner, &mut planes));
}

/// Touched bodies a haptic tick moves itself under local dynamics (thesis 6.5.4).
const TOUCHED: [usize; 3] = [1, 10, 50];

/// One haptic tick of `n` bodies moved here under the hand, each a block resting on four
/// contacts and pushed: local dynamics' cost per tick.
#[divan::bench(args = TOUCHED)]
fn local_dynamics_tick(bencher: Bencher, n: usize) {
    use hapticd_core::scene::local_dynamics::{Change, LocalBody};
    use hapticd_plugin_api::{HapticdBodyContact, HapticdLocalBody};
    let mut record = HapticdLocalBody {
        orientation: [1.0, 0.0, 0.0, 0.0],
        inverse_mass: 1.0,
        inverse_inertia: glam::DMat3::from_diagonal(DVec3::splat(600.0)).to_cols_array(),
        acceleration: [0.0, -9.81, 0.0],
        contact_count: 4,
        ..HapticdLocalBody::default()
    };
    for (k, (x, z)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .into_iter()
        .enumerate()
    {
        record.contacts[k] = HapticdBodyContact {
            point: [0.05 * x, -0.05, 0.05 * z],
            normal: [0.0, 1.0, 0.0],
            gap: 0.0,
            friction: 0.3,
        };
    }
    let mut bodies: Vec<LocalBody> = (0..n)
        .map(|_| LocalBody::new((&record, None), &Change::default(), 0.05, None).unwrap())
        .collect();
    bencher.bench_local(|| {
        for body in &mut bodies {
            body.step(
                DVec3::new(5.0, -2.0, 0.0),
                DVec3::new(0.0, 0.01, 0.0),
                &[],
                1e-3,
            );
        }
    });
}

/// The impulse path's work for the same `n` touched objects per tick: the force summed into
/// each one's impulse and weighted point (the physics moves them later).
#[divan::bench(args = TOUCHED)]
fn impulse_sum_tick(bencher: Bencher, n: usize) {
    let mut sums = vec![(DVec3::ZERO, DVec3::ZERO, 0.0f64); n];
    let (force, point) = (DVec3::new(5.0, -2.0, 0.0), DVec3::new(0.01, 0.05, 0.0));
    bencher.bench_local(|| {
        for sum in &mut sums {
            let magnitude = divan::black_box(force).length() * 1e-3;
            sum.0 -= force * 1e-3;
            sum.1 += point * magnitude;
            sum.2 += magnitude;
        }
    });
}

//! One physics step of a stack of n blocks on a floor (thesis 5.4.2, Fig. 5.10), for the
//! contact-volume penalty method, the deepest-point penalty method and rapier3d (a
//! constraint-based engine), in one run; and one step of the shipped `blocks` scene with two
//! pointers pressing on it (thesis 5.4.7).
//!
//! Run: `make bench`.

use divan::Bencher;
use glam::{DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::friction::FrictionParameters;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::scene::PenaltyScene;
use hapticd_physics::world::{ContactModel, Material, World};
use rapier3d::prelude::{ColliderBuilder, PhysicsWorld, RigidBodyBuilder, Vector};

const HEIGHTS: [usize; 7] = [1, 2, 5, 10, 20, 50, 100];
const SIDE: f64 = 0.1;
const DENSITY: f64 = 1000.0;
/// Stiff enough for 100 blocks to stand (k > 6·ρ·g·(n − 1)²), with a step short enough
/// for that stiffness.
const K: f64 = 1e9;
const DT: f64 = 2e-4;

fn main() {
    divan::main();
}

/// A stack of `n` blocks, settled for 40 ms so every contact is established.
fn stack(n: usize) -> World {
    let area = SIDE * SIDE;
    let mass = DENSITY * SIDE.powi(3);
    let critical = 2.0 * (K * area * mass).sqrt() / area;
    let floor = Polyhedron::cuboid(DVec3::new(1.0, 0.1, 1.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.1, 0.0));
    let mut bodies = vec![Body::new(&floor, 1000.0, true)];
    for i in 0..n {
        let block = Polyhedron::cuboid(DVec3::splat(SIDE / 2.0)).transformed(
            DQuat::IDENTITY,
            DVec3::new(0.0, SIDE / 2.0 + SIDE * i as f64, 0.0),
        );
        bodies.push(Body::new(&block, DENSITY, false));
    }
    let mut world = World::new(
        bodies,
        DVec3::new(0.0, -9.81, 0.0),
        Material {
            stiffness: K,
            damping: critical,
            friction: FrictionParameters {
                static_coefficient: 0.6,
                dynamic_coefficient: 0.5,
                stiffness: K,
                damping: critical,
                slip_speed: 1e-3,
            },
            model: ContactModel::Volume,
        },
    );
    for _ in 0..200 {
        world.step(DT);
    }
    world
}

#[divan::bench(args = HEIGHTS)]
fn volume_penalty(bencher: Bencher, n: usize) {
    let mut world = stack(n);
    bencher.bench_local(|| world.step(DT));
}

/// The deepest point cannot hold a stack (thesis 5.4.2: its 13 blocks fall after 1.8 s;
/// these, stiffer, topple at once), so each step starts again from a stack settled on
/// volume contacts.
#[divan::bench(args = HEIGHTS)]
fn point_penalty(bencher: Bencher, n: usize) {
    let mut settled = stack(n);
    settled.material.stiffness = K * SIDE * SIDE;
    settled.material.damping *= SIDE * SIDE;
    settled.material.model = ContactModel::Point;
    bencher
        .with_inputs(|| settled.clone())
        .bench_local_refs(|world| world.step(DT));
}

#[divan::bench(args = HEIGHTS)]
fn rapier3d(bencher: Bencher, n: usize) {
    let mut world = PhysicsWorld::new();
    world.integration_parameters.dt = DT as f32;
    world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(0.0, -0.1, 0.0)),
        ColliderBuilder::cuboid(1.0, 0.1, 1.0),
    );
    let half = (SIDE / 2.0) as f32;
    for i in 0..n {
        world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(
                0.0,
                half * (1 + 2 * i) as f32,
                0.0,
            )),
            ColliderBuilder::cuboid(half, half, half).density(DENSITY as f32),
        );
    }
    for _ in 0..200 {
        world.step();
    }
    bencher.bench_local(|| world.step());
}

/// Thesis 5.4.7: six blocks and a table, one pointer pressing on a block and one on the table.
#[divan::bench]
fn blocks_scene_two_pointers(bencher: Bencher) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../config/scenes/blocks.yaml");
    let text = std::fs::read_to_string(path).expect("the shipped scene");
    let mut scene = PenaltyScene::parse(&text, 2).expect("the shipped scene parses");
    let k = scene.first_pointer;
    // 1 cm pointer cubes, 2 mm into the 3 cm block (top at y = 0) and into the table.
    for (pointer, at) in [
        (k, DVec3::new(0.035, 0.003, 0.0)),
        (k + 1, DVec3::new(0.0, -0.027, -0.1)),
    ] {
        scene.world.bodies[pointer].place(at, DQuat::IDENTITY, DVec3::ZERO, DVec3::ZERO);
    }
    for _ in 0..400 {
        scene.world.step(scene.dt);
    }
    bencher.bench_local(|| scene.world.step(scene.dt));
}

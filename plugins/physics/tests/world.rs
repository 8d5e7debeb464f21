//! Bodies in contact under the contact-volume penalty method.

use glam::{DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::world::{Material, World};

const G: f64 = 9.81;

fn floor() -> Body {
    let slab = Polyhedron::cuboid(DVec3::new(2.0, 0.5, 2.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
    Body::new(&slab, 1000.0, true)
}

#[test]
fn a_resting_box_settles_at_the_depth_that_carries_its_weight_without_drift_or_spin() {
    // A 0.2 m cube of 1 kg set on the floor (top at y = 0), with critical normal damping.
    let (side, mass, k) = (0.2, 1.0, 1e6);
    let area = side * side;
    let cube = Polyhedron::cuboid(DVec3::splat(side / 2.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.03, side / 2.0, -0.02));
    let damping = 2.0 * (k * area * mass).sqrt() / area;
    let mut world = World::new(
        vec![floor(), Body::new(&cube, mass / side.powi(3), false)],
        DVec3::new(0.0, -G, 0.0),
        Material {
            stiffness: k,
            damping,
            friction: 0.5,
            slip_speed: 0.05,
        },
    );
    for _ in 0..10_000 {
        world.step(1e-3);
    }
    let body = &world.bodies[1];
    let depth = side / 2.0 - body.position.y;
    let expected = mass * G / (k * area);
    assert!(
        (depth - expected).abs() < 0.01 * expected,
        "depth {depth} vs {expected}"
    );
    let drift = (body.position - DVec3::new(0.03, body.position.y, -0.02)).length();
    assert!(drift < 1e-9, "drift {drift}");
    assert!(body.spin.length() < 1e-9 && body.orientation.angle_between(DQuat::IDENTITY) < 1e-9);
    assert!(body.velocity.length() < 1e-9);
}

#[test]
fn a_block_sliding_on_the_floor_decelerates_at_mu_g() {
    let (side, mass, k, mu) = (0.2, 1.0, 1e6, 0.4);
    let area = side * side;
    let block = Polyhedron::cuboid(DVec3::splat(side / 2.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, side / 2.0, 0.0));
    let mut world = World::new(
        vec![floor(), Body::new(&block, mass / side.powi(3), false)],
        DVec3::new(0.0, -G, 0.0),
        Material {
            stiffness: k,
            damping: 2.0 * (k * area * mass).sqrt() / area,
            friction: mu,
            slip_speed: 0.01,
        },
    );
    // Settle on the floor, then slide along x at 1 m/s.
    for _ in 0..1000 {
        world.step(1e-4);
    }
    world.bodies[1].velocity.x = 1.0;
    for _ in 0..1000 {
        world.step(1e-4);
    }
    let deceleration = (1.0 - world.bodies[1].velocity.x) / 0.1;
    assert!(
        (deceleration - mu * G).abs() < 0.02 * mu * G,
        "{deceleration} vs {}",
        mu * G
    );
    // It slides straight, without turning.
    assert!(world.bodies[1].velocity.z.abs() < 1e-9 && world.bodies[1].spin.y.abs() < 1e-6);
}

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

//! Static friction holds a block on a slope right up to the friction angle, whatever the
//! block's shape, the friction damping and how suddenly the slope appears, and lets go just
//! past it, sliding at the kinetic rate.

use glam::{DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::friction::FrictionParameters;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::world::{ContactModel, Material, World};

const G: f64 = 9.81;
const MASS: f64 = 1.0;
const K: f64 = 1e6;
const DT: f64 = 1e-4;
const MU0: f64 = 0.5;
const MU: f64 = 0.4;

fn floor() -> Body {
    let slab = Polyhedron::cuboid(DVec3::new(4.0, 0.5, 4.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
    Body::new(&slab, 1000.0, true)
}

/// Gravity of an incline of slope `angle` (the floor stays flat; gravity tilts down +x).
fn incline(angle: f64) -> DVec3 {
    G * DVec3::new(angle.sin(), -angle.cos(), 0.0)
}

/// A block of `size` (full extents) and 1 kg resting on the floor at the depth that carries
/// it, critically damped in the normal direction, its friction springs damped `damping`
/// times critically.
fn block_on_floor(size: DVec3, damping: f64) -> World {
    let area = size.x * size.z;
    let block = Polyhedron::cuboid(size / 2.0)
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, size.y / 2.0, 0.0));
    let critical = 2.0 * (K * area * MASS).sqrt() / area;
    let mut world = World::new(
        vec![
            floor(),
            Body::new(&block, MASS / (size.x * size.y * size.z), false),
        ],
        DVec3::new(0.0, -G, 0.0),
        Material {
            stiffness: K,
            damping: critical,
            friction: FrictionParameters {
                static_coefficient: MU0,
                dynamic_coefficient: MU,
                stiffness: K,
                damping: damping * critical,
                slip_speed: 1e-3,
            },
            model: ContactModel::Volume,
            scaling: None,
        },
    );
    // Watch it move throughout: a sleeping block would hold by not being stepped.
    world.sleeping = false;
    for _ in 0..3000 {
        world.step(DT);
    }
    world
}

/// The middle of the block's base.
fn base(world: &World, height: f64) -> DVec3 {
    let b = &world.bodies[1];
    b.position + b.orientation * DVec3::new(0.0, -height / 2.0, 0.0)
}

/// Tilt `world`'s gravity to `angle`, at once or evenly over `ramp` seconds.
fn tilt(world: &mut World, angle: f64, ramp: f64) {
    let steps = (ramp / DT).round() as usize;
    for s in 1..=steps {
        world.gravity = incline(angle * s as f64 / steps as f64);
        world.step(DT);
    }
    world.gravity = incline(angle);
}

/// Cube, plate and tall block; friction damped critically and three times over.
fn cases() -> Vec<(&'static str, DVec3, f64)> {
    let shapes = [
        ("cube", DVec3::splat(0.2)),
        ("plate", DVec3::new(0.4, 0.1, 0.4)),
        ("tall block", DVec3::new(0.2, 0.3, 0.2)),
    ];
    shapes
        .into_iter()
        .flat_map(|(name, size)| [1.0, 3.0].map(|d| (name, size, d)))
        .collect()
}

#[test]
fn below_the_friction_angle_a_block_stays_put() {
    let friction_angle = MU0.atan();
    let mut failures = Vec::new();
    for (name, size, damping) in cases() {
        for fraction in [0.9, 0.95, 0.99] {
            for ramp in [0.0, 0.5] {
                let mut world = block_on_floor(size, damping);
                tilt(&mut world, fraction * friction_angle, ramp);
                let start = base(&world, size.y);
                for _ in 0..(3.0 / DT) as usize {
                    world.step(DT);
                }
                let creep = (base(&world, size.y) - start).length();
                if creep >= 1e-3 || !world.is_finite() {
                    failures.push(format!(
                        "{name}, damping {damping}, {fraction} of the angle, ramp {ramp} s: \
                         crept {creep} m"
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn past_the_friction_angle_a_block_slides_at_the_kinetic_rate() {
    let angle = 1.01 * MU0.atan();
    let expected = G * (angle.sin() - MU * angle.cos());
    let mut failures = Vec::new();
    for (name, size, damping) in cases() {
        for ramp in [0.0, 0.5] {
            let mut world = block_on_floor(size, damping);
            tilt(&mut world, angle, ramp);
            // It breaks loose within a second (a tall block leans into its edge first)...
            let start = base(&world, size.y);
            let mut waited = 0.0;
            while (base(&world, size.y) - start).length() < 5e-3 && waited < 1.0 {
                world.step(DT);
                waited += DT;
            }
            if waited >= 1.0 {
                failures.push(format!("{name}, damping {damping}, ramp {ramp} s: held"));
                continue;
            }
            // ...and then slides at the kinetic rate.
            let v0 = world.bodies[1].velocity.x;
            for _ in 0..5000 {
                world.step(DT);
            }
            let acceleration = (world.bodies[1].velocity.x - v0) / 0.5;
            if (acceleration - expected).abs() >= 0.03 * expected {
                failures.push(format!(
                    "{name}, damping {damping}, ramp {ramp} s: {acceleration} m/s² against \
                     {expected}"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

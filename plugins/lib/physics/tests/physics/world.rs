//! Bodies in contact under the contact-volume penalty method: resting, sliding, and held or
//! released by static friction on an incline.

use glam::{DMat3, DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::friction::FrictionParameters;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::world::{ContactModel, Material, World};

const G: f64 = 9.81;
const SIDE: f64 = 0.2;
const MASS: f64 = 1.0;
const K: f64 = 1e6;

fn floor() -> Body {
    let slab = Polyhedron::cuboid(DVec3::new(2.0, 0.5, 2.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
    Body::new(&slab, 1000.0, true)
}

/// A 0.2 m cube of 1 kg standing on the floor at (x, z), critically damped in the normal
/// direction, with friction μ0 / μ, under `gravity`.
fn cube_on_floor(x: f64, z: f64, (mu0, mu): (f64, f64), gravity: DVec3) -> World {
    let area = SIDE * SIDE;
    let cube = Polyhedron::cuboid(DVec3::splat(SIDE / 2.0))
        .transformed(DQuat::IDENTITY, DVec3::new(x, SIDE / 2.0, z));
    let critical = 2.0 * (K * area * MASS).sqrt() / area;
    World::new(
        vec![floor(), Body::new(&cube, MASS / SIDE.powi(3), false)],
        gravity,
        Material {
            stiffness: K,
            damping: critical,
            friction: FrictionParameters {
                static_coefficient: mu0,
                dynamic_coefficient: mu,
                stiffness: K,
                damping: critical,
                slip_speed: 1e-3,
            },
            model: ContactModel::Volume,
            scaling: None,
        },
    )
}

#[test]
fn a_resting_box_settles_at_the_depth_that_carries_its_weight_without_drift_or_spin() {
    let mut world = cube_on_floor(0.03, -0.02, (0.5, 0.4), DVec3::new(0.0, -G, 0.0));
    for _ in 0..10_000 {
        world.step(1e-3);
    }
    let body = &world.bodies[1];
    let depth = SIDE / 2.0 - body.position.y;
    let expected = MASS * G / (K * SIDE * SIDE);
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
    let mu = 0.4;
    let mut world = cube_on_floor(0.0, 0.0, (0.5, mu), DVec3::new(0.0, -G, 0.0));
    for _ in 0..1000 {
        world.step(1e-4);
    }
    world.bodies[1].velocity.x = 1.0;
    // Let the pitching the sudden start excites die out, then measure over 0.1 s.
    for _ in 0..500 {
        world.step(1e-4);
    }
    let v0 = world.bodies[1].velocity.x;
    for _ in 0..1000 {
        world.step(1e-4);
    }
    let deceleration = (v0 - world.bodies[1].velocity.x) / 0.1;
    assert!(
        (deceleration - mu * G).abs() < 0.02 * mu * G,
        "{deceleration} vs {}",
        mu * G
    );
    // It slides straight, without turning, and comes to rest.
    assert!(world.bodies[1].velocity.z.abs() < 1e-9 && world.bodies[1].spin.y.abs() < 1e-6);
    for _ in 0..3000 {
        world.step(1e-4);
    }
    assert!(
        world.bodies[1].velocity.length() < 1e-3,
        "{}",
        world.bodies[1].velocity
    );
}

/// Gravity of an incline of slope `angle` (the floor stays flat; gravity tilts down +x).
fn incline(angle: f64) -> DVec3 {
    G * DVec3::new(angle.sin(), -angle.cos(), 0.0)
}

#[test]
fn on_an_incline_below_the_friction_angle_the_block_sticks() {
    let (mu0, mu) = (0.5, 0.4);
    let angle = 0.3f64.atan(); // tan θ = 0.3 < μ0
    let mut world = cube_on_floor(0.0, 0.0, (mu0, mu), DVec3::new(0.0, -G, 0.0));
    for _ in 0..3000 {
        world.step(1e-4);
    }
    world.gravity = incline(angle);
    // The block leans (the contact is elastic) and then stays put.
    for _ in 0..10_000 {
        world.step(1e-4);
    }
    let settled = world.bodies[1].position;
    for _ in 0..10_000 {
        world.step(1e-4);
    }
    let moved = (world.bodies[1].position - settled).length();
    assert!(moved < 1e-6, "still moving: {moved} m in a second");
    assert!((settled.x).abs() < 1e-3, "slid to {}", settled.x);
}

#[test]
fn on_an_incline_above_the_friction_angle_the_block_slides_at_the_kinetic_rate() {
    let (mu0, mu) = (0.5, 0.4);
    let angle = 0.7f64.atan(); // tan θ = 0.7 > μ0
    let mut world = cube_on_floor(0.0, 0.0, (mu0, mu), DVec3::new(0.0, -G, 0.0));
    for _ in 0..3000 {
        world.step(1e-4);
    }
    world.gravity = incline(angle);
    for _ in 0..3000 {
        world.step(1e-4);
    }
    let v0 = world.bodies[1].velocity.x;
    for _ in 0..5000 {
        world.step(1e-4);
    }
    let acceleration = (world.bodies[1].velocity.x - v0) / 0.5;
    let expected = G * (angle.sin() - mu * angle.cos());
    assert!(
        (acceleration - expected).abs() < 0.02 * expected,
        "{acceleration} vs {expected}"
    );
}

/// The largest spin of a box set down flat on the floor, over the third second.
fn late_spin(model: ContactModel) -> f64 {
    let area = SIDE * SIDE;
    let (k, b) = match model {
        ContactModel::Volume => (K, 2.0 * (K * area * MASS).sqrt() / area),
        ContactModel::Point => (K * area, 2.0 * (K * area * MASS).sqrt()),
    };
    let cube = Polyhedron::cuboid(DVec3::splat(SIDE / 2.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, SIDE / 2.0 + 0.01, 0.0));
    let mut world = World::new(
        vec![floor(), Body::new(&cube, MASS / SIDE.powi(3), false)],
        DVec3::new(0.0, -G, 0.0),
        Material {
            stiffness: k,
            damping: b,
            friction: FrictionParameters {
                static_coefficient: 0.5,
                dynamic_coefficient: 0.4,
                stiffness: K,
                damping: b,
                slip_speed: 1e-3,
            },
            model,
            scaling: None,
        },
    );
    let mut spin: f64 = 0.0;
    for step in 0..30_000 {
        world.step(1e-4);
        if step >= 20_000 {
            spin = spin.max(world.bodies[1].spin.length());
        }
    }
    spin
}

#[test]
fn a_box_rests_still_on_volume_contact_but_rocks_on_its_deepest_point() {
    // Thesis Fig. 5.1: with the deepest point alone the contact point jumps between corners
    // and the torque with it, so the box never settles.
    assert!(late_spin(ContactModel::Volume) < 1e-6);
    assert!(late_spin(ContactModel::Point) > 1e-2);
}

/// Thesis Fig. 5.11: a 2 m cube of 1 kg, tilted 0.1 rad about z, dropped from 1 m onto the
/// floor with k = 1000, b = 50 and a 10 ms step. Returns its angular momentum about z at
/// every step and the lowest normal contact force it ever felt.
fn cube_drop(model: ContactModel, seconds: f64) -> (Vec<f64>, f64) {
    let dt = 0.01;
    let slab = Polyhedron::cuboid(DVec3::new(10.0, 0.5, 10.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
    let cube = Polyhedron::cuboid(DVec3::ONE)
        .transformed(DQuat::from_rotation_z(0.1), DVec3::new(0.0, 2.0, 0.0));
    let mut world = World::new(
        vec![
            Body::new(&slab, 1000.0, true),
            Body::new(&cube, 1.0 / 8.0, false),
        ],
        DVec3::new(0.0, -9.8, 0.0),
        Material {
            stiffness: 1000.0,
            damping: 50.0,
            friction: FrictionParameters {
                static_coefficient: 0.5,
                dynamic_coefficient: 0.4,
                stiffness: 1000.0,
                damping: 50.0,
                slip_speed: 1e-3,
            },
            model,
            scaling: None,
        },
    );
    let mut momentum = Vec::new();
    let mut least_push = f64::INFINITY;
    for _ in 0..(seconds / dt) as usize {
        world.step(dt);
        let body = &world.bodies[1];
        let rotation = DMat3::from_quat(body.orientation);
        let inertia = rotation * body.inertia * rotation.transpose();
        momentum.push((inertia * body.spin).z);
        least_push = least_push.min(world.contact_wrench(1).force.y);
    }
    (momentum, least_push)
}

fn largest(values: &[f64]) -> f64 {
    values.iter().fold(0.0, |m, v| m.max(v.abs()))
}

#[test]
fn a_dropped_cube_settles_within_a_second_on_volume_contact_but_not_on_its_deepest_point() {
    // Steps of 10 ms: landing at 0.45 s.
    let (volume, least_push) = cube_drop(ContactModel::Volume, 4.0);
    let peak = largest(&volume);
    let after = largest(&volume[130..]);
    assert!(
        after < 0.02 * peak,
        "volume: {after} after 1.3 s, peak {peak}"
    );
    assert!(least_push >= -1e-9, "the contact pulled: {least_push} N");
    let (point, _) = cube_drop(ContactModel::Point, 4.0);
    // Still swinging after 3 s by more than the volume contact keeps after 1.3 s.
    let late = &point[300..];
    assert!(largest(late) > 0.02 * peak, "point: {} late", largest(late));
    let turns = late.windows(2).filter(|w| w[0] * w[1] < 0.0).count();
    assert!(turns >= 4, "point: {turns} reversals late");
}

/// The shipped spinning top (thesis Fig. 5.16) with `model`, stepped `seconds`: its rate of
/// turn at 1 s and at 3 s, and its final spin and speed.
fn spinning_top(model: ContactModel, seconds: f64) -> (f64, f64, f64, f64, Body) {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/scenes/top.yaml");
    let mut scene = hapticd_physics::scene::PenaltyScene::load(&path, 0).unwrap();
    scene.set_model(model);
    let dt = scene.dt;
    let (mut at_1, mut at_3) = (0.0, 0.0);
    for step in 1..=(seconds / dt).round() as usize {
        scene.world.step(dt);
        let t = step as f64 * dt;
        let spin = scene.world.bodies[1].spin.length();
        if (t - 1.0).abs() < dt / 2.0 {
            at_1 = spin;
        }
        if (t - 3.0).abs() < dt / 2.0 {
            at_3 = spin;
        }
    }
    let top = scene.world.bodies[1].clone();
    (at_1, at_3, top.spin.length(), top.velocity.length(), top)
}

#[test]
fn a_spinning_top_is_braked_by_friction_over_its_tip_and_comes_to_rest() {
    let (at_1, at_3, spin, speed, top) = spinning_top(ContactModel::Volume, 12.0);
    // Standing on its tip, a 45° cone pressed to depth d with pressure k·(d − r) carries
    // N = πkd³/3 = mg and is braked by T = ∫ μ·k(d − r)·r dA = μ·m·g·d/2.
    let (k, mu, g) = (5.0e8, 0.8, 9.81);
    let d = (3.0 * top.mass * g / (std::f64::consts::PI * k)).cbrt();
    // The body frame is the world frame of the file, where the top stands tilted 0.1 rad.
    let axis = top.orientation * (DQuat::from_rotation_z(0.1) * DVec3::Y);
    let inertia = DMat3::from_quat(top.orientation)
        * top.inertia
        * DMat3::from_quat(top.orientation).transpose();
    let i_axis = axis.dot(inertia * axis);
    let expected = mu * top.mass * g * d / 2.0 / i_axis;
    let braking = (at_1 - at_3) / 2.0;
    assert!(
        (braking / expected - 1.0).abs() < 0.05,
        "braked at {braking:.2} rad/s², friction over the tip gives {expected:.2}"
    );
    // Then it falls, rolls on its rim and lies still.
    assert!(
        spin < 0.05 && speed < 1e-3,
        "still turning: {spin} rad/s, {speed} m/s"
    );
}

#[test]
fn on_its_deepest_point_alone_the_top_spins_on_unbraked() {
    let (at_1, at_3, spin, _, _) = spinning_top(ContactModel::Point, 12.0);
    assert!(at_1 - at_3 < 1.0, "braked from {at_1} to {at_3} rad/s");
    assert!(spin > 150.0, "{spin} rad/s");
}

fn block(half: DVec3, centre: DVec3) -> Polyhedron {
    Polyhedron::cuboid(half).transformed(DQuat::IDENTITY, centre)
}

#[test]
fn a_compound_has_the_mass_properties_of_its_union() {
    // Two unit cubes side by side are one 2 × 1 × 1 box, turned and moved.
    let turn = DQuat::from_rotation_y(0.4) * DQuat::from_rotation_x(0.3);
    let at = DVec3::new(0.3, -1.0, 2.0);
    let place = |p: Polyhedron| p.transformed(turn, at);
    let halves = [
        place(block(DVec3::splat(0.5), DVec3::new(-0.5, 0.0, 0.0))),
        place(block(DVec3::splat(0.5), DVec3::new(0.5, 0.0, 0.0))),
    ];
    let whole = Body::new(
        &place(block(DVec3::new(1.0, 0.5, 0.5), DVec3::ZERO)),
        3.0,
        false,
    );
    let compound = Body::compound(&halves, 3.0, false);
    assert!((compound.mass - whole.mass).abs() < 1e-12);
    assert!((compound.position - whole.position).length() < 1e-12);
    let difference = compound.inertia - whole.inertia;
    assert!(difference.abs().to_cols_array().iter().all(|x| *x < 1e-12));
    // An L of two boxes, against the box formula m(b² + c²)/12 and parallel axes.
    let (long, short) = (DVec3::new(1.0, 0.1, 0.1), DVec3::new(0.1, 0.4, 0.1));
    let (c_long, c_short) = (DVec3::new(0.5, 0.05, 0.05), DVec3::new(0.05, 0.3, 0.05));
    let l = Body::compound(
        &[block(long / 2.0, c_long), block(short / 2.0, c_short)],
        1.0,
        false,
    );
    let box_inertia = |size: DVec3| {
        let m = size.x * size.y * size.z;
        let s = size * size;
        DMat3::from_diagonal(DVec3::new(s.y + s.z, s.x + s.z, s.x + s.y) * m / 12.0)
    };
    let (m_long, m_short) = (long.x * long.y * long.z, short.x * short.y * short.z);
    let centroid = (m_long * c_long + m_short * c_short) / (m_long + m_short);
    let shifted = |m: f64, r: DVec3| {
        (DMat3::from_diagonal(DVec3::splat(r.length_squared()))
            - DMat3::from_cols(r * r.x, r * r.y, r * r.z))
            * m
    };
    let exact = box_inertia(long)
        + shifted(m_long, c_long - centroid)
        + box_inertia(short)
        + shifted(m_short, c_short - centroid);
    assert!((l.position - centroid).length() < 1e-12);
    let error = (l.inertia - exact).abs().to_cols_array();
    assert!(
        error.iter().all(|x| *x < 1e-12),
        "{:?} against {exact:?}",
        l.inertia
    );
}

#[test]
fn an_arch_stands_on_its_legs_over_a_block_it_does_not_touch() {
    let text = "name: arch
dt: 0.0001
material: { stiffness: 1.0e6, damping: 3.0e4, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1.0e6, friction_damping: 3.0e4, slip_speed: 0.001 }
bodies:
  - { name: floor, box: [2, 0.5, 2], position: [0, -0.25, 0], fixed: true }
  - name: arch
    pieces:
      - { box: [0.1, 0.3, 0.2], position: [-0.25, -0.05, 0] }
      - { box: [0.1, 0.3, 0.2], position: [0.25, -0.05, 0] }
      - { box: [0.6, 0.1, 0.2], position: [0, 0.15, 0] }
    position: [0, 0.2, 0]
    density: 500
  - { name: block, box: [0.2, 0.2, 0.1], position: [0, 0.1, 0], density: 500 }
";
    let mut scene =
        hapticd_physics::scene::PenaltyScene::parse(text, std::path::Path::new("test.yaml"), 0)
            .unwrap();
    for _ in 0..20000 {
        scene.world.step(scene.dt);
    }
    let (arch, block) = (&scene.world.bodies[1], &scene.world.bodies[2]);
    // Its convex hull would cover the block; its pieces only touch the floor, on two legs.
    let legs = 2.0 * 0.1 * 0.2;
    let bottom = arch.world_pieces()[0]
        .vertices
        .iter()
        .map(|v| v.y)
        .fold(f64::INFINITY, f64::min);
    let expected = arch.mass * G / (1.0e6 * legs);
    assert!(
        ((-bottom) / expected - 1.0).abs() < 0.01,
        "sunk {} m, expected {expected} m",
        -bottom
    );
    assert!(arch.velocity.length() < 1e-4 && arch.spin.length() < 1e-3);
    let block_bottom = block.world_pieces()[0]
        .vertices
        .iter()
        .map(|v| v.y)
        .fold(f64::INFINITY, f64::min);
    // The block carries its own weight only.
    let block_expected = block.mass * G / (1.0e6 * 0.2 * 0.1);
    assert!(((-block_bottom) / block_expected - 1.0).abs() < 0.01);
}

#[test]
fn scaled_by_reduced_mass_and_step_light_and_heavy_boxes_sink_alike() {
    // Stiffness 2·r_s·m/dt² on the mean depth carries m·g at depth g·dt²/(2·r_s), whatever m.
    let (dt, r_s) = (1e-3, 0.05);
    let text = format!(
        "name: scaled
dt: {dt}
material: {{ stiffness: 1, damping: 1, static_friction: 0.5, friction: 0.4,
            friction_stiffness: 1, friction_damping: 1, slip_speed: 0.001,
            scaling: {{ spring: {r_s}, damper: 0.5 }} }}
bodies:
  - {{ name: floor, box: [2, 0.5, 2], position: [0, -0.25, 0], fixed: true }}
  - {{ name: light, box: [0.1, 0.1, 0.1], position: [-0.3, 0.05, 0], density: 100 }}
  - {{ name: heavy, box: [0.1, 0.1, 0.1], position: [0.3, 0.05, 0], density: 10000 }}
"
    );
    let mut scene =
        hapticd_physics::scene::PenaltyScene::parse(&text, std::path::Path::new("test.yaml"), 0)
            .unwrap();
    for _ in 0..3000 {
        scene.world.step(dt);
    }
    let expected = G * dt * dt / (2.0 * r_s);
    for body in &scene.world.bodies[1..] {
        let bottom = body.world_pieces()[0]
            .vertices
            .iter()
            .map(|v| v.y)
            .fold(f64::INFINITY, f64::min);
        assert!(
            (-bottom / expected - 1.0).abs() < 0.01,
            "{} kg sank {} m, expected {expected} m",
            body.mass,
            -bottom
        );
        assert!(body.velocity.length() < 1e-6 && body.spin.length() < 1e-6);
    }
}

/// Ten 1 kg blocks of 10 cm stacked with the stiffness thesis 5.4.2 gives a stack of 100
/// (10⁹ N/m³) at a 0.2 ms step: the stiff contacts must not ring. Friction springs stiffer
/// than the step allows, or dampers that each stop the whole motion of a block between two
/// contacts, kept every block shaking at centimetres a second for ever.
#[test]
fn a_stiff_stack_comes_to_rest() {
    let (side, density, stiffness, dt) = (0.1, 1000.0, 1e9, 2e-4);
    let area: f64 = side * side;
    let mass = density * side * side * side;
    let critical = 2.0 * (stiffness * area * mass).sqrt() / area;
    let mut bodies = vec![floor()];
    for i in 0..10 {
        let block = Polyhedron::cuboid(DVec3::splat(side / 2.0)).transformed(
            DQuat::IDENTITY,
            DVec3::new(0.0, side / 2.0 + side * i as f64, 0.0),
        );
        bodies.push(Body::new(&block, density, false));
    }
    let mut world = World::new(
        bodies,
        DVec3::new(0.0, -G, 0.0),
        Material {
            stiffness,
            damping: critical,
            friction: FrictionParameters {
                static_coefficient: 0.6,
                dynamic_coefficient: 0.5,
                stiffness,
                damping: critical,
                slip_speed: 1e-3,
            },
            model: ContactModel::Volume,
            scaling: None,
        },
    );
    for _ in 0..(2.0 / dt) as usize {
        world.step(dt);
    }
    for (k, b) in world.bodies.iter().enumerate().skip(1) {
        let (speed, spin) = (b.velocity.length(), b.spin.length());
        assert!(
            speed < 1e-5 && spin < 1e-4,
            "block {k}: {speed} m/s, {spin} rad/s"
        );
        let x = b.position.x.hypot(b.position.z);
        assert!(x < 1e-6, "block {k} moved {x} m sideways");
    }
}

/// A block set down on the floor sleeps once still for half a second, where it would have
/// stayed awake to within a micrometre; a block dropped onto it wakes it, and both sleep
/// again once at rest; tilting gravity wakes them.
#[test]
fn resting_bodies_sleep_until_something_reaches_them() {
    let dt = 1e-3;
    let mut world = cube_on_floor(0.0, 0.0, (0.5, 0.4), DVec3::new(0.0, -G, 0.0));
    let mut awake = world.clone();
    awake.sleeping = false;
    let mut asleep_at = None;
    for k in 0..2000 {
        world.step(dt);
        awake.step(dt);
        if asleep_at.is_none() && world.is_asleep(1) {
            asleep_at = Some(k as f64 * dt);
        }
    }
    let at = asleep_at.expect("the resting block never slept");
    assert!((0.5..1.5).contains(&at), "asleep at {at} s");
    assert!(!awake.is_asleep(1));
    let apart = (world.bodies[1].position - awake.bodies[1].position).length();
    assert!(
        apart < 1e-6,
        "sleeping moved the block {apart} m from where it rests"
    );
    // A second block dropped from 5 cm above it.
    let mut bodies = world.bodies.clone();
    let dropped = Polyhedron::cuboid(DVec3::splat(SIDE / 2.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, 2.5 * SIDE + 0.05, 0.0));
    bodies.push(Body::new(&dropped, MASS / SIDE.powi(3), false));
    let mut world = World::new(bodies, DVec3::new(0.0, -G, 0.0), world.material);
    // Settle the lower one to sleep again in the new world first.
    let low = world.bodies[1].position.y;
    let mut woke = false;
    for _ in 0..3000 {
        world.step(dt);
        woke |= !world.is_asleep(1) && world.bodies[2].position.y < 1.6 * SIDE;
    }
    assert!(woke, "the falling block did not wake the one it landed on");
    let sunk = low - world.bodies[1].position.y;
    let expected = MASS * G / (K * SIDE * SIDE);
    assert!(
        (sunk - expected).abs() < 0.05 * expected,
        "the lower block carries both: sank {sunk} more, expected {expected}"
    );
    assert!(
        world.is_asleep(1) && world.is_asleep(2),
        "at rest again, they sleep"
    );
    world.gravity = incline(0.7f64.atan());
    world.step(dt);
    assert!(!world.is_asleep(1) && !world.is_asleep(2));
}

#[test]
fn flush_faces_pressed_nanometres_deep_far_from_the_origin_keep_an_upright_normal() {
    // Blocks of 1 kg on contacts of 3·10¹⁰ N/m³ sink 33 nm per block they carry: the
    // search for the normal works on a Minkowski difference ten million times wider than
    // the gap it is moved apart by, at coordinates near 8.5 m. The top block turns on the
    // one below without friction, so the search runs again every few steps.
    let (k, side, dt, base) = (3e10, 0.1, 2.5e-5, 8.4);
    let area = side * side;
    let critical = 2.0 * (k * area * MASS).sqrt() / area;
    let slab = Polyhedron::cuboid(DVec3::new(1.0, 0.1, 1.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, base - 0.1, 0.0));
    let mut bodies = vec![Body::new(&slab, 1000.0, true)];
    let mut bottom = base;
    for carried in [2.0, 1.0] {
        bottom -= carried * MASS * G / (k * area);
        let block = Polyhedron::cuboid(DVec3::splat(side / 2.0))
            .transformed(DQuat::IDENTITY, DVec3::new(0.0, bottom + side / 2.0, 0.0));
        bodies.push(Body::new(&block, MASS / side.powi(3), false));
        bottom += side;
    }
    let mut world = World::new(
        bodies,
        DVec3::new(0.0, -G, 0.0),
        Material {
            stiffness: k,
            damping: critical,
            friction: FrictionParameters {
                static_coefficient: 0.0,
                dynamic_coefficient: 0.0,
                stiffness: k,
                damping: critical,
                slip_speed: 1e-3,
            },
            model: ContactModel::Volume,
            scaling: None,
        },
    );
    world.bodies[2].spin = DVec3::new(0.0, 1.0, 0.0);
    for _ in 0..20_000 {
        world.step(dt);
        for i in 1..=2 {
            let sideways = world.contact_wrench(i).force.reject_from(DVec3::Y).length();
            assert!(
                sideways < 1e-6 * MASS * G,
                "block {i}: {sideways} N sideways"
            );
        }
    }
    assert!(world.bodies[2].spin.y > 0.99, "{}", world.bodies[2].spin);
}

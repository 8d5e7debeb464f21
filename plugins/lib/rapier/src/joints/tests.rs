use super::*;
use crate::world::RapierWorld;
use hapticd_physics::scene::SceneFile;
use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};

fn world(text: &str) -> RapierWorld {
    match SceneFile::parse(text, std::path::Path::new("t.yaml"), 0).unwrap() {
        SceneFile::Rapier(spec) => RapierWorld::new(&spec, 0),
        SceneFile::Penalty(_) => panic!("not a rapier scene"),
    }
}

fn step(w: &mut RapierWorld, dt: f64) {
    assert!(w.step(
        &PhysicsInput {
            dt,
            pointers: &[],
            proxies: &[],
            impulses: &[],
            locals: &[],
        },
        &mut PhysicsOutput {
            planes: &mut [],
            bodies: &mut [],
            body_count: &mut 0,
        },
    ));
}

/// The complete elliptic integral of the first kind K(k), by the arithmetic-geometric mean.
fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0, ((1.0 - k) * (1.0 + k)).sqrt());
    while (a - b).abs() > 1e-15 * a {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    std::f64::consts::PI / (2.0 * a)
}

/// A box `size` (x, y, z edges, m) of `density` hung from the middle of its top edge on a
/// hinge along z, released `start` rad from hanging straight down, at `rate` steps a second.
fn pendulum(size: [f64; 3], density: f64, start: f64, rate: f64) -> String {
    let half = size[1] / 2.0;
    // The box turned by `start` about z around the hinge, which stays at the origin.
    let centre = DVec3::new(half * start.sin(), -half * start.cos(), 0.0);
    let turn = DQuat::from_rotation_z(start);
    format!(
        "name: pendulum\nengine: rapier\nrate: {rate}\nmaterial: {{ static_friction: 0, \
         friction: 0 }}\nbodies:\n  - {{ name: bob, box: {size:?}, density: {density}, position: \
         [{}, {}, 0], orientation: [{}, {}, {}, {}] }}\njoints:\n  - {{ kind: revolute, bodies: \
         [world, bob], anchor: [0, 0, 0], axis: [0, 0, 1] }}\n",
        centre.x, centre.y, turn.w, turn.x, turn.y, turn.z
    )
}

/// The times the hinge's rate crosses zero from above (the swing's far turning points),
/// each found between two steps by linear interpolation.
fn turning_points(w: &mut RapierWorld, rate: f64, seconds: f64) -> Vec<f64> {
    let dt = 1.0 / rate;
    let mut last = w.joint_state(0).velocity;
    let mut times = Vec::new();
    for k in 1..=(seconds * rate).round() as usize {
        step(w, dt);
        let now = w.joint_state(0).velocity;
        if last > 0.0 && now <= 0.0 {
            times.push((k as f64 - 1.0 + last / (last - now)) * dt);
        }
        last = now;
    }
    times
}

/// A physical pendulum released from 10° and from 60° swings with the exact period of a
/// large amplitude, 4·√(I/(m·g·d))·K(sin(θ₀/2)): within 1 % stepped at 1 kHz, 3 % at 60 Hz.
#[test]
fn a_hinged_box_swings_with_the_exact_period_of_its_amplitude() {
    for (size, density) in [([0.02, 0.1, 0.02], 1000.0f64), ([0.05, 0.3, 0.01], 300.0)] {
        let m = density * size[0] * size[1] * size[2];
        let d = size[1] / 2.0;
        // About the hinge: the box's own moment about z, moved out by d.
        let moment = m * (size[0] * size[0] + size[1] * size[1]) / 12.0 + m * d * d;
        for degrees in [10.0f64, 60.0] {
            let start = degrees.to_radians();
            let exact = 4.0 * (moment / (m * 9.81 * d)).sqrt() * elliptic_k((start / 2.0).sin());
            for (rate, within) in [(1000.0, 0.01), (60.0, 0.03)] {
                let mut w = world(&pendulum(size, density, start, rate));
                let times = turning_points(&mut w, rate, 6.0 * exact);
                assert!(times.len() >= 5, "{times:?}");
                let period = (times[times.len() - 1] - times[0]) / (times.len() - 1) as f64;
                println!(
                    "{size:?} from {degrees}° at {rate} Hz: {period:.5} s, exact {exact:.5} s \
                     ({:+.3} %)",
                    100.0 * (period / exact - 1.0)
                );
                assert!((period / exact - 1.0).abs() < within);
            }
        }
    }
}

/// A body's energy, J: kinetic, and potential under gravity −y.
fn energy(w: &RapierWorld, i: usize) -> f64 {
    let b = w.body(i);
    let (inertia, mass) = w.inertia[i];
    let turn = glam::DMat3::from_quat(b.orientation);
    let world = turn * inertia * turn.transpose();
    0.5 * mass * b.velocity.length_squared()
        + 0.5 * b.spin.dot(world * b.spin)
        + mass * 9.81 * b.position.y
}

/// With no damping a pendulum released from 60° keeps its swing's energy: its mean over a
/// period after a minute is within 1 % of the first period's, stepped at 1 kHz and at 60 Hz.
#[test]
fn a_hinged_box_keeps_its_energy_for_a_minute() {
    let (size, density) = ([0.02, 0.1, 0.02], 1000.0f64);
    let start = 60f64.to_radians();
    let m = density * size[0] * size[1] * size[2];
    // The swing's energy: what falling from the start to hanging straight gives.
    let swing = m * 9.81 * size[1] / 2.0 * (1.0 - start.cos());
    for rate in [1000.0, 60.0] {
        let mut w = world(&pendulum(size, density, start, rate));
        let period = (0.56 * rate).round() as usize;
        let mut means = Vec::new();
        let mut sum = 0.0;
        for k in 1..=(60.0 * rate) as usize {
            step(&mut w, 1.0 / rate);
            sum += energy(&w, 0);
            if k % period == 0 {
                means.push(sum / period as f64);
                sum = 0.0;
            }
        }
        let drift = (means[means.len() - 1] - means[0]) / swing;
        println!(
            "at {rate} Hz: the swing's energy drifted {:+.3} % in a minute",
            100.0 * drift
        );
        assert!(drift.abs() < 0.01);
    }
}

/// A door (a slab hinged along one edge) pushed at its handle turns as its moment about the
/// hinge says, (a×r)·J / I_a, not as a free slab would; and pulled by the hand's local
/// change of its motion, by the momentum of that change about the hinge.
#[test]
fn a_door_pushed_at_its_handle_turns_by_its_moment_about_the_hinge() {
    let (w_, h, t, density) = (0.4f64, 0.6, 0.02, 500.0);
    let text = format!(
        "name: door\nengine: rapier\nrate: 60\ngravity: [0, 0, 0]\nmaterial: {{ \
         static_friction: 0, friction: 0 }}\nbodies:\n  - {{ name: door, box: [{w_}, {h}, {t}], \
         density: {density}, position: [{}, 0, 0] }}\njoints:\n  - {{ kind: revolute, bodies: \
         [world, door], anchor: [0, 0, 0], axis: [0, 1, 0] }}\n",
        w_ / 2.0
    );
    let m = density * w_ * h * t;
    let moment = m * (w_ * w_ + t * t) / 12.0 + m * (w_ / 2.0) * (w_ / 2.0);
    let (handle, push) = (DVec3::new(0.35, 0.1, 0.0), DVec3::new(0.0, 0.0, 0.1));
    let mut w = world(&text);
    let impulse = hapticd_plugin_api::HapticdImpulse {
        object: 0,
        impulse: push.to_array(),
        point: handle.to_array(),
    };
    w.apply(&impulse, 10.0);
    // A multibody takes a step's force in over that step and the next (75 % and 25 %,
    // measured): the whole impulse is in after two.
    step(&mut w, 1.0 / 60.0);
    step(&mut w, 1.0 / 60.0);
    let expected = DVec3::Y.cross(handle).dot(push) / moment;
    let rate = w.joint_state(0).velocity;
    println!("pushed: {rate:.6} rad/s, (a×r)·J/I_a {expected:.6} rad/s");
    assert!((rate / expected - 1.0).abs() < 1e-3);
}

/// A door (40 × 60 cm, 2.4 kg) on a hinge that stops at `low` and 1.6 rad.
fn door(rate: f64, low: f64, restitution: f64) -> RapierWorld {
    world(&format!(
        "name: door\nengine: rapier\nrate: {rate}\ngravity: [0, 0, 0]\nmaterial: {{ \
         static_friction: 0, friction: 0 }}\nbodies:\n  - {{ name: door, box: [0.4, 0.6, 0.02], \
         density: 500, position: [0.2, 0, 0] }}\njoints:\n  - {{ kind: revolute, bodies: \
         [world, door], anchor: [0, 0, 0], axis: [0, 1, 0], limits: [{low}, 1.6], restitution: \
         {restitution} }}\n"
    ))
}

/// Pushed shut with 20 N at its handle for two seconds, at 60 Hz and at 1 kHz, the door goes
/// no further than 1° past its stop, and once there it rests: its rate does not flip from
/// step to step.
#[test]
fn a_door_pushed_against_its_stop_stays_within_a_degree_of_it() {
    for rate in [60.0, 1000.0] {
        let mut w = door(rate, 0.0, 0.0);
        let handle = w.bodies[0];
        // Shutting is turning toward −y about y: a push along +z at the handle (x = 0.35).
        let (at, push) = (DVec3::new(0.35, 0.0, 0.0), DVec3::new(0.0, 0.0, 20.0));
        let (mut deepest, mut flips, mut last) = (0.0f64, 0, 0.0f64);
        for k in 0..(2.0 * rate) as usize {
            let dt = 1.0 / rate;
            let com = dvec(w.physics.bodies[handle].center_of_mass());
            w.joints.kick(
                &mut w.physics,
                handle,
                (push * dt, (at - com).cross(push * dt)),
                dt,
            );
            step(&mut w, dt);
            let now = w.joint_state(0);
            deepest = deepest.min(now.position);
            if k as f64 > 0.5 * rate && now.velocity * last < 0.0 && now.velocity.abs() > 1e-3 {
                flips += 1;
            }
            last = now.velocity;
        }
        println!(
            "at {rate} Hz: {:.4}° past the stop, {flips} flips",
            -deepest.to_degrees()
        );
        assert!(deepest > -1f64.to_radians());
        assert_eq!(flips, 0);
    }
}

/// Swung into its stop at 2 rad/s, the door comes off it at `restitution` times that speed.
#[test]
fn a_stop_gives_back_its_restitution_of_the_speed() {
    for e in [0.0, 0.3, 0.8] {
        let mut w = door(60.0, -0.5, e);
        rebound(&mut w.physics, &w.joints.built[0], -2.0);
        let mut off = None;
        for _ in 0..60 {
            step(&mut w, 1.0 / 60.0);
            let now = w.joint_state(0);
            if off.is_none() && now.velocity > 0.0 {
                off = Some(now.velocity);
            }
        }
        let came_off = off.unwrap_or(0.0);
        println!("restitution {e}: in at 2 rad/s, off at {came_off:.4} rad/s");
        assert!((came_off - 2.0 * e).abs() < 1e-3, "{came_off}");
    }
}

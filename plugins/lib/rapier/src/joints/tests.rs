use super::*;
use crate::world::RapierWorld;
use hapticd_physics::scene::SceneFile;

fn world(text: &str) -> RapierWorld {
    match SceneFile::parse(text, std::path::Path::new("t.yaml"), 0).unwrap() {
        SceneFile::Rapier(spec) => RapierWorld::new(&spec, 0),
        SceneFile::Penalty(_) => panic!("not a rapier scene"),
    }
}

fn step(w: &mut RapierWorld, dt: f64) {
    assert!(w.step_untouched(dt));
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

//! Joints in the penalty engine, at the device rate: each locked direction of a joint is a
//! stiff spring and damper between its frames on the two bodies (maximal coordinates), set
//! every step from the pair's effective mass there as the contacts' `scaling:` sets them, so
//! that ω·dt stays within the engine's rule for any masses (√(2·0.05) ≈ 0.32) and the joint
//! is as stiff as the step allows: under a 10 N pull a 1 kg link's joint gives
//! F·dt²/(2·0.05·m) = 6 µm at 4 kHz, and gives it back (no drift). The free coordinate's
//! spring, damper and motor are forces along it; a limit puts a coordinate a step took past it
//! back on it and turns its rate into `restitution` of itself (see [`World::stop_joints`]).

use glam::{DQuat, DVec3};

use super::World;
use crate::body::Body;
use crate::joint::{
    FrameMotion, Joint, JointKind, JointState, MotorTarget, Turns, coordinate, critical_damping,
};

/// A locked direction's spring, as a fraction of what makes ω·dt = 1: 2·SPRING·m/dt².
const SPRING: f64 = 0.05;
/// A locked direction's damper: DAMPER·m/dt (about critical for that spring).
const DAMPER: f64 = 0.4;

/// A joint as the world holds it: its frame on each body (origin and rotation in the body's
/// frame; on the world, in the world), the bodies by index (None: the world).
#[derive(Debug, Clone, PartialEq)]
pub struct Linked {
    /// The joint as the file gives it.
    pub joint: Joint,
    frames: [(DVec3, DQuat); 2],
    /// A hinge's whole turns.
    turns: Turns,
}

impl Linked {
    /// `joint` between `bodies` as they are placed now.
    pub fn new(joint: &Joint, bodies: &[Body]) -> Self {
        let frame = DQuat::from_rotation_arc(DVec3::X, joint.axis);
        let on = |body: Option<usize>| match body {
            Some(i) => {
                let b = &bodies[i];
                let back = b.orientation.inverse();
                (back * (joint.anchor - b.position), back * frame)
            }
            None => (joint.anchor, frame),
        };
        Self {
            joint: joint.clone(),
            frames: [on(joint.bodies.0), on(Some(joint.bodies.1))],
            turns: Turns::default(),
        }
    }

    /// The frame on side `side` as its body (or the world) carries it now.
    fn frame(&self, bodies: &[Body], side: usize) -> FrameMotion {
        let body = match side {
            0 => self.joint.bodies.0,
            _ => Some(self.joint.bodies.1),
        };
        let (at, turn) = self.frames[side];
        match body {
            Some(i) => {
                let b = &bodies[i];
                let origin = b.position + b.orientation * at;
                FrameMotion {
                    origin,
                    turn: b.orientation * turn,
                    velocity: b.velocity_at(origin),
                    spin: b.spin,
                }
            }
            None => FrameMotion {
                origin: at,
                turn,
                velocity: DVec3::ZERO,
                spin: DVec3::ZERO,
            },
        }
    }

    /// Where its coordinate stands now.
    pub fn state(&self, bodies: &[Body]) -> JointState {
        let [first, second] = [0, 1].map(|side| self.frame(bodies, side));
        coordinate(self.joint.kind, &first, &second)
    }

    /// Where the joint stands among `bodies`, a hinge counted in whole turns from load.
    pub fn counted(&self, bodies: &[Body]) -> JointState {
        self.turns.counted(self.joint.kind, self.state(bodies))
    }

    /// Follow a hinge's turns to where `bodies` have it now.
    pub(super) fn follow(&mut self, bodies: &[Body]) {
        if self.joint.kind == JointKind::Revolute {
            let now = self.state(bodies).position;
            self.turns.follow(now);
        }
    }
}

/// How readily body `i` (None: the world) moves along `direction` at `x`, and turns about
/// it.
fn mobility(bodies: &[Body], i: Option<usize>, x: DVec3, direction: DVec3) -> (f64, f64) {
    i.map_or((0.0, 0.0), |i| {
        let b = &bodies[i];
        (
            b.inverse_mass_at(x, direction),
            b.inverse_inertia_about(direction),
        )
    })
}

impl World {
    /// Add each joint's forces for a step of `dt` to the bodies' wrenches (torques about the
    /// origin, as the step takes them).
    pub(super) fn add_joint_wrenches(&mut self, dt: f64) {
        for k in 0..self.joints.len() {
            let link = &self.joints[k];
            let (first, second) = (link.frame(&self.bodies, 0), link.frame(&self.bodies, 1));
            let (force, torque) = joint_wrench(link, &self.bodies, (&first, &second), dt);
            let (a, b) = (link.joint.bodies.0, link.joint.bodies.1);
            let mut push = |i: usize, at: DVec3, sign: f64| {
                if !self.bodies[i].fixed {
                    let w = &mut self.wrenches[i];
                    w.force += force * sign;
                    w.torque += at.cross(force * sign) + torque * sign;
                }
            };
            push(b, second.origin, 1.0);
            if let Some(a) = a {
                push(a, first.origin, -1.0);
            }
        }
    }
}

impl World {
    /// After a step: each coordinate the step took past a limit is put back on it, and its
    /// rate into the limit turned into `restitution` of itself out of it, both shared
    /// between the two bodies by how readily each moves along the coordinate (a stop is
    /// hard: no spring of it is felt, and it gives back exactly what it is told).
    pub(super) fn stop_joints(&mut self) {
        for k in 0..self.joints.len() {
            let link = &self.joints[k];
            let Some([low, high]) = link.joint.limits else {
                continue;
            };
            let now = link.state(&self.bodies);
            let (past, into) = if now.position < low {
                (now.position - low, now.velocity < 0.0)
            } else if now.position > high {
                (now.position - high, now.velocity > 0.0)
            } else {
                continue;
            };
            let first = link.frame(&self.bodies, 0);
            let (anchor, axis) = (first.origin, first.turn * DVec3::X);
            let (kind, (a, b)) = (link.joint.kind, link.joint.bodies);
            let change = if into {
                -(1.0 + link.joint.restitution) * now.velocity
            } else {
                0.0
            };
            let moving = link.joint.inertia_along(&self.bodies, anchor, axis);
            for (body, sign) in [(a, -1.0), (Some(b), 1.0)] {
                let Some(i) = body.filter(|&i| !self.bodies[i].fixed) else {
                    continue;
                };
                let b = &mut self.bodies[i];
                // This body's share: what it moves of the pair's motion along the coordinate.
                let share = match kind {
                    JointKind::Revolute => moving / b.inertia_about_line(anchor, axis),
                    _ => moving / b.mass,
                };
                let (back, faster) = (-past * share * sign, change * share * sign);
                match kind {
                    JointKind::Revolute => {
                        let turn = DQuat::from_axis_angle(axis, back);
                        b.position = anchor + turn * (b.position - anchor);
                        b.orientation = (turn * b.orientation).normalize();
                        b.spin += axis * faster;
                        b.velocity += (axis * faster).cross(b.position - anchor);
                    }
                    _ => {
                        b.position += axis * back;
                        b.velocity += axis * faster;
                    }
                }
                b.update_world_shape();
            }
        }
    }
}

/// The force (at the second frame's origin) and torque on the second body of `link`, its
/// frames `first` and `second` now, over a step of `dt` (the first body takes the opposite).
fn joint_wrench(
    link: &Linked,
    bodies: &[Body],
    (first, second): (&FrameMotion, &FrameMotion),
    dt: f64,
) -> (DVec3, DVec3) {
    let j = &link.joint;
    let axis = first.turn * DVec3::X;
    let (mut force, mut torque) = (DVec3::ZERO, DVec3::ZERO);
    // The anchors held together, but along a slider's axis.
    let (gap, closing) = (
        second.origin - first.origin,
        second.velocity - first.velocity,
    );
    for d in basis(axis) {
        if j.kind == JointKind::Prismatic && d == axis {
            continue;
        }
        let m = reduced(bodies, j, (first.origin, second.origin), d).0;
        force -= d * (2.0 * SPRING * m / (dt * dt) * gap.dot(d) + DAMPER * m / dt * closing.dot(d));
    }
    // The frames kept turned alike, but about a hinge's axis; a ball turns freely.
    if j.kind != JointKind::Spherical {
        let local = first.turn.inverse() * second.turn;
        // A hinge's turn about its axis taken out (a swing-twist split), so that what is left
        // is the frames' misalignment however far the hinge has turned.
        let misaligned = match j.kind {
            JointKind::Revolute => {
                let twist = DQuat::from_xyzw(local.x, 0.0, 0.0, local.w).normalize();
                local * twist.inverse()
            }
            _ => local,
        };
        let off = first.turn * wrap(misaligned.to_scaled_axis());
        let turning = second.spin - first.spin;
        for d in basis(axis) {
            if j.kind == JointKind::Revolute && d == axis {
                continue;
            }
            let inertia = reduced(bodies, j, (first.origin, second.origin), d).1;
            torque -= d
                * (2.0 * SPRING * inertia / (dt * dt) * off.dot(d)
                    + DAMPER * inertia / dt * turning.dot(d));
        }
    }
    if j.kind.has_coordinate() {
        let along = coordinate_force(link, bodies, (first, second), dt);
        match j.kind {
            JointKind::Revolute => torque += axis * along,
            _ => force += axis * along,
        }
    }
    (force, torque)
}

/// The force (N, or torque N·m) along `link`'s coordinate: its spring and damper, and its
/// motor.
fn coordinate_force(
    link: &Linked,
    bodies: &[Body],
    (first, second): (&FrameMotion, &FrameMotion),
    dt: f64,
) -> f64 {
    let j = &link.joint;
    let now = coordinate(j.kind, first, second);
    let axis = first.turn * DVec3::X;
    let (stiffest, firmest) = bounds(bodies, j, (first.origin, second.origin), axis, dt);
    // The file's spring and damper, no stiffer than the step allows (an explicit spring
    // past ω·dt = 1 would ring up).
    let stiffness = j.stiffness.min(stiffest);
    let damping = j.damping.min(firmest);
    let mut along = -stiffness * now.position - damping * now.velocity;
    if let Some(motor) = j.motor {
        // A stiff drive, no stiffer than the step allows, within its bound.
        let drive = match motor.target {
            MotorTarget::Velocity(v) => motor.stiffness().min(firmest) * (v - now.velocity),
            MotorTarget::Position(p) => {
                // Critically damped for what the joint moves, as far as the step allows.
                let moving = j.inertia_along(bodies, first.origin, axis);
                let k = motor.stiffness().min(stiffest);
                let c = critical_damping(k, moving).min(firmest);
                k * (p - now.position) - c * now.velocity
            }
        };
        along += drive.clamp(-motor.max_force, motor.max_force);
    }
    along
}

/// The stiffest spring and damper along joint `j`'s coordinate (its axis `axis`, its frames'
/// origins `anchors`) that a step of `dt` integrates with `bodies` where they are: what a
/// force along the coordinate moves within a step (each body about its own centre, before
/// the joint's locks turn it about the joint) bounds them.
fn bounds(bodies: &[Body], j: &Joint, anchors: (DVec3, DVec3), axis: DVec3, dt: f64) -> (f64, f64) {
    let (linear, angular) = reduced(bodies, j, anchors, axis);
    let m = if j.kind == JointKind::Revolute {
        angular
    } else {
        linear
    };
    (2.0 * SPRING * m / (dt * dt), DAMPER * m / dt)
}

/// The stiffest spring and damper the penalty step of `dt` integrates along `joint`'s
/// coordinate, its `bodies` as placed at load: the world holds a file's stiffer ones at
/// these.
pub fn coordinate_bounds(bodies: &[Body], joint: &Joint, dt: f64) -> (f64, f64) {
    bounds(bodies, joint, (joint.anchor, joint.anchor), joint.axis, dt)
}

/// The pair's effective mass along `d` at the anchors, and moment about `d`: the reduced
/// mass of both bodies there (the world does not move).
fn reduced(bodies: &[Body], j: &Joint, anchors: (DVec3, DVec3), d: DVec3) -> (f64, f64) {
    let (m1, i1) = mobility(bodies, j.bodies.0, anchors.0, d);
    let (m2, i2) = mobility(bodies, Some(j.bodies.1), anchors.1, d);
    let inverse = |a: f64, b: f64| if a + b > 0.0 { 1.0 / (a + b) } else { 0.0 };
    (inverse(m1, m2), inverse(i1, i2))
}

/// Three orthonormal directions, the first `axis`.
fn basis(axis: DVec3) -> [DVec3; 3] {
    let (u, v) = axis.any_orthonormal_pair();
    [axis, u, v]
}

/// A rotation vector of the shorter way round.
fn wrap(v: DVec3) -> DVec3 {
    let angle = v.length();
    if angle > std::f64::consts::PI {
        v * ((angle - std::f64::consts::TAU) / angle)
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::SceneFile;
    use glam::DVec3;
    use hapticd_core::kinematics::Wrench;

    /// A door (40 × 60 cm, 2.4 kg) on a hinge along y at the origin that stops at `low` and
    /// 1.6 rad, in the penalty engine at 4 kHz with no gravity.
    fn door(low: f64, restitution: f64) -> crate::scene::PenaltyScene {
        let text = format!(
            "name: door\nengine: penalty\ndt: 0.00025\ngravity: [0, 0, 0]\nmaterial: {{ \
             stiffness: 2.0e7, damping: 1.0e4, static_friction: 0, friction: 0, \
             friction_stiffness: 2.0e7, friction_damping: 1.0e4, slip_speed: 0.02 }}\nbodies:\n  \
             - {{ name: door, box: [0.4, 0.6, 0.02], density: 500, position: [0.2, 0, 0] }}\n\
             joints:\n  - {{ kind: revolute, bodies: [world, door], anchor: [0, 0, 0], axis: [0, \
             1, 0], limits: [{low}, 1.6], restitution: {restitution} }}\n"
        );
        match SceneFile::parse(&text, std::path::Path::new("door.yaml"), 0).unwrap() {
            SceneFile::Penalty(scene) => *scene,
            SceneFile::Rapier(_) => unreachable!("a penalty scene"),
        }
    }

    /// Pushed shut with 20 N at its handle for two seconds, the door goes no further than 1°
    /// past its stop, rests there (its rate never flips from step to step once it has come
    /// to rest), and its hinge holds: the anchor on the door stays within 0.1 mm of the axis.
    #[test]
    fn a_door_pushed_against_its_stop_stays_within_a_degree_of_it() {
        let mut scene = door(0.0, 0.0);
        let (at, push) = (DVec3::new(0.35, 0.0, 0.0), DVec3::new(0.0, 0.0, 20.0));
        scene.world.loads[0] = Wrench {
            force: push,
            torque: at.cross(push),
        };
        let (mut deepest, mut flips, mut last, mut apart) = (0.0f64, 0, 0.0f64, 0.0f64);
        for k in 0..8000 {
            scene.world.step(0.00025);
            let now = scene.world.joint_state(0);
            deepest = deepest.min(now.position);
            if k > 2000 && now.velocity * last < 0.0 && now.velocity.abs() > 1e-3 {
                flips += 1;
            }
            last = now.velocity;
            let b = &scene.world.bodies[0];
            let hinge = b.position + b.orientation * DVec3::new(-0.2, 0.0, 0.0);
            apart = apart.max(DVec3::new(hinge.x, 0.0, hinge.z).length());
        }
        println!(
            "{:.4}° past the stop, {flips} flips, the hinge {:.2e} m off its axis",
            -deepest.to_degrees(),
            apart
        );
        assert!(deepest > -1f64.to_radians());
        assert_eq!(flips, 0);
        assert!(apart < 1e-4);
    }

    /// A hinge's motor driving the door (moment 0.128 kg·m² about the hinge) at 1 rad/s with
    /// at most 0.05 N·m: the door's angular momentum about the hinge never grows faster than
    /// 0.05 N·m gives it, and it reaches the speed within 1 % and holds it; a motor to a position brings the door there and
    /// holds it within a thousandth of a radian.
    #[test]
    fn a_motor_drives_within_its_bound_to_its_target() {
        let motor = |target: &str| {
            let text = format!(
                "name: door\nengine: penalty\ndt: 0.00025\ngravity: [0, 0, 0]\nmaterial: {{ \
                 stiffness: 2.0e7, damping: 1.0e4, static_friction: 0, friction: 0, \
                 friction_stiffness: 2.0e7, friction_damping: 1.0e4, slip_speed: 0.02 \
                 }}\nbodies:\n  - {{ name: door, box: [0.4, 0.6, 0.02], density: 500, \
                 position: [0.2, 0, 0] }}\njoints:\n  - {{ kind: revolute, bodies: [world, \
                 door], anchor: [0, 0, 0], axis: [0, 1, 0], motor: {{ {target}, max_force: \
                 0.05 }} }}\n"
            );
            match SceneFile::parse(&text, std::path::Path::new("door.yaml"), 0).unwrap() {
                SceneFile::Penalty(scene) => *scene,
                SceneFile::Rapier(_) => unreachable!("a penalty scene"),
            }
        };
        let mut scene = motor("velocity: 1.0");
        let dt = 0.00025;
        // The door's angular momentum about the hinge line: the joint's own forces act
        // through it, so only the motor's torque changes it, by at most 0.05 N·m a second.
        let about_hinge = |b: &crate::body::Body| {
            let turn = glam::DMat3::from_quat(b.orientation);
            let own = turn * b.inertia * turn.transpose() * b.spin;
            (own + b.mass * b.position.cross(b.velocity)).y
        };
        let mut over: f64 = 0.0;
        for k in 1..=40_000 {
            scene.world.step(dt);
            let most = 0.05 * k as f64 * dt;
            over = over.max(about_hinge(&scene.world.bodies[0]) / most);
        }
        let last = scene.world.joint_state(0).velocity;
        println!(
            "velocity motor: {last:.5} rad/s, angular momentum at most {over:.5} of 0.05 N·m's"
        );
        assert!(over <= 1.0 + 1e-6, "{over}");
        assert!((last - 1.0).abs() < 0.01, "{last}");
        let mut scene = motor("position: 0.5");
        for _ in 0..40_000 {
            scene.world.step(dt);
        }
        let now = scene.world.joint_state(0);
        println!(
            "position motor: {:.5} rad, {:.5} rad/s",
            now.position, now.velocity
        );
        assert!(
            (now.position - 0.5).abs() < 1e-3 && now.velocity.abs() < 1e-3,
            "{now:?}"
        );
    }

    /// A spring or damper stiffer than the step integrates is said at load, at its place,
    /// with what the world holds it at: for the door 2·0.05·I/dt², I its moment about its
    /// own centre (5.1·10⁴ N·m/rad at 4 kHz).
    #[test]
    fn a_joint_spring_past_what_the_step_takes_is_said_at_load() {
        let text = |stiffness: f64| {
            format!(
                "name: door\nengine: penalty\ndt: 0.00025\ngravity: [0, 0, 0]\nmaterial: {{ \
                 stiffness: 2.0e7, damping: 1.0e4, static_friction: 0, friction: 0, \
                 friction_stiffness: 2.0e7, friction_damping: 1.0e4, slip_speed: 0.02 \
                 }}\nbodies:\n  - {{ name: door, box: [0.4, 0.6, 0.02], density: 500, \
                 position: [0.2, 0, 0] }}\njoints:\n  - {{ kind: revolute, bodies: [world, \
                 door], anchor: [0, 0, 0], axis: [0, 1, 0], stiffness: {stiffness} }}\n"
            )
        };
        let warnings = |stiffness| match SceneFile::parse(
            &text(stiffness),
            std::path::Path::new("door.yaml"),
            0,
        )
        .unwrap()
        {
            SceneFile::Penalty(scene) => scene.warnings.clone(),
            SceneFile::Rapier(_) => unreachable!("a penalty scene"),
        };
        assert!(warnings(100.0).is_empty());
        let said = warnings(1.0e6);
        let moment: f64 = 2.4 * (0.4f64 * 0.4 + 0.02 * 0.02) / 12.0;
        let most = 2.0 * 0.05 * moment / (0.00025f64 * 0.00025);
        assert_eq!(said.len(), 1, "{said:?}");
        let message = said[0].to_string();
        assert!(
            message.contains("joints[0].stiffness") && message.contains(&format!("{most:.3e}")),
            "{message}"
        );
    }

    /// A wheel its motor turns at 6 rad/s for two seconds counts its whole turns: its
    /// coordinate is the sum of its rate over the steps (within a thousandth of a radian),
    /// past a turn and a half, never wrapped back at ±π.
    #[test]
    fn a_wheel_turned_round_counts_its_turns() {
        let text = "name: wheel\nengine: penalty\ndt: 0.00025\ngravity: [0, 0, 0]\nmaterial: { \
                    stiffness: 2.0e7, damping: 1.0e4, static_friction: 0, friction: 0, \
                    friction_stiffness: 2.0e7, friction_damping: 1.0e4, slip_speed: 0.02 \
                    }\nbodies:\n  - { name: wheel, box: [0.1, 0.1, 0.02], density: 500, \
                    position: [0, 0, 0] }\njoints:\n  - { kind: revolute, bodies: [world, \
                    wheel], anchor: [0, 0, 0], axis: [0, 0, 1], motor: { velocity: 6.0, \
                    max_force: 0.5 } }\n";
        let SceneFile::Penalty(mut scene) =
            SceneFile::parse(text, std::path::Path::new("wheel.yaml"), 0).unwrap()
        else {
            unreachable!("a penalty scene");
        };
        let dt = 0.00025;
        let (mut summed, mut lowest) = (0.0, 0.0f64);
        for _ in 0..8000 {
            let before = scene.world.joint_state(0).velocity;
            scene.world.step(dt);
            let now = scene.world.joint_state(0);
            summed += 0.5 * (before + now.velocity) * dt;
            lowest = lowest.min(now.position - summed);
        }
        let at = scene.world.joint_state(0).position;
        println!("{at:.4} rad after 2 s, its rate summed {summed:.4} rad");
        assert!(at > 1.5 * std::f64::consts::TAU, "{at}");
        assert!(
            (at - summed).abs() < 1e-3 && lowest > -1e-3,
            "{at} against {summed}"
        );
    }

    /// Swung into its stop at 2 rad/s, the door comes off it at `restitution` times that
    /// speed, within 2 % of the speed (the stop is a damped spring a few steps long).
    #[test]
    fn a_stop_gives_back_its_restitution_of_the_speed() {
        for e in [0.0, 0.3, 0.8] {
            let mut scene = door(-0.5, e);
            let b = &mut scene.world.bodies[0];
            b.spin = DVec3::new(0.0, -2.0, 0.0);
            b.velocity = b.spin.cross(b.position);
            let mut off = None;
            for _ in 0..4000 {
                scene.world.step(0.00025);
                let now = scene.world.joint_state(0);
                if off.is_none() && now.velocity > 0.0 && now.position > -0.5 {
                    off = Some(now.velocity);
                }
            }
            let came_off = off.unwrap_or(0.0);
            println!("restitution {e}: in at 2 rad/s, off at {came_off:.4} rad/s");
            assert!((came_off - 2.0 * e).abs() < 0.04, "{came_off}");
        }
    }
}

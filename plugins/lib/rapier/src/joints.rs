//! A scene's joints in rapier: a tree of them (chains, a robot's links) as multibodies, in
//! reduced coordinates, and each joint that would close a loop (a four-bar), each ball joint
//! and each joint of a branch too deep for a multibody at its rate as an impulse joint solved
//! with the contacts.
//!
//! Measured on a box hinged at one end, released from 60° (the pendulum of `hapticctl
//! experiment pendulum` and of the core tests' `a_hinged_box_*`): as impulse joints, its
//! period was 1.8 % short at 60 Hz and the swing lost 36 % of its energy a minute at 1 kHz
//! (the position correction of the locked axes takes it); as a multibody, the period is
//! exact within 0.01 % at 60 Hz and the energy holds within 0.01 % a minute. Rapier damps a multibody's joints by default: the
//! damping is set to none, and a joint's own is its drive's.
//!
//! A joint's frame on each body is set whole from the anchor and axis in the world at load
//! (not from the axis alone, which leaves the twist about it to rapier), so its coordinate
//! is 0 where the file places the bodies. The joint's spring, damper and motor drive its one
//! free axis as rapier's force-based motor (N·m/rad and N·m·s/rad, or N/m and N·s/m, as the
//! file gives them); a motor adds its own stiff drive, bounded by its `max_force`. A limit
//! stops the coordinate; what the stop gives back (`restitution:`) is turned around after
//! each step, since rapier's limits give back nothing.
//!
//! A multibody sets its links' velocities from its joints' each step, so an impulse the hand
//! gives a link goes in as a force over the next step ([`Joints::kick`]), which the multibody
//! takes through its joints; what local dynamics moved a link by goes straight into its
//! joints' coordinates ([`articulation`](crate::articulation)). A link joined to what does
//! not move has its limits felt between steps as contacts ([`Joints::limit_contacts`]).

use std::collections::HashMap;

use glam::{DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::joint::{
    FrameMotion, Joint, JointKind, JointState, Motor, MotorTarget, Turns, coordinate as stands,
    critical_damping,
};
use hapticd_plugin_api::HapticdBodyContact;
use rapier3d::prelude::{
    GenericJoint, GenericJointBuilder, ImpulseJointHandle, JointAxesMask, JointAxis, MotorModel,
    MultibodyJointHandle, PhysicsWorld, Pose, RigidBodyActivation, RigidBodyBuilder,
    RigidBodyHandle,
};

use crate::convert::{dquat, dvec, rotation, vector};

/// Nearer its limit than this (rad or m), a coordinate is at it: rapier stops it in `f32`.
const AT_LIMIT: f64 = 1e-3;
/// The lever at which a link turning about its own centre has its limits held, m.
const LIMIT_LEVER: f64 = 0.05;

/// How rapier holds a joint.
#[derive(Clone, Copy)]
enum Handle {
    /// A link of a multibody: the joint to its parent.
    Multibody(MultibodyJointHandle),
    /// A constraint closing a loop.
    Impulse(ImpulseJointHandle),
}

/// The solver's iterations in a world with a loop of joints. A loop is closed by an impulse
/// joint on a multibody's links, and it converges over the iterations: a four-bar's crank
/// turned at 2 rad/s at 60 Hz left its loop open by 6 mm and its rocker 5.6° off the
/// closure with rapier's 4, by 0.1 mm and 0.1° with 8, and no better with 16
/// (`a_four_bar_turned_by_its_crank_rocks_as_its_closure_says`).
const LOOP_ITERATIONS: usize = 8;

/// The most links a branch of a multibody may have below what it hangs from. Measured in
/// rapier at 60 Hz with hinge chains of 2 cm, 1.4 g or 14 g links swinging down onto a floor:
/// chains 2 to 6 links deep (one, or three side by side) stayed whole for 5 s; 7 links deep
/// in three branches, 8 in two or three, 12, 16 or 20 in one diverged within 2 s, and 20 cm
/// links 12 deep did not. The same chains of impulse joints all stayed whole.
const DEEPEST_BRANCH: usize = 6;

/// Whether each joint of `specs` may be a multibody's: not a ball joint (a chain of them as
/// a multibody diverged once it struck the floor, twenty 31 g links at 60 Hz, within a
/// second), nor in a branch deeper than [`DEEPEST_BRANCH`]; such a whole branch is held by
/// impulse joints.
fn reducible(specs: &[Joint]) -> Vec<bool> {
    let tree = |spec: &Joint| spec.kind != JointKind::Spherical;
    // The tree joint that hangs each link from its parent, the first the file gives.
    let mut hung_by = HashMap::new();
    for (k, spec) in specs.iter().enumerate() {
        if tree(spec) {
            hung_by.entry(spec.bodies.1).or_insert(k);
        }
    }
    // Each tree joint's branch (the top joint it hangs under) and its depth in it; a loop
    // ends the climb once it has taken every joint.
    let place = |k: usize| {
        let (mut top, mut depth) = (k, 1);
        while let Some(&up) = specs[top].bodies.0.and_then(|b| hung_by.get(&b))
            && depth <= specs.len()
        {
            (top, depth) = (up, depth + 1);
        }
        (top, depth)
    };
    let places: Vec<(usize, usize)> = (0..specs.len()).map(place).collect();
    let mut deepest = vec![0; specs.len()];
    for (spec, &(top, depth)) in specs.iter().zip(&places) {
        if tree(spec) {
            deepest[top] = deepest[top].max(depth);
        }
    }
    specs
        .iter()
        .zip(&places)
        .map(|(spec, &(top, _))| tree(spec) && deepest[top] <= DEEPEST_BRANCH)
        .collect()
}

/// One joint in the world.
struct Built {
    spec: Joint,
    handle: Handle,
    bodies: [RigidBodyHandle; 2],
    /// The joint's frame in each body's frame: its origin (the anchor) and rotation (its x
    /// axis the joint's axis).
    frames: [(DVec3, DQuat); 2],
    /// The inertia along its coordinate of the two bodies it joins, as loaded (a motor's
    /// damper is critical for it).
    moved: f64,
    /// The coordinate's rate before the step, for a limit's restitution.
    before: f64,
    /// A hinge's whole turns.
    turns: Turns,
}

/// A force and torque given to a body for one step, N and N·m.
type Kick = (RigidBodyHandle, DVec3, DVec3);

/// A scene's joints in its rapier world.
#[derive(Default)]
pub struct Joints {
    built: Vec<Built>,
    /// Forces given to multibody links for the coming step, taken back after it.
    kicks: Vec<Kick>,
}

impl Joints {
    /// The joints `specs` between `bodies` (the file's, by index, loaded as `loaded`) of
    /// `physics`, a fixed body of the world added for those that hold a body to it.
    pub fn build(
        physics: &mut PhysicsWorld,
        bodies: &[RigidBodyHandle],
        loaded: &[Body],
        specs: &[Joint],
    ) -> Self {
        let world = (specs.iter().any(|j| j.bodies.0.is_none()))
            .then(|| physics.insert_body(RigidBodyBuilder::fixed()));
        let reducible = reducible(specs);
        let mut loops = false;
        let built: Vec<Built> = specs
            .iter()
            .zip(reducible)
            .map(|(spec, reducible)| {
                let first = spec.bodies.0.map_or_else(|| world.unwrap(), |i| bodies[i]);
                let pair = [first, bodies[spec.bodies.1]];
                let frame = DQuat::from_rotation_arc(DVec3::X, spec.axis);
                let frames = pair.map(|h| {
                    let b = &physics.bodies[h];
                    let (at, turn) = (dvec(b.translation()), dquat(*b.rotation()));
                    (turn.inverse() * (spec.anchor - at), turn.inverse() * frame)
                });
                let moved = spec.inertia_along(loaded, spec.anchor, spec.axis);
                let joint = joint(spec, moved, frames);
                // A joint that would close a loop, or give a link a second parent, is
                // refused as a multibody's.
                let reduced = reducible
                    .then(|| physics.insert_multibody_joint(pair[0], pair[1], joint))
                    .flatten();
                loops |= reducible && reduced.is_none();
                let handle = match reduced {
                    Some(h) => Handle::Multibody(h),
                    None => Handle::Impulse(physics.insert_impulse_joint(pair[0], pair[1], joint)),
                };
                Built {
                    spec: spec.clone(),
                    handle,
                    bodies: pair,
                    frames,
                    moved,
                    before: 0.0,
                    turns: Turns::default(),
                }
            })
            .collect();
        if loops {
            physics.integration_parameters.num_solver_iterations = LOOP_ITERATIONS;
        }
        for b in &built {
            // A jointed body does not sleep, as in the penalty engine: rapier puts a body
            // turning slower than 0.5 rad/s to sleep, a door swinging slowly or a motor's
            // load at the top of its swing stopped dead.
            for body in b.bodies {
                *physics.bodies[body].activation_mut() = RigidBodyActivation::cannot_sleep();
            }
            if let Handle::Multibody(h) = b.handle
                && let Some((multibody, _)) = physics.multibody_joints.get_mut(h)
            {
                multibody.damping_mut().fill(0.0);
            }
        }
        Joints {
            built,
            kicks: Vec::new(),
        }
    }

    /// Joint `k`'s name.
    pub fn name(&self, k: usize) -> &str {
        &self.built[k].spec.name
    }

    /// What joint `k` is, as its scene gives it.
    pub fn spec(&self, k: usize) -> &Joint {
        &self.built[k].spec
    }

    /// Give joint `k` `motor` (None: none), beside its spring and damper.
    pub fn set_motor(&mut self, physics: &mut PhysicsWorld, k: usize, motor: Option<Motor>) {
        let b = &mut self.built[k];
        b.spec.motor = motor;
        if !b.spec.kind.has_coordinate() {
            return;
        }
        let (spec, moved) = (&b.spec, b.moved);
        let set = |data: &mut GenericJoint| drive(data, spec, moved);
        match b.handle {
            Handle::Multibody(h) => {
                if let Some((multibody, link)) = physics.multibody_joints.get_mut(h)
                    && let Some(link) = multibody.link_mut(link)
                {
                    set(&mut link.joint.data);
                }
            }
            Handle::Impulse(h) => {
                if let Some(joint) = physics.impulse_joints.get_mut(h, true) {
                    set(&mut joint.data);
                }
            }
        }
        for body in b.bodies {
            if let Some(body) = physics.bodies.get_mut(body) {
                body.wake_up(true);
            }
        }
    }

    /// How many there are.
    pub fn len(&self) -> usize {
        self.built.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.built.is_empty()
    }

    /// Where joint `k` is now (a hinge counted in whole turns from load).
    pub fn state(&self, physics: &PhysicsWorld, k: usize) -> JointState {
        let b = &self.built[k];
        b.turns.counted(b.spec.kind, coordinate(physics, b))
    }

    /// The limits of the joint holding link `body` to a body that does not move, as
    /// contacts the haptic side keeps over a period (local dynamics): a point of the link
    /// off the joint, pushed along its path back from the stop, its gap what the link may
    /// still move there. Only those within `margin` (m at the point).
    pub fn limit_contacts(
        &self,
        physics: &PhysicsWorld,
        body: RigidBodyHandle,
        margin: f64,
    ) -> impl Iterator<Item = HapticdBodyContact> {
        self.built
            .iter()
            .filter(move |b| b.bodies[1] == body && b.spec.kind.has_coordinate())
            .filter(|b| !physics.bodies[b.bodies[0]].is_dynamic())
            .flat_map(move |b| {
                let [low, high] = b.spec.limits.unwrap_or([f64::NEG_INFINITY, f64::INFINITY]);
                let q = coordinate(physics, b).position;
                let first = frame(physics, b, 0);
                let (anchor, axis) = (first.origin, first.turn * DVec3::X);
                let centre = dvec(physics.bodies[body].center_of_mass());
                let (point, path) = match b.spec.kind {
                    JointKind::Revolute => {
                        let off = centre - anchor;
                        let along = axis * off.dot(axis);
                        // A link turning about its own centre is held at a lever of its own.
                        let arm = if (off - along).length() < LIMIT_LEVER / 10.0 {
                            axis.any_orthonormal_vector() * LIMIT_LEVER
                        } else {
                            off - along
                        };
                        (anchor + along + arm, axis.cross(arm))
                    }
                    _ => (centre, axis),
                };
                let scale = path.length();
                let direction = path / scale;
                [(q - low, direction), (high - q, -direction)]
                    .into_iter()
                    .map(move |(room, normal)| HapticdBodyContact {
                        point: point.to_array(),
                        normal: normal.to_array(),
                        gap: room * scale,
                        friction: 0.0,
                    })
                    .filter(move |c| c.gap < margin)
            })
    }

    /// Whether a joint joins bodies `a` and `b`.
    pub fn joins(&self, a: RigidBodyHandle, b: RigidBodyHandle) -> bool {
        self.built
            .iter()
            .any(|j| j.bodies == [a, b] || j.bodies == [b, a])
    }

    /// Whether `body` is a link of a multibody, whose velocities its joints set.
    pub fn is_link(&self, physics: &PhysicsWorld, body: RigidBodyHandle) -> bool {
        physics.multibody_joints.rigid_body_link(body).is_some()
    }

    /// Give link `body` the impulse `impulse` (N·s) and angular impulse `turn` (N·m·s, about
    /// its centre of mass) over the coming step of `dt` seconds, as a force and torque the
    /// multibody takes through its joints.
    pub fn kick(
        &mut self,
        physics: &mut PhysicsWorld,
        body: RigidBodyHandle,
        (impulse, turn): (DVec3, DVec3),
        dt: f64,
    ) {
        let (force, torque) = (impulse / dt, turn / dt);
        if !(force.is_finite() && torque.is_finite()) {
            return;
        }
        let b = &mut physics.bodies[body];
        b.add_force(vector(force), true);
        b.add_torque(vector(torque), true);
        self.kicks.push((body, force, torque));
    }

    /// [physics, before the step] Remember each limited coordinate's rate.
    pub fn before_step(&mut self, physics: &PhysicsWorld) {
        for b in &mut self.built {
            if b.spec.limits.is_some() && b.spec.restitution > 0.0 {
                b.before = coordinate(physics, b).velocity;
            }
        }
    }

    /// [physics, after the step] Take back the step's kicks; a coordinate a limit stopped
    /// gets back `restitution` of the rate it hit the limit at, turned around.
    pub fn after_step(&mut self, physics: &mut PhysicsWorld) {
        for (body, force, torque) in self.kicks.drain(..) {
            let b = &mut physics.bodies[body];
            b.add_force(vector(-force), false);
            b.add_torque(vector(-torque), false);
        }
        for b in self.built.iter_mut() {
            if b.spec.kind == JointKind::Revolute {
                let now = coordinate(physics, b).position;
                b.turns.follow(now);
            }
        }
        for b in &self.built {
            let (Some([low, high]), e) = (b.spec.limits, b.spec.restitution) else {
                continue;
            };
            if e <= 0.0 {
                continue;
            }
            let now = coordinate(physics, b);
            let hit = (now.position <= low + AT_LIMIT && b.before < 0.0)
                || (now.position >= high - AT_LIMIT && b.before > 0.0);
            if hit {
                rebound(physics, b, -e * b.before - now.velocity);
            }
        }
    }
}

/// The free axis of a joint with a coordinate.
fn free_axis(kind: JointKind) -> JointAxis {
    match kind {
        JointKind::Prismatic => JointAxis::LinX,
        _ => JointAxis::AngX,
    }
}

/// Drive `data`'s free axis as `spec` says (`moved` the inertia along it): its spring and
/// damper, and its motor's drive, as rapier's force-based motor; none at all where it has
/// neither (rapier holds an axis whose motor has no stiffness and no damping still).
fn drive(data: &mut GenericJoint, spec: &Joint, moved: f64) {
    let axis = free_axis(spec.kind);
    let (mut position, mut velocity) = (0.0, 0.0);
    let (mut stiffness, mut damping) = (spec.stiffness, spec.damping);
    if let Some(motor) = spec.motor {
        match motor.target {
            MotorTarget::Velocity(v) => {
                velocity = v;
                damping += motor.stiffness();
            }
            MotorTarget::Position(p) => {
                position = p;
                let k = motor.stiffness();
                stiffness += k;
                damping += critical_damping(k, moved);
            }
        }
    }
    if stiffness > 0.0 || damping > 0.0 {
        let bound = spec.motor.map_or(f32::MAX, |m| m.max_force as f32);
        data.set_motor_model(axis, MotorModel::ForceBased)
            .set_motor(
                axis,
                position as f32,
                velocity as f32,
                stiffness as f32,
                damping as f32,
            )
            .set_motor_max_force(axis, bound);
    } else {
        data.motor_axes.remove(axis.into());
    }
}

/// The rapier joint of `spec`, its frame on each body `frames`.
fn joint(spec: &Joint, moved: f64, frames: [(DVec3, DQuat); 2]) -> GenericJoint {
    let locked = match spec.kind {
        JointKind::Fixed => JointAxesMask::LOCKED_FIXED_AXES,
        JointKind::Revolute => JointAxesMask::LOCKED_REVOLUTE_AXES,
        JointKind::Prismatic => JointAxesMask::LOCKED_PRISMATIC_AXES,
        JointKind::Spherical => JointAxesMask::LOCKED_SPHERICAL_AXES,
    };
    let pose = |(at, turn): (DVec3, DQuat)| Pose::from_parts(vector(at), rotation(turn));
    let mut joint = GenericJointBuilder::new(locked)
        .local_frame1(pose(frames[0]))
        .local_frame2(pose(frames[1]))
        // Jointed bodies overlap at the joint: a hinge's leaves touch along it.
        .contacts_enabled(false)
        .build();
    if spec.kind.has_coordinate() {
        if let Some([low, high]) = spec.limits {
            joint.set_limits(free_axis(spec.kind), [low as f32, high as f32]);
        }
        drive(&mut joint, spec, moved);
    }
    joint
}

/// Joint `b`'s frame on its body `side`, as the body now carries it.
fn frame(physics: &PhysicsWorld, b: &Built, side: usize) -> FrameMotion {
    let body = &physics.bodies[b.bodies[side]];
    let (at, turn) = (dvec(body.translation()), dquat(*body.rotation()));
    let origin = at + turn * b.frames[side].0;
    let spin = dvec(body.angvel());
    FrameMotion {
        origin,
        turn: turn * b.frames[side].1,
        velocity: dvec(body.linvel()) + spin.cross(origin - dvec(body.center_of_mass())),
        spin,
    }
}

/// Where joint `b`'s coordinate is and how fast it moves.
fn coordinate(physics: &PhysicsWorld, b: &Built) -> JointState {
    stands(b.spec.kind, &frame(physics, b, 0), &frame(physics, b, 1))
}

/// Change joint `b`'s rate by `change` (rad/s or m/s): a multibody link's own joint rate,
/// or for a loop's joint equal and opposite pushes along its axis at the anchor on its two
/// bodies, shared by how easily each turns or slides there.
fn rebound(physics: &mut PhysicsWorld, b: &Built, change: f64) {
    if let Handle::Multibody(h) = b.handle {
        if let Some((multibody, link)) = physics.multibody_joints.get_mut(h) {
            let dof = multibody.link(link).map(|l| l.assembly_id());
            if let Some(dof) = dof {
                multibody.generalized_velocity_mut()[dof] += change as f32;
            }
        }
        return;
    }
    let first = frame(physics, b, 0);
    let (anchor, axis) = (first.origin, first.turn * DVec3::X);
    // Each body's mobility along the joint's one free direction at the anchor.
    let mobility = |h: RigidBodyHandle| -> f64 {
        let body = &physics.bodies[h];
        if !body.is_dynamic() {
            return 0.0;
        }
        let mass = f64::from(body.mass());
        let com = dvec(body.center_of_mass());
        let inverse = body.mass_properties().effective_world_inv_inertia;
        match b.spec.kind {
            JointKind::Revolute => {
                // Turning about the axis through the anchor: the body's moment there.
                let arm = (com - anchor) - axis * (com - anchor).dot(axis);
                let own = 1.0 / axis.dot(dvec(inverse * vector(axis)));
                let moment = own + mass * arm.length_squared();
                1.0 / moment
            }
            _ => 1.0 / mass,
        }
    };
    let (first, second) = (mobility(b.bodies[0]), mobility(b.bodies[1]));
    if first + second <= 0.0 {
        return;
    }
    let impulse = change / (first + second);
    for (side, sign, share) in [(0, -1.0, first), (1, 1.0, second)] {
        if share <= 0.0 {
            continue;
        }
        let body = &mut physics.bodies[b.bodies[side]];
        let com = dvec(body.center_of_mass());
        match b.spec.kind {
            JointKind::Revolute => {
                // A turn about the axis through the anchor, at the rate the impulse gives.
                let spin = axis * (sign * impulse * share);
                body.set_angvel(body.angvel() + vector(spin), true);
                body.set_linvel(body.linvel() + vector(spin.cross(com - anchor)), true);
            }
            _ => {
                let velocity = axis * (sign * impulse * share);
                body.set_linvel(body.linvel() + vector(velocity), true);
            }
        }
    }
}

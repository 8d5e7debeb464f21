//! Joints between bodies, whichever engine steps them (thesis 7.2): what a joint is once a
//! scene file's `joints:` are checked, and where its one coordinate (a hinge's angle, a
//! slider's distance) stands, read from the two bodies it joins.

use glam::{DQuat, DVec3};
use hapticd_plugin_api::{
    HAPTICD_JOINT_FIXED, HAPTICD_JOINT_MOTOR_OFF, HAPTICD_JOINT_MOTOR_POSITION,
    HAPTICD_JOINT_MOTOR_VELOCITY, HAPTICD_JOINT_PRISMATIC, HAPTICD_JOINT_QUERY,
    HAPTICD_JOINT_REVOLUTE, HAPTICD_JOINT_SPHERICAL, HapticdJointCommand, HapticdJointInfo,
    HapticdJointState,
};
use serde::Deserialize;

use crate::body::Body;

/// What a joint lets its bodies do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JointKind {
    /// Nothing: the two move as one.
    Fixed,
    /// Turn about the axis through the anchor (a hinge).
    Revolute,
    /// Slide along the axis (a slider, a drawer).
    Prismatic,
    /// Turn any way about the anchor (a ball joint).
    Spherical,
}

impl JointKind {
    /// Whether it has one coordinate (an angle or a distance), which limits, springs and
    /// motors act on.
    pub fn has_coordinate(self) -> bool {
        matches!(self, JointKind::Revolute | JointKind::Prismatic)
    }

    /// Its `HAPTICD_JOINT_` kind.
    pub fn abi(self) -> u32 {
        match self {
            JointKind::Fixed => HAPTICD_JOINT_FIXED,
            JointKind::Revolute => HAPTICD_JOINT_REVOLUTE,
            JointKind::Prismatic => HAPTICD_JOINT_PRISMATIC,
            JointKind::Spherical => HAPTICD_JOINT_SPHERICAL,
        }
    }
}

/// A world whose joints the joints extension reads and drives, in either engine.
pub trait DrivenJoints {
    /// How many joints it has.
    fn joint_count(&self) -> usize;
    /// Joint `k` as the scene gives it.
    fn joint(&self, k: usize) -> &Joint;
    /// Give joint `k` `motor` (None: none), beside its spring and damper.
    fn set_motor(&mut self, k: usize, motor: Option<Motor>);
    /// Where joint `k` stands now.
    fn joint_state(&self, k: usize) -> JointState;

    /// Joint `k` as the joints extension lists it, None past the last.
    fn joint_info(&self, k: usize) -> Option<HapticdJointInfo> {
        (k < self.joint_count()).then(|| {
            let joint = self.joint(k);
            HapticdJointInfo::new(&joint.name, joint.kind.abi())
        })
    }

    /// Carry out joint `command` (a query, or a change of its motor) and answer where the
    /// joint stands; None for no such joint, an unknown command, or a motor on a joint
    /// without a coordinate. Allocates nothing: it runs between steps, in the haptic tick
    /// for a direct scene.
    fn drive_joint(&mut self, command: &HapticdJointCommand) -> Option<HapticdJointState> {
        let k = command.joint as usize;
        if k >= self.joint_count() || !command.is_finite() {
            return None;
        }
        match commanded(command) {
            Some(motor) if self.joint(k).kind.has_coordinate() => self.set_motor(k, motor),
            None if command.kind == HAPTICD_JOINT_QUERY => {}
            _ => return None,
        }
        let state = self.joint_state(k);
        Some(HapticdJointState {
            position: state.position,
            velocity: state.velocity,
        })
    }
}

/// What a joint command of the joints extension asks of the joint's motor: `Some(motor)`
/// to drive it (None: to stop driving), or nothing for a query or an unknown command.
fn commanded(command: &HapticdJointCommand) -> Option<Option<Motor>> {
    let motor = |target| {
        Some(Some(Motor {
            target,
            max_force: command.max_force,
        }))
    };
    match command.kind {
        HAPTICD_JOINT_MOTOR_VELOCITY => motor(MotorTarget::Velocity(command.target)),
        HAPTICD_JOINT_MOTOR_POSITION => motor(MotorTarget::Position(command.target)),
        HAPTICD_JOINT_MOTOR_OFF => Some(None),
        _ => None,
    }
}

/// What a motor drives its joint's coordinate to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MotorTarget {
    /// A speed, rad/s or m/s.
    Velocity(f64),
    /// A coordinate, rad or m.
    Position(f64),
}

/// A joint's motor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motor {
    /// What it drives to.
    pub target: MotorTarget,
    /// The most torque (N·m) or force (N) it uses.
    pub max_force: f64,
}

/// How far off its target a motor pushes with all of its force, rad or m (a position) and
/// rad/s or m/s (a speed): stiff, without being a rigid constraint.
pub const MOTOR_SLACK: f64 = 0.01;

impl Motor {
    /// Its drive's stiffness (toward a position) or firmness (toward a speed), N·m/rad or
    /// N/m, N·m·s/rad or N·s/m: its whole bound at [`MOTOR_SLACK`] off.
    pub fn stiffness(&self) -> f64 {
        self.max_force / MOTOR_SLACK
    }
}

/// The damper critical for a drive of `stiffness` moving `moved` (the inertia along the
/// coordinate, [`Joint::inertia_along`]): a position motor's, in both engines. Rapier's
/// damper at a twentieth of the stiffness overshot a 2.4 kg door's target by 86 %.
pub fn critical_damping(stiffness: f64, moved: f64) -> f64 {
    2.0 * (stiffness * moved).sqrt()
}

/// A joint, checked: its bodies by their index in `bodies:` (None for the world).
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Its name.
    pub name: String,
    /// What it lets the bodies do.
    pub kind: JointKind,
    /// The two bodies; the first may be the world (None).
    pub bodies: (Option<usize>, usize),
    /// Where it is, in the world at load, m.
    pub anchor: DVec3,
    /// Its unit axis, in the world at load.
    pub axis: DVec3,
    /// The lowest and highest coordinate, if limited.
    pub limits: Option<[f64; 2]>,
    /// Of the speed a limit stops, given back.
    pub restitution: f64,
    /// Spring back to coordinate 0.
    pub stiffness: f64,
    /// Damper on the coordinate's rate.
    pub damping: f64,
    /// Its motor, if it has one.
    pub motor: Option<Motor>,
}

impl Joint {
    /// The inertia along its coordinate of what it joins (`bodies`, the scene's), its axis
    /// `axis` through `anchor`: for a hinge each body's moment about the hinge line, for a
    /// slider its mass, reduced over both (the world and fixed bodies do not move).
    pub fn inertia_along(&self, bodies: &[Body], anchor: DVec3, axis: DVec3) -> f64 {
        let give = |i: Option<usize>| match i.map(|i| &bodies[i]) {
            Some(b) if !b.fixed && self.kind == JointKind::Revolute => {
                1.0 / b.inertia_about_line(anchor, axis)
            }
            Some(b) if !b.fixed => 1.0 / b.mass,
            _ => 0.0,
        };
        let total = give(self.bodies.0) + give(Some(self.bodies.1));
        if total > 0.0 { 1.0 / total } else { 0.0 }
    }
}

/// Where a joint's coordinate is and how fast it moves.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JointState {
    /// The angle (rad) or distance (m) from where the file placed the bodies; 0 for a fixed
    /// or spherical joint.
    pub position: f64,
    /// Its rate, rad/s or m/s.
    pub velocity: f64,
}

/// A hinge's coordinate followed across ±π: the whole turns it made since load, so that a
/// crank turned three times stands at 6π, not at a wrapped angle. A step must turn it by
/// less than half a turn (ω·dt < π: a thousand turns a second at 1 kHz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Turns {
    turns: f64,
    last: f64,
}

impl Turns {
    /// The coordinate, `wrapped` (within ±π) as it stands now, counted from load.
    pub fn at(&self, wrapped: f64) -> f64 {
        wrapped + std::f64::consts::TAU * (self.turns + Self::crossed(wrapped - self.last))
    }

    /// `state` of a joint of `kind` with a hinge's coordinate counted from load (others as
    /// they are).
    pub fn counted(&self, kind: JointKind, state: JointState) -> JointState {
        match kind {
            JointKind::Revolute => JointState {
                position: self.at(state.position),
                ..state
            },
            _ => state,
        }
    }

    /// Follow the coordinate to `wrapped` (within ±π), as a step left it.
    pub fn follow(&mut self, wrapped: f64) {
        self.turns += Self::crossed(wrapped - self.last);
        self.last = wrapped;
    }

    /// The turn a wrapped coordinate that moved by `jump` crossed (±1), if any.
    fn crossed(jump: f64) -> f64 {
        if jump > std::f64::consts::PI {
            -1.0
        } else if jump < -std::f64::consts::PI {
            1.0
        } else {
            0.0
        }
    }
}

/// A joint's frame on one of its bodies, as the body now carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameMotion {
    /// Its origin (the anchor), in the world.
    pub origin: DVec3,
    /// Its rotation in the world (its x axis the joint's axis).
    pub turn: DQuat,
    /// The body's velocity at the origin.
    pub velocity: DVec3,
    /// The body's angular velocity.
    pub spin: DVec3,
}

/// Where the coordinate of a joint of `kind` stands, its frame on its first body `first`
/// and on its second `second`: the second frame's twist about the first's x axis (the
/// shorter way round) or its distance along it, and its rate.
pub fn coordinate(kind: JointKind, first: &FrameMotion, second: &FrameMotion) -> JointState {
    let axis = first.turn * DVec3::X;
    match kind {
        JointKind::Revolute => {
            let turn = first.turn.inverse() * second.turn;
            let angle = 2.0 * turn.x.atan2(turn.w);
            let angle = (angle + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            JointState {
                position: angle,
                velocity: (second.spin - first.spin).dot(axis),
            }
        }
        JointKind::Prismatic => JointState {
            position: (second.origin - first.origin).dot(axis),
            velocity: (second.velocity - first.velocity).dot(axis),
        },
        JointKind::Fixed | JointKind::Spherical => JointState::default(),
    }
}

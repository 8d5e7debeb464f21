//! A running world's joints read and driven from outside (`hapticd.scene.joints/1`): each
//! command checked against the joint it names and what a hand may meet before it goes to
//! the stepping thread, as a body's is.

use hapticd_plugin_api::*;

use super::{
    Answer, CommandError, MAX_DISTANCE, MAX_FORCE, MAX_SPEED, MAX_SPIN, Order, SceneControl,
};

/// Farthest a hinge may be driven to, rad: a thousand radians is some 160 turns.
pub const MAX_ANGLE: f64 = 1000.0;

/// A joint of the running world.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Joint {
    /// Its name.
    pub name: String,
    /// One of the `HAPTICD_JOINT_` kinds.
    pub kind: u32,
}

impl Joint {
    /// What its kind is called.
    pub fn kind_name(&self) -> &'static str {
        match self.kind {
            HAPTICD_JOINT_FIXED => "fixed",
            HAPTICD_JOINT_REVOLUTE => "revolute",
            HAPTICD_JOINT_PRISMATIC => "prismatic",
            HAPTICD_JOINT_SPHERICAL => "spherical",
            _ => "unknown",
        }
    }
}

impl SceneControl {
    /// The world's joints, in the order of their ids.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// The id of the joint called `joint`.
    pub fn find_joint(&self, joint: &str) -> Result<u32, CommandError> {
        self.joints
            .iter()
            .position(|j| j.name == joint)
            .map(|i| i as u32)
            .ok_or_else(|| {
                let names: Vec<&str> = self.joints.iter().map(|j| j.name.as_str()).collect();
                CommandError::UnknownJoint(if names.is_empty() {
                    format!("no joint {joint:?}: this world has none")
                } else {
                    format!(
                        "no joint {joint:?} in this world: its joints are {}",
                        names.join(", ")
                    )
                })
            })
    }

    /// Check `command` for the joint it names: finite, a motor only on a joint with a
    /// coordinate, its target and force within what a hand may meet.
    pub fn check_joint(&self, command: &HapticdJointCommand) -> Result<(), CommandError> {
        let joint = self.joints.get(command.joint as usize).ok_or_else(|| {
            CommandError::UnknownJoint(format!("no joint with id {}", command.joint))
        })?;
        let name = &joint.name;
        if !command.is_finite() {
            return Err(CommandError::NotFinite(format!(
                "a value for {name} is not a finite number"
            )));
        }
        let out = |what: &str, value: f64, limit: f64, unit: &str| {
            Err(CommandError::OutOfRange(format!(
                "{what} {value} {unit} for {name} is beyond {limit} {unit}"
            )))
        };
        let hinge = joint.kind == HAPTICD_JOINT_REVOLUTE;
        let motor = matches!(
            command.kind,
            HAPTICD_JOINT_MOTOR_VELOCITY | HAPTICD_JOINT_MOTOR_POSITION
        );
        match command.kind {
            HAPTICD_JOINT_QUERY
            | HAPTICD_JOINT_MOTOR_OFF
            | HAPTICD_JOINT_MOTOR_VELOCITY
            | HAPTICD_JOINT_MOTOR_POSITION => {}
            kind => {
                return Err(CommandError::Refused(format!(
                    "no joint command of kind {kind}"
                )));
            }
        }
        let driven = matches!(joint.kind, HAPTICD_JOINT_REVOLUTE | HAPTICD_JOINT_PRISMATIC);
        if (motor || command.kind == HAPTICD_JOINT_MOTOR_OFF) && !driven {
            return Err(CommandError::Refused(format!(
                "{name} is a {} joint: it has no coordinate to drive",
                joint.kind_name()
            )));
        }
        if motor && !(command.max_force > 0.0 && command.max_force <= MAX_FORCE) {
            return Err(CommandError::OutOfRange(format!(
                "a motor's force of {} for {name} must be above 0 and at most {MAX_FORCE} (N or N·m)",
                command.max_force
            )));
        }
        let target = command.target.abs();
        match command.kind {
            HAPTICD_JOINT_MOTOR_VELOCITY if hinge && target > MAX_SPIN => {
                out("a rate", target, MAX_SPIN, "rad/s")
            }
            HAPTICD_JOINT_MOTOR_VELOCITY if !hinge && target > MAX_SPEED => {
                out("a speed", target, MAX_SPEED, "m/s")
            }
            HAPTICD_JOINT_MOTOR_POSITION if hinge && target > MAX_ANGLE => {
                out("an angle", target, MAX_ANGLE, "rad")
            }
            HAPTICD_JOINT_MOTOR_POSITION if !hinge && target > MAX_DISTANCE => {
                out("a distance", target, MAX_DISTANCE, "m")
            }
            _ => Ok(()),
        }
    }

    /// Where every joint stands, read between the same two steps (one wait for them all).
    pub fn joint_states(&mut self) -> Result<Vec<HapticdJointState>, CommandError> {
        let orders: Vec<Order> = (0..self.joints.len() as u32)
            .map(|joint| {
                Order::Joint(HapticdJointCommand {
                    joint,
                    ..HapticdJointCommand::default()
                })
            })
            .collect();
        self.wait_all(&orders, "the joints")?
            .into_iter()
            .zip(&self.joints)
            .map(|(answer, joint)| match answer {
                (HAPTICD_OK, Answer::Joint(state)) => Ok(state),
                (status, _) => Err(CommandError::Refused(format!(
                    "the scene refused to read {} (status {status})",
                    joint.name
                ))),
            })
            .collect()
    }

    /// Check `command`, hand it to the stepping thread and wait for its answer: the joint's
    /// state after it.
    pub fn drive(
        &mut self,
        command: HapticdJointCommand,
    ) -> Result<HapticdJointState, CommandError> {
        self.check_joint(&command)?;
        let name = self.joints[command.joint as usize].name.clone();
        match self.wait(Order::Joint(command), &name)? {
            (HAPTICD_OK, Answer::Joint(state)) => Ok(state),
            (status, _) => Err(CommandError::Refused(format!(
                "the scene refused the change to {name} (status {status})"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::channel;
    use super::*;

    /// A world of a door's hinge and a ball joint.
    fn control() -> SceneControl {
        let joint = |name: &str, kind| Joint {
            name: name.into(),
            kind,
        };
        channel(
            Vec::new(),
            vec![
                joint("hinge", HAPTICD_JOINT_REVOLUTE),
                joint("ball", HAPTICD_JOINT_SPHERICAL),
            ],
        )
        .0
    }

    #[test]
    fn joints_are_found_by_name_and_hostile_commands_refused_by_kind() {
        let control = control();
        assert_eq!(control.find_joint("ball"), Ok(1));
        let missing = control.find_joint("door").unwrap_err();
        assert!(format!("{missing}").contains("hinge, ball"), "{missing}");
        let command = |kind, joint, target, max_force| HapticdJointCommand {
            kind,
            joint,
            target,
            max_force,
        };
        let cases = [
            (
                command(HAPTICD_JOINT_MOTOR_VELOCITY, 0, f64::NAN, 1.0),
                "NotFinite",
            ),
            (
                command(HAPTICD_JOINT_MOTOR_VELOCITY, 0, 1.0, f64::INFINITY),
                "NotFinite",
            ),
            (
                command(HAPTICD_JOINT_MOTOR_VELOCITY, 0, 1e3, 1.0),
                "OutOfRange",
            ),
            (
                command(HAPTICD_JOINT_MOTOR_POSITION, 0, 1e4, 1.0),
                "OutOfRange",
            ),
            (
                command(HAPTICD_JOINT_MOTOR_VELOCITY, 0, 1.0, 0.0),
                "OutOfRange",
            ),
            (
                command(HAPTICD_JOINT_MOTOR_VELOCITY, 0, 1.0, 1e6),
                "OutOfRange",
            ),
            (
                command(HAPTICD_JOINT_MOTOR_VELOCITY, 1, 1.0, 1.0),
                "Refused",
            ),
            (command(HAPTICD_JOINT_MOTOR_OFF, 1, 0.0, 0.0), "Refused"),
            (command(9, 0, 0.0, 0.0), "Refused"),
            (command(HAPTICD_JOINT_QUERY, 2, 0.0, 0.0), "UnknownJoint"),
        ];
        for (c, expected) in cases {
            let error = control.check_joint(&c).unwrap_err();
            let name = format!("{error:?}");
            assert!(name.starts_with(expected), "{c:?}: {name}");
        }
        for fine in [
            command(HAPTICD_JOINT_QUERY, 1, 0.0, 0.0),
            command(HAPTICD_JOINT_MOTOR_POSITION, 0, -20.0, 2.0),
            command(HAPTICD_JOINT_MOTOR_OFF, 0, 0.0, 0.0),
        ] {
            assert_eq!(control.check_joint(&fine), Ok(()), "{fine:?}");
        }
    }
}

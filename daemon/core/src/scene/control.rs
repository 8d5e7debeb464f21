//! A running world changed from outside: the host's half of the scene-control and joints
//! extensions.
//!
//! The control plane holds a [`SceneControl`]: the world's bodies and joints by name, a
//! check of each command against them and against what a hand may safely meet, and a ring
//! of requests to the thread that steps the world. That thread ([`Incoming`]) carries a command out
//! between two steps and answers with the body's state; a command that would jump a force
//! (a body put somewhere else) is held until the loop has ramped the forces to zero, as a
//! scene switch is.

use std::time::{Duration, Instant};

use hapticd_plugin_api::*;

use crate::sync::spsc;

mod joints;

pub use joints::Joint;

/// Farthest a body may be put from the frame's centre, metres: a desk's world.
pub const MAX_DISTANCE: f64 = 10.0;
/// Fastest a body may be set moving, m/s.
pub const MAX_SPEED: f64 = 10.0;
/// Fastest a body may be set turning, rad/s.
pub const MAX_SPIN: f64 = 100.0;
/// Largest impulse given at once, N·s.
pub const MAX_IMPULSE: f64 = 10.0;
/// Largest force held on a body, N.
pub const MAX_FORCE: f64 = 100.0;
/// Heaviest a body may be made, kg.
pub const MAX_MASS: f64 = 1000.0;
/// Largest friction coefficient.
pub const MAX_FRICTION: f64 = 10.0;
/// A soft body's Young's modulus, least and most, Pa (a hard rubber's is 10⁸).
pub const YOUNG_RANGE: (f64, f64) = (1.0, 1e9);
/// A soft body's Poisson's ratio: up to a nearly incompressible rubber's.
pub const POISSON_RANGE: (f64, f64) = (0.0, 0.49);
/// A soft body's longest damping time, s.
pub const MOST_DAMPING: f64 = 1.0;

/// A body of the running world.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Body {
    /// Its name in the scene file.
    pub name: String,
    /// Forces do not move it.
    pub fixed: bool,
}

/// What the stepping thread is asked to do.
#[derive(Debug, Clone, Copy)]
pub enum Order {
    /// A command to a body.
    Body(HapticdSceneCommand),
    /// A command to a joint.
    Joint(HapticdJointCommand),
}

/// A command for the stepping thread, numbered to match its answer.
#[derive(Debug, Clone, Copy)]
pub struct Request {
    id: u64,
    order: Order,
}

impl Request {
    /// What it asks.
    pub fn order(&self) -> &Order {
        &self.order
    }

    /// Whether carrying it out could jump the force a hand feels (a body put elsewhere).
    fn jumps(&self) -> bool {
        matches!(self.order, Order::Body(c) if c.kind == HAPTICD_COMMAND_SET_POSE)
    }
}

/// The state a request left its body or joint in.
#[derive(Debug, Clone, Copy)]
pub enum Answer {
    /// A body's.
    Body(HapticdBodyState),
    /// A joint's.
    Joint(HapticdJointState),
}

/// What the stepping thread did with a request.
#[derive(Debug, Clone, Copy)]
pub struct Reply {
    id: u64,
    status: i32,
    answer: Answer,
}

impl Reply {
    /// The answer to `request`: the plugin's status and the state after it.
    pub fn to(request: &Request, status: i32, answer: Answer) -> Self {
        Self {
            id: request.id,
            status,
            answer,
        }
    }
}

/// Why a command was not carried out.
#[derive(Debug, Clone, PartialEq)]
pub enum CommandError {
    /// No body of that name or id.
    UnknownBody(String),
    /// No joint of that name or id.
    UnknownJoint(String),
    /// Forces do not move that body.
    FixedBody(String),
    /// A value that is NaN or infinite.
    NotFinite(String),
    /// A value outside what a hand may meet.
    OutOfRange(String),
    /// The scene refused it (its plugin's status).
    Refused(String),
    /// The stepping thread did not answer in time (the scene stopped, or was replaced).
    Timeout(String),
}

impl std::fmt::Display for CommandError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CommandError::UnknownBody(m)
            | CommandError::UnknownJoint(m)
            | CommandError::FixedBody(m)
            | CommandError::NotFinite(m)
            | CommandError::OutOfRange(m)
            | CommandError::Refused(m)
            | CommandError::Timeout(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for CommandError {}

/// [main] The control plane's end: the world's bodies and joints and the requests to its
/// stepping thread.
pub struct SceneControl {
    bodies: Vec<Body>,
    joints: Vec<Joint>,
    requests: spsc::Producer<Request>,
    replies: spsc::Consumer<Reply>,
    next: u64,
}

/// Requests in flight at most (a world rebuilt with a body more carries four for each of
/// its bodies); a caller beyond them is told the scene is not answering.
const REQUESTS: usize = 4096;

/// How long a command waits for the stepping thread: a ramp down and a physics step or two.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(3);

/// The control of a world of `bodies` and `joints`, its requests' end for the stepping
/// thread, and the end that thread answers through (the same one, or the physics thread of
/// a multi-rate scene).
pub fn channel(
    bodies: Vec<Body>,
    joints: Vec<Joint>,
) -> (SceneControl, Incoming, spsc::Producer<Reply>) {
    let (requests, incoming) = spsc::channel(REQUESTS);
    let (answers, replies) = spsc::channel(REQUESTS);
    let control = SceneControl {
        bodies,
        joints,
        requests,
        replies,
        next: 0,
    };
    (
        control,
        Incoming {
            requests: incoming,
            held: None,
        },
        answers,
    )
}

impl SceneControl {
    /// The world's bodies, in the order of their ids.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// The id of the body called `body`, or numbered so (a name wins over a number).
    pub fn find(&self, body: &str) -> Result<u32, CommandError> {
        let by_name = self.bodies.iter().position(|b| b.name == body);
        let by_id = || {
            body.parse::<usize>()
                .ok()
                .filter(|&i| i < self.bodies.len())
        };
        by_name.or_else(by_id).map(|i| i as u32).ok_or_else(|| {
            let names: Vec<&str> = self.bodies.iter().map(|b| b.name.as_str()).collect();
            CommandError::UnknownBody(format!(
                "no body {body:?} in this world: its bodies are {} (by name, or by id 0 to {})",
                names.join(", "),
                self.bodies.len().saturating_sub(1)
            ))
        })
    }

    /// Check `command` for the body it names: finite, within what a hand may meet, no push
    /// on a fixed body. The orientation of a pose comes back normalised.
    pub fn check(
        &self,
        mut command: HapticdSceneCommand,
    ) -> Result<HapticdSceneCommand, CommandError> {
        let body = self.bodies.get(command.body as usize).ok_or_else(|| {
            CommandError::UnknownBody(format!("no body with id {}", command.body))
        })?;
        if !command.is_finite() {
            return Err(CommandError::NotFinite(format!(
                "a value for {} is not a finite number",
                body.name
            )));
        }
        let length = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let within = |what: &str, value: f64, limit: f64, unit: &str| {
            if value <= limit {
                Ok(())
            } else {
                Err(CommandError::OutOfRange(format!(
                    "{what} {value} {unit} for {} is beyond {limit} {unit}",
                    body.name
                )))
            }
        };
        let pushes = matches!(
            command.kind,
            HAPTICD_COMMAND_SET_VELOCITY
                | HAPTICD_COMMAND_IMPULSE
                | HAPTICD_COMMAND_IMPULSE_AT_CENTRE
                | HAPTICD_COMMAND_SET_FORCE
                | HAPTICD_COMMAND_SET_MASS
        );
        if pushes && body.fixed {
            return Err(CommandError::FixedBody(format!(
                "{} is fixed: forces do not move it, and it has no mass to set (its pose may be set)",
                body.name
            )));
        }
        match command.kind {
            HAPTICD_COMMAND_QUERY => {}
            HAPTICD_COMMAND_SET_POSE => {
                within("a position", length(&command.position), MAX_DISTANCE, "m")?;
                let norm = length(&command.orientation);
                if !(0.9..=1.1).contains(&norm) {
                    return Err(CommandError::OutOfRange(format!(
                        "the orientation for {} is no unit quaternion (w, x, y, z): its length is {norm}",
                        body.name
                    )));
                }
                command.orientation = command.orientation.map(|q| q / norm);
            }
            HAPTICD_COMMAND_SET_VELOCITY => {
                within("a speed", length(&command.vector), MAX_SPEED, "m/s")?;
                within("a spin", length(&command.spin), MAX_SPIN, "rad/s")?;
            }
            HAPTICD_COMMAND_IMPULSE => {
                within("an impulse", length(&command.vector), MAX_IMPULSE, "N·s")?;
                within("a point", length(&command.position), MAX_DISTANCE, "m")?;
            }
            HAPTICD_COMMAND_IMPULSE_AT_CENTRE => {
                within("an impulse", length(&command.vector), MAX_IMPULSE, "N·s")?;
            }
            HAPTICD_COMMAND_SET_FORCE => {
                within("a force", length(&command.vector), MAX_FORCE, "N")?
            }
            HAPTICD_COMMAND_SET_MASS => {
                if command.value <= 0.0 {
                    return Err(CommandError::OutOfRange(format!(
                        "a mass of {} kg for {}: a mass is positive",
                        command.value, body.name
                    )));
                }
                within("a mass", command.value, MAX_MASS, "kg")?;
            }
            HAPTICD_COMMAND_SET_FRICTION => {
                if command.value < 0.0 {
                    return Err(CommandError::OutOfRange(format!(
                        "a friction coefficient of {} for {}: it is 0 or more",
                        command.value, body.name
                    )));
                }
                within("a friction coefficient", command.value, MAX_FRICTION, "")?;
            }
            HAPTICD_COMMAND_SET_MATERIAL => {
                let [young, poisson, damping] = command.vector;
                let between = |what: &str, value: f64, (least, most): (f64, f64), unit: &str| {
                    if (least..=most).contains(&value) {
                        Ok(())
                    } else {
                        Err(CommandError::OutOfRange(format!(
                            "{what} of {value}{unit} for {}: it is from {least}{unit} to \
                             {most}{unit}",
                            body.name
                        )))
                    }
                };
                between("a Young's modulus", young, YOUNG_RANGE, " Pa")?;
                between("a Poisson's ratio", poisson, POISSON_RANGE, "")?;
                between("a damping", damping, (0.0, MOST_DAMPING), " s")?;
            }
            HAPTICD_COMMAND_PIN | HAPTICD_COMMAND_RELEASE => {
                let norm = length(&command.vector);
                if !(0.9..=1.1).contains(&norm) {
                    return Err(CommandError::OutOfRange(format!(
                        "the plane's normal for {} is no unit vector: its length is {norm}",
                        body.name
                    )));
                }
                command.vector = command.vector.map(|n| n / norm);
                within("a plane's offset", command.value.abs(), MAX_DISTANCE, "m")?;
            }
            kind => {
                return Err(CommandError::Refused(format!("no command of kind {kind}")));
            }
        }
        Ok(command)
    }

    /// Check `command` and hand it to the stepping thread without waiting for its answer:
    /// for a world not yet stepped, whose first steps carry it out.
    pub fn enqueue(&mut self, command: HapticdSceneCommand) -> Result<(), CommandError> {
        let command = self.check(command)?;
        self.next += 1;
        let id = self.next;
        let order = Order::Body(command);
        self.requests.try_push(Request { id, order }).map_err(|_| {
            CommandError::Timeout("the world has more changes waiting than it takes".into())
        })
    }

    /// Check `command`, hand it to the stepping thread and wait for its answer: the body's
    /// state after it.
    pub fn send(&mut self, command: HapticdSceneCommand) -> Result<HapticdBodyState, CommandError> {
        let command = self.check(command)?;
        let name = self.bodies[command.body as usize].name.clone();
        match self.wait(Order::Body(command), &name)? {
            (HAPTICD_OK, Answer::Body(state)) => Ok(state),
            _ if command.kind == HAPTICD_COMMAND_SET_MASS => {
                Err(CommandError::OutOfRange(format!(
                    "a mass of {} kg for {name} is not one its scene takes: as in a scene file, its \
                 density must stay in the engine's range and its contact springs stable at the \
                 scene's step",
                    command.value
                )))
            }
            _ if matches!(
                command.kind,
                HAPTICD_COMMAND_SET_MATERIAL | HAPTICD_COMMAND_PIN | HAPTICD_COMMAND_RELEASE
            ) =>
            {
                Err(CommandError::Refused(format!(
                    "{name} is not a soft body (or its scene is too old to change one): only a \
                     soft body has a material and nodes to hold"
                )))
            }
            (status, _) => Err(CommandError::Refused(format!(
                "the scene refused the change to {name} (status {status})"
            ))),
        }
    }

    /// Hand `order` (for `name`) to the stepping thread and wait for its answer: the
    /// plugin's status and the state it left.
    fn wait(&mut self, order: Order, name: &str) -> Result<(i32, Answer), CommandError> {
        let mut answers = self.wait_all(&[order], name)?;
        Ok(answers.remove(0))
    }

    /// Hand `orders` (for `what`) to the stepping thread at once and wait for all their
    /// answers, in order: carried out between the same two steps, when the ring holds them.
    fn wait_all(
        &mut self,
        orders: &[Order],
        what: &str,
    ) -> Result<Vec<(i32, Answer)>, CommandError> {
        let timeout = || {
            CommandError::Timeout(format!(
                "the world did not carry out the change to {what} within {} s",
                ANSWER_TIMEOUT.as_secs()
            ))
        };
        // Answers to requests that timed out before are dropped on the way.
        while self.replies.pop().is_some() {}
        let first = self.next + 1;
        for &order in orders {
            self.next += 1;
            let id = self.next;
            self.requests
                .try_push(Request { id, order })
                .map_err(|_| timeout())?;
        }
        let mut answers = vec![None; orders.len()];
        let mut left = orders.len();
        let started = Instant::now();
        while left > 0 {
            while let Some(reply) = self.replies.pop() {
                let slot = reply.id.checked_sub(first).map(|k| k as usize);
                if let Some(slot) = slot.and_then(|k| answers.get_mut(k))
                    && slot.is_none()
                {
                    *slot = Some((reply.status, reply.answer));
                    left -= 1;
                }
            }
            if left > 0 {
                if started.elapsed() > ANSWER_TIMEOUT {
                    return Err(timeout());
                }
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        Ok(answers.into_iter().flatten().collect())
    }
}

/// [rt] The stepping side's end of the requests.
pub struct Incoming {
    requests: spsc::Consumer<Request>,
    held: Option<Request>,
}

impl Incoming {
    /// The next request to carry out now, in the order sent; one that would jump a force is
    /// held (and those behind it wait) until [`Incoming::release`].
    pub fn due(&mut self) -> Option<Request> {
        if self.held.is_some() {
            return None;
        }
        let request = self.requests.pop()?;
        if request.jumps() {
            self.held = Some(request);
            return None;
        }
        Some(request)
    }

    /// Whether a request waits for the forces to be at zero.
    pub fn holding(&self) -> bool {
        self.held.is_some()
    }

    /// The request that waited for the forces to be at zero.
    pub fn release(&mut self) -> Option<Request> {
        self.held.take()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kind of a body's command.
    fn kind(r: &Request) -> u32 {
        match r.order() {
            Order::Body(c) => c.kind,
            Order::Joint(_) => unreachable!("only bodies here"),
        }
    }

    fn control() -> (SceneControl, Incoming, spsc::Producer<Reply>) {
        channel(
            vec![
                Body {
                    name: "floor".into(),
                    fixed: true,
                },
                Body {
                    name: "block".into(),
                    fixed: false,
                },
            ],
            Vec::new(),
        )
    }

    #[test]
    fn bodies_are_found_by_name_or_id_and_nothing_else() {
        let (control, ..) = control();
        assert_eq!(control.find("block"), Ok(1));
        assert_eq!(control.find("0"), Ok(0));
        for missing in ["2", "-1", "Block", ""] {
            let error = control.find(missing).unwrap_err();
            assert!(
                matches!(&error, CommandError::UnknownBody(m) if m.contains("floor, block")),
                "{error}"
            );
        }
    }

    #[test]
    fn hostile_values_are_refused_by_name_before_they_reach_the_world() {
        let (control, ..) = control();
        let cases = [
            (
                HapticdSceneCommand {
                    vector: [f64::NAN, 0.0, 0.0],
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE, 1)
                },
                "NotFinite",
            ),
            (
                HapticdSceneCommand {
                    position: [0.0, f64::INFINITY, 0.0],
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_POSE, 1)
                },
                "NotFinite",
            ),
            (
                HapticdSceneCommand {
                    vector: [11.0, 0.0, 0.0],
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_IMPULSE, 1)
                },
                "OutOfRange",
            ),
            (
                HapticdSceneCommand {
                    position: [1e9, 0.0, 0.0],
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_POSE, 1)
                },
                "OutOfRange",
            ),
            (
                HapticdSceneCommand {
                    orientation: [0.0; 4],
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_POSE, 1)
                },
                "OutOfRange",
            ),
            (
                HapticdSceneCommand {
                    vector: [0.0, 1e6, 0.0],
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_FORCE, 1)
                },
                "OutOfRange",
            ),
            (
                HapticdSceneCommand {
                    value: -2.0,
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
                },
                "OutOfRange",
            ),
            (
                HapticdSceneCommand {
                    value: 1e300,
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 1)
                },
                "OutOfRange",
            ),
            (
                HapticdSceneCommand {
                    value: -0.1,
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_FRICTION, 1)
                },
                "OutOfRange",
            ),
            (
                HapticdSceneCommand {
                    spin: [0.0, 0.0, 1e4],
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_VELOCITY, 1)
                },
                "OutOfRange",
            ),
            (
                HapticdSceneCommand {
                    vector: [1.0, 0.0, 0.0],
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_VELOCITY, 0)
                },
                "FixedBody",
            ),
            (
                HapticdSceneCommand {
                    value: 1.0,
                    ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_MASS, 0)
                },
                "FixedBody",
            ),
            (
                HapticdSceneCommand::new(HAPTICD_COMMAND_QUERY, 2),
                "UnknownBody",
            ),
            (HapticdSceneCommand::new(77, 1), "Refused"),
        ];
        for (command, expected) in cases {
            let error = control.check(command).unwrap_err();
            let name = format!("{error:?}");
            assert!(name.starts_with(expected), "{command:?}: {name}");
        }
        // A fixed body may be put elsewhere, and a nearly unit quaternion is made one.
        let moved = control
            .check(HapticdSceneCommand {
                orientation: [0.0, 0.0, 1.05, 0.0],
                ..HapticdSceneCommand::new(HAPTICD_COMMAND_SET_POSE, 0)
            })
            .unwrap();
        assert_eq!(moved.orientation, [0.0, 0.0, 1.0, 0.0]);
    }

    #[test]
    fn a_pose_waits_for_quiet_and_the_requests_behind_it_keep_their_order() {
        let (mut control, mut incoming, mut answers) = control();
        let worker = std::thread::spawn(move || {
            let mut order = Vec::new();
            let mut held_seen = false;
            while order.len() < 3 {
                while let Some(r) = incoming.due() {
                    order.push(kind(&r));
                    answers.push(Reply::to(&r, HAPTICD_OK, Answer::Body(Default::default())));
                }
                if incoming.holding() {
                    held_seen = true;
                    let r = incoming.release().unwrap();
                    order.push(kind(&r));
                    answers.push(Reply::to(&r, HAPTICD_OK, Answer::Body(Default::default())));
                }
                std::thread::sleep(Duration::from_millis(1));
            }
            (order, held_seen)
        });
        for kind in [
            HAPTICD_COMMAND_QUERY,
            HAPTICD_COMMAND_SET_POSE,
            HAPTICD_COMMAND_SET_FRICTION,
        ] {
            let mut c = HapticdSceneCommand::new(kind, 1);
            c.value = 0.3;
            control.send(c).unwrap();
        }
        let (order, held_seen) = worker.join().unwrap();
        assert!(held_seen);
        assert_eq!(
            order,
            [
                HAPTICD_COMMAND_QUERY,
                HAPTICD_COMMAND_SET_POSE,
                HAPTICD_COMMAND_SET_FRICTION
            ]
        );
    }

    #[test]
    fn a_refusal_is_named_and_a_world_that_never_answers_times_out() {
        let (mut control, mut incoming, mut answers) = control();
        let worker = std::thread::spawn(move || {
            loop {
                if let Some(r) = incoming.due() {
                    answers.push(Reply::to(
                        &r,
                        HAPTICD_ERROR_ARGUMENT,
                        Answer::Body(HapticdBodyState::default()),
                    ));
                    return incoming;
                }
                std::thread::sleep(Duration::from_millis(1));
            }
        });
        let refused = control
            .send(HapticdSceneCommand::new(HAPTICD_COMMAND_QUERY, 1))
            .unwrap_err();
        assert!(matches!(refused, CommandError::Refused(_)), "{refused:?}");
        let _silent = worker.join().unwrap();
        let late = control
            .send(HapticdSceneCommand::new(HAPTICD_COMMAND_QUERY, 1))
            .unwrap_err();
        assert!(matches!(late, CommandError::Timeout(_)), "{late:?}");
    }
}

//! One device on the network: every `every`-th tick of its telemetry ring published as its
//! effectors' poses, twists and wrenches and its strings' tensions (stamped with the tick's
//! time; each publisher numbering its own messages and naming its own id in their
//! attachments, as rmw_zenoh's do: [`RosPublisher`]), and whole under hapticd's own telemetry
//! key; its world's bodies whenever its picture of the world changes
//! (60 times a second); its state when it changes and once a second, the last kept for
//! subscriptions that come later (transient-local); each touch as it
//! happens. The node and its publishers are announced by liveliness tokens as rmw_zenoh
//! announces its own, and its status is answered as JSON. With commands on, each effector's
//! `wrench_command` topic goes into the device's wrench input.

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use hapticd_core::kinematics::Wrench;
use hapticd_core::telemetry::Sample;
use hapticd_core::transport::CHANNELS;
use hapticd_core::world_state::{MAX_BODIES, WorldFrame, state_of};
use hapticd_ipc::client::{ClientError, Device, Scene};
use hapticd_ipc::touch_events::{Touch, TouchTracker};
use hapticd_ipc::world_share::MappedWorld;
use hapticd_ros2::keys::{DEFAULT_QOS, Graph, Node, TRANSIENT_LOCAL_QOS};
use hapticd_ros2::messages::{
    Header, JointState, Message, PoseArray, PoseStamped, StringMessage, Time, TwistStamped,
    WrenchStamped,
};
use zenoh::Wait;

use crate::ros_publisher::RosPublisher;
use crate::topics::{DeviceTopics, Topic};

/// Nanoseconds since the Unix epoch now: the stamp of what is published.
fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// How often the state is published when it does not change.
const STATE_EVERY: Duration = Duration::from_secs(1);

/// How often the world's picture is looked at for new body poses: twice its rate.
const WORLD_EVERY: Duration = Duration::from_micros(8333);
/// How often the world's joints are read (each a call on the bus) and published.
const JOINTS_EVERY: Duration = Duration::from_millis(20);

/// What went wrong bridging a device.
#[derive(Debug)]
pub enum BridgeError {
    /// hapticd refused or could not be reached.
    Client(ClientError),
    /// Zenoh refused.
    Zenoh(String),
}

impl std::fmt::Display for BridgeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BridgeError::Client(e) => e.fmt(f),
            BridgeError::Zenoh(e) => write!(f, "zenoh: {e}"),
        }
    }
}

impl From<ClientError> for BridgeError {
    fn from(e: ClientError) -> Self {
        BridgeError::Client(e)
    }
}

impl From<zenoh::Error> for BridgeError {
    fn from(e: zenoh::Error) -> Self {
        zenoh_error(e)
    }
}

/// A zenoh error as the bridge says it.
pub fn zenoh_error(e: impl std::fmt::Display) -> BridgeError {
    BridgeError::Zenoh(e.to_string())
}

/// How a device is bridged.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// The ROS graph: domain and distribution.
    pub graph: Graph,
    /// The ROS node's number within the session (one node a device).
    pub node: u32,
    /// Publish one tick in so many.
    pub every: u64,
    /// Whether the bridge takes commands (said in the status).
    pub commands: bool,
}

/// The publishers and subscriptions of one device, with the liveliness tokens that
/// announce them.
struct Entities<'a> {
    session: &'a zenoh::Session,
    node: Node,
    tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

impl<'a> Entities<'a> {
    /// Announce `token`.
    fn announce(&mut self, token: String) -> Result<(), BridgeError> {
        self.tokens.push(
            self.session
                .liveliness()
                .declare_token(token)
                .wait()
                .map_err(zenoh_error)?,
        );
        Ok(())
    }

    /// The next entity's number.
    fn next(&self) -> u32 {
        self.node.id + self.tokens.len() as u32 + 1
    }

    /// The publisher of `topic`, messages `M`, announced.
    fn publisher<M: Message>(&mut self, topic: &Topic) -> Result<RosPublisher<'a>, BridgeError> {
        let token = self
            .node
            .publisher::<M>(self.next(), &topic.name, DEFAULT_QOS);
        self.announce(token.clone())?;
        Ok(RosPublisher::new(self.declare(topic)?, &token))
    }

    /// The publisher of `topic`, messages `M`, announced as transient-local: its last message
    /// reaches subscriptions that come later.
    fn latched_publisher<M: Message>(
        &mut self,
        topic: &Topic,
    ) -> Result<RosPublisher<'a>, BridgeError> {
        let token = self
            .node
            .publisher::<M>(self.next(), &topic.name, TRANSIENT_LOCAL_QOS);
        self.announce(token.clone())?;
        RosPublisher::latched(self.session, self.declare(topic)?, &token).map_err(zenoh_error)
    }

    /// A Zenoh publisher on `topic`'s key.
    fn declare(&self, topic: &Topic) -> Result<zenoh::pubsub::Publisher<'a>, BridgeError> {
        self.session
            .declare_publisher(topic.key.clone())
            .wait()
            .map_err(zenoh_error)
    }

    /// A subscription to `topic`, messages `M`, announced, handing each sample to `take`.
    fn subscription<M: Message>(
        &mut self,
        topic: &Topic,
        take: impl Fn(zenoh::sample::Sample) + Send + Sync + 'static,
    ) -> Result<zenoh::pubsub::Subscriber<()>, BridgeError> {
        self.announce(self.node.subscription::<M>(self.next(), &topic.name))?;
        self.session
            .declare_subscriber(topic.key.clone())
            .callback(take)
            .wait()
            .map_err(zenoh_error)
    }
}

/// Take each effector's `wrench_command` topic into `device`'s wrench input: every message
/// (a `WrenchStamped` in the device's frame, whatever its frame id says) replaces that
/// effector's wrench and refreshes all of them. Nothing when hapticd refuses the bridge's
/// user the input (said in the log): the topics are then not taken.
fn take_wrench_commands(
    device: &Device,
    topics: &DeviceTopics,
    entities: &mut Entities<'_>,
) -> Result<Vec<zenoh::pubsub::Subscriber<()>>, BridgeError> {
    let input = match device.open_wrench_input() {
        Ok(input) => input,
        Err(e) => {
            tracing::warn!(
                "{}: the wrench command topics are not taken: {e}",
                topics.device
            );
            return Ok(Vec::new());
        }
    };
    let shared = Arc::new(Mutex::new((
        input,
        vec![Wrench::ZERO; topics.effectors.len()],
    )));
    let mut subscriptions = Vec::new();
    for (k, t) in topics.effectors.iter().enumerate() {
        let shared = shared.clone();
        subscriptions.push(
            entities.subscription::<WrenchStamped>(&t.command, move |sample| {
                let Ok(message) = WrenchStamped::decode(&sample.payload().to_bytes()) else {
                    return;
                };
                let [fx, fy, fz] = message.force;
                let [tx, ty, tz] = message.torque;
                let mut held = shared.lock().unwrap_or_else(|p| p.into_inner());
                let (input, wrenches) = &mut *held;
                wrenches[k] = Wrench::from_array([fx, fy, fz, tx, ty, tz]);
                input.write(wrenches);
            })?,
        );
    }
    Ok(subscriptions)
}

/// A touch as the touches topic says it (JSON).
fn touch_json(touch: &Touch, effectors: &[String]) -> String {
    serde_json::json!({
        "effector": effectors.get(touch.effector as usize),
        "event": touch.event.name(),
        "tick": touch.tick,
        "time": touch.time,
        "body": touch.body,
        "point": touch.point,
        "normal": touch.normal,
        "force": touch.force,
    })
    .to_string()
}

/// Publish `device`'s ticks on `session` as `settings` say until `until` (for ever without
/// one), and where the joints of the `scene` it runs stand; answer its status all the while. `declared` is dropped once everything is declared
/// (or the bridge failed first).
pub fn run(
    session: &zenoh::Session,
    (device, scene): (&Device, Option<&Scene>),
    settings: Settings,
    until: Option<Instant>,
    declared: std::sync::mpsc::Sender<()>,
) -> Result<(), BridgeError> {
    let identity = device.identity()?;
    let effectors = device.effectors()?;
    let topics = DeviceTopics::new(settings.graph, &identity, &effectors);
    let (node_token, mut entities) = announce_node(session, settings, &topics)?;
    let publishers = Publishers::declare(session, &topics, &mut entities)?;
    let commands = if settings.commands {
        take_wrench_commands(device, &topics, &mut entities)?
    } else {
        Vec::new()
    };
    let last = Arc::new((AtomicU64::new(0), AtomicU32::new(0)));
    let ring = device.open_telemetry()?;
    let status = declare_status(
        session,
        &topics,
        (identity.clone(), last.clone(), effectors.clone()),
        ring.rate(),
        settings,
    )?;
    let string_names: Vec<String> = (0..CHANNELS).map(|k| format!("string{k}")).collect();
    let mut cursor = ring.from_now();
    let mut sample = Sample::EMPTY;
    let mut touches = TouchTracker::new();
    let mut waited = Instant::now();
    let mut state_said: Option<(u32, Instant)> = None;
    let world = device.open_world()?;
    let mut frame = Box::new(WorldFrame::empty());
    let (mut world_seen, mut world_looked) = (None, Instant::now());
    let mut joints_read = Instant::now();
    drop(declared);
    while until.is_none_or(|t| Instant::now() < t) {
        if joints_read.elapsed() >= JOINTS_EVERY {
            joints_read = Instant::now();
            publish_joints(scene, &topics.frame, &publishers.joints)?;
        }
        if world_looked.elapsed() >= WORLD_EVERY {
            world_looked = Instant::now();
            publish_bodies(
                &world,
                &mut frame,
                &mut world_seen,
                &topics.frame,
                &publishers.bodies,
            )?;
        }
        if !ring.next(&mut cursor, &mut sample) {
            if waited.elapsed() > Duration::from_secs(2) {
                return Err(BridgeError::Client(ClientError::Stopped));
            }
            std::thread::sleep(Duration::from_micros(200));
            continue;
        }
        waited = Instant::now();
        last.0.store(sample.tick, Ordering::Relaxed);
        last.1.store(sample.state, Ordering::Relaxed);
        let stamp = now_ns();
        let header = Header {
            stamp: Time::from_nanos(stamp),
            frame_id: topics.frame.clone(),
        };
        publish_touches(
            &mut touches,
            &sample,
            &effectors,
            &publishers.touches,
            stamp as i64,
        )?;
        if state_said.is_none_or(|(s, at)| s != sample.state || at.elapsed() >= STATE_EVERY) {
            let text = StringMessage {
                data: state_of(sample.state).name().into(),
            };
            publishers.state.put(text.encode(), stamp as i64)?;
            state_said = Some((sample.state, Instant::now()));
        }
        if !sample.tick.is_multiple_of(settings.every) {
            continue;
        }
        publish_tick(&publishers, &sample, header, &string_names, stamp as i64)?;
    }
    drop((status, commands, node_token, entities));
    Ok(())
}

/// The device's ROS node on `session`, announced, with none of its entities yet.
fn announce_node<'a>(
    session: &'a zenoh::Session,
    settings: Settings,
    topics: &DeviceTopics,
) -> Result<(zenoh::liveliness::LivelinessToken, Entities<'a>), BridgeError> {
    let node = Node {
        graph: settings.graph,
        zid: session.zid().to_string(),
        id: settings.node * 1000,
        namespace: "/".into(),
        name: topics.frame.clone(),
    };
    let node_token = session
        .liveliness()
        .declare_token(node.token())
        .wait()
        .map_err(zenoh_error)?;
    let entities = Entities {
        session,
        node,
        tokens: Vec::new(),
    };
    Ok((node_token, entities))
}

/// The publishers of one device's topics, and of hapticd's own telemetry.
struct Publishers<'a> {
    /// Each effector's pose, twist and wrench.
    effectors: Vec<(RosPublisher<'a>, RosPublisher<'a>, RosPublisher<'a>)>,
    strings: RosPublisher<'a>,
    bodies: RosPublisher<'a>,
    joints: RosPublisher<'a>,
    state: RosPublisher<'a>,
    touches: RosPublisher<'a>,
    /// Whole samples, under hapticd's own key: no ROS topic, so not announced (its id is
    /// derived from its key).
    telemetry: RosPublisher<'a>,
}

impl<'a> Publishers<'a> {
    /// Declare the publishers of `topics` on `session`, the ROS ones announced by `entities`.
    fn declare(
        session: &'a zenoh::Session,
        topics: &DeviceTopics,
        entities: &mut Entities<'a>,
    ) -> Result<Self, BridgeError> {
        let mut effectors = Vec::new();
        for t in &topics.effectors {
            effectors.push((
                entities.publisher::<PoseStamped>(&t.pose)?,
                entities.publisher::<TwistStamped>(&t.twist)?,
                entities.publisher::<WrenchStamped>(&t.wrench)?,
            ));
        }
        Ok(Self {
            effectors,
            strings: entities.publisher::<JointState>(&topics.strings)?,
            bodies: entities.publisher::<PoseArray>(&topics.bodies)?,
            joints: entities.publisher::<JointState>(&topics.joints)?,
            state: entities.latched_publisher::<StringMessage>(&topics.state)?,
            touches: entities.publisher::<StringMessage>(&topics.touches)?,
            telemetry: RosPublisher::new(
                session
                    .declare_publisher(topics.telemetry())
                    .wait()
                    .map_err(zenoh_error)?,
                &topics.telemetry(),
            ),
        })
    }
}

/// Answer the device's status as JSON: who it is, its last tick and state, how it is bridged.
fn declare_status(
    session: &zenoh::Session,
    topics: &DeviceTopics,
    (identity, last, effectors): (String, Arc<(AtomicU64, AtomicU32)>, Vec<String>),
    rate: f64,
    settings: Settings,
) -> Result<zenoh::query::Queryable<()>, BridgeError> {
    let telemetry_key = topics.telemetry();
    let mut names: Vec<String> = topics
        .effectors
        .iter()
        .flat_map(|t| [&t.pose, &t.twist, &t.wrench])
        .chain([
            &topics.strings,
            &topics.bodies,
            &topics.joints,
            &topics.state,
            &topics.touches,
        ])
        .map(|t| t.name.clone())
        .collect();
    names.sort();
    session
        .declare_queryable(topics.status())
        .callback(move |query| {
            let body = serde_json::json!({
                "identity": identity,
                "effectors": effectors,
                "rate": rate,
                "tick": last.0.load(Ordering::Relaxed),
                "state": state_of(last.1.load(Ordering::Relaxed)).name(),
                "publishing_every": settings.every,
                "topics": names,
                "telemetry": telemetry_key,
                "domain": settings.graph.domain,
                "commands": settings.commands,
            });
            let _ = query
                .reply(query.key_expr().clone(), body.to_string())
                .wait();
        })
        .wait()
        .map_err(zenoh_error)
}

/// Publish where the world's joints with a coordinate stand, read between the same two
/// steps: nothing when it has none, or when the world changed between the list and the
/// states (the next round reads the new one).
fn publish_joints(
    scene: Option<&Scene>,
    frame_id: &str,
    publisher: &RosPublisher<'_>,
) -> Result<(), BridgeError> {
    let Some(scene) = scene else {
        return Ok(());
    };
    let (Ok(joints), Ok(states)) = (scene.joints(), scene.joint_states()) else {
        return Ok(());
    };
    let stamp = now_ns();
    let mut message = JointState {
        header: Header {
            stamp: Time::from_nanos(stamp),
            frame_id: frame_id.to_owned(),
        },
        name: Vec::new(),
        position: Vec::new(),
        velocity: Vec::new(),
        effort: Vec::new(),
    };
    let moving = |kind: &str| kind == "revolute" || kind == "prismatic";
    for (joint, (name, state)) in joints.iter().zip(states) {
        if joint.name != name {
            return Ok(());
        }
        if moving(&joint.kind) {
            message.name.push(name);
            message.position.push(state.position);
            message.velocity.push(state.velocity);
        }
    }
    if message.name.is_empty() {
        return Ok(());
    }
    Ok(publisher.put(message.encode(), stamp as i64)?)
}

/// Publish the world's bodies if its picture (read into `frame`) is not the one `seen`.
fn publish_bodies(
    world: &MappedWorld,
    frame: &mut WorldFrame,
    seen: &mut Option<u64>,
    frame_id: &str,
    publisher: &RosPublisher<'_>,
) -> Result<(), BridgeError> {
    if let Some(sequence) = world.read(frame)
        && *seen != Some(sequence)
    {
        *seen = Some(sequence);
        let stamp = now_ns();
        let n = (frame.body_count as usize).min(MAX_BODIES);
        let bodies = PoseArray {
            header: Header {
                stamp: Time::from_nanos(stamp),
                frame_id: frame_id.to_owned(),
            },
            poses: frame.bodies[..n]
                .iter()
                .map(|b| {
                    let [w, x, y, z] = b.orientation;
                    (b.position, [x, y, z, w])
                })
                .collect(),
        };
        publisher.put(bodies.encode(), stamp as i64)?;
    }
    Ok(())
}

/// Publish each touch `touches` finds in `sample`, as JSON; stop at the first that fails.
fn publish_touches(
    touches: &mut TouchTracker,
    sample: &Sample,
    effectors: &[String],
    publisher: &RosPublisher<'_>,
    stamp_ns: i64,
) -> Result<(), BridgeError> {
    let mut touched = Ok(());
    touches.follow(sample, |touch| {
        if touched.is_ok() {
            let text = StringMessage {
                data: touch_json(&touch, effectors),
            };
            touched = publisher
                .put(text.encode(), stamp_ns)
                .map_err(BridgeError::from);
        }
    });
    touched
}

/// Publish each effector's pose, twist and wrench, the strings' tensions and the sample.
fn publish_tick(
    publishers: &Publishers<'_>,
    sample: &Sample,
    header: Header,
    string_names: &[String],
    stamp_ns: i64,
) -> Result<(), BridgeError> {
    for (k, (pose, twist, wrench)) in publishers.effectors.iter().enumerate() {
        let p = &sample.poses[k];
        let [w, x, y, z] = p.orientation;
        let pose_message = PoseStamped {
            header: header.clone(),
            position: p.position,
            orientation: [x, y, z, w],
        };
        let twist_message = TwistStamped {
            header: header.clone(),
            linear: sample.velocities[k],
            angular: sample.angular_velocities[k],
        };
        let wrench_message = WrenchStamped {
            header: header.clone(),
            force: sample.wrenches[k].force,
            torque: sample.wrenches[k].torque,
        };
        pose.put(pose_message.encode(), stamp_ns)?;
        twist.put(twist_message.encode(), stamp_ns)?;
        wrench.put(wrench_message.encode(), stamp_ns)?;
    }
    let strings = (sample.strings as usize).min(string_names.len());
    let tensions = JointState {
        header,
        name: string_names[..strings].to_vec(),
        position: Vec::new(),
        velocity: Vec::new(),
        effort: sample.tensions[..strings].to_vec(),
    };
    publishers.strings.put(tensions.encode(), stamp_ns)?;
    Ok(publishers.telemetry.put(sample.encode(), stamp_ns)?)
}

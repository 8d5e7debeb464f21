//! A blocking client of hapticd, for programs and scripts built on it: the daemon's devices,
//! their parameters, calibration, every tick of their haptic loop, their touches and their
//! picture of the world, the scenes, and the running world's bodies. Each
//! call runs the typed proxies of [`crate::proxies`] to completion; the proxies themselves
//! serve what this does not wrap.
//!
//! ```no_run
//! use std::time::Duration;
//! use hapticd_ipc::bus::Bus;
//! use hapticd_ipc::client::Hapticd;
//!
//! let hapticd = Hapticd::connect(&Bus::System)?;
//! let device = &hapticd.devices()?[0];
//! println!("{} runs {}", device.identity()?, device.mechanism()?);
//! device.set("Stiffness", 1500.0)?;
//! for sample in device.telemetry(1.0)? {
//!     println!("{} {:?} {:?}", sample.tick, sample.poses[0].position, sample.wrenches[0].force);
//! }
//! hapticd.switch_scene("blocks", Duration::from_secs(60), &mut |_| {})?;
//! # Ok::<(), hapticd_ipc::client::ClientError>(())
//! ```

use std::collections::HashMap;
use std::time::{Duration, Instant};

use hapticd_core::telemetry::Sample;
use zbus::{OwnedVariant, Variant};

use crate::bus::{Bus, has_owner};
use crate::names::{BUS_NAME, DEVICE_INTERFACE, ERROR_PREFIX};
use crate::proxies::{DeviceProxy, ManagerProxy, SceneProxy};
use crate::shared_memory::MapError;
use crate::telemetry_share::{Cursor, MappedTelemetry};
use crate::world_link_share::WorldLink;
use crate::world_share::MappedWorld;
use crate::wrench_share::MappedWrenchInput;

/// What went wrong talking to hapticd.
#[derive(Debug)]
pub enum ClientError {
    /// No hapticd owns its name on the bus.
    NotRunning,
    /// hapticd (or the bus) refused the request: the D-Bus error name (such as
    /// `org.hapticd.Hapticd1.Error.OutOfRange`) and why.
    Refused {
        /// The D-Bus error name.
        name: String,
        /// The daemon's message.
        message: String,
    },
    /// The bus itself failed.
    Bus(zbus::Error),
    /// A shared memory the daemon handed out could not be read.
    Memory(MapError),
    /// The haptic loop stopped writing ticks while they were followed.
    Stopped,
}

impl std::fmt::Display for ClientError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ClientError::NotRunning => f.write_str("hapticd is not running on this bus"),
            ClientError::Refused { name, message } => write!(f, "{name}: {message}"),
            ClientError::Bus(e) => write!(f, "the bus: {e}"),
            ClientError::Memory(e) => e.fmt(f),
            ClientError::Stopped => f.write_str("the haptic loop stopped writing ticks"),
        }
    }
}

impl std::error::Error for ClientError {}

impl From<zbus::Error> for ClientError {
    fn from(e: zbus::Error) -> Self {
        match e {
            zbus::Error::MethodError(name, message, _) => ClientError::Refused {
                name: name.to_string(),
                message: message.unwrap_or_default(),
            },
            zbus::Error::FDO(fdo) => (*fdo).into(),
            other => ClientError::Bus(other),
        }
    }
}

impl From<zbus::fdo::Error> for ClientError {
    fn from(e: zbus::fdo::Error) -> Self {
        match e {
            zbus::fdo::Error::ZBus(e) => e.into(),
            fdo => ClientError::Refused {
                name: zbus::DBusError::name(&fdo).to_string(),
                message: zbus::DBusError::description(&fdo)
                    .unwrap_or_default()
                    .to_string(),
            },
        }
    }
}

/// The daemon, through one bus connection.
pub struct Hapticd {
    connection: zbus::Connection,
    manager: ManagerProxy<'static>,
}

impl Hapticd {
    /// hapticd on `bus`; [`ClientError::NotRunning`] when no one owns its name (asking never
    /// starts a daemon the bus could activate).
    pub fn connect(bus: &Bus) -> Result<Self, ClientError> {
        let connection = zbus::block_on(bus.connection())?;
        if !zbus::block_on(has_owner(&connection, BUS_NAME))? {
            return Err(ClientError::NotRunning);
        }
        Self::on(connection)
    }

    /// hapticd through `connection`, a connection of the program's own.
    pub fn on(connection: zbus::Connection) -> Result<Self, ClientError> {
        let manager = zbus::block_on(ManagerProxy::new(&connection))?;
        Ok(Self {
            connection,
            manager,
        })
    }

    /// Its devices, in order.
    pub fn devices(&self) -> Result<Vec<Device>, ClientError> {
        zbus::block_on(self.manager.devices())?
            .into_iter()
            .map(|path| Device::on(&self.connection, path.as_str()))
            .collect()
    }

    /// The names of the scenes it switches to.
    pub fn scenes(&self) -> Result<Vec<String>, ClientError> {
        Ok(zbus::block_on(self.manager.scenes())?)
    }

    /// The scene running.
    pub fn active_scene(&self) -> Result<String, ClientError> {
        Ok(zbus::block_on(self.manager.active_scene())?)
    }

    /// Read the configuration and look for plugins, descriptors and scenes again; a malformed
    /// configuration is refused with its places, and nothing changes.
    pub fn reload_plugins(&self) -> Result<(), ClientError> {
        Ok(zbus::block_on(self.manager.reload_plugins())?)
    }

    /// The running world's bodies, to read and to change.
    pub fn scene(&self) -> Result<Scene, ClientError> {
        Ok(Scene {
            proxy: zbus::block_on(SceneProxy::new(&self.connection))?,
        })
    }

    /// Switch every device to the scene called `name`, the forces ramped down and up again;
    /// while hapticd says its meshes are being cut into convex pieces (`Error.Preparing`),
    /// ask again for up to `wait`, telling `waiting` what hapticd said each time.
    pub fn switch_scene(
        &self,
        name: &str,
        wait: Duration,
        waiting: &mut dyn FnMut(&str),
    ) -> Result<(), ClientError> {
        let preparing = format!("{ERROR_PREFIX}.Preparing");
        let deadline = Instant::now() + wait;
        loop {
            match zbus::block_on(self.manager.switch_scene(name)).map_err(ClientError::from) {
                Err(ClientError::Refused { name, message })
                    if name == preparing && Instant::now() < deadline =>
                {
                    waiting(&message);
                    std::thread::sleep(Duration::from_millis(500));
                }
                other => return other,
            }
        }
    }
}

/// One device of the daemon.
pub struct Device {
    proxy: DeviceProxy<'static>,
    properties: zbus::fdo::PropertiesProxy<'static>,
}

impl Device {
    /// The device at object `path`, through `connection`.
    pub fn on(connection: &zbus::Connection, path: &str) -> Result<Self, ClientError> {
        let path = path.to_string();
        let proxy = zbus::block_on(DeviceProxy::builder(connection).path(path.clone()).build())?;
        let properties = zbus::block_on(
            zbus::fdo::PropertiesProxy::builder(connection)
                .destination(BUS_NAME)
                .path(path)
                .build(),
        )?;
        Ok(Self { proxy, properties })
    }

    /// The typed proxy, for everything this does not wrap.
    pub fn proxy(&self) -> &DeviceProxy<'static> {
        &self.proxy
    }

    /// Its stable identity (bus path or serial, or `sim`).
    pub fn identity(&self) -> Result<String, ClientError> {
        Ok(zbus::block_on(self.proxy.identity())?)
    }

    /// running, calibrating, fault, disconnected or uncalibrated.
    pub fn state(&self) -> Result<String, ClientError> {
        Ok(zbus::block_on(self.proxy.state())?)
    }

    /// Its effectors' names, in order.
    pub fn effectors(&self) -> Result<Vec<String>, ClientError> {
        Ok(zbus::block_on(self.proxy.effectors())?)
    }

    /// The mechanism that drives it.
    pub fn mechanism(&self) -> Result<String, ClientError> {
        Ok(zbus::block_on(self.proxy.mechanism())?)
    }

    /// Set the parameter `name` (`Stiffness`, `MaxForce`, …; a number each); a value hapticd
    /// refuses (NaN, out of range) is [`ClientError::Refused`] and changes nothing.
    pub fn set(&self, name: &str, value: f64) -> Result<(), ClientError> {
        let interface = zbus::names::InterfaceName::try_from(DEVICE_INTERFACE)
            .expect("the device interface's name is valid");
        Ok(zbus::block_on(self.properties.set(
            interface,
            name,
            &Variant::from(value),
        ))?)
    }

    /// Take the counter offsets now, every grip held at its calibration pose.
    pub fn calibrate(&self) -> Result<(), ClientError> {
        Ok(zbus::block_on(self.proxy.calibrate())?)
    }

    /// Let the forces come back after a fault.
    pub fn reset_fault(&self) -> Result<(), ClientError> {
        Ok(zbus::block_on(self.proxy.reset_fault())?)
    }

    /// The effects rendered besides the scene, by id, each as written.
    pub fn effects(&self) -> Result<Vec<(u32, String)>, ClientError> {
        Ok(zbus::block_on(self.proxy.effects())?)
    }

    /// Start the effect `yaml` describes (one entry of a scene file's `effects:`); its id.
    pub fn add_effect(&self, yaml: &str) -> Result<u32, ClientError> {
        Ok(zbus::block_on(self.proxy.add_effect(yaml))?)
    }

    /// Cross-fade effect `id` into the one `yaml` describes.
    pub fn change_effect(&self, id: u32, yaml: &str) -> Result<(), ClientError> {
        Ok(zbus::block_on(self.proxy.change_effect(id, yaml))?)
    }

    /// Fade effect `id` out.
    pub fn remove_effect(&self, id: u32) -> Result<(), ClientError> {
        Ok(zbus::block_on(self.proxy.remove_effect(id))?)
    }

    /// Fade every effect out.
    pub fn clear_effects(&self) -> Result<(), ClientError> {
        Ok(zbus::block_on(self.proxy.clear_effects())?)
    }

    /// Drive the device with the installed mechanism `mechanism` from its next start.
    pub fn bind_mechanism(&self, mechanism: &str) -> Result<(), ClientError> {
        Ok(zbus::block_on(self.proxy.bind_mechanism(mechanism))?)
    }

    /// The device's telemetry ring, mapped read-only.
    pub fn open_telemetry(&self) -> Result<MappedTelemetry, ClientError> {
        let fd = zbus::block_on(self.proxy.open_telemetry(HashMap::new()))?;
        MappedTelemetry::open(&fd.into()).map_err(ClientError::Memory)
    }

    /// A wrench of the caller's to add to what the device displays (root and the hapticd
    /// group only), replacing any opened before; see [`MappedWrenchInput`].
    pub fn open_wrench_input(&self) -> Result<MappedWrenchInput, ClientError> {
        let fd = zbus::block_on(self.proxy.open_wrench_input(HashMap::new()))?;
        MappedWrenchInput::open(&fd.into()).map_err(ClientError::Memory)
    }

    /// The link of the device's remote scenes to a world on another machine (root and the
    /// hapticd group only); see [`WorldLink`].
    pub fn open_world_link(&self) -> Result<WorldLink, ClientError> {
        let fd = zbus::block_on(self.proxy.open_world_link(HashMap::new()))?;
        WorldLink::open(&fd.into()).map_err(ClientError::Memory)
    }

    /// The device's picture of the world (its grips, strings and the scene's bodies, as
    /// the renderer draws them), mapped read-only.
    pub fn open_world(&self) -> Result<MappedWorld, ClientError> {
        let fd = zbus::block_on(self.proxy.open_world())?;
        MappedWorld::open(&fd.into()).map_err(ClientError::Memory)
    }

    /// The device's touches as they are announced, from now on: each waits for the next.
    pub fn touches(&self) -> Result<Touches, ClientError> {
        let rule = format!(
            "type='signal',interface='{DEVICE_INTERFACE}',member='Touch',path='{}'",
            self.proxy.inner().path()
        );
        let connection = self.proxy.inner().connection();
        let stream = zbus::block_on(zbus::MessageStream::for_match_rule(
            rule.as_str(),
            connection,
            None,
        ))?;
        Ok(Touches { stream })
    }

    /// Every tick of the haptic loop from now for `seconds` of its ticks, as they are
    /// written.
    pub fn telemetry(&self, seconds: f64) -> Result<Ticks, ClientError> {
        let ring = self.open_telemetry()?;
        let cursor = ring.from_now();
        let end = cursor.next + (seconds * ring.rate()).round().max(1.0) as u64;
        Ok(Ticks {
            ring,
            cursor,
            end,
            stopped: false,
        })
    }
}

/// Ticks of a device's haptic loop as they are written (see [`Device::telemetry`]); it ends
/// early should the loop stop writing for two seconds ([`Ticks::stopped`] says so).
pub struct Ticks {
    ring: MappedTelemetry,
    cursor: Cursor,
    end: u64,
    stopped: bool,
}

impl Ticks {
    /// Ticks overwritten before they were read.
    pub fn missed(&self) -> u64 {
        self.cursor.missed
    }

    /// Whether the loop stopped writing before the end.
    pub fn stopped(&self) -> bool {
        self.stopped
    }

    /// Haptic ticks per second.
    pub fn rate(&self) -> f64 {
        self.ring.rate()
    }
}

impl Iterator for Ticks {
    type Item = Sample;

    fn next(&mut self) -> Option<Sample> {
        let mut sample = Sample::EMPTY;
        let waited = Instant::now();
        while self.cursor.next < self.end && !self.stopped {
            if self.ring.next(&mut self.cursor, &mut sample) {
                return Some(sample);
            }
            if waited.elapsed() > Duration::from_secs(2) {
                self.stopped = true;
                break;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        None
    }
}

/// What happened to an effector's touch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TouchEvent {
    /// It began touching a body (or another body than before).
    Begin,
    /// It stopped touching it.
    End,
    /// It began to slide along it after sticking.
    Slip,
}

/// A change of an effector's touch, as the daemon announces it (at most ten a device each
/// tenth of a second).
#[derive(Debug, Clone, PartialEq)]
pub struct Touch {
    /// The effector, by index.
    pub effector: u32,
    /// What happened.
    pub event: TouchEvent,
    /// The tick it happened at.
    pub tick: u64,
    /// The loop's time then, seconds.
    pub time: f64,
    /// The body touched, by id and name; None for a solid that is no body.
    pub body: Option<(u32, String)>,
    /// Where they touch, metres.
    pub point: [f64; 3],
    /// The touched surface's outward normal.
    pub normal: [f64; 3],
    /// The force displayed, newtons.
    pub force: [f64; 3],
}

/// A device's touches as they are announced (see [`Device::touches`]).
pub struct Touches {
    stream: zbus::MessageStream,
}

/// The body of a `Touch` signal.
type TouchSignal = (
    u32,
    String,
    u64,
    f64,
    i32,
    String,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
);

impl Iterator for Touches {
    type Item = Result<Touch, ClientError>;

    /// The next touch, waiting for it; None once the connection is gone.
    fn next(&mut self) -> Option<Self::Item> {
        use zbus::export::futures_core::Stream;
        let stream = &mut self.stream;
        let message = zbus::block_on(std::future::poll_fn(|cx| {
            std::pin::Pin::new(&mut *stream).poll_next(cx)
        }))?;
        let touch = message.map_err(ClientError::from).and_then(|m| {
            let bad = || ClientError::Bus(zbus::Error::InvalidReply);
            let (effector, event, tick, time, body, name, point, normal, force): TouchSignal =
                m.body().deserialize()?;
            let three = |v: Vec<f64>| <[f64; 3]>::try_from(v).map_err(|_| bad());
            let event = match event.as_str() {
                "begin" => TouchEvent::Begin,
                "end" => TouchEvent::End,
                "slip" => TouchEvent::Slip,
                _ => return Err(bad()),
            };
            Ok(Touch {
                effector,
                event,
                tick,
                time,
                body: u32::try_from(body).ok().map(|id| (id, name)),
                point: three(point)?,
                normal: three(normal)?,
                force: three(force)?,
            })
        });
        Some(touch)
    }
}

/// A body of the running world.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Body {
    /// Its name in the scene file.
    pub name: String,
    /// Forces do not move it.
    pub fixed: bool,
}

/// A joint of the running world.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Joint {
    /// Its name.
    pub name: String,
    /// `fixed`, `revolute`, `prismatic` or `spherical`.
    pub kind: String,
}

/// Where a joint stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointState {
    /// Its coordinate: rad (a hinge's counted in whole turns from load) or m.
    pub position: f64,
    /// Its rate, rad/s or m/s.
    pub velocity: f64,
}

/// What a joint's motor does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointMotor {
    /// Drive the coordinate at this rate (rad/s or m/s) with at most `max_force`.
    Velocity {
        /// rad/s or m/s.
        target: f64,
        /// N·m or N.
        max_force: f64,
    },
    /// Drive the coordinate to this position (rad or m) with at most `max_force`.
    Position {
        /// rad or m.
        target: f64,
        /// N·m or N.
        max_force: f64,
    },
    /// Stop driving it.
    Off,
}

/// A body's state, as a change left it (or now, for [`Scene::body`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    /// Centre of mass, metres.
    pub position: [f64; 3],
    /// Orientation, unit quaternion (w, x, y, z).
    pub orientation: [f64; 4],
    /// Velocity of the centre of mass, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity, rad/s.
    pub spin: [f64; 3],
    /// The force held on it besides gravity, newtons.
    pub force: [f64; 3],
    /// Mass, kg (infinite for a fixed body).
    pub mass: f64,
    /// Friction coefficient of its contacts.
    pub friction: f64,
}

impl BodyState {
    /// The state in a Scene method's answer.
    fn from_bus(map: HashMap<String, OwnedVariant>) -> Result<Self, ClientError> {
        let bad = || ClientError::Bus(zbus::Error::InvalidReply);
        let number = |key: &str| -> Result<f64, ClientError> {
            map.get(key)
                .and_then(|v| f64::try_from(&**v).ok())
                .ok_or_else(bad)
        };
        fn numbers<const N: usize>(
            map: &HashMap<String, OwnedVariant>,
            key: &str,
        ) -> Option<[f64; N]> {
            let values: Vec<f64> = map.get(key)?.try_clone().ok()?.try_into().ok()?;
            values.try_into().ok()
        }
        Ok(Self {
            position: numbers(&map, "position").ok_or_else(bad)?,
            orientation: numbers(&map, "orientation").ok_or_else(bad)?,
            velocity: numbers(&map, "velocity").ok_or_else(bad)?,
            spin: numbers(&map, "spin").ok_or_else(bad)?,
            force: numbers(&map, "force").ok_or_else(bad)?,
            mass: number("mass")?,
            friction: number("friction")?,
        })
    }
}

/// The running world's bodies: each change is carried out between two steps of the world
/// (a pose once the forces have ramped to zero) and answers with the body's state after it.
/// A body is its name, or its id as a number; hapticd refuses unknown bodies, values that
/// are not finite or beyond what a hand may meet, and pushes on fixed bodies, by name
/// ([`ClientError::Refused`]).
///
/// ```no_run
/// use hapticd_ipc::bus::Bus;
/// use hapticd_ipc::client::Hapticd;
///
/// let scene = Hapticd::connect(&Bus::System)?.scene()?;
/// let block = scene.body("block")?;
/// let j = 0.2 * block.mass;
/// let after = scene.apply_impulse("block", [j, 0.0, 0.0], None)?;
/// println!("{:?} → {:?}", block.velocity, after.velocity);
/// # Ok::<(), hapticd_ipc::client::ClientError>(())
/// ```
pub struct Scene {
    proxy: SceneProxy<'static>,
}

impl Scene {
    /// The bodies, in id order.
    pub fn bodies(&self) -> Result<Vec<Body>, ClientError> {
        Ok(zbus::block_on(self.proxy.bodies())?
            .into_iter()
            .map(|(name, fixed)| Body { name, fixed })
            .collect())
    }

    /// Where `body` is and how it moves, now.
    pub fn body(&self, body: &str) -> Result<BodyState, ClientError> {
        BodyState::from_bus(zbus::block_on(self.proxy.body(body))?)
    }

    /// Put `body`'s centre of mass at `position` with `orientation` (w, x, y, z).
    pub fn set_pose(
        &self,
        body: &str,
        position: [f64; 3],
        orientation: [f64; 4],
    ) -> Result<BodyState, ClientError> {
        BodyState::from_bus(zbus::block_on(self.proxy.set_pose(
            body,
            &position,
            &orientation,
        ))?)
    }

    /// Set `body` moving at `velocity` (m/s) and turning at `spin` (rad/s).
    pub fn set_velocity(
        &self,
        body: &str,
        velocity: [f64; 3],
        spin: [f64; 3],
    ) -> Result<BodyState, ClientError> {
        BodyState::from_bus(zbus::block_on(
            self.proxy.set_velocity(body, &velocity, &spin),
        )?)
    }

    /// Give `body` the momentum `impulse` (N·s) at `point` (None: its centre of mass).
    pub fn apply_impulse(
        &self,
        body: &str,
        impulse: [f64; 3],
        point: Option<[f64; 3]>,
    ) -> Result<BodyState, ClientError> {
        let point = point.map_or_else(Vec::new, |p| p.to_vec());
        BodyState::from_bus(zbus::block_on(
            self.proxy.apply_impulse(body, &impulse, &point),
        )?)
    }

    /// Push `body` with `force` (N) at every step from now on; a zero force ends it.
    pub fn set_force(&self, body: &str, force: [f64; 3]) -> Result<BodyState, ClientError> {
        BodyState::from_bus(zbus::block_on(self.proxy.set_force(body, &force))?)
    }

    /// Make `body`'s mass `mass` kg, its inertia scaled with it.
    pub fn set_mass(&self, body: &str, mass: f64) -> Result<BodyState, ClientError> {
        BodyState::from_bus(zbus::block_on(self.proxy.set_mass(body, mass))?)
    }

    /// Add `body`, one entry of a scene file's `bodies:` in YAML with a name of its own, to
    /// the world (built again with it, the other bodies' states kept); its id.
    pub fn add_body(&self, body: &str) -> Result<u32, ClientError> {
        Ok(zbus::block_on(self.proxy.add_body(body))?)
    }

    /// Remove `body` from the world (built again without it); the ids after it move down.
    pub fn remove_body(&self, body: &str) -> Result<(), ClientError> {
        Ok(zbus::block_on(self.proxy.remove_body(body))?)
    }

    /// Make the friction coefficient of `body`'s contacts `friction`.
    pub fn set_friction(&self, body: &str, friction: f64) -> Result<BodyState, ClientError> {
        BodyState::from_bus(zbus::block_on(self.proxy.set_friction(body, friction))?)
    }

    /// Make soft `body` of Young's modulus `young` (Pa), Poisson's ratio `poisson` and
    /// damping `damping` (s), its shape and motion kept.
    pub fn set_material(
        &self,
        body: &str,
        (young, poisson, damping): (f64, f64, f64),
    ) -> Result<BodyState, ClientError> {
        let set = self.proxy.set_material(body, young, poisson, damping);
        BodyState::from_bus(zbus::block_on(set)?)
    }

    /// Hold still (`held`) or let go the nodes of soft `body` that stand where
    /// `normal`·x ≤ `offset` (m) now.
    pub fn pin(
        &self,
        body: &str,
        (normal, offset): ([f64; 3], f64),
        held: bool,
    ) -> Result<BodyState, ClientError> {
        let state = match held {
            true => zbus::block_on(self.proxy.pin(body, &normal, offset))?,
            false => zbus::block_on(self.proxy.release(body, &normal, offset))?,
        };
        BodyState::from_bus(state)
    }

    /// The joints, in order.
    pub fn joints(&self) -> Result<Vec<Joint>, ClientError> {
        Ok(zbus::block_on(self.proxy.joints())?
            .into_iter()
            .map(|(name, kind)| Joint { name, kind })
            .collect())
    }

    /// Where `joint` stands now.
    pub fn joint(&self, joint: &str) -> Result<JointState, ClientError> {
        let (position, velocity) = zbus::block_on(self.proxy.joint(joint))?;
        Ok(JointState { position, velocity })
    }

    /// Where every joint stands, read between the same two steps of the world, by name.
    pub fn joint_states(&self) -> Result<Vec<(String, JointState)>, ClientError> {
        Ok(zbus::block_on(self.proxy.joint_states())?
            .into_iter()
            .map(|(name, position, velocity)| (name, JointState { position, velocity }))
            .collect())
    }

    /// Set `joint`'s motor; where the joint stands after it.
    pub fn drive_joint(&self, joint: &str, motor: JointMotor) -> Result<JointState, ClientError> {
        let (kind, target, max_force) = match motor {
            JointMotor::Velocity { target, max_force } => ("velocity", target, max_force),
            JointMotor::Position { target, max_force } => ("position", target, max_force),
            JointMotor::Off => ("off", 0.0, 0.0),
        };
        let (position, velocity) =
            zbus::block_on(self.proxy.drive_joint(joint, kind, target, max_force))?;
        Ok(JointState { position, velocity })
    }
}

//! A blocking client of hapticd, for programs and scripts built on it: the daemon's devices,
//! their parameters, calibration and every tick of their haptic loop, and the scenes. Each
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
use zbus::Variant;

use crate::bus::{Bus, has_owner};
use crate::names::{BUS_NAME, DEVICE_INTERFACE, ERROR_PREFIX};
use crate::proxies::{DeviceProxy, ManagerProxy};
use crate::shared_memory::MapError;
use crate::telemetry_share::{Cursor, MappedTelemetry};

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

    /// The device's telemetry ring, mapped read-only.
    pub fn open_telemetry(&self) -> Result<MappedTelemetry, ClientError> {
        let fd = zbus::block_on(self.proxy.open_telemetry(HashMap::new()))?;
        MappedTelemetry::open(&fd.into()).map_err(ClientError::Memory)
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

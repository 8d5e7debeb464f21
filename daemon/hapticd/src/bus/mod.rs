//! The D-Bus service `org.hapticd.Hapticd1`: a manager object, the running world's bodies
//! (the scene object) and one object per device, on
//! the system bus (or the session bus, or any address, for development and tests).
//!
//! The service runs on its own thread. Requests that block (waiting for the haptic loop,
//! writing state files) run on a few worker threads, so a slow one never holds up the
//! others; the haptic loop only ever sees the commands they push into its ring. Ten times a
//! second the thread compares each device's snapshot with what it last announced and emits
//! PropertiesChanged for whatever changed, and a `Touch` signal for each effector that began or
//! stopped touching a body, or began to slip along it, since (read from the device's
//! telemetry ring).

mod device;
mod error;
mod manager;
mod scene;
mod touches;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

pub use device::DeviceInterface;
pub use error::BusError;
pub use manager::ManagerInterface;
pub use scene::SceneInterface;

use hapticd_ipc::bus::{Bus, unix_user};
use hapticd_ipc::{BUS_NAME, MANAGER_PATH, SCENE_PATH, device_path};
use hapticd_service::Workers;
use zbus::message::Header;

use crate::control::Daemon;

/// How often telemetry is announced.
const TELEMETRY_PERIOD: Duration = Duration::from_millis(100);

/// Log a PropertiesChanged that could not be sent: the change itself stands.
fn report(result: zbus::Result<()>) {
    if let Err(e) = result {
        tracing::warn!("cannot announce a property change: {e}");
    }
}

/// Who sent the request of `header`, as the bus knows them: their uid, or their bus name
/// when the bus cannot say.
async fn caller(connection: &zbus::Connection, header: Option<&Header<'_>>) -> String {
    let Some(sender) = header.and_then(|h| h.sender()) else {
        return "hapticd itself".to_string();
    };
    match unix_user(connection, sender.as_str()).await {
        Ok(uid) => format!("uid {uid}"),
        Err(_) => format!("bus name {sender}"),
    }
}

/// Log what a request that changes something did, and for whom: the journal keeps a trace
/// of every change made over the bus.
fn audit<E: std::fmt::Display>(what: &str, who: &str, result: &Result<(), E>) {
    match result {
        Ok(()) => tracing::info!("{what}, for {who}"),
        Err(e) => tracing::info!("refused to {what}, for {who}: {e}"),
    }
}

/// The running service; dropping it leaves the bus.
pub struct Service {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Drop for Service {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// [main] Connect to `bus` and own [`BUS_NAME`] there. The name is ours only while no other
/// hapticd has it, and nobody may take it from us: a second daemon would leave the first
/// driving its amplifier unreachable. The object server answers before the name is asked
/// for, so that a call arriving before the objects are put on it gets an error at once
/// (UnknownObject), not silence until its time-out.
async fn connect(bus: &Bus) -> zbus::Result<zbus::Connection> {
    let connection = bus.builder().build().await?;
    connection.object_server();
    match connection
        .request_name_with_flags(BUS_NAME, zbus::fdo::RequestNameFlags::DO_NOT_QUEUE)
        .await?
    {
        zbus::fdo::RequestNameReply::PrimaryOwner | zbus::fdo::RequestNameReply::AlreadyOwner => {
            Ok(connection)
        }
        zbus::fdo::RequestNameReply::Exists | zbus::fdo::RequestNameReply::InQueue => {
            Err(zbus::Error::NameTaken)
        }
    }
}

/// Put the manager and every device of `daemon` on `connection`.
async fn publish(connection: &zbus::Connection, daemon: &Arc<Daemon>) -> zbus::Result<()> {
    let workers = Arc::new(Workers::start().map_err(zbus::Error::from)?);
    let objects = connection.object_server();
    objects
        .at(
            MANAGER_PATH,
            ManagerInterface::new(daemon.clone(), workers.clone()),
        )
        .await?;
    objects
        .at(
            SCENE_PATH,
            SceneInterface::new(daemon.clone(), workers.clone()),
        )
        .await?;
    for (index, device) in daemon.devices().iter().enumerate() {
        objects
            .at(
                device_path(index),
                DeviceInterface::new(daemon.clone(), device.clone(), workers.clone()),
            )
            .await?;
    }
    Ok(())
}

/// Why the service could not be served.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ServeError {
    /// Another connection (another hapticd) owns the name on that bus.
    NameTaken(String),
    /// The bus could not be reached or the service not set up.
    Unavailable(String),
}

impl std::fmt::Display for ServeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ServeError::NameTaken(m) | ServeError::Unavailable(m) => f.write_str(m),
        }
    }
}

/// The bus name, owned before any device is opened (a second hapticd must learn that the
/// name is taken before it touches an amplifier the first one drives); its objects are put
/// on it by [`Claim::serve`].
pub struct Claim {
    bus: Bus,
    connection: zbus::Connection,
}

/// [main] Own [`BUS_NAME`] on `bus`, or say why it cannot be.
pub fn claim(bus: Bus) -> Result<Claim, ServeError> {
    match zbus::block_on(connect(&bus)) {
        Ok(connection) => Ok(Claim { bus, connection }),
        Err(zbus::Error::NameTaken) => Err(ServeError::NameTaken(format!(
            "{BUS_NAME} is already owned on {bus:?}: another hapticd is running there, and \
             this one will not take its place"
        ))),
        Err(e) => Err(ServeError::Unavailable(format!(
            "cannot serve {BUS_NAME} on {bus:?}: {e}"
        ))),
    }
}

impl Claim {
    /// [main] Serve `daemon` under the owned name, and announce its devices' changes from a
    /// thread of its own.
    pub fn serve(self, daemon: Arc<Daemon>) -> Result<Service, ServeError> {
        let Claim { bus, connection } = self;
        zbus::block_on(publish(&connection, &daemon)).map_err(|e| {
            ServeError::Unavailable(format!("cannot serve {BUS_NAME} on {bus:?}: {e}"))
        })?;
        let stop = Arc::new(AtomicBool::new(false));
        let stop_flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("hapticd-bus".into())
            .spawn(move || {
                // What clients could read when the objects appeared: only changes from it
                // are news.
                let mut announced: Vec<_> = (0..daemon.devices().len())
                    .map(|index| zbus::block_on(device::baseline(&connection, index)))
                    .collect();
                let mut touches: Vec<_> = daemon
                    .devices()
                    .iter()
                    .map(|d| touches::Touches::of(d))
                    .collect();
                while !stop_flag.load(Ordering::Acquire) {
                    // Between these calls zbus's helper thread serves the requests.
                    std::thread::sleep(TELEMETRY_PERIOD);
                    for (index, last) in announced.iter_mut().enumerate() {
                        let sent =
                            zbus::block_on(device::announce(&connection, index, last.take()));
                        *last = sent;
                    }
                    let bodies = daemon.bodies();
                    for (index, t) in touches.iter_mut().enumerate() {
                        if let Some(t) = t {
                            let found = t.scan();
                            zbus::block_on(device::announce_touches(
                                &connection,
                                index,
                                &found,
                                &bodies,
                            ));
                        }
                    }
                }
            })
            .map_err(|e| ServeError::Unavailable(format!("cannot start the D-Bus thread: {e}")))?;
        Ok(Service {
            stop,
            thread: Some(thread),
        })
    }
}

//! A connection to the running daemon as hapticctl makes it: never starting it, every
//! property as JSON, its changes as they are announced, and what a refusal means to the
//! person who asked ([`DaemonError`]).

use hapticd_ipc::bus::{Bus, has_owner};
use hapticd_ipc::client::ClientError;
use hapticd_ipc::names::error_name;
use hapticd_ipc::telemetry_csv;
use hapticd_ipc::{
    BUS_NAME, DEVICE_INTERFACE as DEVICE, MANAGER_INTERFACE as MANAGER, MANAGER_PATH,
};
use zbus::{Connection, OwnedVariant};

use crate::daemon_view::{Properties, to_json, words};

const PROPERTIES: &str = "org.freedesktop.DBus.Properties";

/// Properties changed, with their new values.
pub type Changes = std::collections::HashMap<String, OwnedVariant>;

/// Why a request to the daemon failed, as the person who made it is told.
#[derive(Debug)]
pub enum DaemonError {
    /// No hapticd on the bus.
    NotRunning(Bus),
    /// The bus's policy refused the caller, in its words.
    Denied(String),
    /// hapticd refused: its error's name and message.
    Refused {
        /// The D-Bus error name.
        name: String,
        /// hapticd's message.
        message: String,
    },
    /// The bus itself failed.
    Bus {
        /// Which bus.
        bus: Bus,
        /// What failed.
        error: zbus::Error,
    },
    /// The bus answered with an error of its own.
    BusSaid(zbus::fdo::Error),
    /// The client library failed otherwise.
    Client(ClientError),
    /// No device of the index or identity asked for.
    NoDevice {
        /// What was asked for.
        asked: String,
        /// The devices there are: `index (identity)`.
        known: Vec<String>,
    },
    /// The bus closed the connection while changes were followed.
    Closed,
    /// A recording cannot be written.
    Write {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The haptic loop stopped writing ticks during a recording, after this many rows.
    Stopped(usize),
}

impl std::fmt::Display for DaemonError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DaemonError::NotRunning(bus) => {
                let start = match bus {
                    Bus::System => " (`systemctl start hapticd` starts it)",
                    _ => "",
                };
                write!(
                    f,
                    "hapticd is not running on the {} bus{start}",
                    bus_name(bus)
                )
            }
            DaemonError::Denied(message) => write!(
                f,
                "not allowed ({message}): root and members of the hapticd group may change things"
            ),
            DaemonError::Refused { name, message } => {
                write!(f, "{}: {message}", error_name(name).unwrap_or(name))
            }
            DaemonError::Bus { bus, error } => write!(f, "the {} bus: {error}", bus_name(bus)),
            DaemonError::BusSaid(error) => error.fmt(f),
            DaemonError::Client(error) => error.fmt(f),
            DaemonError::NoDevice { asked, known } => {
                write!(
                    f,
                    "no device {asked:?}: hapticd drives {}",
                    known.join(", ")
                )
            }
            DaemonError::Closed => f.write_str("the bus closed the connection"),
            DaemonError::Write { path, error } => {
                write!(f, "cannot write {}: {error}", path.display())
            }
            DaemonError::Stopped(rows) => {
                write!(f, "the haptic loop stopped writing ticks after {rows} rows")
            }
        }
    }
}

impl std::error::Error for DaemonError {}

impl DaemonError {
    /// What `error`, on `bus`, means.
    fn on(bus: &Bus, error: zbus::Error) -> Self {
        match error {
            zbus::Error::FDO(fdo) => match *fdo {
                zbus::fdo::Error::ServiceUnknown(_) | zbus::fdo::Error::NameHasNoOwner(_) => {
                    DaemonError::NotRunning(bus.clone())
                }
                zbus::fdo::Error::AccessDenied(m) => DaemonError::Denied(m),
                other => DaemonError::BusSaid(other),
            },
            zbus::Error::MethodError(name, message, _) => DaemonError::Refused {
                name: name.to_string(),
                message: message.unwrap_or_default(),
            },
            error => DaemonError::Bus {
                bus: bus.clone(),
                error,
            },
        }
    }
}

/// The bus in a word, as messages name it.
pub fn bus_name(bus: &Bus) -> String {
    match bus {
        Bus::System => "system".into(),
        Bus::Session => "session".into(),
        Bus::Address(a) => a.clone(),
    }
}

/// A connection to the daemon on one bus.
pub struct Client {
    connection: Connection,
    bus: Bus,
}

impl Client {
    /// Connect to `bus`, where hapticd must be running: hapticctl never has the bus start it
    /// (an activation file of an older install would otherwise start a daemon that was
    /// stopped, or fail with the bus's words).
    pub fn connect(bus: &Bus) -> Result<Client, DaemonError> {
        let connection = zbus::block_on(bus.connection()).map_err(|e| DaemonError::on(bus, e))?;
        let running = zbus::block_on(has_owner(&connection, BUS_NAME))
            .map_err(|e| DaemonError::on(bus, e))?;
        if !running {
            return Err(DaemonError::NotRunning(bus.clone()));
        }
        Ok(Client {
            connection,
            bus: bus.clone(),
        })
    }

    /// The connection.
    pub fn connection(&self) -> &Connection {
        &self.connection
    }

    /// The bus it is on.
    pub fn bus(&self) -> &Bus {
        &self.bus
    }

    /// What `error`, on this connection's bus, means.
    pub fn failed(&self, error: zbus::Error) -> DaemonError {
        DaemonError::on(&self.bus, error)
    }

    /// The client library's view of the device at `path`, on this connection.
    pub fn library_device(&self, path: &str) -> Result<hapticd_ipc::client::Device, DaemonError> {
        hapticd_ipc::client::Device::on(&self.connection, path).map_err(|e| self.refused(e))
    }

    /// The client library's view of the daemon, on this connection.
    pub fn hapticd(&self) -> Result<hapticd_ipc::client::Hapticd, DaemonError> {
        hapticd_ipc::client::Hapticd::on(self.connection.clone()).map_err(|e| self.refused(e))
    }

    /// What `e`, from the client library, means to the person who asked.
    pub fn refused(&self, e: ClientError) -> DaemonError {
        match e {
            ClientError::NotRunning => DaemonError::NotRunning(self.bus.clone()),
            ClientError::Refused { name, message } if name.ends_with(".AccessDenied") => {
                DaemonError::Denied(message)
            }
            ClientError::Refused { name, message } => DaemonError::Refused { name, message },
            ClientError::Bus(e) => self.failed(e),
            other => DaemonError::Client(other),
        }
    }

    /// Call `method` of `interface` at `path` with `body`.
    pub fn call<B>(
        &self,
        path: &str,
        interface: &str,
        method: &str,
        body: &B,
    ) -> Result<zbus::Message, DaemonError>
    where
        B: serde::Serialize + zbus::Type,
    {
        zbus::block_on(self.connection.call_method(
            Some(BUS_NAME),
            path,
            Some(interface),
            method,
            body,
        ))
        .map_err(|e| self.failed(e))
    }

    /// Every property of `interface` at `path`, as JSON.
    pub fn properties(&self, path: &str, interface: &str) -> Result<Properties, DaemonError> {
        let reply = self.call(path, PROPERTIES, "GetAll", &(interface,))?;
        let all: std::collections::HashMap<String, OwnedVariant> =
            reply.body().deserialize().map_err(|e| self.failed(e))?;
        Ok(all.iter().map(|(k, v)| (k.clone(), to_json(v))).collect())
    }

    /// The manager's properties.
    pub fn manager(&self) -> Result<Properties, DaemonError> {
        self.properties(MANAGER_PATH, MANAGER)
    }

    /// Every property of every device the manager lists, in its order.
    pub fn devices(&self, manager: &Properties) -> Result<Vec<Properties>, DaemonError> {
        manager["Devices"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|path| self.properties(path.as_str().unwrap_or_default(), DEVICE))
            .collect()
    }

    /// The daemon's PropertiesChanged signals, of the object at `path` or of every object.
    pub async fn changes(&self, path: Option<&str>) -> Result<zbus::MessageStream, DaemonError> {
        let only = path.map_or(String::new(), |p| format!(",path='{p}'"));
        let rule = format!(
            "type='signal',sender='{BUS_NAME}'{only},interface='{PROPERTIES}',\
             member='PropertiesChanged'"
        );
        zbus::MessageStream::for_match_rule(rule.as_str(), &self.connection, None)
            .await
            .map_err(|e| self.failed(e))
    }

    /// The next change of `stream`: the object's path and the properties changed with their
    /// values (`None` for a signal that does not have that shape).
    pub async fn next_change(
        &self,
        stream: &mut zbus::MessageStream,
    ) -> Result<Option<(String, Changes)>, DaemonError> {
        let Some(message) = next(stream).await else {
            return Err(DaemonError::Closed);
        };
        let message = message.map_err(|e| self.failed(e))?;
        let path = message
            .header()
            .path()
            .map(|p| p.to_string())
            .unwrap_or_default();
        let body: zbus::Result<(String, Changes, Vec<String>)> = message.body().deserialize();
        Ok(body.ok().map(|(_, changed, _)| (path, changed)))
    }

    /// The object path of the device `asked`: its index in `Devices`, or its identity.
    pub fn device(&self, asked: &str) -> Result<String, DaemonError> {
        let manager = self.manager()?;
        let paths: Vec<String> = manager["Devices"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|p| p.as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        if let Ok(index) = asked.parse::<usize>()
            && let Some(path) = paths.get(index)
        {
            return Ok(path.clone());
        }
        let mut known = Vec::new();
        for (index, path) in paths.iter().enumerate() {
            let identity = words(&self.properties(path, DEVICE)?["Identity"]);
            if identity == asked {
                return Ok(path.clone());
            }
            known.push(format!("{index} ({identity})"));
        }
        Err(DaemonError::NoDevice {
            asked: asked.to_string(),
            known,
        })
    }
}

/// A recording taken: its rows, the ticks the ring overwrote before they were read, and the
/// device's rate.
pub struct Recorded {
    /// Rows written, a tick each.
    pub rows: usize,
    /// Ticks missed.
    pub missed: u64,
    /// The device's rate, Hz.
    pub rate: f64,
}

impl Client {
    /// Every tick of the device at `path` for `seconds`, read from its telemetry ring at
    /// the device's rate, into `file` as CSV ([`telemetry_csv`]).
    pub fn record(
        &self,
        path: &str,
        seconds: f64,
        file: &std::path::Path,
    ) -> Result<Recorded, DaemonError> {
        use std::io::Write;
        let cannot = |error| DaemonError::Write {
            path: file.to_path_buf(),
            error,
        };
        let effectors: Vec<String> = self.properties(path, DEVICE)?["Effectors"]
            .as_array()
            .into_iter()
            .flatten()
            .map(words)
            .collect();
        let device = self.library_device(path)?;
        let mut ticks = device.telemetry(seconds).map_err(|e| self.refused(e))?;
        let mut out = std::io::BufWriter::new(std::fs::File::create(file).map_err(cannot)?);
        let (mut rows, mut strings) = (0usize, None);
        for sample in ticks.by_ref() {
            let strings = *strings.get_or_insert_with(|| {
                let n = sample.strings as usize;
                let _ = writeln!(out, "{}", telemetry_csv::header(&effectors, n));
                n
            });
            let row = telemetry_csv::row(&sample, effectors.len(), strings);
            writeln!(out, "{row}").map_err(cannot)?;
            rows += 1;
        }
        if ticks.stopped() {
            return Err(DaemonError::Stopped(rows));
        }
        out.flush().map_err(cannot)?;
        Ok(Recorded {
            rows,
            missed: ticks.missed(),
            rate: ticks.rate(),
        })
    }
}

/// The next message of `stream`, waiting for it.
async fn next(stream: &mut zbus::MessageStream) -> Option<zbus::Result<zbus::Message>> {
    use zbus::export::futures_core::Stream;
    std::future::poll_fn(|cx| std::pin::Pin::new(&mut *stream).poll_next(cx)).await
}

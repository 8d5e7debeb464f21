//! Which bus to find hapticd on, and what the bus daemon says of a connection.

/// A message bus: the system's, the user's session bus, or one at an address (tests,
/// development).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Bus {
    /// The system bus.
    System,
    /// The user's session bus.
    Session,
    /// A bus at this D-Bus address (`unix:path=…`).
    Address(String),
}

/// A word that names no bus.
///
/// ```
/// use hapticd_ipc::bus::{Bus, NotABus};
/// assert_eq!("session".parse(), Ok(Bus::Session));
/// assert_eq!("unix:path=/run/bus".parse(), Ok(Bus::Address("unix:path=/run/bus".into())));
/// assert_eq!("sytem".parse::<Bus>(), Err(NotABus("sytem".into())));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NotABus(pub String);

impl std::fmt::Display for NotABus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:?} is not a bus: give system, session or a D-Bus address",
            self.0
        )
    }
}

impl std::error::Error for NotABus {}

impl std::str::FromStr for Bus {
    type Err = NotABus;

    fn from_str(s: &str) -> Result<Self, NotABus> {
        Ok(match s {
            "system" => Bus::System,
            "session" => Bus::Session,
            a if a.contains(':') => Bus::Address(a.to_string()),
            other => return Err(NotABus(other.to_string())),
        })
    }
}

impl Bus {
    /// A connection builder for this bus (to serve on it, or to set up a client's).
    pub fn builder(&self) -> zbus::connection::Builder<'_> {
        match self {
            Bus::System => zbus::connection::Builder::system(),
            Bus::Session => zbus::connection::Builder::session(),
            Bus::Address(a) => zbus::connection::Builder::address(a.as_str()),
        }
    }

    /// A client's connection to this bus.
    pub async fn connection(&self) -> zbus::Result<zbus::Connection> {
        self.builder().build().await
    }
}

/// Whether someone owns `name` on the bus now. Asking never starts a service that the bus
/// could activate for the name, as a call to it would: a client that only reads must not
/// start the motors' daemon an administrator stopped.
pub async fn has_owner(connection: &zbus::Connection, name: &str) -> zbus::Result<bool> {
    connection
        .call_method(
            Some("org.freedesktop.DBus"),
            "/org/freedesktop/DBus",
            Some("org.freedesktop.DBus"),
            "NameHasOwner",
            &(name,),
        )
        .await?
        .body()
        .deserialize::<bool>()
}

/// The Unix user of the connection `name`, as the bus daemon knows it.
pub async fn unix_user(connection: &zbus::Connection, name: &str) -> zbus::Result<u32> {
    connection
        .call_method(
            Some("org.freedesktop.DBus"),
            "/org/freedesktop/DBus",
            Some("org.freedesktop.DBus"),
            "GetConnectionUnixUser",
            &(name,),
        )
        .await?
        .body()
        .deserialize::<u32>()
}

//! The names hapticd and its renderer are found by on D-Bus. The interfaces' own
//! declarations (the services' `#[interface]` blocks and this crate's proxies) spell them
//! as literals, as zbus's macros need; tests check those against these.

/// The daemon's well-known name.
pub const BUS_NAME: &str = "org.hapticd.Hapticd1";
/// The manager's object path.
pub const MANAGER_PATH: &str = "/org/hapticd/Hapticd1";
/// The manager's interface: scenes, mechanisms, the devices.
pub const MANAGER_INTERFACE: &str = "org.hapticd.Hapticd1.Manager";
/// The scene object's path: the running world's bodies.
pub const SCENE_PATH: &str = "/org/hapticd/Hapticd1/scene";
/// The scene object's interface: bodies read and changed from outside.
pub const SCENE_INTERFACE: &str = "org.hapticd.Hapticd1.Scene";
/// Each device's interface: state, calibration, parameters, telemetry.
pub const DEVICE_INTERFACE: &str = "org.hapticd.Hapticd1.Device";
/// The daemon's errors are `ERROR_PREFIX.<Name>`.
pub const ERROR_PREFIX: &str = "org.hapticd.Hapticd1.Error";
/// The error of a request for a device the daemon does not have, as the network bridge
/// answers it (a name beside the daemon's own, under its prefix).
pub const UNKNOWN_DEVICE_ERROR: &str = "org.hapticd.Hapticd1.Error.UnknownDevice";
/// Version of the daemon's D-Bus API, raised only on incompatible changes.
pub const API_VERSION: u32 = 1;

/// The renderer's well-known name (its own: it comes and goes while hapticd runs on).
pub const RENDERER_BUS_NAME: &str = "org.hapticd.Renderer1";
/// The renderer's object path.
pub const RENDERER_PATH: &str = "/org/hapticd/Renderer1";
/// The renderer's interface: snapshots and frame streams.
pub const RENDERER_INTERFACE: &str = "org.hapticd.Renderer1";
/// The renderer's errors are `RENDERER_ERROR_PREFIX.<Name>`.
pub const RENDERER_ERROR_PREFIX: &str = "org.hapticd.Renderer1.Error";

/// The object path of device `index` (0, 1, … in the order of the manager's `Devices`).
///
/// ```
/// assert_eq!(hapticd_ipc::device_path(0), "/org/hapticd/Hapticd1/device/0");
/// ```
pub fn device_path(index: usize) -> String {
    format!("{MANAGER_PATH}/device/{index}")
}

/// The short name of a D-Bus error of the daemon or the renderer (`NameExpected` for
/// `org.hapticd.Hapticd1.Error.NameExpected`), or None for anybody else's.
///
/// ```
/// use hapticd_ipc::names::error_name;
/// assert_eq!(error_name("org.hapticd.Renderer1.Error.NoWorld"), Some("NoWorld"));
/// assert_eq!(error_name("org.freedesktop.DBus.Error.ServiceUnknown"), None);
/// ```
pub fn error_name(name: &str) -> Option<&str> {
    [ERROR_PREFIX, RENDERER_ERROR_PREFIX]
        .iter()
        .find_map(|prefix| name.strip_prefix(prefix)?.strip_prefix('.'))
}

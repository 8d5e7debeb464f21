//! Following USB amplifiers as they come and go, from the main thread (never the real-time
//! one):
//!
//! - [`Reconnector`]: while the haptic loop reports its amplifier disconnected, look for it
//!   again by identity (its bus path) and, once it is back, open it and hand the loop the new
//!   link. The loop keeps its calibration and parameters across the gap.
//! - [`Arrivals`]: notice an amplifier plugged in that hapticd does not drive yet.
//!
//! Both look in sysfs first, a few small reads every [`RETRY`], and only ask libusb (whose
//! every context starts an event thread) once the amplifier is there.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::transport::Link;
use super::{SUPPORTED_DEVICES, SupportedDevice, usb};

/// How often a missing amplifier is looked for.
pub const RETRY: Duration = Duration::from_millis(500);

/// How long to wait before trying again an amplifier that is there but could not be opened:
/// every try starts a libusb context, and with it a thread whose stack the daemon's locked
/// memory must fault in.
pub const RETRY_REFUSED: Duration = Duration::from_secs(5);

/// Where the kernel lists USB devices.
const SYSFS_USB_DEVICES: &str = "/sys/bus/usb/devices";

/// The supported amplifiers `devices` (a sysfs `bus/usb/devices` directory) lists, by
/// identity (`usb:BUS-PORT.PORT…`, the name the kernel gives the device).
fn listed(devices: &Path) -> Vec<(String, SupportedDevice)> {
    let Ok(entries) = std::fs::read_dir(devices) else {
        return Vec::new();
    };
    let hex = |dir: &Path, name: &str| {
        let text = std::fs::read_to_string(dir.join(name)).ok()?;
        u16::from_str_radix(text.trim(), 16).ok()
    };
    entries
        .flatten()
        .filter_map(|entry| {
            let dir = entry.path();
            let (vendor, product) = (hex(&dir, "idVendor")?, hex(&dir, "idProduct")?);
            let model = SUPPORTED_DEVICES
                .iter()
                .find(|m| m.vendor == vendor && m.product == product)?;
            Some((
                format!("usb:{}", entry.file_name().to_string_lossy()),
                *model,
            ))
        })
        .collect()
}

/// What one look for a missing amplifier found.
pub enum Lookup {
    /// Not time to look again yet, or the device is not connected-and-lost.
    Idle,
    /// Not on the bus (yet).
    Absent,
    /// Back and opened: hand this link to the loop.
    Back(Box<dyn Link>),
    /// On the bus but unusable now (cannot be opened or claimed, or another model sits in
    /// its socket); looked for again later. Each reason is told once, not at every look.
    Refused(String),
}

/// Looks for one amplifier that went missing.
pub struct Reconnector {
    identity: String,
    model: SupportedDevice,
    next_look: Instant,
    told: Option<String>,
}

impl Reconnector {
    /// Follow the amplifier `model` known as `identity`.
    pub fn new(identity: impl Into<String>, model: SupportedDevice) -> Self {
        Self {
            identity: identity.into(),
            model,
            next_look: Instant::now(),
            told: None,
        }
    }

    /// Look for the amplifier again if it is `missing` and the last look is [`RETRY`] old.
    pub fn poll(&mut self, missing: bool, now: Instant) -> Lookup {
        if !missing || now < self.next_look {
            return Lookup::Idle;
        }
        self.next_look = now + RETRY;
        let Some((_, model)) = listed(Path::new(SYSFS_USB_DEVICES))
            .into_iter()
            .find(|(identity, _)| *identity == self.identity)
        else {
            return Lookup::Absent;
        };
        let refused = if model != self.model {
            format!(
                "{} is now a {}, not the {} it was: not reconnected",
                self.identity, model.name, self.model.name
            )
        } else {
            match usb::reopen(&self.identity) {
                Ok(Some(found)) => {
                    self.told = None;
                    return Lookup::Back(Box::new(found.link));
                }
                Ok(None) => return Lookup::Absent,
                Err(e) => e,
            }
        };
        self.next_look = now + RETRY_REFUSED;
        if self.told.as_ref() == Some(&refused) {
            return Lookup::Absent;
        }
        self.told = Some(refused.clone());
        Lookup::Refused(refused)
    }
}

/// Notices a supported amplifier plugged in that hapticd does not drive yet.
pub struct Arrivals {
    devices: PathBuf,
    driven: Vec<String>,
    known: Vec<String>,
    next_look: Instant,
}

impl Arrivals {
    /// Watch the bus; the amplifiers known as `driven` are hapticd's own (their comings and
    /// goings are the [`Reconnector`]'s).
    pub fn new(driven: Vec<String>) -> Self {
        Self::watching(SYSFS_USB_DEVICES, driven)
    }

    /// Watch `devices` (a sysfs `bus/usb/devices` directory). Amplifiers listed now are no
    /// news: hapticd could not use them when it started, and starting again would not help.
    fn watching(devices: impl Into<PathBuf>, driven: Vec<String>) -> Self {
        let devices = devices.into();
        Self {
            known: listed(&devices).into_iter().map(|(id, _)| id).collect(),
            devices,
            driven,
            next_look: Instant::now() + RETRY,
        }
    }

    /// The identity and model of an amplifier plugged in since the last look, looked for at
    /// most every [`RETRY`]. One unplugged and plugged in again is news again.
    pub fn poll(&mut self, now: Instant) -> Option<(String, SupportedDevice)> {
        if now < self.next_look {
            return None;
        }
        self.next_look = now + RETRY;
        let listed = listed(&self.devices);
        let new = listed
            .iter()
            .find(|(id, _)| !self.known.contains(id) && !self.driven.contains(id))
            .cloned();
        self.known = listed.into_iter().map(|(id, _)| id).collect();
        new
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sysfs `bus/usb/devices` directory of its own for a test.
    fn bus(name: &str) -> PathBuf {
        let root = std::env::temp_dir().join(format!("hotplug-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&root).unwrap();
        root
    }

    fn plug(root: &Path, name: &str, vendor: &str, product: &str) {
        let dir = root.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("idVendor"), vendor).unwrap();
        std::fs::write(dir.join("idProduct"), product).unwrap();
    }

    #[test]
    fn sysfs_lists_the_supported_amplifiers_by_their_bus_path() {
        let root = bus("list");
        plug(&root, "1-2", "0cec\n", "0205\n");
        plug(&root, "3-1.4", "0cec", "0203");
        plug(&root, "1-3", "046d\n", "c52b\n");
        plug(&root, "usb1", "1d6b\n", "0002\n");
        // An interface directory has no IDs.
        std::fs::create_dir_all(root.join("1-2:1.0")).unwrap();
        let mut found = listed(&root);
        found.sort_by(|a, b| a.0.cmp(&b.0));
        std::fs::remove_dir_all(&root).unwrap();
        assert_eq!(
            found,
            vec![
                ("usb:1-2".to_string(), SUPPORTED_DEVICES[0]),
                ("usb:3-1.4".to_string(), SUPPORTED_DEVICES[1]),
            ]
        );
        assert!(listed(Path::new("/nonexistent")).is_empty());
    }

    #[test]
    fn only_an_amplifier_plugged_in_after_the_start_is_news() {
        let root = bus("arrivals");
        // There at the start, but hapticd could not use it: starting again would not help.
        plug(&root, "1-2", "0cec", "0205");
        // Driven by hapticd: its returns are not arrivals.
        plug(&root, "2-1", "0cec", "0205");
        let mut arrivals = Arrivals::watching(&root, vec!["usb:2-1".into()]);
        let mut now = Instant::now();
        let mut look = || {
            now += RETRY;
            arrivals.poll(now)
        };
        assert_eq!(look(), None);
        plug(&root, "1-4", "0cec", "0203");
        assert_eq!(look(), Some(("usb:1-4".into(), SUPPORTED_DEVICES[1])));
        assert_eq!(look(), None);
        // Unplugged, then plugged in again: news again.
        std::fs::remove_dir_all(root.join("1-2")).unwrap();
        assert_eq!(look(), None);
        plug(&root, "1-2", "0cec", "0205");
        assert_eq!(look(), Some(("usb:1-2".into(), SUPPORTED_DEVICES[0])));
        std::fs::remove_dir_all(root.join("2-1")).unwrap();
        assert_eq!(look(), None);
        plug(&root, "2-1", "0cec", "0205");
        assert_eq!(look(), None);
        std::fs::remove_dir_all(&root).unwrap();
    }
}

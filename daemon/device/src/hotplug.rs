//! Following USB amplifiers as they come and go, from the main thread (never the real-time
//! one):
//!
//! - [`Reconnector`]: while the haptic loop reports its amplifier disconnected, look for it
//!   again by identity (its bus path) and, once it is back, open it and hand the loop the new
//!   link. The loop keeps its calibration and parameters across the gap.
//! - [`Arrivals`]: notice an amplifier plugged in that hapticd does not drive yet.
//!
//! Both read sysfs, a few small files every [`RETRY`]; an amplifier that is back is opened
//! through its usbfs node straight away, without libusb (whose every context starts a thread
//! that the daemon's locked memory would have to fault in).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::{SUPPORTED_DEVICES, SupportedDevice, usb};

/// How often a missing amplifier is looked for.
pub const RETRY: Duration = Duration::from_millis(500);

/// Where the kernel lists USB devices.
const SYSFS_USB_DEVICES: &str = "/sys/bus/usb/devices";

/// A supported amplifier that sysfs lists.
#[derive(Debug, Clone, PartialEq)]
struct Listed {
    /// `usb:BUS-PORT.PORT…`, from the name the kernel gives the device.
    identity: String,
    /// Which amplifier it is.
    model: SupportedDevice,
    /// Its usbfs node, `/dev/bus/usb/BBB/DDD`, when sysfs gives its numbers.
    node: Option<PathBuf>,
}

/// The supported amplifiers `devices` (a sysfs `bus/usb/devices` directory) lists.
fn listed(devices: &Path) -> Vec<Listed> {
    let Ok(entries) = std::fs::read_dir(devices) else {
        return Vec::new();
    };
    let read = |dir: &Path, name: &str, radix: u32| {
        let text = std::fs::read_to_string(dir.join(name)).ok()?;
        u16::from_str_radix(text.trim(), radix).ok()
    };
    entries
        .flatten()
        .filter_map(|entry| {
            let dir = entry.path();
            let (vendor, product) = (read(&dir, "idVendor", 16)?, read(&dir, "idProduct", 16)?);
            let model = SUPPORTED_DEVICES
                .iter()
                .find(|m| m.vendor == vendor && m.product == product)?;
            let node = read(&dir, "busnum", 10)
                .zip(read(&dir, "devnum", 10))
                .map(|(bus, device)| PathBuf::from(format!("/dev/bus/usb/{bus:03}/{device:03}")));
            Some(Listed {
                identity: format!("usb:{}", entry.file_name().to_string_lossy()),
                model: *model,
                node,
            })
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
    Back(usb::UsbLink),
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
        let Some(back) = listed(Path::new(SYSFS_USB_DEVICES))
            .into_iter()
            .find(|l| l.identity == self.identity)
        else {
            return Lookup::Absent;
        };
        let refused = match (back.model == self.model, &back.node) {
            (false, _) => format!(
                "{} is now a {}, not the {} it was: not reconnected",
                self.identity, back.model.name, self.model.name
            ),
            // Listed before its numbers are written: looked at again next time.
            (true, None) => return Lookup::Absent,
            (true, Some(node)) => match usb::open_node(node, &self.model) {
                Ok(link) => {
                    self.told = None;
                    return Lookup::Back(link);
                }
                Err(e) => format!("{} ({}): {e}", self.identity, self.model.name),
            },
        };
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
            known: listed(&devices).into_iter().map(|l| l.identity).collect(),
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
            .find(|l| !self.known.contains(&l.identity) && !self.driven.contains(&l.identity))
            .map(|l| (l.identity.clone(), l.model));
        self.known = listed.into_iter().map(|l| l.identity).collect();
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

    fn numbered(root: &Path, name: &str, bus: &str, device: &str) {
        std::fs::write(root.join(name).join("busnum"), bus).unwrap();
        std::fs::write(root.join(name).join("devnum"), device).unwrap();
    }

    #[test]
    fn sysfs_lists_the_supported_amplifiers_by_their_bus_path() {
        let root = bus("list");
        plug(&root, "1-2", "0cec\n", "0205\n");
        numbered(&root, "1-2", "1\n", "12\n");
        plug(&root, "3-1.4", "0cec", "0203");
        plug(&root, "1-3", "046d\n", "c52b\n");
        plug(&root, "usb1", "1d6b\n", "0002\n");
        // An interface directory has no IDs.
        std::fs::create_dir_all(root.join("1-2:1.0")).unwrap();
        let mut found = listed(&root);
        found.sort_by(|a, b| a.identity.cmp(&b.identity));
        std::fs::remove_dir_all(&root).unwrap();
        assert_eq!(
            found,
            vec![
                Listed {
                    identity: "usb:1-2".into(),
                    model: SUPPORTED_DEVICES[0],
                    node: Some("/dev/bus/usb/001/012".into()),
                },
                Listed {
                    identity: "usb:3-1.4".into(),
                    model: SUPPORTED_DEVICES[1],
                    node: None,
                },
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

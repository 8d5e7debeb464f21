//! USB controllers: libusb (rusb) finds the supported amplifiers; their bulk transfers go
//! straight through usbfs ([`super::usbfs`]), so the real-time thread never enters libusb.

use std::path::{Path, PathBuf};
use std::time::Duration;

use rusb::UsbContext;

use crate::usbfs::UsbfsDevice;
use crate::{SUPPORTED_DEVICES, SupportedDevice, sh4, simple};
use hapticd_core::transport::{Link, TransportError};

/// How long one transfer may take before the device counts as not answering.
const TIMEOUT: Duration = Duration::from_millis(100);

/// A claimed USB amplifier.
pub struct UsbLink {
    node: PathBuf,
    device: UsbfsDevice,
    out_endpoint: u8,
    in_endpoint: u8,
}

/// A supported controller found on the bus.
pub struct FoundDevice {
    /// Which controller it is.
    pub model: SupportedDevice,
    /// `usb:BUS-PORT.PORT…`: stable while it stays in the same socket.
    pub identity: String,
    /// The opened, claimed device.
    pub link: UsbLink,
}

/// A supported controller on the bus that could not be opened and claimed.
#[derive(Debug)]
pub struct UnusableDevice {
    /// Which controller it is.
    pub model: SupportedDevice,
    /// `usb:BUS-PORT.PORT…`.
    pub identity: String,
    /// Why, and what to do about it.
    pub reason: String,
}

impl std::fmt::Display for UnusableDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({}): {}",
            self.identity, self.model.name, self.reason
        )
    }
}

/// libusb cannot look at the bus at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoBus {
    /// libusb does not start.
    Start(rusb::Error),
    /// It cannot list the devices.
    List(rusb::Error),
}

impl std::fmt::Display for NoBus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoBus::Start(e) => write!(f, "cannot start libusb: {e} (is usbfs at /dev/bus/usb?)"),
            NoBus::List(e) => write!(f, "cannot list USB devices: {e}"),
        }
    }
}

impl std::error::Error for NoBus {}

/// Every supported controller found on the bus, opened and claimed, and those that could
/// not be. `Err` when libusb cannot start or list the bus at all.
pub fn find_devices() -> Result<(Vec<FoundDevice>, Vec<UnusableDevice>), NoBus> {
    let context = rusb::Context::new().map_err(NoBus::Start)?;
    let devices = context.devices().map_err(NoBus::List)?;
    let mut found = Vec::new();
    let mut unusable = Vec::new();
    for device in devices.iter() {
        let Ok(descriptor) = device.device_descriptor() else {
            continue;
        };
        let Some(model) = SUPPORTED_DEVICES
            .iter()
            .find(|m| m.vendor == descriptor.vendor_id() && m.product == descriptor.product_id())
        else {
            continue;
        };
        let ports = device.port_numbers().unwrap_or_default();
        let path: Vec<String> = ports.iter().map(u8::to_string).collect();
        let identity = format!("usb:{}-{}", device.bus_number(), path.join("."));
        match open(&device, model) {
            Ok(link) => found.push(FoundDevice {
                model: *model,
                identity,
                link,
            }),
            Err(e) => unusable.push(UnusableDevice {
                model: *model,
                identity,
                reason: why_unusable(&e, &node_of(&device)),
            }),
        }
    }
    Ok((found, unusable))
}

/// What a person can do about `error`, met opening the amplifier at `node`.
fn why_unusable(error: &std::io::Error, node: &Path) -> String {
    match error.raw_os_error() {
        Some(libc::EACCES) | Some(libc::EPERM) => format!(
            "no access to {}: the udev rules give it to the hapticd user alone; run this \
             as root or as hapticd, or ask the running daemon (hapticctl status)",
            node.display()
        ),
        Some(libc::EBUSY) => format!(
            "{} is claimed by another program (hapticd drives it while it runs: \
             hapticctl status)",
            node.display()
        ),
        _ => format!("{}: {error}", node.display()),
    }
}

/// The usbfs node of `device`.
fn node_of(device: &rusb::Device<rusb::Context>) -> PathBuf {
    PathBuf::from(format!(
        "/dev/bus/usb/{:03}/{:03}",
        device.bus_number(),
        device.address()
    ))
}

fn open(device: &rusb::Device<rusb::Context>, model: &SupportedDevice) -> std::io::Result<UsbLink> {
    open_node(&node_of(device), model)
}

/// Open and claim the amplifier `model` at its usbfs `node` (`/dev/bus/usb/BBB/DDD`).
pub fn open_node(node: &Path, model: &SupportedDevice) -> std::io::Result<UsbLink> {
    let device = UsbfsDevice::open(node, 0, TIMEOUT)?;
    let (out_endpoint, in_endpoint) = match model.protocol {
        super::Protocol::Sh4 => (sh4::ENDPOINT_OUT, sh4::ENDPOINT_IN),
        super::Protocol::Simple => (simple::ENDPOINT_OUT, simple::ENDPOINT_IN),
    };
    Ok(UsbLink {
        node: node.to_path_buf(),
        device,
        out_endpoint,
        in_endpoint,
    })
}

impl UsbLink {
    /// The usbfs node it was opened at (`/dev/bus/usb/BBB/DDD`).
    pub fn node(&self) -> &Path {
        &self.node
    }
}

impl Link for UsbLink {
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.device.write(self.out_endpoint, bytes)
    }

    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
        self.device.read(self.in_endpoint, bytes)
    }

    fn reset_in(&mut self) -> Result<(), TransportError> {
        self.device.clear_halt(self.in_endpoint)
    }
}

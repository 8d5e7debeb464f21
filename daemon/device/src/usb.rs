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

/// Every supported controller found on the bus, opened and claimed, and what went wrong
/// with those that could not be opened. `Err` when libusb cannot start at all (no USB).
pub fn find_devices() -> Result<(Vec<FoundDevice>, Vec<String>), String> {
    let context = rusb::Context::new().map_err(|e| format!("cannot start libusb: {e}"))?;
    let mut found = Vec::new();
    let mut problems = Vec::new();
    let devices = match context.devices() {
        Ok(d) => d,
        Err(e) => return Ok((found, vec![format!("cannot list USB devices: {e}")])),
    };
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
            Err(e) => problems.push(format!("{identity} ({}): {e}", model.name)),
        }
    }
    Ok((found, problems))
}

fn open(device: &rusb::Device<rusb::Context>, model: &SupportedDevice) -> std::io::Result<UsbLink> {
    let node = PathBuf::from(format!(
        "/dev/bus/usb/{:03}/{:03}",
        device.bus_number(),
        device.address()
    ));
    open_node(&node, model)
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

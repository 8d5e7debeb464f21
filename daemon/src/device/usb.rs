//! USB controllers through libusb (rusb): finding the supported amplifiers and moving their
//! bulk transfers.

use std::time::Duration;

use rusb::UsbContext;

use super::transport::{Link, TransportError};
use super::{SUPPORTED_DEVICES, SupportedDevice, sh4, simple};

/// How long one transfer may take before the device counts as not answering.
const TIMEOUT: Duration = Duration::from_millis(100);

/// A claimed USB amplifier.
pub struct UsbLink {
    handle: rusb::DeviceHandle<rusb::Context>,
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

fn transport_error(e: rusb::Error) -> TransportError {
    match e {
        rusb::Error::NoDevice | rusb::Error::NotFound => TransportError::Disconnected,
        rusb::Error::Timeout => TransportError::Timeout,
        rusb::Error::Io => TransportError::Io(5),
        rusb::Error::Access => TransportError::Io(13),
        rusb::Error::Busy => TransportError::Io(16),
        rusb::Error::Pipe => TransportError::Io(32),
        rusb::Error::Overflow => TransportError::Io(75),
        _ => TransportError::Io(0),
    }
}

/// Open and claim every supported controller on the bus. Devices that cannot be opened are
/// reported, not fatal.
pub fn find_devices(context: &rusb::Context) -> (Vec<FoundDevice>, Vec<String>) {
    scan(context, |_| true)
}

/// Open the controller known as `identity` again if it is on the bus (it was unplugged and
/// may be back). A fresh libusb context enumerates the bus anew, whether or not hotplug
/// events reached the daemon. `Ok(None)`: not there (yet).
pub fn reopen(identity: &str) -> Result<Option<FoundDevice>, String> {
    let context = rusb::Context::new().map_err(|e| format!("cannot start libusb: {e}"))?;
    let (mut found, mut problems) = scan(&context, |id| id == identity);
    match (found.pop(), problems.pop()) {
        (Some(device), _) => Ok(Some(device)),
        (None, Some(problem)) => Err(problem),
        (None, None) => Ok(None),
    }
}

/// Open and claim the supported controllers whose identity `wanted` accepts.
fn scan(context: &rusb::Context, wanted: impl Fn(&str) -> bool) -> (Vec<FoundDevice>, Vec<String>) {
    let mut found = Vec::new();
    let mut problems = Vec::new();
    let devices = match context.devices() {
        Ok(d) => d,
        Err(e) => return (found, vec![format!("cannot list USB devices: {e}")]),
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
        if !wanted(&identity) {
            continue;
        }
        match open(&device, model) {
            Ok(link) => found.push(FoundDevice {
                model: *model,
                identity,
                link,
            }),
            Err(e) => problems.push(format!("{identity} ({}): {e}", model.name)),
        }
    }
    (found, problems)
}

fn open(device: &rusb::Device<rusb::Context>, model: &SupportedDevice) -> rusb::Result<UsbLink> {
    let handle = device.open()?;
    // Only detach a kernel driver that is really bound: asking fails on some systems.
    if handle.kernel_driver_active(0).unwrap_or(false) {
        handle.detach_kernel_driver(0)?;
    }
    handle.claim_interface(0)?;
    let (out_endpoint, in_endpoint) = match model.protocol {
        super::Protocol::Sh4 => (sh4::ENDPOINT_OUT, sh4::ENDPOINT_IN),
        super::Protocol::Simple => (simple::ENDPOINT_OUT, simple::ENDPOINT_IN),
    };
    Ok(UsbLink {
        handle,
        out_endpoint,
        in_endpoint,
    })
}

impl Link for UsbLink {
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let n = self
            .handle
            .write_bulk(self.out_endpoint, bytes, TIMEOUT)
            .map_err(transport_error)?;
        if n == bytes.len() {
            Ok(())
        } else {
            Err(TransportError::Io(5))
        }
    }

    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
        self.handle
            .read_bulk(self.in_endpoint, bytes, TIMEOUT)
            .map_err(transport_error)
    }

    fn reset_in(&mut self) -> Result<(), TransportError> {
        self.handle
            .clear_halt(self.in_endpoint)
            .map_err(transport_error)
    }
}

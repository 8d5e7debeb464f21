//! SPIDAR controllers: their wire protocols, the links that carry their bytes, and the
//! table of supported USB devices.
//!
//! - [`sh4`], [`simple`], [`counter`]: the two amplifiers' packets and 24-bit counters;
//! - [`transport`]: those protocols as the core's [`hapticd_core::transport::Transport`];
//! - [`usb`], [`usbfs`], [`hotplug`], [`udev`]: finding, opening and re-opening USB
//!   amplifiers, and the udev rules that let the daemon do so;
//! - [`replay`]: recording a link's traffic and playing it back as the device;
//! - [`guardian`]: the process that zeroes the amplifiers should the daemon die;
//! - [`sim`]: the simulated SPIDAR, a first-class device (an SH4 board, motors, strings
//!   and grip) moved by a scripted hand.
//!
//! Every link, real or simulated, moves the same bytes, so the protocol codecs are
//! exercised whatever the device.

pub mod counter;
pub mod guardian;
pub mod hotplug;
pub mod replay;
pub mod sh4;
pub mod sim;
pub mod simple;
pub mod transport;
pub mod udev;
pub mod usb;
pub mod usbfs;

/// Cyverse's USB vendor ID.
pub const CYVERSE_VENDOR: u16 = 0x0CEC;

/// A supported USB controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SupportedDevice {
    /// USB vendor ID.
    pub vendor: u16,
    /// USB product ID.
    pub product: u16,
    /// What it is.
    pub name: &'static str,
    /// Which protocol it speaks.
    pub protocol: Protocol,
}

/// The wire protocol of a controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Protocol {
    /// Cyverse USB 2.0 SH4 amplifier (SPIDAR-G): 512-byte bulk packets.
    Sh4,
    /// Cyverse USB 2.0 "Simple" amplifier: 32-byte bulk commands.
    Simple,
}

/// Every USB controller hapticd drives. The udev rules are generated from this table
/// ([`udev::rules`]).
pub const SUPPORTED_DEVICES: [SupportedDevice; 2] = [
    SupportedDevice {
        vendor: CYVERSE_VENDOR,
        product: 0x0205,
        name: "Cyverse USB 2.0 SH4 amplifier (SPIDAR-G)",
        protocol: Protocol::Sh4,
    },
    SupportedDevice {
        vendor: CYVERSE_VENDOR,
        product: 0x0203,
        name: "Cyverse USB 2.0 Simple amplifier",
        protocol: Protocol::Simple,
    },
];

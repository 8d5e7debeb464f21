//! SPIDAR controllers: their wire protocols, the transports that carry them, and the table
//! of supported USB devices.
//!
//! Every transport, real or simulated, moves the same bytes, so the protocol codecs are
//! exercised whatever the device.

pub mod counter;
pub mod hotplug;
pub mod replay;
pub mod sh4;
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

/// Motor channels on one amplifier board.
pub const CHANNELS: usize = 8;

/// D/A converter digits per volt of amplifier input (both amplifiers).
pub const DAC_DIGITS_PER_VOLT: f64 = 415.0;

/// What one update reads back from a controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Reading {
    /// Encoder counts, unwrapped to 64 bits.
    pub counts: [i64; CHANNELS],
    /// Digital input bits.
    pub inputs: u16,
    /// Board channel set on the rotary switch (input bits 4..7).
    pub board_channel: u8,
}

/// D/A value for `tension` newtons on a motor of `volts_per_newton`, saturated to the
/// converter's range. Truncated toward zero, so quantisation never raises a tension above
/// what was asked (and so never above a limit).
pub fn dac_for_tension(tension: f64, volts_per_newton: f64) -> i16 {
    let digits = (tension * volts_per_newton * DAC_DIGITS_PER_VOLT).trunc();
    digits.clamp(i16::MIN as f64, i16::MAX as f64) as i16
}

/// Tension a D/A value asks of a motor of `volts_per_newton`.
pub fn tension_for_dac(dac: i16, volts_per_newton: f64) -> f64 {
    dac as f64 / DAC_DIGITS_PER_VOLT / volts_per_newton
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dac_scaling_follows_the_amplifier_constants() {
        // 20 N on the 8 mm pulley motor: 20 × 0.3653 V/N × 415 digits/V = 3031.99 digits.
        assert_eq!(dac_for_tension(20.0, 0.3653), 3031);
        assert!(tension_for_dac(3031, 0.3653) <= 20.0);
        // A reversed motor (negative V/N) gets a negative value.
        assert_eq!(dac_for_tension(1.0, -0.5776), -239);
        assert_eq!(dac_for_tension(1e9, 0.3653), i16::MAX);
    }
}

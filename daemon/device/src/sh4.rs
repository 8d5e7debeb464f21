//! The Cyverse USB 2.0 SH4 amplifier protocol (USB 0x0CEC:0x0205, SPIDAR-G).
//!
//! One 512-byte bulk OUT (endpoint 0x02) and one 512-byte bulk IN (endpoint 0x86) per
//! update, little-endian:
//!
//! | OUT bytes | meaning |
//! |---|---|
//! | 0 | 0x01: update all channels |
//! | 1 | 0x0E |
//! | 2..18 | 8 × int16 D/A values |
//!
//! | IN bytes | meaning |
//! |---|---|
//! | 0..16 | 8 × int16 D/A echo |
//! | 16..32 | 8 × uint16 encoder counts (wrapping) |
//! | 32..48 | 8 × uint16 A/D values, 24 V / 4096 per digit |
//! | 48..50 | 16 input bits; bits 4..7 are the rotary switch (board channel) |
//! | 50..54 | uint32 of unknown meaning |

use hapticd_core::transport::{CHANNELS, DecodeError};

/// Size of every packet, both directions.
pub const PACKET: usize = 512;
/// Bulk OUT endpoint.
pub const ENDPOINT_OUT: u8 = 0x02;
/// Bulk IN endpoint.
pub const ENDPOINT_IN: u8 = 0x86;
/// First OUT byte: update all channels.
pub const COMMAND_UPDATE: u8 = 0x01;
/// Second OUT byte of an update.
pub const COMMAND_UPDATE_ARG: u8 = 0x0E;

/// Volts per A/D digit.
pub const ADC_VOLTS_PER_DIGIT: f64 = 24.0 / 4096.0;

/// The host's half of an update: D/A values to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Command {
    /// D/A value of each channel.
    pub dac: [i16; CHANNELS],
}

/// The board's half of an update.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Report {
    /// D/A values the board applied.
    pub dac_echo: [i16; CHANNELS],
    /// Raw 16-bit encoder counters.
    pub counts: [u16; CHANNELS],
    /// Raw A/D values.
    pub adc: [u16; CHANNELS],
    /// Digital inputs.
    pub inputs: u16,
    /// Trailing word of unknown meaning, kept for recordings.
    pub extra: u32,
}

fn i16_at(bytes: &[u8], at: usize) -> i16 {
    i16::from_le_bytes([bytes[at], bytes[at + 1]])
}

fn u16_at(bytes: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([bytes[at], bytes[at + 1]])
}

impl Command {
    /// Encode into an OUT packet.
    pub fn encode(&self, out: &mut [u8; PACKET]) {
        out.fill(0);
        out[0] = COMMAND_UPDATE;
        out[1] = COMMAND_UPDATE_ARG;
        for (i, v) in self.dac.iter().enumerate() {
            out[2 + 2 * i..4 + 2 * i].copy_from_slice(&v.to_le_bytes());
        }
    }

    /// Decode an OUT packet (the board's side, and recordings).
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        if bytes.len() < 2 + 2 * CHANNELS {
            return Err(DecodeError::Short(bytes.len()));
        }
        if (bytes[0], bytes[1]) != (COMMAND_UPDATE, COMMAND_UPDATE_ARG) {
            return Err(DecodeError::UnknownCommand(bytes[0], bytes[1]));
        }
        let mut dac = [0; CHANNELS];
        for (i, v) in dac.iter_mut().enumerate() {
            *v = i16_at(bytes, 2 + 2 * i);
        }
        Ok(Self { dac })
    }
}

impl Report {
    /// Board channel from the rotary switch.
    pub fn board_channel(&self) -> u8 {
        ((self.inputs >> 4) & 0x0F) as u8
    }

    /// Voltage on A/D channel `i`.
    pub fn adc_volts(&self, i: usize) -> f64 {
        self.adc[i] as f64 * ADC_VOLTS_PER_DIGIT
    }

    /// Encode into an IN packet (the board's side).
    pub fn encode(&self, out: &mut [u8; PACKET]) {
        out.fill(0);
        for i in 0..CHANNELS {
            out[2 * i..2 * i + 2].copy_from_slice(&self.dac_echo[i].to_le_bytes());
            out[16 + 2 * i..18 + 2 * i].copy_from_slice(&self.counts[i].to_le_bytes());
            out[32 + 2 * i..34 + 2 * i].copy_from_slice(&self.adc[i].to_le_bytes());
        }
        out[48..50].copy_from_slice(&self.inputs.to_le_bytes());
        out[50..54].copy_from_slice(&self.extra.to_le_bytes());
    }

    /// Decode an IN packet.
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        if bytes.len() < 54 {
            return Err(DecodeError::Short(bytes.len()));
        }
        let mut r = Report {
            inputs: u16_at(bytes, 48),
            extra: u32::from_le_bytes([bytes[50], bytes[51], bytes[52], bytes[53]]),
            ..Report::default()
        };
        for i in 0..CHANNELS {
            r.dac_echo[i] = i16_at(bytes, 2 * i);
            r.counts[i] = u16_at(bytes, 16 + 2 * i);
            r.adc[i] = u16_at(bytes, 32 + 2 * i);
        }
        Ok(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_bytes_follow_the_layout() {
        let mut out = [0xAA; PACKET];
        Command {
            dac: [1, -1, 0x1234, 0, 0, 0, 0, 3032],
        }
        .encode(&mut out);
        assert_eq!(&out[..8], &[0x01, 0x0E, 0x01, 0x00, 0xFF, 0xFF, 0x34, 0x12]);
        assert_eq!(&out[16..18], &3032i16.to_le_bytes());
        assert!(out[18..].iter().all(|&b| b == 0));
        assert_eq!(Command::decode(&out).unwrap().dac[2], 0x1234);
    }

    #[test]
    fn report_bytes_follow_the_layout() {
        let mut bytes = [0u8; PACKET];
        bytes[16..18].copy_from_slice(&0xBEEFu16.to_le_bytes()); // counter 0
        bytes[30..32].copy_from_slice(&7u16.to_le_bytes()); // counter 7
        bytes[32..34].copy_from_slice(&2048u16.to_le_bytes()); // A/D 0: 12 V
        bytes[48..50].copy_from_slice(&0x0035u16.to_le_bytes()); // switch 3, bits 0 and 2
        let r = Report::decode(&bytes).unwrap();
        assert_eq!((r.counts[0], r.counts[7]), (0xBEEF, 7));
        assert_eq!(r.adc_volts(0), 12.0);
        assert_eq!(r.board_channel(), 3);
        let mut again = [0u8; PACKET];
        r.encode(&mut again);
        assert_eq!(again, bytes);
    }

    #[test]
    fn malformed_packets_are_refused() {
        assert_eq!(Report::decode(&[0; 20]), Err(DecodeError::Short(20)));
        let mut out = [0u8; PACKET];
        out[0] = 0x02;
        assert_eq!(
            Command::decode(&out),
            Err(DecodeError::UnknownCommand(0x02, 0))
        );
    }
}

//! The Cyverse USB 2.0 "Simple" amplifier protocol (USB 0x0CEC:0x0203).
//!
//! Bulk endpoint 2 OUT, endpoint 6 IN, every transfer 32 bytes. An update is a D/A set
//! followed by a counter latch, whose reply carries the counters; a reset is an encoder
//! setup followed by a counter clear.
//!
//! | OUT command | bytes |
//! |---|---|
//! | encoder setup | `A2 1A <direction mask>` |
//! | counter clear | `A2 19 <channel mask>` |
//! | D/A set | `52` + 8 × int16 |
//! | counter latch | `51` |
//!
//! Reply to a latch: counter i is 24-bit two's complement at bytes 3i..3i+3; byte 24 holds
//! 8 input bits, bits 4..7 the rotary switch.

use crate::counter::sign_extend;
use hapticd_core::transport::CHANNELS;

/// Size of every transfer.
pub const PACKET: usize = 32;
/// Bulk OUT endpoint.
pub const ENDPOINT_OUT: u8 = 0x02;
/// Bulk IN endpoint.
pub const ENDPOINT_IN: u8 = 0x86;

/// A host command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// Set counting directions: bit i reverses channel i.
    EncoderSetup(u8),
    /// Clear the counters of the channels in the mask.
    CounterClear(u8),
    /// Set the D/A values.
    SetDac([i16; CHANNELS]),
    /// Latch the counters and reply with them.
    Latch,
}

/// Reply to a latch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LatchReply {
    /// Counters, sign-extended from 24 bits.
    pub counts: [i32; CHANNELS],
    /// Input bits.
    pub inputs: u8,
}

impl Command {
    /// Encode into an OUT transfer.
    pub fn encode(&self, out: &mut [u8; PACKET]) {
        out.fill(0);
        match *self {
            Command::EncoderSetup(mask) => out[..3].copy_from_slice(&[0xA2, 0x1A, mask]),
            Command::CounterClear(mask) => out[..3].copy_from_slice(&[0xA2, 0x19, mask]),
            Command::SetDac(dac) => {
                out[0] = 0x52;
                for (i, v) in dac.iter().enumerate() {
                    out[1 + 2 * i..3 + 2 * i].copy_from_slice(&v.to_le_bytes());
                }
            }
            Command::Latch => out[0] = 0x51,
        }
    }

    /// Decode an OUT transfer (the board's side); `None` for an unknown command.
    pub fn decode(bytes: &[u8; PACKET]) -> Option<Self> {
        match bytes[0] {
            0xA2 if bytes[1] == 0x1A => Some(Command::EncoderSetup(bytes[2])),
            0xA2 if bytes[1] == 0x19 => Some(Command::CounterClear(bytes[2])),
            0x52 => {
                let mut dac = [0; CHANNELS];
                for (i, v) in dac.iter_mut().enumerate() {
                    *v = i16::from_le_bytes([bytes[1 + 2 * i], bytes[2 + 2 * i]]);
                }
                Some(Command::SetDac(dac))
            }
            0x51 => Some(Command::Latch),
            _ => None,
        }
    }
}

impl LatchReply {
    /// Board channel from the rotary switch.
    pub fn board_channel(&self) -> u8 {
        self.inputs >> 4
    }

    /// Encode into an IN transfer (the board's side).
    pub fn encode(&self, out: &mut [u8; PACKET]) {
        out.fill(0);
        for (i, c) in self.counts.iter().enumerate() {
            out[3 * i..3 * i + 3].copy_from_slice(&c.to_le_bytes()[..3]);
        }
        out[24] = self.inputs;
    }

    /// Decode an IN transfer.
    pub fn decode(bytes: &[u8; PACKET]) -> Self {
        let mut counts = [0; CHANNELS];
        for (i, c) in counts.iter_mut().enumerate() {
            let raw = u32::from_le_bytes([bytes[3 * i], bytes[3 * i + 1], bytes[3 * i + 2], 0]);
            *c = sign_extend(raw, 24) as i32;
        }
        Self {
            counts,
            inputs: bytes[24],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_follow_the_layout() {
        let mut out = [0u8; PACKET];
        Command::EncoderSetup(0b1000_0001).encode(&mut out);
        assert_eq!(&out[..4], &[0xA2, 0x1A, 0x81, 0]);
        Command::CounterClear(0xFF).encode(&mut out);
        assert_eq!(&out[..3], &[0xA2, 0x19, 0xFF]);
        Command::SetDac([-2, 0, 0, 0, 0, 0, 0, 0x0102]).encode(&mut out);
        assert_eq!(&out[..3], &[0x52, 0xFE, 0xFF]);
        assert_eq!(&out[15..17], &[0x02, 0x01]);
        Command::Latch.encode(&mut out);
        assert_eq!(out[0], 0x51);
        for c in [
            Command::EncoderSetup(3),
            Command::CounterClear(5),
            Command::SetDac([7; 8]),
            Command::Latch,
        ] {
            c.encode(&mut out);
            assert_eq!(Command::decode(&out), Some(c));
        }
    }

    #[test]
    fn latch_replies_carry_signed_24_bit_counters() {
        let mut bytes = [0u8; PACKET];
        bytes[0..3].copy_from_slice(&[0xFF, 0xFF, 0xFF]); // −1
        bytes[21..24].copy_from_slice(&[0x00, 0x00, 0x80]); // counter 7: −2²³
        bytes[24] = 0x20; // switch 2
        let r = LatchReply::decode(&bytes);
        assert_eq!(
            (r.counts[0], r.counts[7], r.board_channel()),
            (-1, -(1 << 23), 2)
        );
        let mut again = [0u8; PACKET];
        r.encode(&mut again);
        assert_eq!(again, bytes);
    }
}

//! The transport: one update of a controller (write D/A values, read counters), whatever
//! carries the bytes: USB, the simulator, or a recording.
//!
//! A [`Link`] moves raw bulk transfers; an [`Amplifier`] says which bytes one protocol
//! exchanges; [`AmplifierTransport`] speaks any protocol over any link and unwraps the
//! counters, so the simulator and a replay exercise exactly the code that drives hardware.

use crate::Protocol;
use crate::counter::Unwrapper;
use crate::sh4::{self, Command, Report};
use crate::simple;
use hapticd_core::transport::{CHANNELS, DecodeError, Link, Reading, Transport, TransportError};

/// What one update of an amplifier reads before its counters are unwrapped.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RawReading {
    /// Encoder counts as the board sends them, wrapping at [`Amplifier::COUNTER_BITS`].
    pub counts: [u32; CHANNELS],
    /// Digital input bits.
    pub inputs: u16,
    /// Board channel set on the rotary switch.
    pub board_channel: u8,
}

/// The bytes one amplifier protocol exchanges on an update and a reset. The packet buffers
/// live in the protocol's value, so an update never allocates.
pub trait Amplifier: Default + Send {
    /// The width of the board's encoder counters.
    const COUNTER_BITS: u32;

    /// Sends `dac` and reads the counters back.
    fn exchange(
        &mut self,
        link: &mut dyn Link,
        dac: &[i16; CHANNELS],
    ) -> Result<RawReading, TransportError>;

    /// Brings the board (or the link's input queue) back to a known state.
    fn reset(&mut self, link: &mut dyn Link) -> Result<(), TransportError>;
}

/// The SH4 amplifier protocol: one command packet out, one report back.
pub struct Sh4 {
    out: [u8; sh4::PACKET],
    input: [u8; sh4::PACKET],
}

impl Default for Sh4 {
    fn default() -> Self {
        Self {
            out: [0; sh4::PACKET],
            input: [0; sh4::PACKET],
        }
    }
}

impl Amplifier for Sh4 {
    const COUNTER_BITS: u32 = 16;

    fn exchange(
        &mut self,
        link: &mut dyn Link,
        dac: &[i16; CHANNELS],
    ) -> Result<RawReading, TransportError> {
        Command { dac: *dac }.encode(&mut self.out);
        link.write(&self.out)?;
        let n = link.read(&mut self.input)?;
        let report = Report::decode(&self.input[..n]).map_err(TransportError::Protocol)?;
        Ok(RawReading {
            counts: report.counts.map(u32::from),
            inputs: report.inputs,
            board_channel: report.board_channel(),
        })
    }

    fn reset(&mut self, link: &mut dyn Link) -> Result<(), TransportError> {
        link.reset_in()
    }
}

/// The "Simple" amplifier protocol: an update is a D/A set, then a counter latch whose
/// reply carries the counters.
pub struct Simple {
    out: [u8; simple::PACKET],
    input: [u8; simple::PACKET],
}

impl Default for Simple {
    fn default() -> Self {
        Self {
            out: [0; simple::PACKET],
            input: [0; simple::PACKET],
        }
    }
}

impl Simple {
    fn send(
        &mut self,
        link: &mut dyn Link,
        command: simple::Command,
    ) -> Result<(), TransportError> {
        command.encode(&mut self.out);
        link.write(&self.out)
    }
}

impl Amplifier for Simple {
    const COUNTER_BITS: u32 = 24;

    fn exchange(
        &mut self,
        link: &mut dyn Link,
        dac: &[i16; CHANNELS],
    ) -> Result<RawReading, TransportError> {
        self.send(link, simple::Command::SetDac(*dac))?;
        self.send(link, simple::Command::Latch)?;
        let n = link.read(&mut self.input)?;
        if n < simple::PACKET {
            return Err(TransportError::Protocol(DecodeError::Short(n)));
        }
        let reply = simple::LatchReply::decode(&self.input);
        Ok(RawReading {
            // The reply's counters are two's-complement 24-bit values; their bits are the count.
            counts: reply.counts.map(|c| c as u32),
            inputs: u16::from(reply.inputs),
            board_channel: reply.board_channel(),
        })
    }

    fn reset(&mut self, link: &mut dyn Link) -> Result<(), TransportError> {
        self.send(link, simple::Command::EncoderSetup(0))?;
        self.send(link, simple::Command::CounterClear(0xFF))
    }
}

/// An amplifier protocol `A` over a [`Link`] `L`, its counters unwrapped to 64 bits.
pub struct AmplifierTransport<A: Amplifier, L: Link> {
    link: L,
    identity: String,
    amplifier: A,
    counters: [Unwrapper; CHANNELS],
}

/// The SH4 protocol over a link.
pub type Sh4Transport<L> = AmplifierTransport<Sh4, L>;
/// The Simple protocol over a link.
pub type SimpleTransport<L> = AmplifierTransport<Simple, L>;

impl<A: Amplifier, L: Link> AmplifierTransport<A, L> {
    /// A transport over `link`, known as `identity`.
    pub fn new(link: L, identity: impl Into<String>) -> Self {
        Self {
            link,
            identity: identity.into(),
            amplifier: A::default(),
            counters: [Unwrapper::new(A::COUNTER_BITS); CHANNELS],
        }
    }

    /// The link underneath.
    pub fn link(&self) -> &L {
        &self.link
    }
}

impl<A: Amplifier, L: Link> Transport for AmplifierTransport<A, L> {
    fn update(
        &mut self,
        dac: &[i16; CHANNELS],
        reading: &mut Reading,
    ) -> Result<(), TransportError> {
        let raw = self.amplifier.exchange(&mut self.link, dac)?;
        for ((count, counter), raw) in reading
            .counts
            .iter_mut()
            .zip(&mut self.counters)
            .zip(raw.counts)
        {
            *count = counter.update(raw);
        }
        reading.inputs = raw.inputs;
        reading.board_channel = raw.board_channel;
        Ok(())
    }

    fn reset(&mut self) -> Result<(), TransportError> {
        self.amplifier.reset(&mut self.link)?;
        for c in &mut self.counters {
            c.reset();
        }
        Ok(())
    }

    fn identity(&self) -> &str {
        &self.identity
    }

    fn replace_link(&mut self, link: Box<dyn Link>) -> Result<Box<dyn Link>, Box<dyn Link>> {
        self.link.replace(link)
    }
}

/// The transport speaking `protocol` over `link`, known as `identity`.
pub fn for_protocol<L: Link + 'static>(
    protocol: Protocol,
    link: L,
    identity: impl Into<String>,
) -> Box<dyn Transport> {
    match protocol {
        Protocol::Sh4 => Box::new(Sh4Transport::new(link, identity)),
        Protocol::Simple => Box::new(SimpleTransport::new(link, identity)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Simple board in memory: counters that move by a fixed step per latch.
    struct SimpleBoard {
        counts: [i32; CHANNELS],
        dac: [i16; CHANNELS],
        pending: bool,
    }

    impl Link for SimpleBoard {
        fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
            let packet: &[u8; simple::PACKET] =
                bytes.try_into().map_err(|_| TransportError::Io(22))?;
            match simple::Command::decode(packet) {
                Some(simple::Command::SetDac(dac)) => self.dac = dac,
                Some(simple::Command::Latch) => {
                    for (i, c) in self.counts.iter_mut().enumerate() {
                        // Wrap within 24 bits, as the hardware counter does.
                        *c = ((*c + 700_000 * (i as i32 - 3)) << 8) >> 8;
                    }
                    self.pending = true;
                }
                Some(simple::Command::CounterClear(_)) => self.counts = [0; CHANNELS],
                Some(simple::Command::EncoderSetup(_)) => {}
                None => return Err(TransportError::Io(22)),
            }
            Ok(())
        }

        fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
            if !std::mem::take(&mut self.pending) {
                return Err(TransportError::Timeout);
            }
            let packet: &mut [u8; simple::PACKET] =
                bytes.try_into().map_err(|_| TransportError::Io(22))?;
            simple::LatchReply {
                counts: self.counts,
                inputs: 0x50,
            }
            .encode(packet);
            Ok(simple::PACKET)
        }

        fn reset_in(&mut self) -> Result<(), TransportError> {
            Ok(())
        }
    }

    #[test]
    fn simple_counters_unwrap_past_twenty_four_bits() {
        let board = SimpleBoard {
            counts: [0; CHANNELS],
            dac: [0; CHANNELS],
            pending: false,
        };
        let mut t = SimpleTransport::new(board, "test");
        t.reset().unwrap();
        let mut reading = Reading::default();
        for k in 1..=100i64 {
            t.update(&[k as i16; CHANNELS], &mut reading).unwrap();
            for (i, &c) in reading.counts.iter().enumerate() {
                assert_eq!(c, k * 700_000 * (i as i64 - 3), "channel {i}");
            }
        }
        // 70 million counts: far past the 24-bit range, still exact.
        assert_eq!(reading.counts[7], 100 * 700_000 * 4);
        assert_eq!(reading.board_channel, 5);
        assert_eq!(t.link.dac, [100; CHANNELS]);
    }
}

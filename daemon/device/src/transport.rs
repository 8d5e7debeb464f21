//! The transport: one update of a controller (write D/A values, read counters), whatever
//! carries the bytes: USB, the simulator, or a recording.
//!
//! A [`Link`] moves raw bulk transfers; [`Sh4Transport`] speaks the SH4 protocol over any
//! link, so the simulator and a replay exercise exactly the code that drives hardware.

use crate::counter::Unwrapper;
use crate::sh4::{self, Command, Report};
use crate::simple;
use hapticd_core::transport::{CHANNELS, DecodeError, Link, Reading, Transport, TransportError};

/// The SH4 amplifier protocol over a [`Link`].
pub struct Sh4Transport<L: Link> {
    link: L,
    identity: String,
    out: [u8; sh4::PACKET],
    input: [u8; sh4::PACKET],
    counters: [Unwrapper; CHANNELS],
}

impl<L: Link> Sh4Transport<L> {
    /// A transport over `link`, known as `identity`.
    pub fn new(link: L, identity: impl Into<String>) -> Self {
        Self {
            link,
            identity: identity.into(),
            out: [0; sh4::PACKET],
            input: [0; sh4::PACKET],
            counters: [Unwrapper::new(16); CHANNELS],
        }
    }

    /// The link underneath.
    pub fn link(&self) -> &L {
        &self.link
    }

    /// The link underneath, mutably.
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }
}

impl<L: Link> Transport for Sh4Transport<L> {
    fn update(
        &mut self,
        dac: &[i16; CHANNELS],
        reading: &mut Reading,
    ) -> Result<(), TransportError> {
        Command { dac: *dac }.encode(&mut self.out);
        self.link.write(&self.out)?;
        let n = self.link.read(&mut self.input)?;
        let report = Report::decode(&self.input[..n]).map_err(TransportError::Protocol)?;
        for ((count, counter), raw) in reading
            .counts
            .iter_mut()
            .zip(&mut self.counters)
            .zip(report.counts)
        {
            *count = counter.update(u32::from(raw));
        }
        reading.inputs = report.inputs;
        reading.board_channel = report.board_channel();
        Ok(())
    }

    fn reset(&mut self) -> Result<(), TransportError> {
        self.link.reset_in()?;
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

/// The "Simple" amplifier protocol over a [`Link`]: an update is a D/A set, then a counter
/// latch whose reply carries the counters.
pub struct SimpleTransport<L: Link> {
    link: L,
    identity: String,
    out: [u8; simple::PACKET],
    input: [u8; simple::PACKET],
    counters: [Unwrapper; CHANNELS],
}

impl<L: Link> SimpleTransport<L> {
    /// A transport over `link`, known as `identity`.
    pub fn new(link: L, identity: impl Into<String>) -> Self {
        Self {
            link,
            identity: identity.into(),
            out: [0; simple::PACKET],
            input: [0; simple::PACKET],
            counters: [Unwrapper::new(24); CHANNELS],
        }
    }

    fn send(&mut self, command: simple::Command) -> Result<(), TransportError> {
        command.encode(&mut self.out);
        self.link.write(&self.out)
    }
}

impl<L: Link> Transport for SimpleTransport<L> {
    fn update(
        &mut self,
        dac: &[i16; CHANNELS],
        reading: &mut Reading,
    ) -> Result<(), TransportError> {
        self.send(simple::Command::SetDac(*dac))?;
        self.send(simple::Command::Latch)?;
        let n = self.link.read(&mut self.input)?;
        if n < simple::PACKET {
            return Err(TransportError::Protocol(DecodeError::Short(n)));
        }
        let reply = simple::LatchReply::decode(&self.input);
        for ((count, counter), raw) in reading
            .counts
            .iter_mut()
            .zip(&mut self.counters)
            .zip(reply.counts)
        {
            *count = counter.update(raw as u32);
        }
        reading.inputs = u16::from(reply.inputs);
        reading.board_channel = reply.board_channel();
        Ok(())
    }

    fn reset(&mut self) -> Result<(), TransportError> {
        self.send(simple::Command::EncoderSetup(0))?;
        self.send(simple::Command::CounterClear(0xFF))?;
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

//! The transport: one update of a controller (write D/A values, read counters), whatever
//! carries the bytes: USB, the simulator, or a recording.
//!
//! A [`Link`] moves raw bulk transfers; [`Sh4Transport`] speaks the SH4 protocol over any
//! link, so the simulator and a replay exercise exactly the code that drives hardware.

use super::counter::Unwrapper;
use super::sh4::{self, Command, Report};
use super::{CHANNELS, Reading};

/// Why an update failed. `Copy` and allocation-free: it is raised on the real-time thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransportError {
    /// The device is gone (unplugged, or the simulator was stopped).
    Disconnected,
    /// The device did not answer in time.
    Timeout,
    /// Any other I/O failure, with its errno-like code.
    Io(i32),
    /// The device answered something that is not the protocol.
    Protocol(sh4::DecodeError),
}

impl std::fmt::Display for TransportError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TransportError::Disconnected => f.write_str("device disconnected"),
            TransportError::Timeout => f.write_str("device timed out"),
            TransportError::Io(code) => write!(f, "I/O error {code}"),
            TransportError::Protocol(e) => write!(f, "protocol error: {e}"),
        }
    }
}

impl std::error::Error for TransportError {}

/// A controller as the haptic loop sees it.
pub trait Transport: Send {
    /// [rt] One update: apply `dac` and read the counters into `reading`. Blocks only on
    /// the device.
    fn update(
        &mut self,
        dac: &[i16; CHANNELS],
        reading: &mut Reading,
    ) -> Result<(), TransportError>;

    /// [main] Bring the controller to a known state; counters restart from the next read.
    fn reset(&mut self) -> Result<(), TransportError>;

    /// A stable identity (bus path or serial, or `sim:NAME`), the key of persisted calibration.
    fn identity(&self) -> &str;
}

/// Bulk transfers to and from a controller.
pub trait Link: Send {
    /// [rt] Send one OUT transfer.
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError>;
    /// [rt] Receive one IN transfer into `bytes`; returns its length.
    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError>;
    /// [main] Abort and reset the IN pipe.
    fn reset_in(&mut self) -> Result<(), TransportError>;
}

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
}

//! What the haptic loop talks to: a USB amplifier, a traffic recording or the simulated
//! SPIDAR, each behind the transport of its protocol, its traffic recorded on request.

use std::path::Path;

use hapticd::device::Protocol;
use hapticd::device::replay::{self, RecordingLink, ReplayLink, Transfer};
use hapticd::device::transport::{Link, Sh4Transport, SimpleTransport, Transport};
use hapticd::device::usb::FoundDevice;
use hapticd::mechanism::Mechanism;
use hapticd::runtime::spsc;
use hapticd::sim::hand::Script;
use hapticd::sim::{SimParameters, SimulatedBoard};

/// Where the device comes from.
pub enum Source<'a> {
    /// A USB amplifier, opened.
    Usb(FoundDevice),
    /// A traffic recording (`--replay`).
    Replay(&'a Path),
    /// The simulated SPIDAR of `mechanism`, stepped `rate` times a second, its hand following
    /// `script`.
    Simulator {
        /// The mechanism simulated.
        mechanism: &'a Mechanism,
        /// Ticks per second.
        rate: f64,
        /// The simulated hand's script.
        script: &'a Script,
    },
}

/// The transport of `source`, known as `identity`, its traffic sent to `traffic` if given.
pub fn open(
    source: Source<'_>,
    identity: &str,
    traffic: Option<spsc::Producer<Transfer>>,
) -> Result<Box<dyn Transport>, String> {
    Ok(match source {
        Source::Usb(device) => {
            // Boxed, so that a link opened after an unplug can take its place.
            let link: Box<dyn Link> = Box::new(device.link);
            match (device.model.protocol, traffic) {
                (Protocol::Sh4, traffic) => sh4_transport(link, identity, traffic),
                (Protocol::Simple, None) => Box::new(SimpleTransport::new(link, identity)),
                (Protocol::Simple, Some(ring)) => Box::new(SimpleTransport::new(
                    RecordingLink::new(link, ring),
                    identity,
                )),
            }
        }
        Source::Replay(path) => {
            let transfers = replay::read_recording(path).map_err(|e| e.to_string())?;
            sh4_transport(ReplayLink::new(transfers), identity, traffic)
        }
        Source::Simulator {
            mechanism,
            rate,
            script,
        } => {
            let board =
                SimulatedBoard::new(mechanism, 1.0 / rate, script, SimParameters::default());
            sh4_transport(board, identity, traffic)
        }
    })
}

/// The SH4 protocol over `link`, its traffic recorded when `recorder` is given.
fn sh4_transport<L: Link + 'static>(
    link: L,
    identity: &str,
    recorder: Option<spsc::Producer<Transfer>>,
) -> Box<dyn Transport> {
    match recorder {
        Some(ring) => Box::new(Sh4Transport::new(RecordingLink::new(link, ring), identity)),
        None => Box::new(Sh4Transport::new(link, identity)),
    }
}

//! What the haptic loop talks to: a USB amplifier, a traffic recording or the simulated
//! SPIDAR, each behind the transport of its protocol, its traffic recorded on request.

use std::path::PathBuf;

use hapticd_core::mechanism::Mechanism;
use hapticd_core::sync::spsc;
use hapticd_core::transport::{Link, Transport};
use hapticd_device::Protocol;
use hapticd_device::replay::{Recording, RecordingLink, ReplayLink, Transfer};
use hapticd_device::sim::hand::Script;
use hapticd_device::sim::{SimParameters, SimulatedBoard};
use hapticd_device::transport;
use hapticd_device::usb::FoundDevice;

/// What a device is.
pub enum Kind {
    /// A USB amplifier, opened.
    Usb(FoundDevice),
    /// A traffic recording played back.
    Replay(PathBuf),
    /// A simulated SPIDAR.
    Simulator(Simulated),
}

/// A simulated SPIDAR.
pub struct Simulated {
    /// Its name, unique among this daemon's devices.
    pub name: String,
    /// The mechanism it simulates whatever is saved (`--sim`, `devices:`); None: the
    /// configured one, or the one bound over the bus.
    pub mechanism: Option<String>,
    /// The script of its hand.
    pub hand: Script,
}

impl Kind {
    /// The identity its calibration and parameters are kept under, and its name on the bus
    /// and the network.
    pub fn identity(&self) -> String {
        match self {
            Kind::Usb(device) => device.identity.clone(),
            Kind::Replay(path) => format!("replay:{}", path.display()),
            Kind::Simulator(sim) => sim.name.clone(),
        }
    }

    /// The mechanism it drives whatever is saved or configured, if one is given.
    pub fn fixed_mechanism(&self) -> Option<&str> {
        match self {
            Kind::Simulator(sim) => sim.mechanism.as_deref(),
            _ => None,
        }
    }
}

/// The transport of device `kind`, known as `identity`, its traffic sent to `traffic` if
/// given; the simulator simulates `mechanism`, stepped `rate` times a second.
pub fn open(
    kind: Kind,
    identity: &str,
    traffic: Option<spsc::Producer<Transfer>>,
    mechanism: &Mechanism,
    rate: f64,
) -> Result<Box<dyn Transport>, String> {
    Ok(match kind {
        Kind::Usb(device) => {
            // Boxed, so that a link opened after an unplug can take its place.
            let link: Box<dyn Link> = Box::new(device.link);
            recorded(device.model.protocol, link, identity, traffic)
        }
        Kind::Replay(path) => {
            let recording = Recording::read(&path).map_err(|e| e.to_string())?;
            recorded(Protocol::Sh4, ReplayLink::new(recording), identity, traffic)
        }
        Kind::Simulator(sim) => {
            let board =
                SimulatedBoard::new(mechanism, 1.0 / rate, &sim.hand, SimParameters::default())
                    .map_err(|e| e.to_string())?;
            recorded(Protocol::Sh4, board, identity, traffic)
        }
    })
}

/// `protocol` over `link`, its traffic recorded when `recorder` is given.
fn recorded<L: Link + 'static>(
    protocol: Protocol,
    link: L,
    identity: &str,
    recorder: Option<spsc::Producer<Transfer>>,
) -> Box<dyn Transport> {
    match recorder {
        Some(ring) => transport::for_protocol(protocol, RecordingLink::new(link, ring), identity),
        None => transport::for_protocol(protocol, link, identity),
    }
}

//! Following a USB amplifier across an unplug: while the haptic loop reports it
//! disconnected, look for it again by identity (its bus path) and, once it is back, hand
//! the haptic loop a freshly opened link. Runs on the main thread, never on the real-time
//! one; the loop keeps its calibration and parameters across the gap.

use std::time::{Duration, Instant};

use super::transport::Link;
use super::{SupportedDevice, usb};

/// How often a missing amplifier is looked for.
pub const RETRY: Duration = Duration::from_millis(500);

/// What one look for a missing amplifier found.
pub enum Lookup {
    /// Not time to look again yet, or the device is not connected-and-lost.
    Idle,
    /// Not on the bus (yet).
    Absent,
    /// Back and opened: hand this link to the loop.
    Back(Box<dyn Link>),
    /// On the bus but unusable now (cannot be opened or claimed, or another model sits in
    /// its socket); looked for again later. Each reason is told once, not at every look.
    Refused(String),
}

/// Looks for one amplifier that went missing.
pub struct Reconnector {
    identity: String,
    model: SupportedDevice,
    next_look: Instant,
    told: Option<String>,
}

impl Reconnector {
    /// Follow the amplifier `model` known as `identity`.
    pub fn new(identity: impl Into<String>, model: SupportedDevice) -> Self {
        Self {
            identity: identity.into(),
            model,
            next_look: Instant::now(),
            told: None,
        }
    }

    /// Look for the amplifier again if it is `missing` and the last look is [`RETRY`] old.
    pub fn poll(&mut self, missing: bool, now: Instant) -> Lookup {
        if !missing || now < self.next_look {
            return Lookup::Idle;
        }
        self.next_look = now + RETRY;
        let refused = match usb::reopen(&self.identity) {
            Ok(Some(found)) if found.model == self.model => {
                self.told = None;
                return Lookup::Back(Box::new(found.link));
            }
            Ok(Some(found)) => format!(
                "{} is now a {}, not the {} it was: not reconnected",
                self.identity, found.model.name, self.model.name
            ),
            Ok(None) => return Lookup::Absent,
            Err(e) => e,
        };
        if self.told.as_ref() == Some(&refused) {
            return Lookup::Absent;
        }
        self.told = Some(refused.clone());
        Lookup::Refused(refused)
    }
}

//! SPIDAR amplifiers on USB as `hapticctl device …` shows them, each look a [`Report`]: the
//! supported amplifiers found, and the counters read back over a few updates of the first
//! usable one (for bring-up and diagnosis).

use hapticd_core::transport::{CHANNELS, Reading, TransportError};
use hapticd_device::SupportedDevice;
use hapticd_device::transport;
use hapticd_device::usb::{FoundDevice, NoBus, UnusableDevice, find_devices};
use serde_json::{Value, json};

use crate::report::Report;

/// Why an exchange with an amplifier stopped.
#[derive(Debug)]
pub enum ExchangeError {
    /// libusb cannot look at the bus.
    NoBus(NoBus),
    /// No supported amplifier can be used: these were found but not opened.
    NoneUsable(Vec<UnusableDevice>),
    /// An update failed.
    Update {
        /// Its number, from 0.
        index: usize,
        /// Why.
        error: TransportError,
    },
}

impl std::fmt::Display for ExchangeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ExchangeError::NoBus(e) => write!(f, "{e}"),
            ExchangeError::NoneUsable(unusable) if unusable.is_empty() => {
                f.write_str("no usable SPIDAR amplifier: none is connected")
            }
            ExchangeError::NoneUsable(unusable) => {
                let each: Vec<_> = unusable.iter().map(ToString::to_string).collect();
                write!(f, "no usable SPIDAR amplifier: {}", each.join("; "))
            }
            ExchangeError::Update { index, error } => write!(f, "update {index}: {error}"),
        }
    }
}

impl std::error::Error for ExchangeError {}

/// The supported amplifiers on the bus: the usable ones, then those that could not be
/// opened and why.
pub fn list(found: &[FoundDevice], unusable: &[UnusableDevice]) -> Report {
    let usb = |m: &SupportedDevice| format!("{:04x}:{:04x}", m.vendor, m.product);
    let usable = found
        .iter()
        .map(|d| (&d.identity, &d.model, None::<&String>));
    let listed: Vec<_> = usable
        .chain(
            unusable
                .iter()
                .map(|d| (&d.identity, &d.model, Some(&d.reason))),
        )
        .collect();
    let rows: Vec<_> = listed
        .iter()
        .map(|(identity, model, reason)| {
            json!({"identity": identity, "model": model.name, "usb": usb(model),
                   "usable": reason.is_none(), "problem": reason})
        })
        .collect();
    let text: String = listed
        .iter()
        .map(|(identity, model, reason)| match reason {
            None => format!("{identity}  {}  {}\n", usb(model), model.name),
            Some(why) => format!(
                "{identity}  {}  {}  unusable: {why}\n",
                usb(model),
                model.name
            ),
        })
        .collect();
    Report {
        text,
        json: Value::Array(rows),
        charts: Vec::new(),
    }
}

/// `values` as the D/A values of the channels: one whole number of digits per channel,
/// each within an `i16`; `None` otherwise.
pub fn dac_values(values: &[f64]) -> Option<[i16; CHANNELS]> {
    let range = f64::from(i16::MIN)..=f64::from(i16::MAX);
    if values.len() != CHANNELS
        || values
            .iter()
            .any(|v| v.fract() != 0.0 || !range.contains(v))
    {
        return None;
    }
    let mut dac = [0i16; CHANNELS];
    for (d, v) in dac.iter_mut().zip(values) {
        *d = *v as i16;
    }
    Some(dac)
}

/// Run `count` updates on the first usable amplifier, writing `dac` to its channels, and
/// report the counters and the board's switch after each.
pub fn exchange(dac: &[i16; CHANNELS], count: usize) -> Result<Report, ExchangeError> {
    let (found, unusable) = find_devices().map_err(ExchangeError::NoBus)?;
    let Some(device) = found.into_iter().next() else {
        return Err(ExchangeError::NoneUsable(unusable));
    };
    let mut transport =
        transport::for_protocol(device.model.protocol, device.link, device.identity.clone());
    let mut reading = Reading::default();
    let mut updates = Vec::with_capacity(count);
    let mut text = format!("{} ({})\n", device.identity, device.model.name);
    for index in 0..count {
        transport
            .update(dac, &mut reading)
            .map_err(|error| ExchangeError::Update { index, error })?;
        text += &format!(
            "{index:5}: counts {:?} switch {}\n",
            reading.counts, reading.board_channel
        );
        updates.push(json!({"counts": reading.counts, "board_channel": reading.board_channel}));
    }
    Ok(Report {
        text,
        json: json!({"identity": device.identity, "model": device.model.name, "updates": updates}),
        charts: Vec::new(),
    })
}

//! What the haptic loop asks of a device: one update (D/A values out, counters in) over a
//! [`Transport`], whose bytes a [`Link`] carries; and the amplifier constants that turn a
//! tension into a D/A value.
//!
//! The amplifier protocols, USB and the simulator implement these traits in
//! `hapticd-device`; the loop knows only the traits.

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

/// Highest command an amplifier channel may be given, volts. The current drive sets the
/// motor current to make its sense-resistor voltage equal the D/A command, from a 24 V
/// supply (thesis Fig. 3.4): a command above the supply asks for a current it cannot give,
/// so a mechanism that needs one is refused rather than driven at full scale.
pub const AMPLIFIER_MAX_VOLTS: f64 = 24.0;

/// Largest D/A magnitude a string of `tension_max` newtons on a motor of
/// `volts_per_newton` may be given: its tension limit, and never past
/// [`AMPLIFIER_MAX_VOLTS`] (non-finite inputs give 0, no force).
pub fn dac_limit(tension_max: f64, volts_per_newton: f64) -> i16 {
    let volts = tension_max * volts_per_newton.abs();
    if volts > 0.0 {
        (volts.min(AMPLIFIER_MAX_VOLTS) * DAC_DIGITS_PER_VOLT).trunc() as i16
    } else {
        // Zero, negative or NaN: no force at all.
        0
    }
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
    Protocol(DecodeError),
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

    /// [rt] Carry on over `link`: the same controller, opened again after it came back. The
    /// link replaced is returned, to be closed off the real-time thread; a transport whose
    /// link cannot be replaced hands `link` back as the error. The counters go on from their
    /// last totals, so a controller that kept its counts keeps its calibration.
    fn replace_link(&mut self, link: Box<dyn Link>) -> Result<Box<dyn Link>, Box<dyn Link>> {
        Err(link)
    }
}

/// Bulk transfers to and from a controller.
pub trait Link: Send {
    /// [rt] Send one OUT transfer.
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError>;
    /// [rt] Receive one IN transfer into `bytes`; returns its length.
    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError>;
    /// [main] Abort and reset the IN pipe.
    fn reset_in(&mut self) -> Result<(), TransportError>;

    /// [rt] Put `link` in place of the device underneath and return the one it replaces;
    /// a link that does not lead to a replaceable device hands `link` back as the error.
    fn replace(&mut self, link: Box<dyn Link>) -> Result<Box<dyn Link>, Box<dyn Link>> {
        Err(link)
    }
}

/// A link chosen at run time (a USB amplifier): the one kind of link that can be replaced
/// when its device comes back.
impl Link for Box<dyn Link> {
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.as_mut().write(bytes)
    }

    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
        self.as_mut().read(bytes)
    }

    fn reset_in(&mut self) -> Result<(), TransportError> {
        self.as_mut().reset_in()
    }

    fn replace(&mut self, link: Box<dyn Link>) -> Result<Box<dyn Link>, Box<dyn Link>> {
        Ok(std::mem::replace(self, link))
    }
}

/// Why a packet could not be understood.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecodeError {
    /// Fewer bytes than the layout needs.
    Short(usize),
    /// Not an update command.
    UnknownCommand(u8, u8),
}

impl std::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DecodeError::Short(n) => write!(f, "packet of {n} bytes is too short"),
            DecodeError::UnknownCommand(a, b) => write!(f, "unknown command {a:#04x} {b:#04x}"),
        }
    }
}

impl std::error::Error for DecodeError {}

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

    #[test]
    fn the_dac_limit_is_the_tension_limit_within_the_amplifiers_range() {
        // 20 N at 0.3653 V/N is 7.306 V: 3031 digits, what 20 N itself gives.
        assert_eq!(dac_limit(20.0, 0.3653), dac_for_tension(20.0, 0.3653));
        assert_eq!(dac_limit(20.0, -0.3653), 3031);
        // However large the descriptor's numbers, never past 24 V.
        let ceiling = (AMPLIFIER_MAX_VOLTS * DAC_DIGITS_PER_VOLT) as i16;
        for (t, v) in [
            (1e308, 0.3653),
            (20.0, 1e308),
            (f64::MAX, f64::MAX),
            (100.0, 1.0),
        ] {
            assert_eq!(dac_limit(t, v), ceiling, "{t} N, {v} V/N");
        }
        for (t, v) in [
            (f64::NAN, 0.3653),
            (20.0, f64::NAN),
            (0.0, 0.3653),
            (-1.0, 0.3653),
        ] {
            assert_eq!(dac_limit(t, v), 0, "{t} N, {v} V/N");
        }
    }
}

//! The simulated SPIDAR: a first-class device, and hapticd's default when no hardware is
//! plugged in. It is an SH4 amplifier board on the far side of a [`Link`]: it decodes the
//! host's D/A packets and answers with encoder packets, so everything above the link runs
//! exactly as with hardware.
//!
//! The model, per update of `period` seconds, integrated in steps of at most 20 µs:
//! - motors: D/A value → force on the string (digits / 415 / V/N), never below zero (a motor
//!   only reels in), acting on the pulley and rotor (`pulley_mass`, `pulley_damping`);
//! - strings: elastic springs (`string_stiffness`, `string_damping`) from pulley to knot,
//!   taut only when stretched; the encoder counts the string the pulley has paid out, so it
//!   sees the stretch too; counts are quantised;
//! - grips: 50 g point masses (rigid grips also turn, with a small inertia);
//! - hands: a hand mass held to the grip by the skin (spring-damper) and to its scripted
//!   target by the arm (spring-damper), plus any scripted push ([`hand`]).

pub mod hand;

use glam::{DQuat, DVec3};

use crate::sh4::{self, Command, Report};
use hand::{HandTrack, Script};
use hapticd_core::kinematics::{Dof, Pose, rotation_vector};
use hapticd_core::mechanism::Mechanism;
use hapticd_core::transport::{CHANNELS, DAC_DIGITS_PER_VOLT};
use hapticd_core::transport::{Link, TransportError};

/// How far past its target a squeezing hand may press before its arm pulls it back, metres:
/// deeper than any grip, short of running away when it misses.
const SQUEEZE_REACH: f64 = 0.02;

/// Physical constants of the simulated device and hand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimParameters {
    /// Stiffness of each string, N/m (about 20 kN/m at the grip for four strings).
    pub string_stiffness: f64,
    /// Internal damping of each string, N·s/m.
    pub string_damping: f64,
    /// Rotor and pulley inertia as a mass at the string, kg (J/r²).
    pub pulley_mass: f64,
    /// Viscous friction of motor and pulley, N·s/m at the string.
    pub pulley_damping: f64,
    /// Mass of a grip, kg (the mechanism adds the pulleys' share).
    pub grip_mass: f64,
    /// Rotational inertia of a rigid grip, kg·m².
    pub grip_inertia: f64,
    /// Effective mass of a finger and hand, kg.
    pub hand_mass: f64,
    /// Skin between hand and grip: stiffness N/m and damping N·s/m.
    pub skin: (f64, f64),
    /// Arm holding the hand to its target: stiffness N/m and damping N·s/m.
    pub arm: (f64, f64),
    /// Wrist holding a rigid grip's orientation: N·m/rad and N·m·s/rad.
    pub wrist: (f64, f64),
    /// Longest integration step, seconds.
    pub max_substep: f64,
}

impl Default for SimParameters {
    fn default() -> Self {
        Self {
            string_stiffness: 15_000.0,
            string_damping: 2.0,
            // With the grip, about 50 g at the hand, as measured on the 40 cm SPIDAR (thesis 3.2.1).
            pulley_mass: 0.01,
            pulley_damping: 0.5,
            grip_mass: 0.035,
            grip_inertia: 2e-5,
            hand_mass: 0.3,
            skin: (3_000.0, 3.0),
            arm: (300.0, 15.0),
            wrist: (0.5, 0.01),
            max_substep: 20e-6,
        }
    }
}

/// One simulated string.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SimString {
    effector: usize,
    motor: DVec3,
    knot: DVec3,
    metres_per_pulse: f64,
    volts_per_newton: f64,
    /// Encoder length at power-on: the counter reads zero there.
    origin: f64,
    /// String paid out by the pulley, metres.
    paid_out: f64,
    /// Its rate, m/s.
    pay_rate: f64,
}

/// One grip and the hand holding it.
#[derive(Debug, Clone, PartialEq)]
struct SimEffector {
    dof: Dof,
    grip: Pose,
    grip_velocity: DVec3,
    grip_spin: DVec3,
    hand: DVec3,
    hand_velocity: DVec3,
    rest_orientation: DQuat,
    track: HandTrack,
}

/// The simulated SH4 board, mechanism, grips and hands.
#[derive(Debug, Clone)]
pub struct SimulatedBoard {
    parameters: SimParameters,
    period: f64,
    time: f64,
    strings: Vec<SimString>,
    effectors: Vec<SimEffector>,
    dac: [i16; CHANNELS],
    tensions: [f64; CHANNELS],
    motor_forces: [f64; CHANNELS],
    pending_out: bool,
    input_bits: u16,
}

/// A mechanism the simulated board cannot drive: more strings than it has channels.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TooManyStrings {
    /// The mechanism.
    pub mechanism: String,
    /// Its strings.
    pub strings: usize,
}

impl std::fmt::Display for TooManyStrings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} has {} strings; one amplifier board drives at most {CHANNELS}",
            self.mechanism, self.strings
        )
    }
}

impl std::error::Error for TooManyStrings {}

impl SimulatedBoard {
    /// A board driving `mechanism`, updated every `period` seconds, its hands following
    /// `script` (effectors the script does not name hold their calibration pose). At power-on
    /// every grip is at its calibration pose and every counter reads zero. A mechanism with
    /// more strings than the board has channels cannot be driven by it: an error naming it.
    pub fn new(
        mechanism: &Mechanism,
        period: f64,
        script: &Script,
        parameters: SimParameters,
    ) -> Result<Self, TooManyStrings> {
        if mechanism.strings.len() > CHANNELS {
            return Err(TooManyStrings {
                mechanism: mechanism.name.clone(),
                strings: mechanism.strings.len(),
            });
        }
        let effectors: Vec<SimEffector> = mechanism
            .effectors
            .iter()
            .map(|e| {
                let steps = script.hands.get(&e.name).cloned().unwrap_or_default();
                SimEffector {
                    dof: e.dof,
                    grip: e.calibration,
                    grip_velocity: DVec3::ZERO,
                    grip_spin: DVec3::ZERO,
                    hand: e.calibration.position,
                    hand_velocity: DVec3::ZERO,
                    rest_orientation: e.calibration.orientation,
                    track: HandTrack::new(e.calibration.position, steps),
                }
            })
            .collect();
        let strings = mechanism
            .strings
            .iter()
            .map(|s| SimString {
                effector: s.effector,
                motor: s.motor,
                knot: s.knot,
                metres_per_pulse: s.metres_per_pulse,
                volts_per_newton: s.volts_per_newton,
                origin: (s.motor - effectors[s.effector].grip.transform_point(s.knot)).length(),
                paid_out: (s.motor - effectors[s.effector].grip.transform_point(s.knot)).length(),
                pay_rate: 0.0,
            })
            .collect();
        Ok(Self {
            parameters,
            period,
            time: 0.0,
            strings,
            effectors,
            dac: [0; CHANNELS],
            tensions: [0.0; CHANNELS],
            motor_forces: [0.0; CHANNELS],
            pending_out: false,
            input_bits: 0,
        })
    }

    /// Simulated time since power-on, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The true pose of effector `index`'s grip.
    pub fn grip(&self, index: usize) -> Pose {
        self.effectors[index].grip
    }

    /// The true velocity of effector `index`'s grip.
    pub fn grip_velocity(&self, index: usize) -> DVec3 {
        self.effectors[index].grip_velocity
    }

    /// The true angular velocity of effector `index`'s grip, rad/s.
    pub fn grip_spin(&self, index: usize) -> DVec3 {
        self.effectors[index].grip_spin
    }

    /// Tension in each string now, newtons.
    pub fn tensions(&self) -> &[f64; CHANNELS] {
        &self.tensions
    }

    /// Force each motor reels its string in with, newtons.
    pub fn motor_forces(&self) -> &[f64; CHANNELS] {
        &self.motor_forces
    }

    /// The last D/A values received.
    pub fn dac(&self) -> &[i16; CHANNELS] {
        &self.dac
    }

    /// Whether the script has the device unplugged now.
    pub fn unplugged(&self) -> bool {
        self.effectors
            .iter()
            .any(|e| e.track.at(self.time).unplugged)
    }

    /// Advance the model by `dt` seconds under the current D/A values.
    pub fn advance(&mut self, dt: f64) {
        let steps = (dt / self.parameters.max_substep).ceil().max(1.0) as usize;
        let h = dt / steps as f64;
        for _ in 0..steps {
            self.substep(h);
        }
    }

    fn substep(&mut self, h: f64) {
        let p = self.parameters;
        for (i, s) in self.strings.iter_mut().enumerate() {
            let commanded = self.dac[i] as f64 / DAC_DIGITS_PER_VOLT / s.volts_per_newton;
            self.motor_forces[i] = commanded.max(0.0);
            let e = &self.effectors[s.effector];
            let arm = e.grip.orientation * s.knot;
            let span = s.motor - (e.grip.position + arm);
            let direction = span.normalize_or_zero();
            // How fast the knot moves away from the motor.
            let knot_velocity = e.grip_velocity + e.grip_spin.cross(arm);
            let lengthening = -knot_velocity.dot(direction);
            let stretch = span.length() - s.paid_out;
            self.tensions[i] = if stretch > 0.0 {
                (p.string_stiffness * stretch + p.string_damping * (lengthening - s.pay_rate))
                    .max(0.0)
            } else {
                0.0
            };
            // The string pulls the pulley out, the motor reels it in.
            let pulley_force =
                self.tensions[i] - self.motor_forces[i] - p.pulley_damping * s.pay_rate;
            s.pay_rate += pulley_force / p.pulley_mass * h;
            s.paid_out += s.pay_rate * h;
        }
        let time = self.time;
        for (index, e) in self.effectors.iter_mut().enumerate() {
            let rotation = e.grip.orientation;
            let (mut force, mut torque) = (DVec3::ZERO, DVec3::ZERO);
            for (s, &tension) in self.strings.iter().zip(&self.tensions) {
                if s.effector != index {
                    continue;
                }
                let arm = rotation * s.knot;
                let direction = (s.motor - (e.grip.position + arm)).normalize_or_zero();
                force += direction * tension;
                torque += arm.cross(direction) * tension;
            }
            let command = e.track.at(time);
            let skin = p.skin.0 * (e.hand - e.grip.position)
                + p.skin.1 * (e.hand_velocity - e.grip_velocity);
            let mut arm_force = p.arm.0 * (command.target - e.hand)
                + p.arm.1 * (command.velocity - e.hand_velocity);
            if let Some(inward) = command.squeeze.try_normalize()
                && (e.hand - command.target).dot(inward) < SQUEEZE_REACH
            {
                // Squeezing, the arm may press the finger in harder, never pull it back, as
                // long as it has not gone far past its target (it missed what it squeezes).
                arm_force -= arm_force.dot(inward).min(0.0) * inward;
            }
            arm_force += command.push + command.squeeze;
            // Semi-implicit Euler: velocities first, then positions with the new velocities.
            e.grip_velocity += (force + skin) / p.grip_mass * h;
            e.hand_velocity += (arm_force - skin) / p.hand_mass * h;
            e.grip.position += e.grip_velocity * h;
            e.hand += e.hand_velocity * h;
            if e.dof == Dof::Six {
                let wanted = command.turn * e.rest_orientation;
                let error = rotation_vector(wanted * e.grip.orientation.inverse());
                let wrist = p.wrist.0 * error + p.wrist.1 * (command.spin - e.grip_spin);
                e.grip_spin += (torque + wrist) / p.grip_inertia * h;
                e.grip.orientation =
                    (DQuat::from_scaled_axis(e.grip_spin * h) * e.grip.orientation).normalize();
            }
        }
        self.time += h;
    }

    /// Encoder counts now: string paid out since power-on, quantised.
    pub fn counts(&self) -> [i64; CHANNELS] {
        let mut counts = [0; CHANNELS];
        for (c, s) in counts.iter_mut().zip(&self.strings) {
            *c = ((s.paid_out - s.origin) / s.metres_per_pulse).round() as i64;
        }
        counts
    }

    /// Set the digital input bits (bits 4..7: the rotary switch).
    pub fn set_inputs(&mut self, bits: u16) {
        self.input_bits = bits;
    }

    fn report(&self) -> Report {
        let mut report = Report {
            dac_echo: self.dac,
            inputs: self.input_bits,
            ..Report::default()
        };
        for (raw, count) in report.counts.iter_mut().zip(self.counts()) {
            // The hardware counter is 16 bits wide and wraps.
            *raw = count as u16;
        }
        report
    }
}

impl Link for SimulatedBoard {
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        if self.unplugged() {
            self.advance(self.period);
            return Err(TransportError::Disconnected);
        }
        let command = Command::decode(bytes).map_err(TransportError::Protocol)?;
        self.dac = command.dac;
        self.pending_out = true;
        Ok(())
    }

    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
        if !std::mem::take(&mut self.pending_out) {
            return Err(TransportError::Timeout);
        }
        self.advance(self.period);
        let packet: &mut [u8; sh4::PACKET] = bytes
            .get_mut(..sh4::PACKET)
            .and_then(|b| b.try_into().ok())
            .ok_or(TransportError::Io(EINVAL))?;
        self.report().encode(packet);
        Ok(sh4::PACKET)
    }

    fn reset_in(&mut self) -> Result<(), TransportError> {
        self.pending_out = false;
        Ok(())
    }
}

/// errno EINVAL: the caller's buffer cannot hold a packet.
const EINVAL: i32 = 22;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::Sh4Transport;
    use hapticd_core::mechanism::descriptor;
    use hapticd_core::transport::Transport;
    use hapticd_core::transport::{Reading, dac_for_tension};
    use std::path::Path;

    const SPIDAR: &str = "name: s\nend_effectors:\n  - name: grip\n    dof: 3\nstrings:\n\
        - {effector: grip, motor: [-0.2, 0.2, 0.2], metres_per_pulse: 2.0e-5, volts_per_newton: 0.3653, tension_min: 0.5, tension_max: 20}\n\
        - {effector: grip, motor: [0.2, 0.2, -0.2], metres_per_pulse: 2.0e-5, volts_per_newton: 0.3653, tension_min: 0.5, tension_max: 20}\n\
        - {effector: grip, motor: [-0.2, -0.2, -0.2], metres_per_pulse: 2.0e-5, volts_per_newton: 0.3653, tension_min: 0.5, tension_max: 20}\n\
        - {effector: grip, motor: [0.2, -0.2, 0.2], metres_per_pulse: -2.0e-5, volts_per_newton: -0.3653, tension_min: 0.5, tension_max: 20}\n";

    fn spidar() -> Mechanism {
        descriptor::parse(SPIDAR, Path::new("s.yaml")).unwrap()
    }

    #[test]
    fn a_mechanism_of_more_strings_than_channels_is_refused_by_name() {
        let mut m = spidar();
        let string = m.strings[0];
        m.strings.resize(CHANNELS + 1, string);
        let refused = SimulatedBoard::new(&m, 1e-3, &Script::default(), SimParameters::default())
            .err()
            .unwrap();
        assert_eq!(
            refused,
            TooManyStrings {
                mechanism: m.name.clone(),
                strings: CHANNELS + 1
            }
        );
    }

    #[test]
    fn counts_follow_the_grip_through_the_protocol() {
        let m = spidar();
        let script = Script::parse(
            "hands:\n  grip:\n    - move: { to: [0.03, 0, 0], seconds: 0.5 }\n",
            std::path::Path::new("h.yaml"),
        )
        .unwrap();
        let board = SimulatedBoard::new(&m, 1e-3, &script, SimParameters::default()).unwrap();
        let mut transport = Sh4Transport::new(board, "sim:test");
        let mut reading = Reading::default();
        // Half a newton on every string keeps them taut, as the tension minimum does.
        let dac = m
            .strings
            .iter()
            .map(|s| dac_for_tension(0.5, s.volts_per_newton))
            .collect::<Vec<_>>();
        let mut out = [0; CHANNELS];
        out[..4].copy_from_slice(&dac);
        for _ in 0..1000 {
            transport.update(&out, &mut reading).unwrap();
        }
        let board = transport.link();
        let grip = board.grip(0).position;
        assert!(
            (grip - DVec3::new(0.03, 0.0, 0.0)).length() < 3e-3,
            "{grip}"
        );
        // Counts are the string paid out: the change of length less the stretch, in metres
        // per pulse, whatever the encoder's direction.
        for (i, s) in m.strings.iter().enumerate() {
            let stretch = board.tensions()[i] / SimParameters::default().string_stiffness;
            let expected =
                ((s.motor - grip).length() - s.motor.length() - stretch) / s.metres_per_pulse;
            assert!(
                (reading.counts[i] as f64 - expected).abs() <= 0.5 + 1e-6,
                "string {i}"
            );
        }
    }

    #[test]
    fn a_squeezing_finger_with_nothing_to_squeeze_stops_short_of_running_away() {
        let m = spidar();
        let name = &m.effectors[0].name;
        let script = Script::parse(
            &format!("hands:\n  {name}:\n    - hold: {{ seconds: 2, squeeze: [2, 0, 0] }}\n"),
            std::path::Path::new("h.yaml"),
        )
        .unwrap();
        let mut board = SimulatedBoard::new(&m, 1e-3, &script, SimParameters::default()).unwrap();
        let mut out = [0u8; sh4::PACKET];
        Command { dac: [0; CHANNELS] }.encode(&mut out);
        for _ in 0..2000 {
            board.write(&out).unwrap();
            let mut input = [0u8; sh4::PACKET];
            board.read(&mut input).unwrap();
        }
        // 2 N and no arm against it for the first 2 cm; there the arm (6 N at 2 cm) takes
        // over again, and the finger stays.
        let x = board.grip(0).position.x - m.effectors[0].calibration.position.x;
        assert!((0.015..0.025).contains(&x), "moved {x}");
    }

    #[test]
    fn tension_pulls_the_grip_and_stretches_the_string() {
        let m = spidar();
        let mut board =
            SimulatedBoard::new(&m, 1e-3, &Script::default(), SimParameters::default()).unwrap();
        // 5 N on the first string only (toward its motor), counted in D/A digits.
        let mut dac = [0; CHANNELS];
        dac[0] = dac_for_tension(5.0, 0.3653);
        let mut out = [0u8; sh4::PACKET];
        Command { dac }.encode(&mut out);
        for _ in 0..3000 {
            board.write(&out).unwrap();
            let mut input = [0u8; sh4::PACKET];
            board.read(&mut input).unwrap();
        }
        // At rest the arm (300 N/m) balances 5 N: the grip moved ≈ 5/300 m toward the motor
        // (the skin adds its own small compliance in series).
        let toward = m.strings[0].motor.normalize();
        let moved = board.grip(0).position.dot(toward);
        let expected = 5.0 * (1.0 / 300.0 + 1.0 / 3000.0);
        assert!(
            (moved - expected).abs() < 0.03 * expected,
            "{moved} vs {expected}"
        );
        assert!((board.tensions()[0] - 5.0).abs() < 0.01);
        // The encoder counts the stretched string too: 5 N on 15 kN/m is 0.33 mm.
        let geometric =
            (m.strings[0].motor - board.grip(0).position).length() - m.strings[0].motor.length();
        let counted = board.counts()[0] as f64 * m.strings[0].metres_per_pulse;
        assert!(
            (geometric - counted - 5.0 / 15_000.0).abs() < 3e-5,
            "{geometric} {counted}"
        );
        // A negative D/A value on a forward motor asks the string to push: it cannot.
        dac[0] = -1000;
        Command { dac }.encode(&mut out);
        for _ in 0..500 {
            board.write(&out).unwrap();
            board.read(&mut [0u8; sh4::PACKET]).unwrap();
            assert_eq!(board.motor_forces()[0], 0.0);
        }
        assert!(board.tensions()[0] < 0.05, "{}", board.tensions()[0]);
    }

    #[test]
    fn an_unplugged_board_reports_disconnection_then_returns() {
        let m = spidar();
        let script = Script::parse(
            "hands:\n  grip:\n    - hold: { seconds: 0.01 }\n    - unplug: { seconds: 0.01 }\n",
            std::path::Path::new("h.yaml"),
        )
        .unwrap();
        let board = SimulatedBoard::new(&m, 1e-3, &script, SimParameters::default()).unwrap();
        let mut t = Sh4Transport::new(board, "sim:test");
        let mut reading = Reading::default();
        let results: Vec<bool> = (0..40)
            .map(|_| t.update(&[0; CHANNELS], &mut reading).is_ok())
            .collect();
        assert!(results[..9].iter().all(|ok| *ok));
        assert!(results[11..19].iter().all(|ok| !ok));
        assert!(results[22..].iter().all(|ok| *ok));
    }
}

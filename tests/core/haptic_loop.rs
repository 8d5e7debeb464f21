//! The haptic loop closed on the simulated SPIDAR-G: the scripted hand pushes into the floor
//! of the static scene and is held on its surface; faults drive the motors to zero.

use crate::support;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use glam::{DQuat, DVec3};
use hapticd_core::transport::{Link, TransportError};

use hapticd_core::haptic_loop::{
    DeviceState, Frame, HapticLoop, LoopCommand, LoopSettings, Retired,
};
use hapticd_core::scene::Pointer;
use hapticd_core::scene::static_scene::{StaticScene, StaticSceneSpec};
use hapticd_device::sim::hand::Script;
use hapticd_device::sim::{SimParameters, SimulatedBoard};
use hapticd_device::transport::Sh4Transport;
use support::{shipped, simulated_loop};

const DT: f64 = 1e-3;

fn build(script: &str) -> HapticLoop {
    simulated_loop(&shipped("spidar-g"), script, DT)
}

const PUSH_INTO_FLOOR: &str = "hands:\n  grip:\n    - hold: { seconds: 0.3 }\n    - move: { to: [0, -0.05, 0], seconds: 0.3 }\n    - hold: { seconds: 2 }\n";

#[test]
fn the_floor_holds_the_pushing_hand_on_its_surface() {
    let mut haptic = build(PUSH_INTO_FLOOR);
    let mut heights = Vec::new();
    let mut last = None;
    for tick in 0..2600 {
        let frame = *haptic.tick(DT);
        assert_eq!(frame.state, DeviceState::Running, "tick {tick}");
        for (i, s) in haptic.mechanism().strings.iter().enumerate() {
            assert!(frame.tensions[i] <= s.tension_max + 1e-12);
        }
        if tick >= 2100 {
            heights.push(frame.poses[0].position.y);
        }
        last = Some(frame);
    }
    let frame = last.unwrap();
    // The arm (300 N/m) aims 2 cm below the floor at y = −0.03: about 6 N press on a
    // 2 kN/m proxy spring, a few millimetres deep, and the floor pushes back up.
    let mean = heights.iter().sum::<f64>() / heights.len() as f64;
    let spread = heights
        .iter()
        .map(|h| (h - mean).powi(2))
        .sum::<f64>()
        .sqrt()
        / (heights.len() as f64).sqrt();
    assert!((-0.036..-0.030).contains(&mean), "grip held at y = {mean}");
    assert!(spread < 2e-4, "grip not at rest: spread {spread}");
    let force = frame.wrenches[0];
    assert!(force.force.y > 3.0 && force.force.y < 8.0, "{force:?}");
    assert!(
        force.force.x.abs() < 0.5 && force.force.z.abs() < 0.5,
        "{force:?}"
    );
}

/// Mean of `values`.
fn mean(values: &[DVec3]) -> DVec3 {
    values.iter().sum::<DVec3>() / values.len() as f64
}

#[test]
fn a_turned_grip_reads_the_angular_velocity_the_simulator_gives_it() {
    // A third of a turn about a tilted axis, in free air, then still again.
    let rate = DVec3::new(0.6, 1.2, -0.6);
    let script = format!(
        "hands:\n  grip:\n    - hold: {{ seconds: 0.3 }}\n    - turn: {{ rate: [{}, {}, {}], seconds: 1.5 }}\n    - hold: {{ seconds: 1 }}\n",
        rate.x, rate.y, rate.z
    );
    let (mut haptic, board, _) = on_cable(&script);
    let (mut read, mut true_spin, mut still) = (Vec::new(), Vec::new(), Vec::new());
    for tick in 0..3000 {
        let frame = *haptic.tick(DT);
        assert_eq!(frame.state, DeviceState::Running, "tick {tick}");
        for (i, s) in haptic.mechanism().strings.iter().enumerate() {
            assert!(frame.tensions[i] <= s.tension_max + 1e-12);
        }
        let spin = board.lock().unwrap().grip_spin(0);
        // The wrist has caught up with the turn after a few tenths of a second.
        if (800..1800).contains(&tick) {
            read.push(frame.angular_velocities[0]);
            true_spin.push(spin);
        }
        if tick >= 2600 {
            still.push(frame.angular_velocities[0]);
        }
    }
    let (read, truth) = (mean(&read), mean(&true_spin));
    assert!(
        (truth - rate).length() < 0.02 * rate.length(),
        "the wrist turned at {truth}, asked {rate}"
    );
    // The estimate lags the grip by the filter's time constant (0.8 ms) and carries the
    // encoders' steps: over a second its mean is the grip's.
    assert!(
        (read - truth).length() < 0.01 * truth.length(),
        "read {read}, the grip turned at {truth}"
    );
    assert!(mean(&still).length() < 0.01, "at rest: {}", mean(&still));
    let turned = haptic.frame().poses[0].orientation;
    let rest = haptic.mechanism().effectors[0].calibration.orientation;
    let expected = DQuat::from_scaled_axis(rate * 1.5) * rest;
    assert!(
        turned.angle_between(expected) < 0.02,
        "ended at {turned}, the turn asked {expected}"
    );
}

#[test]
fn an_unplugged_device_faults_to_zero_and_resumes() {
    let script = "hands:\n  grip:\n    - hold: { seconds: 0.3 }\n    - move: { to: [0, -0.05, 0], seconds: 0.3 }\n    - hold: { seconds: 0.4 }\n    - unplug: { seconds: 0.2 }\n    - hold: { seconds: 1 }\n";
    let mut haptic = build(script);
    let mut states = Vec::new();
    for _ in 0..2000 {
        let frame = *haptic.tick(DT);
        states.push((frame.state, frame.dac, frame.wrenches[0].force.y));
    }
    // While unplugged (1.0–1.2 s) the loop reports it and commands zero current.
    for (state, dac, _) in &states[1010..1190] {
        assert_eq!(*state, DeviceState::Disconnected);
        assert_eq!(*dac, [0; 8]);
    }
    // Before, it pressed on the floor; after, it presses again.
    assert!(states[950].2 > 3.0);
    let (state, _, force) = states[1999];
    assert_eq!(state, DeviceState::Running);
    assert!(force > 3.0, "{force}");
}

/// A USB cable between the loop and a simulated amplifier: once pulled, every transfer fails
/// as an unplugged amplifier's do, for good; a new cable reaches the same board, whose
/// counters went on counting.
struct Cable {
    board: Arc<Mutex<SimulatedBoard>>,
    pulled: Arc<AtomicBool>,
    /// Added to each raw counter the board reports: a board that restarted its counts with
    /// the strings elsewhere.
    shift: [u16; 8],
}

impl Cable {
    fn board(&self) -> Result<std::sync::MutexGuard<'_, SimulatedBoard>, TransportError> {
        if self.pulled.load(Ordering::Relaxed) {
            return Err(TransportError::Disconnected);
        }
        Ok(self.board.lock().unwrap())
    }
}

impl Link for Cable {
    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.board()?.write(bytes)
    }

    fn read(&mut self, bytes: &mut [u8]) -> Result<usize, TransportError> {
        let n = self.board()?.read(bytes)?;
        // Encoder counts are the little-endian u16s at bytes 16..32 of the SH4 report.
        for (i, shift) in self.shift.iter().enumerate() {
            let at = 16 + 2 * i;
            let raw = u16::from_le_bytes([bytes[at], bytes[at + 1]]).wrapping_add(*shift);
            bytes[at..at + 2].copy_from_slice(&raw.to_le_bytes());
        }
        Ok(n)
    }

    fn reset_in(&mut self) -> Result<(), TransportError> {
        self.board()?.reset_in()
    }
}

/// A SPIDAR-G loop over a cable to a simulated amplifier whose hand follows `script`;
/// returns the loop, the board, and the switch that pulls the cable.
fn on_cable(script: &str) -> (HapticLoop, Arc<Mutex<SimulatedBoard>>, Arc<AtomicBool>) {
    let m = shipped("spidar-g");
    let board = Arc::new(Mutex::new(
        SimulatedBoard::new(
            &m,
            DT,
            &Script::parse(script, std::path::Path::new("hand.yaml")).unwrap(),
            SimParameters::default(),
        )
        .unwrap(),
    ));
    let pulled = Arc::new(AtomicBool::new(false));
    let link: Box<dyn Link> = Box::new(Cable {
        board: board.clone(),
        pulled: pulled.clone(),
        shift: [0; 8],
    });
    let spec =
        StaticSceneSpec::load(&support::repo_dir().join("config/scenes/static.yaml")).unwrap();
    let scene = Box::new(StaticScene::new(spec, &Pointer::at_calibration(&m)));
    let haptic = HapticLoop::new(
        m,
        Box::new(Sh4Transport::new(link, "usb:1-2")),
        scene,
        LoopSettings::default(),
    )
    .unwrap();
    (haptic, board, pulled)
}

/// A SPIDAR-G loop on a simulated amplifier pressing on the floor, its USB cable pulled
/// after 1.5 s and left out for 0.3 s; returns the loop, the board, and the last frame
/// before the unplug.
fn pressed_then_unplugged() -> (HapticLoop, Arc<Mutex<SimulatedBoard>>, Frame) {
    let (mut haptic, board, first_cable) = on_cable(PUSH_INTO_FLOOR);
    for _ in 0..1500 {
        haptic.tick(DT);
    }
    let pressing = *haptic.frame();
    assert_eq!(pressing.state, DeviceState::Running);
    assert!(
        pressing.wrenches[0].force.y > 3.0,
        "{:?}",
        pressing.wrenches[0]
    );
    // Unplugged: the old link never answers again, and the motors get zero once the fault
    // ramp (as for the simulator's own unplug) is over.
    first_cable.store(true, Ordering::Relaxed);
    for tick in 0..300 {
        let frame = *haptic.tick(DT);
        assert_eq!(frame.state, DeviceState::Disconnected);
        if tick >= 10 {
            assert_eq!(frame.dac, [0; 8]);
        }
    }
    (haptic, board, pressing)
}

#[test]
fn an_amplifier_opened_again_after_an_unplug_resumes_with_its_calibration() {
    let (mut haptic, board, pressing) = pressed_then_unplugged();
    // Plugged back and opened again: the loop takes the new link between two ticks.
    haptic.command(LoopCommand::Reconnect(Box::new(Cable {
        board: board.clone(),
        pulled: Arc::new(AtomicBool::new(false)),
        shift: [0; 8],
    })));
    let Some(Retired::Link(mut dead)) = haptic.take_retired() else {
        panic!("the dead link must come back to be closed off the real-time thread");
    };
    assert_eq!(dead.write(&[0; 512]), Err(TransportError::Disconnected));
    let mut first_back = None;
    for _ in 0..1000 {
        let frame = *haptic.tick(DT);
        first_back.get_or_insert(frame);
    }
    let first_back = first_back.unwrap();
    assert_eq!(first_back.state, DeviceState::Running);
    // The counters went on from their totals: the grip is where it was, with the same
    // calibration, not re-calibrated at wherever it happened to be.
    let moved = (first_back.poses[0].position - pressing.poses[0].position).length();
    assert!(moved < 1e-3, "the grip jumped {moved} m across the unplug");
    let frame = *haptic.frame();
    assert_eq!(frame.calibrations, 1);
    assert_eq!(frame.offsets, pressing.offsets);
    assert_eq!(frame.state, DeviceState::Running);
    assert!(
        frame.wrenches[0].force.y > 3.0,
        "pressing again: {:?}",
        frame.wrenches[0]
    );
}

#[test]
fn zero_motors_writes_zero_currents() {
    let mut haptic = build(PUSH_INTO_FLOOR);
    for _ in 0..1000 {
        haptic.tick(DT);
    }
    assert!(haptic.frame().dac.iter().any(|d| *d != 0));
    haptic.zero_motors().unwrap();
    assert_eq!(haptic.frame().dac, [0; 8]);
}

#[test]
fn counts_that_no_longer_fit_the_calibration_hold_the_forces_at_zero_until_it_is_redone() {
    let (mut haptic, board, _) = pressed_then_unplugged();
    // Back, but the board restarted its counters with the strings elsewhere: each counter is
    // off by a different 1000·(i + 1) counts (3–23 cm of string).
    let shift = std::array::from_fn(|i| 1000 * (i as u16 + 1));
    haptic.command(LoopCommand::Reconnect(Box::new(Cable {
        board,
        pulled: Arc::new(AtomicBool::new(false)),
        shift,
    })));
    for _ in 0..500 {
        let frame = *haptic.tick(DT);
        assert_eq!(frame.state, DeviceState::Uncalibrated);
        assert!(!frame.calibrated);
        assert_eq!(frame.dac, [0; 8], "no force on counts that fit no pose");
    }
    // A fault reset is not enough: only a calibration trusts the counts again.
    haptic.command(LoopCommand::ResetFault);
    assert_eq!(haptic.tick(DT).state, DeviceState::Uncalibrated);
    haptic.command(LoopCommand::MeasureOffsets);
    let measured = haptic.tick(DT).measured;
    assert_eq!(
        haptic.frame().state,
        DeviceState::Uncalibrated,
        "measured, not yet used"
    );
    haptic.command(LoopCommand::UseOffsets(measured));
    let frame = *haptic.tick(DT);
    assert_eq!(frame.state, DeviceState::Running);
    assert!(frame.calibrated);
    assert_eq!(frame.calibrations, 2);
}

#[test]
fn a_saved_calibration_is_trusted_only_if_the_counts_fit_it() {
    let m = shipped("spidar-g");
    let script = "hands:\n  grip:\n    - hold: { seconds: 1 }\n";
    let fitting = {
        let mut haptic = simulated_loop(&m, script, DT);
        haptic.tick(DT);
        haptic.frame().offsets
    };
    // The offsets the device itself gave fit; offsets off by 2–16 cm, string by string, do
    // not (the grip cannot be where those lengths meet).
    for (offsets, expected) in [
        (fitting, DeviceState::Running),
        (
            std::array::from_fn(|i| fitting[i] + 0.02 * (i as f64 + 1.0)),
            DeviceState::Uncalibrated,
        ),
    ] {
        let mut haptic = simulated_loop(&m, script, DT);
        haptic.restore_calibration(&offsets[..8]).unwrap();
        for _ in 0..100 {
            assert_eq!(haptic.tick(DT).state, expected);
        }
        assert_eq!(haptic.frame().calibrations, 0);
    }
}

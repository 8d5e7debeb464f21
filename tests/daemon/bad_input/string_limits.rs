//! No accepted mechanism, whatever the scene asks and the counts say, gets a D/A command
//! past its string's limit; counts that stop fitting a pose fault to zero force.

use super::*;

/// A board whose counts are whatever the test says (changed between ticks).
struct Board(Arc<Mutex<[i64; CHANNELS]>>);

impl Transport for Board {
    fn update(
        &mut self,
        _dac: &[i16; CHANNELS],
        reading: &mut Reading,
    ) -> Result<(), TransportError> {
        reading.counts = *self.0.lock().unwrap();
        Ok(())
    }

    fn reset(&mut self) -> Result<(), TransportError> {
        Ok(())
    }

    fn identity(&self) -> &str {
        "test board"
    }
}

/// A scene that asks for whatever wrench the test sets: huge, infinite, NaN.
struct Asking(Wrench);

impl Scene for Asking {
    fn name(&self) -> &str {
        "asking"
    }

    fn render(&mut self, _pointers: &[Pointer], _dt: f64, wrenches: &mut [Wrench]) -> bool {
        wrenches.fill(self.0);
        true
    }

    fn reset(&mut self, _pointers: &[Pointer]) {}
}

/// A random value spread over many orders of magnitude, `lo` to `hi`.
fn log_uniform(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    (rng.range(lo.ln(), hi.ln())).exp()
}

/// One of `sane` mostly, one of `wild` sometimes: a value spread over orders of magnitude.
fn spread(rng: &mut Rng, sane: (f64, f64), wild: (f64, f64)) -> f64 {
    let (lo, hi) = if rng.range(0.0, 1.0) < 0.8 {
        sane
    } else {
        wild
    };
    log_uniform(rng, lo, hi)
}

/// A random mechanism specification: mostly plausible, often at or past the limits.
fn random_spec(rng: &mut Rng) -> MechanismSpec {
    let six = rng.range(0.0, 1.0) < 0.5;
    let count = (if six { 7 } else { 4 }) + (rng.next_u64() % 2) as usize;
    let effector = HapticdEffector::new("grip", if six { 6 } else { 3 });
    let strings = (0..count)
        .map(|_| {
            let motor = rng.unit() * spread(rng, (0.1, 1.0), (0.01, 20.0));
            let knot = if six { rng.unit() * 0.02 } else { DVec3::ZERO };
            let sign = if rng.range(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
            let tension_max = spread(rng, (1.0, 60.0), (1e-3, 1e6));
            HapticdString {
                effector: 0,
                motor: motor.to_array(),
                knot: knot.to_array(),
                metres_per_pulse: sign * spread(rng, (1e-6, 1e-4), (1e-10, 1.0)),
                volts_per_newton: sign * spread(rng, (0.05, 1.0), (1e-7, 1e4)),
                tension_min: tension_max * rng.range(0.0, 1.05),
                tension_max,
            }
        })
        .collect();
    MechanismSpec {
        lambda: log_uniform(rng, 1e-4, 1.0),
        torque_weight: 1.0,
        effectors: vec![effector],
        strings,
    }
}

#[test]
fn no_accepted_mechanism_gets_a_dac_command_past_its_string_limit() {
    let mut rng = Rng::new(16);
    let hostile = [
        Wrench::force(DVec3::new(0.0, -5.0, 0.0)),
        Wrench::from_array([1e300, -1e300, 1e300, 1e300, 0.0, -1e300]),
        Wrench::from_array([f64::MAX; 6]),
        Wrench::force(DVec3::new(f64::INFINITY, 0.0, 0.0)),
        Wrench::from_array([f64::NAN; 6]),
        Wrench::force(DVec3::new(1e-300, 0.0, 0.0)),
    ];
    let (mut accepted, mut ticks) = (0, 0);
    for case in 0..1000 {
        let spec = random_spec(&mut rng);
        let locate = |_: &str| None::<Position>;
        let Ok(m) = Mechanism::from_spec("random", "", Path::new("random"), &spec, &locate) else {
            continue;
        };
        accepted += 1;
        let limit: Vec<f64> = m
            .strings
            .iter()
            .map(|s| (s.tension_max * s.volts_per_newton.abs()).min(AMPLIFIER_MAX_VOLTS))
            .collect();
        let board = Box::new(Board(Arc::default()));
        let scene = Box::new(Asking(hostile[case % hostile.len()]));
        let Ok(mut haptic) = HapticLoop::new(m.clone(), board, scene, LoopSettings::default())
        else {
            continue;
        };
        for tick in 0..300 {
            match tick % 50 {
                48 => haptic.command(LoopCommand::MeasureOffsets),
                49 => haptic.command(LoopCommand::UseOffsets(haptic.frame().measured)),
                _ => {}
            }
            let frame = *haptic.tick(1e-3);
            ticks += 1;
            for (i, &dac) in frame.dac[..m.strings.len()].iter().enumerate() {
                let volts = f64::from(dac).abs() / DAC_DIGITS_PER_VOLT;
                assert!(
                    volts <= limit[i] + 1e-12,
                    "case {case}, tick {tick}, string {i}: {volts} V past {} V ({:?})",
                    limit[i],
                    m.strings[i]
                );
                assert!(frame.tensions[i] <= m.strings[i].tension_max);
            }
        }
    }
    eprintln!("{accepted} of 1000 random mechanisms accepted, {ticks} hostile ticks checked");
    assert!(
        accepted >= 50,
        "only {accepted} of 1000 random mechanisms were accepted"
    );
    assert!(ticks >= 50 * 300);
}

#[test]
fn counts_that_stop_fitting_any_pose_mid_run_fault_to_zero_force() {
    let m = support::shipped("spidar-g");
    let counts = Arc::new(Mutex::new([0; CHANNELS]));
    let board = Box::new(Board(counts.clone()));
    let calibration = m.effectors[0].calibration.position;
    let scene = Box::new(Asking(Wrench::force(DVec3::new(0.0, -3.0, 0.0))));
    let mut haptic = HapticLoop::new(m, board, scene, LoopSettings::default()).unwrap();
    for _ in 0..500 {
        assert_eq!(haptic.tick(1e-3).state, DeviceState::Running);
    }
    assert!(haptic.frame().dac.iter().any(|&d| d != 0));
    // One encoder jumps by a metre's worth of counts: no pose fits the lengths any more.
    counts.lock().unwrap()[3] += 40_000;
    let mut zero_after = None;
    for tick in 0..20 {
        let frame = *haptic.tick(1e-3);
        assert_eq!(frame.state, DeviceState::Uncalibrated, "tick {tick}");
        if zero_after.is_none() && frame.dac.iter().all(|&d| d == 0) {
            zero_after = Some(tick);
        }
    }
    assert!(zero_after.is_some_and(|t| t <= 6), "{zero_after:?}");
    // Calibrating again (the grip held at its calibration pose) brings the forces back.
    haptic.command(LoopCommand::MeasureOffsets);
    haptic.tick(1e-3);
    haptic.command(LoopCommand::UseOffsets(haptic.frame().measured));
    for _ in 0..300 {
        haptic.tick(1e-3);
    }
    assert_eq!(haptic.frame().state, DeviceState::Running);
    assert!((haptic.frame().poses[0].position - calibration).length() < 1e-6);
}

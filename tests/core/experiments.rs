//! The thesis' closed-loop experiments on the simulated SPIDAR: Table 3.4 (stiffest stable
//! wall against loop rate), 3.5.10 (tracing a bar across the edge of the complete region),
//! and 4.7 (shaking a held box, Tables 4.1–4.2), the last through `hapticctl experiment`;
//! a hinged box's swing against the exact period and energy of a pendulum, and a door pushed
//! at low physics rates against 1 kHz (7.2).

use crate::support;

use hapticctl::experiments::{door, grasp, pendulum, shape_tracing, wall_stiffness};
use hapticd_core::haptics::grasp::Method;
use hapticd_physics::scene::Feedback;
use support::{hapticctl, shipped};

#[test]
fn the_stiffest_stable_wall_rises_with_the_loop_rate() {
    let m = shipped("spidar");
    let k: Vec<f64> = [1000.0, 5000.0, 10_000.0]
        .iter()
        .map(|&rate| wall_stiffness::max_stable_stiffness(&m, rate).unwrap().0)
        .collect();
    assert!(k[0] < k[1] && k[1] < k[2], "{k:?}");
    // The thesis measured 7.0 / 25.5 / 28.5 kN/m on hardware: same order of magnitude.
    assert!(
        (3_000.0..30_000.0).contains(&k[0]) && (10_000.0..100_000.0).contains(&k[2]),
        "{k:?}"
    );
}

#[test]
fn the_stability_test_tells_soft_from_too_stiff() {
    let m = shipped("spidar");
    assert!(wall_stiffness::is_stable(&m, 1000.0, 2_000.0, 2.0).unwrap());
    assert!(!wall_stiffness::is_stable(&m, 1000.0, 200_000.0, 2.0).unwrap());
}

#[test]
fn continuous_tensions_trace_the_bar_rounder_and_smoother() {
    let exact = shape_tracing::deviation(&shape_tracing::trace(0.0, 1000.0), 1000.0);
    let continuous = shape_tracing::deviation(&shape_tracing::trace(0.2, 1000.0), 1000.0);
    assert!(
        continuous.roundness < exact.roundness,
        "{continuous:?} vs {exact:?}"
    );
    assert!(
        continuous.roughness < 0.5 * exact.roughness,
        "{continuous:?} vs {exact:?}"
    );
    // Both stay on the surface: pressed in by millimetres, not shaken off.
    for d in [exact, continuous] {
        assert!((0.185..0.2).contains(&d.mean_radius), "{d:?}");
    }
}

/// `hapticctl experiment grasp --json` in the thesis' set-up: both methods' means and spreads.
#[test]
fn shaking_a_held_box_keeps_grip_and_finger_distance_steady_with_the_resultant_distributed() {
    let out = support::succeeded(
        hapticctl()
            .args(["experiment", "grasp", "--json"])
            .output()
            .unwrap(),
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let method = |name: &str| {
        report["results"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["method"] == name)
            .unwrap()
            .clone()
    };
    let (distributed, conventional) = (method("distributed"), method("conventional"));
    let number = |r: &serde_json::Value, key: &str, what: &str| r[key][what].as_f64().unwrap();
    // (4.10): still, the fingers stand l − 2f_g/k apart, within 2 %.
    let predicted = distributed["predicted_still_distance"].as_f64().unwrap();
    let still = number(&distributed, "still_distance", "mean");
    assert!(
        (still - predicted).abs() < 0.02 * predicted,
        "{still} vs {predicted}"
    );
    // Standard deviations, distributed / conventional: at most 0.75 (the thesis' subjects
    // averaged 0.66 for grip force and 0.71 for finger distance).
    for key in ["grip", "distance"] {
        let ratio =
            number(&distributed, key, "deviation") / number(&conventional, key, "deviation");
        assert!(ratio <= 0.75, "{key}: {ratio}");
    }
}

/// The conventional method's fingers close in while the box is pushed, by exactly what (4.8)
/// says: x2 − x1 = l − (2 f_g + |f_r|)/k.
#[test]
fn the_conventional_fingers_close_in_by_the_resultant_as_4_8_says() {
    let setup = grasp::Setup {
        method: Method::Conventional,
        seconds: 6.0,
        ..grasp::Setup::THESIS
    };
    let samples = grasp::run(&setup);
    let pushed: Vec<_> = samples.iter().filter(|s| s.resultant.abs() > 2.0).collect();
    assert!(pushed.len() > 500, "{} pushed samples", pushed.len());
    for s in pushed {
        let predicted = setup.width - (2.0 * s.grip + s.resultant.abs()) / setup.grip_stiffness;
        // (To 2 % of the resultant's part: uneven friction tilts the box a little, and its
        // faces with it; the unit test of the grasp model checks the untilted case exactly.)
        assert!(
            (s.distance - predicted).abs() < 0.02 * s.resultant.abs() / setup.grip_stiffness,
            "t = {}: {} vs {predicted}",
            s.time,
            s.distance
        );
        // Short of the grip alone's l − 2f_g/k by the resultant's share.
        assert!(s.distance < setup.width - 2.0 * s.grip / setup.grip_stiffness - 2e-3);
    }
}

/// Thesis 6.4.1–6.4.2 (Fig. 6.6): a finger strikes a block once, the world at 20 Hz, the
/// haptics at 1 kHz with a 2 kN/m spring, for ten sampling phases. Where the block stops
/// depends on the phase when the physics takes the hand's position, hardly when it takes
/// the impulse of the force displayed; and the impulse method moves the block as far as
/// the same strike does with the physics as fast as the haptics.
#[test]
fn impulse_feedback_makes_a_push_independent_of_the_sampling_phase() {
    use hapticctl::experiments::push_phase::{self, Setup};
    use hapticd_physics::scene::Feedback;
    let setup = Setup::THESIS;
    let sweep = |feedback| {
        let world = push_phase::world(push_phase::SCENE, &setup, feedback).unwrap();
        push_phase::stops(&push_phase::sweep(&world, &setup, 10).unwrap())
    };
    let (impulse, position) = (sweep(Feedback::Impulse), sweep(Feedback::Position));
    assert!(
        impulse.deviation <= 0.2 * position.deviation,
        "impulse {impulse:?}, position {position:?}"
    );
    let fast = Setup {
        rate: setup.haptic_rate,
        ..setup
    };
    let world = push_phase::world(push_phase::SCENE, &fast, Feedback::Impulse).unwrap();
    let reference = push_phase::run(&world, &fast, 0.0).unwrap().stop();
    assert!(reference > 1e-3, "the block hardly moved: {reference} m");
    assert!(
        (impulse.mean / reference - 1.0).abs() <= 0.05,
        "impulse {impulse:?} against {reference} m at 1 kHz"
    );
}

/// Thesis 6.5.4: one push on blocks of 0.1 to 10 kg at low physics rates. Handing back
/// impulses threw a light block (the finger meets it as a wall for a period), and bounded by
/// the finger's speed sends it short; moving the
/// bodies near the finger in the haptic thread (local dynamics) pushes every block as far
/// as the physics at the haptic rate does (within 10 %, at 10, 20 and 30 Hz; the 10 kg block
/// the finger cannot move stays within a millimetre), whatever the sampling phase (a fifth of
/// position feedback's spread), and no faster than the finger.
#[test]
fn local_dynamics_pushes_every_block_as_far_as_physics_at_the_haptic_rate() {
    use hapticctl::experiments::push_mass;
    use hapticd_physics::scene::Feedback;
    for mass in push_mass::MASSES {
        let fast = push_mass::reference(mass).unwrap();
        let reference = fast.stop();
        for rate in push_mass::RATES {
            let local = push_mass::cell(mass, rate, Feedback::Local, 3).unwrap();
            let travel = local.travel();
            if reference.abs() < 1e-3 {
                assert!(
                    travel.mean.abs() < 1e-3 && mass >= 10.0,
                    "{mass} kg at {rate} Hz: local {travel:?} against {reference} m"
                );
                continue;
            }
            assert!(
                (travel.mean / reference - 1.0).abs() <= 0.10,
                "{mass} kg at {rate} Hz: local {travel:?} against {reference} m"
            );
            let position = push_mass::cell(mass, rate, Feedback::Position, 3).unwrap();
            // The goal: at most a fifth of position feedback's spread over phases.
            assert!(
                travel.deviation <= 0.2 * position.travel().deviation,
                "{mass} kg at {rate} Hz: local {travel:?}, position {:?}",
                position.travel()
            );
            if mass <= 1.0 {
                // Handed back whole, an impulse threw these blocks metres (the finger meets
                // them as a wall for a period); bounded by how fast the finger pushed, none
                // is thrown: it goes short instead.
                let impulse = push_mass::cell(mass, rate, Feedback::Impulse, 3).unwrap();
                assert!(
                    impulse.travel().mean < reference,
                    "{mass} kg at {rate} Hz: impulse {:?} against {reference} m",
                    impulse.travel()
                );
                assert!(
                    impulse.speed_ratio() < fast.speed_ratio().max(1.0) + 0.05,
                    "{mass} kg at {rate} Hz: impulse {} against {} at 1 kHz",
                    impulse.speed_ratio(),
                    fast.speed_ratio()
                );
            }
            // The body moves no faster than about the finger pushing it: it overshoots as
            // the proxy's spring unloads, as it does with the physics at the haptic rate.
            assert!(
                local.speed_ratio() < fast.speed_ratio().max(1.0) + 0.05,
                "{mass} kg at {rate} Hz: {} against {} at 1 kHz",
                local.speed_ratio(),
                fast.speed_ratio()
            );
        }
    }
}

/// A physical pendulum released from 10° and from 60° swings with the exact period of a
/// large amplitude, 4·√(I/(m·g·d))·K(sin(θ₀/2)): within 1 % stepped at 1 kHz, 3 % at 60 Hz
/// (a multibody's hinge, reduced coordinates: 0.01 % at 60 Hz measured), for boxes of two
/// shapes and densities.
#[test]
fn a_hinged_box_swings_with_the_exact_period_of_its_amplitude() {
    for (size, density) in [
        (pendulum::SIZE, pendulum::DENSITY),
        ([0.05, 0.3, 0.01], 300.0),
    ] {
        for degrees in [10.0f64, 60.0] {
            let start = degrees.to_radians();
            let exact = pendulum::exact_period(size, density, start);
            for (engine, rate, within) in [
                ("penalty", 4000.0, 0.01),
                ("rapier", 1000.0, 0.01),
                ("rapier", 60.0, 0.03),
            ] {
                let period = pendulum::measured_period(engine, size, density, start, rate);
                println!(
                    "{size:?} from {degrees}°, {engine} at {rate} Hz: {period:.5} s, exact \
                     {exact:.5} s ({:+.3} %)",
                    100.0 * (period / exact - 1.0)
                );
                assert!((period / exact - 1.0).abs() < within);
            }
        }
    }
}

/// With no damping a pendulum released from 60° keeps its swing's energy: its mean over a
/// period after a minute is within 1 % of the first period's, in the penalty engine at 4 kHz
/// and in rapier at 1 kHz and at 60 Hz.
#[test]
fn a_hinged_box_keeps_its_energy_for_a_minute() {
    let start = 60f64.to_radians();
    let (size, density) = (pendulum::SIZE, pendulum::DENSITY);
    for (engine, rate) in [("penalty", 4000.0), ("rapier", 1000.0), ("rapier", 60.0)] {
        let mut swinging =
            pendulum::Pendulum::new(pendulum::scene(engine, size, density, start, rate));
        let energy = |b: pendulum::Bob| {
            let turn = glam::DMat3::from_quat(b.orientation);
            0.5 * b.mass * b.velocity.length_squared()
                + 0.5 * b.spin.dot(turn * b.inertia * turn.transpose() * b.spin)
                + b.mass * 9.81 * b.position.y
        };
        // The swing's energy: what falling from the start to hanging straight gives.
        let swing = swinging.bob().mass * 9.81 * size[1] / 2.0 * (1.0 - start.cos());
        let period = (pendulum::exact_period(size, density, start) * rate).round() as usize;
        let (mut means, mut sum) = (Vec::new(), 0.0);
        for k in 1..=(60.0 * rate) as usize {
            assert!(swinging.step(1.0 / rate));
            sum += energy(swinging.bob());
            if k % period == 0 {
                means.push(sum / period as f64);
                sum = 0.0;
            }
        }
        let drift = (means[means.len() - 1] - means[0]) / swing;
        println!(
            "{engine} at {rate} Hz: the swing's energy drifted {:+.4} % in a minute",
            100.0 * drift
        );
        assert!(drift.abs() < 0.01);
    }
}

/// A door pushed open at its handle by the simulated hand, the physics at 10, 30 and 60 Hz
/// with local dynamics through its hinge, against the same push with the physics at 1 kHz:
/// its angle when the hand lets go and its rate after are within 10 % of the reference's
/// (measured: +0.7 % and −1.4 % for the default door), and the hand met the door's moment
/// about its hinge (its angular impulse over the rate it gave), I/r² at the handle, within
/// 5 % (measured: to the fifth digit), for two doors of different sizes and masses.
#[test]
fn a_door_pushed_at_its_handle_swings_at_low_physics_rates_as_at_1_khz() {
    let heavy = door::Door {
        size: [0.8, 2.0, 0.04],
        density: 600.0,
        handle: 0.7,
        speed: 0.3,
        ..door::Door::default()
    };
    for d in [door::Door::default(), heavy] {
        let reference = door::swing(&d, 1000.0, Feedback::Impulse).unwrap();
        let at = reference.release;
        for rate in door::RATES {
            let run = door::swing(&d, rate, Feedback::Local).unwrap();
            let (angle, rate_after) = (
                run.angle_at(at) / reference.angle_at(at),
                run.rate_after / reference.rate_after,
            );
            let felt = run.felt_moment() / d.moment();
            println!(
                "{:.1} kg door at {rate} Hz: angle at release {angle:.4}, rate after \
                 {rate_after:.4} of the reference's; moment met {felt:.5} of I",
                d.mass()
            );
            assert!((angle - 1.0).abs() < 0.1 && (rate_after - 1.0).abs() < 0.1);
            assert!((felt - 1.0).abs() < 0.05);
        }
        assert!((reference.felt_moment() / d.moment() - 1.0).abs() < 0.05);
    }
}

/// A door pushed shut against its stop at its handle by a hand pushing 20 N, for a second:
/// it passes the stop by less than 1° in the world and as the hand feels it, and the force
/// the hand feels never turns back and forth from tick to tick once the hand has struck
/// (a tenth of a second on), in rapier at 60 and 10 Hz under local dynamics and in the
/// penalty engine at the device rate. (Measured: 0° past and no turn in all three. Before
/// the haptic side held the stop as a contact, the door it moved went 1.7° past at 60 Hz,
/// the force turning back and forth 51 times, and 22° at 10 Hz, where the hand lost it.)
#[test]
fn a_door_pushed_against_its_stop_by_the_hand_holds_without_chatter() {
    let d = door::Door {
        limits: Some([-1.6, 0.0]),
        ..door::Door::default()
    };
    for stepping in [
        "engine: rapier\nrate: 60\nfeedback: local\nmaterial: { static_friction: 0, friction: 0 }",
        "engine: rapier\nrate: 10\nfeedback: local\nmaterial: { static_friction: 0, friction: 0 }",
        door::PENALTY,
    ] {
        let press = door::pressed(&d, stepping, 20.0, 1.0).unwrap();
        let settled = &press.forces[100..];
        let mean = settled.iter().sum::<f64>() / settled.len() as f64;
        let alternations = press.alternations(100, 0.01);
        println!(
            "{}: past the stop {:.4}° (world), {:.4}° (felt); mean force {mean:.2} N, {} \
             alternations",
            stepping.lines().take(2).collect::<Vec<_>>().join(" "),
            press.past.0.to_degrees(),
            press.past.1.to_degrees(),
            alternations
        );
        assert!(press.past.0 < 1f64.to_radians() && press.past.1 < 1f64.to_radians());
        assert_eq!(alternations, 0);
    }
}

//! SPIDAR-G, G6X3L geometry: one rigid cross-shaped grip (arm radius 0.0225 m) held by
//! eight strings; four motors above the grip, four mirrored below it in y. Six DOF.
//!
//! The published geometry fixes the knots of the two strings along x; those of the strings
//! along z are the assignment that keeps the grip force-closed over the widest region around
//! the frame centre (a test checks closure there).

use hapticd_plugin_api::{HapticdEffector, HapticdString, MechanismSpec};

/// Motor exit points of the upper four strings, metres.
const UPPER_MOTORS: [[f64; 3]; 4] = [
    [0.0849, 0.076, 0.0],
    [-0.0849, 0.076, 0.0],
    [0.0, 0.076, 0.0849],
    [0.0, 0.076, -0.0849],
];
/// Knots of the upper four strings on the grip, metres, grip frame.
const UPPER_KNOTS: [[f64; 3]; 4] = [
    [0.0159, 0.0, -0.0159],
    [0.0, 0.0225, 0.0],
    [-0.0159, 0.0, -0.0159],
    [0.0, 0.0225, 0.0],
];
/// Torque-row weight: 1/r² for the grip radius r = 0.0225 m, so a torque error counts like the
/// force error at the knots that would cause it (eq. 3.16 with every row weighted 1 would
/// all but ignore torques of a few N·cm).
const TORQUE_WEIGHT: f64 = 1.0 / (0.0225 * 0.0225);
/// String length per encoder count, metres.
const METRES_PER_PULSE: f64 = 1.66555e-5;
/// Amplifier volts per newton of the maxon motor on an 8 mm pulley.
const VOLTS_PER_NEWTON: f64 = 0.3653;

fn build() -> MechanismSpec {
    let mirror = |p: [f64; 3]| [p[0], -p[1], p[2]];
    let upper = UPPER_MOTORS.into_iter().zip(UPPER_KNOTS);
    let lower = upper.clone().map(|(m, k)| (mirror(m), mirror(k)));
    MechanismSpec {
        lambda: 0.001,
        torque_weight: TORQUE_WEIGHT,
        effectors: vec![HapticdEffector::new("grip", 6)],
        strings: upper
            .chain(lower)
            .map(|(motor, knot)| HapticdString {
                effector: 0,
                motor,
                knot,
                metres_per_pulse: METRES_PER_PULSE,
                volts_per_newton: VOLTS_PER_NEWTON,
                tension_min: 0.3,
                tension_max: 20.0,
            })
            .collect(),
    }
}

hapticd_plugin_api::export_mechanism!(
    name: "spidar-g",
    description: "SPIDAR-G (G6X3L): 8 strings to one rigid cross grip (6 DOF)",
    build: build,
);

//! The frame of SPIDAR and SPIDAR-II: a 0.53 m cube whose alternate corners carry the four
//! motors of one finger (a tetrahedron around the workspace); SPIDAR-II's second finger uses
//! the other four corners.

use hapticd_plugin_api::HapticdString;

/// Half the edge of the frame cube, metres.
pub const HALF_EDGE: f64 = 0.265;
/// Measured string length per encoder count of the 8 mm pulley, metres.
pub const METRES_PER_PULSE: f64 = 2.924e-5;
/// Amplifier volts per newton of the maxon motor on an 8 mm pulley.
pub const VOLTS_PER_NEWTON: f64 = 0.3653;

/// The corners (as signs) of the first finger's tetrahedron.
pub const FIRST_TETRAHEDRON: [[f64; 3]; 4] = [
    [-1.0, 1.0, 1.0],
    [1.0, 1.0, -1.0],
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, 1.0],
];

/// The other four corners: each corner of the first tetrahedron mirrored through the centre.
pub fn second_tetrahedron() -> [[f64; 3]; 4] {
    FIRST_TETRAHEDRON.map(|c| c.map(|s| -s))
}

/// Four strings from the `corners` of the cube to the point grip `effector`.
pub fn finger_strings(effector: u32, corners: [[f64; 3]; 4]) -> [HapticdString; 4] {
    corners.map(|c| HapticdString {
        effector,
        motor: c.map(|s| s * HALF_EDGE),
        knot: [0.0; 3],
        metres_per_pulse: METRES_PER_PULSE,
        volts_per_newton: VOLTS_PER_NEWTON,
        tension_min: 0.5,
        tension_max: 20.0,
    })
}

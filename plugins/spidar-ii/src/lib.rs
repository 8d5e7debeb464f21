//! SPIDAR-II: thumb and index finger, each a point grip on its own tetrahedron of four motors
//! at alternate corners of a 0.53 m cube; the two tetrahedra are complementary.

use hapticd_plugin_api::{HapticdEffector, HapticdString, MechanismSpec};

/// Half the edge of the SPIDAR frame cube, metres.
const HALF: f64 = 0.265;
/// Measured string length per encoder count of the 8 mm pulley, metres.
const METRES_PER_PULSE: f64 = 2.924e-5;
/// Amplifier volts per newton of the maxon motor on an 8 mm pulley.
const VOLTS_PER_NEWTON: f64 = 0.3653;

fn build() -> MechanismSpec {
    let index = [
        [-1.0, 1.0, 1.0],
        [1.0, 1.0, -1.0],
        [-1.0, -1.0, -1.0],
        [1.0, -1.0, 1.0],
    ];
    // The thumb uses the other four corners: each index corner mirrored through the centre.
    let thumb = index.map(|c| c.map(|s: f64| -s));
    let mut effectors = vec![
        HapticdEffector::new("index", 3),
        HapticdEffector::new("thumb", 3),
    ];
    // Fingers rest 5 cm apart along x while calibrating.
    effectors[0].calibration_position = [0.025, 0.0, 0.0];
    effectors[1].calibration_position = [-0.025, 0.0, 0.0];
    let strings = [index, thumb]
        .iter()
        .zip(0u32..)
        .flat_map(|(corners, effector)| {
            corners.map(|c| HapticdString {
                effector,
                motor: c.map(|s| s * HALF),
                knot: [0.0; 3],
                metres_per_pulse: METRES_PER_PULSE,
                volts_per_newton: VOLTS_PER_NEWTON,
                tension_min: 0.5,
                tension_max: 20.0,
            })
        })
        .collect();
    MechanismSpec {
        lambda: 0.01,
        torque_weight: 1.0,
        effectors,
        strings,
    }
}

hapticd_plugin_api::export_mechanism!(
    name: "spidar-ii",
    description: "SPIDAR-II: two finger caps, 4 strings each, on a 0.53 m cube (2 x 3 DOF)",
    build: build,
);

//! SPIDAR: one point grip held by four strings from alternate corners of a 0.53 m cube
//! (thesis Fig. 3.23 a). Translation only.

use hapticd_plugin_api::{HapticdEffector, HapticdString, MechanismSpec};

/// Half the edge of the SPIDAR frame cube, metres.
const HALF: f64 = 0.265;
/// Measured string length per encoder count of the 8 mm pulley, metres.
const METRES_PER_PULSE: f64 = 2.924e-5;
/// Amplifier volts per newton of the maxon motor on an 8 mm pulley.
const VOLTS_PER_NEWTON: f64 = 0.3653;

fn build() -> MechanismSpec {
    let corners = [
        [-1.0, 1.0, 1.0],
        [1.0, 1.0, -1.0],
        [-1.0, -1.0, -1.0],
        [1.0, -1.0, 1.0],
    ];
    MechanismSpec {
        lambda: 0.01,
        torque_weight: 1.0,
        effectors: vec![HapticdEffector::new("grip", 3)],
        strings: corners
            .iter()
            .map(|c| HapticdString {
                effector: 0,
                motor: c.map(|s| s * HALF),
                knot: [0.0; 3],
                metres_per_pulse: METRES_PER_PULSE,
                volts_per_newton: VOLTS_PER_NEWTON,
                tension_min: 0.5,
                tension_max: 20.0,
            })
            .collect(),
    }
}

hapticd_plugin_api::export_mechanism!(
    name: "spidar",
    description: "SPIDAR: 4 strings from a 0.53 m cube to one point grip (3 DOF)",
    build: build,
);

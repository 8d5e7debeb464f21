//! SPIDAR: one point grip held by four strings from alternate corners of a 0.53 m cube
//! (thesis Fig. 3.23 a). Translation only.

use hapticd_plugin_api::{HapticdEffector, MechanismSpec};
use hapticd_spidar_cube::{FIRST_TETRAHEDRON, finger_strings};

fn build() -> MechanismSpec {
    MechanismSpec {
        lambda: 0.01,
        torque_weight: 1.0,
        effectors: vec![HapticdEffector::new("grip", 3)],
        strings: finger_strings(0, FIRST_TETRAHEDRON).to_vec(),
    }
}

hapticd_plugin_api::export_mechanism!(
    name: "spidar",
    description: "SPIDAR: 4 strings from a 0.53 m cube to one point grip (3 DOF)",
    build: build,
);

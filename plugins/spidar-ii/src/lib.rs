//! SPIDAR-II: thumb and index finger, each a point grip on its own tetrahedron of four motors
//! at alternate corners of a 0.53 m cube; the two tetrahedra are complementary.

use hapticd_plugin_api::{HapticdEffector, MechanismSpec};
use hapticd_spidar_cube::{FIRST_TETRAHEDRON, finger_strings, second_tetrahedron};

fn build() -> MechanismSpec {
    let mut effectors = vec![
        HapticdEffector::new("index", 3),
        HapticdEffector::new("thumb", 3),
    ];
    // Fingers rest 5 cm apart along x while calibrating.
    effectors[0].calibration_position = [0.025, 0.0, 0.0];
    effectors[1].calibration_position = [-0.025, 0.0, 0.0];
    let mut strings = finger_strings(0, FIRST_TETRAHEDRON).to_vec();
    strings.extend(finger_strings(1, second_tetrahedron()));
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

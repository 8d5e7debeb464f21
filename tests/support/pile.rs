//! Rapier scene files of many bodies, for the benchmarks of the multi-rate engine: boxes and
//! balls (alternately, 2 cm across) in a cube-shaped lattice that falls into a pile on a
//! floor, or in one layer on the floor.

use std::fmt::Write as _;

/// Bodies 2 cm across, this far apart, metres.
const SPACING: f64 = 0.03;

/// A scene of `n` boxes and balls at `rate` Hz: stacked in a lattice `layers` deep (0: as
/// cube-shaped as `n` allows) with its lowest layer resting on the floor's top at y = −0.03
/// (the desk height of the shipped scenes).
pub fn scene(n: usize, rate: f64, layers: usize) -> String {
    let layers = if layers == 0 {
        (n as f64).cbrt().ceil() as usize
    } else {
        layers
    };
    let side = ((n as f64 / layers as f64).sqrt().ceil() as usize).max(1);
    let width = side as f64 * SPACING + 0.2;
    let mut text = format!(
        "name: pile-{n}\nengine: rapier\nrate: {rate}\n\
         material: {{ static_friction: 0.5, friction: 0.5 }}\nbodies:\n  \
         - {{ name: floor, box: [{width}, 0.1, {width}], position: [0, -0.08, 0], fixed: true }}\n"
    );
    for k in 0..n {
        let (layer, cell) = (k / (side * side), k % (side * side));
        let at = [
            (cell % side) as f64 * SPACING,
            -0.02 + layer as f64 * SPACING,
            (cell / side) as f64 * SPACING,
        ];
        let shape = if k % 2 == 0 {
            "box: [0.02, 0.02, 0.02]"
        } else {
            "sphere: 0.01"
        };
        let _ = writeln!(
            text,
            "  - {{ {shape}, position: [{:.3}, {:.3}, {:.3}], density: 1000 }}",
            at[0] - side as f64 * SPACING / 2.0,
            at[1],
            at[2] - side as f64 * SPACING / 2.0
        );
    }
    text.push_str("pointer:\n  sphere: 0.005\n");
    text
}

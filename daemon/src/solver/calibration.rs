//! From encoder counts to string lengths, and the calibration that anchors them.
//!
//! Encoders are incremental, so a count means nothing until the grip has been held at a
//! known pose: calibration then sets each string's offset so that its length equals the
//! distance from motor to knot at that pose (thesis 3.3.1).

use crate::mechanism::{Mechanism, StringSpec};

/// Length of string `s` of `mechanism` at its effector's calibration pose.
fn calibration_length(mechanism: &Mechanism, s: &StringSpec) -> f64 {
    let pose = &mechanism.effectors[s.effector].calibration;
    (s.motor - pose.transform_point(s.knot)).length()
}

/// Length of every string at its effector's calibration pose, in mechanism string order.
pub fn calibration_lengths(mechanism: &Mechanism) -> Vec<f64> {
    mechanism
        .strings
        .iter()
        .map(|s| calibration_length(mechanism, s))
        .collect()
}

/// Offsets that make `counts`, read with the grip at the calibration pose, give the
/// calibration lengths: offsetᵢ = lᵢ − countsᵢ · metres_per_pulseᵢ.
pub fn offsets(mechanism: &Mechanism, counts: &[i64]) -> Vec<f64> {
    let mut out = vec![0.0; mechanism.strings.len()];
    offsets_into(mechanism, counts, &mut out);
    out
}

/// [`offsets`] into `out`, without allocating.
pub fn offsets_into(mechanism: &Mechanism, counts: &[i64], out: &mut [f64]) {
    for ((o, s), &count) in out.iter_mut().zip(&mechanism.strings).zip(counts) {
        *o = calibration_length(mechanism, s) - count as f64 * s.metres_per_pulse;
    }
}

/// Lengths from counts: lᵢ = offsetᵢ + countsᵢ · metres_per_pulseᵢ (allocation-free).
pub fn lengths_from_counts(
    strings: &[StringSpec],
    offsets: &[f64],
    counts: &[i64],
    out: &mut [f64],
) {
    for (((l, s), &offset), &count) in out.iter_mut().zip(strings).zip(offsets).zip(counts) {
        *l = offset + count as f64 * s.metres_per_pulse;
    }
}

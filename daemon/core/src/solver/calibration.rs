//! From encoder counts to string lengths, and the calibration that anchors them.
//!
//! Encoders are incremental, so a count means nothing until the grip has been held at a
//! known pose: calibration then sets each string's offset so that its length equals the
//! distance from motor to knot at that pose (thesis 3.3.1). Both directions work on slices
//! in the mechanism's string order and never allocate.

/// Offsets that make `counts`, read with the grip at the calibration pose, give the
/// `calibration_lengths`: offsetᵢ = lᵢ − countsᵢ · metres_per_pulseᵢ.
pub fn offsets_into(
    calibration_lengths: &[f64],
    metres_per_pulse: &[f64],
    counts: &[i64],
    out: &mut [f64],
) {
    for (((o, &length), &scale), &count) in out
        .iter_mut()
        .zip(calibration_lengths)
        .zip(metres_per_pulse)
        .zip(counts)
    {
        *o = length - count as f64 * scale;
    }
}

/// Lengths from counts: lᵢ = offsetᵢ + countsᵢ · metres_per_pulseᵢ.
pub fn lengths_from_counts(
    offsets: &[f64],
    metres_per_pulse: &[f64],
    counts: &[i64],
    out: &mut [f64],
) {
    for (((l, &offset), &scale), &count) in out
        .iter_mut()
        .zip(offsets)
        .zip(metres_per_pulse)
        .zip(counts)
    {
        *l = offset + count as f64 * scale;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_at_the_calibration_counts_are_the_calibration_lengths() {
        let (lengths, scale, counts) = ([0.3, 0.25], [1e-5, -2e-5], [1234, -987]);
        let mut offsets = [0.0; 2];
        offsets_into(&lengths, &scale, &counts, &mut offsets);
        let mut back = [0.0; 2];
        lengths_from_counts(&offsets, &scale, &counts, &mut back);
        assert_eq!(back, lengths);
        // 100 counts later the string is 100 × metres_per_pulse longer.
        lengths_from_counts(&offsets, &scale, &[1334, -887], &mut back);
        assert!((back[0] - 0.301).abs() < 1e-12 && (back[1] - 0.248).abs() < 1e-12);
    }
}

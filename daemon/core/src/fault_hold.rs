//! Hysteresis for a fault whose source may come and go: a scene that fails, then renders well
//! for a tick, then fails again (a world too slow for its rate is fresh for a few ticks after
//! each of its late steps) must hold the device in one fault, not flip it every step.

/// How long a scene must render well after failing before the forces come back, seconds:
/// longer than the gaps of a world on and off its rate, shorter than a person notices.
pub const SCENE_RECOVERY: f64 = 0.25;

/// [rt] A fault that holds until its source has been good for a while (no allocation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultHold {
    /// Good this long, seconds, ends the fault.
    recovery: f64,
    failing: bool,
    /// Time good since the last failure, seconds.
    good_for: f64,
}

impl FaultHold {
    /// A hold that trusts its source again after `recovery` seconds of good ticks, not
    /// failing to begin with.
    pub const fn new(recovery: f64) -> Self {
        Self {
            recovery,
            failing: false,
            good_for: 0.0,
        }
    }

    /// [rt] Whether the source is to be trusted after a tick of `dt` seconds in which it was
    /// `ok`: not while it fails, nor until it has been ok for the recovery time since.
    pub fn update(&mut self, ok: bool, dt: f64) -> bool {
        if !ok {
            (self.failing, self.good_for) = (true, 0.0);
        } else if self.failing {
            self.good_for += dt;
            // Within rounding of the recovery time: a sum of ticks is not exact.
            self.failing = self.good_for < self.recovery - 1e-9;
        }
        !self.failing
    }

    /// [rt] Trust the source at once again (a fault reset by hand, a new scene).
    pub fn clear(&mut self) {
        (self.failing, self.good_for) = (false, 0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failure_holds_until_the_source_is_good_for_the_recovery_time() {
        let mut hold = FaultHold::new(0.25);
        assert!(hold.update(true, 1e-3));
        assert!(!hold.update(false, 1e-3));
        for tick in 1..250 {
            assert!(!hold.update(true, 1e-3), "tick {tick}");
        }
        assert!(hold.update(true, 1e-3), "250 good ticks of 1 ms");
        assert!(hold.update(true, 1e-3));
    }

    #[test]
    fn a_source_that_fails_again_starts_the_wait_over() {
        let mut hold = FaultHold::new(0.25);
        hold.update(false, 1e-3);
        // Good for 3 ms after every 37 ms failed, a hundred times: one long fault.
        for _ in 0..100 {
            for _ in 0..3 {
                assert!(!hold.update(true, 1e-3));
            }
            for _ in 0..37 {
                assert!(!hold.update(false, 1e-3));
            }
        }
        for _ in 0..249 {
            assert!(!hold.update(true, 1e-3));
        }
        assert!(hold.update(true, 1e-3));
    }

    #[test]
    fn a_cleared_hold_trusts_at_once() {
        let mut hold = FaultHold::new(SCENE_RECOVERY);
        hold.update(false, 1e-3);
        hold.clear();
        assert!(hold.update(true, 1e-3));
        assert!(!hold.update(false, 1e-3));
    }
}

//! The last stage before the motors: force and torque limits, the NaN guard, and the ramp
//! that takes forces to zero within a few ticks of any fault (and back up gently after).

use crate::kinematics::{Wrench, clamp_length};

/// Limits and ramp times of one effector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyLimits {
    /// Largest force magnitude, newtons.
    pub max_force: f64,
    /// Largest torque magnitude, newton-metres.
    pub max_torque: f64,
    /// Time to ramp from full force to zero on a fault, seconds.
    pub fault_ramp: f64,
    /// Time to ramp back up once healthy, seconds.
    pub resume_ramp: f64,
}

impl Default for SafetyLimits {
    fn default() -> Self {
        Self {
            max_force: 10.0,
            max_torque: 0.3,
            fault_ramp: 0.005,
            resume_ramp: 0.2,
        }
    }
}

/// Applies [`SafetyLimits`] to one effector's wrench, tick by tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyGuard {
    limits: SafetyLimits,
    gain: f64,
    last_good: Wrench,
}

impl SafetyGuard {
    /// A guard starting at zero gain (forces ramp up from nothing).
    pub fn new(limits: SafetyLimits) -> Self {
        Self {
            limits,
            gain: 0.0,
            last_good: Wrench::ZERO,
        }
    }

    /// The limits in force.
    pub fn limits(&self) -> &SafetyLimits {
        &self.limits
    }

    /// Change the limits (takes effect at the next tick).
    pub fn set_limits(&mut self, limits: SafetyLimits) {
        self.limits = limits;
    }

    /// Current gain: 1 healthy, 0 fully faulted, in between while ramping.
    pub fn gain(&self) -> f64 {
        self.gain
    }

    /// Turn the requested `wrench` into the one to display. `healthy` is
    /// false on any fault; a non-finite wrench is a fault too, and the last finite one is
    /// ramped down instead. Returns whether the wrench was finite.
    pub fn apply(&mut self, wrench: &mut Wrench, healthy: bool, dt: f64) -> bool {
        let finite = wrench.is_finite();
        if finite {
            wrench.force = clamp_length(wrench.force, self.limits.max_force);
            wrench.torque = clamp_length(wrench.torque, self.limits.max_torque);
            self.last_good = *wrench;
        } else {
            *wrench = self.last_good;
        }
        if healthy && finite {
            self.gain = (self.gain + dt / self.limits.resume_ramp).min(1.0);
        } else {
            self.gain -= dt / self.limits.fault_ramp;
            // Rounding must not leave a sliver of force on a faulted device.
            if self.gain < 1e-9 {
                self.gain = 0.0;
            }
        }
        *wrench = *wrench * self.gain;
        finite
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn healthy_guard() -> SafetyGuard {
        let mut g = SafetyGuard::new(SafetyLimits::default());
        for _ in 0..1000 {
            g.apply(&mut Wrench::default(), true, 1e-3);
        }
        g
    }

    #[test]
    fn forces_above_the_limit_are_clamped() {
        let mut g = healthy_guard();
        let mut w = Wrench::from_array([30.0, 40.0, 0.0, 0.0, 0.0, 1.0]);
        g.apply(&mut w, true, 1e-3);
        assert!((w.force - DVec3::new(6.0, 8.0, 0.0)).length() < 1e-12);
        assert!((w.torque.z - 0.3).abs() < 1e-12);
    }

    #[test]
    fn huge_finite_forces_are_clamped_not_lost_to_overflow() {
        let mut g = healthy_guard();
        for huge in [1e160, 1e300, f64::MAX] {
            let mut w = Wrench::from_array([0.0, huge, 0.0, -huge, 0.0, huge]);
            assert!(g.apply(&mut w, true, 1e-3));
            assert!(
                (w.force - DVec3::new(0.0, 10.0, 0.0)).length() < 1e-9,
                "{w:?}"
            );
            assert!((w.torque.length() - 0.3).abs() < 1e-12, "{w:?}");
        }
    }

    #[test]
    fn a_fault_ramps_to_zero_within_the_ramp_time() {
        let mut g = healthy_guard();
        let mut previous = 5.0;
        for tick in 0..10 {
            let mut w = Wrench::force(DVec3::X * 5.0);
            g.apply(&mut w, false, 1e-3);
            assert!(w.force.x <= previous);
            previous = w.force.x;
            if tick >= 4 {
                assert_eq!(w.force.x, 0.0, "tick {tick}");
            }
        }
    }

    #[test]
    fn nan_is_a_fault_and_never_reaches_the_motors() {
        let mut g = healthy_guard();
        g.apply(&mut Wrench::force(DVec3::X * 2.0), true, 1e-3);
        let mut w = Wrench::force(DVec3::new(f64::NAN, 0.0, 0.0));
        assert!(!g.apply(&mut w, true, 1e-3));
        assert!(w.is_finite() && w.force.x < 2.0);
    }
}

//! Time-domain passivity observer and controller (Hannaford & Ryu, 2002) on one port.
//!
//! The observer sums the energy the user has put into the virtual world through this port,
//! E = Σ −f·v·T (f: force on the hand, v: grip velocity). A passive world never returns more
//! than it received, so E stays non-negative; when a stiff contact, a delay or a sampling
//! artefact would make it negative, the controller adds just enough damping this tick to
//! dissipate the excess. It is a safety net under every rendering method, not a substitute
//! for choosing stable gains.

use glam::DVec3;

/// How hard the controller may act.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassivityLimits {
    /// Most damping added in one tick, N·s/m (0: the controller only observes).
    pub max_damping: f64,
    /// Most dissipated energy that may be returned later, joules; a contact holds more, see
    /// [`STORE`].
    pub max_credit: f64,
}

impl PassivityLimits {
    /// Observe only: no damping is ever added.
    pub const OFF: PassivityLimits = PassivityLimits {
        max_damping: 0.0,
        max_credit: 0.0,
    };
}

impl Default for PassivityLimits {
    fn default() -> Self {
        Self {
            max_damping: 200.0,
            max_credit: 0.05,
        }
    }
}

/// How deep a contact may store what the hand pressed into it, metres: the credit grows by
/// this times the force displayed. A proxy pressed 2 cm past a floor at MaxForce holds a fifth
/// of a joule, all of which may come back as the hand draws out; capped at the bare credit,
/// the controller braked the way out by fits and starts.
pub const STORE: f64 = 0.02;

/// Passivity observer and controller of one effector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassivityController {
    energy: f64,
    limits: PassivityLimits,
    dissipated: f64,
}

impl PassivityController {
    /// A controller acting within `limits`.
    pub fn new(limits: PassivityLimits) -> Self {
        Self {
            energy: 0.0,
            limits,
            dissipated: 0.0,
        }
    }

    /// Observed energy balance, joules (non-negative when passive).
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// Total energy the controller has removed, joules.
    pub fn dissipated(&self) -> f64 {
        self.dissipated
    }

    /// Forget the balance (after a fault, a scene change).
    pub fn reset(&mut self) {
        self.energy = 0.0;
    }

    /// The force to display instead of `force`, for grip velocity `velocity` over `dt`.
    pub fn filter(&mut self, force: DVec3, velocity: DVec3, dt: f64) -> DVec3 {
        self.energy -= force.dot(velocity) * dt;
        self.energy = self
            .energy
            .min(self.limits.max_credit + STORE * force.length());
        let speed2 = velocity.length_squared();
        if self.energy >= 0.0 || speed2 < 1e-12 {
            return force;
        }
        let alpha = (-self.energy / (dt * speed2)).min(self.limits.max_damping);
        let removed = alpha * speed2 * dt;
        self.energy += removed;
        self.dissipated += removed;
        force - alpha * velocity
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_damper_passes_unchanged() {
        let mut pc = PassivityController::new(PassivityLimits {
            max_damping: 100.0,
            max_credit: 1.0,
        });
        for k in 0..1000 {
            let v = DVec3::new((k as f64 * 0.01).sin(), 0.0, 0.0);
            let f = -5.0 * v;
            assert_eq!(pc.filter(f, v, 1e-3), f);
        }
        assert!(pc.energy() > 0.0 && pc.dissipated() == 0.0);
    }

    #[test]
    fn an_active_element_is_made_passive() {
        // A negative damper pushes the hand along its motion: energy out of nowhere.
        let mut pc = PassivityController::new(PassivityLimits {
            max_damping: 1e6,
            max_credit: 1.0,
        });
        let mut net = 0.0;
        for k in 0..1000 {
            let v = DVec3::new(0.1 + 0.05 * (k as f64 * 0.02).sin(), 0.0, 0.0);
            let f = pc.filter(3.0 * v, v, 1e-3);
            net -= f.dot(v) * 1e-3;
            assert!(net >= -1e-12, "the world gave back {net} J");
        }
        assert!(pc.dissipated() > 0.0);
    }

    #[test]
    fn a_deep_press_gives_back_all_it_was_given_and_the_credit_shrinks_with_the_force() {
        // A stiff floor the hand presses 20 mm into at 2 kN/m and draws back out of: all
        // of the ½ k d² = 0.4 J comes back unchanged, far over the credit between contacts.
        let mut pc = PassivityController::new(PassivityLimits::default());
        let (k, dt, v) = (2000.0, 1e-3, 0.02);
        for tick in 0..2000 {
            let (depth, velocity) = if tick < 1000 {
                (v * (tick + 1) as f64 * dt, DVec3::new(0.0, -v, 0.0))
            } else {
                (v * (2000 - tick - 1) as f64 * dt, DVec3::new(0.0, v, 0.0))
            };
            let f = DVec3::new(0.0, k * depth, 0.0);
            assert_eq!(pc.filter(f, velocity, dt), f, "tick {tick}");
        }
        assert_eq!(pc.dissipated(), 0.0);
        // Out of the floor, what is left is capped again.
        pc.energy = 1.0;
        pc.filter(DVec3::ZERO, DVec3::new(0.0, v, 0.0), dt);
        assert_eq!(pc.energy(), PassivityLimits::default().max_credit);
    }
}

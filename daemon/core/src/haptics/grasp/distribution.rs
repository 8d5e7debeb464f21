//! Sharing the resultant among the fingers (thesis 4.5.3, 4.6.3).
//!
//! The fingers must give the object the resultant (F, N). Finger i may add to its push a
//! share kᵢ ≥ 0 along nᵢ, the direction in which it presses on the object at rᵢ: a share
//! against the press would loosen that finger's grip (requirement 4). Minimise (4.17)
//!
//! ```text
//! P = |F − Σ kᵢnᵢ|² + γ1 |N − Σ rᵢ × kᵢnᵢ|² + γ2 Σ (kᵢ − k·gᵢ)² + γ3 (Σ kᵢ² + k²)
//! ```
//!
//! over kᵢ ≥ 0 and k ≥ 0: the sum close to the resultant (requirement 1), shares in
//! proportion to the grip forces with a common factor k (requirement 2), and γ3 > 0 makes P
//! strictly convex, so the shares change continuously with the fingers and the load
//! (requirement 3).
//!
//! Taken literally, gᵢ = |f_gi| asks every finger for a share in proportion to its grip, the
//! finger in front of a push too: two fingers squeezing a box from opposite sides would both
//! press harder, by several newtons, to give it one. 4.5.3 shares the resultant only among
//! the fingers whose grip points the way of the push, so here gᵢ = |f_gi|·max(0, nᵢ·F̂):
//! a finger's grip counts as far as it presses along the resultant, which keeps P continuous.
//! The weights:
//!
//! - γ1 = 1/L², L the object's size, so a moment error counts like the force error that
//!   would cause it at the object's edge;
//! - γ2 = 0.01: a pull toward even shares weak enough that the sum stays within about 1 % of
//!   the resultant when one finger must carry it all (as when a grasp is shaken sideways);
//! - γ3 = 10⁻⁴: only to keep P strictly convex.
//!
//! What the shares do not deliver (the residual) goes back to the shell, whose springs then
//! carry it (4.6.3): the weight of an object held between two fingers, which no push along
//! the normals can give, is carried that way, by friction.

use glam::DVec3;

use super::MAX_FINGERS;
use crate::solver::box_qp::{self, ActiveSet, BoxQp, MAX_VARS, Matrix, Vector};

/// γ2 of (4.17).
pub const EVEN_SHARES_WEIGHT: f64 = 0.01;

/// γ3 of (4.17).
pub const REGULARISATION_WEIGHT: f64 = 1e-4;

/// A resultant this small (newtons) has no direction to speak of: the alignment of every
/// finger fades to zero with it, continuously.
const ALIGNMENT_FLOOR: f64 = 1e-3;

/// Largest share (newtons) or common factor the solver considers.
const SHARE_LIMIT: f64 = 1e3;

// One variable per finger, and the common factor k.
const _: () = assert!(MAX_FINGERS < MAX_VARS);

/// Where a finger presses on the object and how hard it grips.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Press {
    /// The contact point relative to the object's centre, metres.
    pub point: DVec3,
    /// Unit direction in which the finger presses on the object (the inward normal).
    pub direction: DVec3,
    /// Its grip force, newtons (≥ 0).
    pub grip: f64,
}

/// The shares, kept between calls to warm-start the solver.
#[derive(Debug, Clone, Copy, Default)]
pub struct Distribution {
    state: ActiveSet,
}

impl Distribution {
    /// [rt] Each finger's share kᵢ of the resultant (`force`, `torque` about the centre) into
    /// `shares` (same order as `presses`); `size` is L of γ1. Allocation-free.
    pub fn share(
        &mut self,
        presses: &[Press],
        force: DVec3,
        torque: DVec3,
        size: f64,
        shares: &mut [f64],
    ) {
        let n = presses.len().min(MAX_FINGERS).min(shares.len());
        let moment_weight = 1.0 / (size * size).max(1e-6);
        let mut q: Matrix = [[0.0; MAX_VARS]; MAX_VARS];
        let mut c: Vector = [0.0; MAX_VARS];
        let lower: Vector = [0.0; MAX_VARS];
        // Finite, so the solver's tolerances stay scaled to the problem: no finger share comes
        // near a kilonewton (the safety limits cap forces at 50 N).
        let upper: Vector = [SHARE_LIMIT; MAX_VARS];
        let k = n;
        // How far each finger presses along the resultant (4.5.3): only those count.
        let along = force / (force.length() + ALIGNMENT_FLOOR);
        let mut grips = [0.0; MAX_FINGERS];
        for (g, p) in grips.iter_mut().zip(&presses[..n]) {
            *g = p.grip * p.direction.dot(along).max(0.0);
        }
        for i in 0..n {
            let (ni, bi) = (
                presses[i].direction,
                presses[i].point.cross(presses[i].direction),
            );
            for j in 0..n {
                let (nj, bj) = (
                    presses[j].direction,
                    presses[j].point.cross(presses[j].direction),
                );
                q[i][j] = ni.dot(nj) + moment_weight * bi.dot(bj);
            }
            q[i][i] += EVEN_SHARES_WEIGHT + REGULARISATION_WEIGHT;
            q[i][k] = -EVEN_SHARES_WEIGHT * grips[i];
            q[k][i] = q[i][k];
            q[k][k] += EVEN_SHARES_WEIGHT * grips[i] * grips[i];
            c[i] = -(force.dot(ni) + moment_weight * torque.dot(bi));
        }
        q[k][k] += REGULARISATION_WEIGHT;
        let problem = BoxQp {
            q: &q,
            c: &c,
            lower: &lower,
            upper: &upper,
            n: n + 1,
        };
        box_qp::solve(&problem, &mut self.state);
        shares[..n].copy_from_slice(&self.state.x()[..n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_fingers(grip: f64) -> [Press; 2] {
        [
            Press {
                point: DVec3::new(-0.03, 0.0, 0.0),
                direction: DVec3::X,
                grip,
            },
            Press {
                point: DVec3::new(0.03, 0.0, 0.0),
                direction: -DVec3::X,
                grip,
            },
        ]
    }

    #[test]
    fn a_sideways_resultant_goes_to_the_finger_behind_the_object() {
        let mut d = Distribution::default();
        let mut shares = [0.0; 2];
        d.share(
            &two_fingers(2.0),
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::ZERO,
            0.06,
            &mut shares,
        );
        assert_eq!(shares[1], 0.0);
        assert!((shares[0] - 3.0).abs() < 0.03, "{shares:?}");
        // Uneven grips do not make the finger in front press too.
        let mut uneven = two_fingers(1.9);
        uneven[1].grip = 2.1;
        d.share(
            &uneven,
            DVec3::new(-3.0, 0.0, 0.0),
            DVec3::ZERO,
            0.06,
            &mut shares,
        );
        assert!(
            shares[0] < 1e-9 && (shares[1] - 3.0).abs() < 0.03,
            "{shares:?}"
        );
        d.share(
            &two_fingers(2.0),
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::ZERO,
            0.06,
            &mut shares,
        );
        assert_eq!(shares[0], 0.0);
        assert!((shares[1] - 1.0).abs() < 0.01, "{shares:?}");
    }

    #[test]
    fn weight_along_no_normal_is_left_to_the_shell() {
        let mut d = Distribution::default();
        let mut shares = [0.0; 2];
        d.share(
            &two_fingers(2.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::ZERO,
            0.06,
            &mut shares,
        );
        assert!(shares.iter().all(|&s| s.abs() < 1e-9), "{shares:?}");
    }
}

//! Grip pose from measured string lengths (thesis 3.4): iterate Δr = −M⁺Δl.
//!
//! Solved as damped Gauss–Newton, (W Wᵀ + σ·diag(W Wᵀ)) Δr = W (l(r) − l_measured), since the
//! length Jacobian is −Wᵀ. The damping is relative to the diagonal so that translation (m)
//! and rotation (rad) are treated alike whatever the grip size. Warm-started from the last
//! pose: at 1 kHz a hand moves at most a few millimetres per tick, so two iterations reach
//! the exact pose (thesis 3.4.7).

use glam::{DQuat, DVec3};

use super::geometry::{EffectorKinematics, StringGeometry};
use super::linalg::{ldlt_factor, ldlt_solve};
use crate::kinematics::{Dof, Pose};

/// Relative Levenberg–Marquardt damping: only guards against a singular normal matrix.
const DAMPING: f64 = 1e-9;

/// Result of one pose solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseEstimate {
    /// The solved pose.
    pub pose: Pose,
    /// Root-mean-square length residual at that pose, metres.
    pub residual: f64,
    /// Iterations taken (fewer than asked when a step vanished).
    pub iterations: usize,
}

/// Warm-started pose solver of one effector.
#[derive(Debug, Clone)]
pub struct PoseSolver {
    kinematics: EffectorKinematics,
    pose: Pose,
    geometry: StringGeometry,
}

impl PoseSolver {
    /// A solver starting from `start`.
    pub fn new(kinematics: EffectorKinematics, start: Pose) -> Self {
        let geometry = StringGeometry::at(&kinematics, &start);
        Self {
            kinematics,
            pose: start,
            geometry,
        }
    }

    /// The kinematics solved for.
    pub fn kinematics(&self) -> &EffectorKinematics {
        &self.kinematics
    }

    /// The last solved pose.
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// Geometry at the last solved pose, ready for the tension solve of the same tick.
    pub fn geometry(&self) -> &StringGeometry {
        &self.geometry
    }

    /// Restart from `pose` (e.g. after calibration).
    pub fn reset(&mut self, pose: Pose) {
        self.pose = pose;
        self.geometry.evaluate(&self.kinematics, &pose);
    }

    /// Update the pose to match `measured` lengths (one per string, in effector order) with at
    /// most `iterations` Gauss–Newton steps.
    #[inline]
    pub fn solve(&mut self, measured: &[f64], iterations: usize) -> PoseEstimate {
        let taken = match self.kinematics.dof() {
            Dof::Three => self.iterate::<3>(measured, iterations),
            Dof::Six => self.iterate::<6>(measured, iterations),
        };
        let count = self.geometry.count();
        let squared: f64 = self
            .geometry
            .lengths()
            .iter()
            .zip(measured)
            .map(|(l, m)| (l - m) * (l - m))
            .sum();
        PoseEstimate {
            pose: self.pose,
            residual: (squared / count as f64).sqrt(),
            iterations: taken,
        }
    }

    /// Gauss–Newton steps for an `N`-DOF effector; returns how many were taken.
    fn iterate<const N: usize>(&mut self, measured: &[f64], iterations: usize) -> usize {
        for taken in 0..iterations {
            let mut a = self.geometry.normal_matrix::<N>();
            let mut step = [0.0; N];
            for (i, (&l, &m)) in self.geometry.lengths().iter().zip(measured).enumerate() {
                let column = self.geometry.column(i);
                for (s, c) in step.iter_mut().zip(column) {
                    *s += c * (l - m);
                }
            }
            for (i, row) in a.iter_mut().enumerate() {
                row[i] *= 1.0 + DAMPING;
            }
            if !ldlt_factor(&mut a, N, 0.0) {
                return taken;
            }
            ldlt_solve(&a, N, &mut step);
            self.pose.position += DVec3::new(step[0], step[1], step[2]);
            if N == 6 {
                // normalize(1 + ½δθ) agrees with exp(½δθ) to second order, which keeps
                // Gauss–Newton quadratic, without the sine and cosine.
                let half = DVec3::new(step[3], step[4], step[5]) * 0.5;
                let rotation = DQuat::from_xyzw(half.x, half.y, half.z, 1.0);
                self.pose.orientation = (rotation * self.pose.orientation).normalize();
            }
            self.geometry.evaluate(&self.kinematics, &self.pose);
            if step.iter().all(|s| s.abs() < 1e-15) {
                return taken + 1;
            }
        }
        iterations
    }
}

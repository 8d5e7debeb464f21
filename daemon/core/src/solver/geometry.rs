//! String geometry at a pose: lengths lᵢ = |qᵢ − pᵢ| (eq. 3.4) and the string matrix W
//! (eq. 3.14, 3.18, 3.19) whose column wᵢ is the wrench of unit tension in string i.
//!
//! The same matrix serves both directions of the mechanism: W maps tensions to the wrench
//! on the grip, and −Wᵀ is the Jacobian of the lengths with respect to a pose change
//! (translation, then a small rotation in world axes), the M of eq. 3.9.

use glam::{DMat3, DVec3};

use crate::kinematics::{Dof, MAX_STRINGS_PER_EFFECTOR, Pose, Wrench};

/// The strings of one effector in fixed-size arrays, for use on the real-time thread.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectorKinematics {
    dof: Dof,
    count: usize,
    motors: [DVec3; MAX_STRINGS_PER_EFFECTOR],
    knots: [DVec3; MAX_STRINGS_PER_EFFECTOR],
}

impl EffectorKinematics {
    /// Kinematics of an effector from its strings' (motor, knot) pairs.
    ///
    /// # Panics
    /// With more than [`MAX_STRINGS_PER_EFFECTOR`] strings (validation refuses those).
    pub fn new(dof: Dof, strings: impl IntoIterator<Item = (DVec3, DVec3)>) -> Self {
        let mut k = Self {
            dof,
            count: 0,
            motors: [DVec3::ZERO; MAX_STRINGS_PER_EFFECTOR],
            knots: [DVec3::ZERO; MAX_STRINGS_PER_EFFECTOR],
        };
        for (motor, knot) in strings {
            assert!(k.count < MAX_STRINGS_PER_EFFECTOR, "too many strings");
            k.motors[k.count] = motor;
            k.knots[k.count] = knot;
            k.count += 1;
        }
        k
    }

    /// Degrees of freedom.
    pub fn dof(&self) -> Dof {
        self.dof
    }

    /// Number of strings.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Motor exit points.
    pub fn motors(&self) -> &[DVec3] {
        &self.motors[..self.count]
    }

    /// Knots in the grip frame.
    pub fn knots(&self) -> &[DVec3] {
        &self.knots[..self.count]
    }

    /// String lengths at `pose`, written to the first [`count`](Self::count) slots of `out`.
    pub fn lengths(&self, pose: &Pose, out: &mut [f64]) {
        for ((l, &m), &k) in out.iter_mut().zip(self.motors()).zip(self.knots()) {
            *l = (m - pose.transform_point(k)).length();
        }
    }
}

/// Lengths and string matrix of one effector at one pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StringGeometry {
    dof: usize,
    count: usize,
    lengths: [f64; MAX_STRINGS_PER_EFFECTOR],
    /// Column i of W: unit direction φᵢ toward the motor, then (for 6 DOF) dᵢ × φᵢ with dᵢ
    /// the lever arm from the grip centre to the knot.
    columns: [[f64; 6]; MAX_STRINGS_PER_EFFECTOR],
}

impl Default for StringGeometry {
    fn default() -> Self {
        Self {
            dof: 3,
            count: 0,
            lengths: [0.0; MAX_STRINGS_PER_EFFECTOR],
            columns: [[0.0; 6]; MAX_STRINGS_PER_EFFECTOR],
        }
    }
}

impl StringGeometry {
    /// Geometry of `kinematics` at `pose`.
    pub fn at(kinematics: &EffectorKinematics, pose: &Pose) -> Self {
        let mut g = Self::default();
        g.evaluate(kinematics, pose);
        g
    }

    /// Recompute for `kinematics` at `pose`.
    pub fn evaluate(&mut self, kinematics: &EffectorKinematics, pose: &Pose) {
        self.dof = kinematics.dof.count();
        self.count = kinematics.count;
        if kinematics.dof == Dof::Three {
            // A point grip has no knot offsets and no torque rows: skip the rotation.
            for i in 0..self.count {
                let span = kinematics.motors[i] - pose.position;
                let length = span.length();
                let phi = span * length.recip();
                self.lengths[i] = length;
                self.columns[i][..3].copy_from_slice(&phi.to_array());
            }
            return;
        }
        // One matrix per pose: cheaper than rotating each knot by the quaternion.
        let rotation = DMat3::from_quat(pose.orientation);
        for i in 0..self.count {
            let arm = rotation * kinematics.knots[i];
            let span = kinematics.motors[i] - (pose.position + arm);
            let length = span.length();
            let phi = span * length.recip();
            let torque = arm.cross(phi);
            self.lengths[i] = length;
            self.columns[i] = [phi.x, phi.y, phi.z, torque.x, torque.y, torque.z];
        }
    }

    /// Number of wrench (and pose) components: 3 or 6.
    pub fn dof(&self) -> usize {
        self.dof
    }

    /// Number of strings.
    pub fn count(&self) -> usize {
        self.count
    }

    /// String lengths.
    pub fn lengths(&self) -> &[f64] {
        &self.lengths[..self.count]
    }

    /// Column i of W (its first [`dof`](Self::dof) entries are meaningful).
    pub fn column(&self, i: usize) -> &[f64; 6] {
        &self.columns[i]
    }

    /// The wrench W τ produced by `tensions` (no torque for 3 DOF).
    pub fn wrench(&self, tensions: &[f64]) -> Wrench {
        let mut w = [0.0; 6];
        for (column, &t) in self.columns[..self.count].iter().zip(tensions) {
            for (wr, c) in w.iter_mut().zip(column) {
                *wr += c * t;
            }
        }
        Wrench::from_array(w)
    }

    /// W Wᵀ, the Gauss–Newton normal matrix of the pose problem, for `N` = [`dof`](Self::dof)
    /// (a compile-time size lets the small loops unroll).
    pub fn normal_matrix<const N: usize>(&self) -> [[f64; N]; N] {
        debug_assert_eq!(N, self.dof);
        let mut a = [[0.0; N]; N];
        for column in &self.columns[..self.count] {
            for r in 0..N {
                for c in 0..=r {
                    a[r][c] += column[r] * column[c];
                }
            }
        }
        for r in 0..N {
            for c in r + 1..N {
                a[r][c] = a[c][r];
            }
        }
        a
    }

    /// Whether small pose changes are observable from the lengths: W has full row rank,
    /// judged scale-free on W Wᵀ normalised to unit diagonal.
    pub fn pose_observable(&self) -> bool {
        match self.dof {
            3 => self.observable::<3>(),
            _ => self.observable::<6>(),
        }
    }

    fn observable<const N: usize>(&self) -> bool {
        let mut a = self.normal_matrix::<N>();
        let n = N;
        let mut scale = [0.0; N];
        for i in 0..n {
            if a[i][i].is_nan() || a[i][i] <= 0.0 {
                return false;
            }
            scale[i] = 1.0 / a[i][i].sqrt();
        }
        for r in 0..n {
            for c in 0..n {
                a[r][c] *= scale[r] * scale[c];
            }
        }
        super::linalg::ldlt_factor(&mut a, n, 1e-10)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    /// A tetrahedral 6-DOF test rig: eight strings from cube corners to a grip of radius 2 cm.
    fn rig() -> EffectorKinematics {
        let corners = [-1.0f64, 1.0];
        let mut strings = Vec::new();
        for &x in &corners {
            for &y in &corners {
                for &z in &corners {
                    let motor = DVec3::new(x, y, z) * 0.2;
                    strings.push((motor, DVec3::new(y, z, x) * 0.02));
                }
            }
        }
        EffectorKinematics::new(Dof::Six, strings)
    }

    #[test]
    fn jacobian_is_minus_w_transpose() {
        let k = rig();
        let pose = Pose {
            position: DVec3::new(0.01, -0.02, 0.015),
            orientation: DQuat::from_euler(glam::EulerRot::XYZ, 0.1, -0.2, 0.3),
        };
        let g = StringGeometry::at(&k, &pose);
        let h = 1e-7;
        for axis in 0..6 {
            let mut delta = [0.0; 6];
            delta[axis] = h;
            let moved = Pose {
                position: pose.position + DVec3::new(delta[0], delta[1], delta[2]),
                orientation: DQuat::from_scaled_axis(DVec3::new(delta[3], delta[4], delta[5]))
                    * pose.orientation,
            };
            let mut l = [0.0; MAX_STRINGS_PER_EFFECTOR];
            k.lengths(&moved, &mut l);
            for i in 0..k.count() {
                let numeric = (l[i] - g.lengths()[i]) / h;
                let analytic = -g.column(i)[axis];
                assert!((numeric - analytic).abs() < 1e-5, "axis {axis} string {i}");
            }
        }
    }

    #[test]
    fn wrench_of_unit_tension_is_the_column() {
        let k = rig();
        let g = StringGeometry::at(&k, &Pose::IDENTITY);
        let mut t = [0.0; 8];
        t[3] = 1.0;
        assert_eq!(g.wrench(&t).to_array(), *g.column(3));
        assert!(g.pose_observable());
    }
}

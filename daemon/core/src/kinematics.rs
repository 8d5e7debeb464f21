//! The vocabulary of poses shared by mechanisms, solvers, scenes and the loop: a grip's
//! degrees of freedom, its pose, and the size limits that fix every real-time buffer.

use glam::{DQuat, DVec3};

/// Most strings one end effector may have; fixes the size of every real-time buffer.
pub const MAX_STRINGS_PER_EFFECTOR: usize = 16;

/// Degrees of freedom of an end effector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dof {
    /// A point grip (finger cap): position only.
    Three,
    /// A rigid grip: position and orientation.
    Six,
}

impl Dof {
    /// Number of pose (and wrench) components.
    pub const fn count(self) -> usize {
        match self {
            Dof::Three => 3,
            Dof::Six => 6,
        }
    }
}

/// Position and orientation of an end effector, frame-centred metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Grip centre.
    pub position: DVec3,
    /// Grip orientation (identity for point grips).
    pub orientation: DQuat,
}

impl Default for Pose {
    fn default() -> Self {
        Pose::IDENTITY
    }
}

impl Pose {
    /// The frame centre with identity orientation.
    pub const IDENTITY: Pose = Pose {
        position: DVec3::ZERO,
        orientation: DQuat::IDENTITY,
    };

    /// A knot given in the grip frame, in world coordinates.
    pub fn transform_point(&self, knot: DVec3) -> DVec3 {
        self.position + self.orientation * knot
    }
}

/// Most effectors a running device may have (the size of every per-tick record).
pub const MAX_EFFECTORS: usize = 4;

/// A quaternion from the order files, D-Bus and the plugin ABI write it in: `[w, x, y, z]`.
pub fn quat_from_wxyz([w, x, y, z]: [f64; 4]) -> DQuat {
    DQuat::from_xyzw(x, y, z, w)
}

/// A quaternion in the order files, D-Bus and the plugin ABI write it in: `[w, x, y, z]`.
pub fn quat_to_wxyz(q: DQuat) -> [f64; 4] {
    [q.w, q.x, q.y, q.z]
}

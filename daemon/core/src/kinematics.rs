//! The vocabulary of poses shared by mechanisms, solvers, scenes and the loop: a grip's
//! degrees of freedom, its pose, and the size limits that fix every real-time buffer.

use glam::{DQuat, DVec3};
use hapticd_plugin_api::{HapticdBodyPose, HapticdWrench};

/// Most strings one end effector may have; fixes the size of every real-time buffer.
pub const MAX_STRINGS_PER_EFFECTOR: usize = 16;

/// Farthest anything in a scene may be placed from its origin, metres: a room with room to
/// spare, and near enough that positions keep their millimetres.
pub const WORLD_EXTENT: f64 = 1e3;

/// Smallest and largest edge, radius or thickness of a solid in a scene, metres: below the
/// smaller one there is no inertia to integrate nor a surface to feel.
pub const SOLID_SIZES: (f64, f64) = (1e-4, 1e3);

/// The axis a mesh file calls up (a scene's `up:` of a mesh): hapticd's up is y, as glTF's
/// and most modelling tools'; CAD programs and scanners often write z up, and such a file
/// would lie on its side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Up {
    /// y up: the file as it is.
    #[default]
    Y,
    /// z up: the file turned a quarter about x, its z becoming hapticd's y.
    Z,
}

impl Up {
    /// The turn that brings the file's up to hapticd's y.
    pub fn turn(self) -> DQuat {
        match self {
            Up::Y => DQuat::IDENTITY,
            Up::Z => DQuat::from_rotation_x(-std::f64::consts::FRAC_PI_2),
        }
    }
}

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
///
/// ```
/// use glam::{DQuat, DVec3};
/// use hapticd_core::kinematics::Pose;
///
/// let grip = Pose {
///     position: DVec3::new(0.1, 0.0, 0.0),
///     orientation: DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2),
/// };
/// // A knot 1 cm along the grip's x axis sits 1 cm along the world's y axis.
/// let knot = grip.transform_point(DVec3::new(0.01, 0.0, 0.0));
/// assert!((knot - DVec3::new(0.1, 0.01, 0.0)).length() < 1e-15);
/// ```
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

    /// A world point in this frame's coordinates (the inverse of
    /// [`transform_point`](Self::transform_point)).
    pub fn inverse_transform_point(&self, point: DVec3) -> DVec3 {
        self.orientation.inverse() * (point - self.position)
    }
}

/// Most effectors a running device may have (the size of every per-tick record).
pub const MAX_EFFECTORS: usize = 4;

/// A pose from the ABI's (its orientation normalised).
pub fn pose_of(pose: &HapticdBodyPose) -> Pose {
    Pose {
        position: DVec3::from(pose.position),
        orientation: quat_from_wxyz(pose.orientation).normalize(),
    }
}

/// A quaternion from the order files, D-Bus and the plugin ABI write it in: `[w, x, y, z]`.
#[inline]
pub fn quat_from_wxyz([w, x, y, z]: [f64; 4]) -> DQuat {
    DQuat::from_xyzw(x, y, z, w)
}

/// A quaternion in the order files, D-Bus and the plugin ABI write it in: `[w, x, y, z]`.
#[inline]
pub fn quat_to_wxyz(q: DQuat) -> [f64; 4] {
    [q.w, q.x, q.y, q.z]
}

/// The rotation `q` makes as its axis scaled by its angle, the short way round (angle at most
/// π): `q` and `-q` are one rotation, and a relative turn read from two nearby orientations
/// must not come out as nearly a whole turn the other way. Turns under 2e-8 rad, rounding's
/// noise in a relative turn of two equal orientations, read as none.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use hapticd_core::kinematics::rotation_vector;
///
/// let turn = DVec3::new(0.0, 0.0, 0.3);
/// let q = DQuat::from_scaled_axis(turn);
/// assert!((rotation_vector(q) - turn).length() < 1e-15);
/// assert!((rotation_vector(-q) - turn).length() < 1e-15);
/// ```
pub fn rotation_vector(q: DQuat) -> DVec3 {
    if q.w < 0.0 { -q } else { q }.to_scaled_axis()
}

/// A force and a torque: what a scene asks a pointer to feel, what the strings apply to a
/// grip, what a body gets from a contact. For a grip the torque is about its centre.
///
/// ```
/// use glam::DVec3;
/// use hapticd_core::kinematics::Wrench;
///
/// let push = Wrench::force(DVec3::new(0.0, 0.0, 2.0));
/// let both = push + push * 0.5;
/// assert_eq!(both.to_array(), [0.0, 0.0, 3.0, 0.0, 0.0, 0.0]);
/// assert_eq!(Wrench::from_array(both.to_array()), both);
/// assert!(!(push * f64::NAN).is_finite());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Wrench {
    /// Force, newtons.
    pub force: DVec3,
    /// Torque, newton-metres.
    pub torque: DVec3,
}

impl Wrench {
    /// No force, no torque.
    pub const ZERO: Wrench = Wrench {
        force: DVec3::ZERO,
        torque: DVec3::ZERO,
    };

    /// A force alone.
    #[inline]
    pub const fn force(force: DVec3) -> Wrench {
        Wrench {
            force,
            torque: DVec3::ZERO,
        }
    }

    /// From the six components the solvers work on: force, then torque.
    #[inline]
    pub fn from_array(w: [f64; 6]) -> Wrench {
        Wrench {
            force: DVec3::new(w[0], w[1], w[2]),
            torque: DVec3::new(w[3], w[4], w[5]),
        }
    }

    /// The six components the solvers work on: force, then torque.
    #[inline]
    pub fn to_array(&self) -> [f64; 6] {
        let (f, t) = (self.force, self.torque);
        [f.x, f.y, f.z, t.x, t.y, t.z]
    }

    /// Whether every component is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.force.is_finite() && self.torque.is_finite()
    }
}

impl std::ops::Add for Wrench {
    type Output = Wrench;

    #[inline]
    fn add(self, other: Wrench) -> Wrench {
        Wrench {
            force: self.force + other.force,
            torque: self.torque + other.torque,
        }
    }
}

impl std::ops::Mul<f64> for Wrench {
    type Output = Wrench;

    #[inline]
    fn mul(self, scale: f64) -> Wrench {
        Wrench {
            force: self.force * scale,
            torque: self.torque * scale,
        }
    }
}

impl From<Wrench> for HapticdWrench {
    #[inline]
    fn from(w: Wrench) -> Self {
        HapticdWrench {
            force: w.force.to_array(),
            torque: w.torque.to_array(),
        }
    }
}

impl From<HapticdWrench> for Wrench {
    #[inline]
    fn from(w: HapticdWrench) -> Self {
        Wrench {
            force: DVec3::from(w.force),
            torque: DVec3::from(w.torque),
        }
    }
}

/// `v` shortened to length `max` if it is longer. A vector too long to square is measured
/// scaled down, so a huge finite one is shortened, not lost to overflow.
#[inline]
pub fn clamp_length(v: DVec3, max: f64) -> DVec3 {
    // The common case, every tick: short enough, measured directly.
    let squared = v.length_squared();
    if squared.is_finite() && squared <= max * max {
        return v;
    }
    let scale = v.abs().max_element();
    if scale == 0.0 || !scale.is_finite() {
        return v;
    }
    let unit = v / scale;
    let length = unit.length() * scale;
    if length > max {
        unit / unit.length() * max
    } else {
        v
    }
}

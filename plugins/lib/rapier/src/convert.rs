//! rapier3d computes in `f32` with its own glam; the rest of hapticd in `f64`. Metres near
//! a desk keep 0.1 µm in `f32`, far below what a hand feels.

use glam::{DQuat, DVec3};
use rapier3d::prelude::{Rotation, Vector};

/// A rapier vector from ours.
pub fn vector(v: DVec3) -> Vector {
    Vector::new(v.x as f32, v.y as f32, v.z as f32)
}

/// Our vector from a rapier one.
pub fn dvec(v: Vector) -> DVec3 {
    DVec3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

/// A rapier rotation from ours.
pub fn rotation(q: DQuat) -> Rotation {
    Rotation::from_xyzw(q.x as f32, q.y as f32, q.z as f32, q.w as f32)
}

/// Our rotation from a rapier one.
pub fn dquat(q: Rotation) -> DQuat {
    DQuat::from_xyzw(
        f64::from(q.x),
        f64::from(q.y),
        f64::from(q.z),
        f64::from(q.w),
    )
    .normalize()
}

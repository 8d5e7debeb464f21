//! The intermediate representation of thesis 6.3.1: for a pointer, every solid within reach
//! as the plane through its nearest point with the outward normal there, and the velocity of
//! the solid's surface at that point (6.5.3: the nearest point is not a material point, so
//! friction needs the surface's own velocity).
//!
//! Candidates come from the broad phase's bounding-volume tree (rapier's query pipeline), so
//! the cost follows the number of solids near the pointer, not the size of the world.

use glam::DVec3;
use hapticd_plugin_api::{HAPTICD_MAX_PLANES, HapticdPlane, HapticdPlanes};
use rapier3d::parry::bounding_volume::Aabb;
use rapier3d::prelude::{PhysicsWorld, QueryFilter};

use crate::convert::{dvec, vector};

/// Fastest hand the published planes are made for, m/s.
pub const HAND_SPEED: f64 = 1.0;

/// Reach beyond a hand's travel: the thickest finger cap or proxy offset, metres.
pub const MARGIN: f64 = 0.02;

/// Nearer than this, a point lies on the surface and the direction to it says nothing about
/// the normal, metres.
const ON_SURFACE: f64 = 1e-6;

/// How far from a pointer solids are published at `rate` physics steps per second. A set of
/// planes is rendered until the next but one arrives (it is interpolated toward over the
/// period after its own), so a hand at [`HAND_SPEED`] travels at most two periods on it.
pub fn reach(rate: f64) -> f64 {
    HAND_SPEED * 2.0 / rate + MARGIN
}

/// A candidate plane and its distance from the pointer.
#[derive(Debug, Clone, Copy)]
pub struct Candidate {
    /// Distance from the pointer to the plane's point, metres.
    pub distance: f64,
    /// The plane.
    pub plane: HapticdPlane,
}

/// Write to `out` the planes of the (at most [`HAPTICD_MAX_PLANES`]) nearest solids of
/// `physics` within `reach` of `point`, nearest first. Kinematic bodies (the pointers of
/// position feedback) are left out; a collider's `user_data` is its object number.
/// `scratch` keeps its capacity between calls.
pub fn near(
    physics: &PhysicsWorld,
    point: DVec3,
    reach: f64,
    scratch: &mut Vec<Candidate>,
    out: &mut HapticdPlanes,
) {
    scratch.clear();
    let box_ = Aabb::new(
        vector(point - DVec3::splat(reach)),
        vector(point + DVec3::splat(reach)),
    );
    let query = physics.query_pipeline_with_filter(QueryFilter::exclude_kinematic());
    let at = vector(point);
    for (_, collider) in query.intersect_aabb_conservative(box_) {
        let (projection, feature) = collider
            .shape()
            .project_point_and_get_feature(collider.position(), at);
        let nearest = dvec(projection.point);
        let offset = point - nearest;
        let distance = offset.length();
        if distance > reach {
            continue;
        }
        let face = || {
            let local = collider
                .position()
                .inverse_transform_point(projection.point);
            collider
                .shape()
                .feature_normal_at_point(0, feature, local)
                .map(|n| dvec(collider.position().rotation * n))
        };
        let normal = if distance > ON_SURFACE && !projection.is_inside {
            offset / distance
        } else if let Some(n) = face() {
            // On the surface or inside it (a proxy resting on a face, a grip through
            // it): the normal of the face the point is nearest to, not of a direction
            // that means nothing at that distance.
            n
        } else if distance > ON_SURFACE {
            -offset / distance
        } else {
            // On the surface of a shape without faces: the direction from its centre is
            // outward enough for a convex piece.
            (nearest - dvec(collider.position().translation)).normalize_or(DVec3::Y)
        };
        let velocity = collider
            .parent()
            .and_then(|b| physics.bodies.get(b))
            .map_or(DVec3::ZERO, |b| dvec(b.velocity_at_point(projection.point)));
        scratch.push(Candidate {
            distance,
            plane: HapticdPlane {
                object: collider.user_data as u32,
                point: nearest.to_array(),
                normal: normal.to_array(),
                velocity: velocity.to_array(),
            },
        });
    }
    scratch.sort_unstable_by(|a, b| a.distance.total_cmp(&b.distance));
    let count = scratch.len().min(HAPTICD_MAX_PLANES);
    out.count = count as u32;
    for (slot, c) in out.planes.iter_mut().zip(&scratch[..count]) {
        *slot = c.plane;
    }
}

//! Normal contact forces integrated over the intersection volume (thesis 5.3.5).
//!
//! The penalty spring acts everywhere on the contact plane with a depth equal to the
//! thickness of the intersection along the contact normal n. Splitting the intersection's
//! surface into triangles, each projected onto the contact plane with its signed area (faces
//! turned toward n count positive, away negative), the depths integrate in closed form
//! (eq. 5.8, 5.9); summed over the closed surface this is exactly k_N·V·n acting through the
//! intersection's centroid. The damper integrates the normal relative velocity, linearly
//! interpolated over each triangle (eq. 5.12, 5.13), over the contact area once (the faces
//! turned toward n).

use glam::DVec3;

use hapticd_core::kinematics::Wrench;

use super::polyhedron::Polyhedron;

/// The penalty spring over the intersection `solid`, for the contact plane through `point`
/// with unit normal `normal` and stiffness `k_n` (N/m³: force per unit depth per unit area).
pub fn spring(solid: &Polyhedron, point: DVec3, normal: DVec3, k_n: f64) -> Wrench {
    let mut w = Wrench::default();
    // Each corner's depth h and its projection p onto the contact plane.
    let project = |v: DVec3| {
        let h = (v - point).dot(normal);
        (h, v - h * normal)
    };
    solid.fans(
        |plane| plane.spans(normal),
        project,
        |[(h0, p0), (h1, p1), (h2, p2)]| {
            // Signed projected area: positive for faces turned toward the normal.
            let area = (p1 - p0).cross(p2 - p0).dot(normal) / 2.0;
            let mean_h = (h0 + h1 + h2) / 3.0;
            let mean_p = (p0 + p1 + p2) / 3.0;
            let spread = (h0 - mean_h) * (p0 - mean_p)
                + (h1 - mean_h) * (p1 - mean_p)
                + (h2 - mean_h) * (p2 - mean_p);
            w.force += k_n * area * mean_h * normal;
            w.torque += k_n * area * (mean_h * mean_p + spread / 12.0).cross(normal);
        },
    );
    w
}

/// The penalty damper over the contact area of `solid`: damping `b_n` (N·s/m³) on the
/// normal component of `velocity(x)`, the relative velocity of the two bodies at x. It acts
/// both ways, resisting separation as well as approach, so that a rebound loses energy too;
/// the caller keeps the total contact force from pulling.
pub fn damper(
    solid: &Polyhedron,
    normal: DVec3,
    b_n: f64,
    velocity: impl Fn(DVec3) -> DVec3,
) -> Wrench {
    let mut w = Wrench::default();
    let approach = |x: DVec3| (x, velocity(x).dot(normal) * normal);
    solid.fans(
        |plane| plane.faces(normal),
        approach,
        |[(x0, v0), (x1, v1), (x2, v2)]| {
            let area = (x1 - x0).cross(x2 - x0).dot(normal) / 2.0;
            let mean_v = (v0 + v1 + v2) / 3.0;
            let mean_p = (x0 + x1 + x2) / 3.0;
            let spread = (x0 - mean_p).cross(v0 - mean_v)
                + (x1 - mean_p).cross(v1 - mean_v)
                + (x2 - mean_p).cross(v2 - mean_v);
            w.force += b_n * area * mean_v;
            w.torque += b_n * area * (mean_p.cross(mean_v) + spread / 12.0);
        },
    );
    w
}

/// Distributed Coulomb friction while sliding (eq. 5.14–5.16): at every point of the
/// contact, μ times the local spring pressure, against the local sliding direction.
/// `velocity(x)` is the velocity of the body pushed along `normal` relative to the other at
/// x (a rigid motion's); the wrench returned acts on that body. Each triangle is integrated
/// with the edge-midpoint rule, exact for the pressure (linear) times a uniform direction; sampling
/// inside the triangle matters where the direction turns: on a spinning patch the pressure
/// peaks at the centre, where the sliding speed vanishes, and is zero at the rim, where it is
/// largest, so vertex samples alone would miss the torque that brakes the spin. Below
/// `slip_speed` the force fades linearly to zero, so that an explicit step cannot reverse the
/// sliding direction (it must exceed μ·g·dt).
pub fn sliding_friction(
    solid: &Polyhedron,
    point: DVec3,
    normal: DVec3,
    (k_n, mu, slip_speed): (f64, f64, f64),
    velocity: impl Fn(DVec3) -> DVec3,
) -> Wrench {
    let mut w = Wrench::default();
    // Each corner's depth, projection onto the contact plane and sliding velocity; a rigid
    // motion's velocity at an edge's midpoint is the mean of its ends'.
    let corner = |v: DVec3| {
        let h = (v - point).dot(normal);
        (
            h,
            v - h * normal,
            velocity(v).reject_from_normalized(normal),
        )
    };
    solid.fans(
        |plane| plane.spans(normal),
        corner,
        |t| {
            let [(_, p0, _), (_, p1, _), (_, p2, _)] = t;
            let area = (p1 - p0).cross(p2 - p0).dot(normal) / 2.0;
            for (a, b) in [(0, 1), (1, 2), (2, 0)] {
                let ((ha, pa, sa), (hb, pb, sb)) = (t[a], t[b]);
                let slip = (sa + sb) / 2.0;
                let direction = -slip / slip.length().max(slip_speed);
                let f = area / 3.0 * mu * k_n * (ha + hb) / 2.0 * direction;
                w.force += f;
                w.torque += ((pa + pb) / 2.0).cross(f);
            }
        },
    );
    w
}

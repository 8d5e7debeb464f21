//! Static and dynamic friction over a contact area (thesis 5.3.6, Fig. 5.8).
//!
//! While stuck, every point of the contact carries a tangential spring-damper whose ends are
//! fixed to the two bodies at first contact: the spring's stretch is the relative
//! displacement since then, r + θ × q at the point q (r: slide of the contact's area
//! centroid, θ: twist about the normal). Integrated over the contact area about its
//! centroid, where the first moment vanishes, this gives
//!   f = −k_S·A·r − b_S·A·v,   m = −(k_S·θ + b_S·ω)·J·n   (J: polar moment of the area),
//! the planar form of eq. 5.22–5.28. The contact breaks loose when that force or torque
//! exceeds the largest static friction, μ0·N (or μ0·N·ρ̄ for the torque, ρ̄ the mean distance
//! of the area from its centroid), and slides with the distributed dynamic friction of
//! [`sliding_friction`] until it comes to rest. There the springs start again unstretched:
//! anchoring them at the dynamic friction instead (as Fig. 5.8 does) stores that force in
//! the springs, which then push a block that has just stopped back and forth.

use glam::DVec3;

use hapticd_core::kinematics::Wrench;

use super::contact::sliding_friction;
use super::polyhedron::Polyhedron;

/// Friction parameters of a contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionParameters {
    /// Static friction coefficient μ0.
    pub static_coefficient: f64,
    /// Dynamic friction coefficient μ (≤ μ0).
    pub dynamic_coefficient: f64,
    /// Stiffness of the friction springs per unit area, N/m³.
    pub stiffness: f64,
    /// Damping of the friction springs per unit area, N·s/m³.
    pub damping: f64,
    /// Sliding slower than this (m/s) at the contact counts as at rest.
    pub slip_speed: f64,
}

/// The friction state of one pair of bodies.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrictionState {
    /// Whether the bodies touched at the last step.
    pub in_contact: bool,
    /// Whether they are sliding (dynamic friction) rather than stuck.
    pub sliding: bool,
    /// Spring stretch at the contact centroid, in the contact plane, metres.
    slide: DVec3,
    /// Spring twist about the normal, radians.
    twist: f64,
    /// Where the contact centroid was.
    centre: DVec3,
}

/// The contact region of an overlap: the faces of the intersection turned toward the
/// normal, projected onto the plane across it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactPatch {
    /// Area, m² (zero when nothing faces the normal).
    pub area: f64,
    /// Area centroid, projected onto the plane through the origin across the normal.
    pub centroid: DVec3,
    /// Polar moment of the area about its centroid, m⁴.
    pub polar: f64,
    /// Mean distance of the area from its centroid, m.
    pub mean_radius: f64,
}

impl ContactPatch {
    /// The patch of `solid` across `normal`.
    pub fn of(solid: &Polyhedron, normal: DVec3) -> Self {
        // Triangles of the faces turned toward the normal, projected, with their areas.
        let triangles = || {
            solid.triangles().filter_map(move |t| {
                let t = t.map(|v| v.reject_from_normalized(normal));
                let s = (t[1] - t[0]).cross(t[2] - t[0]).dot(normal) / 2.0;
                (s > 0.0).then_some((s, t))
            })
        };
        let (area, moment) = triangles().fold((0.0, DVec3::ZERO), |(a, m), (s, t)| {
            (a + s, m + s * (t[0] + t[1] + t[2]) / 3.0)
        });
        if area <= 0.0 {
            return Self::default();
        }
        let centroid = moment / area;
        let (mut polar, mut radius) = (0.0, 0.0);
        for (s, t) in triangles() {
            let q = t.map(|x| x - centroid);
            let sum = q[0] + q[1] + q[2];
            // ∫|q|² over a triangle: S/12 (Σ|qᵢ|² + |Σqᵢ|²).
            polar += s / 12.0
                * (q.iter().map(|x| x.length_squared()).sum::<f64>() + sum.length_squared());
            radius += s * (sum / 3.0).length();
        }
        Self {
            area,
            centroid,
            polar,
            mean_radius: radius / area,
        }
    }
}

/// The friction wrench (torque about the origin) on the body pushed along `normal`, whose
/// velocity relative to the other is `velocity(x)` and relative spin `spin`; `normal_force`
/// is the contact's normal force and `pressure` its stiffness k_N (for the distributed
/// dynamic friction); `patch` is the contact region of `solid`. Updates `state` for a step
/// of `dt`.
#[allow(clippy::too_many_arguments)]
pub fn friction(
    state: &mut FrictionState,
    solid: &Polyhedron,
    patch: &ContactPatch,
    normal: DVec3,
    normal_force: f64,
    pressure: f64,
    parameters: &FrictionParameters,
    velocity: impl Fn(DVec3) -> DVec3,
    spin: DVec3,
    dt: f64,
) -> Wrench {
    let ContactPatch {
        area,
        centroid: plane_centre,
        polar,
        mean_radius,
    } = *patch;
    if area <= 0.0 {
        state.in_contact = false;
        return Wrench::default();
    }
    // The area centroid, on the contact plane through the overlap.
    let depth_point = solid.vertices.iter().sum::<DVec3>() / solid.vertices.len() as f64;
    let centre = plane_centre + depth_point.dot(normal) * normal;
    if !state.in_contact {
        *state = FrictionState {
            in_contact: true,
            centre,
            ..FrictionState::default()
        };
    }
    // Carry the anchor to where the contact is now.
    let twist = state.twist * normal;
    state.slide = (state.slide + twist.cross(centre - state.centre)).reject_from_normalized(normal);
    state.centre = centre;
    let slip = velocity(centre).reject_from_normalized(normal);
    let turn = spin.dot(normal);
    let p = parameters;
    if state.sliding && slip.length() < p.slip_speed && turn.abs() * mean_radius < p.slip_speed {
        // Stuck again: the springs start unstretched where the bodies came to rest.
        *state = FrictionState {
            in_contact: true,
            sliding: false,
            centre,
            ..FrictionState::default()
        };
    }
    if !state.sliding {
        state.slide += slip * dt;
        state.twist += turn * dt;
        let force = -(p.stiffness * state.slide + p.damping * slip) * area;
        let torque = -(p.stiffness * state.twist + p.damping * turn) * polar * normal;
        let limit = p.static_coefficient * normal_force;
        if force.length() <= limit && torque.length() <= limit * mean_radius {
            return Wrench {
                force,
                torque: torque + centre.cross(force),
            };
        }
        state.sliding = true;
    }
    let dynamic = sliding_friction(
        solid,
        centre,
        normal,
        (pressure, p.dynamic_coefficient, p.slip_speed),
        &velocity,
    );
    // Sliding: re-anchor the springs to the dynamic friction.
    let dynamic_torque = (dynamic.torque - centre.cross(dynamic.force)).dot(normal);
    state.slide = -dynamic.force.reject_from_normalized(normal) / (p.stiffness * area);
    state.twist = if polar > 0.0 {
        -dynamic_torque / (p.stiffness * polar)
    } else {
        0.0
    };
    dynamic
}

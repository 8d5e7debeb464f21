//! Static and dynamic friction over a contact area (thesis 5.3.6, Fig. 5.8).
//!
//! While stuck, every point of the contact carries a tangential spring-damper whose ends are
//! fixed to the two bodies at first contact: the spring's stretch is the relative
//! displacement since then, r + θ × q at the point q (r: slide of the contact's area
//! centroid, θ: twist about the normal). Integrated over the contact area about its
//! centroid, where the first moment vanishes, this gives
//!   f = −k_S·A·r − b_S·A·v,   m = −(k_S·θ + b_S·ω)·J·n   (J: polar moment of the area),
//! the planar form of eq. 5.22–5.28.
//!
//! The thesis lets the contact break loose when that force or torque exceeds the largest
//! static friction, μ0·N (μ0·N·ρ̄ for the torque, ρ̄ the mean distance of the area from its
//! centroid). But the springs carry more than the load while they catch bodies a sudden load
//! has set moving, and a block that pitches or settles to a new load sees its normal force
//! swing: a block set down on a slope a little below the friction angle then slid off. So
//! the contact here breaks loose when the load itself (the forces on the two bodies other
//! than this contact's, [`Loading`]) exceeds μ0 times the larger of the normal force and the
//! load pressing the bodies together, or when the springs and dampers pull more than twice
//! that (bodies set moving from outside). It then slides with the distributed dynamic
//! friction of [`sliding_friction`] until the slide slows below the slip speed with a load
//! the dynamic friction could hold (the thesis' step 3); there the springs start again
//! unstretched: anchoring them at the dynamic friction instead (as
//! Fig. 5.8 does) stores that force in the springs, which then push a block that has just
//! stopped back and forth.

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
    /// Spin about the normal at the last step.
    turn: f64,
    /// Friction torque about the normal at the last step.
    twist_held: f64,
}

impl FrictionState {
    /// Where the contact's centroid was at the last step.
    pub fn centre(&self) -> DVec3 {
        self.centre
    }
}

/// How far past the largest static friction a stuck contact's springs and dampers may pull
/// for a moment while they catch the bodies' inertia under a load the contact holds. Beyond
/// it the bodies are moving faster than a load could make them (set moving from outside, or
/// thrown against each other), and the contact slides.
const OVERSHOOT: f64 = 2.0;

/// What the rest of the world asks of a contact: the forces on its two bodies other than
/// its own, as the contact would have to hold them to keep the bodies still relative to each
/// other. A load that arrives at once first moves the bodies, and the friction springs then
/// catch them with more than the load for a moment: that surplus is the bodies' inertia, and
/// must not break a contact that holds the load itself (nor must the normal force's dip
/// while the bodies settle to a lighter load lower the limit).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Loading {
    /// The tangential force on the pushed body relative to the other, N.
    pub load: DVec3,
    /// The force pressing them together, N.
    pub pressing: f64,
    /// Their moment of inertia about the normal, at the contact, kg·m².
    pub turning: f64,
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
    /// The area centroid on the plane across `normal` through `point`.
    pub fn point_on(&self, point: DVec3, normal: DVec3) -> DVec3 {
        self.centroid + point.dot(normal) * normal
    }

    /// The patch of `solid` across `normal`.
    pub fn of(solid: &Polyhedron, normal: DVec3) -> Self {
        // The faces turned toward the normal, projected onto the plane across it.
        let project = |v: DVec3| v.reject_from_normalized(normal);
        let area_of = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).dot(normal) / 2.0;
        let (mut area, mut moment) = (0.0, DVec3::ZERO);
        solid.fans(
            |plane| plane.faces(normal),
            project,
            |t| {
                let s = area_of(&t);
                area += s;
                moment += s * (t[0] + t[1] + t[2]) / 3.0;
            },
        );
        if area <= 0.0 {
            return Self::default();
        }
        let centroid = moment / area;
        let (mut polar, mut radius) = (0.0, 0.0);
        solid.fans(
            |plane| plane.faces(normal),
            project,
            |t| {
                let s = area_of(&t);
                let q = t.map(|x| x - centroid);
                let sum = q[0] + q[1] + q[2];
                // ∫|q|² over a triangle: S/12 (Σ|qᵢ|² + |Σqᵢ|²).
                polar += s / 12.0
                    * (q.iter().map(|x| x.length_squared()).sum::<f64>() + sum.length_squared());
                radius += s * (sum / 3.0).length();
            },
        );
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
/// dynamic friction); `patch` is the contact region of `solid`; `loading` is what the rest
/// of the world asks of it (none for bodies it cannot move, such as a pointer held to its
/// grip against a fixed table: what the springs hold is then the load). Updates `state`
/// for a step of `dt`.
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
    loading: Option<&Loading>,
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
    let pressing = normal_force.max(loading.map_or(0.0, |l| l.pressing));
    // The spin about the normal has no load from outside worked out for it: its load is
    // what changed the spin over the last step less the friction torque that acted.
    let twist_load =
        loading.map(|l| (l.turning * (turn - state.turn) / dt - state.twist_held).abs());
    state.turn = turn;
    // A slide comes to rest where it is slow and holding the bodies asks no more than the
    // dynamic friction (5.3.6, step 3): a block just broken loose by a load past μ0·N
    // starts from rest too, but slides on. Bodies the contact cannot move ask the dampers'
    // force at that speed.
    if state.sliding && slip.length() < p.slip_speed && turn.abs() * mean_radius < p.slip_speed {
        let hold = loading.map_or(p.damping * area * slip.length(), |l| l.load.length());
        let twist_hold = twist_load.unwrap_or(p.damping * polar * turn.abs());
        let dynamic = p.dynamic_coefficient * pressing;
        if hold <= dynamic && twist_hold <= dynamic * mean_radius {
            // The springs start unstretched.
            state.sliding = false;
            (state.slide, state.twist) = (DVec3::ZERO, 0.0);
        }
    }
    if !state.sliding {
        state.slide += slip * dt;
        state.twist += turn * dt;
        let force = -(p.stiffness * state.slide + p.damping * slip) * area;
        let torque = -(p.stiffness * state.twist + p.damping * turn) * polar * normal;
        // Bodies whose motion the contact cannot change: what the springs hold is the load.
        let load = loading.map_or(force.length(), |l| l.load.length());
        let twist_load = twist_load.unwrap_or(torque.length());
        let limit = p.static_coefficient * pressing;
        let holds = |load: f64, held: f64, limit: f64| load <= limit && held <= OVERSHOOT * limit;
        if holds(load, force.length(), limit)
            && holds(twist_load, torque.length(), limit * mean_radius)
        {
            state.twist_held = torque.dot(normal);
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
    state.twist_held = dynamic_torque;
    state.slide = -dynamic.force.reject_from_normalized(normal) / (p.stiffness * area);
    state.twist = if polar > 0.0 {
        -dynamic_torque / (p.stiffness * polar)
    } else {
        0.0
    };
    dynamic
}

//! A scene for rapier's constraint solver (thesis Ch. 6), as its file describes it: the
//! bodies and what each piece is, the physics rate and what the haptic side hands back. The
//! rapier scene plugin (`plugins/lib/rapier`) builds the world from it; nothing here links
//! rapier.

use glam::DVec3;
use hapticd_core::diagnostics::Diagnostic;

use super::checks::{Bodies, Primitive, RATE_RANGE};
use hapticd_core::kinematics::Pose;
use hapticd_core::scene::exact_shapes::{Solid, SurfacePiece};
use hapticd_core::scene::held_part::HeldSpec;

use super::held::{self, Held};
use super::schema::{RawFeedback, RawScene};
use super::soft::Soft;
use crate::body::Body;
use crate::joint::Joint;
use crate::polyhedron::Polyhedron;
use crate::soft::SoftPart;

/// What a multi-rate world takes back from the haptic side (`feedback:`, thesis 6.2–6.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feedback {
    /// Local dynamics (thesis 6.5.4): the bodies near a pointer move in the haptic thread
    /// under the hand between physics steps, and what the hand did to them goes back.
    Local,
    /// The impulse the hand gave each body over a physics period, at its point.
    Impulse,
    /// The conventional method: each pointer is a kinematic body moved to the hand's
    /// position as the physics samples it.
    Position,
}

impl Feedback {
    /// The name a scene file gives it.
    pub fn name(self) -> &'static str {
        match self {
            Feedback::Local => "local",
            Feedback::Impulse => "impulse",
            Feedback::Position => "position",
        }
    }
}

/// A scene for rapier's constraint solver, as its file describes it: the world the rapier
/// scene plugin builds and steps at `rate`.
#[derive(Debug, Clone)]
pub struct RapierScene {
    /// The scene's name.
    pub name: String,
    /// Gravity, m/s².
    pub gravity: DVec3,
    /// Physics steps per second.
    pub rate: f64,
    /// What the haptic side gives back.
    pub feedback: Feedback,
    /// μ0 of every contact.
    pub static_friction: f64,
    /// μ of every contact.
    pub friction: f64,
    /// The bodies (centroid, mass and inertia as the penalty engine has them).
    pub bodies: Vec<Body>,
    /// What each piece of each body is, in the order of [`Body::pieces`].
    pub primitives: Vec<Vec<Primitive>>,
    /// The triangles of each body that is a mesh, in its frame: a fixed one's collider, and
    /// what is drawn instead of a body's convex pieces.
    pub surfaces: Vec<Option<Vec<[DVec3; 3]>>>,
    /// Whether each body's mass and inertia are given (a robot's link), not its solids'.
    pub weighed: Vec<bool>,
    /// Names of the bodies.
    pub names: Vec<String>,
    /// The joints between the bodies.
    pub joints: Vec<Joint>,
    /// The soft bodies, stepped at the physics rate against the fixed bodies (their ids
    /// after the rigid ones').
    pub soft: Vec<SoftPart>,
    /// The pointers' solid, centred at the origin, if the file gives one.
    pub pointer: Option<(Body, Primitive)>,
    /// The body the first pointer holds (`pointer.holds`), last of `bodies`, which the
    /// world places where the god-object's proxy is.
    pub held: Option<HeldSpec>,
    /// What works but is worth knowing.
    pub warnings: Vec<Diagnostic>,
}

/// The physics rate `raw` asks for, steps a second (the slowest allowed unless it says).
pub(super) fn physics_rate(raw: &RawScene) -> f64 {
    raw.rate.unwrap_or(RATE_RANGE.0)
}

impl RapierScene {
    /// The scene of checked `raw`, its `bodies`, `joints`, `soft` bodies, `pointer` solid
    /// and the body that pointer holds.
    pub(super) fn build(
        raw: RawScene,
        (bodies, joints, soft): (Bodies, Vec<Joint>, Vec<Soft>),
        (pointer, held): (Option<(Polyhedron, Primitive)>, Option<Held>),
        warnings: Vec<Diagnostic>,
    ) -> Self {
        let Bodies {
            mut bodies,
            mut primitives,
            mut surfaces,
            mut weighed,
            ..
        } = bodies;
        let mut names: Vec<String> = raw
            .bodies
            .iter()
            .filter(|b| b.rigid())
            .map(|b| b.name.clone())
            .collect();
        // After the file's other rigid bodies, so that their numbers (and the joints'
        // between them) stand, and before the soft ones.
        let held = held.map(|held| {
            let (body, kinds, surface, name, spec) = held::rapier_body(&raw, held, bodies.len());
            bodies.push(body);
            primitives.push(kinds);
            surfaces.push(surface);
            weighed.push(false);
            names.push(name);
            spec
        });
        let feedback = match raw.feedback {
            Some(RawFeedback::Position) => Feedback::Position,
            Some(RawFeedback::Local) | None => Feedback::Local,
            Some(RawFeedback::Impulse) => Feedback::Impulse,
        };
        let rate = physics_rate(&raw);
        // Among the file's bodies a soft body touches the fixed ones (rapier moves the
        // others); the rapier world adds the pointers' solids, which it touches under
        // position feedback alone.
        let soft = soft
            .into_iter()
            .map(|s| s.part(&bodies, bodies.len(), false))
            .collect();
        RapierScene {
            name: raw.name,
            gravity: DVec3::from(raw.gravity),
            rate,
            feedback,
            static_friction: raw.material.static_friction,
            friction: raw.material.friction,
            bodies,
            primitives,
            surfaces,
            weighed,
            names,
            joints,
            soft,
            pointer: pointer.map(|(shape, primitive)| {
                let density = raw.pointer.as_ref().map_or(1000.0, |p| p.density);
                (Body::new(&shape, density, false), primitive)
            }),
            held,
            warnings,
        }
    }

    /// Whether body `i` collides as its mesh's own triangles (a fixed mesh), one object,
    /// rather than as its convex pieces, one object each.
    pub fn is_trimesh(&self, i: usize) -> bool {
        self.bodies[i].fixed && self.surfaces[i].is_some()
    }

    /// Each closed piece of each rigid body's surface where the file puts it (a mesh's own
    /// triangles, else its convex pieces' faces): what a held body meets. A piece that is a
    /// ball or a box says so, with its object (the world numbers its bodies' objects in
    /// order, a body's pieces in order).
    pub fn surface_pieces(&self) -> Vec<SurfacePiece> {
        let mut out = Vec::new();
        let mut first_object = 0u32;
        for (i, (body, surface)) in self.bodies.iter().zip(&self.surfaces).enumerate() {
            let pose = Pose {
                position: body.position,
                orientation: body.orientation,
            };
            let primitives = &self.primitives[i];
            let pieces = held::surface_pieces(body, surface.as_ref());
            // A mesh is one piece, its own surface, whatever its objects.
            let exact: Vec<Option<(u32, Solid)>> = match surface {
                Some(_) => Vec::new(),
                None => (primitives.iter().zip(&body.pieces).enumerate())
                    .map(|(k, (kind, piece))| {
                        let centre = piece.vertex_centre();
                        let solid = match *kind {
                            Primitive::Ball { radius } => Solid::Ball { centre, radius },
                            Primitive::Cuboid { half, rotation } => Solid::Box {
                                centre,
                                rotation,
                                half,
                            },
                            Primitive::Hull => return None,
                        };
                        Some((first_object + k as u32, solid))
                    })
                    .collect(),
            };
            for (k, triangles) in pieces.into_iter().enumerate() {
                out.push(SurfacePiece {
                    body: i as u32,
                    fixed: body.fixed,
                    pose,
                    triangles,
                    exact: exact.get(k).copied().flatten(),
                });
            }
            first_object += match self.is_trimesh(i) {
                true => 1,
                false => primitives.len() as u32,
            };
        }
        out
    }
}

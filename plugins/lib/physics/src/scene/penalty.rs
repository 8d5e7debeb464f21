//! A scene for the penalty engine (thesis Ch. 5): its world with a body per pointer at the
//! end, the material for each contact model, couplings and grasping, built from a checked
//! file.

use std::path::Path;

use glam::DVec3;
use hapticd_core::diagnostics::{self, Diagnostic, Diagnostics, Findings};
use hapticd_core::haptics::grasp::{GraspSettings, Method};
use serde::de::IgnoredAny;

use super::SceneFile;
use super::checks::{Bodies, INERTIA_DAMPING_FACTOR, Penalty, Primitive};
use super::held::{HeldPart, HeldPointer};
use super::schema::{RawGraspMethod, RawPointer, RawScene};
use super::soft::Soft;
use crate::body::Body;
use crate::coupling::Coupling;
use crate::friction::FrictionParameters;
use crate::grasping::Grasping;
use crate::joint::Joint;
use crate::polyhedron::Polyhedron;
use crate::soft::SoftPart;
use crate::world::{ContactModel, Material, World};
use hapticd_core::kinematics::Wrench;

/// The `pointer:` solid and what it is.
type PointerSolid = (Polyhedron, Primitive);

/// A loaded scene: the world with one fixed body per pointer at its end.
pub struct PenaltyScene {
    /// The scene's name.
    pub name: String,
    /// The world.
    pub world: World,
    /// Longest physics step, seconds.
    pub dt: f64,
    /// Index of the first pointer body in the world.
    pub first_pointer: usize,
    /// Names of the bodies in world order; pointers are `pointer 1`, `pointer 2`, …
    pub names: Vec<String>,
    /// The triangles of each body (before the pointers) that is a mesh, in its frame: drawn
    /// instead of its convex pieces.
    pub surfaces: Vec<Option<Vec<[DVec3; 3]>>>,
    /// The material as the file gives it for each contact model.
    pub(super) materials: [Material; 2],
    /// The coupling of each pointer; none for one placed at its grip.
    pub(super) couplings: Vec<Option<Coupling>>,
    /// Whether the pointers have been put at their grips once.
    pub(super) pointers_placed: bool,
    /// Bodies held between pointers, when the file asks for grasping.
    pub grasping: Option<Grasping>,
    /// What the file asks for that works, but worth knowing (a step near its stability
    /// limit).
    pub warnings: Vec<Diagnostic>,
    /// The soft bodies, stepped once a tick beside the world.
    pub soft: Vec<SoftPart>,
    /// What the soft bodies push each world body with over a tick, and what they move and
    /// turn along with it, kg and kg·m² ([`crate::soft::pushed_load`]).
    pub(super) pushed: Vec<(Wrench, (f64, f64))>,
    /// Each coupled pointer's coupling load in the step.
    pub(super) coupled: Vec<Wrench>,
    /// Each world body's own load, kept while the soft bodies' pushes are added to it.
    pub(super) own_loads: Vec<Wrench>,
    /// The body the pointer holds, rendered by its god-object (`pointer.holds`).
    pub(super) held: Option<HeldPart>,
}

impl PenaltyScene {
    /// Load the penalty scene file at `path` for `pointers` pointers.
    pub fn load(path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        Self::parse(&diagnostics::read_text(path)?, path, pointers)
    }

    /// Keep a held body's god-object to its share of each tick by the wall clock, as on the
    /// haptic thread (see [`GodObject::keep_to_the_clock`]); a run in simulated time leaves
    /// it off.
    ///
    /// [`GodObject::keep_to_the_clock`]: hapticd_core::haptics::god_object::GodObject::keep_to_the_clock
    pub fn keep_to_the_clock(&mut self) {
        if let Some(held) = &mut self.held {
            held.keep_to_the_clock();
        }
    }

    /// Parse penalty scene `text` for `pointers` pointers (see [`SceneFile::parse`]); a
    /// file for another engine is an error at its `engine:`.
    pub fn parse(text: &str, path: &Path, pointers: usize) -> Result<Self, Diagnostics> {
        match SceneFile::parse(text, path, pointers)? {
            SceneFile::Penalty(scene) => Ok(*scene),
            SceneFile::Rapier(_) => {
                let map = diagnostics::parse_yaml::<IgnoredAny>(text, path)?.map;
                let locate = |field: &str| map.find(field);
                let mut f = Findings::new(path, &locate);
                f.error("engine", "a rapier scene; this runs penalty scenes only");
                Err(f.into_error())
            }
        }
    }

    /// The scene of checked `raw`, its material `penalty`, `bodies` and `pointer` solid,
    /// for `pointers` pointers.
    pub(super) fn build(
        raw: RawScene,
        penalty: Penalty,
        (bodies, joints, soft): (Bodies, Vec<Joint>, Vec<Soft>),
        (pointer, held): (Option<PointerSolid>, Option<HeldPointer>),
        pointers: usize,
        warnings: Vec<Diagnostic>,
    ) -> Self {
        let Bodies {
            mut bodies,
            boxes,
            surfaces,
            ..
        } = bodies;
        let first_pointer = bodies.len();
        let dt = penalty.dt;
        let mut couplings = Vec::with_capacity(pointers);
        let coupling = raw
            .pointer
            .as_ref()
            .and_then(|p| p.coupling.as_ref())
            .map(|c| Coupling {
                stiffness: c.stiffness,
                damping: c.damping,
                rotational_stiffness: c.rotational_stiffness,
                rotational_damping: c.rotational_damping,
            });
        let mut part = None;
        match (&raw.pointer, &pointer, held) {
            // The held body is the first pointer: placed by its god-object, or coupled. The
            // others are fingertips.
            (_, fingertip, Some((body, god))) => {
                couplings.push(coupling.filter(|_| god.is_none()));
                bodies.push(body);
                part = god;
                if let Some((shape, _)) = fingertip {
                    for _ in 1..pointers {
                        bodies.push(Body::new(shape, RawPointer::fingertip().density, true));
                        couplings.push(None);
                    }
                }
            }
            (Some(p), Some((shape, _)), None) => {
                for _ in 0..pointers {
                    bodies.push(Body::new(shape, p.density, coupling.is_none()));
                    couplings.push(coupling);
                }
            }
            _ => {}
        }
        let grasping = raw.grasp.as_ref().filter(|_| pointers >= 2).map(|g| {
            // The pointer's half size: where its solid meets a face its centre is that far out.
            let pointer = bodies[first_pointer].pieces[0]
                .vertices
                .iter()
                .fold(DVec3::ZERO, |m, v| m.max(v.abs()))
                .min_element();
            Grasping::new(&bodies[..first_pointer], &boxes, pointer, |mass| {
                GraspSettings {
                    method: match g.method {
                        RawGraspMethod::Distributed => Method::Distributed,
                        RawGraspMethod::Conventional => Method::Conventional,
                    },
                    grip_stiffness: g.grip_stiffness,
                    inertia_stiffness: g.inertia_stiffness,
                    // Unless the file says, a damping ratio of about 0.18 for the body on the
                    // inertia spring: through the shares the damper acts on the fingers' own
                    // motion, and with the device's tick of delay a heavier one shakes them.
                    inertia_damping: g
                        .inertia_damping
                        .unwrap_or(INERTIA_DAMPING_FACTOR * (g.inertia_stiffness * mass).sqrt()),
                    // Holding is sticking: the static coefficient.
                    friction: raw.material.static_friction,
                }
            })
        });
        let soft = soft
            .into_iter()
            .map(|s| {
                let mut part = s.part(&bodies, first_pointer, true);
                part.factor_aside();
                part
            })
            .collect();
        let material = Material {
            stiffness: penalty.stiffness,
            damping: penalty.damping,
            friction: FrictionParameters {
                static_coefficient: raw.material.static_friction,
                dynamic_coefficient: raw.material.friction,
                stiffness: penalty.friction_stiffness,
                damping: penalty.friction_damping,
                slip_speed: penalty.slip_speed,
            },
            model: ContactModel::Volume,
            scaling: penalty.scaling,
        };
        let materials = [
            material,
            Material {
                stiffness: penalty.point[0],
                damping: penalty.point[1],
                model: ContactModel::Point,
                ..material
            },
        ];
        let mut scene = PenaltyScene {
            name: raw.name,
            world: World::new(bodies, DVec3::from(raw.gravity), material),
            dt,
            first_pointer,
            names: raw
                .bodies
                .into_iter()
                .filter(|b| b.rigid())
                .map(|b| b.name)
                .chain((1..=pointers).map(|k| format!("pointer {k}")))
                .collect(),
            surfaces,
            materials,
            couplings,
            pointers_placed: false,
            grasping,
            warnings,
            soft,
            pushed: Vec::new(),
            coupled: vec![Wrench::default(); pointers],
            own_loads: Vec::new(),
            held: part,
        };
        let bodies = scene.world.bodies.len();
        scene.pushed = vec![(Wrench::default(), (0.0, 0.0)); bodies];
        scene.own_loads = vec![Wrench::default(); bodies];
        scene.set_model(penalty.model);
        // The god-object keeps the held body out of the fixed bodies; the world's contacts
        // push the moving ones.
        if scene.held.is_some() {
            scene.world.guided = Some(first_pointer);
        }
        scene.world.join(&joints);
        // A body holding a soft body's nodes, or resting on one, is pushed by it every
        // tick: none sleeps where a soft body may touch a body that moves.
        scene.world.sleeping &= scene.soft.is_empty()
            || scene.world.bodies[..scene.first_pointer]
                .iter()
                .all(|b| b.fixed);
        scene
    }
}

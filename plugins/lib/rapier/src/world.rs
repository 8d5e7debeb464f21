//! A scene file's world as a rapier world, stepped at the scene's rate in the physics thread.
//!
//! Each body of the file is a rigid body with one collider per convex piece (rapier's own
//! box, ball or convex hull), of the same mass as the penalty engine gives it. Contacts
//! between bodies use μ (`friction:`): rapier's Coulomb cone has one coefficient, so the
//! sliding one keeps a body from sticking harder than the file allows. Every dynamic body
//! has continuous collision detection, so a fast body at 10 Hz does not pass through a wall.
//!
//! Objects of planes and impulses are collider numbers in file order (one per convex
//! piece), so a body that is not convex shows each piece as a plane of its own; then one per
//! soft body.
//!
//! A soft body is stepped after the rigid ones, at the same rate, against the fixed bodies.
//! The hand presses it through the impulses it gives it: each period's, as a force over
//! the next step on the surface where it pressed (thesis 6.5.5: deformed by what the hand
//! gave, not by how deep the finger went). Its plane under a pointer says how far the
//! surface gives for each newton pressed on it before the next step (the compliance
//! extension), so that the finger meets it where that step will have it. Under position
//! feedback the pointers' solids push its nodes out of their overlap instead (the
//! conventional method), its planes rigid.

use glam::{DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::mass::volume_and_centroid;
use hapticd_physics::scene::{Feedback, Primitive, RapierScene};
use hapticd_physics::soft::SoftPart;
use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
use hapticd_plugin_api::{
    HAPTICD_MAX_BODY_CONTACTS, HAPTICD_MAX_PLANES, HapticdBodyContact, HapticdBodyPose,
    HapticdImpulse, HapticdLocalBody, HapticdLocalState, HapticdMobility, HapticdPlane,
    HapticdPlaneCompliance, HapticdPlanes, HapticdPointer,
};
use rapier3d::geometry::PairContacts;
use rapier3d::na::Vector6;
use rapier3d::parry::bounding_volume::BoundingVolume;
use rapier3d::prelude::{
    Collider, ColliderBuilder, ColliderHandle, MassProperties, Matrix, PhysicsWorld, Pose,
    QueryFilter, RigidBodyBuilder, RigidBodyHandle, TriMeshFlags, Vector,
};

use crate::articulation;
use crate::convert::{dquat, dvec, rotation, vector};
use crate::joints::Joints;
use crate::surfaces::{self, Candidate};
use hapticd_physics::joint::{DrivenJoints, Joint, JointState, Motor};

/// Where a body is and how it moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    /// Centre of mass, metres.
    pub position: DVec3,
    /// Orientation.
    pub orientation: DQuat,
    /// Velocity of the centre of mass, m/s.
    pub velocity: DVec3,
    /// Angular velocity, rad/s.
    pub spin: DVec3,
}

impl BodyState {
    /// Where the body is: its centre of mass and orientation.
    pub fn pose(&self) -> hapticd_core::kinematics::Pose {
        hapticd_core::kinematics::Pose {
            position: self.position,
            orientation: self.orientation,
        }
    }
}

/// How much deeper in a fixed solid a hand-back may take a body before its pose is left
/// out, metres: rapier's own contacts let a resting body sink a fraction of this.
const SINK: f64 = 1e-3;

/// A multi-rate world on rapier.
pub struct RapierWorld {
    pub(crate) physics: PhysicsWorld,
    /// The rigid body of each body of the file.
    pub(crate) bodies: Vec<RigidBodyHandle>,
    /// The name of each body of the file.
    pub(crate) names: Vec<String>,
    /// Each collider (object number) and the body it belongs to.
    pieces: Vec<(ColliderHandle, usize)>,
    /// Kinematic bodies following the pointers (position feedback only).
    pointers: Vec<RigidBodyHandle>,
    /// The pointers' solid, as far as the planes must keep a grip from what it touches.
    pointer_solid: Option<PointerSolid>,
    /// Each body's inertia about its centre of mass in its own axes, and its mass.
    pub(crate) inertia: Vec<(glam::DMat3, f64)>,
    /// Each body's volume, m³ (a mass set from outside keeps its density in range).
    pub(crate) volumes: Vec<f64>,
    /// Each body's objects: the first and how many.
    objects: Vec<(u32, u32)>,
    /// The last change of the hand each body took in.
    applied: Vec<u64>,
    /// Whether each body's last change was left out (see [`RapierWorld::take_in`]).
    left_out: Vec<bool>,
    feedback: Feedback,
    reach: f64,
    scratch: Vec<Candidate>,
    /// The joints between the bodies.
    pub(crate) joints: Joints,
    /// The soft bodies: ids after the rigid bodies', objects after the colliders'.
    pub(crate) soft: Vec<SoftPart>,
    /// The bodies as the file has them, then the pointers' solids: the fixed ones, and the
    /// pointers under position feedback (parked far away otherwise), are what the soft
    /// bodies meet.
    still: Vec<Body>,
    /// What each soft body was pushed with at the last step: where, and the force, N.
    soft_loads: Vec<Vec<(DVec3, DVec3)>>,
    /// How each pointer's planes of the last step give.
    gives: Vec<[HapticdPlaneCompliance; HAPTICD_MAX_PLANES]>,
    /// The body the first pointer holds, placed where its proxy is, and the point the grip
    /// holds in its frame.
    held: Option<(RigidBodyHandle, DVec3)>,
}

/// The solid a pointer is in the physics under position feedback. The haptic side renders
/// a point (the grip) against the planes, so each plane is moved out by the solid's extent
/// along its normal: the grip meets a plane exactly when the solid meets the surface, and a
/// body the solid pushes ahead is felt instead of staying out of the point's reach.
enum PointerSolid {
    Ball(f64),
    /// A box or hull: its corners about its centre (the one piece a pointer's collider is).
    Corners(Vec<DVec3>),
}

impl PointerSolid {
    fn of(body: &Body, primitive: Primitive) -> Self {
        match primitive {
            Primitive::Ball { radius } => Self::Ball(radius),
            Primitive::Cuboid { .. } | Primitive::Hull => {
                Self::Corners(body.pieces[0].vertices.clone())
            }
        }
    }

    /// How far the solid reaches from its centre along unit `direction`, metres.
    fn extent(&self, direction: DVec3) -> f64 {
        match self {
            Self::Ball(radius) => *radius,
            Self::Corners(corners) => corners.iter().map(|c| c.dot(direction)).fold(0.0, f64::max),
        }
    }
}

/// The size of the world's typical moving body, metres: rapier scales its tolerances by it
/// (contact prediction, allowed penetration, the broad phase's fattening). Its default of a
/// metre suits a room; on a desk, centimetre bodies would each be paired with every body
/// within 8 cm, and a falling pile of a thousand make two hundred thousand pairs.
fn length_unit(bodies: &[Body]) -> f64 {
    let mut sizes: Vec<f64> = bodies
        .iter()
        .filter(|b| !b.fixed)
        .map(|b| {
            let (low, high) = b
                .pieces
                .iter()
                .flat_map(|p| &p.vertices)
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(low, high), v| {
                    (low.min(*v), high.max(*v))
                });
            (high - low).max_element()
        })
        .collect();
    sizes.sort_by(f64::total_cmp);
    sizes
        .get(sizes.len() / 2)
        .map_or(1.0, |s| s.clamp(1e-3, 1.0))
}

/// The collider of `primitive`, piece `piece` of `body` (in the body's frame).
fn collider(body: &Body, piece: usize, primitive: Primitive) -> ColliderBuilder {
    let solid = &body.pieces[piece];
    let centre = solid.vertex_centre();
    match primitive {
        Primitive::Cuboid { half, rotation: r } => {
            ColliderBuilder::cuboid(half.x as f32, half.y as f32, half.z as f32)
                .position(Pose::from_parts(vector(centre), rotation(r)))
        }
        Primitive::Ball { radius } => {
            ColliderBuilder::ball(radius as f32).translation(vector(centre))
        }
        Primitive::Hull => {
            let points: Vec<_> = solid.vertices.iter().map(|v| vector(*v)).collect();
            ColliderBuilder::convex_hull(&points)
                .expect("the scene file's hull spans a volume (checked when read)")
        }
    }
}

/// The collider of a fixed mesh: its own triangles, holes and all (in its body's frame).
fn trimesh(surface: &[[DVec3; 3]]) -> ColliderBuilder {
    let vertices: Vec<Vector> = surface.iter().flatten().map(|c| vector(*c)).collect();
    let indices = (0..surface.len() as u32)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    // Corners shared between triangles merged, so that contacts on an edge see both faces.
    ColliderBuilder::trimesh_with_flags(
        vertices,
        indices,
        TriMeshFlags::MERGE_DUPLICATE_VERTICES | TriMeshFlags::DELETE_DEGENERATE_TRIANGLES,
    )
    .expect("a body's mesh closes a volume, so some triangles have an area (checked when read)")
}

/// The nearest points of collider `mine` and `solid` where they are now, within `margin`:
/// the contact of `mine` with it, the normal along which `solid` pushes.
fn contact_now(mine: &Collider, solid: &Collider, margin: f64) -> Option<HapticdBodyContact> {
    let c = rapier3d::parry::query::contact(
        mine.position(),
        mine.shape(),
        solid.position(),
        solid.shape(),
        margin as f32,
    )
    .ok()??;
    Some(HapticdBodyContact {
        point: dvec(c.point1).to_array(),
        normal: (-dvec(c.normal1)).to_array(),
        gap: f64::from(c.dist),
        friction: f64::from(mine.friction().min(solid.friction())),
    })
}

/// Contact points gathered for one body, before [`spread`] chooses among them.
const FOUND: usize = 4 * HAPTICD_MAX_BODY_CONTACTS;

/// Choose up to `out.len()` of the contacts `found` (each tagged with its pair, `pairs` of
/// them) into `out` and say how many: every pair in turn, and within a pair the point
/// farthest from those already chosen. A block in a corner touches a floor and two walls
/// with four corners each; the first pairs alone would fill the record and drop the floor,
/// and a face's first two points may lie on one edge.
fn spread(
    found: &[(usize, HapticdBodyContact)],
    pairs: usize,
    out: &mut [HapticdBodyContact],
) -> usize {
    let mut taken = [false; FOUND];
    let mut count = 0;
    let point = |k: usize| DVec3::from(found[k].1.point);
    loop {
        let before = count;
        for pair in 0..pairs {
            if count == out.len() {
                return count;
            }
            let chosen = |k: usize| taken[k] && found[k].0 == pair;
            // The farthest from this pair's chosen points (any of them at first).
            let far = |k: usize| {
                (0..found.len())
                    .filter(|&j| chosen(j))
                    .map(|j| point(j).distance_squared(point(k)))
                    .fold(f64::INFINITY, f64::min)
            };
            let best = (0..found.len())
                .filter(|&k| found[k].0 == pair && !taken[k])
                .max_by(|&a, &b| far(a).total_cmp(&far(b)));
            if let Some(k) = best {
                taken[k] = true;
                out[count] = found[k].1;
                count += 1;
            }
        }
        if count == before {
            return count;
        }
    }
}

impl RapierWorld {
    /// The world of `spec` for `pointers` pointers.
    pub fn new(spec: &RapierScene, pointers: usize) -> Self {
        let mut physics = PhysicsWorld::new();
        physics.gravity = vector(spec.gravity);
        physics.integration_parameters.dt = (1.0 / spec.rate) as f32;
        physics.integration_parameters.length_unit = length_unit(&spec.bodies) as f32;
        let mut bodies = Vec::with_capacity(spec.bodies.len());
        let mut pieces = Vec::new();
        let mut objects = Vec::with_capacity(spec.bodies.len());
        let held = spec.held.map(|h| h.body as usize);
        for (i, (body, primitives)) in spec.bodies.iter().zip(&spec.primitives).enumerate() {
            let builder = if held == Some(i) {
                RigidBodyBuilder::kinematic_position_based()
            } else if body.fixed {
                RigidBodyBuilder::fixed()
            } else {
                RigidBodyBuilder::dynamic().ccd_enabled(true)
            };
            let handle = physics.insert_body(
                builder
                    .pose(Pose::from_parts(
                        vector(body.position),
                        rotation(body.orientation),
                    ))
                    .linvel(vector(body.velocity))
                    .angvel(vector(body.spin)),
            );
            let surface = spec.surfaces.get(i).and_then(Option::as_ref);
            let colliders: Vec<ColliderBuilder> = match surface {
                Some(surface) if spec.is_trimesh(i) => vec![trimesh(surface)],
                _ => (0..primitives.len())
                    .map(|k| collider(body, k, primitives[k]))
                    .collect(),
            };
            // A mesh's mass and inertia are its closed volume's, not its pieces', and a
            // robot link's are as its description gives them.
            let weighed = spec.weighed.get(i).copied().unwrap_or(false);
            let density = if weighed || surface.is_some() {
                let m = Matrix::from_cols_array(&body.inertia.as_mat3().to_cols_array());
                let mass = MassProperties::with_inertia_matrix(Vector::ZERO, body.mass as f32, m);
                physics.bodies[handle].set_additional_mass_properties(mass, false);
                0.0
            } else {
                let volume: f64 = body.pieces.iter().map(|p| volume_and_centroid(p).0).sum();
                (body.mass / volume) as f32
            };
            objects.push((pieces.len() as u32, colliders.len() as u32));
            for c in colliders {
                // The haptic side pushes what the held body touches (local dynamics): the
                // world's contacts with it would push those twice.
                let c = c
                    .density(density)
                    .friction(spec.friction as f32)
                    .sensor(held == Some(i))
                    .user_data(pieces.len() as u128);
                let c = physics
                    .colliders
                    .insert_with_parent(c, handle, &mut physics.bodies);
                pieces.push((c, i));
            }
            bodies.push(handle);
        }
        let joints = Joints::build(&mut physics, &bodies, &spec.bodies, &spec.joints);
        let mut world = Self {
            physics,
            bodies,
            names: spec.names.clone(),
            pieces,
            pointers: Vec::new(),
            pointer_solid: None,
            inertia: spec.bodies.iter().map(|b| (b.inertia, b.mass)).collect(),
            volumes: spec.bodies.iter().map(|b| b.volume).collect(),
            objects,
            applied: vec![0; spec.bodies.len()],
            left_out: vec![false; spec.bodies.len()],
            feedback: spec.feedback,
            reach: surfaces::reach(spec.rate),
            scratch: Vec::new(),
            joints,
            soft: spec.soft.clone(),
            still: spec.bodies.clone(),
            // A push a pointer a period at most.
            soft_loads: vec![Vec::with_capacity(pointers); spec.soft.len()],
            gives: vec![[HapticdPlaneCompliance::default(); HAPTICD_MAX_PLANES]; pointers],
            held: None,
        };
        world.held = spec.held.map(|h| (world.bodies[h.body as usize], h.grip));
        if let Some((shape, primitive)) = &spec.pointer {
            // Sampled at the physics rate, a pointer jumps centimetres a step: its contacts
            // are predicted along that jump (soft CCD), so it strikes what lies in its path
            // instead of landing inside and being pushed out by position correction alone.
            let jump = world.reach as f32;
            for _ in 0..pointers {
                let handle = world.physics.insert_body(
                    RigidBodyBuilder::kinematic_position_based().soft_ccd_prediction(jump),
                );
                let c = collider(shape, 0, *primitive).friction(spec.friction as f32);
                world
                    .physics
                    .colliders
                    .insert_with_parent(c, handle, &mut world.physics.bodies);
                world.pointers.push(handle);
            }
            world.pointer_solid = Some(PointerSolid::of(shape, *primitive));
        }
        // Only soft bodies meet the pointers' solids here (rapier's own bodies meet its
        // kinematic pointers): a world without one keeps none to move each step.
        if let Some((shape, _)) = spec.pointer.as_ref().filter(|_| !spec.soft.is_empty()) {
            // Placed at their grips: what a soft body presses on them with moves nothing.
            let mut solid = shape.clone();
            solid.kinematic = true;
            world.still.extend(std::iter::repeat_n(solid, pointers));
        }
        let first = world.bodies.len();
        for part in &mut world.soft {
            part.meet(&world.still, first, false);
        }
        world.set_feedback(spec.feedback);
        world
    }

    /// The joints between the bodies.
    pub fn joints(&self) -> &Joints {
        &self.joints
    }

    /// Where joint `k` (in the file's order) is now.
    pub fn joint_state(&self, k: usize) -> JointState {
        self.joints.state(&self.physics, k)
    }

    /// What the world takes back from the hand.
    pub fn feedback(&self) -> Feedback {
        self.feedback
    }

    /// Take `feedback` from the hand from now on. Unless the feedback is by position, the
    /// pointers' bodies are parked far away, where they touch nothing.
    pub fn set_feedback(&mut self, feedback: Feedback) {
        self.feedback = feedback;
        if feedback != Feedback::Position {
            for (k, handle) in self.pointers.iter().enumerate() {
                let away = DVec3::new(1e4 + 10.0 * k as f64, 1e4, 1e4);
                self.physics.bodies[*handle].set_translation(vector(away), false);
            }
        }
    }

    /// How far from a pointer solids are published, metres.
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Number of bodies of the file: the rigid ones, then the soft ones.
    pub fn body_count(&self) -> usize {
        self.bodies.len() + self.soft.len()
    }

    /// Where each body of the file is now, in the file's order.
    pub fn poses(&self) -> Vec<hapticd_core::kinematics::Pose> {
        (0..self.body_count())
            .map(|i| self.body(i).pose())
            .collect()
    }

    /// Body `i` of the file, as it is now (a soft one taken whole: its centre of mass,
    /// turned as its rest shape best fits it).
    pub fn body(&self, i: usize) -> BodyState {
        if let Some(soft) = self.soft_body(i) {
            let body = &soft.body;
            return BodyState {
                position: body.centre(),
                orientation: body.turn(),
                velocity: body.velocity(),
                spin: body.spin(),
            };
        }
        let b = &self.physics.bodies[self.bodies[i]];
        BodyState {
            position: dvec(b.center_of_mass()),
            orientation: dquat(*b.rotation()),
            velocity: dvec(b.linvel()),
            spin: dvec(b.angvel()),
        }
    }

    /// The rigid body that object (collider) `object` belongs to.
    pub fn body_of(&self, object: u32) -> Option<usize> {
        self.pieces.get(object as usize).map(|(_, body)| *body)
    }

    /// The body, rigid or soft, that object `object` belongs to.
    pub fn object_body(&self, object: u32) -> Option<usize> {
        self.body_of(object)
            .or_else(|| Some(self.bodies.len() + self.soft_of_object(object)?))
    }

    /// Which soft body object `object` is.
    fn soft_of_object(&self, object: u32) -> Option<usize> {
        (object as usize)
            .checked_sub(self.pieces.len())
            .filter(|&k| k < self.soft.len())
    }

    /// The soft bodies, in the file's order.
    pub fn soft_bodies(&self) -> &[SoftPart] {
        &self.soft
    }

    /// The soft body of id `i`, if it is one.
    pub(crate) fn soft_body(&self, i: usize) -> Option<&SoftPart> {
        self.soft.get(i.checked_sub(self.bodies.len())?)
    }

    /// The soft body of id `i`, if it is one, to change.
    pub(crate) fn soft_body_mut(&mut self, i: usize) -> Option<&mut SoftPart> {
        let k = i.checked_sub(self.bodies.len())?;
        self.soft.get_mut(k)
    }

    /// Where the corners of the soft bodies' surfaces (the geometry's deforming solids)
    /// stand now, the first ones into `out`; how many there are.
    pub fn corners(&self, out: &mut [[f32; 3]]) -> usize {
        hapticd_physics::scene::soft_corners(&self.soft, out)
    }

    /// How plane `plane` of pointer `pointer`, as the last step published them, gives
    /// under a press: None for a rigid one.
    pub fn compliance(&self, pointer: u32, plane: u32) -> Option<HapticdPlaneCompliance> {
        let give = *self.gives.get(pointer as usize)?.get(plane as usize)?;
        (give.compliance > 0.0).then_some(give)
    }

    /// Push soft body `k` with `impulse` given over `dt`: its mean force over the next step,
    /// where it pressed. What is not finite is ignored.
    fn push_soft(&mut self, k: usize, impulse: &HapticdImpulse, dt: f64) {
        let (j, at) = (DVec3::from(impulse.impulse), DVec3::from(impulse.point));
        let force = j / dt;
        if !(force.is_finite() && at.is_finite()) {
            return;
        }
        self.soft[k].push(at, force);
        self.soft_loads[k].push((at, force));
    }

    /// Under position feedback, put the pointers' solids the soft bodies meet where the
    /// grips are (deforming them by their overlap, the conventional method); else far away.
    fn place_pointer_solids(&mut self, grips: &[HapticdPointer]) {
        let first = self.bodies.len();
        for (k, solid) in self.still.iter_mut().skip(first).enumerate() {
            let grip = grips
                .get(k)
                .map(|g| (DVec3::from(g.position), DVec3::from(g.velocity)));
            (solid.position, solid.velocity) = match grip {
                Some((at, v)) if self.feedback == Feedback::Position && at.is_finite() => {
                    (at, if v.is_finite() { v } else { DVec3::ZERO })
                }
                _ => (DVec3::new(1e4 + 10.0 * k as f64, -1e4, 1e4), DVec3::ZERO),
            };
            solid.update_world_shape();
        }
    }

    /// Add each soft body's surface within reach of `at` to pointer `pointer`'s `out`, with
    /// how it gives before the next step of `dt`.
    fn soft_surfaces_near(&mut self, pointer: usize, at: DVec3, out: &mut HapticdPlanes, dt: f64) {
        let first = self.pieces.len() as u32;
        for k in 0..self.soft.len() {
            let count = out.count as usize;
            if count >= HAPTICD_MAX_PLANES {
                return;
            }
            let Some(near) = self.soft[k]
                .nearest(at)
                .filter(|n| n.distance <= self.reach)
            else {
                continue;
            };
            out.planes[count] = HapticdPlane {
                object: first + k as u32,
                point: near.point.to_array(),
                normal: near.normal.to_array(),
                velocity: near.velocity.to_array(),
            };
            out.count += 1;
            if let (Feedback::Position, Some(solid)) = (self.feedback, &self.pointer_solid) {
                // The surface as the grip point meets it, and as rigid as its step left it.
                let point = near.point + near.normal * solid.extent(-near.normal);
                out.planes[count].point = point.to_array();
                continue;
            }
            // The press the surface stands under: the push taken in nearest it.
            let load = self.soft_loads[k]
                .iter()
                .min_by(|a, b| {
                    a.0.distance(near.point)
                        .total_cmp(&b.0.distance(near.point))
                })
                .map_or(0.0, |(_, force)| (-near.normal).dot(*force).max(0.0));
            let compliance = self.soft[k]
                .compliance(dt, &near.weights, near.normal)
                .unwrap_or(0.0);
            if let Some(give) = self.gives.get_mut(pointer) {
                give[count] = HapticdPlaneCompliance { compliance, load };
            }
        }
    }

    /// Give the body of `impulse.object` the momentum `impulse.impulse` at `impulse.point`:
    /// Δv = J/m, Δω = I⁻¹((p − r) × J), but no more of it than brings the point, along J,
    /// to `hand_speed`: a hand cannot push a body faster than it moves itself (a whole
    /// period's ∫F dt of a finger pressed deep into a light body threw it at tens of metres a
    /// second). Fixed bodies, unknown objects and non-finite impulses are ignored.
    pub fn apply(&mut self, impulse: &HapticdImpulse, hand_speed: f64) {
        let (j, p) = (DVec3::from(impulse.impulse), DVec3::from(impulse.point));
        let Some(body) = self.body_of(impulse.object) else {
            return;
        };
        if !(j.is_finite() && p.is_finite() && hand_speed.is_finite()) {
            return;
        }
        let b = &mut self.physics.bodies[self.bodies[body]];
        let n = j.normalize_or_zero();
        let props = b.mass_properties();
        let arm = p - dvec(props.world_com);
        let turn = dvec(props.effective_world_inv_inertia * vector(arm.cross(n)));
        let inverse_mass = f64::from(props.effective_inv_mass.max_element());
        let mass = 1.0 / (inverse_mass + arm.cross(n).dot(turn));
        let along = dvec(b.velocity_at_point(vector(p))).dot(n);
        let most = ((hand_speed - along).max(0.0) * mass).min(j.length());
        if !(most.is_finite() && most > 0.0) {
            return;
        }
        let handle = self.bodies[body];
        if self.joints.is_link(&self.physics, handle) {
            let dt = f64::from(self.physics.integration_parameters.dt);
            let kick = (n * most, arm.cross(n * most));
            self.joints.kick(&mut self.physics, handle, kick, dt);
        } else {
            let b = &mut self.physics.bodies[handle];
            b.apply_impulse_at_point(vector(n * most), vector(p), true);
        }
    }

    /// Add what the hand did to a body over a period: its centre moved and turned, its
    /// velocities changed. Fixed bodies, unknown bodies and changes that are not finite are
    /// ignored.
    pub fn take_in(&mut self, change: &HapticdLocalState) {
        let i = change.body as usize;
        let Some(&handle) = self.bodies.get(i) else {
            return;
        };
        let [d, r, v, w] = [
            change.displacement,
            change.rotation,
            change.velocity,
            change.spin,
        ]
        .map(DVec3::from);
        if !(d.is_finite() && r.is_finite() && v.is_finite() && w.is_finite()) {
            return;
        }
        let b = &self.physics.bodies[handle];
        if !b.is_dynamic() {
            return;
        }
        if self.joints.is_link(&self.physics, handle) {
            // Its joints set where a link is: what the hand changed goes into their
            // coordinates.
            self.applied[i] = self.applied[i].max(change.sequence);
            let six = |a: DVec3, b: DVec3| Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z);
            articulation::take_in(&mut self.physics, handle, six(d, r), six(v, w));
            return;
        }
        let centre = dvec(b.center_of_mass());
        let turn = DQuat::from_scaled_axis(r);
        let origin = dvec(b.translation());
        let orientation = (turn * dquat(*b.rotation())).normalize();
        let moved = Pose::from_parts(
            vector(centre + d + turn * (origin - centre)),
            rotation(orientation),
        );
        // The haptic side moves a body against its contacts as the last step left them: a
        // body turned far within a period can be taken into a fixed solid no contact of its
        // stood for, where a pose set directly stays (a tipped figure was left 5 cm deep in
        // a 2 cm floor). Such a change is left out: the next period starts from the body as
        // the physics has it. The bound is on the depth, not on each change's: a pressed
        // bunny taken a millimetre deeper every period went through a 2 cm floor in a second.
        let now = self.depth_in_fixed(handle, b.position());
        let deeper = self.depth_in_fixed(handle, &moved) > now.max(SINK);
        self.applied[i] = self.applied[i].max(change.sequence);
        // Said so, so that the haptic side restarts the body from where it is here instead
        // of handing the same change back again and again, its own motion drifting away.
        self.left_out[i] = deeper;
        if deeper {
            return;
        }
        let b = &mut self.physics.bodies[handle];
        b.set_position(moved, false);
        b.set_linvel(b.linvel() + vector(v), false);
        b.set_angvel(b.angvel() + vector(w), true);
    }

    /// How deep body `handle`'s colliders, with the body at `pose`, are in the fixed solids
    /// they overlap, metres (0 when in none; fixed meshes, which the query cannot measure,
    /// are left out).
    fn depth_in_fixed(&self, handle: RigidBodyHandle, pose: &Pose) -> f64 {
        let physics = &self.physics;
        let fixed = physics.colliders.iter().filter(|(_, c)| {
            c.parent()
                .is_none_or(|p| physics.bodies.get(p).is_some_and(|b| b.is_fixed()))
        });
        let mut deepest: f64 = 0.0;
        for (_, solid) in fixed {
            let solid_box = solid.compute_aabb();
            for &mine in physics.bodies[handle].colliders() {
                let mine = &physics.colliders[mine];
                let at = mine
                    .position_wrt_parent()
                    .map_or(*pose, |local| *pose * *local);
                if !mine.shape().compute_aabb(&at).intersects(&solid_box) {
                    continue;
                }
                let contact = rapier3d::parry::query::contact(
                    &at,
                    mine.shape(),
                    solid.position(),
                    solid.shape(),
                    0.0,
                );
                if let Ok(Some(c)) = contact {
                    deepest = deepest.max(-f64::from(c.dist));
                }
            }
        }
        deepest
    }

    /// [physics] The planes of the solids within reach of a pointer at `point`, as a step
    /// publishes them: under position feedback, moved out by the pointers' solid.
    pub fn surfaces_near(&mut self, point: DVec3, out: &mut HapticdPlanes) {
        surfaces::near(&self.physics, point, self.reach, &mut self.scratch, out);
        if let (Feedback::Position, Some(solid)) = (self.feedback, &self.pointer_solid) {
            for plane in &mut out.planes[..out.count as usize] {
                let normal = DVec3::from(plane.normal);
                let point = DVec3::from(plane.point) + normal * solid.extent(-normal);
                plane.point = point.to_array();
            }
        }
    }

    /// How body `i` answers the hand through its joints, None for a free body.
    pub fn mobility(&self, i: usize) -> Option<HapticdMobility> {
        articulation::mobility(&self.physics, *self.bodies.get(i)?)
    }

    /// Body `i` as the haptic side moves it: its state, mass, inertia and contacts now.
    pub fn local_body(&self, i: usize) -> HapticdLocalBody {
        let handle = self.bodies[i];
        let mut out = self.local_state(i);
        let margin = self.reach / 2.0;
        // The other solids the narrow phase pairs it with. Its points were found before the
        // step moved the body: each pair's contact is found again where the body is now (a
        // ball rolled on has its contact at its bottom, not where the roll took the old
        // one), and a pair of several points (a box standing on its face) keeps them,
        // measured from that contact's plane.
        let mut found = [(0, HapticdBodyContact::default()); FOUND];
        let mut paired = [None; FOUND];
        let (pairs, kept) = self.paired_contacts(handle, margin, &mut found, &mut paired);
        let mut count = spread(&found[..kept], pairs, &mut out.contacts);
        // Then the nearest of the fixed solids it could reach in a period that the narrow
        // phase does not see yet (it predicts a fraction of a millimetre): a ball lifted off
        // the floor by a hair, pushed down by the hand, lands on it instead of going through.
        // And a link's joint limits, where its joint holds it to what does not move: a door
        // pushed against its stop between steps stays at it.
        let limits = self.joints.limit_contacts(&self.physics, handle, margin);
        for contact in limits.chain(self.fixed_near(handle, margin, &paired[..pairs])) {
            if count == HAPTICD_MAX_BODY_CONTACTS || !contact.gap.is_finite() {
                break;
            }
            out.contacts[count] = contact;
            count += 1;
        }
        out.contact_count = count as u32;
        out
    }

    /// Body `i` as the haptic side moves it, without its contacts: state, mass and inertia.
    fn local_state(&self, i: usize) -> HapticdLocalBody {
        let b = &self.physics.bodies[self.bodies[i]];
        let state = self.body(i);
        let (inertia, mass) = self.inertia[i];
        let turn = glam::DMat3::from_quat(state.orientation);
        let inverse = turn * inertia.inverse() * turn.transpose();
        let (first_object, object_count) = self.objects[i];
        HapticdLocalBody {
            body: i as u32,
            first_object,
            object_count,
            applied: self.applied[i],
            left_out: u32::from(self.left_out[i]),
            position: state.position.to_array(),
            orientation: hapticd_core::kinematics::quat_to_wxyz(state.orientation),
            velocity: state.velocity.to_array(),
            spin: state.spin.to_array(),
            inverse_mass: 1.0 / mass,
            inverse_inertia: inverse.transpose().to_cols_array(),
            acceleration: (dvec(self.physics.gravity) * f64::from(b.gravity_scale())).to_array(),
            ..HapticdLocalBody::default()
        }
    }

    /// Body `handle`'s contacts with the solids paired with it, found again: (pairs, contacts).
    fn paired_contacts(
        &self,
        handle: RigidBodyHandle,
        margin: f64,
        found: &mut [(usize, HapticdBodyContact); FOUND],
        paired: &mut [Option<ColliderHandle>; FOUND],
    ) -> (usize, usize) {
        let (mut pairs, mut kept) = (0, 0);
        for &collider in self.physics.bodies[handle].colliders() {
            let mine = &self.physics.colliders[collider];
            for pair in self.physics.narrow_phase.contact_pairs_with(collider) {
                let PairContacts::Rigid(contacts) = &pair.contacts else {
                    continue;
                };
                let first = pair.collider1 == collider;
                let other = if first {
                    pair.collider2
                } else {
                    pair.collider1
                };
                let Some(solid) = self.physics.colliders.get(other) else {
                    continue;
                };
                if !self.is_world(handle, solid) || pairs == FOUND {
                    continue;
                }
                let Some(now) = contact_now(mine, solid, margin) else {
                    continue;
                };
                let (at, push) = (DVec3::from(now.point), DVec3::from(now.normal));
                paired[pairs] = Some(other);
                let points = contacts.manifolds.iter().flat_map(|m| &m.points);
                if points.clone().count() < 2 {
                    if kept < FOUND {
                        found[kept] = (pairs, now);
                        kept += 1;
                    }
                } else {
                    for point in points.take(FOUND - kept) {
                        let local = if first {
                            point.local_p1
                        } else {
                            point.local_p2
                        };
                        let p = dvec(mine.position() * local);
                        let contact = HapticdBodyContact {
                            point: p.to_array(),
                            gap: now.gap + (p - at).dot(push),
                            ..now
                        };
                        found[kept] = (pairs, contact);
                        kept += 1;
                    }
                }
                pairs += 1;
            }
        }
        (pairs, kept)
    }

    /// Body `handle`'s contacts with the nearest fixed solids not `paired`, nearest first.
    fn fixed_near(
        &self,
        handle: RigidBodyHandle,
        margin: f64,
        paired: &[Option<ColliderHandle>],
    ) -> [HapticdBodyContact; HAPTICD_MAX_BODY_CONTACTS] {
        let unused = HapticdBodyContact {
            gap: f64::INFINITY,
            ..HapticdBodyContact::default()
        };
        let mut near = [unused; HAPTICD_MAX_BODY_CONTACTS];
        for &collider in self.physics.bodies[handle].colliders() {
            let mine = &self.physics.colliders[collider];
            let aabb = mine.compute_aabb().loosened(margin as f32);
            let query = self
                .physics
                .query_pipeline_with_filter(QueryFilter::default().exclude_rigid_body(handle));
            for (other, solid) in query.intersect_aabb_conservative(aabb) {
                // Moving neighbours will have moved by the time the hand's change is
                // taken in: only fixed solids are contacts to wait on for a period.
                let fixed = solid
                    .parent()
                    .is_none_or(|p| self.physics.bodies.get(p).is_some_and(|b| b.is_fixed()));
                if !fixed || paired.contains(&Some(other)) || !self.is_world(handle, solid) {
                    continue;
                }
                let Some(c) = contact_now(mine, solid, margin) else {
                    continue;
                };
                let farthest = near.iter_mut().max_by(|a, b| a.gap.total_cmp(&b.gap));
                if let Some(slot) = farthest.filter(|slot| c.gap < slot.gap) {
                    *slot = c;
                }
            }
        }
        near.sort_unstable_by(|a, b| a.gap.total_cmp(&b.gap));
        near
    }

    /// Write to `out` the bodies that move near the held body (within the reach of a
    /// period), for the haptic side to move; how many.
    fn near_held(&self, out: &mut [HapticdLocalBody]) -> usize {
        let Some((handle, _)) = self.held else {
            return 0;
        };
        let mut count = 0;
        // The held body and the pointers' solids are kinematic.
        let query = self
            .physics
            .query_pipeline_with_filter(QueryFilter::exclude_kinematic());
        for &collider in self.physics.bodies[handle].colliders() {
            let aabb = self.physics.colliders[collider]
                .compute_aabb()
                .loosened(self.reach as f32);
            for (_, solid) in query.intersect_aabb_conservative(aabb) {
                let Some(body) = self.body_of(solid.user_data as u32) else {
                    continue;
                };
                let listed = out[..count].iter().any(|b| b.body == body as u32);
                if listed
                    || count == out.len()
                    || !self.physics.bodies[self.bodies[body]].is_dynamic()
                {
                    continue;
                }
                out[count] = self.local_body(body);
                count += 1;
            }
        }
        count
    }

    /// Whether `solid` is part of the world body `handle` meets: not a piece of the body
    /// itself, nor a pointer's, nor of a body joined to it (which its joint holds, and
    /// which it does not touch).
    fn is_world(&self, handle: RigidBodyHandle, solid: &Collider) -> bool {
        solid.parent().is_none_or(|p| {
            p != handle
                && self.physics.bodies.get(p).is_none_or(|b| !b.is_kinematic())
                && !self.joints.joins(handle, p)
        })
    }

    /// One step of `dt` seconds with no hand in the world. False when the world is no
    /// longer finite.
    pub fn advance(&mut self, dt: f64) -> bool {
        self.step(
            &PhysicsInput {
                dt,
                pointers: &[],
                proxies: &[],
                impulses: &[],
                locals: &[],
            },
            &mut PhysicsOutput {
                planes: &mut [],
                bodies: &mut [],
                body_count: &mut 0,
            },
        )
    }

    /// [physics] One physics step: take in what the hand did (local changes and impulses,
    /// or the pointers' positions under position feedback), step, and publish each
    /// pointer's planes around its proxy and, under local feedback, the dynamic bodies they
    /// belong to. False when the world is no longer finite.
    pub fn step(&mut self, input: &PhysicsInput<'_>, output: &mut PhysicsOutput<'_>) -> bool {
        // Before the hand's changes, which a jointed body takes in over this step.
        self.physics.integration_parameters.dt = input.dt as f32;
        match self.feedback {
            Feedback::Local | Feedback::Impulse => {
                for change in input.locals {
                    self.take_in(change);
                }
                // The fastest finger bounds every push (an impulse does not say whose it is),
                // as fast as it pushed over the period (its proxy's velocity).
                let hand_speed = input
                    .proxies
                    .iter()
                    .map(|p| DVec3::from(p.velocity).length())
                    .fold(0.0, f64::max);
                for loads in &mut self.soft_loads {
                    loads.clear();
                }
                for impulse in input.impulses {
                    match self.soft_of_object(impulse.object) {
                        Some(k) => self.push_soft(k, impulse, input.dt),
                        None => self.apply(impulse, hand_speed),
                    }
                }
            }
            Feedback::Position => {
                for (handle, p) in self.pointers.iter().zip(input.pointers) {
                    let at = DVec3::from(p.position);
                    if at.is_finite() {
                        self.physics.bodies[*handle].set_next_kinematic_translation(vector(at));
                    }
                }
            }
        }
        if let (Some((handle, grip)), Some(proxy)) = (self.held, input.proxies.first()) {
            let (at, turn) = (
                DVec3::from(proxy.position),
                hapticd_core::kinematics::quat_from_wxyz(proxy.orientation),
            );
            if at.is_finite() && turn.is_finite() && turn.length() > 0.5 {
                let turn = turn.normalize();
                let centre = at - turn * grip;
                self.physics.bodies[handle]
                    .set_next_kinematic_position(Pose::from_parts(vector(centre), rotation(turn)));
            }
        }
        self.joints.before_step(&self.physics);
        self.physics.step();
        self.joints.after_step(&mut self.physics);
        let gravity = dvec(self.physics.gravity);
        self.place_pointer_solids(input.pointers);
        let first = self.bodies.len();
        for part in &mut self.soft {
            // A material or pins changed over the bus are factored here: the physics
            // thread may take the time a device tick may not.
            part.refactor(input.dt);
            part.step(input.dt, gravity, &self.still, first, &mut []);
        }
        // Around the proxy, where the finger rests, or the grip when there is none.
        let around = if input.proxies.len() == input.pointers.len() {
            input.proxies
        } else {
            input.pointers
        };
        for gives in &mut self.gives {
            *gives = [HapticdPlaneCompliance::default(); HAPTICD_MAX_PLANES];
        }
        for (k, (out, p)) in output.planes.iter_mut().zip(around).enumerate() {
            let at = DVec3::from(p.position);
            self.surfaces_near(at, out);
            self.soft_surfaces_near(k, at, out, input.dt);
        }
        *output.body_count = 0;
        if self.feedback == Feedback::Local {
            let mut count = self.near_held(output.bodies);
            let planes = output
                .planes
                .iter()
                .flat_map(|p| &p.planes[..p.count as usize]);
            for plane in planes {
                let Some(body) = self.body_of(plane.object) else {
                    continue;
                };
                let listed = output.bodies[..count].iter().any(|b| b.body == body as u32);
                if listed
                    || count == output.bodies.len()
                    || !self.physics.bodies[self.bodies[body]].is_dynamic()
                {
                    continue;
                }
                output.bodies[count] = self.local_body(body);
                count += 1;
            }
            *output.body_count = count as u32;
        }
        let rigid = (0..self.bodies.len()).all(|i| {
            let b = self.body(i);
            b.position.is_finite() && b.velocity.is_finite() && b.spin.is_finite()
        });
        rigid && self.soft.iter().all(SoftPart::is_finite)
    }
}

/// A world shared by hosts (`hapticd-world`) is this world.
impl hapticd_core::scene::shared_world::Stepped for RapierWorld {
    fn step(&mut self, input: &PhysicsInput<'_>, output: &mut PhysicsOutput<'_>) -> bool {
        RapierWorld::step(self, input, output)
    }

    fn poses(&mut self, poses: &mut [HapticdBodyPose]) -> usize {
        for (i, out) in poses.iter_mut().take(self.body_count()).enumerate() {
            *out = hapticd_core::world_state::body_pose(&self.body(i).pose());
        }
        self.body_count()
    }

    fn mobilities(&self, bodies: &[HapticdLocalBody], out: &mut [Option<HapticdMobility>]) {
        for (out, body) in out.iter_mut().zip(bodies) {
            *out = self.mobility(body.body as usize);
        }
    }

    fn compliances(
        &self,
        planes: &[HapticdPlanes],
        out: &mut [[HapticdPlaneCompliance; HAPTICD_MAX_PLANES]],
    ) {
        for ((out, gives), _) in out.iter_mut().zip(&self.gives).zip(planes) {
            *out = *gives;
        }
    }
}

impl DrivenJoints for RapierWorld {
    fn joint_count(&self) -> usize {
        self.joints.len()
    }

    fn joint(&self, k: usize) -> &Joint {
        self.joints.spec(k)
    }

    fn set_motor(&mut self, k: usize, motor: Option<Motor>) {
        self.joints.set_motor(&mut self.physics, k, motor);
    }

    fn joint_state(&self, k: usize) -> JointState {
        RapierWorld::joint_state(self, k)
    }
}

#[cfg(test)]
mod tests;

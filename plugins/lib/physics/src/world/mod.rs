//! A world of rigid bodies in contact, stepped by the penalty method with forces integrated
//! over each contact's intersection volume (thesis 5.3).

use glam::{DQuat, DVec3};

use super::body::Body;
use super::clip::Clipper;
use hapticd_core::kinematics::Wrench;

use super::friction::{FrictionParameters, FrictionState};
use super::gjk;
use super::polyhedron::Polyhedron;

mod collide;
mod joints;

pub use joints::{Linked, coordinate_bounds};

/// How hard and how damped contacts are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Normal stiffness: force per unit depth per unit area, N/m³.
    pub stiffness: f64,
    /// Normal damping: force per unit approach speed per unit area, N·s/m³.
    pub damping: f64,
    /// Friction.
    pub friction: FrictionParameters,
    /// How contact forces are computed.
    pub model: ContactModel,
    /// When set, each contact's stiffness and damping follow from its pair's reduced mass
    /// and the step instead (the numbers above are then unused).
    pub scaling: Option<Scaling>,
}

/// Stiffness and damping set per contact from the pair's reduced mass m along the
/// direction and the step dt, as Springhead does, so that any pair stays inside the explicit
/// integrator's stability limit: the contact is a spring of 2·`spring`·m/dt² (N/m) on its
/// mean depth and a damper of `damper`·m/dt (N·s/m), spread over the contact area; friction
/// springs likewise with the tangential reduced mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scaling {
    /// Spring ratio r_s (the spring alone would oscillate at √(2·r_s)/dt rad/s).
    pub spring: f64,
    /// Damper ratio r_d.
    pub damper: f64,
}

impl Scaling {
    /// `material` with the stiffness and damping for a contact of `area` (1 for the point
    /// model) whose bodies move 1/m per newton along the normal (`normal_mobility`) and
    /// along the contact (`tangent_mobility`). Pairs contacts cannot move keep `material`.
    fn apply(
        &self,
        material: &mut Material,
        area: f64,
        (normal_mobility, tangent_mobility): (f64, f64),
        dt: f64,
    ) {
        if normal_mobility <= 0.0 || tangent_mobility <= 0.0 || area <= 0.0 {
            return;
        }
        let spring = |mobility: f64| 2.0 * self.spring / (mobility * dt * dt * area);
        let damper = |mobility: f64| self.damper / (mobility * dt * area);
        material.stiffness = spring(normal_mobility);
        material.damping = damper(normal_mobility);
        material.friction.stiffness = spring(tangent_mobility);
        material.friction.damping = damper(tangent_mobility);
    }
}

/// How contact forces are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ContactModel {
    /// Integrated over the intersection volume (the thesis' method): `stiffness` and
    /// `damping` are per unit area.
    #[default]
    Volume,
    /// At the deepest point only, for comparison (thesis Fig. 5.1, 5.12): `stiffness` (N/m)
    /// and `damping` (N·s/m) act there, with sliding friction μ at that point.
    Point,
}

/// Pairs of bodies a world leaves out of its contacts without allocating.
pub const IGNORED_PAIRS: usize = 16;

/// Bodies, gravity and the contact material.
#[derive(Debug, Clone)]
pub struct World {
    /// The bodies.
    pub bodies: Vec<Body>,
    /// Gravity, m/s².
    pub gravity: DVec3,
    /// Material of every contact.
    pub material: Material,
    /// A load on each body besides gravity (a pulling spring, a virtual coupling), its
    /// torque about the body's centroid; it stays until changed.
    pub loads: Vec<Wrench>,
    /// Each body's own friction coefficient, set from outside: a contact takes the lower of
    /// its two bodies' (the material's for a body with none), its static coefficient
    /// scaled with it.
    pub friction: Vec<Option<f64>>,
    /// Pairs of bodies (i < j) whose contacts the steps leave out, such as a held body and
    /// the pointers holding it, whose forces come from the grasp instead. Room for
    /// [`IGNORED_PAIRS`] without allocating.
    pub ignored_pairs: Vec<(usize, usize)>,
    /// The joints between bodies (see [`World::join`]).
    pub joints: Vec<Linked>,
    /// A body placed from outside clear of the fixed bodies (a held part's god-object): its
    /// contacts with them are left out.
    pub guided: Option<usize>,
    clipper: Clipper,
    overlap: Polyhedron,
    wrenches: Vec<Wrench>,
    /// Index of each body's first piece among all bodies' pieces, and their total at the end.
    first_piece: Vec<usize>,
    /// The contact of the pair of pieces (p, q), p < q, at p·P + q (P pieces in all).
    pairs: Vec<Pair>,
    /// The force on each body at the last step (zero on a sleeping one: it is in balance).
    forces: Vec<DVec3>,
    /// Steps taken.
    steps: u64,
    /// Each body's contacts at the last step (they share its motion among their dampers).
    contacts: Vec<u32>,
    /// Each body's contacts so far in this step.
    counting: Vec<u32>,
    /// Each body's bounding box at this step.
    boxes: Vec<Aabb>,
    /// Bodies in order of their boxes' lower ends along the sweep axis.
    order: Vec<usize>,
    /// Whether bodies at rest may sleep (see [`World::step`]).
    pub sleeping: bool,
    /// Which bodies sleep, and where each was put to sleep.
    asleep: Vec<Option<(DVec3, DQuat)>>,
    /// Steps each body has moved slower than [`SLEEP_SPEED`].
    still: Vec<u32>,
    /// The bodies touching in this step, as a union-find forest over body indices.
    island: Vec<usize>,
    /// Whether a pointer moved by hand reaches a body in this step.
    held: Vec<bool>,
    /// The fewest still steps of any body of the island rooted at a body.
    island_still: Vec<u32>,
    /// Whether the last step found every body asleep (and was skipped).
    quiet: bool,
    /// Gravity and loads at the last step: a change wakes the bodies.
    last_gravity: DVec3,
    last_loads: Vec<Wrench>,
}

/// What a world keeps of the contact between two pieces from one step to the next.
#[derive(Debug, Clone, Copy, Default)]
struct Pair {
    /// The step at which they were last in contact.
    touched: u64,
    /// Their contact normal at that step.
    normal: DVec3,
    /// Where the second body was relative to the first (turn, shift, in the first's frame)
    /// when their normal was last searched for, and that normal in the first's frame.
    found: (DQuat, DVec3, DVec3),
    /// The contact force on the second at that step.
    force: DVec3,
    /// Their friction.
    friction: FrictionState,
}

/// A contact of one body with another at the last step, as seen from the first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touching {
    /// The other body.
    pub other: usize,
    /// Where they touch (the contact's centroid), metres.
    pub point: DVec3,
    /// Unit normal along which the other pushes this body.
    pub normal: DVec3,
    /// Whether the contact slides (dynamic friction) rather than sticks.
    pub sliding: bool,
}

/// A body whose every point moves slower than this (m/s) is still.
pub const SLEEP_SPEED: f64 = 1e-3;
/// How long (s) a group of touching bodies must all be still before it sleeps.
pub const SLEEP_AFTER: f64 = 0.5;

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Aabb {
    min: DVec3,
    max: DVec3,
}

impl Aabb {
    /// Contains nothing: growing it by a point gives that point.
    const EMPTY: Aabb = Aabb {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };

    /// The box grown to take in `point`.
    fn grow(self, point: DVec3) -> Aabb {
        Aabb {
            min: self.min.min(point),
            max: self.max.max(point),
        }
    }

    /// The box around every vertex of `pieces`.
    fn around(pieces: &[Polyhedron]) -> Aabb {
        pieces
            .iter()
            .flat_map(|p| &p.vertices)
            .fold(Aabb::EMPTY, |b, v| b.grow(*v))
    }

    fn overlaps(&self, other: &Aabb) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }

    fn centre(&self) -> DVec3 {
        (self.min + self.max) / 2.0
    }
}

/// The axis along which the boxes' centres spread most: sweeping along it leaves the
/// fewest boxes overlapping in that one coordinate.
fn widest_axis(boxes: &[Aabb]) -> usize {
    let centres = boxes
        .iter()
        .fold(Aabb::EMPTY, |b, other| b.grow(other.centre()));
    let spread = centres.max - centres.min;
    if spread.x >= spread.y && spread.x >= spread.z {
        0
    } else if spread.y >= spread.z {
        1
    } else {
        2
    }
}

impl World {
    /// Whether every body's state is finite: a world that overflowed stays broken.
    pub fn is_finite(&self) -> bool {
        self.bodies.iter().all(|b| {
            b.position.is_finite()
                && b.orientation.is_finite()
                && b.velocity.is_finite()
                && b.spin.is_finite()
        })
    }

    /// A world of `bodies`.
    pub fn new(bodies: Vec<Body>, gravity: DVec3, material: Material) -> Self {
        let n = bodies.len();
        let first_piece: Vec<usize> = std::iter::once(0)
            .chain(bodies.iter().scan(0, |count, b| {
                *count += b.pieces.len();
                Some(*count)
            }))
            .collect();
        let pairs = first_piece[n] * first_piece[n];
        let (mut clipper, mut overlap) = (Clipper::default(), Polyhedron::default());
        let faces = bodies
            .iter()
            .flat_map(|b| &b.pieces)
            .map(|p| p.faces.len())
            .max()
            .unwrap_or(0);
        clipper.reserve(faces, &mut overlap);
        Self {
            first_piece,
            pairs: vec![Pair::default(); pairs],
            forces: vec![DVec3::ZERO; n],
            steps: 0,
            contacts: vec![0; n],
            counting: vec![0; n],
            boxes: vec![Aabb::EMPTY; n],
            order: (0..n).collect(),
            sleeping: true,
            asleep: vec![None; n],
            still: vec![0; n],
            island: (0..n).collect(),
            held: vec![false; n],
            island_still: vec![0; n],
            quiet: false,
            last_gravity: gravity,
            last_loads: vec![Wrench::ZERO; n],
            wrenches: vec![Wrench::default(); n],
            loads: vec![Wrench::ZERO; n],
            friction: vec![None; n],
            ignored_pairs: Vec::with_capacity(IGNORED_PAIRS),
            joints: Vec::new(),
            guided: None,
            bodies,
            gravity,
            material,
            clipper,
            overlap,
        }
    }

    /// The contact normal from one piece to another, `theirs`, for their overlap: the
    /// area-weighted face normals of the intersection, faces of the first counted as they
    /// are and faces of `theirs` reversed.
    fn contact_normal(&self, theirs: &Polyhedron) -> DVec3 {
        let theirs = &theirs.planes;
        let mut sum = DVec3::ZERO;
        for (face, plane) in self.overlap.faces.iter().zip(&self.overlap.planes) {
            let v = &self.overlap.vertices;
            let mut area = DVec3::ZERO;
            for k in 1..face.len() - 1 {
                area += (v[face[k]] - v[face[0]]).cross(v[face[k + 1]] - v[face[0]]) / 2.0;
            }
            let sign = if theirs.contains(plane) { -1.0 } else { 1.0 };
            sum += sign * area.length() * plane.normal;
        }
        sum.normalize_or_zero()
    }

    /// The mean of the overlap's vertices: a point inside the contact.
    fn overlap_centre(&self) -> DVec3 {
        let v = &self.overlap.vertices;
        v.iter().sum::<DVec3>() / v.len() as f64
    }

    /// Weight and load of body `i`: what acts on it besides contacts, as a wrench about the
    /// origin (nothing on a body contacts cannot move).
    fn body_wrench(&self, i: usize) -> Wrench {
        self.wrench_under(i, &self.loads)
    }

    /// Weight and load of body `i` under `loads`, as [`World::body_wrench`].
    fn wrench_under(&self, i: usize, loads: &[Wrench]) -> Wrench {
        let b = &self.bodies[i];
        if b.fixed {
            return Wrench::default();
        }
        let force = b.mass * self.gravity + loads[i].force;
        Wrench {
            force,
            torque: b.position.cross(force) + loads[i].torque,
        }
    }

    /// The contact force and torque (about its centroid) on body `i` in the last step (its
    /// load that step's, not one set since).
    pub fn contact_wrench(&self, i: usize) -> Wrench {
        let (w, own) = (self.wrenches[i], self.wrench_under(i, &self.last_loads));
        let force = w.force - own.force;
        let b = &self.bodies[i];
        Wrench {
            force,
            torque: w.torque - own.torque - b.position.cross(force),
        }
    }

    /// The contact normal of thesis 5.3.2: move piece `b` out of piece `a` along the
    /// previous normal until they separate, and take the direction between their closest
    /// points. `None` for a new contact (no previous normal). `size` is the overlap's.
    fn separation_normal(
        &self,
        a: &Polyhedron,
        b: &Polyhedron,
        previous: DVec3,
        size: f64,
    ) -> Option<DVec3> {
        if previous == DVec3::ZERO {
            return None;
        }
        let along = |v: &DVec3| v.dot(previous);
        let extent = self
            .overlap
            .vertices
            .iter()
            .map(along)
            .fold(f64::NEG_INFINITY, f64::max)
            - self
                .overlap
                .vertices
                .iter()
                .map(along)
                .fold(f64::INFINITY, f64::min);
        // Apart by a hundredth of the depth, and by at least a ten-thousandth of the
        // overlap's size: two flush faces pressed 30 nm together and apart by a hundredth of
        // that make a Minkowski difference a million times wider than tall, whose nearest
        // point the search then finds off to the side.
        let gap = extent * 0.01 + size * 1e-4 + 1e-12;
        let (pa, pb) = gjk::closest_points(&a.vertices, &b.vertices, previous * (extent + gap))?;
        // Moved out so, they are at most `gap` apart: a search that stopped farther out
        // missed the nearest points.
        let apart = pb - pa;
        if apart.length() > 2.0 * gap {
            return None;
        }
        apart.try_normalize()
    }

    /// Advance every body by `dt`. Fixed bodies stay where they are put (they may be moved
    /// between steps, like a pointer following the grip).
    ///
    /// Bodies at rest sleep: when every body of a group touching one another (and fixed
    /// bodies) has moved slower than [`SLEEP_SPEED`] at every point for [`SLEEP_AFTER`]
    /// seconds, and no pointer moved by hand reaches it, the group stops where it is and
    /// costs nothing until a moving body or pointer reaches one of its bodies, or gravity,
    /// a load, a velocity or a pose is changed from outside; the bodies then wake with their
    /// contacts and friction springs as they were. So a resting body keeps still to within
    /// what it moves in that half second.
    pub fn step(&mut self, dt: f64) {
        self.wake_the_disturbed();
        // Nothing moves: the step would change nothing. It is not counted either, so the
        // contacts stay those of the last step taken.
        if self.sleeping && (0..self.bodies.len()).all(|i| !self.moves(i)) {
            if !self.quiet {
                self.wrenches.fill(Wrench::ZERO);
                self.forces.fill(DVec3::ZERO);
                self.quiet = true;
            }
            return;
        }
        self.quiet = false;
        for i in 0..self.bodies.len() {
            // Every torque here is about the world origin; a sleeping body is in balance.
            self.wrenches[i] = if self.asleep[i].is_some() {
                Wrench::ZERO
            } else {
                self.body_wrench(i)
            };
            self.island[i] = i;
            self.held[i] = false;
        }
        // Broad phase: sort and sweep the bounding boxes along one axis.
        self.steps += 1;
        for (bounding, b) in self.boxes.iter_mut().zip(&self.bodies) {
            *bounding = Aabb::around(b.world_pieces());
        }
        let axis = widest_axis(&self.boxes);
        // Insertion sort: the order barely changes between steps, so this is near-linear,
        // and it works in place.
        let key = |k: usize| self.boxes[k].min[axis];
        for sorted in 1..self.order.len() {
            let mut k = sorted;
            while k > 0 && key(self.order[k - 1]) > key(self.order[k]) {
                self.order.swap(k - 1, k);
                k -= 1;
            }
        }
        let n = self.bodies.len();
        // First wake what moving bodies reach, then take the contacts: a body woken in the
        // middle of the second pass would miss the contacts taken before it.
        for waking in [true, false] {
            for first in 0..n {
                for second in first + 1..n {
                    let (p, q) = (self.order[first], self.order[second]);
                    if self.boxes[q].min[axis] > self.boxes[p].max[axis] {
                        break;
                    }
                    if !self.boxes[p].overlaps(&self.boxes[q]) {
                        continue;
                    }
                    let (i, j) = (p.min(q), p.max(q));
                    if waking {
                        self.reach(i, j);
                    } else {
                        self.meet(i, j, dt);
                    }
                }
            }
        }
        self.add_joint_wrenches(dt);
        std::mem::swap(&mut self.contacts, &mut self.counting);
        self.counting.fill(0);
        for ((b, force), (w, asleep)) in self
            .bodies
            .iter_mut()
            .zip(&mut self.forces)
            .zip(self.wrenches.iter().zip(&self.asleep))
        {
            *force = w.force;
            if asleep.is_none() {
                // Torques were taken about the origin; the body turns about its centroid.
                let torque = w.torque - b.position.cross(w.force);
                b.integrate(w.force, torque, dt);
            }
        }
        self.stop_joints();
        for link in &mut self.joints {
            link.follow(&self.bodies);
        }
        if self.sleeping {
            self.fall_asleep(dt);
        }
    }

    /// Join the bodies by `joints` as they are placed now. Jointed bodies do not touch each
    /// other, and a world with joints never sleeps (its joints' springs hold it).
    pub fn join(&mut self, joints: &[crate::joint::Joint]) {
        self.joints = joints
            .iter()
            .map(|j| Linked::new(j, &self.bodies))
            .collect();
        if !self.joints.is_empty() {
            self.sleeping = false;
        }
    }

    /// Where joint `k` stands now (a hinge counted in whole turns from load).
    pub fn joint_state(&self, k: usize) -> crate::joint::JointState {
        self.joints[k].counted(&self.bodies)
    }

    /// Whether bodies `i` and `j` are joined.
    fn joined(&self, i: usize, j: usize) -> bool {
        self.joints.iter().any(|l| {
            let (a, b) = (l.joint.bodies.0, l.joint.bodies.1);
            (a == Some(i) && b == j) || (a == Some(j) && b == i)
        })
    }

    /// Whether body `i` moves this step: awake and free, or a pointer moved by hand.
    fn moves(&self, i: usize) -> bool {
        let b = &self.bodies[i];
        self.asleep[i].is_none() && (!b.fixed || b.kinematic)
    }

    /// Bodies `i` and `j` overlap in the broad phase: a moving one wakes a sleeping one,
    /// and a pointer moved by hand keeps the other awake (a body it holds too, whose
    /// contacts with it are left out).
    fn reach(&mut self, i: usize, j: usize) {
        match (self.moves(i), self.moves(j)) {
            (true, false) => self.wake(j),
            (false, true) => self.wake(i),
            _ => {}
        }
        let by_hand = |k: usize| self.bodies[k].fixed && self.bodies[k].kinematic;
        if by_hand(i) || by_hand(j) {
            self.held[i] = true;
            self.held[j] = true;
        }
    }

    /// Bodies `i` < `j` overlap in the broad phase: add their contact wrenches and join
    /// their islands; two that do not move keep their contacts as they were.
    fn meet(&mut self, i: usize, j: usize, dt: f64) {
        if !self.moves(i) && !self.moves(j) {
            self.keep_contacts(i, j);
            return;
        }
        if self.collide(i, j, dt) && !self.bodies[i].fixed && !self.bodies[j].fixed {
            let (ri, rj) = (self.root(i), self.root(j));
            self.island[ri] = rj;
        }
    }

    /// The root of body `i`'s island.
    fn root(&mut self, mut i: usize) -> usize {
        while self.island[i] != i {
            self.island[i] = self.island[self.island[i]];
            i = self.island[i];
        }
        i
    }

    /// Keep the contacts between the pieces of bodies `i` and `j` that touched at the last
    /// step as they are (neither moves).
    fn keep_contacts(&mut self, i: usize, j: usize) {
        let pieces = self.first_piece[self.bodies.len()];
        for p in self.first_piece[i]..self.first_piece[i + 1] {
            for q in self.first_piece[j]..self.first_piece[j + 1] {
                let pair = p * pieces + q;
                if self.pairs[pair].touched + 1 == self.steps {
                    self.pairs[pair].touched = self.steps;
                    self.counting[i] += 1;
                    self.counting[j] += 1;
                }
            }
        }
    }

    /// Body `i`'s strongest contact at the last step (of all its pieces' with any other
    /// body's), if it touched anything. Allocates nothing.
    pub fn strongest_contact(&self, i: usize) -> Option<Touching> {
        let pieces = self.first_piece[self.bodies.len()];
        let mut best: Option<(f64, Touching)> = None;
        for p in self.first_piece[i]..self.first_piece[i + 1] {
            for (other, q) in (0..self.bodies.len())
                .flat_map(|j| (self.first_piece[j]..self.first_piece[j + 1]).map(move |q| (j, q)))
            {
                if other == i {
                    continue;
                }
                // Stored under the lower piece number, its normal pushing the higher one.
                let (pair, sign) = if p < q {
                    (p * pieces + q, -1.0)
                } else {
                    (q * pieces + p, 1.0)
                };
                let pair = &self.pairs[pair];
                if pair.touched != self.steps || self.steps == 0 {
                    continue;
                }
                let strength = pair.force.length();
                if best.is_none_or(|(s, _)| strength > s) {
                    let touching = Touching {
                        other,
                        point: pair.friction.centre(),
                        normal: sign * pair.normal,
                        sliding: pair.friction.sliding,
                    };
                    best = Some((strength, touching));
                }
            }
        }
        best.map(|(_, t)| t)
    }

    /// Put body `i` at a pose from outside: its contacts start afresh (friction springs
    /// stretched to where it was would yank it back) and it wakes.
    pub fn teleport(&mut self, i: usize, position: DVec3, orientation: DQuat) {
        let b = &mut self.bodies[i];
        (b.position, b.orientation) = (position, orientation.normalize());
        b.update_world_shape();
        let pieces = self.first_piece[self.bodies.len()];
        for p in self.first_piece[i]..self.first_piece[i + 1] {
            for q in 0..pieces {
                self.pairs[p * pieces + q].touched = 0;
                self.pairs[q * pieces + p].touched = 0;
            }
        }
        self.wake(i);
    }

    /// The friction coefficient of body `i`'s contacts.
    pub fn friction_of(&self, i: usize) -> f64 {
        self.friction[i].unwrap_or(self.material.friction.dynamic_coefficient)
    }

    /// `material` with the friction of a contact between bodies `i` and `j`.
    fn pair_friction(&self, material: &mut Material, i: usize, j: usize) {
        if self.friction[i].is_none() && self.friction[j].is_none() {
            return;
        }
        let f = &mut material.friction;
        let mu = self.friction_of(i).min(self.friction_of(j));
        let ratio = if f.dynamic_coefficient > 0.0 {
            f.static_coefficient / f.dynamic_coefficient
        } else {
            1.0
        };
        (f.dynamic_coefficient, f.static_coefficient) = (mu, mu * ratio);
    }

    /// Wake body `i`.
    fn wake(&mut self, i: usize) {
        if self.asleep[i].take().is_some() {
            self.still[i] = 0;
            self.wrenches[i] = self.body_wrench(i);
        }
    }

    /// Wake the sleeping bodies that something changed from outside since the last step:
    /// gravity, their load, their velocity or their pose (or all, with sleeping off).
    fn wake_the_disturbed(&mut self) {
        let gravity = self.gravity != self.last_gravity;
        self.last_gravity = self.gravity;
        for i in 0..self.bodies.len() {
            let b = &self.bodies[i];
            let disturbed = self.asleep[i].is_some_and(|(position, orientation)| {
                gravity
                    || self.loads[i] != self.last_loads[i]
                    || b.velocity != DVec3::ZERO
                    || b.spin != DVec3::ZERO
                    || b.position != position
                    || b.orientation != orientation
            });
            if disturbed || !self.sleeping {
                self.asleep[i] = None;
            }
            self.last_loads[i] = self.loads[i];
        }
    }

    /// Count each free body's still steps, and put to sleep the islands whose every body
    /// has been still long enough and that no pointer moved by hand reaches.
    fn fall_asleep(&mut self, dt: f64) {
        let n = self.bodies.len();
        for i in 0..n {
            if !self.awake(i) {
                continue;
            }
            let b = &self.bodies[i];
            let reach = (self.boxes[i].max - self.boxes[i].min).length() / 2.0;
            let slow = b.velocity.length() + b.spin.length() * reach < SLEEP_SPEED;
            self.still[i] = if slow {
                self.still[i].saturating_add(1)
            } else {
                0
            };
            self.island_still[i] = u32::MAX;
        }
        for i in 0..n {
            if self.awake(i) {
                let r = self.root(i);
                let still = if self.held[i] { 0 } else { self.still[i] };
                self.island_still[r] = self.island_still[r].min(still);
            }
        }
        let needed = (SLEEP_AFTER / dt).ceil() as u32;
        for i in 0..n {
            if self.awake(i) {
                let r = self.root(i);
                if self.island_still[r] >= needed {
                    let b = &mut self.bodies[i];
                    b.velocity = DVec3::ZERO;
                    b.spin = DVec3::ZERO;
                    self.asleep[i] = Some((b.position, b.orientation));
                }
            }
        }
    }

    /// Whether body `i` is free to move and awake.
    fn awake(&self, i: usize) -> bool {
        !self.bodies[i].fixed && self.asleep[i].is_none()
    }

    /// Whether body `i` sleeps.
    pub fn is_asleep(&self, i: usize) -> bool {
        self.asleep[i].is_some()
    }
}

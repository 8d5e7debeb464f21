//! The 6-DOF god-object of a held part (thesis 7.2; Ortega et al. 2007, Wang et al. 2013):
//! the part has a proxy pose that follows the grip's but never enters what it touches, and
//! the user feels the 6-DOF spring between the grip and the proxy.
//!
//! Each tick the part's exact mesh is queried against every obstacle's both ways (the
//! part's samples against the obstacle's triangles, the obstacle's samples against the
//! part's, see [`SignedMesh`]), within the reach of this tick's motion. Each contact is a
//! linear constraint on the proxy's small motion δ = (v, ω): the contact point moves no
//! closer than its gap, n·(v + ω × r) ≥ −gap. The proxy moves by the δ that stretches the
//! spring least in its own metric, K = diag(k, k, k, kᵣ, kᵣ, kᵣ), subject to them: in
//! that metric the shortest motion into the constraints' polyhedron, a least-distance
//! problem solved exactly ([`LeastDistance`]), each contact's push its multiplier. At the
//! solution the spring's pull balances the contacts' push, so what the user feels is
//! exactly the contacts' wrench, as statics has it. (Projected Gauss–Seidel over the
//! contacts crawls where a peg's edge lies along a rim's, rows a few degrees apart: the
//! torque felt there chattered by a tenth of itself.)
//!
//! Friction (Coulomb's, one coefficient μ) holds each contact point still along its two
//! tangents, with a force no larger than μ times the contact's push: Gauss–Seidel sweeps
//! over the tangents, warm-started from the last tick's, give each tangent the force that
//! cancels the point's sliding, clamped to that cone's edge (a box of two tangents), in
//! rounds alternating with the pushes' exact solve. Held, the part stays where it was put
//! until the hand pulls it sideways harder than μ times how hard it presses; sliding, the
//! hand feels that much.
//!
//! Time-critical, it degrades and does not overrun: contacts past [`CONTACTS`] are left for
//! the next tick (the deepest taken first), and the proxy then moves no farther than the
//! nearest one left; the rounds and sweeps are bounded, and the solve is cut back to what
//! the contacts allow; a tick that finds more candidates than its table holds, or whose
//! pushes need more steps than their solve takes, keeps the last pose. On a real-time
//! thread ([`GodObject::keep_to_the_clock`]) a query that runs past its share of the tick
//! stops where it is and goes on at the next tick, the proxy held where it was meanwhile:
//! a pose whose query takes two ticks is moved from every other tick, never frozen, as it
//! would be if each tick began the query again and timed out the same way.

use std::time::{Duration, Instant};

use glam::{DAffine3, DQuat, DVec3};

use super::bvh::PairWalk;
use super::least_distance::LeastDistance;
use super::signed_mesh::{Near, SignedMesh};
use crate::kinematics::{Wrench, rotation_vector};

/// Most contacts a tick solves over.
pub const CONTACTS: usize = 64;
/// Gauss–Seidel sweeps over the contacts' tangents in a round of the friction.
pub const SWEEPS: usize = 20;
/// Most rounds of friction and pushes in a tick.
const ROUNDS: usize = 10;
/// Most steps of the pushes' exact solve in a round: a tick that needs more keeps its pose.
const LEAST_STEPS: usize = 8 * CONTACTS;
/// Samples a query may find near one obstacle: a tick finding more keeps its last pose.
pub const CANDIDATES: usize = 3072;
/// Slots of the table the candidates are gathered in (a power of two, well over
/// [`CANDIDATES`] so that probes stay short).
const SLOTS: usize = 4096;
/// The share of a tick (by the wall clock) that a god-object keeping to the clock gives its
/// contact query: the rest is the solve's (bounded by its steps), the device's and the
/// strings' tensions'.
pub const QUERY_SHARE: f64 = 0.4;
/// How far a contact may still be violated when the solve stops, metres.
const TOLERANCE: f64 = 1e-8;
/// The least reach of a tick's query, metres: contacts resting within rounding of zero gap
/// are always found.
const MIN_REACH: f64 = 2e-5;
/// Features of one sample whose normals are closer than this (cosine: 3°, as a flat
/// stretch's) are one constraint: the nearer is kept. Two faces meeting at a shallow inward
/// fold are both kept: the nearer alone lets a sample slide along it through the other.
const SAME_SIDE: f64 = FLAT_COSINE;

/// The spring and damper the user feels and how far the proxy may move in a tick.
///
/// A spring displayed a tick at a time gives back k·T/2 per unit speed squared more than
/// it took (T the tick); a damper past that, b > k·T/2 (Colgate and Schenkel), keeps the
/// whole passive, as the defaults are at 1 kHz. It acts only on the grip's motion relative
/// to the proxy's: none when the part moves freely with the hand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GodObjectParameters {
    /// Spring between grip and proxy, N/m.
    pub stiffness: f64,
    /// Damper between grip and proxy, N·s/m.
    pub damping: f64,
    /// Rotational spring between grip and proxy, N·m/rad.
    pub rotational_stiffness: f64,
    /// Rotational damper between grip and proxy, N·m·s/rad.
    pub rotational_damping: f64,
    /// Farthest any point of the part moves in one tick, metres: a hand far from the
    /// proxy (at the start, or pressed deep) is caught up with at this pace.
    pub max_step: f64,
    /// Coulomb's coefficient of friction at every contact (0, or anything but a finite
    /// positive number: none).
    pub friction: f64,
}

impl Default for GodObjectParameters {
    fn default() -> Self {
        Self {
            stiffness: 2_000.0,
            damping: 5.0,
            rotational_stiffness: 2.0,
            rotational_damping: 5e-3,
            max_step: 2e-3,
            friction: 0.0,
        }
    }
}

/// Something the held part cannot enter, where it is now.
#[derive(Debug, Clone, Copy)]
pub struct Obstacle<'a> {
    /// Its surface, in its own frame.
    pub mesh: &'a SignedMesh,
    /// Where its frame is.
    pub position: DVec3,
    /// How its frame is turned.
    pub orientation: DQuat,
}

/// One contact of the part at the start of a tick.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Contact {
    /// The obstacle touched, its place in the list the tick was given.
    pub obstacle: usize,
    /// The point of the part that touches, in the world.
    pub point: DVec3,
    /// Unit normal along which the obstacle pushes the part.
    pub normal: DVec3,
    /// How far apart they are along it, metres: negative where the part is inside.
    pub gap: f64,
    /// The force the obstacle pushes with, newtons, once the tick is solved.
    pub force: f64,
    /// The friction the obstacle holds the part with, newtons, across the normal.
    pub friction: DVec3,
    /// Which sample and feature it is, to warm-start the next tick.
    key: u64,
}

/// What a tick gives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GodObjectOutput {
    /// The wrench on the hand: force, and torque about the grip.
    pub felt: Wrench,
    /// The deepest the part was found inside anything at the start of the tick, metres
    /// (0 when nowhere).
    pub penetration: f64,
    /// Whether the tick kept the last pose: it found too much to look at, or its query,
    /// out of time, goes on at the next tick.
    pub held_back: bool,
}

/// One sample's features near an obstacle: the nearest, and others facing other ways.
#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    /// The sample, plus one (0 for an empty slot).
    sample: u32,
    kept: [Option<Near>; 3],
}

impl Slot {
    /// Take `near` in: the nearest feature first whatever its side, then up to two others
    /// outside the obstacle, seen from within their normal cones, and facing more than 45°
    /// away from those kept.
    fn take(&mut self, near: Near) {
        let Some(first) = self.kept[0] else {
            self.kept[0] = Some(near);
            return;
        };
        let near = if near.distance.abs() < first.distance.abs() {
            self.kept[0] = Some(near);
            first
        } else {
            near
        };
        // Behind a face that is not the nearest is not inside the solid: such a feature
        // is a far side, no constraint; nor is an edge or corner seen from outside its
        // normal cone (one inside a flat stretch, seen from beside it).
        if near.distance <= 0.0 || !near.facing {
            return;
        }
        for k in 0..3 {
            match self.kept[k] {
                Some(other) if other.normal.dot(near.normal) > SAME_SIDE => {
                    if k > 0 && near.distance < other.distance {
                        self.kept[k] = Some(near);
                    }
                    return;
                }
                Some(_) => {}
                None => {
                    self.kept[k] = Some(near);
                    return;
                }
            }
        }
        if let Some(far) = (1..3).max_by(|&a, &b| {
            let d = |k: usize| self.kept[k].map_or(f64::INFINITY, |n| n.distance);
            d(a).total_cmp(&d(b))
        }) && self.kept[far].is_some_and(|f| near.distance < f.distance)
        {
            self.kept[far] = Some(near);
        }
    }
}

/// The table a query gathers its candidates in: a slot per sample found, open addressing,
/// emptied after each query by the slots it used.
#[derive(Debug, Clone)]
struct Table {
    slots: Vec<Slot>,
    used: Vec<u32>,
}

/// How a gathering of candidates ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Gathered {
    /// Every candidate is in the table.
    Done,
    /// More than [`CANDIDATES`] came near.
    Full,
    /// The clock passed the deadline: the walk holds where to go on from.
    Stopped,
}

impl Table {
    fn new() -> Self {
        Self {
            slots: vec![Slot::default(); SLOTS],
            used: Vec::with_capacity(CANDIDATES),
        }
    }

    /// [rt] Gather, for each sample of `samples` (placed in `triangles`' frame by
    /// `placed`), its features on `triangles` within `reach`, `walk` going on from where it
    /// stands, until done or the clock passes `deadline`.
    fn gather(
        &mut self,
        triangles: &SignedMesh,
        samples: &SignedMesh,
        ((turn, shift), reach): ((DQuat, DVec3), f64),
        (walk, deadline): (&mut PairWalk, Option<Instant>),
    ) -> Gathered {
        let mut full = false;
        let placed = DAffine3::from_rotation_translation(turn, shift);
        // The sample last placed: pairs come a sample's triangles in a row.
        let mut last = (usize::MAX, DVec3::ZERO);
        let done = triangles.walk_near(samples, (placed, reach), walk, deadline, |s, t| {
            if full {
                return;
            }
            if last.0 != s {
                last = (s, placed.transform_point3(samples.samples()[s]));
            }
            let Some(near) = triangles.near_within(t, last.1, reach) else {
                return;
            };
            match self.slot(s) {
                Some(slot) => slot.take(near),
                None => full = true,
            }
        });
        match (full, done) {
            (true, _) => Gathered::Full,
            (false, true) => Gathered::Done,
            (false, false) => Gathered::Stopped,
        }
    }

    /// [rt] The slot of `sample`, taken if it has none; None when the table is full.
    fn slot(&mut self, sample: usize) -> Option<&mut Slot> {
        let key = sample as u32 + 1;
        let mut i = (key.wrapping_mul(0x9e37_79b1) >> (32 - SLOTS.trailing_zeros())) as usize;
        loop {
            match self.slots[i].sample {
                s if s == key => return Some(&mut self.slots[i]),
                0 => {
                    if self.used.len() >= CANDIDATES {
                        return None;
                    }
                    self.slots[i].sample = key;
                    self.used.push(i as u32);
                    return Some(&mut self.slots[i]);
                }
                _ => i = (i + 1) & (SLOTS - 1),
            }
        }
    }

    /// [rt] Empty the slots used.
    fn clear(&mut self) {
        for &i in &self.used {
            self.slots[i as usize] = Slot::default();
        }
        self.used.clear();
    }
}

/// The contacts of a tick: those found, then the few that stand for them.
///
/// Contacts along one flat stretch of an obstacle (the same obstacle, normals within
/// [`FLAT_COSINE`], the same plane to within [`SAME_PLANE`]) are one cluster. Each of their
/// constraints n·(v + ω × r) ≥ −gap is affine in the point r where the surfaces are flat,
/// so those at the corners of the cluster's spread, reckoned with their gaps, imply the rest:
/// each cluster keeps the points farthest along eight directions across its normal, each
/// weighed against its gap, and its deepest.
#[derive(Debug, Clone)]
struct Found {
    raw: Vec<Contact>,
    clusters: Vec<Cluster>,
    contacts: [Contact; CONTACTS],
    count: usize,
    /// The smallest gap of those left out (infinite when none was).
    spill: f64,
}

/// Contacts found before they are reduced, at most.
const RAW: usize = 4096;
/// Clusters a tick sorts its contacts into, at most.
const CLUSTERS: usize = 128;
/// Normals of one cluster are within this (cosine: 3°).
const FLAT_COSINE: f64 = 0.9986;
/// Contacts of one cluster lie on planes this close, metres.
const SAME_PLANE: f64 = 2e-4;
/// The directions across a cluster's normal its extreme points are taken along, and its
/// deepest.
const EXTREMES: usize = 9;

/// Contacts along one flat stretch.
#[derive(Debug, Clone, Copy)]
struct Cluster {
    obstacle: usize,
    normal: DVec3,
    /// The obstacle's plane: n·q for a point q of its surface.
    offset: f64,
    across: (DVec3, DVec3),
    /// For each direction, the best score so far and its contact among the raw ones.
    best: [(f64, u32); EXTREMES],
}

impl Found {
    fn new() -> Self {
        Self {
            raw: Vec::with_capacity(RAW),
            clusters: Vec::with_capacity(CLUSTERS),
            contacts: [Contact::default(); CONTACTS],
            count: 0,
            spill: f64::INFINITY,
        }
    }

    /// [rt] Start a tick.
    fn clear(&mut self) {
        self.raw.clear();
        self.clusters.clear();
        (self.count, self.spill) = (0, f64::INFINITY);
    }

    /// [rt] Take `contact` in, or count it as left out when there is no room.
    fn add(&mut self, contact: Contact) {
        if self.raw.len() < RAW {
            self.raw.push(contact);
        } else {
            self.spill = self.spill.min(contact.gap);
        }
    }

    /// [rt] Sort the contacts found into clusters and keep those that stand for each, for a
    /// tick that turns the part by at most `turn` radians.
    fn reduce(&mut self, turn: f64) {
        for (i, c) in self.raw.iter().enumerate() {
            let offset = c.normal.dot(c.point) - c.gap;
            let found = self.clusters.iter().position(|k| {
                k.obstacle == c.obstacle
                    && k.normal.dot(c.normal) > FLAT_COSINE
                    && (k.offset - offset).abs() < SAME_PLANE
            });
            let cluster = match found {
                Some(k) => &mut self.clusters[k],
                None if self.clusters.len() < CLUSTERS => {
                    self.clusters.push(Cluster {
                        obstacle: c.obstacle,
                        normal: c.normal,
                        offset,
                        across: c.normal.any_orthonormal_pair(),
                        best: [(f64::NEG_INFINITY, 0); EXTREMES],
                    });
                    self.clusters.last_mut().expect("just pushed")
                }
                None => {
                    self.spill = self.spill.min(c.gap);
                    continue;
                }
            };
            let (a, b) = cluster.across;
            // A constraint n·(v + ω × r) + gap is affine in the point across the cluster and
            // in its gap: the least over the cluster, for a turn of at most `turn`, is at
            // a point farthest along some direction d across it by turn·d·r − gap. The gap
            // weighs in: where a crease of the part lies on a face, the points along it
            // are the deepest, and those beside it, farther out, recede.
            let (x, y) = (c.point.dot(a) * turn, c.point.dot(b) * turn);
            let scores = [x, -x, y, -y, x + y, -x - y, x - y, y - x, 0.0].map(|s| s - c.gap);
            for (best, score) in cluster.best.iter_mut().zip(scores) {
                if score > best.0 {
                    *best = (score, i as u32);
                }
            }
        }
        for k in 0..self.clusters.len() {
            let best = self.clusters[k].best;
            for (e, &(_, i)) in best.iter().enumerate() {
                // A point extreme along several directions is kept once.
                if best[..e].iter().all(|&(_, j)| j != i) {
                    self.keep(self.raw[i as usize]);
                }
            }
        }
    }

    /// [rt] Keep `contact` if it is among the deepest.
    fn keep(&mut self, contact: Contact) {
        if self.count < CONTACTS {
            self.contacts[self.count] = contact;
            self.count += 1;
            return;
        }
        let (shallowest, gap) = (self.contacts.iter().enumerate())
            .map(|(i, c)| (i, c.gap))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, f64::NEG_INFINITY));
        if contact.gap < gap {
            self.spill = self.spill.min(gap);
            self.contacts[shallowest] = contact;
        } else {
            self.spill = self.spill.min(contact.gap);
        }
    }
}

/// The warm-start key of a contact: obstacle `o`, which way round the query went, the
/// sample, and which of its features.
fn key(o: usize, side: usize, sample: u32, feature: usize) -> u64 {
    ((o as u64) << 36) | ((side as u64) << 34) | (u64::from(sample) << 2) | feature as u64
}

/// The god-object of one held part.
#[derive(Debug, Clone)]
pub struct GodObject {
    part: SignedMesh,
    position: DVec3,
    orientation: DQuat,
    parameters: GodObjectParameters,
    found: Found,
    /// Last tick's contacts' keys, forces and friction.
    previous: [(u64, f64, DVec3); CONTACTS],
    previous_count: usize,
    /// The query's reach this tick, metres.
    reach: f64,
    table: Table,
    /// The grip's pose at the last tick.
    last_grip: Option<(DVec3, DQuat)>,
    /// The pushes' exact solve.
    least: LeastDistance,
    /// The walk of the query's trees, kept while a query waits for the next tick.
    walk: PairWalk,
    /// Whether a tick's query keeps to [`QUERY_SHARE`] of the tick.
    on_the_clock: bool,
    /// Where a query out of time stopped.
    pending: Option<Pending>,
}

/// Where a query that ran out of time stopped: the obstacle and the way round it was
/// gathering, and what the obstacles up to it looked like, so that the next tick goes on
/// only if none of them moved.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Pending {
    obstacle: usize,
    side: usize,
    print: u64,
}

/// [rt] `print` mixed with obstacle `o`'s surface and place: a digest that changes when
/// any obstacle moves at all, or another takes its place in the list.
fn fingerprint(print: u64, o: usize, obstacle: &Obstacle) -> u64 {
    let (p, q) = (obstacle.position, obstacle.orientation);
    let surface = std::ptr::from_ref(obstacle.mesh) as u64;
    [o as u64, surface]
        .into_iter()
        .chain([p.x, p.y, p.z, q.x, q.y, q.z, q.w].map(f64::to_bits))
        .fold(print, |h, v| (h ^ v).wrapping_mul(0x0000_0100_0000_01b3))
}

/// How a tick's query ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Query {
    /// Every contact within reach is found.
    Found,
    /// More candidates than the table holds: the tick keeps its pose and looks close next.
    TooMany,
    /// Out of time: it goes on at the next tick, the pose held.
    Unfinished,
}

impl GodObject {
    /// The god-object of `part` (its mesh in its own frame, the grip holding that frame's
    /// origin), starting at `position` and `orientation`.
    pub fn new(
        part: SignedMesh,
        position: DVec3,
        orientation: DQuat,
        parameters: GodObjectParameters,
    ) -> Self {
        Self {
            part,
            position,
            orientation: orientation.normalize(),
            parameters,
            found: Found::new(),
            previous: [(0, 0.0, DVec3::ZERO); CONTACTS],
            previous_count: 0,
            reach: parameters.max_step,
            table: Table::new(),
            last_grip: None,
            least: LeastDistance::default(),
            walk: PairWalk::default(),
            on_the_clock: false,
            pending: None,
        }
    }

    /// Keep each tick's contact query to [`QUERY_SHARE`] of the tick by the wall clock: a
    /// query out of time goes on at the next tick, the proxy held where it was until it is
    /// done. For a god-object on a real-time thread; one run in simulated time (an
    /// experiment, a test) leaves it off and comes out the same on every run.
    pub fn keep_to_the_clock(&mut self) {
        self.on_the_clock = true;
    }

    /// Where the proxy is.
    pub fn pose(&self) -> (DVec3, DQuat) {
        (self.position, self.orientation)
    }

    /// The part's mesh.
    pub fn part(&self) -> &SignedMesh {
        &self.part
    }

    /// The contacts of the last tick, their forces solved.
    pub fn contacts(&self) -> &[Contact] {
        &self.found.contacts[..self.found.count]
    }

    /// [rt] Move the proxy towards the grip at `grip` (position, orientation) as far as the
    /// `obstacles` let it, `dt` after the last tick, and give the wrench the user feels.
    /// Allocates nothing (the obstacles come as an iterator, so that a scene can give its
    /// own without gathering them).
    pub fn update<'m>(
        &mut self,
        grip: (DVec3, DQuat),
        dt: f64,
        obstacles: impl IntoIterator<Item = Obstacle<'m>>,
    ) -> GodObjectOutput {
        let (grip_position, grip_orientation) = grip;
        let (was, was_turned) = (self.position, self.orientation);
        // Reading the clock takes no lock and no system call (the vDSO's).
        let deadline = (self.on_the_clock && dt > 0.0)
            .then(|| Instant::now() + Duration::from_secs_f64((QUERY_SHARE * dt).min(1.0)));
        let query = self.find_contacts(obstacles, deadline);
        let penetration = self.contacts().iter().map(|c| -c.gap).fold(0.0, f64::max);
        if query == Query::Found {
            let wanted = (
                grip_position - self.position,
                rotation_vector(grip_orientation * self.orientation.inverse()),
            );
            let (v, w) = self.solve(wanted);
            let motion = v.length() + w.length() * self.part.radius();
            // No point may go beyond what this tick looked at, nor pass a contact it left
            // out.
            let limit = self.reach.min(self.found.spill.max(0.0));
            let scale = if motion > limit { limit / motion } else { 1.0 };
            // The next tick looks somewhat farther than this one went: a part held back by
            // its reach looks farther each tick, one that stopped looks close.
            self.reach =
                (1.5 * motion * scale + MIN_REACH).clamp(MIN_REACH, self.parameters.max_step);
            let (position, orientation) = (
                self.position + v * scale,
                (DQuat::from_scaled_axis(w * scale) * self.orientation).normalize(),
            );
            if position.is_finite() && orientation.is_finite() {
                (self.position, self.orientation) = (position, orientation);
            }
        } else if query == Query::TooMany {
            self.reach = MIN_REACH;
            self.previous_count = 0;
        }
        let p = &self.parameters;
        let mut felt = Wrench {
            force: p.stiffness * (self.position - grip_position),
            torque: p.rotational_stiffness
                * rotation_vector(self.orientation * grip_orientation.inverse()),
        };
        if let Some((last, last_turned)) = self.last_grip
            && dt > 0.0
        {
            // The proxy's motion over the tick less the grip's.
            let slip = (self.position - was) - (grip_position - last);
            let turn = rotation_vector(self.orientation * was_turned.inverse())
                - rotation_vector(grip_orientation * last_turned.inverse());
            felt.force += p.damping / dt * slip;
            felt.torque += p.rotational_damping / dt * turn;
        }
        self.last_grip = Some(grip);
        GodObjectOutput {
            felt,
            penetration,
            held_back: query != Query::Found,
        }
    }

    /// [rt] Gather the contacts within this tick's reach, both ways round for each
    /// obstacle, until done or the clock passes `deadline`: going on from where the last
    /// tick's query stopped if none of the obstacles it had looked at moved since, else
    /// (they are looked at again at the next tick) from the start.
    fn find_contacts<'m>(
        &mut self,
        obstacles: impl IntoIterator<Item = Obstacle<'m>>,
        deadline: Option<Instant>,
    ) -> Query {
        // Between queries the table is empty and the walk at the roots.
        let pending = self.pending.take();
        if pending.is_none() {
            self.found.clear();
        }
        let mut resumed = false;
        let part = (self.position, self.orientation);
        let mut print = 0xcbf2_9ce4_8422_2325;
        for (o, obstacle) in obstacles.into_iter().enumerate() {
            print = fingerprint(print, o, &obstacle);
            let mut first_side = 0;
            if let Some(p) = pending.filter(|_| !resumed) {
                if o < p.obstacle {
                    continue;
                }
                if p.print != print {
                    break;
                }
                (resumed, first_side) = (true, p.side);
            }
            let other = (obstacle.position, obstacle.orientation);
            for side in first_side..2 {
                // The samples of one against the triangles of the other, in the latter's
                // frame: the part's against the obstacle's first, then the other way.
                let (triangles, samples, (from, from_turn), (to, to_turn)) = if side == 0 {
                    (obstacle.mesh, &self.part, part, other)
                } else {
                    (&self.part, obstacle.mesh, other, part)
                };
                let back = to_turn.inverse();
                let placed = (back * from_turn, back * (from - to));
                let walk = (&mut self.walk, deadline);
                match self
                    .table
                    .gather(triangles, samples, (placed, self.reach), walk)
                {
                    Gathered::Done => self.walk.restart(),
                    Gathered::Full => {
                        self.table.clear();
                        self.walk.restart();
                        return Query::TooMany;
                    }
                    Gathered::Stopped => {
                        self.pending = Some(Pending {
                            obstacle: o,
                            side,
                            print,
                        });
                        return Query::Unfinished;
                    }
                }
                for &u in &self.table.used {
                    let slot = &self.table.slots[u as usize];
                    for (k, near) in slot.kept.iter().enumerate() {
                        let Some(near) = near else { continue };
                        let outward = to_turn * near.normal;
                        let (point, normal) = if side == 0 {
                            let sample = samples.samples()[slot.sample as usize - 1];
                            (from_turn * sample + from, outward)
                        } else {
                            (to_turn * near.point + to, -outward)
                        };
                        self.found.add(Contact {
                            obstacle: o,
                            point,
                            normal,
                            gap: near.gap,
                            force: 0.0,
                            friction: DVec3::ZERO,
                            key: key(o, side, slot.sample, k),
                        });
                    }
                }
                self.table.clear();
            }
        }
        if pending.is_some() && !resumed {
            // What it had looked at moved (or is gone): the next tick starts again.
            self.table.clear();
            self.walk.restart();
            return Query::Unfinished;
        }
        self.found
            .reduce(self.reach / self.part.radius().max(f64::MIN_POSITIVE));
        Query::Found
    }

    /// [rt] The proxy's motion (translation, rotation vector) for the `wanted` one: the
    /// least spring stretch the contacts allow. Their pushes are solved exactly (a
    /// least-distance problem, [`LeastDistance`]); with friction, rounds of Gauss–Seidel
    /// sweeps over the tangents (warm-started from the last tick's) alternate with it, each
    /// holding the other's forces. Cut back where the contacts as linearised would still be
    /// entered.
    fn solve(&mut self, wanted: (DVec3, DVec3)) -> (DVec3, DVec3) {
        let (k, kr, mu) = (
            self.parameters.stiffness,
            self.parameters.rotational_stiffness,
            self.parameters.friction,
        );
        // A coefficient that is not a finite positive number holds nothing (and could not
        // bound the clamp below).
        let frictional = mu > 0.0 && mu.is_finite();
        let mut rows = [Rows::default(); CONTACTS];
        let previous = &self.previous[..self.previous_count];
        let contacts = &mut self.found.contacts[..self.found.count];
        // The wanted motion with the friction's push: what the pushes are solved against.
        let mut held = wanted;
        for (row, c) in rows.iter_mut().zip(contacts.iter_mut()) {
            let r = c.point - self.position;
            let (t1, t2) = c.normal.any_orthonormal_pair();
            *row = Rows::new(r, [c.normal, t1, t2], (k, kr));
            c.force = 0.0;
            c.friction = match frictional {
                true => previous
                    .iter()
                    .find(|(key, _, _)| *key == c.key)
                    .map_or(DVec3::ZERO, |&(_, _, t)| t - c.normal * c.normal.dot(t)),
                false => DVec3::ZERO,
            };
            for j in 1..3 {
                row.push(j, c.friction.dot(row.directions[j]), &mut held, (k, kr));
            }
        }
        let rows = &rows[..contacts.len()];
        let mut motion = wanted;
        for _ in 0..ROUNDS {
            motion = pushes(&mut self.least, rows, contacts, held, (k, kr));
            if !frictional {
                break;
            }
            // Each tangent's force cancels the point's sliding along it, within the cone's
            // box, the pushes held.
            let mut changed = 0.0f64;
            for _ in 0..SWEEPS {
                for (row, c) in rows.iter().zip(contacts.iter_mut()) {
                    let bound = mu * c.force;
                    for j in 1..3 {
                        let d = row.directions[j];
                        let now = c.friction.dot(d);
                        let slide = row.along(j, motion.0, motion.1);
                        let next = (now - slide / row.reach[j]).clamp(-bound, bound);
                        if next != now {
                            row.push(j, next - now, &mut motion, (k, kr));
                            row.push(j, next - now, &mut held, (k, kr));
                            c.friction += d * (next - now);
                            changed = changed.max((next - now).abs());
                        }
                    }
                }
            }
            if changed / k < TOLERANCE {
                break;
            }
        }
        let (v, w) = motion;
        let mut scale = 1.0f64;
        for (row, c) in rows.iter().zip(contacts.iter()) {
            let along = row.along(0, v, w);
            // Within the solve's tolerance is solved: a contact resting at no gap would
            // otherwise hold the proxy still for good.
            if c.gap >= 0.0 && c.gap + along < -TOLERANCE {
                scale = scale.min((c.gap + TOLERANCE) / -along);
            }
        }
        for (slot, c) in self.previous.iter_mut().zip(contacts.iter()) {
            *slot = (c.key, c.force, c.friction);
        }
        self.previous_count = contacts.len();
        (v * scale, w * scale)
    }
}

/// [rt] The contacts' pushes for the motion `base` (the wanted one with the friction's
/// push), exactly: in the spring's metric, the shortest change of it that enters no contact
/// as linearised (n·(v + ω × r) ≥ −gap), each push the constraint's multiplier. Where no
/// motion meets them all (a part found inside solids on opposite sides) it is asked only to
/// go no deeper into any, which standing still does. Gives the motion, the pushes into
/// `contacts`.
fn pushes(
    least: &mut LeastDistance,
    rows: &[Rows],
    contacts: &mut [Contact],
    base: (DVec3, DVec3),
    (k, kr): (f64, f64),
) -> (DVec3, DVec3) {
    let (sk, skr) = (k.sqrt(), kr.sqrt());
    for deeper_only in [false, true] {
        least.clear();
        for (row, c) in rows.iter().zip(contacts.iter()) {
            let (d, a) = (row.directions[0] / sk, row.arms[0] / skr);
            let gap = if deeper_only { c.gap.max(0.0) } else { c.gap };
            least.push(
                [d.x, d.y, d.z, a.x, a.y, a.z],
                -gap - row.along(0, base.0, base.1),
            );
        }
        if let Some(s) = least.solve(LEAST_STEPS) {
            for (c, &force) in contacts.iter_mut().zip(&s.multipliers) {
                c.force = force;
            }
            let y = s.y;
            return (
                base.0 + DVec3::new(y[0], y[1], y[2]) / sk,
                base.1 + DVec3::new(y[3], y[4], y[5]) / skr,
            );
        }
    }
    // Out of steps: the proxy stays where it is, pushed by nothing this tick.
    for c in contacts.iter_mut() {
        c.force = 0.0;
    }
    (DVec3::ZERO, DVec3::ZERO)
}

/// A contact's three rows of the solve: its normal and two tangents.
#[derive(Debug, Clone, Copy, Default)]
struct Rows {
    /// The normal, then the tangents.
    directions: [DVec3; 3],
    /// Each direction's moment arm about the proxy's origin, r × d.
    arms: [DVec3; 3],
    /// How far the point moves along each per newton along it.
    reach: [f64; 3],
}

impl Rows {
    fn new(r: DVec3, directions: [DVec3; 3], (k, kr): (f64, f64)) -> Self {
        let arms = directions.map(|d| r.cross(d));
        Self {
            directions,
            arms,
            reach: arms.map(|a| 1.0 / k + a.length_squared() / kr),
        }
    }

    /// How far the point moves along row `j` under the motion (v, w).
    fn along(&self, j: usize, v: DVec3, w: DVec3) -> f64 {
        self.directions[j].dot(v) + self.arms[j].dot(w)
    }

    /// Move `motion` as a force `f` along row `j` moves the proxy through the springs
    /// (k, kᵣ): by f·(d/k, (r×d)/kᵣ).
    fn push(&self, j: usize, f: f64, motion: &mut (DVec3, DVec3), (k, kr): (f64, f64)) {
        motion.0 += self.directions[j] * (f / k);
        motion.1 += self.arms[j] * (f / kr);
    }
}

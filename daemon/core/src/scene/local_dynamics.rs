//! Local dynamics (thesis 6.5.4): the bodies near a pointer move in the haptic thread, at
//! the haptic rate, under the hand's force, between two physics steps.
//!
//! A physics step hands over, for each such body, its state, its mass and inertia and its
//! contacts with the rest of the world as the step left them. Each haptic tick integrates
//! the body twice from that state over the period: once under the hand's force ("hand")
//! and once without it ("free"), both against the same contacts, which stay where they were
//! (the other solid waits for the next step). Their difference is what the hand did.
//!
//! When the next state arrives, it does not yet hold what the hand did over the period that
//! just ended (the physics takes that in one step later). What goes back is how the body
//! under the hand differs from that next state (plus the changes still pending): the hand's
//! part, and whatever the step's coarser integration did differently (one step of friction
//! stops a block that slides here for most of a period). The physics adds it at its next
//! step, so the world follows the hand, and the body restarts from the next state plus
//! everything pending: where it was under the hand. A body the next step no longer
//! publishes gets the hand's part alone. Only what differs beyond what goes back (a
//! collision the step saw on a body the next set leaves out) is a jump, spread over the
//! next period so that the surfaces felt never step.
//!
//! Contacts are solved as unilateral velocity constraints with Coulomb friction by a few
//! sweeps of projected Gauss–Seidel, speculative over their gap: a body resting on a floor
//! neither sinks nor sticks to it, and a body pushed into a corner does not move into it.
//!
//! A body held by joints moves through its articulated mobility as the physics hands it
//! over ([`Mobility`]): a door pushed at its handle swings as a mass I/r² would there and
//! not at all along its hinge, its velocity field and its planes turning with it. It hands
//! back the hand's part alone: how the mechanism moves by itself is the world's, and each
//! link of one handing back its own way of it moved the joints by all of them.

use glam::{DMat3, DQuat, DVec3};
use hapticd_plugin_api::{
    HAPTICD_MAX_BODY_CONTACTS, HapticdLocalBody, HapticdLocalState, HapticdMobility,
};

pub use mobility::Mobility;

use crate::kinematics::{MAX_EFFECTORS, Pose, quat_from_wxyz, rotation_vector};

/// Gauss–Seidel sweeps over a body's contacts per tick.
const SWEEPS: usize = 4;

/// Where a body is and how it moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Centre of mass, metres.
    pub position: DVec3,
    /// Orientation.
    pub orientation: DQuat,
    /// Velocity of the centre of mass, m/s.
    pub velocity: DVec3,
    /// Angular velocity, rad/s.
    pub spin: DVec3,
}

impl Motion {
    /// `self` changed by `change` (what the hand did, or a sum of such).
    fn plus(&self, change: &Change) -> Motion {
        Motion {
            position: self.position + change.displacement,
            orientation: (DQuat::from_scaled_axis(change.rotation) * self.orientation).normalize(),
            velocity: self.velocity + change.velocity,
            spin: self.spin + change.spin,
        }
    }

    /// Whether every number of it is finite.
    fn is_finite(&self) -> bool {
        self.position.is_finite()
            && self.orientation.is_finite()
            && self.velocity.is_finite()
            && self.spin.is_finite()
    }

    /// The pose part.
    pub fn pose(&self) -> Pose {
        Pose {
            position: self.position,
            orientation: self.orientation,
        }
    }
}

/// How one motion differs from another: what the hand did over a period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Change {
    /// Displacement of the centre of mass, metres.
    pub displacement: DVec3,
    /// Rotation vector, radians.
    pub rotation: DVec3,
    /// Velocity change, m/s.
    pub velocity: DVec3,
    /// Angular velocity change, rad/s.
    pub spin: DVec3,
}

impl Change {
    /// `a` relative to `b`.
    fn between(a: &Motion, b: &Motion) -> Change {
        Change {
            displacement: a.position - b.position,
            rotation: rotation_vector(a.orientation * b.orientation.inverse()),
            velocity: a.velocity - b.velocity,
            spin: a.spin - b.spin,
        }
    }

    /// Both changes (rotations small enough to add as vectors: a period's worth).
    pub fn add(&mut self, other: &Change) {
        self.displacement += other.displacement;
        self.rotation += other.rotation;
        self.velocity += other.velocity;
        self.spin += other.spin;
    }

    /// Whether nothing changed.
    pub fn is_zero(&self) -> bool {
        *self == Change::default()
    }

    /// The change as the ABI hands it back, for `body`, numbered `sequence`.
    pub fn to_abi(&self, body: u32, sequence: u64) -> HapticdLocalState {
        HapticdLocalState {
            body,
            sequence,
            displacement: self.displacement.to_array(),
            rotation: self.rotation.to_array(),
            velocity: self.velocity.to_array(),
            spin: self.spin.to_array(),
        }
    }
}

/// A body the haptic side moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalBody {
    /// The body's number in the scene.
    pub body: u32,
    first_object: u32,
    object_count: u32,
    /// The state the physics published, which the planes of this set were found at.
    base: Motion,
    /// How it answers an impulse, as published (inertia in world axes at `base`'s
    /// orientation), kept over the period.
    mobility: Mobility,
    /// The contacts with the rest of the world as the step left them.
    rows: [Row; HAPTICD_MAX_BODY_CONTACTS],
    contact_count: usize,
    hand: Motion,
    free: Motion,
    /// Each contact's impulses (normal, two tangents) at the last tick, for the hand's and
    /// the free motion: the next tick starts from them, so a resting contact is exact.
    warm: [[DVec3; HAPTICD_MAX_BODY_CONTACTS]; 2],
    /// Displayed pose minus `hand`'s when the state last restarted, fading out over a
    /// period: position and rotation vector.
    offset: (DVec3, DVec3),
    /// Seconds since the restart, and the period the offset fades over.
    since: f64,
    period: f64,
}

/// A contact with the rest of the world, as every tick of the period solves it.
///
/// Lever arm, directions and masses stay as published: over one period a body turns
/// little, and a ball's contact stays at its bottom however it rolls (turning the published
/// point with the body would lift it off the floor and let the ball sink). The gap follows
/// the body to first order: its translation, and its turn about the centre (nothing for a
/// ball, a tipping box's corner for a box).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Row {
    /// From the centre of mass at the published state to the contact point, world axes.
    r: DVec3,
    /// Normal (along which the other solid pushes) and two tangents.
    directions: [DVec3; 3],
    /// What a unit impulse along each direction does to the centre's velocity and to the
    /// spin.
    moves: [DVec3; 3],
    turns: [DVec3; 3],
    /// The point's mass along each direction.
    masses: [f64; 3],
    /// Gap along the normal when published, metres.
    gap: f64,
    /// `r × normal`: how a turn opens the gap.
    lever: DVec3,
    friction: f64,
}

/// A hand's push on a body for one tick, as the proxy's spring gives it: a finger pushes
/// with at most its spring's force, and no faster than it moves itself.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Push {
    /// Where it pushes (the proxy), metres.
    pub point: DVec3,
    /// How hard, N (zero: no push).
    pub force: DVec3,
    /// How fast the finger has pushed at most over the physics period, m/s (its grip's
    /// speed, with the speed at which its proxy catches up with a grip gone deeper).
    pub speed: f64,
}

/// A push as the sweeps bound it: an impulse along its force of at most the force's over
/// the tick, and only so much of it as keeps the point, along that line, no faster than
/// the hand (a light body under a deep finger was thrown at metres a second by the spring's
/// whole force, and spun at hundreds of radians a second).
#[derive(Debug, Clone, Copy, Default)]
struct HandRow {
    r: DVec3,
    direction: DVec3,
    moves: DVec3,
    turn: DVec3,
    /// The point's mass along the direction.
    mass: f64,
    /// The finger's speed.
    speed: f64,
    /// The impulse of the whole force over the tick, and the impulse given so far.
    most: f64,
    amount: f64,
}

impl HandRow {
    fn new(push: &Push, centre: DVec3, mobility: &Mobility, shift: DVec3, dt: f64) -> Self {
        let direction = push.force.normalize_or_zero();
        let r = push.point - centre;
        let (moves, turn, inverse) = mobility.unit(r, direction, shift);
        let most = push.force.length() * dt;
        HandRow {
            r,
            direction,
            moves,
            turn,
            mass: mass(inverse),
            speed: push.speed * mobility.release(),
            most,
            amount: most,
        }
    }
}

/// The state a physics step published for a body.
fn published_motion(published: &HapticdLocalBody) -> Motion {
    Motion {
        position: DVec3::from(published.position),
        orientation: quat_from_wxyz(published.orientation).normalize(),
        velocity: DVec3::from(published.velocity),
        spin: DVec3::from(published.spin),
    }
}

/// The mass of a point whose inverse mass along a line is `inverse`: none where joints hold
/// it (a door pushed along its hinge), which no impulse then moves.
fn mass(inverse: f64) -> f64 {
    if inverse > 1e-9 { 1.0 / inverse } else { 0.0 }
}

/// The unit tangents of `n`.
fn tangents(n: DVec3) -> (DVec3, DVec3) {
    let t = n.any_orthonormal_vector();
    (t, n.cross(t))
}

impl LocalBody {
    /// The body `published` describes, moved on by the changes still `pending` for it,
    /// starting a physics period of `period` seconds. `jointed`: how its joints let it
    /// move, if any hold it. `shown`: where the body was displayed just before, whose
    /// difference fades out over the period (None: start where it is). None when the
    /// record is not finite or its mass is not positive.
    pub fn new(
        (published, jointed): (&HapticdLocalBody, Option<&HapticdMobility>),
        pending: &Change,
        period: f64,
        shown: Option<Pose>,
    ) -> Option<LocalBody> {
        let base = published_motion(published);
        let inverse_inertia = DMat3::from_cols_array(&published.inverse_inertia).transpose();
        let gravity = DVec3::from(published.acceleration);
        let finite = base.is_finite() && inverse_inertia.is_finite() && gravity.is_finite();
        if !(finite && published.inverse_mass > 0.0 && published.inverse_mass.is_finite()) {
            return None;
        }
        let mobility = match jointed {
            Some(m) => Mobility::jointed(m)?,
            None => Mobility::free(published.inverse_mass, inverse_inertia, gravity),
        };
        let mut rows = [Row::default(); HAPTICD_MAX_BODY_CONTACTS];
        let mut count = 0;
        for c in published.contacts
            [..(published.contact_count as usize).min(HAPTICD_MAX_BODY_CONTACTS)]
            .iter()
        {
            let (point, normal) = (DVec3::from(c.point), DVec3::from(c.normal));
            let normal = normal.normalize_or_zero();
            if !point.is_finite() || normal == DVec3::ZERO || !c.gap.is_finite() {
                continue;
            }
            let r = point - base.position;
            let (t1, t2) = tangents(normal);
            let directions = [normal, t1, t2];
            let units = directions.map(|d| mobility.unit(r, d, DVec3::ZERO));
            rows[count] = Row {
                r,
                directions,
                moves: units.map(|u| u.0),
                turns: units.map(|u| u.1),
                masses: units.map(|u| mass(u.2)),
                gap: c.gap,
                lever: r.cross(normal),
                friction: if c.friction.is_finite() {
                    c.friction.max(0.0)
                } else {
                    0.0
                },
            };
            count += 1;
        }
        let start = base.plus(pending);
        let offset = shown.map_or((DVec3::ZERO, DVec3::ZERO), |s| {
            (
                s.position - start.position,
                rotation_vector(s.orientation * start.orientation.inverse()),
            )
        });
        Some(LocalBody {
            body: published.body,
            first_object: published.first_object,
            object_count: published.object_count,
            base,
            mobility,
            rows,
            contact_count: count,
            hand: start,
            free: start,
            warm: [[DVec3::ZERO; HAPTICD_MAX_BODY_CONTACTS]; 2],
            offset,
            since: 0.0,
            period,
        })
    }

    /// Whether `object` is one of this body's.
    pub fn owns(&self, object: u32) -> bool {
        object.wrapping_sub(self.first_object) < self.object_count
    }

    /// Where the body is felt and seen: its motion under the hand, plus what is left of the
    /// restart's jump.
    pub fn shown(&self) -> Motion {
        let fade = 1.0 - (self.since / self.period).min(1.0);
        let (position, rotation) = self.offset;
        Motion {
            position: self.hand.position + position * fade,
            orientation: (DQuat::from_scaled_axis(rotation * fade) * self.hand.orientation)
                .normalize(),
            // The fade moves the surface too: friction carries a finger along with it.
            velocity: self.hand.velocity - position / self.period * f64::from(fade > 0.0),
            spin: self.hand.spin - rotation / self.period * f64::from(fade > 0.0),
        }
    }

    /// Where a point and a direction found at the published state are now, as shown, and
    /// the velocity of the surface there. The plane goes with the centre, not with the turn:
    /// it is the nearest face to a finger, not a material one, and the nearest face of a
    /// ball stays where it is however the ball spins (a box turns little in one period).
    /// Along the normal the surface moves as the plane does; the spin only slides it, which
    /// friction carries a finger along with.
    /// A jointed body's plane turns with it: a door's face at its handle moves as the door
    /// turns about its hinge, not as its centre does.
    pub fn carry(&self, point: DVec3, normal: DVec3) -> (DVec3, DVec3, DVec3) {
        let now = self.shown();
        if self.mobility.is_jointed() {
            let turn = now.orientation * self.base.orientation.inverse();
            let at = now.position + turn * (point - self.base.position);
            return (
                at,
                turn * normal,
                now.velocity + now.spin.cross(at - now.position),
            );
        }
        let at = point + (now.position - self.base.position);
        let slide = now.spin.cross(at - now.position);
        (
            at,
            normal,
            now.velocity + slide - normal * slide.dot(normal),
        )
    }

    /// The state under the hand.
    pub fn motion(&self) -> Motion {
        self.hand
    }

    /// How far the body is shown from where the physics has it once it has taken every
    /// change handed back so far: this period's change, and what is left of the restart's
    /// jump.
    pub fn unsent(&self) -> DVec3 {
        self.shown().position - self.free.position
    }

    /// Whether joints hold the body.
    pub fn is_jointed(&self) -> bool {
        self.mobility.is_jointed()
    }

    /// Whether a hand moved the body since the period began.
    pub fn touched(&self) -> bool {
        self.hand != self.free
    }

    /// What the hand did since the period began.
    pub fn change(&self) -> Change {
        Change::between(&self.hand, &self.free)
    }

    /// How the body under the hand differs from the state the next step published for it,
    /// moved on by the changes still `pending` for it: all the physics must add for the two
    /// to agree. Besides the hand's part ([`LocalBody::change`]), it holds what the
    /// step's coarser integration of the same contacts did differently (a block coasting
    /// on a floor for less than a period is stopped by one step of friction), and what the
    /// step saw and the contacts here did not. None when the state published is not finite.
    pub fn change_to(&self, next: &HapticdLocalBody, pending: &Change) -> Option<Change> {
        let next = published_motion(next).plus(pending);
        next.is_finite().then(|| Change::between(&self.hand, &next))
    }

    /// [rt] One tick of `dt`: `force` and `torque` (about the centre of mass, as it is now
    /// under the hand) act on the body, and the hands push it ([`Push`]).
    pub fn step(&mut self, force: DVec3, torque: DVec3, pushes: &[Push], dt: f64) {
        let pushed = pushes.iter().any(|p| p.force != DVec3::ZERO);
        // Untouched and not yet apart, the twin is the same body: spare its sums.
        let same =
            self.hand == self.free && force == DVec3::ZERO && torque == DVec3::ZERO && !pushed;
        let mut warm = self.warm;
        let load = (force, torque, pushes);
        if same {
            self.hand = self.advance(&self.hand, load, None, dt, &mut warm[0]);
            self.free = self.hand;
            warm[1] = warm[0];
        } else {
            let none = (DVec3::ZERO, DVec3::ZERO, &[][..]);
            self.free = self.advance(&self.free, none, None, dt, &mut warm[1]);
            let free = Some(&self.free);
            self.hand = self.advance(&self.hand, load, free, dt, &mut warm[0]);
        }
        self.warm = warm;
        self.since += dt;
    }

    /// `m` moved on by `dt` under a force and a torque, the hands' pushes (`load`) and the
    /// contacts. Pushed, it moves from `free` (the same body without the hand, this tick)
    /// no faster than the fastest hand at any point as far from its centre as the pushes and
    /// contacts are: the sweeps bound each push along its own line, but a light body pinned
    /// under a deep finger, its contacts not converged in a few sweeps, turned and jumped at
    /// twice the hand's speed. Off its centre, a push is bounded so the more than along its
    /// line: the point pushed goes slower than the hand, never faster.
    fn advance(
        &self,
        m: &Motion,
        (force, torque, pushes): (DVec3, DVec3, &[Push]),
        free: Option<&Motion>,
        dt: f64,
        sums: &mut [DVec3; HAPTICD_MAX_BODY_CONTACTS],
    ) -> Motion {
        let shift = m.position - self.base.position;
        let (dv, dw) = self.mobility.respond(force, torque, shift);
        let (a, alpha) = self.mobility.acceleration(shift);
        let mut v = m.velocity + (dv + a) * dt;
        let mut w = m.spin + (dw + alpha) * dt;
        // Each push starts whole; the sweeps take back what would carry its point faster
        // than its hand.
        let mut hands = [HandRow::default(); MAX_EFFECTORS];
        let mut hand_count = 0;
        for push in pushes
            .iter()
            .filter(|p| p.force != DVec3::ZERO)
            .take(MAX_EFFECTORS)
        {
            let row = HandRow::new(push, m.position, &self.mobility, shift, dt);
            v += self.mobility.moved(row.direction, row.moves, row.most);
            w += row.turn * row.most;
            hands[hand_count] = row;
            hand_count += 1;
        }
        let hands = &mut hands[..hand_count];
        // How far the body has moved and turned since published (small: within a period).
        let turn = m.orientation * self.base.orientation.inverse();
        let turned = DVec3::new(turn.x, turn.y, turn.z) * (2.0 * turn.w.signum());
        let moved = shift;
        let rows = &self.rows[..self.contact_count];
        let mut closing = [0.0; HAPTICD_MAX_BODY_CONTACTS];
        for (closing, row) in closing.iter_mut().zip(rows) {
            // The approach speed that just closes the gap in one tick.
            let gap = row.gap + moved.dot(row.directions[0]) + turned.dot(row.lever);
            *closing = gap.max(0.0) / dt;
        }
        let push = |row: &Row, k: usize, amount: f64, v: &mut DVec3, w: &mut DVec3| {
            *v += self.mobility.moved(row.directions[k], row.moves[k], amount);
            *w += row.turns[k] * amount;
        };
        for (row, sum) in rows.iter().zip(sums.iter()) {
            for k in 0..3 {
                push(row, k, sum[k], &mut v, &mut w);
            }
        }
        for _ in 0..SWEEPS {
            for ((row, closing), sum) in rows.iter().zip(&closing).zip(sums.iter_mut()) {
                let along =
                    |k: usize, v: DVec3, w: DVec3| (v + w.cross(row.r)).dot(row.directions[k]);
                // Normal: the point may close the gap, never move into the other solid.
                let normal = (sum.x + (-closing - along(0, v, w)) * row.masses[0]).max(0.0);
                push(row, 0, normal - sum.x, &mut v, &mut w);
                sum.x = normal;
                // Friction: stop sliding within the cone of the normal impulse.
                let limit = row.friction * normal;
                for k in 1..3 {
                    let old = sum[k];
                    let new = (old - along(k, v, w) * row.masses[k]).clamp(-limit, limit);
                    push(row, k, new - old, &mut v, &mut w);
                    sum[k] = new;
                }
            }
            for hand in hands.iter_mut() {
                let along = (v + w.cross(hand.r)).dot(hand.direction);
                let amount = (hand.amount + (hand.speed - along) * hand.mass).clamp(0.0, hand.most);
                v += self
                    .mobility
                    .moved(hand.direction, hand.moves, amount - hand.amount);
                w += hand.turn * (amount - hand.amount);
                hand.amount = amount;
            }
        }
        if let Some(free) = free.filter(|_| !hands.is_empty()) {
            let speed = hands.iter().map(|h| h.speed).fold(0.0, f64::max);
            let reach = hands
                .iter()
                .map(|h| h.r.length())
                .chain(rows.iter().map(|r| r.r.length()))
                .fold(0.0, f64::max);
            let (dv, dw) = (v - free.velocity, w - free.spin);
            let fastest = dv.length() + dw.length() * reach;
            // Both motions keep their contacts, and so does any mix of the two.
            if fastest > speed {
                let keep = speed / fastest;
                v = free.velocity + dv * keep;
                w = free.spin + dw * keep;
            }
        }
        let step = v * dt;
        Motion {
            position: m.position + step,
            orientation: (DQuat::from_scaled_axis(w * dt) * m.orientation).normalize(),
            // A jointed body's velocity field turns with it: the velocity at its centre is
            // the field's at the point the centre moved to (a hinge stays still).
            velocity: if self.mobility.is_jointed() {
                v + w.cross(step)
            } else {
                v
            },
            spin: w,
        }
    }
}

mod mobility;
#[cfg(test)]
mod tests;

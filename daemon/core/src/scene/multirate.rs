//! The haptic side of a multi-rate scene (thesis 6.3): the physics publishes, at its own
//! rate, the surfaces near each pointer as planes; every haptic tick moves each plane from
//! where the set before last had it toward where the last set has it (6.3.2, so the world
//! felt lags one physics period and never jumps), renders the planes through the proxy
//! (6.3.3), carries a proxy resting on a surface with the surface's own velocity (6.5.3),
//! and sums the force it displays into an impulse on the touched object over each physics
//! period (6.3.4), handed back when the next set arrives (6.3.5).
//!
//! A soft surface gives under the finger between two sets: the world says how far its plane
//! moves in for each newton pressed on it and the press it already stands under, and each
//! tick moves it in by that compliance times the press beyond it, so that the finger meets
//! the surface where the world's next step will have it (6.5.5) instead of a wall for a
//! period.
//!
//! With local dynamics (6.5.4) the set also carries the bodies near the pointers: those are
//! moved here every tick under the force displayed ([`local_dynamics`](super::local_dynamics)),
//! their planes move with them, and what the hand did to them goes back instead of an
//! impulse. Planes are found around the proxies (the physics is told where they rest), a
//! touched face is kept while the finger rests on it, and a grip that starts inside a solid
//! feels nothing until it is out.
//!
//! The daemon runs this in the haptic thread against a physics thread; `hapticctl` runs it
//! in step with the physics, at a chosen phase, for experiments. Neither allocates here.

use glam::{DQuat, DVec3};
use hapticd_plugin_api::{
    HAPTICD_MAX_LOCAL_BODIES, HAPTICD_MAX_PLANES, HapticdImpulse, HapticdLocalBody,
    HapticdLocalState, HapticdMobility, HapticdPlane, HapticdPlaneCompliance, HapticdPlanes,
    HapticdPointer,
};

use super::exact_shapes::{ExactShapes, nearest_on};
use super::held_part::{HeldPart, line_of_action};
use super::local_dynamics::{Change, LocalBody, Motion, Push};
use crate::haptics::obstacle::Shape;
use crate::haptics::proxy::{Proxy, ProxyParameters};
use crate::kinematics::{MAX_EFFECTORS, Pose, Wrench, quat_to_wxyz};
use crate::scene::{Pointer, Touch};

/// One set of planes as the physics published it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlaneSet {
    /// Increases with every physics step; 0 before the first.
    pub sequence: u64,
    /// The planes near each pointer.
    pub planes: [HapticdPlanes; MAX_EFFECTORS],
    /// How each of those planes gives under a press (zero: rigid, or a world that does not
    /// say).
    pub compliances: [[HapticdPlaneCompliance; HAPTICD_MAX_PLANES]; MAX_EFFECTORS],
    /// Bodies in `bodies` (local dynamics; 0: impulses only).
    pub body_count: u32,
    /// The bodies near the pointers, to move here until the next set.
    pub bodies: [HapticdLocalBody; HAPTICD_MAX_LOCAL_BODIES],
    /// For each of `bodies`, how its joints let it move (None: free, or a world that does
    /// not say).
    pub mobilities: [Option<HapticdMobility>; HAPTICD_MAX_LOCAL_BODIES],
    /// Seconds the step that made this set took (0: not measured). A world whose steps
    /// outlast its period rests as long as it works, so the next set comes no sooner than
    /// twice this.
    pub step: f64,
    /// The world was found too large for its rate and its thread yields to the others on its
    /// CPU: when the next set comes is up to them, so the world counts as failed only once
    /// [`STALE_PERIODS`] times [`MAX_PACE`] passed.
    pub yielding: bool,
    /// Other hosts' hands touch the same world (a shared world of several hosts): a
    /// body no hand here moved is the world's to move, since where this side, a round trip
    /// behind, has it would undo their pushes.
    pub shared: bool,
}

/// What the haptic side hands back to the physics when a period ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HandBack {
    /// The momentum given to an object it did not move itself.
    Impulse(HapticdImpulse),
    /// How a body it moved differs from the world's, and whether the hand moved it that
    /// period (else the difference is the haptic side's own integration of it alone).
    Local(HapticdLocalState, bool),
}

/// Hand-backs remembered until the physics says it took them in: more than the one period
/// it lags by, for a physics thread that ran late or a world on another machine (at 60
/// steps a second, half a second of round trip).
const PENDING: usize = 32;

/// The changes of one hand-back.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Pending {
    sequence: u64,
    count: usize,
    changes: [(u32, Change); HAPTICD_MAX_LOCAL_BODIES],
}

/// The changes in `records` for `published`'s body that its step had not taken in.
fn pending_for(records: &[Pending], published: &HapticdLocalBody) -> Change {
    let mut pending = Change::default();
    for record in records.iter().filter(|h| h.sequence > published.applied) {
        for (body, change) in &record.changes[..record.count] {
            if *body == published.body {
                pending.add(change);
            }
        }
    }
    pending
}

/// Sets older than this many physics periods (as the world keeps them, see [`MAX_PACE`])
/// count as stale: the scene has failed.
pub const STALE_PERIODS: f64 = 3.0;

/// Longest time between sets the haptic side renders at, seconds. A world that steps later
/// than its rate (too large for it: the physics thread backs off) is rendered at its own pace,
/// each set interpolated over the time the last one took, up to this.
pub const MAX_PACE: f64 = 0.5;

/// How much of the pace a set that came sooner keeps.
const PACE_DECAY: f64 = 0.9;

/// Impulse summed over one physics period on one plane.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Accumulator {
    impulse: DVec3,
    weighted_point: DVec3,
    weight: f64,
}

/// A plane where the haptic side renders it this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface {
    /// A point of the plane.
    pub point: DVec3,
    /// Outward unit normal.
    pub normal: DVec3,
    /// Velocity of the solid's surface there.
    pub velocity: DVec3,
}

/// The haptic side of a multi-rate scene for up to [`MAX_EFFECTORS`] pointers.
#[derive(Debug, Clone)]
pub struct PlaneRenderer {
    period: f64,
    /// The time the last set took to come, from the nominal period up to [`MAX_PACE`].
    pace: f64,
    proxies: Vec<Proxy>,
    parameters: ProxyParameters,
    previous: PlaneSet,
    current: PlaneSet,
    since_update: f64,
    sums: [[Accumulator; HAPTICD_MAX_PLANES]; MAX_EFFECTORS],
    /// The plane each proxy rested on last tick, if any.
    resting: [Option<usize>; MAX_EFFECTORS],
    /// The object and the surface each proxy rested on last tick, kept across sets.
    touched: [Option<(u32, Surface)>; MAX_EFFECTORS],
    /// Pointers whose grip was inside a solid when rendering began: no force until out.
    embedded: [bool; MAX_EFFECTORS],
    /// Energy each pointer has put into its contact with a local body and the body has
    /// not taken yet, joules (the body port's passivity observer).
    ports: [f64; MAX_EFFECTORS],
    /// The bodies of the current set as moved here, in the set's order.
    locals: [Option<LocalBody>; HAPTICD_MAX_LOCAL_BODIES],
    /// What each pointer's hand pushes each of `locals` with this tick.
    loads: [[Push; MAX_EFFECTORS]; HAPTICD_MAX_LOCAL_BODIES],
    /// The fastest each finger has pushed lately (its grip's speed with the speed its proxy
    /// catches up at, remembered over about a physics period), m/s: the most a push or an
    /// impulse handed back may give a body.
    reach: [f64; MAX_EFFECTORS],
    /// The last hand-backs of local changes, newest at `hand_backs % PENDING`.
    pending: [Pending; PENDING],
    hand_backs: u64,
    /// The body a pointer holds, if one does.
    held: Option<Box<HeldPart>>,
    /// The pieces of the bodies that are exactly balls or boxes.
    exact: ExactShapes,
}

/// Where the physics should find the surfaces around a pointer
/// ([`PlaneRenderer::queries`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Query {
    /// Where the pointer's proxy is, metres.
    pub at: DVec3,
    /// How a held body's proxy is turned (None: the grip's orientation).
    pub orientation: Option<DQuat>,
    /// The fastest its finger has pushed lately, m/s.
    pub reach: f64,
}

/// The record of a proxy the physics is given: where it is and how a held body's is turned
/// (a [`PlaneRenderer::queries`] answer), and as its velocity the fastest its finger pushed
/// over the period, along the grip's motion (`grip`'s, whose record it otherwise copies).
pub fn proxy_record(grip: &HapticdPointer, query: Query) -> HapticdPointer {
    HapticdPointer {
        position: query.at.to_array(),
        orientation: query.orientation.map_or(grip.orientation, quat_to_wxyz),
        velocity: (DVec3::from(grip.velocity).normalize_or(DVec3::X) * query.reach).to_array(),
    }
}

/// A body's pose `fraction` of the way from where the step before last left it to where the
/// last step left it (thesis 6.5.2): the position along the line, the orientation along the
/// shortest turn.
pub fn pose_between(before: &Pose, after: &Pose, fraction: f64) -> Pose {
    Pose {
        position: before.position.lerp(after.position, fraction),
        orientation: before.orientation.slerp(after.orientation, fraction),
    }
}

/// `plane` moved `fraction` of the way from `old` (its pose in the set before).
fn between(old: Option<&HapticdPlane>, plane: &HapticdPlane, fraction: f64) -> Surface {
    let now = Surface {
        point: DVec3::from(plane.point),
        normal: DVec3::from(plane.normal),
        velocity: DVec3::from(plane.velocity),
    };
    let Some(old) = old else {
        return now;
    };
    Surface {
        point: DVec3::from(old.point).lerp(now.point, fraction),
        normal: DVec3::from(old.normal)
            .lerp(now.normal, fraction)
            .normalize_or(now.normal),
        velocity: DVec3::from(old.velocity).lerp(now.velocity, fraction),
    }
}

impl PlaneRenderer {
    /// A renderer for physics at `rate` Hz and these pointers (at most [`MAX_EFFECTORS`]).
    pub fn new(rate: f64, pointers: &[Pointer]) -> Self {
        Self {
            period: 1.0 / rate,
            pace: 1.0 / rate,
            proxies: pointers
                .iter()
                .take(MAX_EFFECTORS)
                .map(|p| Proxy::new(p.pose.position))
                .collect(),
            parameters: ProxyParameters::default(),
            previous: PlaneSet::default(),
            current: PlaneSet::default(),
            since_update: 0.0,
            sums: [[Accumulator::default(); HAPTICD_MAX_PLANES]; MAX_EFFECTORS],
            resting: [None; MAX_EFFECTORS],
            touched: [None; MAX_EFFECTORS],
            embedded: [true; MAX_EFFECTORS],
            ports: [0.0; MAX_EFFECTORS],
            locals: [None; HAPTICD_MAX_LOCAL_BODIES],
            loads: [[Push::default(); MAX_EFFECTORS]; HAPTICD_MAX_LOCAL_BODIES],
            reach: [0.0; MAX_EFFECTORS],
            pending: [Pending::default(); PENDING],
            hand_backs: 0,
            held: None,
            exact: ExactShapes::default(),
        }
    }

    /// Touch the bodies moved here by these exact pieces from now on (made off the haptic
    /// thread).
    pub fn set_exact_shapes(&mut self, shapes: ExactShapes) {
        self.exact = shapes;
    }

    /// Render `part` for the pointer that holds it from now on (made off the haptic thread).
    pub fn hold(&mut self, part: HeldPart) {
        self.held = Some(Box::new(part));
    }

    /// [rt] What each pointer's proxy rests on, into `touches`: the body of the object
    /// touched (`bodies[object]`, none past its end), the plane's normal, whether it slides.
    pub fn write_touches(&self, bodies: &[u32], touches: &mut [Touch]) {
        for ((out, proxy), touched) in touches.iter_mut().zip(&self.proxies).zip(&self.touched) {
            let touch = proxy.touch();
            *out = match touched {
                Some((object, surface)) => Touch {
                    body: bodies
                        .get(*object as usize)
                        .copied()
                        .unwrap_or(Touch::NONE.body),
                    normal: surface.normal,
                    ..touch
                },
                None => touch,
            };
        }
    }

    /// Where each pointer's proxy is: the point the finger rests on surfaces at.
    pub fn proxies(&self) -> impl Iterator<Item = DVec3> + '_ {
        self.proxies.iter().map(Proxy::position)
    }

    /// Where the physics should find the surfaces around each proxy: the proxy itself, or
    /// for one resting on a body moved here, the point that is where the proxy is on the
    /// body once the physics has it where every change handed back puts it. The planes come
    /// back found on that body and are carried to where it is shown; found around the proxy
    /// itself, a ball rolled on under the finger would come back with the face turned
    /// toward where it was.
    ///
    /// With each, the fastest its finger has pushed lately (over about a physics period),
    /// m/s: the physics bounds the impulses it takes in by it. A pointer that holds a body
    /// gives its god-object's pose: the world puts the held body there.
    pub fn queries(&self) -> impl Iterator<Item = Query> + '_ {
        self.proxies
            .iter()
            .zip(&self.touched)
            .zip(&self.reach)
            .enumerate()
            .map(|(p, ((proxy, touched), &reach))| {
                if let Some(held) = self.held.as_ref().filter(|h| h.pointer() == p) {
                    let pose = held.proxy();
                    return Query {
                        at: pose.position,
                        orientation: Some(pose.orientation),
                        reach,
                    };
                }
                let body = touched
                    .and_then(|(object, _)| self.owner(object))
                    .and_then(|i| self.locals[i].as_ref());
                Query {
                    at: proxy.position() - body.map_or(DVec3::ZERO, LocalBody::unsent),
                    orientation: None,
                    reach,
                }
            })
    }

    /// The proxy parameters rendered with.
    pub fn parameters(&self) -> ProxyParameters {
        self.parameters
    }

    /// [rt] Render with `parameters` from now on.
    pub fn set_parameters(&mut self, parameters: &ProxyParameters) {
        self.parameters = *parameters;
    }

    /// [rt] Put the proxies at the pointers, free.
    pub fn reset(&mut self, pointers: &[Pointer]) {
        for (proxy, pointer) in self.proxies.iter_mut().zip(pointers) {
            proxy.reset(pointer.pose.position);
        }
        self.resting = [None; MAX_EFFECTORS];
        self.touched = [None; MAX_EFFECTORS];
        self.embedded = [true; MAX_EFFECTORS];
        self.ports = [0.0; MAX_EFFECTORS];
    }

    /// The body of the scene numbered `body` where it is felt now, if it is moved here (a
    /// held body where its god-object is).
    pub fn local(&self, body: u32) -> Option<Motion> {
        if let Some(held) = self.held.as_ref().filter(|h| h.body() == body) {
            return Some(held.motion());
        }
        self.locals
            .iter()
            .flatten()
            .find(|b| b.body == body)
            .map(LocalBody::shown)
    }

    /// Which of the current set's local bodies owns `object`.
    fn owner(&self, object: u32) -> Option<usize> {
        self.locals
            .iter()
            .position(|b| b.as_ref().is_some_and(|b| b.owns(object)))
    }

    /// How far the world felt has moved from the set before last toward the last: the
    /// fraction of a physics period (or of the time the last set took, if longer) since the
    /// last set came, at most 1. Graphics and telemetry move bodies by the same fraction
    /// (thesis 6.5.2), so what is seen is what is felt.
    pub fn fraction(&self) -> f64 {
        (self.since_update / self.pace).min(1.0)
    }

    /// How long after the current set the world counts as failed, seconds.
    fn patience(&self) -> f64 {
        let pace = match self.current.yielding {
            true => MAX_PACE,
            false => self.pace,
        };
        STALE_PERIODS * pace
    }

    /// Plane `k` of pointer `p` in the current set, moved `fraction` of a period from where
    /// the set before had the same object's plane; a locally moved body's plane where that
    /// body is now.
    pub fn interpolated(&self, p: usize, k: usize, fraction: f64) -> Surface {
        let plane = &self.current.planes[p].planes[k];
        if let Some(b) = self
            .owner(plane.object)
            .and_then(|i| self.locals[i].as_ref())
        {
            // A body moved here is where it is now, not a period behind.
            let (point, normal, velocity) =
                b.carry(DVec3::from(plane.point), DVec3::from(plane.normal));
            return Surface {
                point,
                normal,
                velocity,
            };
        }
        let old = self
            .earlier(p, k)
            .map(|j| &self.previous.planes[p].planes[j]);
        between(old, plane, fraction)
    }

    /// Where in the set before the current one pointer `p` had the object of its plane `k`.
    fn earlier(&self, p: usize, k: usize) -> Option<usize> {
        let object = self.current.planes[p].planes[k].object;
        let earlier = &self.previous.planes[p];
        let count = (earlier.count as usize).min(HAPTICD_MAX_PLANES);
        (0..count).find(|&j| earlier.planes[j].object == object)
    }

    /// [rt] One haptic tick of `dt`: take `latest` if the physics published it since the
    /// last tick (what the period that ended gave the world goes to `emit`), then write
    /// each pointer's wrench. False, with zero wrenches, while no set has come yet or the
    /// last one is [`STALE_PERIODS`] old (in the world's own pace).
    pub fn tick(
        &mut self,
        latest: &PlaneSet,
        pointers: &[Pointer],
        dt: f64,
        wrenches: &mut [Wrench],
        mut emit: impl FnMut(HandBack),
    ) -> bool {
        wrenches.fill(Wrench::ZERO);
        if latest.sequence != self.current.sequence {
            if self.current.sequence != 0 {
                // Up at most twice a set (a world that stalled and resumes is not taken for one
                // that slowed down), down a tenth a set (a world late by fits is kept at the
                // pace of its late sets, not flapping between stale and fresh).
                let interval = self.since_update + dt;
                let pace = interval.max(PACE_DECAY * self.pace).min(2.0 * self.pace);
                let announced = 2.0 * latest.step;
                self.pace = pace.max(announced).clamp(self.period, MAX_PACE);
            }
            self.hand_back(latest, &mut emit);
            self.previous = self.current;
            self.current = *latest;
            self.keep_touched_faces();
            self.restart_locals();
            self.since_update = 0.0;
        } else {
            self.since_update += dt;
        }
        if self.current.sequence == 0 || self.since_update > self.patience() {
            return false;
        }
        self.loads = [[Push::default(); MAX_EFFECTORS]; HAPTICD_MAX_LOCAL_BODIES];
        let fraction = self.fraction();
        for (p, (pointer, wrench)) in pointers.iter().zip(wrenches.iter_mut()).enumerate() {
            if p >= self.proxies.len() {
                break;
            }
            *wrench = match self.held.as_ref().is_some_and(|h| h.pointer() == p) {
                true => self.render_held(p, pointer, dt),
                false => self.render_pointer(p, pointer, fraction, dt),
            };
        }
        for (body, load) in self.locals.iter_mut().zip(&self.loads) {
            if let Some(body) = body {
                body.step(DVec3::ZERO, DVec3::ZERO, load, dt);
            }
        }
        true
    }

    /// [rt] The wrench of pointer `p` this tick, the reaction summed on what it touches.
    fn render_pointer(&mut self, p: usize, pointer: &Pointer, fraction: f64, dt: f64) -> Wrench {
        let count = (self.current.planes[p].count as usize).min(HAPTICD_MAX_PLANES);
        let grip = pointer.pose.position;
        let (surfaces, shapes) = self.surfaces(p, count, fraction, grip);
        if self.embedded[p] && self.still_embedded(p, grip, &surfaces[..count]) {
            return Wrench::ZERO;
        }
        // A proxy resting on a moving surface moves with it, and out of any plane that
        // moved onto it, before it walks toward the grip.
        let mut at = self.proxies[p].position();
        if let Some(k) = self.resting[p].filter(|&k| k < count) {
            at += surfaces[k].velocity * dt;
        }
        for s in &surfaces[..count] {
            let depth = (at - s.point).dot(s.normal);
            if depth < 0.0 {
                at -= s.normal * depth;
            }
        }
        let proxy = &mut self.proxies[p];
        proxy.carry(at);
        let out = proxy.update(
            grip,
            pointer.velocity,
            &shapes[..count],
            &self.parameters,
            dt,
        );
        self.remember_reach(p, pointer, out.proxy, dt);
        self.resting[p] = None;
        self.touched[p] = None;
        if !out.in_contact {
            self.ports[p] = 0.0;
            return Wrench::force(out.force);
        }
        // The surface the proxy rests on takes the reaction.
        let touched = (0..count).min_by(|&a, &b| {
            let d = |k: usize| shapes[k].signed_distance(out.proxy).abs();
            d(a).total_cmp(&d(b))
        });
        let mut force = out.force;
        if let Some(k) = touched {
            force = self.react((p, k), surfaces[k], pointer, out.proxy, force, dt);
        }
        Wrench::force(force)
    }

    /// [rt] The wrench of pointer `p`, which holds a body, this tick: its god-object's, among
    /// the fixed bodies and the bodies moved here, which its contacts push.
    fn render_held(&mut self, p: usize, pointer: &Pointer, dt: f64) -> Wrench {
        let Some(held) = self.held.as_mut() else {
            return Wrench::ZERO;
        };
        let (out, loads) = held.follow(pointer.pose, dt, &self.locals);
        let proxy = held.proxy().position;
        self.remember_reach(p, pointer, proxy, dt);
        let mut pushed = false;
        for (i, load) in loads.into_iter().enumerate() {
            let Some(body) = self.locals[i].as_ref().map(LocalBody::motion) else {
                continue;
            };
            if load.0 == DVec3::ZERO {
                continue;
            }
            let point = line_of_action(body.position, load);
            self.loads[i][p] = self.passive_push(p, (&body, point), load.0, pointer.velocity, dt);
            pushed = true;
        }
        if !pushed {
            self.ports[p] = 0.0;
        }
        out.felt
    }

    /// [rt] Remember how fast pointer `p`'s finger pushes, its proxy now at `proxy`, `dt`
    /// after the last tick.
    fn remember_reach(&mut self, p: usize, pointer: &Pointer, proxy: DVec3, dt: f64) {
        // The finger is the proxy, which catches up over a physics period with a grip that
        // went deeper while the body was held (pinned against another, or met as a wall
        // until the physics moves it): without that, a body riding the finger would keep
        // the depth, and its force, for as long as it is pushed.
        // Remembered over about a period, fading (not reset when a set comes: what a body
        // is given must not depend on when the physics samples).
        let catch_up = pointer.pose.position.distance(proxy) / self.period;
        let fading = self.reach[p] * (-dt / self.period).exp();
        self.reach[p] = fading.max(pointer.velocity.length() + catch_up);
    }

    /// [rt] Pointer `p`'s first `count` planes, `fraction` moved and soft ones given under
    /// `grip`, as surfaces and half-spaces.
    #[inline]
    fn surfaces(
        &self,
        p: usize,
        count: usize,
        fraction: f64,
        grip: DVec3,
    ) -> ([Surface; HAPTICD_MAX_PLANES], [Shape; HAPTICD_MAX_PLANES]) {
        let mut surfaces = [Surface {
            point: DVec3::ZERO,
            normal: DVec3::Y,
            velocity: DVec3::ZERO,
        }; HAPTICD_MAX_PLANES];
        let mut shapes = [Shape::HalfSpace {
            point: DVec3::ZERO,
            normal: DVec3::Y,
        }; HAPTICD_MAX_PLANES];
        for k in 0..count {
            if let Some((surface, shape)) = self.exact(p, k) {
                (surfaces[k], shapes[k]) = (surface, shape);
                continue;
            }
            surfaces[k] = self.interpolated(p, k, fraction);
            let give = self.give(p, k, fraction);
            surfaces[k].point -= surfaces[k].normal * self.given(&surfaces[k], give, grip);
            shapes[k] = Shape::HalfSpace {
                point: surfaces[k].point,
                normal: surfaces[k].normal,
            };
        }
        (surfaces, shapes)
    }

    /// Plane `k` of pointer `p`, when it is of an exact piece of a body moved here: that
    /// piece where the body is now, and its tangent plane at the point nearest the proxy.
    #[inline]
    fn exact(&self, p: usize, k: usize) -> Option<(Surface, Shape)> {
        let object = self.current.planes[p].planes[k].object;
        let solid = self.exact.of(object)?;
        let body = self.locals[self.owner(object)?].as_ref()?.shown();
        let shape = solid.placed(&body.pose());
        let (point, normal) = nearest_on(&shape, self.proxies[p].position())?;
        let velocity = body.velocity + body.spin.cross(point - body.position);
        let surface = Surface {
            point,
            normal,
            velocity,
        };
        Some((surface, shape))
    }

    /// How plane `k` of pointer `p` gives, `fraction` of the way from how the set before had
    /// the same object's plane give: as the plane itself moves, so that a new set takes
    /// over without a step in the force.
    fn give(&self, p: usize, k: usize, fraction: f64) -> HapticdPlaneCompliance {
        let now = self.current.compliances[p][k];
        let Some(old) = self.earlier(p, k) else {
            return now;
        };
        let old = self.previous.compliances[p][old];
        let lerp = |a: f64, b: f64| a + (b - a) * fraction;
        HapticdPlaneCompliance {
            compliance: lerp(old.compliance, now.compliance),
            load: lerp(old.load, now.load),
        }
    }

    /// How far `surface`, giving as `give` says, moves in under a grip at `grip`, metres
    /// (less than 0: out, the press it stood under eased). The proxy's spring k and the
    /// surface's compliance c in series: pressed d behind the plane the grip meets
    /// F = k·(d − s), and the surface moves s = c·(F − F₀), so s = c·(k·d − F₀)/(1 + c·k);
    /// a grip clear of it leaves it at −c·F₀, where nothing presses.
    fn given(&self, surface: &Surface, give: HapticdPlaneCompliance, grip: DVec3) -> f64 {
        let (c, load) = (give.compliance, give.load);
        if c <= 0.0 {
            return 0.0;
        }
        let k = self.parameters.stiffness;
        let behind = (surface.point - grip).dot(surface.normal);
        (c * (k * behind - load) / (1.0 + c * k)).max(-c * load)
    }

    /// [rt] Restart pointer `p`'s proxy at `grip`; whether the grip is still inside a solid.
    #[inline]
    fn still_embedded(&mut self, p: usize, grip: DVec3, surfaces: &[Surface]) -> bool {
        // Each plane is the nearest face of its solid to where the proxy was, so the
        // grip is behind one exactly when it is inside that solid: no force until it
        // has left them all, from where it is (never a push out through a face).
        let inside = surfaces
            .iter()
            .any(|s| (grip - s.point).dot(s.normal) < 0.0);
        self.proxies[p].reset(grip);
        self.resting[p] = None;
        self.touched[p] = None;
        if !inside {
            self.embedded[p] = false;
        }
        inside
    }

    /// [rt] Pointer `p`'s force on plane `k`, pushing only; its reaction goes to what it touches.
    #[inline]
    fn react(
        &mut self,
        (p, k): (usize, usize),
        surface: Surface,
        pointer: &Pointer,
        proxy: DVec3,
        mut force: DVec3,
        dt: f64,
    ) -> DVec3 {
        // A contact pushes, never pulls: the damper of a grip leaving the surface would
        // draw it back in.
        let normal = surface.normal;
        force -= normal * force.dot(normal).min(0.0);
        self.resting[p] = Some(k);
        let object = self.current.planes[p].planes[k].object;
        self.touched[p] = Some((object, surface));
        let moved = self
            .owner(object)
            .and_then(|i| Some((i, self.locals[i].as_ref()?.motion())));
        if let Some((i, body)) = moved {
            self.loads[i][p] = self.passive_push(p, (&body, proxy), -force, pointer.velocity, dt);
        } else {
            self.ports[p] = 0.0;
            let sum = &mut self.sums[p][k];
            let magnitude = force.length() * dt;
            sum.impulse -= force * dt;
            sum.weighted_point += proxy * magnitude;
            sum.weight += magnitude;
        }
        force
    }

    /// [rt] Pointer `p`'s push on a body moving as `body`, at `point` with `on_body`, the hand
    /// moving at `hand`, as much of it as keeps the body port passive: the body takes no more
    /// work than the hand has put into the contact (what the finger presses on is the body's
    /// nearest face as the last step saw it, and a ball rolling from under it would
    /// otherwise be driven by a face it no longer has).
    fn passive_push(
        &mut self,
        p: usize,
        (body, point): (&Motion, DVec3),
        on_body: DVec3,
        hand: DVec3,
        dt: f64,
    ) -> Push {
        let arm = point - body.position;
        let given = on_body.dot(body.velocity + body.spin.cross(arm)) * dt;
        let available = self.ports[p] + on_body.dot(hand) * dt;
        let share = if given > available.max(0.0) {
            (available / given).max(0.0)
        } else {
            1.0
        };
        self.ports[p] = available - share * given;
        Push {
            point,
            force: on_body * share,
            speed: self.reach[p],
        }
    }

    /// A face a proxy rests on stays the face it rests on: a new set whose plane of that
    /// object has turned over (its nearest face is now another one) keeps the old plane.
    fn keep_touched_faces(&mut self) {
        for (planes, touched) in self.current.planes.iter_mut().zip(&self.touched) {
            let Some((object, surface)) = touched else {
                continue;
            };
            let count = (planes.count as usize).min(HAPTICD_MAX_PLANES);
            for plane in planes.planes[..count]
                .iter_mut()
                .filter(|q| q.object == *object)
            {
                if DVec3::from(plane.normal).dot(surface.normal) < 0.0 {
                    plane.point = surface.point.to_array();
                    plane.normal = surface.normal.to_array();
                }
            }
        }
    }

    /// Start the current set's bodies from their published states, plus the hand's changes
    /// the physics has not taken in yet, where they were shown last tick.
    fn restart_locals(&mut self) {
        let old = self.locals;
        let count = (self.current.body_count as usize).min(HAPTICD_MAX_LOCAL_BODIES);
        self.locals = [None; HAPTICD_MAX_LOCAL_BODIES];
        let published = self.current.bodies.iter().zip(&self.current.mobilities);
        for (slot, (published, jointed)) in self.locals.iter_mut().zip(published.take(count)) {
            let pending = pending_for(&self.pending, published);
            let shown = old
                .iter()
                .flatten()
                .find(|b| b.body == published.body)
                .map(|b| b.shown().pose());
            *slot = LocalBody::new((published, jointed.as_ref()), &pending, self.pace, shown);
        }
    }

    /// Emit the impulse summed on each plane of the current set and, for each local body,
    /// how it differs from the state the `next` set has for it (what the hand did, where
    /// the next set has lost it), and start new sums.
    fn hand_back(&mut self, next: &PlaneSet, emit: &mut impl FnMut(HandBack)) {
        for (sums, planes) in self.sums.iter_mut().zip(&self.current.planes) {
            let count = (planes.count as usize).min(HAPTICD_MAX_PLANES);
            for (sum, plane) in sums.iter_mut().zip(&planes.planes[..count]) {
                if sum.weight > 0.0 {
                    emit(HandBack::Impulse(HapticdImpulse {
                        object: plane.object,
                        point: (sum.weighted_point / sum.weight).to_array(),
                        impulse: sum.impulse.to_array(),
                    }));
                }
            }
            *sums = [Accumulator::default(); HAPTICD_MAX_PLANES];
        }
        let mut record = Pending {
            sequence: self.hand_backs + 1,
            ..Pending::default()
        };
        let count = (next.body_count as usize).min(HAPTICD_MAX_LOCAL_BODIES);
        let untouched_are_the_worlds = next.shared;
        for body in self.locals.iter().flatten() {
            if untouched_are_the_worlds && !body.touched() {
                continue;
            }
            // A body whose last change the physics left out (it would have gone into a fixed
            // solid) gets this period's hand alone, and so restarts where the physics has it:
            // handed the whole difference again, it was refused again, period after period,
            // while it drifted on here (a pressed bunny went 10 cm from where the world had it).
            // A jointed body gets the hand's part alone: how a mechanism moves by itself is
            // the world's, and several links of one each handing back their own way of it
            // moved its joints by all of them (an arm pushed at its hand at 10 Hz went
            // unstable).
            let whole = next.bodies[..count]
                .iter()
                .find(|b| b.body == body.body && b.left_out == 0 && !body.is_jointed())
                .and_then(|b| body.change_to(b, &pending_for(&self.pending, b)));
            let change = whole.unwrap_or_else(|| body.change());
            if !change.is_zero() {
                record.changes[record.count] = (body.body, change);
                record.count += 1;
                let state = change.to_abi(body.body, record.sequence);
                emit(HandBack::Local(state, body.touched()));
            }
        }
        if record.count > 0 {
            self.hand_backs = record.sequence;
            self.pending[(record.sequence % PENDING as u64) as usize] = record;
        }
        // Resting indices refer to the set being replaced.
        self.resting = [None; MAX_EFFECTORS];
    }
}

#[cfg(test)]
mod tests;

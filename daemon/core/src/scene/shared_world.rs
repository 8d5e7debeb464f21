//! One world for the grips of several haptic hosts (thesis Fig. 6.13): each host gets
//! pointers of its own among the world's, each step takes in what every host handed back
//! and writes, for each host, the planes near its grips' proxies and the bodies it moves
//! itself, with the last of its own changes the step took in. `hapticd-world` runs one for
//! hosts on other machines; hapticd runs one for its own devices when they share a scene.
//!
//! The world never waits for a host: a step uses the latest grips each host sent, and a
//! host silent for [`FORGET_AFTER`] loses its pointers (parked far away, where they touch
//! nothing) until it speaks again.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
use hapticd_plugin_api::{
    HAPTICD_MAX_LOCAL_BODIES, HAPTICD_MAX_PLANES, HapticdBodyPose, HapticdImpulse,
    HapticdLocalBody, HapticdLocalState, HapticdMobility, HapticdPlaneCompliance, HapticdPlanes,
    HapticdPointer,
};

use super::ledger::Ledger;
use super::multirate::PlaneSet;
use super::remote::{HostUpdate, MAX_POSES, encode_world};
use crate::wire::Encoder;

/// A world a [`SharedWorld`] steps: a rapier world in `hapticd-world`, a scene plugin's in
/// hapticd.
pub trait Stepped {
    /// One step of `input`'s length with its grips and hand-backs, its planes and local
    /// bodies into `output`; false when the world failed (or is no longer finite).
    fn step(&mut self, input: &PhysicsInput<'_>, output: &mut PhysicsOutput<'_>) -> bool;
    /// The poses of its bodies into `poses`, and how many it has.
    fn poses(&mut self, poses: &mut [HapticdBodyPose]) -> usize;
    /// How the joints let each of the last step's local `bodies` move, into `out` (None for
    /// a free body; a world without joints leaves them all None).
    fn mobilities(&self, bodies: &[HapticdLocalBody], out: &mut [Option<HapticdMobility>]) {
        let _ = bodies;
        out.fill(None);
    }
    /// How each of the last step's `planes` gives, pointer by pointer, into `out` (a world
    /// of rigid bodies leaves them all rigid).
    fn compliances(
        &self,
        planes: &[HapticdPlanes],
        out: &mut [[HapticdPlaneCompliance; HAPTICD_MAX_PLANES]],
    ) {
        let _ = planes;
        out.fill([HapticdPlaneCompliance::default(); HAPTICD_MAX_PLANES]);
    }
}

/// A new host's grips outnumber the world's free pointers.
#[derive(Debug, Clone, PartialEq)]
pub struct NoRoom {
    /// The host's name.
    pub host: String,
    /// The grips it brought.
    pub count: usize,
    /// The pointers the world has in all (`--pointers`).
    pub pointers: usize,
}

impl std::fmt::Display for NoRoom {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "no room for host {}'s {} grips: the world has {} (--pointers)",
            self.host, self.count, self.pointers
        )
    }
}

impl std::error::Error for NoRoom {}

/// A host silent this long is forgotten.
pub const FORGET_AFTER: Duration = Duration::from_secs(1);

/// A haptic host the world has heard from.
#[derive(Debug)]
struct Host {
    name: String,
    /// Its number in the ledger.
    id: u64,
    /// Its pointers are the world's `first .. first + count`.
    first: usize,
    count: usize,
    heard: Instant,
    /// The last sequence of its changes taken in, by body.
    applied: BTreeMap<u32, u64>,
}

/// A world shared by hosts.
pub struct SharedWorld<W> {
    world: W,
    period: f64,
    pointers: Vec<HapticdPointer>,
    proxies: Vec<HapticdPointer>,
    planes: Vec<HapticdPlanes>,
    /// How each of `planes` gives under a press.
    compliances: Vec<[HapticdPlaneCompliance; HAPTICD_MAX_PLANES]>,
    bodies: [HapticdLocalBody; HAPTICD_MAX_LOCAL_BODIES],
    body_count: u32,
    /// How each of `bodies` moves through its joints.
    mobilities: [Option<HapticdMobility>; HAPTICD_MAX_LOCAL_BODIES],
    hosts: Vec<Host>,
    admitted: u64,
    ledger: Ledger,
    impulses: Vec<HapticdImpulse>,
    locals: Vec<HapticdLocalState>,
    step: u64,
    /// Where the bodies are after the last step.
    poses: Box<[HapticdBodyPose]>,
    pose_count: usize,
}

/// Where a new host's grips went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Admitted {
    /// Its first pointer among the world's.
    pub first: usize,
    /// Its pointers.
    pub count: usize,
}

/// Where an unused pointer waits: far from every solid, each apart.
fn parked(k: usize) -> HapticdPointer {
    HapticdPointer {
        position: [1e3 + 10.0 * k as f64, 1e3, 1e3],
        orientation: [1.0, 0.0, 0.0, 0.0],
        velocity: [0.0; 3],
    }
}

impl<W: Stepped> SharedWorld<W> {
    /// `world`, stepped `rate` times a second, with room for `capacity` pointers.
    pub fn new(world: W, rate: f64, capacity: usize) -> Self {
        let pointers: Vec<_> = (0..capacity).map(parked).collect();
        Self {
            world,
            period: 1.0 / rate,
            proxies: pointers.clone(),
            pointers,
            planes: vec![HapticdPlanes::default(); capacity],
            compliances: vec![[HapticdPlaneCompliance::default(); HAPTICD_MAX_PLANES]; capacity],
            bodies: [HapticdLocalBody::default(); HAPTICD_MAX_LOCAL_BODIES],
            body_count: 0,
            mobilities: [None; HAPTICD_MAX_LOCAL_BODIES],
            hosts: Vec::new(),
            admitted: 0,
            ledger: Ledger::default(),
            impulses: Vec::new(),
            locals: Vec::new(),
            step: 0,
            poses: vec![HapticdBodyPose::default(); MAX_POSES].into(),
            pose_count: 0,
        }
    }

    /// The world stepped.
    pub fn world(&self) -> &W {
        &self.world
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.step
    }

    /// The hosts it hears from, by name.
    pub fn hosts(&self) -> impl Iterator<Item = &str> {
        self.hosts.iter().map(|h| h.name.as_str())
    }

    /// Seconds a step advances.
    pub fn period(&self) -> f64 {
        self.period
    }

    /// Take host `name`'s message `update`, heard `now`: its grips from now on, its
    /// hand-backs into the next step. A new host gets pointers of its own if the world has
    /// room (an error otherwise), and is told where.
    pub fn take(
        &mut self,
        name: &str,
        update: HostUpdate,
        now: Instant,
    ) -> Result<Option<Admitted>, NoRoom> {
        let (index, admitted) = match self.hosts.iter().position(|h| h.name == name) {
            Some(i) => (i, None),
            None => {
                let admitted = self.admit(name, update.pointers.len(), now)?;
                (self.hosts.len() - 1, Some(admitted))
            }
        };
        let shared = self.hosts.len() > 1;
        let host = &mut self.hosts[index];
        host.heard = now;
        let n = host.count.min(update.pointers.len());
        let slots = host.first..host.first + n;
        self.pointers[slots.clone()].copy_from_slice(&update.pointers[..n]);
        self.proxies[slots].copy_from_slice(&update.proxies[..n]);
        // A hand-back covers the period before the last update the host had when it sent
        // it, or the one before that: taken as made on the older view.
        let base = update.seen.saturating_sub(2);
        for (k, change) in update.locals.iter().enumerate() {
            let seen = host.applied.entry(change.body).or_insert(0);
            *seen = (*seen).max(change.sequence);
            // Shared, the world moves what no hand moved: a host's view of a body is a
            // round trip old, and where it has the body would undo another hand's push.
            let touched = update.touched.get(k).copied().unwrap_or(true);
            if !touched && shared {
                continue;
            }
            let taken = self.ledger.reconcile(host.id, base, self.step + 1, change);
            self.locals.push(taken);
        }
        self.impulses.extend_from_slice(&update.impulses);
        Ok(admitted)
    }

    /// Room for host `name`'s `count` pointers: the first run of free ones.
    fn admit(&mut self, name: &str, count: usize, now: Instant) -> Result<Admitted, NoRoom> {
        let used = |k: usize| {
            self.hosts
                .iter()
                .any(|h| (h.first..h.first + h.count).contains(&k))
        };
        let first = (0..=self.pointers.len().saturating_sub(count))
            .find(|&f| (f..f + count).all(|k| !used(k)))
            .ok_or_else(|| NoRoom {
                host: name.to_string(),
                count,
                pointers: self.pointers.len(),
            })?;
        self.admitted += 1;
        self.hosts.push(Host {
            name: name.to_string(),
            id: self.admitted,
            first,
            count,
            heard: now,
            applied: BTreeMap::new(),
        });
        Ok(Admitted { first, count })
    }

    /// Forget the hosts silent since before `now - FORGET_AFTER`, each told to `forgotten`;
    /// their pointers are parked.
    pub fn forget_silent(&mut self, now: Instant, mut forgotten: impl FnMut(&str)) {
        let (pointers, proxies) = (&mut self.pointers, &mut self.proxies);
        self.hosts.retain(|h| {
            let alive = now.duration_since(h.heard) < FORGET_AFTER;
            if !alive {
                forgotten(&h.name);
                for k in h.first..h.first + h.count {
                    (pointers[k], proxies[k]) = (parked(k), parked(k));
                }
            }
            alive
        });
    }

    /// One step with everything the hosts handed back; false when the world is no longer
    /// finite.
    pub fn step(&mut self) -> bool {
        let finite = self.world.step(
            &PhysicsInput {
                dt: self.period,
                pointers: &self.pointers,
                proxies: &self.proxies,
                impulses: &self.impulses,
                locals: &self.locals,
            },
            &mut PhysicsOutput {
                planes: &mut self.planes,
                bodies: &mut self.bodies,
                body_count: &mut self.body_count,
            },
        );
        let count = (self.body_count as usize).min(HAPTICD_MAX_LOCAL_BODIES);
        self.world
            .mobilities(&self.bodies[..count], &mut self.mobilities[..count]);
        self.world.compliances(&self.planes, &mut self.compliances);
        self.impulses.clear();
        self.locals.clear();
        self.step += 1;
        self.pose_count = self.world.poses(&mut self.poses).min(MAX_POSES);
        finite
    }

    /// Each host's update of the last step, by name, written into `out` in turn.
    pub fn updates(&self, out: &mut Encoder, mut send: impl FnMut(&str, &[u8])) {
        let poses = &self.poses[..self.pose_count];
        let shared = self.hosts.len() > 1;
        for host in &self.hosts {
            let mut set = PlaneSet {
                body_count: self.body_count,
                bodies: self.bodies,
                mobilities: self.mobilities,
                shared,
                ..PlaneSet::default()
            };
            set.planes[..host.count]
                .copy_from_slice(&self.planes[host.first..host.first + host.count]);
            set.compliances[..host.count]
                .copy_from_slice(&self.compliances[host.first..host.first + host.count]);
            for b in &mut set.bodies[..self.body_count as usize] {
                b.applied = host.applied.get(&b.body).copied().unwrap_or(0);
            }
            out.clear();
            encode_world(out, self.step, &set, host.count, poses);
            send(&host.name, out.bytes());
        }
    }
}

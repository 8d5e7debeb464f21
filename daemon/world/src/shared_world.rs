//! One rapier world for the grips of several haptic hosts (thesis Fig. 6.13 over a network):
//! each host gets pointers of its own among the world's, each step takes in what every host
//! handed back and writes, for each host, the planes near its grips' proxies and the bodies
//! it moves itself, with the last of its own changes the step took in.
//!
//! The world never waits for a host: a step uses the latest grips each host sent, and a
//! host silent for [`FORGET_AFTER`] loses its pointers (parked far away, where they touch
//! nothing) until it speaks again.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use glam::{DMat3, DVec3};
use hapticd_core::scene::multirate::PlaneSet;
use hapticd_core::scene::remote::{HostUpdate, encode_world};
use hapticd_core::wire::Encoder;
use hapticd_physics::scene::RapierScene;
use hapticd_plugin_api::export::{PhysicsInput, PhysicsOutput};
use hapticd_plugin_api::{
    HAPTICD_MAX_LOCAL_BODIES, HapticdBodyPose, HapticdImpulse, HapticdLocalBody, HapticdLocalState,
    HapticdPlanes, HapticdPointer,
};
use hapticd_rapier::world::RapierWorld;

use crate::ledger::Ledger;

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

/// A rapier world shared by hosts.
pub struct SharedWorld {
    world: RapierWorld,
    names: Vec<String>,
    period: f64,
    pointers: Vec<HapticdPointer>,
    proxies: Vec<HapticdPointer>,
    planes: Vec<HapticdPlanes>,
    bodies: [HapticdLocalBody; HAPTICD_MAX_LOCAL_BODIES],
    body_count: u32,
    hosts: Vec<Host>,
    admitted: u64,
    ledger: Ledger,
    impulses: Vec<HapticdImpulse>,
    locals: Vec<HapticdLocalState>,
    step: u64,
    /// The largest kinetic energy of the world's bodies so far, joules.
    peak_energy: f64,
}

/// Where an unused pointer waits: far from every solid, each apart.
fn parked(k: usize) -> HapticdPointer {
    HapticdPointer {
        position: [1e3 + 10.0 * k as f64, 1e3, 1e3],
        orientation: [1.0, 0.0, 0.0, 0.0],
        velocity: [0.0; 3],
    }
}

impl SharedWorld {
    /// The world of `spec` with room for `capacity` pointers.
    pub fn new(spec: &RapierScene, capacity: usize) -> Self {
        let pointers: Vec<_> = (0..capacity).map(parked).collect();
        Self {
            world: RapierWorld::new(spec, capacity),
            names: spec.names.clone(),
            period: 1.0 / spec.rate,
            proxies: pointers.clone(),
            pointers,
            planes: vec![HapticdPlanes::default(); capacity],
            bodies: [HapticdLocalBody::default(); HAPTICD_MAX_LOCAL_BODIES],
            body_count: 0,
            hosts: Vec::new(),
            admitted: 0,
            ledger: Ledger::default(),
            impulses: Vec::new(),
            locals: Vec::new(),
            step: 0,
            peak_energy: 0.0,
        }
    }

    /// Seconds a step advances.
    pub fn period(&self) -> f64 {
        self.period
    }

    /// Take host `name`'s message `update`, heard `now`: its grips from now on, its
    /// hand-backs into the next step. A new host gets pointers of its own if the world has
    /// room (an error otherwise).
    pub fn take(&mut self, name: &str, update: HostUpdate, now: Instant) -> Result<(), NoRoom> {
        let index = match self.hosts.iter().position(|h| h.name == name) {
            Some(i) => i,
            None => self.admit(name, update.pointers.len(), now)?,
        };
        let host = &mut self.hosts[index];
        host.heard = now;
        let n = host.count.min(update.pointers.len());
        let slots = host.first..host.first + n;
        self.pointers[slots.clone()].copy_from_slice(&update.pointers[..n]);
        self.proxies[slots].copy_from_slice(&update.proxies[..n]);
        // A hand-back covers the period before the last update the host had when it sent
        // it, or the one before that: taken as made on the older view.
        let base = update.seen.saturating_sub(2);
        for change in &update.locals {
            let seen = host.applied.entry(change.body).or_insert(0);
            *seen = (*seen).max(change.sequence);
            let taken = self.ledger.reconcile(host.id, base, self.step + 1, change);
            self.locals.push(taken);
        }
        self.impulses.extend_from_slice(&update.impulses);
        Ok(())
    }

    /// Room for host `name`'s `count` pointers: the first run of free ones.
    fn admit(&mut self, name: &str, count: usize, now: Instant) -> Result<usize, NoRoom> {
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
        tracing::info!(
            "host {name}: {count} grip(s), pointers {first}..{}",
            first + count
        );
        self.admitted += 1;
        self.hosts.push(Host {
            name: name.to_string(),
            id: self.admitted,
            first,
            count,
            heard: now,
            applied: BTreeMap::new(),
        });
        Ok(self.hosts.len() - 1)
    }

    /// Forget the hosts silent since before `now - FORGET_AFTER`; their pointers are parked.
    pub fn forget_silent(&mut self, now: Instant) {
        let (pointers, proxies) = (&mut self.pointers, &mut self.proxies);
        self.hosts.retain(|h| {
            let alive = now.duration_since(h.heard) < FORGET_AFTER;
            if !alive {
                tracing::info!("host {}: silent, forgotten", h.name);
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
        self.impulses.clear();
        self.locals.clear();
        self.step += 1;
        self.peak_energy = self.peak_energy.max(self.kinetic_energy());
        finite
    }

    /// Each host's update of the last step, by name, written into `out` in turn.
    pub fn updates(&self, out: &mut Encoder, mut send: impl FnMut(&str, &[u8])) {
        let poses: Vec<HapticdBodyPose> = (0..self.world.body_count())
            .map(|i| hapticd_core::world_state::body_pose(&self.world.body(i).pose()))
            .collect();
        for host in &self.hosts {
            let mut set = PlaneSet {
                body_count: self.body_count,
                bodies: self.bodies,
                ..PlaneSet::default()
            };
            set.planes[..host.count]
                .copy_from_slice(&self.planes[host.first..host.first + host.count]);
            for b in &mut set.bodies[..self.body_count as usize] {
                b.applied = host.applied.get(&b.body).copied().unwrap_or(0);
            }
            out.clear();
            encode_world(out, self.step, &set, host.count, &poses);
            send(&host.name, out.bytes());
        }
    }

    /// Kinetic energy of the world's moving bodies, joules.
    fn kinetic_energy(&self) -> f64 {
        (0..self.world.body_count())
            .map(|i| {
                let body = self.world.local_body(i);
                if body.inverse_mass <= 0.0 {
                    return 0.0;
                }
                let (v, w) = (DVec3::from(body.velocity), DVec3::from(body.spin));
                let inertia = DMat3::from_cols_array(&body.inverse_inertia)
                    .transpose()
                    .inverse();
                let rotation = if inertia.is_finite() {
                    0.5 * w.dot(inertia * w)
                } else {
                    0.0
                };
                0.5 * v.length_squared() / body.inverse_mass + rotation
            })
            .sum()
    }

    /// The world's state as its status query answers it (JSON): its step, hosts, energy now
    /// and at most, and every body.
    pub fn status(&self, name: &str) -> serde_json::Value {
        let bodies: Vec<_> = (0..self.world.body_count())
            .map(|i| {
                let b = self.world.body(i);
                let local = self.world.local_body(i);
                serde_json::json!({
                    "name": self.names.get(i),
                    "position": b.position.to_array(),
                    "orientation": hapticd_core::kinematics::quat_to_wxyz(b.orientation),
                    "velocity": b.velocity.to_array(),
                    "spin": b.spin.to_array(),
                    "mass": if local.inverse_mass > 0.0 { 1.0 / local.inverse_mass } else { 0.0 },
                })
            })
            .collect();
        let hosts: Vec<_> = self.hosts.iter().map(|h| &h.name).collect();
        serde_json::json!({
            "world": name,
            "step": self.step,
            "rate": 1.0 / self.period,
            "hosts": hosts,
            "kinetic_energy": self.kinetic_energy(),
            "peak_kinetic_energy": self.peak_energy,
            "bodies": bodies,
        })
    }
}

//! One world for several devices of this daemon: two hands in one world (thesis 5.4.7, there
//! with two SPIDAR-G), each device on a haptic thread of its own.
//!
//! A world stepped inside a haptic tick belongs to that tick's thread, so only a multi-rate
//! world (thesis Ch. 6) is shared: a scene plugin's world stepped by a thread of its own,
//! each device rendering it through a linked scene ([`crate::remote_scene::linked`]) exactly
//! as it renders a world on another machine. The thread plays the network's part and
//! `hapticd-world`'s: it takes every device's messages from the device's link, steps the
//! world with every device's grips and hand-backs ([`SharedWorld`]: pointers of its own for
//! each device, two hands pushing one body reconciled so that it does not gain energy
//! neither gave), and delivers each device its planes and bodies. A device that switches to
//! another scene stops speaking; its pointers are parked a second later.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Instant;

use hapticd_core::scene::remote::{HostUpdate, MAX_HOST_BYTES, MAX_WORLD_BYTES, decode_host};
use hapticd_core::scene::shared_world::SharedWorld;
use hapticd_core::scene::world_link::Outbox;
use hapticd_core::scene::{Pointer, Scene};
use hapticd_core::wire::Encoder;
use hapticd_ipc::world_link_share::WorldLink;

use crate::physics_budget::Pacer;
use crate::plugin_scene::PluginWorld;

/// A device that takes part in a shared world.
#[derive(Debug, Clone, Copy)]
pub struct Host<'a> {
    /// Its name (its identity).
    pub name: &'a str,
    /// Its grips.
    pub pointers: &'a [Pointer],
    /// Its ticks a second.
    pub rate: f64,
}

/// The thread stepping a shared world; it stops when this is dropped.
pub struct WorldThread {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Drop for WorldThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// Start stepping `world` for `hosts`: the scene each renders, in their order, and the
/// world's thread.
pub fn start(
    world: PluginWorld,
    hosts: &[Host],
) -> std::io::Result<(Vec<Box<dyn Scene>>, WorldThread)> {
    let mut scenes = Vec::with_capacity(hosts.len());
    let mut links = Vec::with_capacity(hosts.len());
    for host in hosts {
        let link = Arc::new(WorldLink::create()?.0);
        let parts = (world.geometry.clone(), world.object_bodies.clone());
        let scene = crate::remote_scene::linked(
            world.name.clone(),
            world.rate,
            parts,
            link.clone(),
            host.pointers,
        )?;
        scenes.push(scene);
        links.push(link);
    }
    let names: Vec<String> = hosts.iter().map(|h| h.name.to_string()).collect();
    let capacity = hosts.iter().map(|h| h.pointers.len()).sum();
    let (scene, rate) = (world.name.clone(), world.rate);
    let mut shared = SharedWorld::new(world, rate, capacity);
    // Every device in the world, and the world's first step in every link, before any
    // haptic tick: a device never renders without its world.
    let now = Instant::now();
    for host in hosts {
        let grips: Vec<_> = host.pointers.iter().map(Pointer::to_abi).collect();
        let first = HostUpdate {
            seen: 0,
            proxies: grips.clone(),
            pointers: grips,
            impulses: Vec::new(),
            locals: Vec::new(),
            touched: Vec::new(),
        };
        if let Ok(Some(admitted)) = shared.take(host.name, first, now) {
            tracing::info!(
                "{}: grips {}..{} of scene {scene}'s shared world",
                host.name,
                admitted.first,
                admitted.first + admitted.count
            );
        }
    }
    let mut delivered = vec![0u64; links.len()];
    let mut out = Encoder::with_capacity(MAX_WORLD_BYTES);
    if !step_and_deliver(&mut shared, &names, &links, &mut delivered, &mut out) {
        return Err(std::io::Error::other("its world failed its first step"));
    }
    let stop = Arc::new(AtomicBool::new(false));
    let stopping = stop.clone();
    let thread = std::thread::Builder::new()
        .name("hapticd-world".into())
        .spawn(move || {
            let at = Served {
                names: &names,
                links: &links,
                delivered,
                out,
            };
            serve(shared, &scene, at, &stopping)
        })?;
    Ok((
        scenes,
        WorldThread {
            stop,
            thread: Some(thread),
        },
    ))
}

/// The links a world thread serves, by host name, and what it delivered each.
struct Served<'a> {
    names: &'a [String],
    links: &'a [Arc<WorldLink>],
    delivered: Vec<u64>,
    out: Encoder,
}

/// One step of `shared`, each host's update delivered into its link (its `delivered`-th);
/// false when the world failed.
fn step_and_deliver(
    shared: &mut SharedWorld<PluginWorld>,
    names: &[String],
    links: &[Arc<WorldLink>],
    delivered: &mut [u64],
    out: &mut Encoder,
) -> bool {
    if !shared.step() {
        return false;
    }
    shared.updates(out, |host, bytes| {
        if let Some(k) = names.iter().position(|n| n == host) {
            delivered[k] += 1;
            links[k].deliver(delivered[k], bytes);
        }
    });
    true
}

/// Step `shared` (scene `scene`'s world) for the hosts `at` serves until `stop`.
fn serve(mut shared: SharedWorld<PluginWorld>, scene: &str, mut at: Served, stop: &AtomicBool) {
    let period_ns = (shared.period() * 1e9) as u64;
    // Off the haptic CPUs, and real-time only while its steps fit, as a physics thread.
    let mut pacer = Pacer::new(scene.to_string(), period_ns);
    let mut outboxes: Vec<Outbox> = at.links.iter().map(|l| Outbox::after(l)).collect();
    let mut message = Vec::with_capacity(MAX_HOST_BYTES);
    while !stop.load(Ordering::Acquire) {
        let now = Instant::now();
        for ((name, link), outbox) in at.names.iter().zip(at.links).zip(&mut outboxes) {
            outbox.read(link, &mut message, |bytes| {
                // The daemon's own scenes wrote these, for hosts admitted at the start.
                if let Some(update) = decode_host(bytes) {
                    let _ = shared.take(name, update, now);
                }
            });
        }
        shared.forget_silent(now, |name| {
            tracing::info!("{name}: left scene {scene}'s shared world");
        });
        let (names, links) = (at.names, at.links);
        if !step_and_deliver(&mut shared, names, links, &mut at.delivered, &mut at.out) {
            // The devices' scenes find their planes stale and fade out, as after a failed
            // physics thread.
            tracing::error!("scene {scene}: its shared world failed; stopped stepping it");
            return;
        }
        pacer.judge();
        pacer.rest();
    }
}

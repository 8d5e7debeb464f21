//! A scene whose world is stepped on another machine (`engine: remote`,
//! [`hapticd_core::scene::remote`]) or by a world thread of this daemon shared by its devices
//! (its shared scene): rendered here exactly as a multi-rate plugin's world is
//! (the same haptic side, the same checks of what is published), but its "physics thread"
//! steps nothing: it takes each world update the network bridge delivers into the device's
//! world link, and sends back where the grips and proxies are with what the haptic side
//! handed back. The daemon itself never touches the network.
//!
//! A world that stops updating (no bridge, no world host, a cut link) fades as a stalled
//! physics thread does; an update that is no update disables the scene, for the log to say.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use hapticd_core::scene::Pointer;
use hapticd_core::scene::Scene;
use hapticd_core::scene::multirate::PlaneSet;
use hapticd_core::scene::output_check::OutputFault;
use hapticd_core::scene::remote::{
    self, MAX_HOST_BYTES, MAX_WORLD_BYTES, RemoteSceneSpec, decode_world,
};
use hapticd_core::wire::Encoder;
use hapticd_core::world_state::MAX_BODIES;
use hapticd_ipc::world_link_share::WorldLink;
use hapticd_plugin_api::Geometry;

use crate::plugin_scene::{MultiRateScene, Taken};

/// How often the link is looked at, and the longest a hand-back waits to be sent.
const POLL: Duration = Duration::from_millis(1);

/// The scene `name` of `spec` for `pointers`, its world reached through `link`.
pub fn open(
    name: String,
    spec: &RemoteSceneSpec,
    link: Arc<WorldLink>,
    pointers: &[Pointer],
) -> std::io::Result<Box<dyn Scene>> {
    linked(
        name,
        spec.rate,
        (Geometry::default(), Vec::new()),
        link,
        pointers,
    )
}

/// The scene `name` of a world stepped `rate` times a second for `pointers` (drawn as
/// `geometry`, the body of each of its objects in `object_bodies`), reached through `link`:
/// from another machine through the bridge, or from a world of this daemon
/// (its shared scene).
pub fn linked(
    name: String,
    rate: f64,
    (geometry, object_bodies): (Geometry, Vec<u32>),
    link: Arc<WorldLink>,
    pointers: &[Pointer],
) -> std::io::Result<Box<dyn Scene>> {
    let parts = (geometry, None, None, object_bodies);
    let (mut scene, mut physics, _) = MultiRateScene::new(name, parts, rate, pointers);
    // The world hears from the host at least twice a period, touching or not: it learns
    // where the grips are and that the host is there.
    let keep_alive = Duration::from_secs_f64(0.5 / rate);
    scene.thread = Some(
        std::thread::Builder::new()
            .name("hapticd-remote".into())
            .spawn(move || {
                let mut inbox = Vec::with_capacity(MAX_WORLD_BYTES);
                let mut message = Encoder::with_capacity(MAX_HOST_BYTES);
                let mut pending = Taken {
                    impulses: Vec::with_capacity(1024),
                    locals: Vec::with_capacity(1024),
                    touched: Vec::with_capacity(1024),
                };
                let mut set = PlaneSet::default();
                let (mut delivered, mut sent, mut seen) = (0, Instant::now(), 0);
                let n = physics.pointers;
                while !physics.stopping() {
                    physics.add_hand_backs(&mut pending);
                    if let Some(number) = link.latest(&mut inbox)
                        && number != delivered
                    {
                        delivered = number;
                        let poses = &mut physics.bodies.after[..MAX_BODIES];
                        let Some(update) = decode_world(&inbox, &mut set, poses) else {
                            physics.fail(Some(OutputFault::Undecodable { bytes: inbox.len() }));
                            return;
                        };
                        if !physics.publish(&mut set, update.poses) {
                            return;
                        }
                        seen = update.step;
                        physics.steps.0.fetch_add(1, Ordering::Relaxed);
                    }
                    let due = sent.elapsed() >= keep_alive;
                    if due || !pending.impulses.is_empty() || !pending.locals.is_empty() {
                        let hands = *physics.hands_in.latest();
                        let cut = |len: usize| len.min(remote::MAX_HAND_BACKS);
                        let (i, l) = (cut(pending.impulses.len()), cut(pending.locals.len()));
                        message.clear();
                        remote::encode_host(
                            &mut message,
                            seen,
                            &hands.pointers[..n],
                            &hands.proxies[..n],
                            &pending.impulses[..i],
                            (&pending.locals[..l], &pending.touched[..l]),
                        );
                        link.send(message.bytes());
                        pending.impulses.drain(..i);
                        pending.locals.drain(..l);
                        pending.touched.drain(..l);
                        sent = Instant::now();
                    }
                    std::thread::sleep(POLL);
                }
            })?,
    );
    Ok(Box::new(scene))
}

//! A device's world link carried over Zenoh: the updates the world host sends the device go
//! into its link as they arrive, and the messages its remote scene leaves in the link go to
//! the world host, every one and in order (they carry what the hand gave the world). The
//! bridge reads none of them: the daemon checks what it renders, the world host what it
//! takes in.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use hapticd_core::scene::world_link::Outbox;
use hapticd_ipc::client::Device;
use hapticd_zenoh::world_keys;
use zenoh::Wait;
use zenoh::qos::CongestionControl;

use crate::bridge::{BridgeError, zenoh_error};

/// How often the link's outbox is looked at.
const POLL: Duration = Duration::from_millis(1);

/// Carry world `world` to and from `device` (known to the world as `host`) until `until`
/// (for ever without one). Nothing when hapticd refuses the bridge's user the link (said in
/// the log).
pub fn run(
    session: &zenoh::Session,
    device: &Device,
    world: &str,
    host: &str,
    until: Option<Instant>,
) -> Result<(), BridgeError> {
    let link = match device.open_world_link() {
        Ok(link) => Arc::new(link),
        Err(e) => {
            tracing::warn!("{host}: world {world} is not carried: {e}");
            return Ok(());
        }
    };
    let publisher = session
        .declare_publisher(world_keys::to_world(world, host))
        .congestion_control(CongestionControl::Block)
        .wait()
        .map_err(zenoh_error)?;
    let delivered = Arc::new(AtomicU64::new(0));
    let inbox = (link.clone(), delivered.clone());
    let _updates = session
        .declare_subscriber(world_keys::to_host(world, host))
        .callback(move |sample| {
            let number = inbox.1.fetch_add(1, Ordering::Relaxed) + 1;
            inbox.0.deliver(number, &sample.payload().to_bytes());
        })
        .wait()
        .map_err(zenoh_error)?;
    tracing::info!("{host}: carrying world {world}");
    let (mut outbox, mut message) = (Outbox::after(&link), Vec::new());
    while until.is_none_or(|t| Instant::now() < t) {
        let mut put = Ok(());
        let lost = outbox.read(&link, &mut message, |bytes| {
            if put.is_ok() {
                put = publisher.put(bytes.to_vec()).wait();
            }
        });
        if let Some(missed) = lost {
            tracing::warn!("{host}: {missed} messages to world {world} were lost so far");
        }
        put.map_err(zenoh_error)?;
        std::thread::sleep(POLL);
    }
    Ok(())
}

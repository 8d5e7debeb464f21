//! One device on the network: every `every`-th tick of its telemetry ring published as its
//! effectors' `PoseStamped` and `WrenchStamped` (the tick number as the sample's sequence
//! number in its attachment, as rmw_zenoh attaches it), and its status answered as JSON.

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use hapticd_core::telemetry::Sample;
use hapticd_core::world_state::state_of;
use hapticd_ipc::client::{ClientError, Device};
use hapticd_ros2::keys::attachment;
use hapticd_ros2::messages::{Header, Message, PoseStamped, Time, WrenchStamped};
use zenoh::Wait;

use crate::topics::{EffectorTopics, status_key};

/// Nanoseconds since the Unix epoch now: the stamp of what is published.
fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// What went wrong bridging a device.
#[derive(Debug)]
pub enum BridgeError {
    /// hapticd refused or could not be reached.
    Client(ClientError),
    /// Zenoh refused.
    Zenoh(String),
}

impl std::fmt::Display for BridgeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BridgeError::Client(e) => e.fmt(f),
            BridgeError::Zenoh(e) => write!(f, "zenoh: {e}"),
        }
    }
}

impl From<ClientError> for BridgeError {
    fn from(e: ClientError) -> Self {
        BridgeError::Client(e)
    }
}

/// A zenoh error as the bridge says it.
fn zenoh_error(e: impl std::fmt::Display) -> BridgeError {
    BridgeError::Zenoh(e.to_string())
}

/// Publish `device`'s ticks on `session` in ROS domain `domain`, one in `every`, until `until`
/// (for ever without one); answer its status all the while.
pub fn run(
    session: &zenoh::Session,
    device: &Device,
    domain: u32,
    every: u64,
    until: Option<Instant>,
) -> Result<(), BridgeError> {
    let identity = device.identity()?;
    let effectors = device.effectors()?;
    let topics: Vec<EffectorTopics> = effectors
        .iter()
        .map(|e| EffectorTopics::new(domain, &identity, e))
        .collect();
    let mut publishers = Vec::new();
    for t in &topics {
        let pose = session
            .declare_publisher(t.pose.clone())
            .wait()
            .map_err(zenoh_error)?;
        let wrench = session
            .declare_publisher(t.wrench.clone())
            .wait()
            .map_err(zenoh_error)?;
        publishers.push((pose, wrench));
    }
    // The publisher's id in attachments: the session's, as rmw_zenoh derives its own.
    let id: [u8; 16] = session.zid().to_le_bytes();
    let last = Arc::new((AtomicU64::new(0), AtomicU32::new(0)));
    let status = {
        let (identity, last, effectors) = (identity.clone(), last.clone(), effectors.clone());
        let rate = device.open_telemetry()?.rate();
        session
            .declare_queryable(status_key(&identity))
            .callback(move |query| {
                let body = serde_json::json!({
                    "identity": identity,
                    "effectors": effectors,
                    "rate": rate,
                    "tick": last.0.load(Ordering::Relaxed),
                    "state": state_of(last.1.load(Ordering::Relaxed)).name(),
                    "publishing_every": every,
                });
                let _ = query
                    .reply(query.key_expr().clone(), body.to_string())
                    .wait();
            })
            .wait()
            .map_err(zenoh_error)?
    };
    let ring = device.open_telemetry()?;
    let mut cursor = ring.from_now();
    let mut sample = Sample::EMPTY;
    let mut waited = Instant::now();
    while until.is_none_or(|t| Instant::now() < t) {
        if !ring.next(&mut cursor, &mut sample) {
            if waited.elapsed() > Duration::from_secs(2) {
                return Err(BridgeError::Client(ClientError::Stopped));
            }
            std::thread::sleep(Duration::from_micros(200));
            continue;
        }
        waited = Instant::now();
        last.0.store(sample.tick, Ordering::Relaxed);
        last.1.store(sample.state, Ordering::Relaxed);
        if !sample.tick.is_multiple_of(every) {
            continue;
        }
        let stamp = now_ns();
        let attached = attachment(sample.tick as i64, stamp as i64, &id);
        for (k, ((pose, wrench), t)) in publishers.iter().zip(&topics).enumerate() {
            let header = Header {
                stamp: Time::from_nanos(stamp),
                frame_id: t.frame.clone(),
            };
            let p = &sample.poses[k];
            let [w, x, y, z] = p.orientation;
            let pose_message = PoseStamped {
                header: header.clone(),
                position: p.position,
                orientation: [x, y, z, w],
            };
            let wrench_message = WrenchStamped {
                header,
                force: sample.wrenches[k].force,
                torque: sample.wrenches[k].torque,
            };
            pose.put(pose_message.encode())
                .attachment(attached.to_vec())
                .wait()
                .map_err(zenoh_error)?;
            wrench
                .put(wrench_message.encode())
                .attachment(attached.to_vec())
                .wait()
                .map_err(zenoh_error)?;
        }
    }
    drop(status);
    Ok(())
}

//! `org.hapticd.Renderer1` at `/org/hapticd/Renderer1`: pictures of hapticd's world.
//!
//! The service owns its own name (not hapticd's), so that it can come and go (restart after
//! a driver crash) while hapticd's haptic loop runs on untouched. Requests wait for the
//! drawing thread on hapticd's worker threads, never on the bus's.

use std::collections::HashMap;
use std::sync::mpsc::{self, Sender};
use std::sync::{Arc, Mutex, PoisonError};

use hapticd_service::Workers;
use zbus::OwnedVariant;
use zbus::interface;
use zbus::message::Header;

use crate::drawing::{Availability, Job};
use crate::error::Error;
use crate::limits::{Admission, Limits};
use crate::options;
use crate::statistics::Statistics;

/// Size of a snapshot or stream that gives none, pixels.
const DEFAULT_SIZE: (u32, u32) = (640, 480);

/// The renderer on the bus.
pub struct RendererInterface {
    jobs: Mutex<Sender<Job>>,
    workers: Arc<Workers>,
    availability: Availability,
    limits: Limits,
    statistics: Arc<Statistics>,
}

impl RendererInterface {
    /// The interface sending work to the drawing thread through `jobs`, which counts into
    /// `statistics` and keeps the streams within `limits`.
    pub fn new(
        jobs: Sender<Job>,
        workers: Arc<Workers>,
        availability: Availability,
        limits: Limits,
        statistics: Arc<Statistics>,
    ) -> Self {
        Self {
            jobs: Mutex::new(jobs),
            workers,
            availability,
            limits,
            statistics,
        }
    }

    /// Hand `job` (made around its reply channel) to the drawing thread; await the reply.
    async fn ask<T: Send + 'static>(
        &self,
        job: impl FnOnce(Sender<Result<T, Error>>) -> Job,
    ) -> Result<T, Error> {
        let (reply, answer) = mpsc::channel();
        let gone = || Error::Failed("the drawing thread has stopped".into());
        self.jobs
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .send(job(reply))
            .map_err(|_| gone())?;
        self.workers
            .run(move || answer.recv().unwrap_or_else(|_| Err(gone())))
            .await
    }
}

/// Pictures of hapticd's world: its scene, pointers and strings, drawn with Vulkan.
#[interface(name = "org.hapticd.Renderer1")]
impl RendererInterface {
    /// Whether pictures can be drawn here (a Vulkan driver and device were found).
    #[zbus(property(emits_changed_signal = "const"))]
    fn available(&self) -> bool {
        matches!(self.availability, Availability::Available(_))
    }

    /// The device pictures are drawn on, as its driver names it; empty when unavailable.
    #[zbus(property(emits_changed_signal = "const"))]
    fn driver(&self) -> String {
        match &self.availability {
            Availability::Available(name) => name.clone(),
            Availability::Unavailable(_) => String::new(),
        }
    }

    /// Why pictures cannot be drawn; empty when they can.
    #[zbus(property(emits_changed_signal = "const"))]
    fn unavailable_reason(&self) -> String {
        match &self.availability {
            Availability::Available(_) => String::new(),
            Availability::Unavailable(why) => why.clone(),
        }
    }

    /// What the renderer will take on, by the names of its command line's options:
    /// `max-frame-pixels`, `max-streams-per-caller`, `max-streams-per-user`,
    /// `max-streams`, `max-pixel-rate-per-user`, `max-pixel-rate` (pixels a second; a
    /// frame counts as at least 320 × 240), `max-stream-memory` (MiB).
    #[zbus(property(emits_changed_signal = "const"))]
    fn limits(&self) -> HashMap<String, u64> {
        let l = &self.limits;
        HashMap::from([
            ("max-frame-pixels".to_string(), l.max_frame_pixels),
            (
                "max-streams-per-caller".to_string(),
                l.max_streams_per_caller.into(),
            ),
            (
                "max-streams-per-user".to_string(),
                l.max_streams_per_user.into(),
            ),
            ("max-streams".to_string(), l.max_streams.into()),
            (
                "max-pixel-rate-per-user".to_string(),
                l.max_pixel_rate_per_user,
            ),
            ("max-pixel-rate".to_string(), l.max_pixel_rate),
            ("max-stream-memory".to_string(), l.max_stream_memory),
        ])
    }

    /// What the renderer has open and has done: `streams` and `drawings` open (identical
    /// streams share one drawing), the `pixel_rate` they draw and the `stream_memory`
    /// (bytes) their rings hold; `frames_drawn` for streams since it started (a shared
    /// drawing's once), `frames_late` (drawn when the next was already due, so frames were
    /// dropped), `snapshots` drawn, and `snapshot_wait_frames_max`, the most stream frames
    /// begun while a Snapshot waited for its turn.
    #[zbus(property(emits_changed_signal = "false"))]
    fn statistics(&self) -> HashMap<String, u64> {
        self.statistics.by_name()
    }

    /// One picture of the world now, as a PNG file's bytes. Options: `width`, `height`
    /// (pixels, 1–8192, at most `max-frame-pixels` in all; default 640 × 480), and changes
    /// to the scene's camera: `azimuth`, `elevation` (radians), `distance` (metres),
    /// `target` (x, y, z in metres).
    async fn snapshot(&self, options: HashMap<String, OwnedVariant>) -> Result<Vec<u8>, Error> {
        let request = options::parse(&options, DEFAULT_SIZE)?;
        self.limits.check_frame(&request)?;
        let stamp = self.statistics.frames_begun();
        self.ask(|reply| Job::Snapshot {
            request,
            stamp,
            reply,
        })
        .await
    }

    /// A stream of frames for a viewer: a sealed, read-only memfd holding a ring of RGBA
    /// frames (`hapticd_ipc::frame_ring` describes its layout), drawn `rate` times a second
    /// (1–120, default 30) with the options of Snapshot, each announced to the caller
    /// alone by a Frame signal. The frames stop when the caller leaves the bus. Streams
    /// asking for the same picture share one ring, drawn once. Refused beyond the
    /// `Limits`: `TooManyStreams`, `PixelRateTooHigh`, `FrameTooLarge`, `TooMuchMemory`.
    async fn open_frame_stream(
        &self,
        options: HashMap<String, OwnedVariant>,
        #[zbus(header)] header: Header<'_>,
        #[zbus(connection)] connection: &zbus::Connection,
    ) -> Result<zbus::OwnedFd, Error> {
        let request = options::parse(&options, DEFAULT_SIZE)?;
        self.limits.check_frame(&request)?;
        let owner = header
            .sender()
            .map(|s| s.to_string())
            .ok_or_else(|| Error::Failed("a request without a sender".into()))?;
        let uid = unix_user(connection, &owner).await?;
        let fd = self
            .ask(|reply| Job::OpenStream {
                request,
                owner,
                uid,
                reply,
            })
            .await?;
        Ok(fd.into())
    }

    /// Frame `number` of the caller's stream is in its ring (sent to that caller only).
    #[zbus(signal)]
    async fn frame(
        emitter: &zbus::object_server::SignalEmitter<'_>,
        number: u64,
    ) -> zbus::Result<()>;
}

/// The Unix user of the connection `name`, as the bus daemon knows it.
async fn unix_user(connection: &zbus::Connection, name: &str) -> Result<u32, Error> {
    hapticd_ipc::bus::unix_user(connection, name)
        .await
        .map_err(|e| Error::Failed(format!("cannot tell the user of {name}: {e}")))
}

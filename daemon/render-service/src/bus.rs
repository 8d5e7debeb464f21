//! `org.hapticd.Renderer1` at `/org/hapticd/Renderer1`: pictures of hapticd's world.
//!
//! The service owns its own name (not hapticd's), so that it can come and go (restart after
//! a driver crash) while hapticd's haptic loop runs on untouched. Requests wait for the
//! drawing thread on hapticd's worker threads, never on the bus's.

use std::collections::HashMap;
use std::sync::mpsc::{self, Sender};
use std::sync::{Arc, Mutex, PoisonError};

use hapticd::bus::Workers;
use zbus::OwnedVariant;
use zbus::interface;
use zbus::message::Header;

use crate::drawing::{Availability, Job};
use crate::options;

/// The service's well-known name.
pub const BUS_NAME: &str = "org.hapticd.Renderer1";
/// The renderer's object.
pub const OBJECT_PATH: &str = "/org/hapticd/Renderer1";
/// The interface's name.
pub const INTERFACE: &str = "org.hapticd.Renderer1";
/// Size of a snapshot or stream that gives none, pixels.
const DEFAULT_SIZE: (u32, u32) = (640, 480);

/// Errors of the renderer; on D-Bus each is `org.hapticd.Renderer1.Error.<Variant>`.
#[derive(Debug, Clone, PartialEq, zbus::DBusError)]
#[zbus(prefix = "org.hapticd.Renderer1.Error")]
pub enum Error {
    /// An option that is not known, or of the wrong type.
    InvalidOption(String),
    /// A number outside its range.
    OutOfRange(String),
    /// A number that is NaN or infinite.
    NotFinite(String),
    /// No Vulkan driver or device on this machine: the service runs without pictures.
    Unavailable(String),
    /// hapticd is not running, or its world cannot be read.
    NoWorld(String),
    /// Drawing failed.
    Failed(String),
}

/// The renderer on the bus.
pub struct RendererInterface {
    jobs: Mutex<Sender<Job>>,
    workers: Arc<Workers>,
    availability: Availability,
}

impl RendererInterface {
    /// The interface sending work to the drawing thread through `jobs`.
    pub fn new(jobs: Sender<Job>, workers: Arc<Workers>, availability: Availability) -> Self {
        Self {
            jobs: Mutex::new(jobs),
            workers,
            availability,
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

    /// One picture of the world now, as a PNG file's bytes. Options: `width`, `height`
    /// (pixels, 1–8192; default 640 × 480), and changes to the scene's camera: `azimuth`,
    /// `elevation` (radians), `distance` (metres), `target` (x, y, z in metres).
    async fn snapshot(&self, options: HashMap<String, OwnedVariant>) -> Result<Vec<u8>, Error> {
        let request = options::parse(&options, DEFAULT_SIZE)?;
        self.ask(|reply| Job::Snapshot { request, reply }).await
    }

    /// A stream of frames for a viewer: a sealed, read-only memfd holding a ring of RGBA
    /// frames (`hapticd::frame_ring` describes its layout), drawn `rate` times a second
    /// (1–120, default 30) with the options of Snapshot, each announced to the caller
    /// alone by a Frame signal. The frames stop when the caller leaves the bus.
    async fn open_frame_stream(
        &self,
        options: HashMap<String, OwnedVariant>,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<zbus::OwnedFd, Error> {
        let request = options::parse(&options, DEFAULT_SIZE)?;
        let owner = header
            .sender()
            .map(|s| s.to_string())
            .ok_or_else(|| Error::Failed("a request without a sender".into()))?;
        let fd = self
            .ask(|reply| Job::OpenStream {
                request,
                owner,
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

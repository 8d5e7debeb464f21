//! The drawing thread: it owns the Vulkan device and hapticd's world, draws what is asked
//! (a snapshot now, or every frame of each open stream at its rate), and is the only thread
//! that touches either. Requests reach it through a channel; a stream's frames go into its
//! ring and the viewer that opened it is sent a `Frame` signal for each.
//!
//! Streams asking for the same picture (size, camera and rate) share one drawing: it is
//! drawn once into one ring, whose descriptor each of them is handed. Between any two
//! stream frames every request waiting is served, so a Snapshot waits at most for the
//! frame being drawn when it came, however many streams are open; of the drawings due, the
//! one whose frame is latest goes next, so an overloaded thread makes every stream late
//! alike (their late frames are dropped, not caught up with).

use std::os::fd::OwnedFd;
use std::sync::Arc;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::time::{Duration, Instant};

use hapticd_ipc::bus::Bus;
use hapticd_ipc::frame_ring::FrameRingWriter;
use hapticd_ipc::names::{RENDERER_INTERFACE, RENDERER_PATH};
use hapticd_render::caption::{self, Edge};
use hapticd_render::picture::Picture;
use hapticd_render::vulkan::Renderer;

use crate::error::Error;
use crate::limits::{self, Admission, Asked, Held, Limits};
use crate::options::Request;
use crate::statistics::Statistics;
use crate::world_source::WorldSource;

/// The background: a pale sky.
const SKY: [f32; 4] = [0.93, 0.95, 0.98, 1.0];

/// How often streams are checked for viewers that left the bus.
const OWNER_CHECK: Duration = Duration::from_secs(1);

/// What the drawing thread is asked to do.
pub enum Job {
    /// Draw one picture and answer with its PNG.
    Snapshot {
        /// What to draw.
        request: Request,
        /// [`Statistics::frames_begun`] when it was asked for.
        stamp: u64,
        /// Where the answer goes.
        reply: Sender<Result<Vec<u8>, Error>>,
    },
    /// Open a stream of frames for the viewer `owner` (a unique bus name) of user `uid`.
    OpenStream {
        /// Size, camera and rate.
        request: Request,
        /// The viewer, whose frames stop when it leaves the bus.
        owner: String,
        /// The viewer's Unix user, whose streams are counted together.
        uid: u32,
        /// The ring's descriptor, or why not.
        reply: Sender<Result<OwnedFd, Error>>,
    },
    /// The service's bus connection, for signals and to see viewers leave.
    Connected(zbus::Connection),
}

/// Whether pictures can be drawn, and on what.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Availability {
    /// A device to draw on, by its driver's name for it.
    Available(String),
    /// Why not (no loader, no driver, no suitable device).
    Unavailable(String),
}

/// A viewer of a drawing: one open stream.
struct Viewer {
    owner: String,
    uid: u32,
}

/// One picture drawn at its rate for the streams that asked for it.
struct SharedDrawing {
    request: Request,
    ring: FrameRingWriter,
    next: Instant,
    viewers: Vec<Viewer>,
}

/// Start the drawing thread for hapticd's device `device` on `bus`, within `limits`,
/// counting into `statistics`; it ends when the returned sender is dropped.
pub fn start(
    bus: Bus,
    device: usize,
    limits: Limits,
    statistics: Arc<Statistics>,
) -> std::io::Result<(Sender<Job>, Availability)> {
    let (jobs, queue) = mpsc::channel();
    let (told, availability) = mpsc::channel();
    std::thread::Builder::new()
        .name("render-draw".into())
        .spawn(move || {
            let renderer = Renderer::new();
            let _ = told.send(availability_of(&renderer));
            match renderer {
                Ok(renderer) => Drawing {
                    renderer,
                    source: WorldSource::new(bus, device),
                    drawings: Vec::new(),
                    limits,
                    statistics,
                    connection: None,
                    checked: Instant::now(),
                }
                .run(queue),
                // Answer every request with why, until the service ends.
                Err(why) => {
                    for job in queue {
                        refuse(job, &why.0);
                    }
                }
            }
        })?;
    let availability = availability
        .recv()
        .unwrap_or_else(|_| Availability::Unavailable("the drawing thread ended".into()));
    Ok((jobs, availability))
}

fn availability_of(
    renderer: &Result<Renderer, hapticd_render::vulkan::Unavailable>,
) -> Availability {
    match renderer {
        Ok(r) => Availability::Available(r.device_name().to_string()),
        Err(e) => Availability::Unavailable(e.to_string()),
    }
}

fn refuse(job: Job, why: &str) {
    let error = || Error::Unavailable(format!("no pictures on this machine: {why}"));
    match job {
        Job::Snapshot { reply, .. } => {
            let _ = reply.send(Err(error()));
        }
        Job::OpenStream { reply, .. } => {
            let _ = reply.send(Err(error()));
        }
        Job::Connected(_) => {}
    }
}

struct Drawing {
    renderer: Renderer,
    source: WorldSource,
    drawings: Vec<SharedDrawing>,
    limits: Limits,
    statistics: Arc<Statistics>,
    connection: Option<zbus::Connection>,
    checked: Instant,
}

impl Drawing {
    fn run(mut self, queue: Receiver<Job>) {
        loop {
            // Every request waiting goes before the next stream frame.
            loop {
                match queue.try_recv() {
                    Ok(job) => self.handle(job),
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => return,
                }
            }
            if self.checked.elapsed() >= OWNER_CHECK {
                self.forget_departed();
            }
            let now = Instant::now();
            let due = (0..self.drawings.len()).min_by_key(|&k| self.drawings[k].next);
            match due {
                Some(k) if self.drawings[k].next <= now => self.draw_stream(k, now),
                // Nothing due: wait for a request or the next frame's time.
                due => {
                    let job = match due {
                        None => queue.recv().map_err(|_| RecvTimeoutError::Disconnected),
                        Some(k) => queue.recv_timeout(self.drawings[k].next - now),
                    };
                    match job {
                        Ok(job) => self.handle(job),
                        Err(RecvTimeoutError::Timeout) => {}
                        Err(RecvTimeoutError::Disconnected) => return,
                    }
                }
            }
        }
    }

    fn handle(&mut self, job: Job) {
        match job {
            Job::Snapshot {
                request,
                stamp,
                reply,
            } => {
                self.statistics.snapshot_served(stamp);
                let _ = reply.send(self.draw(&request).map(|p| p.to_png()));
            }
            Job::OpenStream {
                request,
                owner,
                uid,
                reply,
            } => {
                let _ = reply.send(self.open_stream(request, owner, uid));
            }
            Job::Connected(connection) => self.connection = Some(connection),
        }
    }

    /// Open a stream for `owner` of user `uid` within the limits: a viewer of the drawing
    /// of the same picture if there is one, else of a new drawing.
    fn open_stream(&mut self, request: Request, owner: String, uid: u32) -> Result<OwnedFd, Error> {
        // Streams of viewers that left are not counted against those that stay.
        self.forget_departed();
        let shared = self.drawings.iter().position(|d| d.request == request);
        let held: Vec<Held> = self
            .drawings
            .iter()
            .flat_map(|d| {
                d.viewers.iter().map(|v| Held {
                    owner: &v.owner,
                    uid: v.uid,
                    request: &d.request,
                })
            })
            .collect();
        let drawn: Vec<&Request> = self.drawings.iter().map(|d| &d.request).collect();
        let asked = Asked {
            owner: &owner,
            uid,
            request: &request,
            shared: shared.is_some(),
        };
        self.limits.check_stream(&asked, &held, &drawn)?;
        let cannot = |e: std::io::Error| Error::Failed(format!("cannot make a frame ring: {e}"));
        let k = match shared {
            Some(k) => k,
            None => {
                let ring =
                    FrameRingWriter::create(request.size.0, request.size.1).map_err(cannot)?;
                self.drawings.push(SharedDrawing {
                    request,
                    ring,
                    next: Instant::now(),
                    viewers: Vec::new(),
                });
                self.drawings.len() - 1
            }
        };
        let fd = self.drawings[k].ring.share().map_err(cannot);
        if fd.is_ok() {
            self.drawings[k].viewers.push(Viewer { owner, uid });
        }
        self.drawings.retain(|d| !d.viewers.is_empty());
        self.count_open();
        fd
    }

    /// One picture, with its status line.
    fn draw(&mut self, request: &Request) -> Result<Picture, Error> {
        let view = self.source.view().map_err(|e| Error::NoWorld(e.0))?;
        let camera = request.view.apply(&view.camera);
        let meshes: Vec<_> = view.scenery.meshes.iter().collect();
        let mut picture = self
            .renderer
            .draw(&meshes, &camera, request.size, SKY)
            .map_err(|e| Error::Failed(e.to_string()))?;
        caption::write(&mut picture, &view.status, Edge::Bottom);
        Ok(picture)
    }

    /// Draw the frame of drawing `k`, due by `now`, and tell each of its viewers.
    fn draw_stream(&mut self, k: usize, now: Instant) {
        let request = self.drawings[k].request;
        let period = Duration::from_secs_f64(1.0 / request.rate);
        let next = self.drawings[k].next + period;
        // Late frames are dropped, not caught up with.
        self.statistics.frame_begun(next < now);
        self.drawings[k].next = next.max(now);
        let Ok(picture) = self.draw(&request) else {
            return;
        };
        let drawing = &mut self.drawings[k];
        let number = drawing.ring.write(&picture.rgba);
        self.statistics.frame_drawn();
        let Some(connection) = &self.connection else {
            return;
        };
        for viewer in &drawing.viewers {
            let _ = zbus::block_on(connection.emit_signal(
                Some(viewer.owner.as_str()),
                RENDERER_PATH,
                RENDERER_INTERFACE,
                "Frame",
                &(number,),
            ));
        }
    }

    /// Forget the streams of viewers that left the bus, and drawings no one views.
    fn forget_departed(&mut self) {
        self.checked = Instant::now();
        let Some(connection) = &self.connection else {
            return;
        };
        let mut present: Vec<(String, bool)> = Vec::new();
        for drawing in &mut self.drawings {
            drawing.viewers.retain(|v| {
                if let Some((_, here)) = present.iter().find(|(name, _)| *name == v.owner) {
                    return *here;
                }
                let here = has_owner(connection, &v.owner);
                present.push((v.owner.clone(), here));
                here
            });
        }
        self.drawings.retain(|d| !d.viewers.is_empty());
        self.count_open();
    }

    /// Publish what is open now.
    fn count_open(&self) {
        let streams = self.drawings.iter().map(|d| d.viewers.len()).sum();
        let rate = self
            .drawings
            .iter()
            .map(|d| limits::pixel_rate(&d.request))
            .sum();
        let memory = self
            .drawings
            .iter()
            .map(|d| limits::ring_bytes(d.request.size))
            .sum();
        self.statistics
            .open(streams, self.drawings.len(), rate, memory);
    }
}

/// Whether `name` is still on the bus.
fn has_owner(connection: &zbus::Connection, name: &str) -> bool {
    let reply = zbus::block_on(connection.call_method(
        Some("org.freedesktop.DBus"),
        "/org/freedesktop/DBus",
        Some("org.freedesktop.DBus"),
        "NameHasOwner",
        &(name,),
    ));
    // If the bus cannot say, keep drawing.
    reply
        .ok()
        .and_then(|m| m.body().deserialize::<bool>().ok())
        .unwrap_or(true)
}

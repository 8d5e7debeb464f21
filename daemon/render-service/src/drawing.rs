//! The drawing thread: it owns the Vulkan device and hapticd's world, draws what is asked
//! (a snapshot now, or every frame of each open stream at its rate), and is the only thread
//! that touches either. Requests reach it through a channel; a stream's frames go into its
//! ring and the viewer that opened it is sent a `Frame` signal for each.

use std::os::fd::OwnedFd;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant};

use hapticd::bus::Bus;
use hapticd::frame_ring::FrameRingWriter;
use hapticd_render::picture::Picture;
use hapticd_render::vulkan::Renderer;

use crate::bus::{Error, OBJECT_PATH};
use crate::options::Request;
use crate::status_line;
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
        /// Where the answer goes.
        reply: Sender<Result<Vec<u8>, Error>>,
    },
    /// Open a stream of frames for the viewer `owner` (a unique bus name).
    OpenStream {
        /// Size, camera and rate.
        request: Request,
        /// The viewer, whose frames stop when it leaves the bus.
        owner: String,
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

/// An open stream.
struct Stream {
    request: Request,
    owner: String,
    ring: FrameRingWriter,
    next: Instant,
}

/// Start the drawing thread for hapticd's device `device` on `bus`; it ends when the
/// returned sender is dropped.
pub fn start(bus: Bus, device: usize) -> std::io::Result<(Sender<Job>, Availability)> {
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
                    streams: Vec::new(),
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
    streams: Vec<Stream>,
    connection: Option<zbus::Connection>,
    checked: Instant,
}

impl Drawing {
    fn run(mut self, queue: Receiver<Job>) {
        loop {
            let job = match self.streams.iter().map(|s| s.next).min() {
                None => queue.recv().map_err(|_| RecvTimeoutError::Disconnected),
                Some(due) => queue.recv_timeout(due.saturating_duration_since(Instant::now())),
            };
            match job {
                Ok(job) => self.handle(job),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            }
            self.draw_streams();
        }
    }

    fn handle(&mut self, job: Job) {
        match job {
            Job::Snapshot { request, reply } => {
                let _ = reply.send(self.draw(&request).map(|p| p.to_png()));
            }
            Job::OpenStream {
                request,
                owner,
                reply,
            } => {
                let opened = FrameRingWriter::create(request.size.0, request.size.1)
                    .and_then(|ring| Ok((ring.share()?, ring)))
                    .map_err(|e| Error::Failed(format!("cannot make a frame ring: {e}")));
                let _ = reply.send(opened.map(|(fd, ring)| {
                    self.streams.push(Stream {
                        request,
                        owner,
                        ring,
                        next: Instant::now(),
                    });
                    fd
                }));
            }
            Job::Connected(connection) => self.connection = Some(connection),
        }
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
        status_line::write(&mut picture, &view.status);
        Ok(picture)
    }

    /// Draw the frames due, and forget streams whose viewer left.
    fn draw_streams(&mut self) {
        if self.checked.elapsed() >= OWNER_CHECK {
            self.checked = Instant::now();
            if let Some(connection) = &self.connection {
                self.streams.retain(|s| has_owner(connection, &s.owner));
            }
        }
        let now = Instant::now();
        for k in 0..self.streams.len() {
            if self.streams[k].next > now {
                continue;
            }
            let request = self.streams[k].request;
            let period = Duration::from_secs_f64(1.0 / request.rate);
            // Late frames are dropped, not caught up with.
            self.streams[k].next = (self.streams[k].next + period).max(now);
            let Ok(picture) = self.draw(&request) else {
                continue;
            };
            let stream = &mut self.streams[k];
            let number = stream.ring.write(&picture.rgba);
            if let Some(connection) = &self.connection {
                let _ = zbus::block_on(connection.emit_signal(
                    Some(stream.owner.as_str()),
                    OBJECT_PATH,
                    crate::bus::INTERFACE,
                    "Frame",
                    &(number,),
                ));
            }
        }
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

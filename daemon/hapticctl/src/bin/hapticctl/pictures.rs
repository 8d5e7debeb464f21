//! Pictures of the running daemon's world, from hapticd-render (`org.hapticd.Renderer1`):
//! `hapticctl snapshot` writes one to a PNG file, `hapticctl view` shows them live in a
//! window (winit, on Wayland or X11), copying each frame of its stream to the window's
//! pixels (softbuffer): the viewer needs no GPU of its own.

use std::collections::HashMap;
use std::num::NonZeroU32;
use std::path::PathBuf;
use std::rc::Rc;
use std::time::{Duration, Instant};

use clap::Args;
use hapticd_ipc::bus::{Bus, has_owner};
use hapticd_ipc::frame_ring::FrameRingReader;
use hapticd_ipc::names::{RENDERER_BUS_NAME, RENDERER_INTERFACE, RENDERER_PATH, error_name};
use hapticd_render::caption::{self, Edge};
use hapticd_render::picture::Picture;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Fullscreen, Window, WindowId};
use zbus::Variant;

use crate::Failure;

/// Size and camera of a picture, as the renderer takes them.
#[derive(Args, Clone)]
pub struct ViewArgs {
    /// Width, pixels (1–8192).
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Height, pixels (1–8192).
    #[arg(long, default_value_t = 480)]
    height: u32,
    /// Turn the scene's camera to this azimuth about the vertical, radians (0: from +z).
    #[arg(long, allow_negative_numbers = true)]
    azimuth: Option<f64>,
    /// Look down onto the scene at this angle, radians.
    #[arg(long, allow_negative_numbers = true)]
    elevation: Option<f64>,
    /// Stand this far from what the camera looks at, metres (a negative one reaches the
    /// renderer, which says why it refuses it).
    #[arg(long, allow_negative_numbers = true)]
    distance: Option<f64>,
    /// Look at this point, metres: x,y,z.
    #[arg(
        long,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    target: Option<Vec<f64>>,
}

impl ViewArgs {
    /// The options of a Snapshot or OpenFrameStream call.
    pub fn options(&self) -> HashMap<&'static str, Variant<'static>> {
        let mut options = HashMap::from([
            ("width", Variant::from(self.width)),
            ("height", Variant::from(self.height)),
        ]);
        for (key, value) in [
            ("azimuth", self.azimuth),
            ("elevation", self.elevation),
            ("distance", self.distance),
        ] {
            if let Some(x) = value {
                options.insert(key, Variant::from(x));
            }
        }
        // The renderer checks that it is three numbers and says so.
        if let Some(target) = &self.target {
            options.insert("target", Variant::from(target.clone()));
        }
        options
    }
}

#[derive(Args)]
pub struct SnapshotArgs {
    /// Where to write the picture (PNG).
    out: PathBuf,
    #[command(flatten)]
    view: ViewArgs,
}

/// Call `method` of the renderer on `bus`.
pub fn call_renderer<B>(bus: &Bus, method: &str, body: &B) -> Result<zbus::Message, Failure>
where
    B: serde::Serialize + zbus::Type,
{
    let connection = renderer_connection(bus)?;
    zbus::block_on(connection.call_method(
        Some(RENDERER_BUS_NAME),
        RENDERER_PATH,
        Some(RENDERER_INTERFACE),
        method,
        body,
    ))
    .map_err(renderer_failure)
}

/// A connection to `bus`, where the renderer must be running (asked without starting it).
fn renderer_connection(bus: &Bus) -> Result<zbus::Connection, Failure> {
    let connection = zbus::block_on(bus.connection())
        .map_err(|e| Failure::failed(format!("cannot reach the bus {bus:?}: {e}")))?;
    match zbus::block_on(has_owner(&connection, RENDERER_BUS_NAME)) {
        Ok(true) => Ok(connection),
        Ok(false) => Err(renderer_not_running()),
        Err(e) => Err(renderer_failure(e)),
    }
}

/// The renderer is not on the bus.
fn renderer_not_running() -> Failure {
    Failure::failed(
        "hapticd-render is not running (it comes with hapticd.service; see \
         `systemctl status hapticd-render`)",
    )
}

/// What a failed call to the renderer tells the user; refused options are usage errors.
fn renderer_failure(e: zbus::Error) -> Failure {
    match e {
        zbus::Error::FDO(fdo)
            if matches!(
                *fdo,
                zbus::fdo::Error::ServiceUnknown(_) | zbus::fdo::Error::NameHasNoOwner(_)
            ) =>
        {
            renderer_not_running()
        }
        zbus::Error::MethodError(name, message, _) => {
            let kind = error_name(name.as_str()).unwrap_or(name.as_str());
            let text = format!("{kind}: {}", message.unwrap_or_default());
            if matches!(kind, "InvalidOption" | "OutOfRange" | "NotFinite") {
                Failure::usage(text)
            } else {
                Failure::failed(text)
            }
        }
        other => Failure::failed(format!("the renderer: {other}")),
    }
}

/// `hapticctl snapshot FILE.png`: a picture of the world now.
pub fn snapshot(args: &SnapshotArgs, bus: &Bus) -> Result<(), Failure> {
    let reply = call_renderer(bus, "Snapshot", &(args.view.options(),))?;
    let png: Vec<u8> = reply
        .body()
        .deserialize()
        .map_err(|e| Failure::failed(format!("the renderer's answer: {e}")))?;
    std::fs::write(&args.out, png)
        .map_err(|e| Failure::failed(format!("cannot write {}: {e}", args.out.display())))
}

#[derive(Args)]
pub struct ViewerArgs {
    /// Fill the screen, without decorations (for a dedicated screen or a kiosk).
    #[arg(long)]
    fullscreen: bool,
    /// Frames per second to ask for (1–120).
    #[arg(long, default_value_t = 30.0)]
    rate: f64,
    /// The frames' size and camera (the window scales them to its size).
    #[command(flatten)]
    view: ViewArgs,
}

/// Ask the renderer on `bus` for a stream of frames; the connection must stay open for
/// the frames to keep coming.
fn open_stream(
    bus: &Bus,
    args: &ViewerArgs,
) -> Result<(zbus::Connection, FrameRingReader), Failure> {
    let connection = renderer_connection(bus)?;
    let mut options = args.view.options();
    options.insert("rate", Variant::from(args.rate));
    let reply = zbus::block_on(connection.call_method(
        Some(RENDERER_BUS_NAME),
        RENDERER_PATH,
        Some(RENDERER_INTERFACE),
        "OpenFrameStream",
        &(options,),
    ))
    .map_err(renderer_failure)?;
    let fd: zbus::OwnedFd = reply
        .body()
        .deserialize()
        .map_err(|e| Failure::failed(format!("the renderer's answer: {e}")))?;
    let ring = FrameRingReader::open(&fd.into()).map_err(|e| Failure::failed(e.to_string()))?;
    Ok((connection, ring))
}

/// After this long without a frame the stream is asked for again (a renderer restarted).
const STALL: Duration = Duration::from_secs(2);

/// After this long without a frame (or four of the stream's periods, if longer) the one
/// shown is marked as old: dimmed, with its age written over it.
const STALE: Duration = Duration::from_millis(500);

/// The window and what it shows.
struct Viewer<'a> {
    bus: &'a Bus,
    args: &'a ViewerArgs,
    /// The stream: its bus connection (kept open) and its ring.
    stream: (zbus::Connection, FrameRingReader),
    window: Option<Rc<Window>>,
    surface: Option<softbuffer::Surface<Rc<Window>, Rc<Window>>>,
    rgba: Vec<u8>,
    shown: u64,
    /// When a frame last came, or the stream was last asked for.
    fresh: Instant,
    /// When the frame shown came.
    arrived: Instant,
    /// The age last written over a stale frame, whole seconds (`None`: shown as fresh).
    marked: Option<u64>,
    failure: Option<Failure>,
}

impl Viewer<'_> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, failure: Failure) {
        self.failure = Some(failure);
        event_loop.exit();
    }

    /// How long the frame shown has been shown, if that makes it stale.
    fn staleness(&self) -> Option<Duration> {
        let period = Duration::from_secs_f64(4.0 / self.args.rate.clamp(1.0, 120.0));
        let age = self.arrived.elapsed();
        (age > STALE.max(period)).then_some(age)
    }

    /// Show the latest frame, scaled to the window; a stale one dimmed, with its age.
    fn present(&mut self) -> Result<(), String> {
        if let Some(number) = self.stream.1.read(&mut self.rgba)
            && number != self.shown
        {
            self.shown = number;
            self.fresh = Instant::now();
            self.arrived = self.fresh;
        }
        self.marked = self.staleness().map(|age| age.as_secs());
        let (Some(window), Some(surface)) = (&self.window, &mut self.surface) else {
            return Ok(());
        };
        let size = window.inner_size();
        let (Some(width), Some(height)) =
            (NonZeroU32::new(size.width), NonZeroU32::new(size.height))
        else {
            return Ok(());
        };
        surface.resize(width, height).map_err(|e| e.to_string())?;
        let mut buffer = surface.buffer_mut().map_err(|e| e.to_string())?;
        let (fw, fh) = self.stream.1.size();
        let stale;
        let rgba = match self.marked {
            Some(seconds) if self.rgba.len() == fw as usize * fh as usize * 4 => {
                let mut picture = Picture {
                    width: fw,
                    height: fh,
                    rgba: self.rgba.iter().map(|&c| c / 2 + 64).collect(),
                };
                caption::write(
                    &mut picture,
                    &format!("no new frame for {seconds} s: is hapticd-render running?"),
                    Edge::Top,
                );
                stale = picture.rgba;
                &stale
            }
            _ => &self.rgba,
        };
        let (w, h) = (size.width as usize, size.height as usize);
        for y in 0..h {
            let sy = y * fh as usize / h;
            for x in 0..w {
                let sx = x * fw as usize / w;
                let at = (sy * fw as usize + sx) * 4;
                buffer[y * w + x] = match rgba.get(at..at + 3) {
                    Some(&[r, g, b]) => u32::from(r) << 16 | u32::from(g) << 8 | u32::from(b),
                    _ => 0x20_22_28,
                };
            }
        }
        buffer.present().map_err(|e| e.to_string())
    }
}

impl ApplicationHandler for Viewer<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let (width, height) = self.stream.1.size();
        let mut attributes = Window::default_attributes()
            .with_title("hapticd")
            .with_inner_size(PhysicalSize::new(width, height));
        if self.args.fullscreen {
            // The window manager's full screen, and the monitor's size and place as well: a
            // kiosk's X server may run no window manager to honour the first.
            attributes = attributes
                .with_decorations(false)
                .with_fullscreen(Some(Fullscreen::Borderless(None)));
            if let Some(monitor) = event_loop
                .primary_monitor()
                .or_else(|| event_loop.available_monitors().next())
            {
                attributes = attributes
                    .with_inner_size(monitor.size())
                    .with_position(monitor.position());
            }
        }
        let window = match event_loop.create_window(attributes) {
            Ok(w) => Rc::new(w),
            Err(e) => return self.fail(event_loop, Failure::failed(format!("no window: {e}"))),
        };
        let surface = softbuffer::Context::new(window.clone())
            .and_then(|context| softbuffer::Surface::new(&context, window.clone()));
        match surface {
            Ok(surface) => {
                self.surface = Some(surface);
                self.window = Some(window);
            }
            Err(e) => self.fail(
                event_loop,
                Failure::failed(format!("cannot draw in the window: {e}")),
            ),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::KeyboardInput { event, .. }
                if event.state.is_pressed()
                    && matches!(
                        event.logical_key.as_ref(),
                        Key::Named(NamedKey::Escape) | Key::Character("q")
                    ) =>
            {
                event_loop.exit()
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.present() {
                    self.fail(
                        event_loop,
                        Failure::failed(format!("cannot show a frame: {e}")),
                    );
                }
            }
            WindowEvent::Resized(_) => {
                if let Some(window) = &self.window {
                    window.request_redraw();
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        // A new frame, or the one shown turning stale or a second older.
        let mark = self.staleness().map(|age| age.as_secs());
        if (self.stream.1.latest() != self.shown || mark != self.marked)
            && let Some(window) = &self.window
        {
            window.request_redraw();
        }
        // A renderer that restarted draws into a new ring: ask for one again.
        if self.fresh.elapsed() > STALL {
            self.fresh = Instant::now();
            if let Ok(stream) = open_stream(self.bus, self.args) {
                self.stream = stream;
                self.shown = 0;
            }
        }
        let period = Duration::from_secs_f64(1.0 / self.args.rate.clamp(1.0, 120.0));
        event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + period / 2));
    }
}

/// `hapticctl view`: a window showing the daemon's world live.
pub fn view(args: &ViewerArgs, bus: &Bus) -> Result<(), Failure> {
    let no_display = "no display to open a window on: set WAYLAND_DISPLAY or DISPLAY, or write \
                      a picture with `hapticctl snapshot FILE.png`";
    if ["WAYLAND_DISPLAY", "DISPLAY"]
        .iter()
        .all(|v| std::env::var_os(v).is_none_or(|d| d.is_empty()))
    {
        return Err(Failure::failed(no_display));
    }
    let stream = open_stream(bus, args)?;
    let event_loop = EventLoop::new().map_err(|e| {
        // winit names the place in its own source where it failed: only the reason is ours.
        let why = e.to_string();
        let reason = why.rsplit_once(": ").map_or(why.as_str(), |(_, r)| r);
        Failure::failed(format!("{no_display} ({reason})"))
    })?;
    let mut viewer = Viewer {
        bus,
        args,
        stream,
        window: None,
        surface: None,
        rgba: Vec::new(),
        shown: 0,
        fresh: Instant::now(),
        arrived: Instant::now(),
        marked: None,
        failure: None,
    };
    event_loop
        .run_app(&mut viewer)
        .map_err(|e| Failure::failed(format!("the window's event loop: {e}")))?;
    viewer.failure.map_or(Ok(()), Err)
}

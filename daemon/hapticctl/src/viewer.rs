//! A window showing the running daemon's world live (`hapticctl view`), on Wayland or X11
//! (winit): each frame of hapticd-render's stream is copied to the window's pixels
//! (softbuffer), so the viewer needs no GPU of its own. A frame that stops coming is dimmed
//! and captioned with its age; a renderer that restarted is asked for its stream again.

use std::num::NonZeroU32;
use std::rc::Rc;
use std::time::{Duration, Instant};

use hapticd_ipc::bus::Bus;
use hapticd_render::caption::{self, Edge};
use hapticd_render::picture::Picture;
use softbuffer::SoftBufferError;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::error::{EventLoopError, OsError};
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Fullscreen, Window, WindowId};

use crate::pictures::{RendererError, Stream, View, open_stream};

/// After this long without a frame the stream is asked for again (a renderer restarted).
const STALL: Duration = Duration::from_secs(2);

/// After this long without a frame (or four of the stream's periods, if longer) the one
/// shown is marked as old: dimmed, with its age written over it.
const STALE: Duration = Duration::from_millis(500);

/// What a user without a display is told.
const NO_DISPLAY: &str = "no display to open a window on: set WAYLAND_DISPLAY or DISPLAY, or \
                          write a picture with `hapticctl snapshot FILE.png`";

/// Why the window could not show the world.
#[derive(Debug)]
pub enum ViewError {
    /// There is no display to open a window on; the windowing system's reason, when it said
    /// one.
    NoDisplay(Option<String>),
    /// The renderer gave no stream.
    Renderer(RendererError),
    /// The window could not be made.
    Window(OsError),
    /// The window could not be drawn in.
    Surface(SoftBufferError),
    /// A frame could not be shown.
    Frame(SoftBufferError),
    /// The window's event loop failed.
    EventLoop(EventLoopError),
}

impl std::fmt::Display for ViewError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ViewError::NoDisplay(None) => f.write_str(NO_DISPLAY),
            ViewError::NoDisplay(Some(reason)) => write!(f, "{NO_DISPLAY} ({reason})"),
            ViewError::Renderer(e) => write!(f, "{e}"),
            ViewError::Window(e) => write!(f, "no window: {e}"),
            ViewError::Surface(e) => write!(f, "cannot draw in the window: {e}"),
            ViewError::Frame(e) => write!(f, "cannot show a frame: {e}"),
            ViewError::EventLoop(e) => write!(f, "the window's event loop: {e}"),
        }
    }
}

impl std::error::Error for ViewError {}

impl ViewError {
    /// Whether the renderer refused the options asked for (see
    /// [`RendererError::refuses_options`]).
    pub fn refuses_options(&self) -> bool {
        matches!(self, ViewError::Renderer(e) if e.refuses_options())
    }
}

/// Show the world in a window until it is closed (or Escape or `q` is pressed): frames of
/// the renderer on `bus` as `view` asks, `rate` a second, filling the screen if
/// `fullscreen`.
pub fn show(bus: &Bus, view: &View, rate: f64, fullscreen: bool) -> Result<(), ViewError> {
    if ["WAYLAND_DISPLAY", "DISPLAY"]
        .iter()
        .all(|v| std::env::var_os(v).is_none_or(|d| d.is_empty()))
    {
        return Err(ViewError::NoDisplay(None));
    }
    let stream = open_stream(bus, view, rate).map_err(ViewError::Renderer)?;
    let event_loop = EventLoop::new().map_err(|e| {
        // winit names the place in its own source where it failed: only the reason is ours.
        let why = e.to_string();
        let reason = why.rsplit_once(": ").map_or(why.as_str(), |(_, r)| r);
        ViewError::NoDisplay(Some(reason.to_string()))
    })?;
    let mut viewer = Viewer {
        bus,
        view,
        rate,
        fullscreen,
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
        .map_err(ViewError::EventLoop)?;
    viewer.failure.map_or(Ok(()), Err)
}

/// The window and what it shows.
struct Viewer<'a> {
    bus: &'a Bus,
    view: &'a View,
    /// Frames a second asked for.
    rate: f64,
    fullscreen: bool,
    stream: Stream,
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
    failure: Option<ViewError>,
}

impl Viewer<'_> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, failure: ViewError) {
        self.failure = Some(failure);
        event_loop.exit();
    }

    /// How long the frame shown has been shown, if that makes it stale.
    fn staleness(&self) -> Option<Duration> {
        let period = Duration::from_secs_f64(4.0 / self.rate.clamp(1.0, 120.0));
        let age = self.arrived.elapsed();
        (age > STALE.max(period)).then_some(age)
    }

    /// Show the latest frame, scaled to the window; a stale one dimmed, with its age.
    fn present(&mut self) -> Result<(), SoftBufferError> {
        if let Some(number) = self.stream.ring.read(&mut self.rgba)
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
        surface.resize(width, height)?;
        let mut buffer = surface.buffer_mut()?;
        let frame = self.stream.ring.size();
        let stale;
        let rgba = match self.marked {
            Some(seconds) if self.rgba.len() == frame.0 as usize * frame.1 as usize * 4 => {
                stale = marked_stale(&self.rgba, frame, seconds);
                &stale
            }
            _ => &self.rgba,
        };
        scale_into(&mut buffer, (size.width, size.height), rgba, frame);
        buffer.present()
    }
}

/// A frame `width × height` (`rgba`) shown `seconds` after it came: dimmed, and captioned.
fn marked_stale(rgba: &[u8], (width, height): (u32, u32), seconds: u64) -> Vec<u8> {
    let mut picture = Picture {
        width,
        height,
        rgba: rgba.iter().map(|&c| c / 2 + 64).collect(),
    };
    caption::write(
        &mut picture,
        &format!("no new frame for {seconds} s: is hapticd-render running?"),
        Edge::Top,
    );
    picture.rgba
}

/// Copy the frame `rgba` of `frame` pixels into `buffer` of `window` pixels (0RGB), scaled
/// to fill it; where the frame has no pixel (not yet come), a dark grey.
fn scale_into(buffer: &mut [u32], window: (u32, u32), rgba: &[u8], frame: (u32, u32)) {
    let (w, h) = (window.0 as usize, window.1 as usize);
    let (fw, fh) = (frame.0 as usize, frame.1 as usize);
    for y in 0..h {
        let sy = y * fh / h;
        for x in 0..w {
            let sx = x * fw / w;
            let at = (sy * fw + sx) * 4;
            buffer[y * w + x] = match rgba.get(at..at + 3) {
                Some(&[r, g, b]) => u32::from(r) << 16 | u32::from(g) << 8 | u32::from(b),
                _ => 0x20_22_28,
            };
        }
    }
}

impl ApplicationHandler for Viewer<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let (width, height) = self.stream.ring.size();
        let mut attributes = Window::default_attributes()
            .with_title("hapticd")
            .with_inner_size(PhysicalSize::new(width, height));
        if self.fullscreen {
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
            Err(e) => return self.fail(event_loop, ViewError::Window(e)),
        };
        let surface = softbuffer::Context::new(window.clone())
            .and_then(|context| softbuffer::Surface::new(&context, window.clone()));
        match surface {
            Ok(surface) => {
                self.surface = Some(surface);
                self.window = Some(window);
            }
            Err(e) => self.fail(event_loop, ViewError::Surface(e)),
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
                    self.fail(event_loop, ViewError::Frame(e));
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
        if (self.stream.ring.latest() != self.shown || mark != self.marked)
            && let Some(window) = &self.window
        {
            window.request_redraw();
        }
        // A renderer that restarted draws into a new ring: ask for one again.
        if self.fresh.elapsed() > STALL {
            self.fresh = Instant::now();
            if let Ok(stream) = open_stream(self.bus, self.view, self.rate) {
                self.stream = stream;
                self.shown = 0;
            }
        }
        let period = Duration::from_secs_f64(1.0 / self.rate.clamp(1.0, 120.0));
        event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + period / 2));
    }
}

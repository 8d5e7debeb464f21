//! Pictures of the running daemon's world, asked of hapticd-render (`org.hapticd.Renderer1`)
//! on the bus: one as PNG bytes, or a stream of frames in a shared ring (which
//! `viewer` shows in a window).

use std::collections::HashMap;

use hapticd_ipc::bus::{Bus, has_owner};
use hapticd_ipc::frame_ring::FrameRingReader;
use hapticd_ipc::names::{RENDERER_BUS_NAME, RENDERER_INTERFACE, RENDERER_PATH, error_name};
use hapticd_ipc::shared_memory::MapError;
use zbus::Variant;

/// Size and camera of a picture, as the renderer takes them; a camera setting left out is
/// the scene's own.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct View {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Azimuth about the vertical, radians (0: from +z).
    pub azimuth: Option<f64>,
    /// Angle looking down onto the scene, radians.
    pub elevation: Option<f64>,
    /// Distance from what the camera looks at, metres.
    pub distance: Option<f64>,
    /// The point looked at, metres (the renderer checks that it is three numbers).
    pub target: Option<Vec<f64>>,
}

impl View {
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
        if let Some(target) = &self.target {
            options.insert("target", Variant::from(target.clone()));
        }
        options
    }
}

/// Why the renderer gave no picture.
#[derive(Debug)]
pub enum RendererError {
    /// The bus cannot be reached.
    Bus {
        /// The bus.
        bus: Bus,
        /// Why not.
        error: zbus::Error,
    },
    /// hapticd-render is not on the bus.
    NotRunning,
    /// The renderer refused the call.
    Refused {
        /// Its error's name, less the interface's prefix.
        kind: String,
        /// What it said.
        message: String,
    },
    /// The call failed otherwise.
    Call(zbus::Error),
    /// The answer is not what the call returns.
    Answer(zbus::Error),
    /// The stream's ring cannot be read.
    Ring(MapError),
}

impl std::fmt::Display for RendererError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RendererError::Bus { bus, error } => write!(f, "cannot reach the bus {bus:?}: {error}"),
            RendererError::NotRunning => f.write_str(
                "hapticd-render is not running (it comes with hapticd.service; see \
                 `systemctl status hapticd-render`)",
            ),
            RendererError::Refused { kind, message } => write!(f, "{kind}: {message}"),
            RendererError::Call(e) => write!(f, "the renderer: {e}"),
            RendererError::Answer(e) => write!(f, "the renderer's answer: {e}"),
            RendererError::Ring(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for RendererError {}

impl RendererError {
    /// Whether the renderer refused the options asked for (a size, camera or rate it does
    /// not take): the caller's mistake, not the renderer's.
    pub fn refuses_options(&self) -> bool {
        matches!(
            self,
            RendererError::Refused { kind, .. }
                if matches!(kind.as_str(), "InvalidOption" | "OutOfRange" | "NotFinite")
        )
    }

    /// What a failed call to the renderer means.
    fn of_call(error: zbus::Error) -> Self {
        match error {
            zbus::Error::FDO(fdo)
                if matches!(
                    *fdo,
                    zbus::fdo::Error::ServiceUnknown(_) | zbus::fdo::Error::NameHasNoOwner(_)
                ) =>
            {
                RendererError::NotRunning
            }
            zbus::Error::MethodError(name, message, _) => RendererError::Refused {
                kind: error_name(name.as_str())
                    .unwrap_or(name.as_str())
                    .to_string(),
                message: message.unwrap_or_default(),
            },
            other => RendererError::Call(other),
        }
    }
}

/// A stream of frames: the ring the renderer draws them into, and the bus connection that
/// asked for it, which must stay open for the frames to keep coming.
pub struct Stream {
    /// The connection that opened the stream.
    pub connection: zbus::Connection,
    /// The frames.
    pub ring: FrameRingReader,
}

/// Call `method` of the renderer on `bus` with `options` (asked without starting it).
fn call(
    bus: &Bus,
    method: &str,
    options: HashMap<&'static str, Variant<'static>>,
) -> Result<(zbus::Connection, zbus::Message), RendererError> {
    let connection = zbus::block_on(bus.connection()).map_err(|error| RendererError::Bus {
        bus: bus.clone(),
        error,
    })?;
    match zbus::block_on(has_owner(&connection, RENDERER_BUS_NAME)) {
        Ok(true) => {}
        Ok(false) => return Err(RendererError::NotRunning),
        Err(e) => return Err(RendererError::of_call(e)),
    }
    let reply = zbus::block_on(connection.call_method(
        Some(RENDERER_BUS_NAME),
        RENDERER_PATH,
        Some(RENDERER_INTERFACE),
        method,
        &(options,),
    ))
    .map_err(RendererError::of_call)?;
    Ok((connection, reply))
}

/// A picture of the world now as `view` asks, as a PNG file's bytes.
pub fn snapshot(bus: &Bus, view: &View) -> Result<Vec<u8>, RendererError> {
    let (_, reply) = call(bus, "Snapshot", view.options())?;
    reply.body().deserialize().map_err(RendererError::Answer)
}

/// A stream of pictures as `view` asks, `rate` a second.
pub fn open_stream(bus: &Bus, view: &View, rate: f64) -> Result<Stream, RendererError> {
    let mut options = view.options();
    options.insert("rate", Variant::from(rate));
    let (connection, reply) = call(bus, "OpenFrameStream", options)?;
    let fd: zbus::OwnedFd = reply.body().deserialize().map_err(RendererError::Answer)?;
    let ring = FrameRingReader::open(&fd.into()).map_err(RendererError::Ring)?;
    Ok(Stream { connection, ring })
}

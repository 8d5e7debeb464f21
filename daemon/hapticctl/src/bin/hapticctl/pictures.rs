//! Pictures of the running daemon's world, from hapticd-render (`org.hapticd.Renderer1`):
//! `hapticctl snapshot` writes one to a PNG file.

use std::collections::HashMap;
use std::path::PathBuf;

use clap::Args;
use hapticd::bus::Bus;
use zbus::Variant;

use crate::Failure;

/// The renderer's bus name, object and interface.
pub const RENDERER: &str = "org.hapticd.Renderer1";
const RENDERER_PATH: &str = "/org/hapticd/Renderer1";

/// Size and camera of a picture, as the renderer takes them.
#[derive(Args, Clone, Copy)]
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
    /// Stand this far from what the camera looks at, metres.
    #[arg(long)]
    distance: Option<f64>,
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
    let connection = zbus::block_on(bus.connection())
        .map_err(|e| Failure::failed(format!("cannot reach the bus {bus:?}: {e}")))?;
    zbus::block_on(connection.call_method(
        Some(RENDERER),
        RENDERER_PATH,
        Some(RENDERER),
        method,
        body,
    ))
    .map_err(renderer_failure)
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
            Failure::failed(
                "hapticd-render is not running (it comes with hapticd.service; see \
                 `systemctl status hapticd-render`)",
            )
        }
        zbus::Error::MethodError(name, message, _) => {
            let kind = name
                .as_str()
                .trim_start_matches("org.hapticd.Renderer1.Error.");
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

//! `hapticctl snapshot` and `hapticctl view`: pictures of the running daemon's world from
//! hapticd-render, written to a PNG file ([`hapticctl::pictures`]) or shown live in a window
//! ([`hapticctl::viewer`]).

use std::path::PathBuf;

use clap::Args;
use hapticctl::pictures::{self, View};
use hapticctl::viewer;
use hapticd_ipc::bus::Bus;

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
    /// The picture asked for.
    fn view(&self) -> View {
        View {
            width: self.width,
            height: self.height,
            azimuth: self.azimuth,
            elevation: self.elevation,
            distance: self.distance,
            target: self.target.clone(),
        }
    }
}

#[derive(Args)]
pub struct SnapshotArgs {
    /// Where to write the picture (PNG).
    out: PathBuf,
    #[command(flatten)]
    view: ViewArgs,
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

/// Options the renderer refused are usage errors; anything else failed.
fn failure(refused_options: bool, error: impl std::fmt::Display) -> Failure {
    if refused_options {
        Failure::usage(error)
    } else {
        Failure::failed(error)
    }
}

/// `hapticctl snapshot FILE.png`: a picture of the world now.
pub fn snapshot(args: &SnapshotArgs, bus: &Bus) -> Result<(), Failure> {
    let png =
        pictures::snapshot(bus, &args.view.view()).map_err(|e| failure(e.refuses_options(), e))?;
    std::fs::write(&args.out, png)
        .map_err(|e| Failure::failed(format!("cannot write {}: {e}", args.out.display())))
}

/// `hapticctl view`: a window showing the daemon's world live.
pub fn view(args: &ViewerArgs, bus: &Bus) -> Result<(), Failure> {
    viewer::show(bus, &args.view.view(), args.rate, args.fullscreen)
        .map_err(|e| failure(e.refuses_options(), e))
}

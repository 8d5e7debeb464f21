//! `hapticctl render`: one frame of a scene file, drawn with Vulkan, no daemon needed
//! ([`hapticctl::scenery`]).

use std::path::PathBuf;

use clap::Args;
use glam::DVec3;
use hapticctl::scenery::{SceneryError, add_mechanism, draw, scenery};
use hapticd_config::catalog::Catalog;
use hapticd_core::kinematics::Pose;
use hapticd_render::vulkan::MAX_EDGE;

use crate::Failure;
use crate::mechanism::{Numbers, parse_numbers, resolve, vec3};

#[derive(Args)]
pub struct RenderArgs {
    /// Scene file: static (`shapes:`) or physics (`bodies:`, either engine), or the name of
    /// an installed scene.
    scene: PathBuf,
    /// Where to write the picture (PNG).
    #[arg(long)]
    out: PathBuf,
    /// Width, pixels (1–8192).
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Height, pixels (1–8192).
    #[arg(long, default_value_t = 480)]
    height: u32,
    /// Physics scenes: step the world this many seconds first (0–600); the camera frames
    /// the scene as it was at the start.
    #[arg(long, default_value_t = 0.0)]
    at: f64,
    /// Draw this mechanism too (a name or descriptor, as `hapticctl mechanism` takes it):
    /// its motors, its grips at their calibration poses and its strings coloured by tension.
    #[arg(long)]
    mechanism: Option<String>,
    /// With `--mechanism`: the force, newtons, each grip presents (x,y,z), which sets the
    /// strings' tensions; drawn as an arrow at the grip (5 mm per newton).
    #[arg(long, value_parser = parse_numbers, allow_negative_numbers = true)]
    force: Option<Numbers>,
    /// Physics scenes: hold the first hand's pointer still here (x,y,z, metres) instead of
    /// at its calibration pose, so that the picture shows the scene as it answers a finger
    /// there (with `--at`: a soft body pressed).
    #[arg(long, value_parser = parse_numbers, allow_negative_numbers = true)]
    grip: Option<Numbers>,
}

/// Farthest a grip may be held from the origin, metres: well beyond any workspace.
const FARTHEST_GRIP: f64 = 10.0;

/// Draw one frame of `args.scene`, with the mechanism asked for from `catalog`.
pub fn run(args: &RenderArgs, catalog: &Catalog) -> Result<(), Failure> {
    for (name, value) in [("--width", args.width), ("--height", args.height)] {
        if !(1..=MAX_EDGE).contains(&value) {
            return Err(Failure::usage(format!(
                "{name} must be 1–{MAX_EDGE} pixels, not {value}"
            )));
        }
    }
    if !(0.0..=600.0).contains(&args.at) {
        return Err(Failure::usage(format!(
            "--at must be 0–600 s, not {}",
            args.at
        )));
    }
    let mechanism = args
        .mechanism
        .as_deref()
        .map(|name| resolve(catalog, name))
        .transpose()?;
    // The hands rest at the mechanism's calibration poses, or one at the origin, where
    // the shipped mechanisms calibrate theirs.
    let mut rests: Vec<Pose> = match &mechanism {
        Some(m) => m.effectors.iter().map(|e| e.calibration).collect(),
        None => vec![Pose::IDENTITY],
    };
    if let Some(grip) = args.grip.as_deref() {
        let grip = vec3(grip, "--grip")?;
        if grip.length() > FARTHEST_GRIP {
            return Err(Failure::usage(format!(
                "--grip must lie within {FARTHEST_GRIP} m of the origin"
            )));
        }
        rests[0].position = grip;
    }
    let scene = crate::scene_file::resolve(&args.scene)?;
    let (mut scenery, mut camera) = scenery(&scene, args.at, &rests).map_err(|e| match e {
        SceneryError::Input(e) => Failure::from(e),
        SceneryError::Static => {
            Failure::usage("--at is for physics scenes; a static scene stays put")
        }
        e => Failure::failed(e),
    })?;
    match (&mechanism, &args.force) {
        (Some(mechanism), force) => {
            let force = force
                .as_deref()
                .map_or(Ok(DVec3::ZERO), |f| vec3(f, "--force"))?;
            if !force.is_finite() || force.length() > 1e3 {
                return Err(Failure::usage("--force must be finite and at most 1000 N"));
            }
            add_mechanism(&mut scenery, mechanism, force);
            camera = scenery.camera();
        }
        (None, Some(_)) => return Err(Failure::usage("--force needs --mechanism")),
        (None, None) => {}
    }
    let picture = draw(&scenery, &camera, (args.width, args.height)).map_err(Failure::failed)?;
    picture.write_png(&args.out).map_err(Failure::failed)
}

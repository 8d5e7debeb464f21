//! `hapticctl render`: one frame of a scene file, drawn with Vulkan, no daemon needed.

use std::path::{Path, PathBuf};

use clap::Args;
use hapticctl::scenery::Scenery;
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_physics::scene::SceneFile;
use hapticd_plugin_api::HapticdPlanes;
use hapticd_rapier::world::RapierWorld;
use hapticd_render::camera::Camera;
use hapticd_render::vulkan::{MAX_EDGE, Picture, Renderer};

use crate::Failure;

/// The background: a pale sky.
const SKY: [f32; 4] = [0.93, 0.95, 0.98, 1.0];

#[derive(Args)]
pub struct RenderArgs {
    /// Scene file: static (`shapes:`) or physics (`bodies:`, either engine).
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
}

/// Whether the file at `path` describes physics (its `bodies:`) rather than static solids.
fn is_physics(text: &str) -> bool {
    text.lines().any(|l| l.starts_with("bodies:"))
}

/// What the scene file shows after `at` seconds, and a camera that frames it as it was at
/// the start (so pictures at several times compare).
fn scenery(path: &Path, at: f64) -> Result<(Scenery, Camera), Failure> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Failure::failed(format!("cannot read {}: {e}", path.display())))?;
    if !is_physics(&text) {
        if at != 0.0 {
            return Err(Failure::usage(
                "--at is for physics scenes; a static scene stays put",
            ));
        }
        let scenery = Scenery::of_static(&StaticSceneSpec::parse(&text, path)?);
        let camera = scenery.camera();
        return Ok((scenery, camera));
    }
    match SceneFile::parse(&text, path, 0)? {
        SceneFile::Penalty(mut scene) => {
            let camera = Scenery::of_penalty(&scene.world.bodies, scene.first_pointer).camera();
            let steps = (at / scene.dt).round() as usize;
            for _ in 0..steps {
                if !scene.step_pointers(scene.dt, &[], &mut []) {
                    return Err(Failure::failed(format!(
                        "{}: the world is no longer finite",
                        path.display()
                    )));
                }
            }
            let scenery = Scenery::of_penalty(&scene.world.bodies, scene.first_pointer);
            Ok((scenery, camera))
        }
        SceneFile::Rapier(spec) => {
            let mut world = RapierWorld::new(&spec, 0);
            let camera = Scenery::of_rapier(&world, &spec).camera();
            let steps = (at * spec.rate).round() as usize;
            let mut planes: [HapticdPlanes; 0] = [];
            for _ in 0..steps {
                if !world.step(1.0 / spec.rate, &[], &[], &mut planes) {
                    return Err(Failure::failed(format!(
                        "{}: the world is no longer finite",
                        path.display()
                    )));
                }
            }
            Ok((Scenery::of_rapier(&world, &spec), camera))
        }
    }
}

/// Write `picture` to `path` as PNG.
pub fn save_png(picture: &Picture, path: &Path) -> Result<(), Failure> {
    let failed = |e: &dyn std::fmt::Display| {
        Failure::failed(format!("cannot write {}: {e}", path.display()))
    };
    let file = std::fs::File::create(path).map_err(|e| failed(&e))?;
    let mut encoder =
        png::Encoder::new(std::io::BufWriter::new(file), picture.width, picture.height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_compression(png::Compression::Fast);
    encoder
        .write_header()
        .and_then(|mut w| w.write_image_data(&picture.rgba))
        .map_err(|e| failed(&e))
}

/// Draw one frame of `args.scene`.
pub fn run(args: &RenderArgs) -> Result<(), Failure> {
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
    let (scenery, camera) = scenery(&args.scene, args.at)?;
    let renderer = Renderer::new().map_err(|e| Failure::failed(format!("cannot render: {e}")))?;
    let meshes: Vec<_> = scenery.meshes.iter().collect();
    let picture = renderer
        .draw(&meshes, &camera, (args.width, args.height), SKY)
        .map_err(|e| Failure::failed(format!("cannot render: {e}")))?;
    save_png(&picture, &args.out)
}

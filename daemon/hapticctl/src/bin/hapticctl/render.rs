//! `hapticctl render`: one frame of a scene file, drawn with Vulkan, no daemon needed.

use std::path::{Path, PathBuf};

use clap::Args;
use hapticd_core::scene::engine::{Engine, engine_of_text};
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_physics::coupling::Grip;
use hapticd_physics::scene::{PenaltyScene, SceneFile};
use hapticd_rapier::world::RapierWorld;
use hapticd_render::camera::Camera;
use hapticd_render::scenery::Scenery;
use hapticd_render::shading::Shaded;
use hapticd_render::vulkan::{MAX_EDGE, Renderer};

use crate::Failure;
use crate::mechanism::{Numbers, parse_numbers, resolve, vec3};
use glam::DVec3;
use hapticd_config::catalog::Catalog;
use hapticd_core::kinematics::{Pose, Wrench};
use hapticd_core::solver::geometry::StringGeometry;

/// The background: a pale sky.
const SKY: [f32; 4] = [0.93, 0.95, 0.98, 1.0];

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
}

/// Add `name`'s mechanism to `scenery`, each grip presenting `force`.
fn add_mechanism(
    scenery: &mut Scenery,
    catalog: &Catalog,
    name: &str,
    force: DVec3,
) -> Result<(), Failure> {
    let mechanism = resolve(catalog, name)?;
    let poses: Vec<Pose> = mechanism.effectors.iter().map(|e| e.calibration).collect();
    let mut tensions = vec![0.0; mechanism.strings.len()];
    for (index, effector) in mechanism.effectors.iter().enumerate() {
        let geometry = StringGeometry::at(&mechanism.kinematics(index), &poses[index]);
        let solution = mechanism
            .tension_solver(index)
            .solve(&geometry, &Wrench::force(force));
        for (&string, &t) in effector.strings.iter().zip(solution.tensions()) {
            tensions[string] = t;
        }
    }
    let forces = vec![force; poses.len()];
    scenery.add_mechanism(&mechanism, &poses, &tensions, &forces);
    Ok(())
}

/// What the scene file shows after `at` seconds with a hand resting at each of `rests`
/// (the scene's pointers there), and a camera that frames it as it was at the start (so
/// pictures at several times compare).
fn scenery(path: &Path, at: f64, rests: &[Pose]) -> Result<(Scenery, Camera), Failure> {
    let text = hapticd_core::diagnostics::read_text(path)?;
    let resting: Vec<DVec3> = rests.iter().map(|r| r.position).collect();
    if engine_of_text(&text, path)? == Engine::Static {
        if at != 0.0 {
            return Err(Failure::usage(
                "--at is for physics scenes; a static scene stays put",
            ));
        }
        let geometry = Shaded::new(
            StaticSceneSpec::parse_with_meshes(&text, path, &hapticd_mesh::scene_triangles)?
                .geometry(),
        );
        let mut scenery = Scenery::of_geometry(&geometry, &[]);
        scenery.add_proxies(&resting);
        let camera = scenery.camera();
        return Ok((scenery, camera));
    }
    let file = SceneFile::parse(&text, path, rests.len())?;
    let geometry = Shaded::new(file.geometry());
    let no_longer_finite =
        || Failure::failed(format!("{}: the world is no longer finite", path.display()));
    match file {
        SceneFile::Penalty(mut scene) => {
            // The pointers' solids are placed at the grips by the first step.
            let grips: Vec<Grip> = rests
                .iter()
                .map(|r| Grip {
                    position: r.position,
                    orientation: r.orientation,
                    velocity: DVec3::ZERO,
                    spin: DVec3::ZERO,
                })
                .collect();
            let mut felt = vec![Wrench::default(); grips.len()];
            let mut step = |scene: &mut PenaltyScene| {
                let dt = scene.dt;
                scene
                    .step_pointers(dt, &grips, &mut felt)
                    .then_some(())
                    .ok_or_else(no_longer_finite)
            };
            step(&mut scene)?;
            let camera = Scenery::of_geometry(&geometry, &scene.poses()).camera();
            for _ in 1..(at / scene.dt).round() as usize {
                step(&mut scene)?;
            }
            Ok((Scenery::of_geometry(&geometry, &scene.poses()), camera))
        }
        SceneFile::Rapier(spec) => {
            // The rapier scenes' pointers are drawn where the fingers rest, as the daemon
            // draws them.
            let mut world = RapierWorld::new(&spec, 0);
            let at_start = |world: &RapierWorld| {
                let mut scenery = Scenery::of_geometry(&geometry, &world.poses());
                scenery.add_proxies(&resting);
                scenery
            };
            let camera = at_start(&world).camera();
            for _ in 0..(at * spec.rate).round() as usize {
                if !world.advance(1.0 / spec.rate) {
                    return Err(no_longer_finite());
                }
            }
            Ok((at_start(&world), camera))
        }
    }
}

/// Frames of a run written as PNG files at [`FRAME_RATE`] per second of simulated time
/// (`hapticctl scene run --frames DIR`), for figures and videos.
pub struct Frames {
    dir: PathBuf,
    renderer: Renderer,
    /// Framed on the first frame, then kept, so the pictures follow one another.
    camera: Option<Camera>,
    next: f64,
    written: usize,
}

/// Frames per second of simulated time.
pub const FRAME_RATE: f64 = 30.0;

/// Size of a frame, pixels.
const FRAME_SIZE: (u32, u32) = (640, 480);

impl Frames {
    /// Frames into `dir` (made if missing).
    pub fn create(dir: &Path) -> Result<Self, Failure> {
        std::fs::create_dir_all(dir)
            .map_err(|e| Failure::failed(format!("cannot make {}: {e}", dir.display())))?;
        let renderer =
            Renderer::new().map_err(|e| Failure::failed(format!("cannot render: {e}")))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            renderer,
            camera: None,
            next: 0.0,
            written: 0,
        })
    }

    /// At simulated time `t`: draw `scenery()` if a frame is due.
    pub fn offer(&mut self, t: f64, scenery: impl FnOnce() -> Scenery) -> Result<(), Failure> {
        if t + 1e-9 < self.next {
            return Ok(());
        }
        let scenery = scenery();
        let camera = *self.camera.get_or_insert_with(|| scenery.camera());
        let meshes: Vec<_> = scenery.meshes.iter().collect();
        let picture = self
            .renderer
            .draw(&meshes, &camera, FRAME_SIZE, SKY)
            .map_err(|e| Failure::failed(format!("cannot render: {e}")))?;
        let path = self.dir.join(format!("frame-{:05}.png", self.written));
        picture.write_png(&path).map_err(Failure::failed)?;
        self.written += 1;
        self.next += 1.0 / FRAME_RATE;
        Ok(())
    }
}

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
    // The hands rest at the mechanism's calibration poses, or one at the origin, where
    // the shipped mechanisms calibrate theirs.
    let rests: Vec<Pose> = match &args.mechanism {
        Some(name) => resolve(catalog, name)?
            .effectors
            .iter()
            .map(|e| e.calibration)
            .collect(),
        None => vec![Pose::IDENTITY],
    };
    let scene = crate::scene_file::resolve(&args.scene)?;
    let (mut scenery, mut camera) = scenery(&scene, args.at, &rests)?;
    match (&args.mechanism, &args.force) {
        (Some(name), force) => {
            let force = force
                .as_deref()
                .map_or(Ok(DVec3::ZERO), |f| vec3(f, "--force"))?;
            if !force.is_finite() || force.length() > 1e3 {
                return Err(Failure::usage("--force must be finite and at most 1000 N"));
            }
            add_mechanism(&mut scenery, catalog, name, force)?;
            camera = scenery.camera();
        }
        (None, Some(_)) => return Err(Failure::usage("--force needs --mechanism")),
        (None, None) => {}
    }
    let mut renderer =
        Renderer::new().map_err(|e| Failure::failed(format!("cannot render: {e}")))?;
    let meshes: Vec<_> = scenery.meshes.iter().collect();
    let picture = renderer
        .draw(&meshes, &camera, (args.width, args.height), SKY)
        .map_err(|e| Failure::failed(format!("cannot render: {e}")))?;
    picture.write_png(&args.out).map_err(Failure::failed)
}

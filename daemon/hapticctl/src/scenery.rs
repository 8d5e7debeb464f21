//! Scene files drawn with Vulkan, no daemon needed: what a scene file shows after a while,
//! a mechanism's strings over it (`hapticctl render`), and the frames of a run written as it
//! goes (`hapticctl scene run --frames`).

use std::path::{Path, PathBuf};

use glam::DVec3;
use hapticd_core::diagnostics::Diagnostics;
use hapticd_core::kinematics::{Pose, Wrench};
use hapticd_core::mechanism::Mechanism;
use hapticd_core::scene::engine::{Engine, engine_of_text};
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_core::solver::geometry::StringGeometry;
use hapticd_physics::coupling::Grip;
use hapticd_physics::scene::{PenaltyScene, RapierScene, SceneFile};
use hapticd_rapier::world::RapierWorld;
use hapticd_render::camera::Camera;
use hapticd_render::picture::{Picture, PictureError};
use hapticd_render::scenery::Scenery;
use hapticd_render::shading::Shaded;
use hapticd_render::vulkan::{Renderer, Unavailable};

/// The background: a pale sky.
const SKY: [f32; 4] = [0.93, 0.95, 0.98, 1.0];

/// Frames per second of simulated time.
pub const FRAME_RATE: f64 = 30.0;

/// Size of a frame, pixels.
const FRAME_SIZE: (u32, u32) = (640, 480);

/// Why a scene file's picture cannot be made.
#[derive(Debug)]
pub enum SceneryError {
    /// The file cannot be read, or is no scene file.
    Input(Diagnostics),
    /// A static scene was asked for after some time: it stays put.
    Static,
    /// The world of the file at this path stopped being finite.
    NotFinite(PathBuf),
}

impl std::fmt::Display for SceneryError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SceneryError::Input(e) => write!(f, "{e}"),
            SceneryError::Static => f.write_str("a static scene stays put"),
            SceneryError::NotFinite(path) => {
                write!(f, "{}: the world is no longer finite", path.display())
            }
        }
    }
}

impl std::error::Error for SceneryError {}

impl From<Diagnostics> for SceneryError {
    fn from(e: Diagnostics) -> Self {
        SceneryError::Input(e)
    }
}

/// Why nothing was drawn.
#[derive(Debug)]
pub enum DrawError {
    /// The directory of the frames cannot be made.
    Directory {
        /// The directory.
        dir: PathBuf,
        /// Why not.
        error: std::io::Error,
    },
    /// Vulkan cannot draw.
    Render(Unavailable),
    /// A frame cannot be written.
    Write(PictureError),
}

impl std::fmt::Display for DrawError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DrawError::Directory { dir, error } => {
                write!(f, "cannot make {}: {error}", dir.display())
            }
            DrawError::Render(e) => write!(f, "cannot render: {e}"),
            DrawError::Write(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for DrawError {}

/// What the scene file at `path` shows after `at` seconds with a hand resting at each of
/// `rests` (the scene's pointers there), and a camera that frames it as it was at the start
/// (so pictures at several times compare).
pub fn scenery(path: &Path, at: f64, rests: &[Pose]) -> Result<(Scenery, Camera), SceneryError> {
    let text = hapticd_core::diagnostics::read_text(path)?;
    let resting: Vec<DVec3> = rests.iter().map(|r| r.position).collect();
    if engine_of_text(&text, path)? == Engine::Static {
        if at != 0.0 {
            return Err(SceneryError::Static);
        }
        let geometry = Shaded::new(
            StaticSceneSpec::parse_with_files(&text, path, hapticd_mesh::scene_files())?.geometry(),
        );
        let mut scenery = Scenery::of_geometry(&geometry, &[], &[]);
        scenery.add_proxies(&resting);
        let camera = scenery.camera();
        return Ok((scenery, camera));
    }
    let file = SceneFile::parse(&text, path, rests.len())?;
    let geometry = Shaded::new(file.geometry());
    match file {
        SceneFile::Penalty(scene) => penalty_scenery(path, *scene, &geometry, at, rests),
        SceneFile::Rapier(spec) => rapier_scenery(path, &spec, &geometry, at, &resting),
    }
}

/// A penalty scene's picture after `at` seconds, its pointers' solids at `rests`.
fn penalty_scenery(
    path: &Path,
    mut scene: PenaltyScene,
    geometry: &Shaded,
    at: f64,
    rests: &[Pose],
) -> Result<(Scenery, Camera), SceneryError> {
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
            .ok_or_else(|| SceneryError::NotFinite(path.to_path_buf()))
    };
    step(&mut scene)?;
    let camera = Scenery::of_geometry(geometry, &scene.poses(), &scene.all_corners()).camera();
    for _ in 1..(at / scene.dt).round() as usize {
        step(&mut scene)?;
    }
    Ok((
        Scenery::of_geometry(geometry, &scene.poses(), &scene.all_corners()),
        camera,
    ))
}

/// A rapier scene's picture after `at` seconds, its pointers drawn where the fingers rest
/// (`resting`), as the daemon draws them.
fn rapier_scenery(
    path: &Path,
    spec: &RapierScene,
    geometry: &Shaded,
    at: f64,
    resting: &[DVec3],
) -> Result<(Scenery, Camera), SceneryError> {
    let mut world = RapierWorld::new(spec, 0);
    let shown = |world: &RapierWorld| {
        let mut scenery = Scenery::of_geometry(geometry, &world.poses(), &[]);
        scenery.add_proxies(resting);
        scenery
    };
    let camera = shown(&world).camera();
    for _ in 0..(at * spec.rate).round() as usize {
        if !world.advance(1.0 / spec.rate) {
            return Err(SceneryError::NotFinite(path.to_path_buf()));
        }
    }
    Ok((shown(&world), camera))
}

/// Add `mechanism` to `scenery`, each grip at its calibration pose presenting `force`, its
/// strings coloured by the tensions that present it.
pub fn add_mechanism(scenery: &mut Scenery, mechanism: &Mechanism, force: DVec3) {
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
    scenery.add_mechanism(mechanism, &poses, &tensions, &forces);
}

/// `scenery` seen by `camera` on a picture of `size` pixels, over a pale sky.
pub fn draw(scenery: &Scenery, camera: &Camera, size: (u32, u32)) -> Result<Picture, DrawError> {
    let mut renderer = Renderer::new().map_err(DrawError::Render)?;
    let meshes: Vec<_> = scenery.meshes.iter().collect();
    renderer
        .draw(&meshes, camera, size, SKY)
        .map_err(DrawError::Render)
}

/// Frames of a run written as PNG files at [`FRAME_RATE`] per second of simulated time
/// (frame-00000.png, …), for figures and videos.
pub struct Frames {
    dir: PathBuf,
    renderer: Renderer,
    /// Framed on the first frame, then kept, so the pictures follow one another.
    camera: Option<Camera>,
    next: f64,
    written: usize,
}

impl Frames {
    /// Frames into `dir` (made if missing).
    pub fn create(dir: &Path) -> Result<Self, DrawError> {
        std::fs::create_dir_all(dir).map_err(|error| DrawError::Directory {
            dir: dir.to_path_buf(),
            error,
        })?;
        let renderer = Renderer::new().map_err(DrawError::Render)?;
        Ok(Self {
            dir: dir.to_path_buf(),
            renderer,
            camera: None,
            next: 0.0,
            written: 0,
        })
    }

    /// At simulated time `t`: draw `scenery()` if a frame is due.
    pub fn offer(&mut self, t: f64, scenery: impl FnOnce() -> Scenery) -> Result<(), DrawError> {
        if t + 1e-9 < self.next {
            return Ok(());
        }
        let scenery = scenery();
        let camera = *self.camera.get_or_insert_with(|| scenery.camera());
        let meshes: Vec<_> = scenery.meshes.iter().collect();
        let picture = self
            .renderer
            .draw(&meshes, &camera, FRAME_SIZE, SKY)
            .map_err(DrawError::Render)?;
        let path = self.dir.join(format!("frame-{:05}.png", self.written));
        picture.write_png(&path).map_err(DrawError::Write)?;
        self.written += 1;
        self.next += 1.0 / FRAME_RATE;
        Ok(())
    }
}

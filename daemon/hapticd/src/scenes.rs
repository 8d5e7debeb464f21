//! Finding a scene by name: a scene plugin (`.so`), a scene file, or the name of a scene in
//! the configured directories; physics scene files run on the scene plugin of their engine.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use hapticd_core::kinematics::Wrench;
use hapticd_core::scene::static_scene::{StaticScene, StaticSceneSpec};
use hapticd_core::scene::{Pointer, Scene};
use hapticd_physics::scene::{Engine, SceneFile};

/// Why a scene could not be opened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum OpenError {
    /// No scene of that name or path.
    NotFound(String),
    /// The scene file or plugin is there but cannot be loaded.
    Invalid(String),
}

impl std::fmt::Display for OpenError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OpenError::NotFound(m) | OpenError::Invalid(m) => f.write_str(m),
        }
    }
}

/// Where scenes are found.
#[derive(Debug, Clone, Copy)]
pub struct Places<'a> {
    /// Directories of scene files, searched in order.
    pub dirs: &'a [PathBuf],
    /// Directories of scene plugins, for the engines of physics scene files.
    pub plugin_dirs: &'a [PathBuf],
}

/// [main] The scene `name` for `pointers`, to render at `rate` Hz: a scene plugin (`.so`,
/// given `file`), a scene file (a path), or the name of a scene in `places` (searched in
/// order). Static scene files render in the daemon; physics scene files (their `bodies:`
/// say so) run on their engine's plugin. A scene that cannot compute a tick in half of one
/// is refused.
pub fn open(
    name: &str,
    file: Option<&Path>,
    places: Places,
    pointers: &[Pointer],
    rate: f64,
) -> Result<Box<dyn Scene>, OpenError> {
    let mut scene = find(name, file, places, pointers)?;
    fits_tick(scene.as_mut(), pointers, rate)?;
    Ok(scene)
}

/// Ticks a new scene is tried for before it reaches the haptic thread.
const TRIAL_TICKS: usize = 3;

/// Refuse `scene` if its fastest of a few trial ticks, run here off the real-time thread,
/// takes more than half the tick: on the haptic thread it would overrun every tick.
fn fits_tick(scene: &mut dyn Scene, pointers: &[Pointer], rate: f64) -> Result<(), OpenError> {
    let period = 1.0 / rate;
    let mut wrenches = vec![Wrench::ZERO; pointers.len()];
    let mut fastest = Duration::MAX;
    for _ in 0..TRIAL_TICKS {
        let started = Instant::now();
        scene.render(pointers, period, &mut wrenches);
        fastest = fastest.min(started.elapsed());
    }
    scene.reset(pointers);
    if fastest.as_secs_f64() > 0.5 * period {
        return Err(OpenError::Invalid(format!(
            "scene {} takes {:.0} µs to compute a tick, more than half of the {:.0} µs tick at \
             {rate} Hz: give it a longer physics step or run the loop slower",
            scene.name(),
            fastest.as_secs_f64() * 1e6,
            period * 1e6
        )));
    }
    Ok(())
}

/// Whether `name` names a scene rather than giving a path: what a caller on the bus may
/// send (a file of its own it sends by descriptor).
pub fn is_name(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('.')
        && !name.contains(['/', '\0'])
        && Path::new(name).extension().is_none()
}

/// The file of scene `name`: a path as given, or `NAME.yaml` in the first of `dirs` that
/// has it.
pub fn locate(name: &str, dirs: &[PathBuf]) -> Result<PathBuf, OpenError> {
    let path = Path::new(name);
    let path = if !is_name(name) {
        path.to_path_buf()
    } else {
        dirs.iter()
            .map(|d| d.join(format!("{name}.yaml")))
            .find(|p| p.exists())
            .ok_or_else(|| OpenError::NotFound(format!("no scene named {name:?} in {dirs:?}")))?
    };
    if !path.exists() {
        return Err(OpenError::NotFound(format!(
            "{}: no such scene file",
            path.display()
        )));
    }
    Ok(path)
}

/// The file pictures of scene `name` are drawn from, absolute: the scene file, or for a
/// scene plugin the `file` it is given; None when there is none.
pub fn file_of(name: &str, file: Option<&Path>, dirs: &[PathBuf]) -> Option<PathBuf> {
    let path = locate(name, dirs).ok()?;
    let path = if path.extension().is_some_and(|e| e == "so") {
        file?.to_path_buf()
    } else {
        path
    };
    std::fs::canonicalize(path).ok()
}

/// The plugin that runs physics scene files of `engine`, found in `plugin_dirs`.
fn engine_plugin(engine: Engine) -> &'static str {
    match engine {
        Engine::Penalty => "libhapticd_scene_penalty.so",
        Engine::Rapier => "libhapticd_scene_rapier.so",
    }
}

/// The scene plugin called `name` (`libhapticd_scene_NAME.so`) in the first of
/// `plugin_dirs` that has it.
fn scene_plugin(name: &str, plugin_dirs: &[PathBuf]) -> Option<PathBuf> {
    let file = format!("libhapticd_scene_{}.so", name.replace('-', "_"));
    plugin_dirs
        .iter()
        .map(|d| d.join(&file))
        .find(|p| p.exists())
}

fn find(
    name: &str,
    file: Option<&Path>,
    places: Places,
    pointers: &[Pointer],
) -> Result<Box<dyn Scene>, OpenError> {
    let path = match locate(name, places.dirs) {
        // A name that is no scene file may be a scene plugin's.
        Err(OpenError::NotFound(why)) if is_name(name) => scene_plugin(name, places.plugin_dirs)
            .ok_or_else(|| {
                OpenError::NotFound(format!(
                    "{why}, nor a scene plugin libhapticd_scene_{name}.so in {:?}",
                    places.plugin_dirs
                ))
            })?,
        found => found?,
    };
    if path.extension().is_some_and(|e| e == "so") {
        return crate::plugin_scene::load(&path, file, pointers).map_err(OpenError::Invalid);
    }
    if SceneFile::is_physics(&path) {
        // Checked here first, so that mistakes come back with their places.
        let plugin = engine_plugin(
            SceneFile::load(&path, pointers.len())
                .map_err(|e| OpenError::Invalid(e.to_string()))?
                .engine(),
        );
        let engine = places
            .plugin_dirs
            .iter()
            .map(|d| d.join(plugin))
            .find(|p| p.exists())
            .ok_or_else(|| {
                OpenError::Invalid(format!(
                    "{}: a physics scene, but no {plugin} in {:?} to run it",
                    path.display(),
                    places.plugin_dirs
                ))
            })?;
        return crate::plugin_scene::load(&engine, Some(&path), pointers)
            .map_err(OpenError::Invalid);
    }
    let spec = StaticSceneSpec::load(&path).map_err(|e| OpenError::Invalid(e.to_string()))?;
    Ok(Box::new(StaticScene::new(spec, pointers)))
}

/// Names of the usable scene files in `dirs`, static and physics, first directory first,
/// without repeats.
pub fn available(dirs: &[PathBuf]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for dir in dirs {
        let Ok(listing) = std::fs::read_dir(dir) else {
            continue;
        };
        let mut here: Vec<String> = listing
            .filter_map(|e| e.ok())
            .filter_map(|e| {
                let path = e.path();
                let stem = path.file_stem()?.to_str()?.to_string();
                let usable = if SceneFile::is_physics(&path) {
                    SceneFile::load(&path, 0).is_ok()
                } else {
                    StaticSceneSpec::load(&path).is_ok()
                };
                (path.extension()? == "yaml" && usable).then_some(stem)
            })
            .collect();
        here.sort();
        for name in here {
            if !names.contains(&name) {
                names.push(name);
            }
        }
    }
    names
}

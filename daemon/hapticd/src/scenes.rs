//! Finding a scene by name: a scene plugin (`.so`), a static scene file, or the name of a
//! static scene in the configured directories.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use hapticd_core::kinematics::Wrench;
use hapticd_core::scene::{Pointer, Scene};

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

/// [main] The scene `name` for `pointers`, to render at `rate` Hz: a scene plugin (`.so`,
/// given `file`), a static scene file (a path), or the name of a static scene in `dirs`
/// (searched in order). A scene that cannot compute a tick in half of one is refused.
pub fn open(
    name: &str,
    file: Option<&Path>,
    dirs: &[PathBuf],
    pointers: &[Pointer],
    rate: f64,
) -> Result<Box<dyn Scene>, OpenError> {
    let mut scene = find(name, file, dirs, pointers)?;
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

/// The file of scene `name`: a path as given, or `NAME.yaml` in the first of `dirs` that
/// has it.
pub fn locate(name: &str, dirs: &[PathBuf]) -> Result<PathBuf, OpenError> {
    let path = Path::new(name);
    let is_path = name.contains('/') || path.extension().is_some();
    let path = if is_path {
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

fn find(
    name: &str,
    file: Option<&Path>,
    dirs: &[PathBuf],
    pointers: &[Pointer],
) -> Result<Box<dyn Scene>, OpenError> {
    let path = locate(name, dirs)?;
    if path.extension().is_some_and(|e| e == "so") {
        return crate::plugin_scene::load(&path, file, pointers).map_err(OpenError::Invalid);
    }
    let spec = hapticd_core::scene::static_scene::StaticSceneSpec::load(&path)
        .map_err(|e| OpenError::Invalid(e.to_string()))?;
    Ok(Box::new(
        hapticd_core::scene::static_scene::StaticScene::new(spec, pointers),
    ))
}

/// Names of the static scenes in `dirs`, first directory first, without repeats.
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
                (path.extension()? == "yaml"
                    && hapticd_core::scene::static_scene::StaticSceneSpec::load(&path).is_ok())
                .then_some(stem)
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

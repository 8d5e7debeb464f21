//! Scenes: what the user touches. A scene turns the pointers' motion (one pointer per end
//! effector) into the wrench each one should feel.
//!
//! - [`static_scene`]: fixed floors, walls, boxes and spheres rendered through the proxy;
//! - [`plugin_scene`]: scenes from plugins, direct or multi-rate.

pub mod plugin_scene;
pub mod static_scene;

use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::haptics::proxy::ProxyParameters;
use crate::mechanism::{Mechanism, Pose};

/// One pointer as the scene sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pointer {
    /// Grip pose.
    pub pose: Pose,
    /// Grip velocity, m/s.
    pub velocity: DVec3,
}

impl Pointer {
    /// One pointer per effector of `mechanism`, at rest at its calibration pose.
    pub fn at_calibration(mechanism: &Mechanism) -> Vec<Pointer> {
        mechanism
            .effectors
            .iter()
            .map(|e| Pointer {
                pose: e.calibration,
                velocity: DVec3::ZERO,
            })
            .collect()
    }
}

/// A world the haptic loop renders.
pub trait Scene: Send {
    /// [main] The scene's name.
    fn name(&self) -> &str;

    /// [rt] The wrench (force, then torque) to present on each pointer after a tick of `dt`
    /// seconds. `wrenches` has one slot per pointer. Returns false when the scene has failed
    /// (a plugin error, stale physics): the loop then ramps the forces to zero.
    fn render(&mut self, pointers: &[Pointer], dt: f64, wrenches: &mut [[f64; 6]]) -> bool;

    /// [rt] Forget contact state (after a fault, or when the pointers jumped).
    fn reset(&mut self, pointers: &[Pointer]);

    /// [rt] Render with these proxy parameters from now on (scenes without a proxy ignore
    /// them).
    fn set_proxy(&mut self, _parameters: &ProxyParameters) {}

    /// [main] The proxy parameters the scene renders with, if it renders through a proxy
    /// (before the loop tunes it: those its file gives).
    fn proxy(&self) -> Option<ProxyParameters> {
        None
    }
}

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

/// [main] The scene `name` for `pointers`: a scene plugin (`.so`, given `file`), a static
/// scene file (a path), or the name of a static scene in `dirs` (searched in order).
pub fn open(
    name: &str,
    file: Option<&Path>,
    dirs: &[PathBuf],
    pointers: &[Pointer],
) -> Result<Box<dyn Scene>, OpenError> {
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
    if path.extension().is_some_and(|e| e == "so") {
        return plugin_scene::load(&path, file, pointers).map_err(OpenError::Invalid);
    }
    let spec = static_scene::StaticSceneSpec::load(&path).map_err(OpenError::Invalid)?;
    Ok(Box::new(static_scene::StaticScene::new(spec, pointers)))
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
                (path.extension()? == "yaml" && static_scene::StaticSceneSpec::load(&path).is_ok())
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

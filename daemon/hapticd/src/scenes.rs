//! Finding a scene by name: a scene plugin (`.so`), a static scene file, or the name of a
//! static scene in the configured directories.

use std::path::{Path, PathBuf};

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

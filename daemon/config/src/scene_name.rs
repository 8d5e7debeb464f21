//! Scene names: what a caller may send instead of a path, and the scene file a name stands
//! for in the configured scene directories.

use std::path::{Path, PathBuf};

/// No scene file of that name or path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NoScene {
    /// No `NAME.yaml` in any of the directories.
    Named {
        /// The name.
        name: String,
        /// The directories searched.
        dirs: Vec<PathBuf>,
    },
    /// The path given names no file.
    NoFile(PathBuf),
}

impl std::fmt::Display for NoScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoScene::Named { name, dirs } => write!(f, "no scene named {name:?} in {dirs:?}"),
            NoScene::NoFile(path) => write!(f, "{}: no such scene file", path.display()),
        }
    }
}

impl std::error::Error for NoScene {}

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
pub fn locate(name: &str, dirs: &[PathBuf]) -> Result<PathBuf, NoScene> {
    let path = if !is_name(name) {
        PathBuf::from(name)
    } else {
        dirs.iter()
            .map(|d| d.join(format!("{name}.yaml")))
            .find(|p| p.exists())
            .ok_or_else(|| NoScene::Named {
                name: name.to_string(),
                dirs: dirs.to_vec(),
            })?
    };
    if !path.exists() {
        return Err(NoScene::NoFile(path));
    }
    Ok(path)
}

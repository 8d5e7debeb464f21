//! The scenes the daemon lists (`Manager.Scenes`): every scene file of the scene
//! directories whose head says what runs it, and which that can run here.
//!
//! Listing never reads a scene's meshes nor asks an engine's plugin to check its file: any
//! caller may read the list, and a mesh of half a million triangles took half a second to
//! read each time. What a file says of itself (its engine) is kept with the file's identity
//! (inode, size, modification time) and read again only when that changes; a file that
//! cannot be switched to for a reason found only when it loads says so when it is asked for.
//!
//! A read that finds the directories as they were (their own stamps, which an added,
//! removed or renamed file changes) and the files checked within the last second is
//! answered from the list as it stands, without looking at any file: a flood of readers
//! costs a few `stat` calls each.

use std::collections::{HashMap, HashSet};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};
use std::time::{Duration, Instant};

use hapticd_core::scene::engine::{Engine, engine_of_text};
use hapticd_core::scene::remote::{self, RemoteSceneSpec};

use crate::scenes::{Places, scene_plugin};
use hapticd_config::scene_name::is_name;

/// What identifies a file's contents without reading them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Stamp {
    device: u64,
    inode: u64,
    size: u64,
    modified: (i64, i64),
}

impl Stamp {
    fn of(meta: &std::fs::Metadata) -> Self {
        Self {
            device: meta.dev(),
            inode: meta.ino(),
            size: meta.size(),
            modified: (meta.mtime(), meta.mtime_nsec()),
        }
    }
}

/// What a scene file says of itself: the engine that runs it, or None when its head cannot
/// be read (not YAML, no such engine value, a remote scene that is malformed).
#[derive(Debug, Clone)]
struct Summary {
    stamp: Stamp,
    engine: Option<Engine>,
}

/// How long the files' own stamps are trusted while their directories stay the same: a
/// file edited in place (which changes no directory) is seen within this.
const RECHECK: Duration = Duration::from_secs(1);

/// The scene files seen so far, and the list as last made.
#[derive(Debug, Default)]
pub struct SceneList {
    state: Mutex<State>,
}

#[derive(Debug, Default)]
struct State {
    /// Each file seen, by path.
    seen: HashMap<PathBuf, Summary>,
    /// The directories looked in (scene files', then plugins'), as they were then.
    dirs: Vec<(PathBuf, Option<Stamp>)>,
    /// When the files were last looked at.
    checked: Option<Instant>,
    names: Vec<String>,
}

/// The directories of `places` with their stamps now.
fn stamped(places: Places) -> Vec<(PathBuf, Option<Stamp>)> {
    places
        .dirs
        .iter()
        .chain(places.plugin_dirs)
        .map(|d| (d.clone(), std::fs::metadata(d).ok().map(|m| Stamp::of(&m))))
        .collect()
}

impl SceneList {
    /// An empty list: each file is summarised when first seen.
    pub fn new() -> Self {
        Self::default()
    }

    /// The list as it stands, if no directory of `places` changed and the files were
    /// looked at within the last second; None when [`SceneList::names`] must look again,
    /// or is looking now (this never waits for it).
    pub fn unchanged(&self, places: Places) -> Option<Vec<String>> {
        let state = match self.state.try_lock() {
            Ok(state) => state,
            Err(std::sync::TryLockError::Poisoned(p)) => p.into_inner(),
            Err(std::sync::TryLockError::WouldBlock) => return None,
        };
        let fresh = state.checked.is_some_and(|t| t.elapsed() < RECHECK);
        (fresh && state.dirs == stamped(places)).then(|| state.names.clone())
    }

    /// Names of the scene files in `places.dirs`, first directory first, without repeats:
    /// static ones, remote ones that parse, and those whose engine has a plugin in
    /// `places.plugin_dirs`. Only the files that changed since the last call are read.
    pub fn names(&self, places: Places) -> Vec<String> {
        let mut state = self.state.lock().unwrap_or_else(PoisonError::into_inner);
        // Stamped before the files are looked at: a change while they are is seen next time.
        let dirs = stamped(places);
        let seen = &mut state.seen;
        let mut names: Vec<String> = Vec::new();
        let mut present: HashSet<PathBuf> = HashSet::new();
        for dir in places.dirs {
            let Ok(listing) = std::fs::read_dir(dir) else {
                continue;
            };
            let mut here: Vec<(String, PathBuf)> = listing
                .filter_map(|e| e.ok())
                .filter_map(|e| {
                    let path = e.path();
                    let stem = path.file_stem()?.to_str()?.to_string();
                    (path.extension()? == "yaml").then_some((stem, path))
                })
                .collect();
            here.sort();
            for (name, path) in here {
                // Followed links, as a switch follows them; a FIFO or directory is no scene.
                let Ok(meta) = std::fs::metadata(&path) else {
                    continue;
                };
                if !meta.is_file() {
                    continue;
                }
                let stamp = Stamp::of(&meta);
                let summary = match seen.get(&path) {
                    Some(s) if s.stamp == stamp => s.clone(),
                    _ => {
                        let s = Summary {
                            stamp,
                            engine: head(&path),
                        };
                        seen.insert(path.clone(), s.clone());
                        s
                    }
                };
                present.insert(path);
                if runs_here(summary.engine.as_ref(), places) && !names.contains(&name) {
                    names.push(name);
                }
            }
        }
        // Files gone from the directories are forgotten.
        seen.retain(|path, _| present.contains(path));
        state.dirs = dirs;
        state.checked = Some(Instant::now());
        state.names.clone_from(&names);
        names
    }
}

/// The engine scene file `path` declares, read from its head alone.
fn head(path: &Path) -> Option<Engine> {
    let text = hapticd_core::diagnostics::read_text(path).ok()?;
    let engine = engine_of_text(&text, path).ok()?;
    match &engine {
        Engine::Plugin(name) if name == remote::ENGINE => {
            RemoteSceneSpec::parse(&text, path).ok()?;
        }
        _ => {}
    }
    Some(engine)
}

/// Whether a scene of `engine` can run with `places`: static and remote scenes in the
/// daemon, any other where its engine's plugin is installed.
fn runs_here(engine: Option<&Engine>, places: Places) -> bool {
    match engine {
        None => false,
        Some(Engine::Static) => true,
        Some(Engine::Plugin(name)) => {
            name == remote::ENGINE
                || (is_name(name) && scene_plugin(name, places.plugin_dirs).is_some())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_added_changed_and_removed_are_seen_and_only_they_are_read_again() {
        let dir = std::env::temp_dir().join(format!("scene-list-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let dirs = [dir.clone()];
        let places = Places {
            dirs: &dirs,
            plugin_dirs: &[],
            world_link: None,
        };
        // A static scene naming a mesh that is not there: listed, its mesh never read.
        let a = dir.join("a.yaml");
        std::fs::write(&a, "shapes:\n  - mesh: { file: missing.stl }\n").unwrap();
        let list = SceneList::new();
        assert_eq!(list.unchanged(places), None, "nothing listed yet");
        assert_eq!(list.names(places), ["a"]);
        assert_eq!(list.unchanged(places).unwrap(), ["a"]);
        // A new file changes the directory: the list must be made again.
        std::fs::write(dir.join("b.yaml"), "engine: nowhere\n").unwrap();
        assert_eq!(list.unchanged(places), None);
        assert_eq!(list.names(places), ["a"], "no plugin runs engine nowhere");
        // Edited in place (no directory changes): seen by the next full look.
        std::fs::write(&a, "shapes: [unclosed\n").unwrap();
        assert_eq!(list.names(places), Vec::<String>::new());
        std::fs::remove_file(&a).unwrap();
        std::fs::write(dir.join("c.yaml"), "shapes: []\n").unwrap();
        assert_eq!(list.names(places), ["c"]);
        assert_eq!(list.state.lock().unwrap().seen.len(), 2, "a is forgotten");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! Meshes' convex pieces made ready before a scene switch: cutting a mesh takes from a
//! fraction of a second to minutes, and a switch must not wait that long. The daemon reads
//! which meshes a scene file's bodies name (the engines' rule: every `mesh:` of a penalty
//! scene, a movable body's under rapier) and, for those the cache lacks, cuts them in a
//! thread of their own; a switch waits for that only briefly, then says the scene is being
//! prepared, and the next switch finds the pieces cached. The plugin itself reads them from
//! the same cache ([`Cache::from_environment`]).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use hapticd_mesh::cache::Cache;
use hapticd_mesh::decomposition::{RESOLUTION, decompose};
use hapticd_mesh::{Limits, TriangleMesh, properties};
use serde_json::Value;

/// How long a switch waits for pieces being cut before saying so: about as long as a
/// switch's own force ramp, so that small meshes switch at once.
const WAIT: Duration = Duration::from_millis(500);

/// Where cutting stands, shared with the threads that cut.
#[derive(Default)]
struct Cutting {
    /// Meshes being cut now.
    running: HashSet<PathBuf>,
    /// Meshes whose pieces the cache could not keep: the plugin cuts those itself as it
    /// loads them, rather than the switch saying "being cut" forever.
    unkept: HashSet<PathBuf>,
}

/// Meshes' pieces cut ahead of the switches that need them.
pub struct Preparation {
    cache: Cache,
    cutting: Arc<Mutex<Cutting>>,
}

/// A scene's meshes are being cut into convex pieces, in the background.
#[derive(Debug, Clone, PartialEq)]
pub struct StillCutting {
    /// The meshes.
    pub meshes: Vec<PathBuf>,
    /// Whether this request started the cutting (else an earlier one did).
    pub now: bool,
}

impl std::fmt::Display for StillCutting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<String> = self
            .meshes
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        write!(
            f,
            "{} are {} being cut into convex pieces for the cache; switch again in a moment \
             (hapticctl mesh decompose prepares a mesh ahead)",
            names.join(", "),
            if self.now { "now" } else { "still" }
        )
    }
}

impl std::error::Error for StillCutting {}

impl Preparation {
    /// Preparation into this process's cache ([`Cache::from_environment`]).
    pub fn from_environment() -> Self {
        Self {
            cache: Cache::from_environment(),
            cutting: Arc::default(),
        }
    }

    fn cutting(&self) -> std::sync::MutexGuard<'_, Cutting> {
        self.cutting.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Make sure the convex pieces of every mesh the scene file `file` needs cut are cached:
    /// Ok at once when they are (or the file names none, or cannot be read: the plugin says
    /// what is wrong with it), Ok after cutting them when that takes less than [`WAIT`], and
    /// otherwise the message to give while they are cut in the background.
    pub fn ready(&self, file: &Path) -> Result<(), StillCutting> {
        if self.cache.dir().is_none() {
            return Ok(());
        }
        let dir = hapticd_core::diagnostics::directory_of(file);
        let needed: Vec<(PathBuf, TriangleMesh)> = hapticd_core::diagnostics::read_text(file)
            .ok()
            .and_then(|text| serde_saphyr::from_str::<Value>(&text).ok())
            .map(|scene| cut_meshes(&scene))
            .unwrap_or_default()
            .into_iter()
            .filter_map(|name| {
                let path = dir.join(name);
                let mesh = hapticd_mesh::load(&path, 1.0, Limits::DEFAULT, Some(dir)).ok()?;
                let closed = properties::closure(&mesh).is_closed();
                let unkept = self.cutting().unkept.contains(&path);
                (closed && !unkept && self.cache.lookup(&mesh).is_none()).then_some((path, mesh))
            })
            .collect();
        if needed.is_empty() {
            return Ok(());
        }
        let meshes: Vec<PathBuf> = needed.iter().map(|(p, _)| p.clone()).collect();
        let busy = |now: bool| StillCutting {
            meshes: meshes.clone(),
            now,
        };
        let fresh: Vec<(PathBuf, TriangleMesh)> = {
            let mut cutting = self.cutting();
            needed
                .into_iter()
                .filter(|(path, _)| cutting.running.insert(path.clone()))
                .collect()
        };
        if fresh.is_empty() {
            return Err(busy(false));
        }
        let started: Vec<PathBuf> = fresh.iter().map(|(path, _)| path.clone()).collect();
        let (done, finished) = mpsc::channel();
        let (cache, cutting) = (self.cache.clone(), Arc::clone(&self.cutting));
        let start = Instant::now();
        let spawned = std::thread::Builder::new()
            .name("mesh-pieces".into())
            .spawn(move || {
                for (path, mesh) in fresh {
                    // Uncut, it is left to its scene to refuse it, in its own words.
                    let kept = decompose(&mesh, RESOLUTION)
                        .map(|d| (cache.store(&mesh, &d.pieces), d.pieces.len()));
                    let seconds = start.elapsed().as_secs_f64();
                    match &kept {
                        Ok((Some(entry), pieces)) => tracing::info!(
                            "{}: cut into {pieces} convex pieces in {seconds:.1} s, kept in {}",
                            path.display(),
                            entry.display()
                        ),
                        Ok((None, _)) => tracing::warn!(
                            "{}: cut into convex pieces, but the cache cannot keep them: each \
                             switch to its scenes cuts it again",
                            path.display()
                        ),
                        Err(e) => tracing::warn!("{}: {e}", path.display()),
                    }
                    let kept = kept.ok().and_then(|(entry, _)| entry);
                    let mut cutting = cutting.lock().unwrap_or_else(|e| e.into_inner());
                    cutting.running.remove(&path);
                    if kept.is_none() {
                        cutting.unkept.insert(path);
                    }
                }
                let _ = done.send(());
            });
        if spawned.is_err() {
            // No thread to spare: the plugin cuts them as it loads, as it would uncached.
            let mut cutting = self.cutting();
            for path in &started {
                cutting.running.remove(path);
            }
            return Ok(());
        }
        match finished.recv_timeout(WAIT) {
            Ok(()) => Ok(()),
            Err(_) => Err(busy(true)),
        }
    }
}

/// The meshes a scene's bodies name whose pieces the engine touches: every body's of a
/// penalty scene, the movable ones' of a rapier scene (a fixed mesh is its triangles there).
fn cut_meshes(scene: &Value) -> Vec<String> {
    let rapier = scene.get("engine").and_then(Value::as_str) == Some("rapier");
    scene
        .get("bodies")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .filter(|b| !(rapier && b.get("fixed").and_then(Value::as_bool) == Some(true)))
        .filter_map(|b| b.get("mesh").and_then(Value::as_str).map(String::from))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_meshes_to_cut_are_those_the_engine_touches_through_pieces() {
        let scene = |engine: &str| {
            serde_saphyr::from_str::<Value>(&format!(
                "name: s\nengine: {engine}\nbodies:\n  - {{ mesh: a.obj, fixed: true }}\n  \
                 - {{ mesh: b.obj }}\n  - {{ box: [1, 1, 1] }}\n"
            ))
            .unwrap()
        };
        assert_eq!(cut_meshes(&scene("penalty")), ["a.obj", "b.obj"]);
        assert_eq!(cut_meshes(&scene("rapier")), ["b.obj"]);
        // A static scene's mesh shapes are maps, touched triangle by triangle: none to cut.
        let fixed = "name: s\nshapes:\n  - mesh: { file: a.obj }\n";
        assert!(cut_meshes(&serde_saphyr::from_str::<Value>(fixed).unwrap()).is_empty());
    }
}

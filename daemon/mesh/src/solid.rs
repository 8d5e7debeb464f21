//! A mesh as a physics scene's body takes it: its surface where the file puts it, the mass
//! properties of the volume it closes, and the convex pieces both engines touch it through.

use std::path::{Path, PathBuf};

use crate::cache::Cache;
use crate::properties::{MassProperties, closure, cuboid, mass_properties};
use crate::{Limits, MeshError, MeshFileError, TriangleMesh};

/// A closed mesh ready to be a body, in the mesh file's frame times its scale.
#[derive(Debug, Clone)]
pub struct MeshSolid {
    /// The surface.
    pub mesh: TriangleMesh,
    /// Volume, centre and inertia (at density 1) of what the surface closes.
    pub properties: MassProperties,
    /// The convex pieces, each a closed convex surface (none when not asked for).
    pub pieces: Vec<TriangleMesh>,
    /// Whether the pieces came from the cache.
    pub cached: bool,
}

/// The mesh `file` (relative to `scene_dir`) of a scene in `scene_dir` (read from within that directory alone, under
/// [`Limits::DEFAULT`]) scaled by `scale`, which must close a volume; with its convex pieces
/// from `cache` (decomposed now if it holds none) when one is given.
pub fn solid(
    file: &Path,
    scene_dir: &Path,
    scale: f64,
    cache: Option<&Cache>,
) -> Result<MeshSolid, MeshFileError> {
    // Read at scale 1: the cache keys the mesh as the file has it.
    let (file, mut mesh) = read(file, scene_dir, scale)?;
    let file = &file;
    let refuse = |error| MeshFileError {
        file: file.clone(),
        error,
    };
    let c = closure(&mesh);
    if !c.is_closed() {
        return Err(refuse(MeshError::Open {
            open_edges: c.open_edges,
            bad_edges: c.bad_edges,
        }));
    }
    let (pieces, cached) = match cache {
        Some(cache) => cache.pieces(&mesh).map_err(refuse)?,
        None => (Vec::new(), false),
    };
    if mass_properties(&mesh).volume <= 0.0 {
        return Err(refuse(MeshError::InsideOut));
    }
    mesh.scale(scale);
    Ok(MeshSolid {
        properties: mass_properties(&mesh),
        mesh,
        pieces: pieces
            .into_iter()
            .map(|mut p| {
                p.scale(scale);
                p
            })
            .collect(),
        cached,
    })
}

/// The mesh `file` of a scene in `scene_dir` as a fixed body's surface: its triangles as they
/// are, holes and all (a scan is seldom closed, and a fixed body needs no volume). Its mass
/// properties are those of its bounding box, which nothing moves.
pub fn surface(file: &Path, scene_dir: &Path, scale: f64) -> Result<MeshSolid, MeshFileError> {
    let (_, mut mesh) = read(file, scene_dir, scale)?;
    mesh.scale(scale);
    let (low, high) = mesh.bounds();
    let properties = mass_properties(&cuboid(low, high));
    Ok(MeshSolid {
        mesh,
        properties,
        pieces: Vec::new(),
        cached: false,
    })
}

/// The mesh `file` (relative to `scene_dir`, read from within it, under [`Limits::DEFAULT`])
/// at scale 1, once `scale` is known to be usable; with the file's path.
fn read(
    file: &Path,
    scene_dir: &Path,
    scale: f64,
) -> Result<(PathBuf, TriangleMesh), MeshFileError> {
    let file = scene_dir.join(file);
    let refuse = |error| MeshFileError {
        file: file.clone(),
        error,
    };
    if !(scale.is_finite() && scale > 0.0) {
        return Err(refuse(MeshError::Scale(scale)));
    }
    let mesh = crate::read(&file, 1.0, Limits::DEFAULT, Some(scene_dir)).map_err(refuse)?;
    Ok((file, mesh))
}

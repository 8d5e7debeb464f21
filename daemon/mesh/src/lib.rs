//! Triangle meshes for hapticd: a user's part, a scanned object or a model from a 3D tool,
//! read from Wavefront OBJ, STL (binary or ASCII) or glTF 2.0 (`.gltf` with its buffers, or
//! `.glb`), checked as every other input is, and measured.
//!
//! - [`TriangleMesh`]: welded vertices, triangles, and the normals the file gave;
//! - [`load`] and [`Limits`]: reading a file by its extension, refusing what could hurt;
//! - [`properties`]: whether the surface is closed, its volume, centre and inertia;
//! - [`decomposition`]: a movable mesh as convex pieces, kept between runs by [`cache`];
//! - [`enclosure`]: whether a closed mesh holds a point, and its surface nearest one;
//! - [`solid`]: a mesh as a physics body takes it;
//! - [`triangle`]: a triangle's point nearest a point;
//! - `height_map` and `scene_files` (feature `scene-files`): a grey PNG a texture lays over
//!   a surface, and the readers of what a scene file names;
//! - `obj`, `stl`, `gltf`: the three formats.
//!
//! Coordinates are metres once the scene's `scale:` is applied; every finding names the file.

pub mod cache;
pub mod decomposition;
pub mod enclosure;
mod error;
mod gltf;
#[cfg(feature = "scene-files")]
pub mod height_map;
mod obj;
pub mod properties;
mod solid;
mod stl;
pub mod triangle;

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;
use hapticd_core::diagnostics::{Diagnostics, FileRules, read_file};
#[cfg(feature = "scene-files")]
use hapticd_core::scene::static_scene::{MeshFaces, SceneFiles};

pub use crate::error::{Budget, Format, MeshError, MeshFileError};

pub use solid::{MeshSolid, solid, surface};

/// What a mesh file may hold: enough for a detailed CAD part, and few enough that a file
/// cannot make hapticd spend seconds or gigabytes.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Most vertices, after identical ones are merged.
    pub vertices: usize,
    /// Most triangles.
    pub triangles: usize,
    /// Largest file, bytes; for glTF also the most its buffers hold together.
    pub bytes: u64,
    /// Most nodes of a glTF file.
    pub nodes: usize,
}

impl Limits {
    /// hapticd's: 500 000 vertices and triangles, 64 MiB a file, 100 000 glTF nodes.
    pub const DEFAULT: Limits = Limits {
        vertices: 500_000,
        triangles: 500_000,
        bytes: 64 << 20,
        nodes: 100_000,
    };
}

/// A surface of triangles, its vertices shared (merged where the file repeats a position).
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions, metres.
    pub vertices: Vec<DVec3>,
    /// Each triangle's three vertices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Each triangle's corner normals, when the file gives them (for smooth shading).
    pub normals: Option<Vec<[DVec3; 3]>>,
}

/// A mesh as a format reader hands it over, before checks and merging: corner positions
/// by index, and corner normals where the file has them.
struct Read {
    positions: Vec<DVec3>,
    triangles: Vec<[usize; 3]>,
    normals: Option<Vec<[DVec3; 3]>>,
}

/// Read the mesh in `file` (its format by its extension), scaled by `scale`, within
/// `limits`. With `within`, the file and any buffer it names must lie in that directory
/// once links are followed (a file a bus caller named). Refused with the file's diagnostics
/// (see [`read`] for the typed refusal).
pub fn load(
    file: &Path,
    scale: f64,
    limits: Limits,
    within: Option<&Path>,
) -> Result<TriangleMesh, Diagnostics> {
    let refuse = |e: MeshError| Diagnostics::file(file, e.to_string());
    check_scale(scale).map_err(refuse)?;
    let (bytes, rules) = contents(file, limits, within)?;
    parse(&bytes, file, rules, scale, limits).map_err(refuse)
}

/// [`load`], refused with why.
pub fn read(
    file: &Path,
    scale: f64,
    limits: Limits,
    within: Option<&Path>,
) -> Result<TriangleMesh, MeshError> {
    check_scale(scale)?;
    let (bytes, rules) =
        contents(file, limits, within).map_err(|e| MeshError::Unreadable(e.message()))?;
    parse(&bytes, file, rules, scale, limits)
}

/// The bytes of `file`, read as `limits` and `within` allow, and the rules they were read
/// under (the buffers a glTF file names are read under the same).
fn contents<'a>(
    file: &Path,
    limits: Limits,
    within: Option<&'a Path>,
) -> Result<(Vec<u8>, FileRules<'a>), hapticd_core::diagnostics::FileError> {
    let rules = FileRules {
        max_bytes: limits.bytes,
        within,
    };
    Ok((read_file(file, rules)?, rules))
}

fn check_scale(scale: f64) -> Result<(), MeshError> {
    if scale.is_finite() && scale > 0.0 {
        Ok(())
    } else {
        Err(MeshError::Scale(scale))
    }
}

/// The mesh in `bytes`, the contents of `file` (its format by its extension).
fn parse(
    bytes: &[u8],
    file: &Path,
    rules: FileRules,
    scale: f64,
    limits: Limits,
) -> Result<TriangleMesh, MeshError> {
    let extension = file
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    // The readers check what they are given before they trust it; should a format crate
    // still panic on a file, the file is refused, not the process ended.
    let read = std::panic::catch_unwind(|| match extension.as_deref() {
        Some("obj") => obj::read(bytes, limits),
        Some("stl") => stl::read(bytes, limits),
        Some("gltf") | Some("glb") => gltf::read(bytes, file, rules, limits),
        _ => Err(MeshError::UnknownFormat),
    })
    .unwrap_or(Err(MeshError::ReaderFault))?;
    TriangleMesh::checked(read, scale, limits)
}

impl TriangleMesh {
    /// `read` scaled, checked and with its identical positions merged.
    fn checked(read: Read, scale: f64, limits: Limits) -> Result<TriangleMesh, MeshError> {
        if read.triangles.len() > limits.triangles {
            return Err(MeshError::too_large(
                Budget::Triangles,
                format!(
                    "{} triangles; a mesh has at most {}",
                    read.triangles.len(),
                    limits.triangles
                ),
            ));
        }
        if read.triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        if let Some(k) = read.positions.iter().position(|p| !p.is_finite()) {
            return Err(MeshError::NotFinite(k + 1));
        }
        // One vertex per position, so that triangles sharing an edge share its vertices.
        let mut index: HashMap<[u64; 3], u32> = HashMap::new();
        let mut vertices = Vec::new();
        let mut merged = Vec::with_capacity(read.positions.len());
        for p in &read.positions {
            let p = *p * scale;
            let key = p.to_array().map(|c| (c + 0.0).to_bits());
            let next = vertices.len() as u32;
            let k = *index.entry(key).or_insert(next);
            if k == next {
                vertices.push(p);
            }
            merged.push(k);
        }
        if vertices.len() > limits.vertices {
            return Err(MeshError::too_large(
                Budget::Vertices,
                format!(
                    "{} vertices; a mesh has at most {}",
                    vertices.len(),
                    limits.vertices
                ),
            ));
        }
        let mut triangles = Vec::with_capacity(read.triangles.len());
        for (t, corners) in read.triangles.iter().enumerate() {
            let mut triangle = [0u32; 3];
            for (out, &corner) in triangle.iter_mut().zip(corners) {
                *out = *merged.get(corner).ok_or(MeshError::NoSuchVertex {
                    triangle: t + 1,
                    vertex: corner + 1,
                    vertices: read.positions.len(),
                })?;
            }
            triangles.push(triangle);
        }
        let normals = read
            .normals
            .filter(|n| n.len() == triangles.len() && n.iter().flatten().all(|v| v.is_finite()));
        Ok(TriangleMesh {
            vertices,
            triangles,
            normals,
        })
    }

    /// The triangles as corner positions.
    pub fn corners(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        self.triangles
            .iter()
            .map(|t| t.map(|k| self.vertices[k as usize]))
    }

    /// Scale the mesh by `factor` about the origin.
    pub fn scale(&mut self, factor: f64) {
        for v in &mut self.vertices {
            *v *= factor;
        }
    }

    /// The smallest axis-aligned box holding the mesh: lowest and highest corner.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.vertices
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &p| {
                (l.min(p), h.max(p))
            })
    }
}

/// The readers of the files a scene names: its meshes ([`scene_triangles`]) and height maps
/// ([`height_map::height_map`]).
#[cfg(feature = "scene-files")]
pub fn scene_files() -> SceneFiles<'static> {
    SceneFiles {
        meshes: &scene_triangles,
        images: &height_map::height_map,
    }
}

/// The triangles of the mesh `file` a scene in `scene_dir` names, scaled by `scale`, and
/// whether they bound a solid: read under [`Limits::DEFAULT`], and only from within the
/// scene's directory. The reader hapticd and hapticctl give static scenes
/// (`hapticd_core::scene::static_scene::MeshReader`).
#[cfg(feature = "scene-files")]
fn scene_triangles(
    file: &Path,
    scene_dir: &Path,
    scale: f64,
) -> Result<MeshFaces, Box<dyn std::error::Error + Send + Sync>> {
    let mesh =
        read(file, scale, Limits::DEFAULT, Some(scene_dir)).map_err(|error| MeshFileError {
            file: file.to_path_buf(),
            error,
        })?;
    Ok(MeshFaces {
        closed: properties::closure(&mesh).is_closed(),
        triangles: mesh.corners().collect(),
    })
}

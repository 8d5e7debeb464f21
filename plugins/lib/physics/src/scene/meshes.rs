//! Bodies of mesh files (`mesh: FILE`, with `scale:` and `up:`): the file read from the scene's own
//! directory, its mass and inertia those of the volume it closes, and its convex pieces
//! (decomposed once and cached, [`hapticd_mesh::cache`]) what the engines touch it through.
//! A fixed mesh under rapier keeps its triangles instead, holes and all.

use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3};
use hapticd_core::diagnostics::Findings;
use hapticd_core::kinematics::{SOLID_SIZES, WORLD_EXTENT};
use hapticd_mesh::cache::Cache;

use super::schema::RawBody;
use crate::polyhedron::Polyhedron;

/// Smallest and largest `scale:`.
pub const SCALE_RANGE: (f64, f64) = (1e-6, 1e6);

/// Where a scene's meshes come from: the scene file's directory, and the cache of their
/// convex pieces.
pub(super) struct MeshFiles<'a> {
    dir: PathBuf,
    /// None: meshes are checked, not cut.
    cache: Option<&'a Cache>,
}

impl<'a> MeshFiles<'a> {
    /// The meshes of the scene file at `path`, their pieces in `cache` (none: not cut).
    pub(super) fn of_scene(path: &Path, cache: Option<&'a Cache>) -> Self {
        Self {
            dir: hapticd_core::diagnostics::directory_of(path).to_path_buf(),
            cache,
        }
    }
}

/// A mesh body where the file puts it.
pub(super) struct MeshBody {
    /// Its convex pieces (none for a fixed mesh under rapier).
    pub(super) pieces: Vec<Polyhedron>,
    /// Its triangles.
    pub(super) surface: Vec<[DVec3; 3]>,
    /// Volume, m³.
    pub(super) volume: f64,
    /// Centre of volume.
    pub(super) centre: DVec3,
    /// Inertia about the centre at density 1, world frame.
    pub(super) inertia: DMat3,
}

/// How a body takes its mesh file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Reading {
    /// A closed surface, with its convex pieces when the files cut meshes: a rigid body.
    Pieces,
    /// A closed surface alone: a soft body, cut into tetrahedra of its own.
    Closed,
    /// The triangles as they are, holes and all: a fixed body under rapier.
    Surface,
}

/// The mesh `file` of body `b` (at field path `at`), read as `reading` says, in the file's
/// frame times its scale, and the turn that places it (its orientation and `up:`); `None`
/// after reporting what is wrong.
pub(super) fn read_mesh(
    f: &mut Findings,
    at: &str,
    b: &RawBody,
    file: &str,
    files: &MeshFiles<'_>,
    reading: Reading,
) -> Option<(hapticd_mesh::MeshSolid, DQuat)> {
    if b.size.is_some() || b.hull.is_some() || b.sphere.is_some() || b.pieces.is_some() {
        f.error(
            at,
            "give exactly one of box:, hull:, sphere:, pieces: or mesh:",
        );
        return None;
    }
    let turn = f.unit_quaternion(format!("{at}.orientation"), b.orientation)
        * b.up.unwrap_or_default().turn();
    let placed = f.coordinates(format!("{at}.position"), &b.position, WORLD_EXTENT, "m");
    let scale = b.scale.unwrap_or(1.0);
    let (small, large) = SCALE_RANGE;
    let scaled = f.within(format!("{at}.scale"), scale, small, large, "");
    if !(placed && scaled) {
        return None;
    }
    let read = match reading {
        Reading::Pieces => hapticd_mesh::solid(Path::new(file), &files.dir, scale, files.cache),
        Reading::Closed => hapticd_mesh::solid(Path::new(file), &files.dir, scale, None),
        Reading::Surface => hapticd_mesh::surface(Path::new(file), &files.dir, scale),
    };
    let solid = match read {
        Ok(solid) => solid,
        Err(e) => {
            f.error(format!("{at}.mesh"), e.to_string());
            return None;
        }
    };
    let (low, high) = solid.mesh.bounds();
    let (smallest, largest) = SOLID_SIZES;
    let size = (high - low).max_element();
    if !(smallest..=largest).contains(&size) {
        f.error(
            format!("{at}.mesh"),
            format!("{size:.3e} m across once scaled; a solid is {smallest} to {largest} m"),
        );
        return None;
    }
    Some((solid, turn))
}

/// The mesh `file` of body `b` (at field path `at`), with its convex pieces when `pieces`
/// and `files` cuts meshes; `None` after reporting what is wrong.
pub(super) fn mesh_body(
    f: &mut Findings,
    at: &str,
    b: &RawBody,
    file: &str,
    files: &MeshFiles<'_>,
    pieces: bool,
) -> Option<MeshBody> {
    let reading = if pieces {
        Reading::Pieces
    } else {
        Reading::Surface
    };
    let (solid, turn) = read_mesh(f, at, b, file, files, reading)?;
    let cut = files.cache.is_some() && pieces;
    let smallest = SOLID_SIZES.0;
    let position = DVec3::from(b.position);
    let place = |v: DVec3| turn * v + position;
    let mut convex = Vec::with_capacity(solid.pieces.len());
    for piece in &solid.pieces {
        // A sliver V-HACD leaves flat holds no volume to touch through; its neighbours do.
        if let Ok(p) = Polyhedron::of_convex_surface(&piece.vertices, &piece.triangles)
            && p.thickness() >= smallest
        {
            convex.push(p.transformed(turn, position));
        }
    }
    if cut && convex.is_empty() {
        f.error(format!("{at}.mesh"), "no convex piece of it holds a volume");
        return None;
    }
    let rotation = DMat3::from_quat(turn);
    let p = solid.properties;
    Some(MeshBody {
        pieces: convex,
        surface: solid.mesh.corners().map(|t| t.map(place)).collect(),
        volume: p.volume,
        centre: place(p.centre),
        inertia: rotation * p.inertia * rotation.transpose(),
    })
}

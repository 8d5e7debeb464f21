//! Triangle meshes as hapticd reads them (`hapticctl mesh …`), each look a [`Report`]: what
//! a mesh is (its size, whether it bounds a solid, the solid's volume, centre and inertia,
//! its convex pieces if they are cut), and its cutting into the convex pieces a movable body
//! is simulated with.

use std::path::{Path, PathBuf};

use glam::DMat3;
use hapticd_mesh::cache::Cache;
use hapticd_mesh::decomposition::{RESOLUTION, decompose as cut};
use hapticd_mesh::properties::{MassProperties, closure, is_convex, mass_properties};
use hapticd_mesh::{MeshError, TriangleMesh};
use serde_json::json;

use crate::report::Report;

/// Why a mesh cannot be cut into convex pieces: it bounds no solid.
#[derive(Debug)]
pub enum NoSolid {
    /// The surface of the mesh in this file is not closed.
    Open(PathBuf),
    /// The faces of the mesh in this file point inwards.
    Inward(PathBuf),
    /// The mesh in this file could not be cut, as the error says.
    Uncut(PathBuf, MeshError),
}

impl std::fmt::Display for NoSolid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoSolid::Open(file) => write!(
                f,
                "{}: the surface is not closed, so it bounds no solid to cut (hapticctl mesh \
                 inspect says where)",
                file.display()
            ),
            NoSolid::Inward(file) => write!(
                f,
                "{}: its faces point inwards (the volume they close is negative)",
                file.display()
            ),
            NoSolid::Uncut(file, error) => write!(f, "{}: {error}", file.display()),
        }
    }
}

impl std::error::Error for NoSolid {}

/// What `mesh` (read from `file`, its coordinates scaled by `scale`) is: triangles,
/// vertices, bounds, whether it is closed, and the volume, centre and inertia it encloses
/// (the mass and inertia of a body of it at `density`, kg/m³, if given), and whether
/// `cache` holds its convex pieces.
pub fn inspect(
    file: &Path,
    mesh: &TriangleMesh,
    scale: f64,
    density: Option<f64>,
    cache: &Cache,
) -> Report {
    let (low, high) = mesh.bounds();
    let edges = closure(mesh);
    let solid = mass_properties(mesh);
    let closed = edges.is_closed();
    let convex = closed && is_convex(mesh);
    let mut text = surface_text(file, mesh);
    if closed {
        text += &solid_text(&solid, convex, density);
    } else {
        text += &format!(
            "closed: no ({} open edges, {} edges shared by more than two triangles or flipped \
             faces): it can be a static scene's shape, not a physics scene's body\n",
            edges.open_edges, edges.bad_edges
        );
    }
    // The pieces a scene would touch it through, if they are cut (scenes key the file as it
    // is, unscaled).
    let pieces = (closed && scale == 1.0)
        .then(|| cache.lookup(mesh))
        .flatten();
    match (&pieces, cache.entry(mesh)) {
        (Some(pieces), Some(entry)) => {
            text += &format!(
                "convex pieces: {}, kept in {}\n",
                pieces.len(),
                entry.display()
            );
        }
        _ if closed => text += "convex pieces: not cut yet (hapticctl mesh decompose cuts them)\n",
        _ => {}
    }
    let json = json!({
        "file": file,
        "triangles": mesh.triangles.len(),
        "vertices": mesh.vertices.len(),
        "normals": mesh.normals.is_some(),
        "bounds": [low.to_array(), high.to_array()],
        "closed": closed,
        "open_edges": edges.open_edges,
        "bad_edges": edges.bad_edges,
        "volume": closed.then_some(solid.volume),
        "centre": closed.then_some(solid.centre.to_array()),
        "inertia": closed.then_some(solid.inertia.to_cols_array_2d()),
        "convex": closed.then_some(convex),
        "density": density,
        "mass": density.filter(|_| closed).map(|d| solid.volume * d),
        "body_inertia": density
            .filter(|_| closed)
            .map(|d| (solid.inertia * d).to_cols_array_2d()),
        "pieces": pieces.as_ref().map(Vec::len),
    });
    Report {
        text,
        json,
        charts: Vec::new(),
    }
}

/// The first lines of `inspect`: the file's triangles, vertices and bounds.
fn surface_text(file: &Path, mesh: &TriangleMesh) -> String {
    let (low, high) = mesh.bounds();
    let size = high - low;
    format!(
        "{}: {} triangles, {} vertices{}\nbounds: {:.6} {:.6} {:.6} to {:.6} {:.6} {:.6} m \
         ({:.6} × {:.6} × {:.6})\n",
        file.display(),
        mesh.triangles.len(),
        mesh.vertices.len(),
        if mesh.normals.is_some() {
            ", with normals"
        } else {
            ""
        },
        low.x,
        low.y,
        low.z,
        high.x,
        high.y,
        high.z,
        size.x,
        size.y,
        size.z,
    )
}

/// The lines of `inspect` about the solid a closed mesh bounds.
fn solid_text(solid: &MassProperties, convex: bool, density: Option<f64>) -> String {
    let mut text = format!(
        "closed: yes\nvolume: {:.9e} m³, centre {:.6} {:.6} {:.6} m\ninertia per kg/m³ \
         about the centre: {}\n",
        solid.volume,
        solid.centre.x,
        solid.centre.y,
        solid.centre.z,
        inertia_text(&solid.inertia),
    );
    if solid.volume < 0.0 {
        text += "the triangles face inwards: a negative volume\n";
    }
    text += if convex {
        "convex: yes (a body of it is its own one piece)\n"
    } else {
        "convex: no\n"
    };
    if let Some(d) = density {
        text += &format!(
            "at {d} kg/m³: mass {:.6e} kg, inertia about the centre {}\n",
            solid.volume * d,
            inertia_text(&(solid.inertia * d)),
        );
    }
    text
}

/// An inertia tensor as `inspect` prints it: the moments, then the products, kg·m².
fn inertia_text(i: &DMat3) -> String {
    format!(
        "{:.6e} {:.6e} {:.6e} (products {:.3e} {:.3e} {:.3e}) kg·m²",
        i.x_axis.x, i.y_axis.y, i.z_axis.z, i.y_axis.x, i.z_axis.x, i.z_axis.y
    )
}

/// `mesh` (read from `file`, its coordinates scaled by `scale`) cut into convex pieces at
/// `resolution` voxels along its longest side: their number, their volume against the
/// mesh's, and the time it took. The pieces are kept in `cache` when scenes would read them:
/// cut at the default resolution from the mesh as its file has it.
pub fn decompose(
    file: &Path,
    mesh: &TriangleMesh,
    (resolution, scale): (u32, f64),
    cache: &Cache,
) -> Result<Report, NoSolid> {
    if !closure(mesh).is_closed() {
        return Err(NoSolid::Open(file.to_path_buf()));
    }
    let volume = mass_properties(mesh).volume;
    if volume <= 0.0 {
        return Err(NoSolid::Inward(file.to_path_buf()));
    }
    let started = std::time::Instant::now();
    let pieces = cut(mesh, resolution).map_err(|e| NoSolid::Uncut(file.to_path_buf(), e))?;
    let seconds = started.elapsed().as_secs_f64();
    let kept = if resolution == RESOLUTION && scale == 1.0 {
        cache.store(mesh, &pieces.pieces)
    } else {
        None
    };
    let hulls = pieces.volume();
    let error = (hulls - volume) / volume;
    let text = format!(
        "{}: {} convex pieces in {:.3} s; their volume {:.6e} m³ against the mesh's {:.6e} m³ \
         ({:+.2} %)\n",
        file.display(),
        pieces.pieces.len(),
        seconds,
        hulls,
        volume,
        100.0 * error
    ) + &kept
        .as_ref()
        .map(|entry| format!("kept in {}\n", entry.display()))
        .unwrap_or_default();
    let json = json!({
        "kept": kept,
        "file": file,
        "pieces": pieces.pieces.len(),
        "seconds": seconds,
        "volume": volume,
        "pieces_volume": hulls,
        "volume_error": error,
    });
    Ok(Report {
        text,
        json,
        charts: Vec::new(),
    })
}

//! `hapticctl mesh …`: look at a triangle mesh (OBJ, STL, glTF) as hapticd reads it.

use std::path::PathBuf;

use clap::{Args, Subcommand};
use hapticd_mesh::cache::Cache;
use hapticd_mesh::properties::{closure, is_convex, mass_properties};
use hapticd_mesh::{Limits, load};
use serde_json::json;

use crate::Failure;
use crate::mechanism::{Output, print};

#[derive(Subcommand)]
pub enum Command {
    /// Triangles, vertices, bounds, whether the surface is closed, and the volume, centre
    /// and inertia it encloses.
    Inspect(InspectArgs),
    /// Cut a mesh into the convex pieces a movable body is simulated with: their number,
    /// their volume against the mesh's, and the time it took.
    Decompose(DecomposeArgs),
}

#[derive(Args)]
pub struct DecomposeArgs {
    /// The mesh file: .obj, .stl, .gltf or .glb.
    file: PathBuf,
    /// Scale the file's coordinates by S to make metres (as a scene's `scale:`).
    #[arg(long, default_value_t = 1.0)]
    scale: f64,
    /// Voxels along the mesh's longest side (finer: more, tighter pieces; slower). Pieces
    /// are kept for scenes at the default alone.
    #[arg(long, default_value_t = hapticd_mesh::decomposition::RESOLUTION)]
    resolution: u32,
    /// Keep the pieces in DIR, where hapticd finds them (default: $CACHE_DIRECTORY, else
    /// ~/.cache/hapticd; the installed daemon's is /var/cache/hapticd, written as its user:
    /// `sudo -u hapticd hapticctl mesh decompose --cache /var/cache/hapticd FILE`).
    #[arg(long, value_name = "DIR")]
    cache: Option<PathBuf>,
    #[command(flatten)]
    output: Output,
}

#[derive(Args)]
pub struct InspectArgs {
    /// The mesh file: .obj, .stl, .gltf or .glb.
    file: PathBuf,
    /// Scale the file's coordinates by S to make metres (as a scene's `scale:`).
    #[arg(long, default_value_t = 1.0)]
    scale: f64,
    /// Look for its convex pieces in DIR (default: $CACHE_DIRECTORY, else ~/.cache/hapticd).
    #[arg(long, value_name = "DIR")]
    cache: Option<PathBuf>,
    /// Also give the mass and inertia a body of this density (kg/m³) would have, as a
    /// scene's `density:`.
    #[arg(long, value_name = "KG_PER_M3")]
    density: Option<f64>,
    #[command(flatten)]
    output: Output,
}

/// Run one `mesh` subcommand.
pub fn run(command: Command) -> Result<(), Failure> {
    match command {
        Command::Inspect(args) => inspect(&args),
        Command::Decompose(args) => decompose(&args),
    }
}

fn inspect(args: &InspectArgs) -> Result<(), Failure> {
    if let Some(d) = args.density
        && !(d.is_finite() && d > 0.0)
    {
        return Err(Failure::usage(format!(
            "--density must be a finite number > 0, not {d}"
        )));
    }
    let mesh = load(&args.file, args.scale, Limits::DEFAULT, None)?;
    let (low, high) = mesh.bounds();
    let edges = closure(&mesh);
    let solid = mass_properties(&mesh);
    let size = high - low;
    let mut text = format!(
        "{}: {} triangles, {} vertices{}\nbounds: {:.6} {:.6} {:.6} to {:.6} {:.6} {:.6} m \
         ({:.6} × {:.6} × {:.6})\n",
        args.file.display(),
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
    );
    let closed = edges.is_closed();
    let convex = closed && is_convex(&mesh);
    if closed {
        let i = solid.inertia;
        text += &format!(
            "closed: yes\nvolume: {:.9e} m³, centre {:.6} {:.6} {:.6} m\ninertia per kg/m³ \
             about the centre: {}\n",
            solid.volume,
            solid.centre.x,
            solid.centre.y,
            solid.centre.z,
            inertia_text(&i),
        );
        if solid.volume < 0.0 {
            text += "the triangles face inwards: a negative volume\n";
        }
        text += if convex {
            "convex: yes (a body of it is its own one piece)\n"
        } else {
            "convex: no\n"
        };
        if let Some(d) = args.density {
            text += &format!(
                "at {d} kg/m³: mass {:.6e} kg, inertia about the centre {}\n",
                solid.volume * d,
                inertia_text(&(solid.inertia * d)),
            );
        }
    } else {
        text += &format!(
            "closed: no ({} open edges, {} edges shared by more than two triangles or flipped \
             faces): it can be a static scene's shape, not a physics scene's body\n",
            edges.open_edges, edges.bad_edges
        );
    }
    // The pieces a scene would touch it through, if they are cut (scenes key the file as it
    // is, unscaled).
    let cache = cache_of(&args.cache);
    let pieces = (closed && args.scale == 1.0)
        .then(|| cache.lookup(&mesh))
        .flatten();
    match (&pieces, cache.entry(&mesh)) {
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
    let value = json!({
        "file": args.file,
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
        "density": args.density,
        "mass": args.density.filter(|_| closed).map(|d| solid.volume * d),
        "body_inertia": args
            .density
            .filter(|_| closed)
            .map(|d| (solid.inertia * d).to_cols_array_2d()),
        "pieces": pieces.as_ref().map(Vec::len),
    });
    print(&args.output, value, text);
    Ok(())
}

/// An inertia tensor as `inspect` prints it: the moments, then the products, kg·m².
fn inertia_text(i: &glam::DMat3) -> String {
    format!(
        "{:.6e} {:.6e} {:.6e} (products {:.3e} {:.3e} {:.3e}) kg·m²",
        i.x_axis.x, i.y_axis.y, i.z_axis.z, i.y_axis.x, i.z_axis.x, i.z_axis.y
    )
}

fn decompose(args: &DecomposeArgs) -> Result<(), Failure> {
    if !(8..=512).contains(&args.resolution) {
        return Err(Failure::usage(format!(
            "--resolution must be 8 to 512 voxels, not {}",
            args.resolution
        )));
    }
    let mesh = load(&args.file, args.scale, Limits::DEFAULT, None)?;
    if !closure(&mesh).is_closed() {
        return Err(Failure::failed(format!(
            "{}: the surface is not closed, so it bounds no solid to cut (hapticctl mesh \
             inspect says where)",
            args.file.display()
        )));
    }
    if mass_properties(&mesh).volume <= 0.0 {
        return Err(Failure::failed(format!(
            "{}: its faces point inwards (the volume they close is negative)",
            args.file.display()
        )));
    }
    let started = std::time::Instant::now();
    let pieces = hapticd_mesh::decomposition::decompose(&mesh, args.resolution);
    let seconds = started.elapsed().as_secs_f64();
    // Scenes read the pieces of the mesh as its file has it, at the default resolution.
    let kept = if args.resolution == hapticd_mesh::decomposition::RESOLUTION && args.scale == 1.0 {
        cache_of(&args.cache).store(&mesh, &pieces.pieces)
    } else {
        None
    };
    let volume = mass_properties(&mesh).volume;
    let hulls = pieces.volume();
    let error = (hulls - volume) / volume;
    let text = format!(
        "{}: {} convex pieces in {:.3} s; their volume {:.6e} m³ against the mesh's {:.6e} m³ \
         ({:+.2} %)\n",
        args.file.display(),
        pieces.pieces.len(),
        seconds,
        hulls,
        volume,
        100.0 * error
    ) + &kept
        .as_ref()
        .map(|entry| format!("kept in {}\n", entry.display()))
        .unwrap_or_default();
    let value = json!({
        "kept": kept,
        "file": args.file,
        "pieces": pieces.pieces.len(),
        "seconds": seconds,
        "volume": volume,
        "pieces_volume": hulls,
        "volume_error": error,
    });
    print(&args.output, value, text);
    Ok(())
}

/// The cache at `dir`, or this user's.
fn cache_of(dir: &Option<PathBuf>) -> Cache {
    dir.clone().map_or_else(Cache::from_environment, Cache::at)
}

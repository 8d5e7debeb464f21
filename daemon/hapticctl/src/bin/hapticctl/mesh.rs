//! `hapticctl mesh …`: look at a triangle mesh (OBJ, STL, glTF) as hapticd reads it
//! ([`hapticctl::mesh_report`]).

use std::path::PathBuf;

use clap::{Args, Subcommand};
use hapticctl::mesh_report;
use hapticd_mesh::cache::Cache;
use hapticd_mesh::{Limits, load};

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
    let cache = cache_of(&args.cache);
    let report = mesh_report::inspect(&args.file, &mesh, args.scale, args.density, &cache);
    print(&args.output, report.json, report.text);
    Ok(())
}

fn decompose(args: &DecomposeArgs) -> Result<(), Failure> {
    if !(8..=512).contains(&args.resolution) {
        return Err(Failure::usage(format!(
            "--resolution must be 8 to 512 voxels, not {}",
            args.resolution
        )));
    }
    let mesh = load(&args.file, args.scale, Limits::DEFAULT, None)?;
    let cache = cache_of(&args.cache);
    let report = mesh_report::decompose(&args.file, &mesh, (args.resolution, args.scale), &cache)
        .map_err(Failure::failed)?;
    print(&args.output, report.json, report.text);
    Ok(())
}

/// The cache at `dir`, or this user's.
fn cache_of(dir: &Option<PathBuf>) -> Cache {
    dir.clone().map_or_else(Cache::from_environment, Cache::at)
}

//! A movable mesh as convex pieces (V-HACD, parry3d's): what both engines can simulate,
//! each piece a hull of the mesh's own vertices. The pieces stand for the mesh in contact
//! only; its mass and inertia stay the mesh's own ([`crate::properties`]). A convex mesh is
//! its own one piece: voxels could only add error to it.

use glam::DVec3;
use parry3d::math::Vector;
use parry3d::transformation::vhacd::{VHACD, VHACDParameters};

use crate::properties::{is_convex, mass_properties};
use crate::{MeshError, TriangleMesh};

/// Voxels along the mesh's longest side: V-HACD's default, fine enough for a mug's handle.
pub const RESOLUTION: u32 = 64;

/// The convex pieces of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Decomposition {
    /// Each piece as a closed triangle mesh (its convex hull).
    pub pieces: Vec<TriangleMesh>,
}

impl Decomposition {
    /// The pieces' volume together, m³ (more than the mesh's where they overlap or bulge).
    pub fn volume(&self) -> f64 {
        self.pieces.iter().map(|p| mass_properties(p).volume).sum()
    }
}

/// `mesh` cut into convex pieces at `resolution` voxels along its longest side (at least 8);
/// [`MeshError::Uncut`] where the decomposition fails on it.
pub fn decompose(mesh: &TriangleMesh, resolution: u32) -> Result<Decomposition, MeshError> {
    if is_convex(mesh) {
        return Ok(Decomposition {
            pieces: vec![TriangleMesh {
                normals: None,
                ..mesh.clone()
            }],
        });
    }
    // The decomposition works in single precision: about the mesh's centre, so that a part
    // far from the origin keeps its detail.
    let (low, high) = mesh.bounds();
    let centre = (low + high) / 2.0;
    let points: Vec<Vector> = mesh
        .vertices
        .iter()
        .map(|v| {
            let p = (*v - centre).as_vec3();
            Vector::new(p.x, p.y, p.z)
        })
        .collect();
    let resolution = resolution.max(8);
    let parameters = VHACDParameters {
        resolution,
        ..Default::default()
    };
    // Keeping which triangles each voxel holds lets each piece be the hull of the mesh's own
    // vertices, not of voxel corners. Its hull of a part it clipped can fail (parry3d 0.31
    // panics on the shipped mug at 161 voxels): the mesh is refused, not the process ended.
    let hulls = std::panic::catch_unwind(|| {
        VHACD::decompose(&parameters, &points, &mesh.triangles, true)
            .compute_exact_convex_hulls(&points, &mesh.triangles)
    })
    .map_err(|_| MeshError::Uncut(resolution))?;
    let pieces = hulls
        .into_iter()
        .filter(|(_, triangles)| !triangles.is_empty())
        .map(|(vertices, triangles)| TriangleMesh {
            vertices: vertices
                .iter()
                .map(|v| DVec3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z)) + centre)
                .collect::<Vec<DVec3>>(),
            triangles,
            normals: None,
        })
        .collect();
    Ok(Decomposition { pieces })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::properties::closure;

    #[test]
    fn a_convex_mesh_is_its_own_one_piece_and_two_apart_are_cut() {
        let (low, high) = (DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.1, 2.05, 3.2));
        let mesh = crate::properties::cuboid(low, high);
        let d = decompose(&mesh, RESOLUTION).unwrap();
        // Exactly the box: no voxel error added (V-HACD cut a cube into 9 pieces of +26 %).
        assert_eq!(d.pieces, vec![mesh.clone()]);
        // Two unit cubes a unit apart: convex along every edge, yet not one convex solid.
        let mut pair = crate::properties::cuboid(DVec3::ZERO, DVec3::ONE);
        let other = crate::properties::cuboid(DVec3::X * 2.0, DVec3::new(3.0, 1.0, 1.0));
        let first = pair.vertices.len() as u32;
        pair.vertices.extend(&other.vertices);
        pair.triangles
            .extend(other.triangles.iter().map(|t| t.map(|k| k + first)));
        assert!(!crate::properties::is_convex(&pair));
        let d = decompose(&pair, RESOLUTION).unwrap();
        assert!(d.pieces.len() >= 2, "{}", d.pieces.len());
        for piece in &d.pieces {
            assert!(closure(piece).is_closed());
        }
        assert!((d.volume() - 2.0).abs() < 1e-6, "{}", d.volume());
    }
}

//! Normals for solids of triangles, worked out once a scene: where the faces of a mesh meet
//! at a shallow angle its curved surface is drawn smooth (each corner's normal the area-weighted
//! mean of the faces there that lie within [`CREASE`] of its own), while its edges stay sharp.

use std::collections::HashMap;

use glam::DVec3;
use hapticd_plugin_api::{Geometry, HAPTICD_SHAPE_TRIANGLES};

/// Faces meeting at less than this angle, radians (35°), are one smooth surface; a box's
/// edges (90°) and a mug's rim stay sharp, a cylinder of a dozen sides or more is round.
pub const CREASE: f64 = 35.0 * std::f64::consts::PI / 180.0;

/// A scene's solids and the normal at each corner of each of their triangles.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Shaded {
    /// The solids.
    pub geometry: Geometry,
    /// Per triangle of `geometry.triangles`, its corners' normals (in its solid's frame).
    normals: Vec<[DVec3; 3]>,
}

impl Shaded {
    /// `geometry` with its triangles' normals: smooth within each solid, flat elsewhere.
    pub fn new(geometry: Geometry) -> Self {
        let face = |k: usize| {
            let [a, b, c] = geometry.triangles[k].corners.map(DVec3::from);
            (b - a).cross(c - a)
        };
        let mut normals: Vec<[DVec3; 3]> = (0..geometry.triangles.len())
            .map(|k| [face(k).normalize_or_zero(); 3])
            .collect();
        let cos_crease = CREASE.cos();
        for solid in geometry
            .solids
            .iter()
            .filter(|s| s.shape == HAPTICD_SHAPE_TRIANGLES)
        {
            let first = solid.first_triangle as usize;
            let count = geometry.triangles_of(solid).len();
            // The faces at each corner position.
            let mut at: HashMap<[u64; 3], Vec<usize>> = HashMap::new();
            for k in first..first + count {
                for c in geometry.triangles[k].corners {
                    at.entry(c.map(|x| (x + 0.0).to_bits()))
                        .or_default()
                        .push(k);
                }
            }
            let triangles = &geometry.triangles[first..first + count];
            for (triangle, corners) in triangles.iter().zip(&mut normals[first..first + count]) {
                let own = corners[0];
                for (corner, normal) in triangle.corners.iter().zip(corners) {
                    let sum: DVec3 = at[&corner.map(|x| (x + 0.0).to_bits())]
                        .iter()
                        .map(|&f| face(f))
                        .filter(|n| n.normalize_or_zero().dot(own) >= cos_crease)
                        .sum();
                    *normal = sum.try_normalize().unwrap_or(own);
                }
            }
        }
        Self { geometry, normals }
    }

    /// The corner normals of triangle `k` of the geometry.
    pub fn normals(&self, k: usize) -> [DVec3; 3] {
        self.normals[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hapticd_plugin_api::{HapticdSolid, HapticdTriangle};

    /// A solid of `triangles` in a geometry of its own.
    fn solid(triangles: Vec<[DVec3; 3]>) -> Geometry {
        let mut geometry = Geometry::default();
        let body = geometry.add_body();
        geometry.add_triangles(
            HapticdSolid {
                body,
                ..HapticdSolid::placed([0.0; 3], [1.0, 0.0, 0.0, 0.0])
            },
            triangles.into_iter().map(|t| HapticdTriangle {
                corners: t.map(|c| c.to_array()),
            }),
        );
        geometry
    }

    #[test]
    fn a_faceted_cylinder_is_round_and_a_boxs_edge_stays_sharp() {
        // Two faces of a 16-sided prism meeting at 22.5°: at their shared edge both take the
        // bisector, the radial direction there.
        let side = |k: f64| {
            DVec3::new(
                (k * 22.5f64).to_radians().cos(),
                0.0,
                -(k * 22.5f64).to_radians().sin(),
            )
        };
        let (a, b, c) = (side(0.0), side(1.0), side(2.0));
        let up = DVec3::Y;
        let prism = solid(vec![[a, b, b + up], [b, c, c + up]]);
        let shaded = Shaded::new(prism);
        let radial = side(1.0);
        assert!(
            shaded.normals(0)[1].distance(radial) < 1e-12,
            "{:?}",
            shaded.normals(0)
        );
        assert!(shaded.normals(1)[0].distance(radial) < 1e-12);
        // Two faces of a box at 90° (normals +z and +x): each keeps its own at the shared edge.
        let (o, x, z) = (DVec3::ZERO, DVec3::X, DVec3::Z);
        let edge = solid(vec![[o, x, x + up], [o, up, z]]);
        let shaded = Shaded::new(edge);
        for corner in shaded.normals(0) {
            assert!(corner.distance(DVec3::Z) < 1e-12, "{corner}");
        }
        for corner in shaded.normals(1) {
            assert!(corner.distance(DVec3::X) < 1e-12, "{corner}");
        }
    }
}

//! Normals for solids of triangles, worked out once a scene: where the faces of a mesh meet
//! at a shallow angle its curved surface is drawn smooth (each corner's normal the area-weighted
//! mean of the faces there that lie within [`CREASE`] of its own), while its edges stay sharp.

use std::collections::HashMap;

use glam::DVec3;
use hapticd_plugin_api::{
    Geometry, HAPTICD_SHAPE_TRIANGLES, HAPTICD_SOLID_DEFORMING, HapticdTriangle,
};

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
    /// Per deforming solid (by its place among the solids), which faces meet at each
    /// corner of each triangle, as it stood at load.
    deforming: Vec<(usize, Meeting)>,
}

impl Shaded {
    /// `geometry` with its triangles' normals: smooth within each solid, flat elsewhere.
    pub fn new(geometry: Geometry) -> Self {
        let face = |t: &HapticdTriangle| {
            let [a, b, c] = t.corners.map(DVec3::from);
            (b - a).cross(c - a)
        };
        let mut normals: Vec<[DVec3; 3]> = geometry
            .triangles
            .iter()
            .map(|t| [face(t).normalize_or_zero(); 3])
            .collect();
        let mut deforming = Vec::new();
        for (k, solid) in geometry.solids.iter().enumerate() {
            if solid.shape != HAPTICD_SHAPE_TRIANGLES {
                continue;
            }
            let first = solid.first_triangle as usize;
            let triangles = geometry.triangles_of(solid);
            let meeting = Meeting::new(triangles);
            let faces: Vec<DVec3> = triangles.iter().map(face).collect();
            normals[first..first + triangles.len()].copy_from_slice(&meeting.normals(&faces));
            if solid.flags & HAPTICD_SOLID_DEFORMING != 0 {
                deforming.push((k, meeting));
            }
        }
        Self {
            geometry,
            normals,
            deforming,
        }
    }

    /// The corner normals of triangle `k` of the geometry.
    pub fn normals(&self, k: usize) -> [DVec3; 3] {
        self.normals[k]
    }

    /// The corner normals of deforming solid `solid` (its place among the solids) with its
    /// triangles' corners at `corners`, three a triangle; None for a solid that does not
    /// deform or corners that are not its triangles'.
    pub fn deformed_normals(
        &self,
        solid: usize,
        corners: &[[DVec3; 3]],
    ) -> Option<Vec<[DVec3; 3]>> {
        let (_, meeting) = self.deforming.iter().find(|(k, _)| *k == solid)?;
        (meeting.corners.len() == corners.len()).then(|| {
            let faces: Vec<DVec3> = corners
                .iter()
                .map(|[a, b, c]| (*b - *a).cross(*c - *a))
                .collect();
            meeting.normals(&faces)
        })
    }
}

/// Which faces of a solid meet at each corner of each of its triangles: those with a
/// corner at the same point.
#[derive(Debug, Clone, Default, PartialEq)]
struct Meeting {
    /// Per triangle, per corner, its group in `groups`.
    corners: Vec<[u32; 3]>,
    /// The faces (by place in the solid) at each point.
    groups: Vec<Vec<u32>>,
}

impl Meeting {
    fn new(triangles: &[HapticdTriangle]) -> Self {
        let mut at: HashMap<[u64; 3], u32> = HashMap::new();
        let mut groups: Vec<Vec<u32>> = Vec::new();
        let corners = triangles
            .iter()
            .enumerate()
            .map(|(k, t)| {
                t.corners.map(|c| {
                    let group = *at.entry(c.map(|x| (x + 0.0).to_bits())).or_insert_with(|| {
                        groups.push(Vec::new());
                        groups.len() as u32 - 1
                    });
                    groups[group as usize].push(k as u32);
                    group
                })
            })
            .collect();
        Self { corners, groups }
    }

    /// Each corner's normal, given each face's area vector (`faces`, one per triangle): the
    /// mean of the faces meeting there within [`CREASE`] of its own face, by area.
    fn normals(&self, faces: &[DVec3]) -> Vec<[DVec3; 3]> {
        let cos_crease = CREASE.cos();
        self.corners
            .iter()
            .zip(faces)
            .map(|(groups, face)| {
                let own = face.normalize_or_zero();
                groups.map(|g| {
                    let sum: DVec3 = self.groups[g as usize]
                        .iter()
                        .map(|&f| faces[f as usize])
                        .filter(|n| n.normalize_or_zero().dot(own) >= cos_crease)
                        .sum();
                    sum.try_normalize().unwrap_or(own)
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hapticd_plugin_api::HapticdSolid;

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

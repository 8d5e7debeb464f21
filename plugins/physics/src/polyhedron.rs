//! Convex polyhedra: faces as counter-clockwise vertex loops (seen from outside), each with
//! its outward plane.

use glam::{DQuat, DVec3};

/// A plane n·x = d with unit outward normal n; the solid is where n·x ≤ d.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Outward unit normal.
    pub normal: DVec3,
    /// Offset along the normal.
    pub offset: f64,
}

impl Plane {
    /// Signed distance of `p` (positive outside).
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }
}

/// A convex polyhedron.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Polyhedron {
    /// Vertex positions.
    pub vertices: Vec<DVec3>,
    /// Faces: indices into `vertices`, counter-clockwise seen from outside.
    pub faces: Vec<Vec<usize>>,
    /// Outward plane of each face.
    pub planes: Vec<Plane>,
}

impl Polyhedron {
    /// An axis-aligned box centred at the origin with half edges `half`.
    pub fn cuboid(half: DVec3) -> Self {
        let vertices = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { -half.x } else { half.x },
                    if i & 2 == 0 { -half.y } else { half.y },
                    if i & 4 == 0 { -half.z } else { half.z },
                )
            })
            .collect();
        // Each face counter-clockwise seen from outside.
        let faces = vec![
            vec![0, 4, 6, 2], // −x
            vec![1, 3, 7, 5], // +x
            vec![0, 1, 5, 4], // −y
            vec![2, 6, 7, 3], // +y
            vec![0, 2, 3, 1], // −z
            vec![4, 5, 7, 6], // +z
        ];
        let mut p = Self {
            vertices,
            faces,
            planes: Vec::new(),
        };
        p.update_planes();
        p
    }

    /// The polyhedron bounded by `planes` (each n·x ≤ d), built by clipping a box of half edge
    /// `extent` that must contain it. Planes that cut nothing leave no face.
    pub fn from_planes(planes: &[Plane], extent: f64) -> Self {
        let mut p = Self::cuboid(DVec3::splat(extent));
        let mut clipper = super::clip::Clipper::default();
        for plane in planes {
            let mut out = Polyhedron::default();
            clipper.clip(&p, *plane, &mut out);
            p = out;
        }
        p
    }

    /// Recompute every face plane from its vertices (Newell's method, robust for any convex
    /// polygon).
    pub fn update_planes(&mut self) {
        self.planes.clear();
        for face in &self.faces {
            let (normal, centre) = newell(&self.vertices, face);
            self.planes.push(Plane {
                normal,
                offset: normal.dot(centre),
            });
        }
    }

    /// The polyhedron rotated by `rotation`, then moved by `translation`.
    pub fn transformed(&self, rotation: DQuat, translation: DVec3) -> Self {
        let mut p = self.clone();
        for v in &mut p.vertices {
            *v = rotation * *v + translation;
        }
        for plane in &mut p.planes {
            plane.normal = rotation * plane.normal;
            plane.offset += plane.normal.dot(translation);
        }
        p
    }

    /// Each triangle of the surface, fanned from its face's first vertex, counter-clockwise
    /// seen from outside.
    pub fn triangles(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        self.faces.iter().flat_map(move |face| {
            (1..face.len().saturating_sub(1)).map(move |k| {
                [
                    self.vertices[face[0]],
                    self.vertices[face[k]],
                    self.vertices[face[k + 1]],
                ]
            })
        })
    }

    /// Whether `p` is inside or on every face (within `tolerance`).
    pub fn contains(&self, p: DVec3, tolerance: f64) -> bool {
        self.planes
            .iter()
            .all(|plane| plane.distance(p) <= tolerance)
    }
}

/// Unit normal (Newell's method) and vertex centroid of the planar polygon `face` (indices
/// into `vertices`).
pub fn newell(vertices: &[DVec3], face: &[usize]) -> (DVec3, DVec3) {
    let mut normal = DVec3::ZERO;
    let mut centre = DVec3::ZERO;
    for (k, &i) in face.iter().enumerate() {
        let (a, b) = (vertices[i], vertices[face[(k + 1) % face.len()]]);
        normal += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
        centre += a;
    }
    (
        normal.normalize_or_zero(),
        centre / face.len().max(1) as f64,
    )
}

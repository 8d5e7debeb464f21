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

    /// Whether a face on this plane is turned toward `normal`.
    pub fn faces(&self, normal: DVec3) -> bool {
        self.normal.dot(normal) > 0.0
    }

    /// Whether a face on this plane is seen other than edge-on along `normal`: one seen
    /// edge-on has no area across the normal, and adds nothing to an integral over it.
    pub fn spans(&self, normal: DVec3) -> bool {
        self.normal.dot(normal).abs() > 1e-12
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
    /// The mean of the vertices: the centre of a box or of a ball's hull, which are
    /// symmetric (not the centroid of a general polyhedron, which the mass module gives).
    pub fn vertex_centre(&self) -> DVec3 {
        self.vertices.iter().copied().sum::<DVec3>() / self.vertices.len().max(1) as f64
    }

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

    /// The triangles of [`Polyhedron::triangles`] on the faces whose planes `keep` keeps,
    /// each corner mapped by `each`, which sees every vertex of a face once rather than once
    /// per triangle.
    pub fn fans<T: Copy>(
        &self,
        keep: impl Fn(&Plane) -> bool,
        each: impl Fn(DVec3) -> T,
        mut triangle: impl FnMut([T; 3]),
    ) {
        for (face, plane) in self.faces.iter().zip(&self.planes) {
            if !keep(plane) {
                continue;
            }
            let Some((&first, rest)) = face.split_first() else {
                continue;
            };
            let first = each(self.vertices[first]);
            let mut previous = None;
            for &k in rest {
                let next = each(self.vertices[k]);
                if let Some(previous) = previous {
                    triangle([first, previous, next]);
                }
                previous = Some(next);
            }
        }
    }

    /// The least width across the solid: over every face normal, the extent of the vertices
    /// along it (for a box, its shortest edge).
    pub fn thickness(&self) -> f64 {
        self.planes
            .iter()
            .map(|plane| {
                let along = self.vertices.iter().map(|v| plane.normal.dot(*v));
                let (lo, hi) = along.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                    (lo.min(d), hi.max(d))
                });
                hi - lo
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Area of the largest face: the largest patch a contact with a flat solid can have.
    pub fn largest_face_area(&self) -> f64 {
        self.faces
            .iter()
            .map(|face| {
                let v = |k: usize| self.vertices[face[k % face.len()]];
                (1..face.len().saturating_sub(1))
                    .map(|k| (v(k) - v(0)).cross(v(k + 1) - v(0)))
                    .sum::<DVec3>()
                    .length()
                    / 2.0
            })
            .fold(0.0, f64::max)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hull::HullError;
    use crate::mass::volume_and_centroid;

    #[test]
    fn the_hull_of_a_box_with_points_inside_is_the_box() {
        let half = DVec3::new(0.3, 0.2, 0.1);
        let shift = DVec3::new(1.0, -2.0, 0.5);
        let mut points: Vec<DVec3> = Polyhedron::cuboid(half)
            .vertices
            .iter()
            .map(|v| *v + shift)
            .collect();
        // Interior points and points on faces and edges add nothing.
        points.extend([shift, shift + DVec3::new(0.3, 0.0, 0.0), shift + half * 0.5]);
        points.extend([shift + DVec3::new(0.3, 0.2, 0.0)]);
        let hull = Polyhedron::hull(&points).unwrap();
        assert_eq!(hull.faces.len(), 6);
        assert_eq!(hull.vertices.len(), 8);
        let (volume, centroid) = volume_and_centroid(&hull);
        assert!(
            (volume - 8.0 * half.x * half.y * half.z).abs() < 1e-12,
            "{volume}"
        );
        assert!((centroid - shift).length() < 1e-12);
    }

    #[test]
    fn the_hull_holds_every_point_and_its_corners_are_points() {
        // Points on a sphere (all extreme) plus points inside it.
        let mut points = Vec::new();
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for k in 0..40 {
            let p = DVec3::new(next(), next(), next()).normalize();
            points.push(if k % 3 == 0 { p * 0.5 } else { p });
        }
        let hull = Polyhedron::hull(&points).unwrap();
        for p in &points {
            assert!(hull.contains(*p, 1e-9), "{p} outside");
        }
        for v in &hull.vertices {
            assert!(
                points.iter().any(|p| (*p - *v).length() < 1e-9),
                "{v} invented"
            );
        }
        // Euler's formula for a convex polyhedron.
        let edges: usize = hull.faces.iter().map(Vec::len).sum::<usize>() / 2;
        assert_eq!(hull.vertices.len() + hull.faces.len(), edges + 2);
    }

    #[test]
    fn flat_point_sets_are_refused() {
        let square = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::X + DVec3::Y];
        assert_eq!(Polyhedron::hull(&square).err(), Some(HullError::Flat));
        assert_eq!(
            Polyhedron::hull(&[DVec3::ZERO, DVec3::NAN, DVec3::X, DVec3::Z]).err(),
            Some(HullError::NotFinite)
        );
    }
}

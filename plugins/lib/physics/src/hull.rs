//! Polyhedra built from planes and from points: the region bounded by a set of planes
//! (clipping a large box), and the convex hull of a point set (the planes through three
//! points with all others on one side).

use glam::{DQuat, DVec3};

use crate::clip::Clipper;
use crate::polyhedron::{Plane, Polyhedron};

impl Polyhedron {
    /// The polyhedron bounded by `planes` (each n·x ≤ d), built by clipping a box of half edge
    /// `extent` that must contain it. Planes that cut nothing leave no face.
    pub fn from_planes(planes: &[Plane], extent: f64) -> Self {
        let mut p = Self::cuboid(DVec3::splat(extent));
        let mut clipper = Clipper::default();
        for plane in planes {
            let mut out = Polyhedron::default();
            clipper.clip(&p, *plane, &mut out);
            p = out;
        }
        p
    }

    /// The convex hull of `points`: bounded by every plane through three of them that has all
    /// the others on one side (coplanar faces merge into one). Cubic in the number of points,
    /// which suits the tens of vertices a scene file gives. An error when the points span no
    /// volume.
    pub fn hull(points: &[DVec3]) -> Result<Self, String> {
        if points.iter().any(|p| !p.is_finite()) {
            return Err("hull vertices must be finite".into());
        }
        let centre = points.iter().copied().sum::<DVec3>() / points.len().max(1) as f64;
        let radius = points
            .iter()
            .map(|p| (*p - centre).length())
            .fold(0.0, f64::max);
        let tolerance = 1e-9 * radius;
        let mut planes: Vec<Plane> = Vec::new();
        for (i, &a) in points.iter().enumerate() {
            for (j, &b) in points.iter().enumerate().skip(i + 1) {
                for &c in &points[j + 1..] {
                    let normal = (b - a).cross(c - a);
                    if normal.length() <= tolerance * radius {
                        continue;
                    }
                    let normal = normal.normalize();
                    let side = |p: &DVec3| normal.dot(*p - a);
                    let plane = if points.iter().all(|p| side(p) <= tolerance) {
                        Plane {
                            normal,
                            offset: normal.dot(a),
                        }
                    } else if points.iter().all(|p| side(p) >= -tolerance) {
                        Plane {
                            normal: -normal,
                            offset: -normal.dot(a),
                        }
                    } else {
                        continue;
                    };
                    let known = planes.iter().any(|q| {
                        q.normal.dot(plane.normal) > 1.0 - 1e-12
                            && (q.offset - plane.offset).abs() <= tolerance
                    });
                    if !known {
                        planes.push(plane);
                    }
                }
            }
        }
        if planes.len() < 4 {
            return Err("hull vertices must not all lie in one plane".into());
        }
        let shifted: Vec<Plane> = planes
            .iter()
            .map(|q| Plane {
                normal: q.normal,
                offset: q.offset - q.normal.dot(centre),
            })
            .collect();
        let hull = Self::from_planes(&shifted, 2.0 * radius);
        Ok(hull.transformed(DQuat::IDENTITY, centre))
    }
}

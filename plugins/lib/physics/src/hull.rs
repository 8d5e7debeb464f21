//! Polyhedra built from planes and from points: the region bounded by a set of planes
//! (clipping a large box), and the convex hull of a point set (the planes through three
//! points with all others on one side).

use glam::{DQuat, DVec3};

use crate::clip::Clipper;
use crate::polyhedron::{Plane, Polyhedron};

/// Why points make no convex solid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HullError {
    /// A point is not finite.
    NotFinite,
    /// They all lie in one plane (or on a line, or at one point).
    Flat,
    /// A triangle names a vertex the piece does not have.
    NoSuchVertex,
}

impl std::fmt::Display for HullError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            HullError::NotFinite => "hull vertices must be finite",
            HullError::Flat => "hull vertices must not all lie in one plane",
            HullError::NoSuchVertex => "a triangle names a vertex the piece lacks",
        })
    }
}

impl std::error::Error for HullError {}

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
    pub fn hull(points: &[DVec3]) -> Result<Self, HullError> {
        let (centre, radius) = spread(points)?;
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
                    push_new(&mut planes, plane, tolerance);
                }
            }
        }
        Self::bounded_by(&planes, centre, radius)
    }

    /// The convex solid whose surface is `triangles` over `vertices` (a convex piece of a
    /// mesh): bounded by the triangles' planes, those of one face merged. Linear in the
    /// triangles, for pieces of hundreds of points. An error when they span no volume.
    pub fn of_convex_surface(
        vertices: &[DVec3],
        triangles: &[[u32; 3]],
    ) -> Result<Self, HullError> {
        let (centre, radius) = spread(vertices)?;
        let mut planes: Vec<Plane> = Vec::new();
        for t in triangles {
            let [a, b, c] = t.map(|k| vertices.get(k as usize).copied());
            let (Some(a), Some(b), Some(c)) = (a, b, c) else {
                return Err(HullError::NoSuchVertex);
            };
            let normal = (b - a).cross(c - a);
            if normal.length() <= 1e-18 * radius * radius {
                continue;
            }
            // Outwards, whichever way the triangle winds: away from the piece's centre.
            let normal = normal.normalize() * normal.dot(a - centre).signum();
            push_new(
                &mut planes,
                Plane {
                    normal,
                    offset: normal.dot(a),
                },
                1e-9 * radius,
            );
        }
        Self::bounded_by(&planes, centre, radius)
    }

    /// The solid of `planes` around `centre`, within `radius` of it.
    fn bounded_by(planes: &[Plane], centre: DVec3, radius: f64) -> Result<Self, HullError> {
        if planes.len() < 4 {
            return Err(HullError::Flat);
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

    /// A ball of `radius` about the origin as the hull of a geodesic sphere (the icosahedron
    /// with its edges halved: 42 vertices, 80 faces), blown up until its volume is the ball's.
    /// Its mass is then exact and its inertia within 1 % of the ball's; its surface departs
    /// from the sphere by at most 4 % of the radius.
    pub fn ball(radius: f64) -> Self {
        let phi = (1.0 + 5f64.sqrt()) / 2.0;
        let mut points = Vec::with_capacity(42);
        for (a, b) in [(1.0, phi), (1.0, -phi), (-1.0, phi), (-1.0, -phi)] {
            points.push(DVec3::new(0.0, a, b));
            points.push(DVec3::new(a, b, 0.0));
            points.push(DVec3::new(b, 0.0, a));
        }
        // Edges of this icosahedron are 2 long; their midpoints lifted to the sphere.
        for i in 0..12 {
            for j in i + 1..12 {
                if ((points[i] - points[j]).length() - 2.0).abs() < 1e-9 {
                    points.push((points[i] + points[j]) / 2.0);
                }
            }
        }
        let unit: Vec<DVec3> = points.iter().map(|p| p.normalize()).collect();
        let hull = Self::hull(&unit).expect("a geodesic sphere spans a volume");
        let (volume, _) = crate::mass::volume_and_centroid(&hull);
        let scale = radius * (4.0 / 3.0 * std::f64::consts::PI / volume).cbrt();
        let points: Vec<DVec3> = unit.iter().map(|p| *p * scale).collect();
        Self::hull(&points).expect("a geodesic sphere spans a volume")
    }
}

/// The mean of `points` and their greatest distance from it; an error when one is not
/// finite.
fn spread(points: &[DVec3]) -> Result<(DVec3, f64), HullError> {
    if points.iter().any(|p| !p.is_finite()) {
        return Err(HullError::NotFinite);
    }
    let centre = points.iter().copied().sum::<DVec3>() / points.len().max(1) as f64;
    let radius = points
        .iter()
        .map(|p| (*p - centre).length())
        .fold(0.0, f64::max);
    Ok((centre, radius))
}

/// Add `plane` to `planes` unless one of them is the same within `tolerance`.
fn push_new(planes: &mut Vec<Plane>, plane: Plane, tolerance: f64) {
    let known = planes.iter().any(|q| {
        q.normal.dot(plane.normal) > 1.0 - 1e-12 && (q.offset - plane.offset).abs() <= tolerance
    });
    if !known {
        planes.push(plane);
    }
}

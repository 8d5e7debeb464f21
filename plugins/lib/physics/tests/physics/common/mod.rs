//! Shared by the physics tests: reproducible random solids and an independent reference for
//! the volume and centroid of a convex polyhedron given by its planes.

use glam::DVec3;
use hapticd_physics::polyhedron::{Plane, Polyhedron};

// Shared with the end-to-end tests, which use the rest of it.
#[allow(dead_code)]
#[path = "../../../../../../tests/support/rng.rs"]
mod rng;
pub use rng::Rng;

/// Volume and centroid of {x : every plane}, by vertex enumeration.
pub fn reference(planes: &[Plane]) -> (f64, DVec3) {
    let mut vertices: Vec<DVec3> = Vec::new();
    let n = planes.len();
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let (a, b, c) = (planes[i], planes[j], planes[k]);
                let det = a.normal.dot(b.normal.cross(c.normal));
                if det.abs() < 1e-12 {
                    continue;
                }
                let x = (a.offset * b.normal.cross(c.normal)
                    + b.offset * c.normal.cross(a.normal)
                    + c.offset * a.normal.cross(b.normal))
                    / det;
                if planes.iter().all(|p| p.distance(x) <= 1e-9)
                    && vertices.iter().all(|v| (*v - x).length() > 1e-9)
                {
                    vertices.push(x);
                }
            }
        }
    }
    if vertices.len() < 4 {
        return (0.0, DVec3::ZERO);
    }
    let inside = vertices.iter().sum::<DVec3>() / vertices.len() as f64;
    let (mut volume, mut moment) = (0.0, DVec3::ZERO);
    for plane in planes {
        let on: Vec<DVec3> = vertices
            .iter()
            .copied()
            .filter(|v| plane.distance(*v).abs() < 1e-9)
            .collect();
        if on.len() < 3 {
            continue;
        }
        let centre = on.iter().sum::<DVec3>() / on.len() as f64;
        let u = plane.normal.any_orthonormal_vector();
        let w = plane.normal.cross(u);
        let mut ordered = on.clone();
        ordered.sort_by(|p, q| {
            let angle = |v: &DVec3| (*v - centre).dot(w).atan2((*v - centre).dot(u));
            angle(p).total_cmp(&angle(q))
        });
        for t in 0..ordered.len() {
            let (b, c) = (ordered[t], ordered[(t + 1) % ordered.len()]);
            let v = ((centre - inside).dot((b - inside).cross(c - inside)) / 6.0).abs();
            volume += v;
            moment += v * (inside + centre + b + c) / 4.0;
        }
    }
    (volume, moment / volume)
}

/// A convex polyhedron around `centre`: `count` random tangent planes of a ball of radius
/// `radius`, trimmed by a box.
pub fn random_polyhedron(rng: &mut Rng, centre: DVec3, radius: f64, count: usize) -> Polyhedron {
    let planes: Vec<Plane> = (0..count)
        .map(|_| {
            let normal = rng.unit();
            Plane {
                normal,
                offset: normal.dot(centre) + radius,
            }
        })
        .collect();
    Polyhedron::from_planes(&planes, 10.0)
}

/// Whether `a` and `b` agree to `relative`.
pub fn close(a: f64, b: f64, relative: f64) -> bool {
    (a - b).abs() <= relative * a.abs().max(b.abs()).max(1e-300)
}

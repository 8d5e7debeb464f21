//! A ball as a mesh of many triangles (latitude rings and longitude segments): the large mesh
//! the proxy's tests and benchmarks touch, with the exact sphere to compare against.

use glam::DVec3;
use hapticd_core::haptics::obstacle::Shape;

/// The faces of a ball of `radius` at `centre` with `rings` × `segments` quads (two
/// triangles each, one at each pole), counter-clockwise from outside: 2·rings·segments less
/// 2·segments triangles.
pub fn ball_faces(centre: DVec3, radius: f64, rings: usize, segments: usize) -> Vec<Shape> {
    let at = |ring: usize, segment: usize| {
        // The bottom pole exactly at the pole, as the top one is (sin π rounds to 1e-16):
        // its faces then have no area and are left out, instead of slivers of rounding.
        let (sin, cos) = match ring {
            r if r == rings => (0.0, -1.0),
            r => (std::f64::consts::PI * r as f64 / rings as f64).sin_cos(),
        };
        let around = std::f64::consts::TAU * segment as f64 / segments as f64;
        centre + radius * DVec3::new(sin * around.cos(), cos, sin * around.sin())
    };
    // Each wound to face away from the centre; those at a pole have no area and are left out.
    let face = |p: DVec3, q: DVec3, r: DVec3| {
        if (q - p).cross(r - p).dot(p + q + r - 3.0 * centre) >= 0.0 {
            Shape::triangle(p, q, r)
        } else {
            Shape::triangle(p, r, q)
        }
    };
    let mut faces = Vec::with_capacity(2 * rings * segments);
    for ring in 0..rings {
        for segment in 0..segments {
            let next = (segment + 1) % segments;
            let (a, b) = (at(ring, segment), at(ring, next));
            let (c, d) = (at(ring + 1, next), at(ring + 1, segment));
            faces.extend(face(a, b, c));
            faces.extend(face(a, c, d));
        }
    }
    faces
}

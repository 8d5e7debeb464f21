//! Mass properties of a closed polyhedron, by the divergence theorem: every face is fanned
//! into triangles, each triangle with a reference point makes a signed tetrahedron.

use glam::DVec3;

use super::polyhedron::Polyhedron;

/// Volume and centroid of `p` (zero volume and its first vertex for an empty or flat one).
pub fn volume_and_centroid(p: &Polyhedron) -> (f64, DVec3) {
    let Some(&origin) = p.vertices.first() else {
        return (0.0, DVec3::ZERO);
    };
    let (mut six_volume, mut moment) = (0.0, DVec3::ZERO);
    for face in &p.faces {
        let a = p.vertices[face[0]] - origin;
        for k in 1..face.len().saturating_sub(1) {
            let (b, c) = (
                p.vertices[face[k]] - origin,
                p.vertices[face[k + 1]] - origin,
            );
            let det = a.dot(b.cross(c));
            six_volume += det;
            moment += det * (a + b + c);
        }
    }
    if six_volume.abs() < 1e-300 {
        return (0.0, origin);
    }
    (six_volume / 6.0, origin + moment / (4.0 * six_volume))
}

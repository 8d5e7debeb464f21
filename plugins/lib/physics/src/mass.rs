//! Mass properties of a closed polyhedron, by the divergence theorem: every face is fanned
//! into triangles, each triangle with a reference point makes a signed tetrahedron.

use glam::{DMat3, DVec3};

use super::polyhedron::Polyhedron;

/// Volume and centroid of `p` (zero volume and its first vertex for an empty or flat one).
pub fn volume_and_centroid(p: &Polyhedron) -> (f64, DVec3) {
    let Some(&origin) = p.vertices.first() else {
        return (0.0, DVec3::ZERO);
    };
    let (mut six_volume, mut moment) = (0.0, DVec3::ZERO);
    for [a, b, c] in p.triangles().map(|t| t.map(|v| v - origin)) {
        let det = a.dot(b.cross(c));
        six_volume += det;
        moment += det * (a + b + c);
    }
    if six_volume.abs() < 1e-300 {
        return (0.0, origin);
    }
    (six_volume / 6.0, origin + moment / (4.0 * six_volume))
}

/// Volume, centroid, and inertia tensor about the centroid of `p` at unit density.
///
/// Each face triangle with the first vertex makes a tetrahedron whose second moments have a
/// closed form (the canonical covariance det/120 · A·J·Aᵀ, J = [[2,1,1],[1,2,1],[1,1,2]]).
pub fn mass_properties(p: &Polyhedron) -> (f64, DVec3, DMat3) {
    let (volume, centroid) = volume_and_centroid(p);
    let Some(&origin) = p.vertices.first() else {
        return (0.0, DVec3::ZERO, DMat3::ZERO);
    };
    let mut covariance = DMat3::ZERO;
    let j = DMat3::from_cols(
        DVec3::new(2.0, 1.0, 1.0),
        DVec3::new(1.0, 2.0, 1.0),
        DVec3::new(1.0, 1.0, 2.0),
    );
    for [a, b, c] in p.triangles().map(|t| t.map(|v| v - origin)) {
        let det = a.dot(b.cross(c));
        let m = DMat3::from_cols(a, b, c);
        covariance += m * j * m.transpose() * (det / 120.0);
    }
    // Move the second moments from the reference vertex to the centroid.
    let r = centroid - origin;
    let outer = DMat3::from_cols(r * r.x, r * r.y, r * r.z);
    let covariance = covariance - outer * volume;
    let inertia = DMat3::from_diagonal(DVec3::splat(
        covariance.x_axis.x + covariance.y_axis.y + covariance.z_axis.z,
    )) - covariance;
    (volume, centroid, inertia)
}

/// `inertia` about a body's centre moved to a point `offset` from it (parallel axes), the
/// body of `mass`.
pub fn moved_inertia(inertia: DMat3, mass: f64, offset: DVec3) -> DMat3 {
    inertia
        + (DMat3::from_diagonal(DVec3::splat(offset.length_squared()))
            - DMat3::from_cols(offset * offset.x, offset * offset.y, offset * offset.z))
            * mass
}

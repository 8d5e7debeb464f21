//! What a mesh is as a solid: whether its surface is closed (every edge shared by exactly
//! two triangles that run along it in opposite directions), and the volume, centre and
//! inertia it encloses, by the divergence theorem over its triangles (exact for any closed
//! polyhedron: each triangle and the origin span a tetrahedron, signed by its winding).

use std::collections::HashMap;

use glam::{DMat3, DVec3};

use crate::TriangleMesh;

/// How the surface is joined along its edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Closure {
    /// Edges only one triangle has: the rims of holes.
    pub open_edges: usize,
    /// Edges more than two triangles share, or two that run the same way (a flipped face).
    pub bad_edges: usize,
}

impl Closure {
    /// Whether the surface bounds a solid.
    pub fn is_closed(&self) -> bool {
        self.open_edges == 0 && self.bad_edges == 0
    }
}

/// The surface's edges, counted.
pub fn closure(mesh: &TriangleMesh) -> Closure {
    // For each undirected edge: how often it runs low→high and high→low.
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for t in &mesh.triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let entry = edges.entry((a.min(b), a.max(b))).or_default();
            if a < b {
                entry.0 += 1;
            } else {
                entry.1 += 1;
            }
        }
    }
    let mut closure = Closure {
        open_edges: 0,
        bad_edges: 0,
    };
    for &(up, down) in edges.values() {
        match (up, down) {
            (1, 1) => {}
            (1, 0) | (0, 1) => closure.open_edges += 1,
            _ => closure.bad_edges += 1,
        }
    }
    closure
}

/// Whether the closed surface `mesh` bounds a convex solid: convex along every edge (each
/// neighbour's far corner on or behind a triangle's plane) and filling its convex hull
/// (which a surface of several convex parts, or one that winds round twice, does not).
/// Lengths are compared at a billionth of the mesh's size.
pub fn is_convex(mesh: &TriangleMesh) -> bool {
    if !closure(mesh).is_closed() {
        return false;
    }
    let (low, high) = mesh.bounds();
    let tolerance = 1e-9 * (high - low).max_element();
    // Each directed edge's triangle; the edge run the other way belongs to its neighbour.
    let mut across: HashMap<(u32, u32), usize> = HashMap::new();
    for (k, t) in mesh.triangles.iter().enumerate() {
        for i in 0..3 {
            across.insert((t[i], t[(i + 1) % 3]), k);
        }
    }
    let v = |k: u32| mesh.vertices[k as usize];
    for t in &mesh.triangles {
        let normal = (v(t[1]) - v(t[0])).cross(v(t[2]) - v(t[0]));
        if normal.length() <= 0.0 {
            continue;
        }
        let normal = normal.normalize();
        for i in 0..3 {
            let Some(&other) = across.get(&(t[(i + 1) % 3], t[i])) else {
                return false;
            };
            let far = mesh.triangles[other]
                .iter()
                .find(|&&c| c != t[i] && c != t[(i + 1) % 3]);
            if far.is_some_and(|&c| normal.dot(v(c) - v(t[0])) > tolerance) {
                return false;
            }
        }
    }
    let hull = convex_hull(mesh);
    let volume = mass_properties(mesh).volume;
    volume > 0.0 && mass_properties(&hull).volume <= volume * (1.0 + 1e-6)
}

/// The convex hull of `mesh`'s vertices, computed in single precision about their centre.
fn convex_hull(mesh: &TriangleMesh) -> TriangleMesh {
    let (low, high) = mesh.bounds();
    let centre = (low + high) / 2.0;
    let points: Vec<parry3d::math::Vector> = mesh
        .vertices
        .iter()
        .map(|v| {
            let p = (*v - centre).as_vec3();
            parry3d::math::Vector::new(p.x, p.y, p.z)
        })
        .collect();
    let (vertices, triangles) = parry3d::transformation::convex_hull(&points);
    TriangleMesh {
        vertices: vertices
            .iter()
            .map(|p| DVec3::new(f64::from(p.x), f64::from(p.y), f64::from(p.z)) + centre)
            .collect(),
        triangles,
        normals: None,
    }
}

/// A solid's mass properties at unit density: volume, centre, and inertia about the centre
/// (kg·m² per kg/m³).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// Volume, m³ (negative if the triangles face inwards).
    pub volume: f64,
    /// Centre of volume, metres.
    pub centre: DVec3,
    /// Inertia tensor about the centre, at density 1.
    pub inertia: DMat3,
}

/// The mass properties of the solid `mesh` bounds (meaningful when it is closed).
pub fn mass_properties(mesh: &TriangleMesh) -> MassProperties {
    // Second moments ∫x xᵀ dV of the tetrahedron (0, a, b, c): det · A·S·Aᵀ with A = [a b c]
    // and S the unit tetrahedron's ([[2,1,1],[1,2,1],[1,1,2]] / 120).
    let s = DMat3::from_cols_array(&[2.0, 1.0, 1.0, 1.0, 2.0, 1.0, 1.0, 1.0, 2.0]) / 120.0;
    let (mut volume, mut first, mut second) = (0.0, DVec3::ZERO, DMat3::ZERO);
    for [a, b, c] in mesh.corners() {
        let det = a.dot(b.cross(c));
        volume += det / 6.0;
        first += det / 24.0 * (a + b + c);
        let m = DMat3::from_cols(a, b, c);
        second += m * s * m.transpose() * det;
    }
    let centre = if volume != 0.0 {
        first / volume
    } else {
        DVec3::ZERO
    };
    // About the centre, then from second moments to inertia: I = tr(C)·1 − C.
    let about = second - outer(centre, centre) * volume;
    let trace = about.x_axis.x + about.y_axis.y + about.z_axis.z;
    MassProperties {
        volume,
        centre,
        inertia: DMat3::from_diagonal(DVec3::splat(trace)) - about,
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The box `low..high` as twelve triangles facing out.
pub(crate) fn cuboid(low: DVec3, high: DVec3) -> TriangleMesh {
    let corner = |k: u32| {
        DVec3::new(
            if k & 1 == 0 { low.x } else { high.x },
            if k & 2 == 0 { low.y } else { high.y },
            if k & 4 == 0 { low.z } else { high.z },
        )
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    TriangleMesh {
        vertices: (0..8).map(corner).collect(),
        triangles: quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect(),
        normals: None,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn a_box_has_the_volume_centre_and_inertia_of_the_formulas() {
        let (low, high) = (DVec3::new(0.3, -1.0, 2.0), DVec3::new(1.5, 0.5, 2.4));
        let mesh = cuboid(low, high);
        assert!(closure(&mesh).is_closed());
        let p = mass_properties(&mesh);
        let size = high - low;
        let volume = size.x * size.y * size.z;
        assert!((p.volume - volume).abs() < 1e-12, "{}", p.volume);
        assert!((p.centre - (low + high) / 2.0).length() < 1e-12);
        // A box's inertia per unit density: V·(b² + c²)/12 about each axis, no products.
        let expected = DMat3::from_diagonal(
            DVec3::new(
                size.y * size.y + size.z * size.z,
                size.x * size.x + size.z * size.z,
                size.x * size.x + size.y * size.y,
            ) * volume
                / 12.0,
        );
        let worst = (p.inertia - expected)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(worst < 1e-12, "{:?}", p.inertia);
    }

    #[test]
    fn holes_and_flipped_faces_are_counted() {
        let mut mesh = cuboid(DVec3::ZERO, DVec3::ONE);
        mesh.triangles.pop();
        assert_eq!(
            closure(&mesh),
            Closure {
                open_edges: 3,
                bad_edges: 0
            }
        );
        let mut mesh = cuboid(DVec3::ZERO, DVec3::ONE);
        mesh.triangles[0].swap(1, 2);
        assert!(closure(&mesh).bad_edges > 0);
        // Turned inside out, the volume says so.
        let mut mesh = cuboid(DVec3::ZERO, DVec3::ONE);
        mesh.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        assert!((mass_properties(&mesh).volume + 1.0).abs() < 1e-12);
    }
}

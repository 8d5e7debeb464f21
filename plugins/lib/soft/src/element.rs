//! What one tetrahedron contributes: the gradients of its shape functions at its quadrature
//! points, from its corners' barycentric gradients (its edges are straight, so these are
//! all it needs), and its nodes' shares of its mass.
//!
//! A quadratic element's nodes are its four corners, then the middles of its edges in the
//! order of [`EDGES`].

use glam::DVec3;

/// The edges of a tetrahedron, by corner: a quadratic element's nodes 4 to 9 are their
/// middles, in this order.
pub const EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)];

/// The most nodes an element has.
pub const MOST_NODES: usize = 10;

/// The degree of an element's shape functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// Four nodes, constant strain: cheap, but locks in bending (a cantilever of four
    /// elements through its depth sags 0.79 of its sag).
    Linear,
    /// Ten nodes, linear strain: bends as a beam does.
    Quadratic,
}

/// The 4-point rule exact for quadratics: each point's barycentric coordinates are a
/// permutation of (A, B, B, B), each of weight ¼.
const A: f64 = 0.585_410_196_624_968_5;
const B: f64 = 0.138_196_601_125_010_5;

impl Order {
    /// Nodes per element.
    pub fn nodes(self) -> usize {
        match self {
            Order::Linear => 4,
            Order::Quadratic => 10,
        }
    }

    /// The quadrature points (barycentric coordinates) and weights (shares of the volume)
    /// that integrate the element's stiffness exactly.
    pub fn quadrature(self) -> &'static [([f64; 4], f64)] {
        match self {
            Order::Linear => &[([0.25; 4], 1.0)],
            Order::Quadratic => &[
                ([A, B, B, B], 0.25),
                ([B, A, B, B], 0.25),
                ([B, B, A, B], 0.25),
                ([B, B, B, A], 0.25),
            ],
        }
    }

    /// The gradients of the element's shape functions at barycentric point `at`, from its
    /// corners' barycentric gradients `corners`, into `out` (its first [`Order::nodes`]).
    pub fn gradients(self, corners: &[DVec3; 4], at: &[f64; 4], out: &mut [DVec3; MOST_NODES]) {
        match self {
            Order::Linear => out[..4].copy_from_slice(corners),
            Order::Quadratic => {
                for k in 0..4 {
                    out[k] = corners[k] * (4.0 * at[k] - 1.0);
                }
                for (e, &(i, j)) in EDGES.iter().enumerate() {
                    out[4 + e] = (corners[j] * at[i] + corners[i] * at[j]) * 4.0;
                }
            }
        }
    }

    /// Node `k`'s share of the element's mass, lumped: a quarter each for a linear element;
    /// for a quadratic one, in proportion to the diagonal of its consistent mass (a corner
    /// 1/36, an edge's middle 4/27), as its shape functions' integrals (a corner's is 0)
    /// would starve the corners.
    pub fn mass_share(self, k: usize) -> f64 {
        match (self, k) {
            (Order::Linear, _) => 0.25,
            (Order::Quadratic, 0..4) => 1.0 / 36.0,
            (Order::Quadratic, _) => 4.0 / 27.0,
        }
    }
}

/// The signed volume of the tetrahedron `corners`: positive where they turn positively.
pub fn signed_volume(corners: [DVec3; 4]) -> f64 {
    let [a, b, c, d] = corners;
    (b - a).dot((c - a).cross(d - a)) / 6.0
}

/// The barycentric gradients of the tetrahedron `corners` and its signed volume.
pub fn barycentric_gradients(corners: [DVec3; 4]) -> ([DVec3; 4], f64) {
    let (e1, e2, e3) = (
        corners[1] - corners[0],
        corners[2] - corners[0],
        corners[3] - corners[0],
    );
    let six = e1.dot(e2.cross(e3));
    // ∇λ₁ = (e2 × e3)/6V and so on; λ₀ = 1 − λ₁ − λ₂ − λ₃.
    let g1 = e2.cross(e3) / six;
    let g2 = e3.cross(e1) / six;
    let g3 = e1.cross(e2) / six;
    ([-(g1 + g2 + g3), g1, g2, g3], six / 6.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A field the shape functions reproduce exactly has the right gradient at every
    /// quadrature point: a linear field for both orders, a quadratic one for quadratic
    /// elements; and the mass shares sum to one.
    #[test]
    fn shape_functions_reproduce_their_fields_gradients() {
        let corners = [
            DVec3::new(0.1, -0.2, 0.3),
            DVec3::new(1.2, 0.1, 0.2),
            DVec3::new(0.3, 0.9, -0.1),
            DVec3::new(0.2, 0.3, 1.1),
        ];
        let (g, volume) = barycentric_gradients(corners);
        assert!(volume > 0.0);
        let mut nodes = corners.to_vec();
        nodes.extend(EDGES.iter().map(|&(i, j)| (corners[i] + corners[j]) / 2.0));
        let field = |p: DVec3| 0.7 * p.x * p.x - 0.3 * p.y * p.z + 0.2 * p.x + 1.0;
        let exact = |p: DVec3| DVec3::new(1.4 * p.x + 0.2, -0.3 * p.z, -0.3 * p.y);
        let linear = |p: DVec3| 2.0 * p.x - p.y + 0.5 * p.z;
        for order in [Order::Linear, Order::Quadratic] {
            let total: f64 = (0..order.nodes()).map(|k| order.mass_share(k)).sum();
            assert!((total - 1.0).abs() < 1e-12);
            for (at, _) in order.quadrature() {
                let mut grads = [DVec3::ZERO; MOST_NODES];
                order.gradients(&g, at, &mut grads);
                let point: DVec3 = (0..4).map(|k| corners[k] * at[k]).sum();
                let of = |f: &dyn Fn(DVec3) -> f64| -> DVec3 {
                    (0..order.nodes()).map(|k| grads[k] * f(nodes[k])).sum()
                };
                assert!((of(&linear) - DVec3::new(2.0, -1.0, 0.5)).length() < 1e-12);
                if order == Order::Quadratic {
                    assert!((of(&field) - exact(point)).length() < 1e-12);
                }
            }
        }
    }
}

//! A closed mesh asked about points: whether it holds one, and the point of its surface
//! nearest one. What cutting a mesh into tetrahedra needs (a soft body of a user's mesh):
//! thousands of questions against up to hundreds of thousands of triangles, so the triangles
//! are sorted once into a grid of cells and each question looks only at the cells it must.
//!
//! Whether a point is inside is counted along three rays, one along each axis: a ray that
//! grazes an edge or a corner may count a crossing twice or not at all, but it takes two
//! such rays to outvote the third.

use glam::DVec3;

use crate::TriangleMesh;

/// Most cells along the grid's longest side.
const MOST_CELLS: f64 = 64.0;

/// A closed surface's triangles, sorted into the cells of a grid over its bounds.
#[derive(Debug, Clone)]
pub struct Enclosure {
    corners: Vec<[DVec3; 3]>,
    /// The surface's bounds: its lowest and highest corner, m (the grid's lowest corner is
    /// the first).
    low: DVec3,
    high: DVec3,
    /// A cell's side, m.
    cell: f64,
    /// Cells along each axis.
    cells: [usize; 3],
    /// Each cell's triangles: those whose bounds meet it.
    bins: Vec<Vec<u32>>,
}

impl Enclosure {
    /// The enclosure of `mesh`, which must be closed and turned outward (as
    /// [`solid`](crate::solid) checks).
    pub fn new(mesh: &TriangleMesh) -> Enclosure {
        let corners: Vec<[DVec3; 3]> = mesh.corners().collect();
        let (low, high) = mesh.bounds();
        let size = (high - low).max(DVec3::splat(1e-12));
        // About two triangles a cell where the surface passes: a cube root of the count
        // along a side, at least one cell and at most MOST_CELLS.
        let along = (corners.len() as f64).cbrt().clamp(1.0, MOST_CELLS);
        let cell = size.max_element() / along;
        let cells = (size / cell).ceil().max(DVec3::ONE);
        let cells = [cells.x as usize, cells.y as usize, cells.z as usize];
        let mut enclosure = Enclosure {
            corners: Vec::new(),
            low,
            high,
            cell,
            cells,
            bins: vec![Vec::new(); cells[0] * cells[1] * cells[2]],
        };
        for (t, c) in corners.iter().enumerate() {
            let from = enclosure.cell_of(c[0].min(c[1]).min(c[2]));
            let to = enclosure.cell_of(c[0].max(c[1]).max(c[2]));
            for k in from[2]..=to[2] {
                for j in from[1]..=to[1] {
                    for i in from[0]..=to[0] {
                        let bin = enclosure.bin([i, j, k]);
                        enclosure.bins[bin].push(t as u32);
                    }
                }
            }
        }
        enclosure.corners = corners;
        enclosure
    }

    /// The smallest axis-aligned box holding the surface: lowest and highest corner.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.low, self.high)
    }

    /// Whether `x` is inside the surface: what at least two of the rays from it along +x,
    /// +y and +z say, each inside when it crosses the surface an odd number of times.
    pub fn contains(&self, x: DVec3) -> bool {
        (0..3)
            .filter(|&axis| self.crossings(x, axis) % 2 == 1)
            .count()
            >= 2
    }

    /// The point of the surface nearest `x`.
    pub fn nearest(&self, x: DVec3) -> DVec3 {
        let centre = self.cell_of(x);
        let (mut best, mut distance) = (x, f64::INFINITY);
        let rings = self.cells.iter().max().copied().unwrap_or(1);
        for ring in 0..=rings {
            // Every cell this ring out or further is at least `ring − 1` cells away.
            if distance <= ring.saturating_sub(1) as f64 * self.cell {
                break;
            }
            for bin in self.ring(centre, ring) {
                for &t in &self.bins[bin] {
                    let p = crate::triangle::nearest_point(x, self.corners[t as usize]);
                    let d = p.distance(x);
                    if d < distance {
                        (best, distance) = (p, d);
                    }
                }
            }
        }
        best
    }

    /// The times the ray from `x` along +`axis` crosses the surface: each crossing counted
    /// in the one cell it falls in.
    fn crossings(&self, x: DVec3, axis: usize) -> usize {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let start = self.cell_of(x);
        let mut count = 0;
        for step in start[axis]..self.cells[axis] {
            let mut at = start;
            at[axis] = step;
            let (from, to) = (
                self.low[axis] + step as f64 * self.cell,
                self.low[axis] + (step + 1) as f64 * self.cell,
            );
            let last = step + 1 == self.cells[axis];
            for &t in &self.bins[self.bin(at)] {
                let c = self.corners[t as usize];
                if let Some(hit) = crossing(x, c, axis, u, v)
                    && hit > x[axis]
                    && hit >= from
                    && (hit < to || last)
                {
                    count += 1;
                }
            }
        }
        count
    }

    /// The cells `ring` cells from `centre` (in the largest of the three directions),
    /// within the grid.
    fn ring(&self, centre: [usize; 3], ring: usize) -> impl Iterator<Item = usize> + '_ {
        let span =
            |a: usize| centre[a].saturating_sub(ring)..=(centre[a] + ring).min(self.cells[a] - 1);
        let (xs, ys, zs) = (span(0), span(1), span(2));
        zs.flat_map(move |k| {
            let (xs, ys) = (xs.clone(), ys.clone());
            ys.flat_map(move |j| xs.clone().map(move |i| [i, j, k]))
        })
        .filter(move |at| (0..3).map(|a| at[a].abs_diff(centre[a])).max() == Some(ring))
        .map(|at| self.bin(at))
    }

    /// The cell holding `x`, the nearest one for a point outside the grid.
    fn cell_of(&self, x: DVec3) -> [usize; 3] {
        let at = ((x - self.low) / self.cell).floor();
        [0, 1, 2].map(|a| (at[a].max(0.0) as usize).min(self.cells[a] - 1))
    }

    fn bin(&self, [i, j, k]: [usize; 3]) -> usize {
        i + self.cells[0] * (j + self.cells[1] * k)
    }
}

/// Where the line through `x` along `axis` meets triangle `c` (its coordinate along `axis`),
/// if it does; `u` and `v` the other two axes. A line through an edge meets one of the two
/// triangles beside it: the one whose edge runs "up" in (u, v), turned as the triangle is.
fn crossing(x: DVec3, c: [DVec3; 3], axis: usize, u: usize, v: usize) -> Option<f64> {
    let edges = [(c[1], c[2]), (c[2], c[0]), (c[0], c[1])];
    let w = edges.map(|(a, b)| (b[u] - a[u]) * (x[v] - a[v]) - (b[v] - a[v]) * (x[u] - a[u]));
    let area = w[0] + w[1] + w[2];
    if area == 0.0 {
        return None;
    }
    let s = area.signum();
    let owns = |(a, b): (DVec3, DVec3)| {
        let (du, dv) = (s * (b[u] - a[u]), s * (b[v] - a[v]));
        dv > 0.0 || (dv == 0.0 && du < 0.0)
    };
    for (e, edge) in w.into_iter().zip(edges) {
        if e * s < 0.0 || (e == 0.0 && !owns(edge)) {
            return None;
        }
    }
    Some((w[0] * c[0][axis] + w[1] * c[1][axis] + w[2] * c[2][axis]) / area)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::properties::closure;

    /// A ball of radius 1 as a closed surface: an octahedron split `levels` times, its
    /// vertices on the sphere.
    fn ball(levels: usize) -> TriangleMesh {
        let mut vertices = vec![
            DVec3::X,
            -DVec3::X,
            DVec3::Y,
            -DVec3::Y,
            DVec3::Z,
            -DVec3::Z,
        ];
        let mut triangles: Vec<[u32; 3]> = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        for _ in 0..levels {
            let mut middles = std::collections::HashMap::new();
            let mut middle = |a: u32, b: u32, vertices: &mut Vec<DVec3>| {
                *middles.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let m = (vertices[a as usize] + vertices[b as usize]).normalize();
                    vertices.push(m);
                    vertices.len() as u32 - 1
                })
            };
            triangles = triangles
                .iter()
                .flat_map(|&[a, b, c]| {
                    let (ab, bc, ca) = (
                        middle(a, b, &mut vertices),
                        middle(b, c, &mut vertices),
                        middle(c, a, &mut vertices),
                    );
                    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
                })
                .collect();
        }
        TriangleMesh {
            vertices,
            triangles,
            normals: None,
        }
    }

    /// Points spread over a box of half-side `half`, the same each run.
    fn points(count: usize, half: f64) -> impl Iterator<Item = DVec3> {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        (0..count).map(move |_| DVec3::new(next(), next(), next()) * half)
    }

    /// Against every triangle looked at, the nearest point is the nearest of all, and a
    /// point is inside exactly where the surface nearest it faces away from it.
    #[test]
    fn nearest_points_are_every_triangles_nearest_and_inside_is_behind_the_surface() {
        let mesh = ball(3);
        assert!(closure(&mesh).is_closed());
        let enclosure = Enclosure::new(&mesh);
        for x in points(2000, 1.5) {
            let found = enclosure.nearest(x);
            let every = mesh
                .corners()
                .map(|c| crate::triangle::nearest_point(x, c))
                .min_by(|p, q| p.distance(x).total_cmp(&q.distance(x)))
                .unwrap();
            assert!(
                (found.distance(x) - every.distance(x)).abs() < 1e-12,
                "{x}: {found} vs {every}"
            );
            // The ball's faces are convex: inside is inside every face's plane.
            let behind = mesh
                .corners()
                .all(|[a, b, c]| (b - a).cross(c - a).dot(x - a) < 0.0);
            if found.distance(x) > 1e-9 {
                assert_eq!(enclosure.contains(x), behind, "{x}");
            }
        }
    }

    /// Points on the grid's own cell boundaries and through the mesh's vertices (rays
    /// along edges) are still sorted right: a cube's.
    #[test]
    fn rays_through_edges_and_corners_are_counted_once() {
        let cube = crate::properties::cuboid(DVec3::splat(-1.0), DVec3::ONE);
        let enclosure = Enclosure::new(&cube);
        for i in -4..=4 {
            for j in -4..=4 {
                for k in -4..=4 {
                    let x = DVec3::new(i as f64, j as f64, k as f64) * 0.5;
                    let inside = x.abs().max_element() < 1.0;
                    let on = x.abs().max_element() == 1.0;
                    if !on {
                        assert_eq!(enclosure.contains(x), inside, "{x}");
                    }
                }
            }
        }
    }
}

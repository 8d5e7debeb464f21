//! A closed triangle mesh that tells how far a point is from its surface, and on which side:
//! the exact shape a held part and what it touches are queried as, concave or not.
//!
//! Near a point, the triangles are found through a [`Bvh`]; the closest point on each comes
//! with the feature it lies on (the face, an edge, a corner), and the side is read from that
//! feature's angle-weighted pseudo-normal (Bærentzen and Aanæs), which tells inside from
//! outside wherever the closest point lies. Each mesh also carries samples of its own
//! surface, its corners and points along the edges where it folds outward, for the other
//! side of a two-way query: where two solids meet, a corner or an edge of one of them is
//! nearest the other's surface, so checking both meshes' samples against each other's
//! triangles finds every touch, edge crossing edge included to within the samples' spacing.
//! An edge folded inward needs no samples (the other solid meets it with edges and corners
//! that fold outward), but a point beside it is held off its faces' own planes.

use std::collections::HashMap;
use std::time::Instant;

use glam::{DAffine3, DVec3};

use super::bvh::{Bvh, PairWalk};

/// How far apart the samples along a solid's creases are at a right angle, metres
/// ([`SignedMesh::of_triangles`]): an edge crossing an edge between two goes at most half as
/// deep.
pub const CREASE_SPACING: f64 = 1e-4;

/// An edge whose faces turn by less than this (radians) is flat: a crossing there cannot go
/// deeper than the corners show.
const FLAT: f64 = 1e-3;

/// What is wrong with a mesh that cannot be a solid's surface.
#[derive(Debug, Clone, PartialEq)]
pub enum MeshFault {
    /// No triangle.
    Empty,
    /// A corner that is not a finite point, or a triangle naming a corner that is not there.
    Corrupt,
    /// An edge with a face on one side only: the surface has a hole, so it bounds nothing.
    Open {
        /// How many such edges.
        edges: usize,
    },
    /// An edge two faces cross in the same direction, or more than two faces share: the
    /// surface folds over itself or is wound inconsistently.
    Tangled {
        /// How many such edges.
        edges: usize,
    },
}

impl std::fmt::Display for MeshFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MeshFault::Empty => write!(f, "it has no triangle"),
            MeshFault::Corrupt => write!(f, "a corner is not a finite point or is not there"),
            MeshFault::Open { edges } => write!(
                f,
                "its surface is open ({edges} edges have a face on one side only), so it encloses no solid"
            ),
            MeshFault::Tangled { edges } => write!(
                f,
                "its surface folds over itself or is wound both ways ({edges} edges)"
            ),
        }
    }
}

/// Which part of a triangle a closest point lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Feature {
    /// Inside the face.
    Face,
    /// On edge k, from corner k to corner k + 1 (mod 3).
    Edge(u8),
    /// At corner k.
    Corner(u8),
}

/// The nearest a point comes to one triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Near {
    /// Distance to the surface: positive outside, negative inside, metres.
    pub distance: f64,
    /// How far the point may go along `normal` before it enters the solid, metres: the
    /// distance, except beside an edge where the surface folds inward, where it is the
    /// distance to the face's own plane (the space left there is what lies in front of
    /// both faces).
    pub gap: f64,
    /// The closest point on the triangle.
    pub point: DVec3,
    /// The outward unit normal there: along the way from the closest point to a point
    /// outside, against it for one inside.
    pub normal: DVec3,
    /// Whether that way lies within the normal cone of the feature (between the normals of
    /// the faces that meet there): always so for the surface's nearest feature; not for an
    /// edge or corner inside a flat stretch seen from beside it, which no solid presents.
    pub facing: bool,
}

/// A closed, consistently wound triangle mesh in its own frame, ready for distance queries.
#[derive(Debug, Clone, PartialEq)]
pub struct SignedMesh {
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// Each triangle's outward unit normal.
    normals: Vec<DVec3>,
    /// How far each triangle's plane lies from the origin along its normal.
    offsets: Vec<f64>,
    /// Each corner's angle-weighted pseudo-normal.
    corner_normals: Vec<DVec3>,
    /// Each corner's pseudo-normal's least cosine with its faces' normals.
    corner_cones: Vec<f64>,
    /// Each triangle's edges' pseudo-normals (edge k from corner k to k + 1): the mean of the
    /// two faces' normals.
    edge_normals: Vec<[DVec3; 3]>,
    /// Each triangle's edges where the surface folds inward: bit k for edge k.
    folds_in: Vec<u8>,
    tree: Bvh,
    samples: Vec<DVec3>,
    sample_tree: Bvh,
    /// The farthest any sample lies from the frame's origin.
    radius: f64,
}

impl SignedMesh {
    /// The mesh of `triangles` over `vertices` (counter-clockwise seen from outside),
    /// corners at the same place welded, the edges where it folds outward sampled every
    /// `spacing` metres or closer (at a right angle; shallower creases more sparsely, since a
    /// crossing between samples goes less deep there). Built here, off the haptic thread.
    pub fn new(
        vertices: &[DVec3],
        triangles: &[[u32; 3]],
        spacing: f64,
    ) -> Result<Self, MeshFault> {
        if triangles.is_empty() {
            return Err(MeshFault::Empty);
        }
        if !(spacing > 0.0 && spacing.is_finite())
            || vertices.iter().any(|v| !v.is_finite())
            || triangles
                .iter()
                .flatten()
                .any(|&i| i as usize >= vertices.len())
        {
            return Err(MeshFault::Corrupt);
        }
        // Corners at the same place are one: a file's faces often repeat them for their
        // normals or texture coordinates.
        let mut welded: HashMap<[u64; 3], u32> = HashMap::new();
        let mut points = Vec::new();
        let index: Vec<u32> = vertices
            .iter()
            .map(|v| {
                let key = (*v + DVec3::ZERO).to_array().map(f64::to_bits);
                *welded.entry(key).or_insert_with(|| {
                    points.push(*v);
                    points.len() as u32 - 1
                })
            })
            .collect();
        let triangles: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| index[i as usize]))
            .filter(|[a, b, c]| a != b && b != c && c != a)
            .collect();
        if triangles.is_empty() {
            return Err(MeshFault::Empty);
        }
        let mut edges: HashMap<(u32, u32), (usize, usize)> = HashMap::new();
        let mut tangled = 0;
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                if edges.insert((tri[k], tri[(k + 1) % 3]), (t, k)).is_some() {
                    tangled += 1;
                }
            }
        }
        if tangled > 0 {
            return Err(MeshFault::Tangled { edges: tangled });
        }
        let open = edges
            .keys()
            .filter(|&&(a, b)| !edges.contains_key(&(b, a)))
            .count();
        if open > 0 {
            return Err(MeshFault::Open { edges: open });
        }
        let corner = |t: &[u32; 3], k: usize| points[t[k % 3] as usize];
        let normals: Vec<DVec3> = triangles
            .iter()
            .map(|t| {
                (corner(t, 1) - corner(t, 0))
                    .cross(corner(t, 2) - corner(t, 0))
                    .normalize_or_zero()
            })
            .collect();
        let mut corner_normals = vec![DVec3::ZERO; points.len()];
        for (t, n) in triangles.iter().zip(&normals) {
            for k in 0..3 {
                let (here, next, last) = (corner(t, k), corner(t, k + 1), corner(t, k + 2));
                let angle = (next - here).angle_between(last - here);
                if angle.is_finite() {
                    corner_normals[t[k] as usize] += angle * *n;
                }
            }
        }
        for n in &mut corner_normals {
            *n = n.normalize_or_zero();
        }
        let mut corner_cones = vec![1.0f64; points.len()];
        for (t, n) in triangles.iter().zip(&normals) {
            for &i in t {
                let cone = &mut corner_cones[i as usize];
                *cone = cone.min(corner_normals[i as usize].dot(*n));
            }
        }
        let mut edge_normals = vec![[DVec3::ZERO; 3]; triangles.len()];
        let mut folds_in = vec![0u8; triangles.len()];
        let mut creases = Vec::new();
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let (other, _) = edges[&(b, a)];
                let (mine, theirs) = (normals[t], normals[other]);
                edge_normals[t][k] = (mine + theirs).normalize_or_zero();
                if mine.angle_between(theirs) <= FLAT {
                    continue;
                }
                // Inward where the other face's far corner lies in front of this face.
                let far = triangles[other]
                    .into_iter()
                    .find(|&i| i != a && i != b)
                    .map_or(points[a as usize], |i| points[i as usize]);
                if (far - points[a as usize]).dot(mine) > 0.0 {
                    folds_in[t] |= 1 << k;
                    continue;
                }
                // Each edge once, from the face where it runs from the lower corner; only
                // where the surface folds outward: where two solids touch, one folded
                // inward (filling more than half the space round the edge) is met by the
                // other's faces, edges and corners, which fold outward.
                if a < b {
                    creases.push(Crease {
                        ends: [a, b],
                        faces: [mine, theirs],
                    });
                }
            }
        }
        let samples = crease_samples(&points, &creases, spacing);
        let boxes: Vec<(DVec3, DVec3)> = triangles
            .iter()
            .map(|t| {
                let (a, b, c) = (corner(t, 0), corner(t, 1), corner(t, 2));
                (a.min(b).min(c), a.max(b).max(c))
            })
            .collect();
        let points_boxes: Vec<(DVec3, DVec3)> = samples.iter().map(|&s| (s, s)).collect();
        let radius = samples.iter().map(|s| s.length()).fold(0.0, f64::max);
        // Triangles and samples in their trees' order, corners in the order the triangles
        // first name them: a query reads a leaf's together.
        let (tree, order) = Bvh::build_renumbered(&boxes);
        let (sample_tree, sample_order) = Bvh::build_renumbered(&points_boxes);
        let triangles = renumbered(&triangles, &order);
        let mut new_corner = vec![u32::MAX; points.len()];
        let mut corner_order = Vec::with_capacity(points.len());
        for &i in triangles.iter().flatten() {
            if new_corner[i as usize] == u32::MAX {
                new_corner[i as usize] = corner_order.len() as u32;
                corner_order.push(i);
            }
        }
        let triangles: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| new_corner[i as usize]))
            .collect();
        let normals = renumbered(&normals, &order);
        let vertices = renumbered(&points, &corner_order);
        let offsets = triangles
            .iter()
            .zip(&normals)
            .map(|(t, n)| n.dot(vertices[t[0] as usize]))
            .collect();
        Ok(SignedMesh {
            tree,
            sample_tree,
            vertices,
            triangles,
            normals,
            offsets,
            corner_normals: renumbered(&corner_normals, &corner_order),
            corner_cones: renumbered(&corner_cones, &corner_order),
            edge_normals: renumbered(&edge_normals, &order),
            folds_in: renumbered(&folds_in, &order),
            samples: renumbered(&samples, &sample_order),
            radius,
        })
    }

    /// The surface of `triangles` (each counter-clockwise seen from outside, corners given
    /// by position), its creases sampled every [`CREASE_SPACING`]: a solid's surface for
    /// exact queries. Built here, off the haptic thread.
    pub fn of_triangles(triangles: &[[DVec3; 3]]) -> Result<Self, MeshFault> {
        let corners: Vec<DVec3> = triangles.iter().flatten().copied().collect();
        let indices: Vec<[u32; 3]> = (0..triangles.len() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        Self::new(&corners, &indices, CREASE_SPACING)
    }

    /// The triangles, after welding.
    pub fn triangles(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        self.triangles
            .iter()
            .map(|t| t.map(|i| self.vertices[i as usize]))
    }

    /// The surface samples: every corner on a crease, then points along the creases.
    pub fn samples(&self) -> &[DVec3] {
        &self.samples
    }

    /// The farthest a sample lies from the frame's origin, metres.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// [rt] Call `visit(sample, triangle)` with each pair of a sample of `other` and a
    /// triangle of this mesh that may come within `reach` of each other, `other` `placed` in
    /// this mesh's frame (turned and shifted only), going on with `walk` from where it
    /// stopped; no allocation. True when done, false when the clock passed `deadline` first
    /// (see [`Bvh::walk_pairs`]).
    pub fn walk_near(
        &self,
        other: &SignedMesh,
        (placed, reach): (DAffine3, f64),
        walk: &mut PairWalk,
        deadline: Option<Instant>,
        mut visit: impl FnMut(usize, usize),
    ) -> bool {
        self.tree.walk_pairs(
            &other.sample_tree,
            (placed, reach),
            walk,
            deadline,
            |t, s| visit(s, t),
        )
    }

    /// [rt] How near `p` (in this mesh's frame) comes to triangle `t`, signed by the
    /// pseudo-normal of the feature its closest point lies on; None when it is farther than
    /// `reach`, the triangle's plane looked at first, which settles most.
    pub fn near_within(&self, t: usize, p: DVec3, reach: f64) -> Option<Near> {
        if (p.dot(self.normals[t]) - self.offsets[t]).abs() > reach {
            return None;
        }
        let [i, j, k] = self.triangles[t];
        let (a, b, c) = (
            self.vertices[i as usize],
            self.vertices[j as usize],
            self.vertices[k as usize],
        );
        // A leaf pairs every sample with every triangle of its own: those beside the
        // triangle's box by more than the reach are settled before the closest point.
        let (low, high) = (a.min(b).min(c) - reach, a.max(b).max(c) + reach);
        if p.cmplt(low).any() || p.cmpgt(high).any() {
            return None;
        }
        let closest = closest_on_triangle(p, a, b, c);
        ((p - closest.0).length_squared() <= reach * reach).then(|| self.signed(t, p, closest))
    }

    /// The nearness of `p` to triangle `t` whose closest point is `point` on `feature`.
    fn signed(&self, t: usize, p: DVec3, (point, feature): (DVec3, Feature)) -> Near {
        let tri = self.triangles[t];
        let (pseudo, cone) = match feature {
            Feature::Face => (self.normals[t], 1.0),
            Feature::Edge(k) => {
                let n = self.edge_normals[t][k as usize];
                (n, n.dot(self.normals[t]))
            }
            Feature::Corner(k) => {
                let i = tri[k as usize] as usize;
                (self.corner_normals[i], self.corner_cones[i])
            }
        };
        let away = p - point;
        let length = away.length();
        // Closer than rounding can tell a direction from: the feature's own normal.
        if length <= 1e-12 {
            return Near {
                distance: 0.0,
                gap: 0.0,
                point,
                normal: pseudo,
                facing: true,
            };
        }
        let direction = away / length;
        let sign = if direction.dot(pseudo) < 0.0 {
            -1.0
        } else {
            1.0
        };
        // Outside, beside an edge folded inward: held off the face's plane, which there
        // bounds the space left (the way from the edge would let the point slide along the
        // other face and through this one).
        if let Feature::Edge(k) = feature
            && self.folds_in[t] & (1 << k) != 0
            && sign > 0.0
        {
            let normal = self.normals[t];
            return Near {
                distance: length,
                gap: p.dot(normal) - self.offsets[t],
                point,
                normal,
                facing: true,
            };
        }
        Near {
            distance: sign * length,
            gap: sign * length,
            point,
            normal: sign * direction,
            facing: sign * direction.dot(pseudo) >= cone - 1e-9,
        }
    }
}

/// An edge where the surface turns.
struct Crease {
    /// Its corners, the lower first.
    ends: [u32; 2],
    /// The normals of its faces, the one it runs along counter-clockwise first.
    faces: [DVec3; 2],
}

impl Crease {
    /// Its corner at the other end from corner `v`.
    fn other(&self, v: usize) -> usize {
        let [a, b] = self.ends;
        if a as usize == v {
            b as usize
        } else {
            a as usize
        }
    }
}

/// The samples of a surface's `creases` over `points`, `spacing` apart at a right angle:
/// the corners where creases meet or turn, then points along each straight run of creases
/// between them. A crease goes on straight through a corner that a finely cut face only
/// put there (two creases in line between the same two faces), and is sampled at its own
/// spacing across it: such corners every 0.3 mm would give a shallow crease ten times the
/// samples it needs.
fn crease_samples(points: &[DVec3], creases: &[Crease], spacing: f64) -> Vec<DVec3> {
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); points.len()];
    for (e, crease) in creases.iter().enumerate() {
        for &end in &crease.ends {
            at[end as usize].push(e);
        }
    }
    let same = |x: DVec3, y: DVec3| x.dot(y) > 1.0 - 1e-12;
    let through = |v: usize| -> bool {
        let [e, f] = at[v][..] else { return false };
        let away = |e: usize| (points[creases[e].other(v)] - points[v]).normalize_or_zero();
        let ([m, n], [p, q]) = (creases[e].faces, creases[f].faces);
        away(e).dot(away(f)) < -1.0 + 1e-12
            && ((same(m, p) && same(n, q)) || (same(m, q) && same(n, p)))
    };
    let mut samples: Vec<DVec3> = (0..points.len())
        .filter(|&v| !at[v].is_empty() && !through(v))
        .map(|v| points[v])
        .collect();
    let mut walked = vec![false; creases.len()];
    let run = |from: usize, mut e: usize, walked: &mut Vec<bool>, samples: &mut Vec<DVec3>| {
        let mut here = from;
        loop {
            walked[e] = true;
            here = creases[e].other(here);
            if !through(here) {
                break;
            }
            e = at[here].iter().copied().find(|&f| f != e).unwrap_or(e);
            if walked[e] {
                break;
            }
        }
        let (p, q) = (points[from], points[here]);
        let [m, n] = creases[e].faces;
        // A crossing between samples h apart goes about h/2·tan(turn/2) deep: half the
        // spacing whatever the crease.
        let step = spacing / (m.angle_between(n) / 2.0).tan().min(4.0);
        let pieces = ((q - p).length() / step).ceil() as usize;
        samples.extend((1..pieces).map(|i| p.lerp(q, i as f64 / pieces as f64)));
    };
    for v in (0..points.len()).filter(|&v| !through(v)) {
        for &e in &at[v] {
            if !walked[e] {
                run(v, e, &mut walked, &mut samples);
            }
        }
    }
    // A ring of creases all in line cannot close; should rounding make one, it is walked
    // from a corner of its own.
    for e in 0..creases.len() {
        if !walked[e] {
            let from = creases[e].ends[0] as usize;
            samples.push(points[from]);
            run(from, e, &mut walked, &mut samples);
        }
    }
    samples
}

/// `items` taken in `order` (the old number of each new one).
fn renumbered<T: Copy>(items: &[T], order: &[u32]) -> Vec<T> {
    order.iter().map(|&i| items[i as usize]).collect()
}

/// The point of `triangle` closest to `p`.
pub(super) fn closest_point(triangle: &[DVec3; 3], p: DVec3) -> DVec3 {
    closest_on_triangle(p, triangle[0], triangle[1], triangle[2]).0
}

/// The point of triangle `a`, `b`, `c` closest to `p`, and the feature it lies on: the
/// Voronoi regions of the corners, then the edges, then the face (Ericson, 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (DVec3, Feature) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Corner(0));
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Corner(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (a + ab * (d1 / (d1 - d3)), Feature::Edge(0));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Corner(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (a + ac * (d2 / (d2 - d6)), Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, Feature::Edge(1));
    }
    let total = va + vb + vc;
    if total <= 0.0 {
        // No area: the nearest of its edges' ends will do.
        return (a, Feature::Corner(0));
    }
    (a + ab * (vb / total) + ac * (vc / total), Feature::Face)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    /// A unit cube's 12 triangles, wound outward, each with corners of its own.
    fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let faces = super::super::fixtures::box_faces(DVec3::splat(0.5), DVec3::splat(0.5));
        let corners = faces.iter().flatten().copied().collect();
        let triangles = (0..faces.len() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        (corners, triangles)
    }

    /// How near `p` comes to triangle `t` of `mesh`.
    fn near(mesh: &SignedMesh, t: usize, p: DVec3) -> Near {
        mesh.near_within(t, p, f64::INFINITY)
            .expect("within any reach")
    }

    /// The signed distance from `p` to `mesh`'s surface, scanning every triangle.
    fn distance(mesh: &SignedMesh, p: DVec3) -> f64 {
        (0..mesh.triangles.len())
            .map(|t| near(mesh, t, p))
            .min_by(|x, y| x.distance.abs().total_cmp(&y.distance.abs()))
            .map_or(f64::INFINITY, |n| n.distance)
    }

    /// A reproducible point in [-0.5, 1.5]³.
    fn point(k: u64) -> DVec3 {
        let hash = |s: u64| {
            let x = (k.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ s).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        DVec3::new(hash(1), hash(2), hash(3)) * 2.0 - 0.5
    }

    /// The exact signed distance from `p` to the unit cube at the origin's corner.
    fn unit_cube_distance(p: DVec3) -> f64 {
        let q = (p - 0.5).abs() - 0.5;
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
    }

    #[test]
    fn the_distance_to_a_cube_is_the_box_formula_inside_and_out() {
        let (v, t) = cube();
        let mesh = SignedMesh::new(&v, &t, 0.1).unwrap();
        for k in 0..2000 {
            let p = point(k);
            assert!(
                (distance(&mesh, p) - unit_cube_distance(p)).abs() < 1e-12,
                "{p}"
            );
        }
    }

    #[test]
    fn a_cube_is_sampled_at_its_corners_and_along_its_edges() {
        let (v, t) = cube();
        let mesh = SignedMesh::new(&v, &t, 0.1).unwrap();
        // 8 corners and 9 points inside each of the 12 edges; none across the faces'
        // diagonals, which are flat.
        assert_eq!(mesh.samples().len(), 8 + 12 * 9);
        assert!((mesh.radius() - 3f64.sqrt()).abs() < 1e-12);
    }

    /// A unit cube whose faces are cut into `n` × `n` squares of two triangles each.
    fn cut_cube(n: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let (mut corners, mut triangles) = (Vec::new(), Vec::new());
        for d in 0..3 {
            for side in [0, n] {
                // Grid point (i, j) of the face at `side` across axis d, by its whole
                // coordinates, so that faces meeting at an edge name the same points.
                let at = |i: u32, j: u32| {
                    let mut c = [0u32; 3];
                    (c[d], c[(d + 1) % 3], c[(d + 2) % 3]) = (side, i, j);
                    DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) / n as f64
                };
                for (i, j) in (0..n).flat_map(|i| (0..n).map(move |j| (i, j))) {
                    let square = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                    for mut t in [[0, 1, 2], [0, 2, 3]] {
                        if side == 0 {
                            t.swap(1, 2);
                        }
                        let first = corners.len() as u32;
                        corners.extend(t.map(|k| square[k]));
                        triangles.push([first, first + 1, first + 2]);
                    }
                }
            }
        }
        (corners, triangles)
    }

    #[test]
    fn a_finely_cut_face_adds_no_samples_along_its_creases() {
        let (v, t) = cube();
        let plain = SignedMesh::new(&v, &t, 0.1).unwrap();
        for n in [2, 3, 7] {
            let (v, t) = cut_cube(n);
            let mesh = SignedMesh::new(&v, &t, 0.1).unwrap();
            assert_eq!(mesh.samples().len(), plain.samples().len(), "cut in {n}");
            for a in mesh.samples() {
                assert!(
                    plain.samples().iter().any(|b| a.distance(*b) < 1e-12),
                    "cut in {n}: {a} is not a sample of the plain cube"
                );
            }
            // And the distances it gives are the plain cube's.
            for k in 0..500 {
                let p = point(k);
                assert!(
                    (distance(&mesh, p) - unit_cube_distance(p)).abs() < 1e-12,
                    "{p}"
                );
            }
        }
    }

    #[test]
    fn an_edge_folded_inward_is_not_sampled_and_holds_off_both_faces() {
        // A trough 1 deep: the section (-1, -1), (1, -1), (1, h), (0, 0), (-1, h), its top two
        // faces folded inward by 10° each along the valley x = y = 0.
        let h = 10f64.to_radians().tan();
        let section = [[-1.0, -1.0], [1.0, -1.0], [1.0, h], [0.0, 0.0], [-1.0, h]];
        let corners: Vec<DVec3> = [0.0, 1.0]
            .iter()
            .flat_map(|&z| section.iter().map(move |&[x, y]| DVec3::new(x, y, z)))
            .collect();
        let mut triangles = Vec::new();
        for k in 1..4u32 {
            // The ends fanned from (-1, -1): the near one seen from -z, the far from +z.
            triangles.push([0, k + 1, k]);
            triangles.push([5, 5 + k, 5 + k + 1]);
        }
        for k in 0..5u32 {
            let next = (k + 1) % 5;
            triangles.push([k, next, 5 + next]);
            triangles.push([k, 5 + next, 5 + k]);
        }
        let mesh = SignedMesh::new(&corners, &triangles, 0.1).unwrap();
        // Samples along every upright edge but the valley's.
        let on = |x: f64, y: f64| {
            (mesh.samples().iter())
                .filter(|s| s.x == x && s.y == y && s.z > 0.0 && s.z < 1.0)
                .count()
        };
        assert!(on(1.0, -1.0) > 0 && on(1.0, h) > 0 && on(-1.0, h) > 0);
        assert_eq!(on(0.0, 0.0), 0);
        // Just over the right face near the valley: the left face, whose nearest point is
        // the valley, holds it off the left face's own plane.
        let p = DVec3::new(0.02, 0.02 * h + 0.001, 0.5);
        let left = DVec3::new(h, 1.0, 0.0).normalize();
        let beside: Vec<Near> = (0..mesh.triangles.len())
            .map(|t| near(&mesh, t, p))
            .filter(|n| n.normal.dot(left) > 1.0 - 1e-12 && n.distance > 0.0)
            .collect();
        assert!(!beside.is_empty());
        for n in &beside {
            assert!((n.gap - left.dot(p)).abs() < 1e-12, "{n:?}");
            assert!(n.facing && n.distance > n.gap + 0.01, "{n:?}");
        }
        // Above the right face, as the nearest feature says.
        let right = DVec3::new(-h, 1.0, 0.0).normalize();
        assert!((distance(&mesh, p) - right.dot(p)).abs() < 1e-12);
    }

    #[test]
    fn an_open_or_inside_out_surface_is_refused() {
        // Each triangle's corners its own: welded at the same places, they close a cube.
        let (v, mut t) = cube();
        assert!(SignedMesh::new(&v, &t, 0.1).is_ok());
        t.pop();
        assert_eq!(
            SignedMesh::new(&v, &t, 0.1),
            Err(MeshFault::Open { edges: 3 })
        );
        let (v, mut t) = cube();
        t[0].swap(1, 2);
        assert!(matches!(
            SignedMesh::new(&v, &t, 0.1),
            Err(MeshFault::Tangled { .. })
        ));
        let mut bad = v.clone();
        bad[3].x = f64::NAN;
        assert_eq!(SignedMesh::new(&bad, &t, 0.1), Err(MeshFault::Corrupt));
        assert_eq!(SignedMesh::new(&v, &[], 0.1), Err(MeshFault::Empty));
    }

    #[test]
    fn a_walk_stopped_by_the_clock_and_taken_up_again_visits_the_pairs_of_a_whole_one() {
        let (v, t) = cube();
        let mesh = SignedMesh::new(&v, &t, 0.05).unwrap();
        let turn = DQuat::from_rotation_y(0.4) * DQuat::from_rotation_x(0.3);
        let query = (
            DAffine3::from_rotation_translation(turn, DVec3::new(0.7, 0.9, 0.2)),
            0.05,
        );
        let mut whole = Vec::new();
        let mut walk = PairWalk::default();
        assert!(mesh.walk_near(&mesh, query, &mut walk, None, |s, t| whole.push((s, t))));
        // A deadline already past: each call takes a few dozen pairs of nodes and stops.
        let (mut pieces, mut calls) = (Vec::new(), 1);
        walk.restart();
        while !mesh.walk_near(&mesh, query, &mut walk, Some(Instant::now()), |s, t| {
            pieces.push((s, t))
        }) {
            calls += 1;
        }
        assert!(calls > 1, "{calls} calls");
        assert!(!whole.is_empty());
        assert_eq!(pieces, whole);
    }

    #[test]
    fn the_pairs_near_a_placed_mesh_are_those_a_scan_of_every_pair_finds() {
        let (v, t) = cube();
        let mesh = SignedMesh::new(&v, &t, 0.05).unwrap();
        let turn = DQuat::from_rotation_y(0.4) * DQuat::from_rotation_x(0.3);
        let shift = DVec3::new(0.7, 0.9, 0.2);
        let reach = 0.05;
        let mut found = Vec::new();
        let placed = DAffine3::from_rotation_translation(turn, shift);
        let mut walk = PairWalk::default();
        let done = mesh.walk_near(&mesh, (placed, reach), &mut walk, None, |s, t| {
            if near(&mesh, t, turn * mesh.samples()[s] + shift)
                .distance
                .abs()
                <= reach
            {
                found.push((s, t));
            }
        });
        assert!(done);
        found.sort_unstable();
        found.dedup();
        let mut expected = Vec::new();
        for (s, p) in mesh.samples().iter().enumerate() {
            for t in 0..12 {
                if near(&mesh, t, turn * *p + shift).distance.abs() <= reach {
                    expected.push((s, t));
                }
            }
        }
        assert!(!expected.is_empty());
        assert_eq!(found, expected);
    }
}

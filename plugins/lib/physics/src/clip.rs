//! Exact intersection of convex polyhedra by plane clipping.
//!
//! Clipping keeps the part of a polyhedron where n·x ≤ d: each face loop is cut
//! (Sutherland–Hodgman), the points where edges cross the plane are shared by the two faces
//! of the edge, and the points on the plane close the hole as a new face, ordered by angle
//! around their centroid. Intersecting A with B is clipping A by every face plane of B.
//! The clipper keeps its work buffers, face lists included, between calls, and
//! [`Clipper::reserve`] sizes them beforehand for the largest pieces of a world, so that
//! clipping inside a haptic tick allocates nothing, from the first contact on.

use glam::DVec3;

use super::polyhedron::{Plane, Polyhedron};

/// Points closer to a plane than this count as on it, metres.
const ON_PLANE: f64 = 1e-12;

/// Room in a new face list: any pooled list may serve any face, so each is made big enough
/// for the faces of ordinary contacts (a box face cut by a box's six planes has at most 10).
const FACE_CAPACITY: usize = 16;

/// Reusable buffers for clipping.
#[derive(Debug, Clone, Default)]
pub struct Clipper {
    distance: Vec<f64>,
    kept: Vec<Option<usize>>,
    /// Edge (from, to) of the input → index of its crossing point in the output.
    crossings: Vec<(usize, usize, usize)>,
    cap: Vec<(f64, usize)>,
    spare: Polyhedron,
    /// Emptied face lists, kept for reuse.
    pool: Vec<Vec<usize>>,
}

impl Clipper {
    /// Room for intersecting pieces of at most `faces` faces each, and for `out`, the
    /// intersection they are written to. A convex intersection has at most the faces of both
    /// (2·faces), each with at most that many vertices, and at most twice as many vertices
    /// as faces; every buffer gets that much and more.
    pub fn reserve(&mut self, faces: usize, out: &mut Polyhedron) {
        let faces = 2 * faces + 4;
        let vertices = 2 * faces + 8;
        self.distance.reserve(vertices);
        self.kept.reserve(vertices);
        // Each edge crosses at most once; a convex polyhedron has under three per vertex.
        self.crossings.reserve(3 * vertices);
        self.cap.reserve(vertices);
        // Face lists live in the pool or in one of the three polyhedra clipping writes to.
        let lists = 3 * faces;
        self.pool.reserve(lists);
        while self.pool.len() < lists {
            self.pool.push(Vec::with_capacity(faces.max(FACE_CAPACITY)));
        }
        for p in [&mut self.spare, out] {
            p.vertices.reserve(vertices);
            p.faces.reserve(faces);
            p.planes.reserve(faces);
        }
    }

    /// Write the part of `input` where `plane.distance(x) ≤ 0` to `out` (empty when none).
    pub fn clip(&mut self, input: &Polyhedron, plane: Plane, out: &mut Polyhedron) {
        self.empty(out);
        self.distance.clear();
        self.distance
            .extend(input.vertices.iter().map(|&v| plane.distance(v)));
        if self.distance.iter().all(|&s| s <= ON_PLANE) {
            self.copy(input, out);
            return;
        }
        if self.distance.iter().all(|&s| s >= -ON_PLANE) {
            return;
        }
        self.kept.clear();
        self.cap.clear();
        for (&v, &s) in input.vertices.iter().zip(&self.distance) {
            if s <= ON_PLANE {
                // A vertex left on the plane is a corner of the cap too.
                if on_plane(v, s) {
                    self.cap.push((0.0, out.vertices.len()));
                }
                self.kept.push(Some(out.vertices.len()));
                out.vertices.push(v);
            } else {
                self.kept.push(None);
            }
        }
        self.crossings.clear();
        for (face, face_plane) in input.faces.iter().zip(&input.planes) {
            let mut loop_ = self.face_list();
            for (k, &i) in face.iter().enumerate() {
                let j = face[(k + 1) % face.len()];
                if let Some(index) = self.kept[i] {
                    loop_.push(index);
                }
                let (si, sj) = (self.distance[i], self.distance[j]);
                if (si < -ON_PLANE && sj > ON_PLANE) || (si > ON_PLANE && sj < -ON_PLANE) {
                    loop_.push(self.crossing(input, out, i, j));
                }
            }
            if loop_.len() >= 3 {
                out.faces.push(loop_);
                out.planes.push(*face_plane);
            } else {
                loop_.clear();
                self.pool.push(loop_);
            }
        }
        self.close_cap(plane, out);
    }

    /// An empty face list, from the pool when it has one.
    fn face_list(&mut self) -> Vec<usize> {
        self.pool
            .pop()
            .unwrap_or_else(|| Vec::with_capacity(FACE_CAPACITY))
    }

    /// Empty `p`, keeping its face lists for reuse.
    fn empty(&mut self, p: &mut Polyhedron) {
        p.vertices.clear();
        p.planes.clear();
        for mut face in p.faces.drain(..) {
            face.clear();
            self.pool.push(face);
        }
    }

    /// Make `out` a copy of `input`, with face lists from the pool.
    fn copy(&mut self, input: &Polyhedron, out: &mut Polyhedron) {
        self.empty(out);
        out.vertices.extend_from_slice(&input.vertices);
        out.planes.extend_from_slice(&input.planes);
        for face in &input.faces {
            let mut copy = self.face_list();
            copy.extend_from_slice(face);
            out.faces.push(copy);
        }
    }

    /// Index in `out` of the point where edge (i, j) of `input` crosses the plane, shared by
    /// both faces of the edge.
    fn crossing(&mut self, input: &Polyhedron, out: &mut Polyhedron, i: usize, j: usize) -> usize {
        let key = (i.min(j), i.max(j));
        if let Some(&(_, _, index)) = self.crossings.iter().find(|c| (c.0, c.1) == key) {
            return index;
        }
        let (si, sj) = (self.distance[i], self.distance[j]);
        let t = si / (si - sj);
        let point = input.vertices[i].lerp(input.vertices[j], t);
        let index = out.vertices.len();
        out.vertices.push(point);
        self.crossings.push((key.0, key.1, index));
        self.cap.push((0.0, index));
        index
    }

    /// Close the cut with a face of the points on the plane (gathered in `cap` as the cut
    /// made or kept them), counter-clockwise seen from outside (along the plane's normal).
    fn close_cap(&mut self, plane: Plane, out: &mut Polyhedron) {
        if self.cap.len() < 3 {
            return;
        }
        let centre =
            self.cap.iter().map(|c| out.vertices[c.1]).sum::<DVec3>() / self.cap.len() as f64;
        let u = plane.normal.any_orthonormal_vector();
        let w = plane.normal.cross(u);
        for (angle, index) in &mut self.cap {
            let d = out.vertices[*index] - centre;
            *angle = pseudo_angle(d.dot(u), d.dot(w));
        }
        self.cap.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mut face = self.face_list();
        face.extend(self.cap.iter().map(|c| c.1));
        out.faces.push(face);
        out.planes.push(plane);
    }

    /// Write the intersection of `a` and `b` to `out` (empty when they do not overlap).
    pub fn intersect(&mut self, a: &Polyhedron, b: &Polyhedron, out: &mut Polyhedron) {
        let inside = |p: &Polyhedron, plane: &Plane| {
            p.vertices.iter().all(|&v| plane.distance(v) <= ON_PLANE)
        };
        // Most of a contact's planes leave the overlap whole: they cost no copy, and the
        // first that cuts cuts `a` itself.
        let Some(first) = b.planes.iter().position(|plane| !inside(a, plane)) else {
            self.copy(a, out);
            return;
        };
        self.clip(a, b.planes[first], out);
        let mut spare = std::mem::take(&mut self.spare);
        for &plane in &b.planes[first + 1..] {
            if out.faces.is_empty() {
                break;
            }
            if inside(out, &plane) {
                continue;
            }
            self.clip(out, plane, &mut spare);
            std::mem::swap(out, &mut spare);
        }
        self.spare = spare;
    }
}

/// Whether a vertex at `v`, `distance` from a plane, lies on it (to rounding, which grows
/// with the coordinates).
fn on_plane(v: DVec3, distance: f64) -> bool {
    distance.abs() <= 1e-9 * (1.0 + v.length())
}

/// A number that grows with the angle of (x, y) from the x axis, as atan2 does, from 0 to 4
/// over the turn: enough to sort points around a centre, at a fraction of atan2's cost.
fn pseudo_angle(x: f64, y: f64) -> f64 {
    let p = y / (x.abs() + y.abs()).max(f64::MIN_POSITIVE);
    if x < 0.0 {
        2.0 - p
    } else if y < 0.0 {
        4.0 + p
    } else {
        p
    }
}

//! The solids of a static scene as its proxies walk among them: the few primitives scanned
//! each step, a mesh's triangles (up to hundreds of thousands) found through a
//! bounding-volume hierarchy, so that a step costs about as much on a scanned part as on a
//! box.

use glam::DVec3;

use super::bvh::Bvh;
use super::obstacle::{Entry, Obstacles, SURFACE, Shape};

/// How far beyond its triangle's box a segment is still looked at: well past the rounding
/// [`Shape::entry`] allows for.
const MARGIN: f64 = 1e3 * SURFACE;

/// Shapes sorted for the walk: primitives, and triangles in a hierarchy.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scenery {
    primitives: Vec<Shape>,
    triangles: Vec<Shape>,
    /// Where each primitive, then each triangle, was among the shapes it was made from.
    places: Vec<usize>,
    tree: Bvh,
}

impl Scenery {
    /// The scenery of `shapes` (built here, off the haptic thread).
    pub fn new(shapes: &[Shape]) -> Self {
        let is_triangle = |s: &Shape| matches!(s, Shape::Triangle { .. });
        let (triangles, primitives): (Vec<Shape>, Vec<Shape>) =
            shapes.iter().partition(|s| is_triangle(s));
        let places = (0..shapes.len())
            .filter(|&i| !is_triangle(&shapes[i]))
            .chain((0..shapes.len()).filter(|&i| is_triangle(&shapes[i])))
            .collect();
        let boxes: Vec<(DVec3, DVec3)> = triangles
            .iter()
            .map(|t| match t {
                Shape::Triangle {
                    corners: [a, b, c], ..
                } => (a.min(*b).min(*c), a.max(*b).max(*c)),
                _ => unreachable!("partitioned"),
            })
            .collect();
        Self {
            tree: Bvh::build(&boxes),
            places,
            primitives,
            triangles,
        }
    }
}

impl Obstacles for Scenery {
    fn entries(&self, a: DVec3, b: DVec3, visit: &mut dyn FnMut(Entry)) {
        self.primitives.entries(a, b, visit);
        self.tree.visit_segment(a, b, MARGIN, |i| {
            if let Some(e) = self.triangles[i].entry(a, b) {
                visit(e);
            }
        });
    }
}

impl Scenery {
    /// [rt] The shape whose surface is nearest `p` (the one a proxy there rests on; its place
    /// among the shapes the scenery was made from) and its outward unit normal there: the
    /// primitives scanned, the triangles near `p` found in the tree; None with no solid near.
    pub fn nearest(&self, p: DVec3) -> Option<(usize, DVec3)> {
        self.nearest_within(p, MARGIN)
    }

    /// [rt] As [`nearest`](Self::nearest), looking at the triangles whose boxes `p` is within
    /// `reach` of.
    pub fn nearest_within(&self, p: DVec3, reach: f64) -> Option<(usize, DVec3)> {
        let mut nearest: Option<(f64, usize)> = None;
        let mut consider = |k: usize, shape: &Shape| {
            let d = shape.signed_distance(p).abs();
            if nearest.is_none_or(|(best, _)| d < best) {
                nearest = Some((d, k));
            }
        };
        for (k, shape) in self.primitives.iter().enumerate() {
            consider(k, shape);
        }
        let first = self.primitives.len();
        self.tree
            .visit_segment(p, p, reach, |i| consider(first + i, &self.triangles[i]));
        let (_, k) = nearest?;
        let shape = if k < first {
            &self.primitives[k]
        } else {
            &self.triangles[k - first]
        };
        // The distance's gradient, by central differences a micrometre apart.
        let h = 1e-6;
        let d = |e: DVec3| shape.signed_distance(p + e * h) - shape.signed_distance(p - e * h);
        let normal = DVec3::new(d(DVec3::X), d(DVec3::Y), d(DVec3::Z)).normalize_or_zero();
        Some((self.places[k], normal))
    }
}

//! A bounding-volume hierarchy of axis-aligned boxes, for finding the few triangles of a
//! large mesh that a proxy's step can reach: built once off the haptic thread (each node's
//! items split at the middle of the box's longest side, or at the median of their centres
//! where that leaves one side empty or the tree grows deep), walked in the haptic thread with
//! a stack of fixed size, so a query neither allocates nor recurses.

use std::time::Instant;

use glam::{DAffine3, DVec3};

/// Most items in a leaf: measured on the god-object's benchmark, two beat one, four and eight
/// (a pair of leaves pairs each item of one with each of the other's).
const LEAF: usize = 2;
/// Pairs a walk takes between looks at the clock (a look costs tens of nanoseconds, a pair
/// a few).
const CLOCK_EVERY: u32 = 64;
/// Levels split at the middle of a box, at most; deeper, at the median of the centres.
const MIDDLE_SPLITS: usize = 48;
/// Nodes a walk holds at once: one more than the tree is deep. Past [`MIDDLE_SPLITS`]
/// levels median splits halve the items at each level, so 2^47 items would be needed to
/// overflow it.
const DEPTH: usize = MIDDLE_SPLITS + 48;

/// One node: its box, and either its items (a leaf) or its second child (the first follows
/// it).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Node {
    low: DVec3,
    high: DVec3,
    /// Half the box's diagonal: the radius of the ball about its centre that holds it.
    radius: f64,
    /// A leaf's first item in [`Bvh::order`], or an inner node's second child.
    start: u32,
    /// A leaf's item count; 0 for an inner node.
    count: u32,
}

/// A hierarchy over items given by their boxes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Item indices, each leaf's together.
    order: Vec<u32>,
}

impl Bvh {
    /// The hierarchy of items whose boxes are `boxes` (lowest and highest corner each).
    pub fn build(boxes: &[(DVec3, DVec3)]) -> Self {
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * boxes.len() / LEAF + 1),
            order: (0..boxes.len() as u32).collect(),
        };
        if !boxes.is_empty() {
            bvh.split(boxes, 0, boxes.len(), 0);
        }
        bvh
    }

    /// The hierarchy of items whose boxes are `boxes`, the items renumbered in the order its
    /// leaves hold them (each leaf's items next to each other in the caller's arrays too,
    /// which a walk then reads without jumping about memory), and for each new number the
    /// item's old one.
    pub fn build_renumbered(boxes: &[(DVec3, DVec3)]) -> (Self, Vec<u32>) {
        let mut bvh = Self::build(boxes);
        let old = std::mem::replace(&mut bvh.order, (0..boxes.len() as u32).collect());
        (bvh, old)
    }

    /// Add the node of items `order[start..end]`, `level` deep, and its children; its index.
    fn split(&mut self, boxes: &[(DVec3, DVec3)], start: usize, end: usize, level: usize) -> usize {
        let items = &mut self.order[start..end];
        let (low, high) =
            items
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &i| {
                    let (a, b) = boxes[i as usize];
                    (l.min(a), h.max(b))
                });
        let index = self.nodes.len();
        self.nodes.push(Node {
            low,
            high,
            radius: (high - low).length() / 2.0,
            start: start as u32,
            count: items.len() as u32,
        });
        if items.len() <= LEAF {
            return index;
        }
        let extent = high - low;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let centre = |i: &u32| {
            let (a, b) = boxes[*i as usize];
            (a + b)[axis]
        };
        // The middle of the box first: a median among many centres at one coordinate (the
        // corners along a wall's vertical edges) leaves the few elsewhere in every leaf.
        let half = (low + high)[axis];
        let mut middle = 0;
        if level < MIDDLE_SPLITS {
            for k in 0..items.len() {
                if centre(&items[k]) < half {
                    items.swap(middle, k);
                    middle += 1;
                }
            }
        }
        if middle == 0 || middle == items.len() {
            middle = items.len() / 2;
            items.select_nth_unstable_by(middle, |x, y| centre(x).total_cmp(&centre(y)));
        }
        self.split(boxes, start, start + middle, level + 1);
        let second = self.split(boxes, start + middle, end, level + 1);
        self.nodes[index].start = second as u32;
        self.nodes[index].count = 0;
        index
    }

    /// [rt] Call `visit` with every item whose box, grown by `margin`, the segment from `a`
    /// to `b` meets (and perhaps a few more); no allocation.
    pub fn visit_segment(&self, a: DVec3, b: DVec3, margin: f64, visit: impl FnMut(usize)) {
        let d = b - a;
        let inverse = d.recip();
        self.walk(
            |node| meets(a, d, inverse, node.low - margin, node.high + margin),
            visit,
        );
    }

    /// [rt] Call `visit` with each item of the leaves whose nodes `enter` accepts, their
    /// parents accepted too; a stack of fixed size, no recursion.
    fn walk(&self, enter: impl Fn(&Node) -> bool, mut visit: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; DEPTH];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let at = stack[depth];
            let node = &self.nodes[at as usize];
            if !enter(node) {
                continue;
            }
            if node.count > 0 {
                let items = &self.order[node.start as usize..(node.start + node.count) as usize];
                for &i in items {
                    visit(i as usize);
                }
            } else {
                // Median splits keep the tree far shallower than the stack is deep.
                stack[depth] = at + 1;
                stack[depth + 1] = node.start;
                depth += 2;
            }
        }
    }

    /// [rt] Call `visit(mine, theirs)` with every pair of an item of this hierarchy and one
    /// of `other`'s whose boxes come within `reach` of each other (and perhaps a few more),
    /// `other`'s frame being `placed` in this one (turned and shifted only), going on with
    /// `walk` from where it stopped. Walks both trees together (the wider node of a pair
    /// split first), `other`'s boxes taken as the balls around them; a stack of fixed size,
    /// no allocation.
    ///
    /// True when the walk is done; false when the clock passed `deadline` first, `walk`
    /// then holding the pairs still to look at: called again with the same trees, placing
    /// and reach, it visits just those, each leaf's pairs whole in one call or the next.
    pub fn walk_pairs(
        &self,
        other: &Bvh,
        (placed, reach): (DAffine3, f64),
        walk: &mut PairWalk,
        deadline: Option<Instant>,
        mut visit: impl FnMut(usize, usize),
    ) -> bool {
        if self.nodes.is_empty() || other.nodes.is_empty() {
            walk.depth = 0;
            return true;
        }
        // The stack and its depth in the walk's place only between calls: the loop keeps
        // them where the compiler likes.
        let PairWalk { stack, depth } = walk;
        let mut at = *depth;
        let mut taken = 0u32;
        while at > 0 {
            taken = taken.wrapping_add(1);
            if taken.is_multiple_of(CLOCK_EVERY) && deadline.is_some_and(|d| Instant::now() >= d) {
                *depth = at;
                return false;
            }
            at -= 1;
            let (a, b) = stack[at];
            let (mine, theirs) = (&self.nodes[a as usize], &other.nodes[b as usize]);
            let centre = placed.transform_point3((theirs.low + theirs.high) / 2.0);
            let radius = theirs.radius;
            let gap = (mine.low - centre).max(centre - mine.high).max(DVec3::ZERO);
            if gap.length_squared() > (radius + reach) * (radius + reach) {
                continue;
            }
            match (mine.count > 0, theirs.count > 0) {
                (true, true) => {
                    // Each of theirs in turn with all of mine: a caller that places theirs
                    // does so once for the run of calls.
                    for &j in
                        &other.order[theirs.start as usize..(theirs.start + theirs.count) as usize]
                    {
                        for &i in
                            &self.order[mine.start as usize..(mine.start + mine.count) as usize]
                        {
                            visit(i as usize, j as usize);
                        }
                    }
                }
                (leaf, other_leaf) => {
                    let wider = mine.radius >= radius;
                    if !leaf && (other_leaf || wider) {
                        stack[at] = (a + 1, b);
                        stack[at + 1] = (mine.start, b);
                    } else {
                        stack[at] = (a, b + 1);
                        stack[at + 1] = (a, theirs.start);
                    }
                    at += 2;
                }
            }
        }
        *depth = 0;
        true
    }
}

/// Where a walk of two hierarchies' pairs stands ([`Bvh::walk_pairs`]): the pairs of nodes
/// still to look at. A new one stands at the roots.
#[derive(Debug, Clone)]
pub struct PairWalk {
    /// Each pair taken off pushes at most two, each a level deeper in one tree.
    stack: [(u32, u32); 2 * DEPTH],
    depth: usize,
}

impl Default for PairWalk {
    fn default() -> Self {
        Self {
            stack: [(0, 0); 2 * DEPTH],
            depth: 1,
        }
    }
}

impl PairWalk {
    /// [rt] Start again from the roots.
    pub fn restart(&mut self) {
        (self.stack[0], self.depth) = ((0, 0), 1);
    }
}

/// Whether the segment `a + s·d`, s in [0, 1], meets the box from `low` to `high` (slabs; a
/// direction component of 0 leaves that slab to the start point alone).
fn meets(a: DVec3, d: DVec3, inverse: DVec3, low: DVec3, high: DVec3) -> bool {
    let (mut enter, mut leave) = (0.0f64, 1.0f64);
    for k in 0..3 {
        if d[k] == 0.0 {
            if a[k] < low[k] || a[k] > high[k] {
                return false;
            }
            continue;
        }
        let (t0, t1) = ((low[k] - a[k]) * inverse[k], (high[k] - a[k]) * inverse[k]);
        enter = enter.max(t0.min(t1));
        leave = leave.min(t0.max(t1));
        if enter > leave {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reproducible point in the unit cube.
    fn point(k: u64) -> DVec3 {
        let hash = |s: u64| {
            let x = (k.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ s).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        DVec3::new(hash(1), hash(2), hash(3))
    }

    #[test]
    fn a_segment_visits_every_box_it_meets_as_a_scan_of_all_of_them_finds() {
        let boxes: Vec<(DVec3, DVec3)> = (0..5000)
            .map(|k| {
                let c = point(k);
                (c - 0.004, c + 0.004 + point(k + 99_999) * 0.01)
            })
            .collect();
        let bvh = Bvh::build(&boxes);
        for k in 0..300 {
            let (a, b) = (
                point(10_000 + k),
                point(20_000 + k) * 0.05 + point(10_000 + k),
            );
            let margin = 1e-3;
            let mut visited = Vec::new();
            bvh.visit_segment(a, b, margin, |i| visited.push(i));
            visited.sort_unstable();
            let d = b - a;
            let expected: Vec<usize> = (0..boxes.len())
                .filter(|&i| meets(a, d, d.recip(), boxes[i].0 - margin, boxes[i].1 + margin))
                .collect();
            // Every box the segment meets, each once, and few others: those sharing a leaf.
            assert!(visited.windows(2).all(|w| w[0] < w[1]), "segment {k}");
            assert!(
                expected.iter().all(|i| visited.binary_search(i).is_ok()),
                "segment {k}"
            );
            assert!(
                visited.len() <= 4 * expected.len() + 16,
                "segment {k}: {}",
                visited.len()
            );
        }
        // A segment along an axis, and one that is a point.
        let mut seen = 0;
        let (a, b) = (DVec3::new(0.5, 0.5, -1.0), DVec3::new(0.5, 0.5, 2.0));
        bvh.visit_segment(a, b, 0.0, |i| {
            let (l, h) = boxes[i];
            seen += usize::from(l.x <= 0.5 && h.x >= 0.5 && l.y <= 0.5 && h.y >= 0.5);
        });
        assert_eq!(
            seen,
            boxes
                .iter()
                .filter(|(l, h)| l.x <= 0.5 && h.x >= 0.5 && l.y <= 0.5 && h.y >= 0.5)
                .count()
        );
        let p = boxes[7].0 + 1e-6;
        let mut found = false;
        bvh.visit_segment(p, p, 0.0, |i| found |= i == 7);
        assert!(found);
    }
}

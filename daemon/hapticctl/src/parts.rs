//! Parts to put together, as closed triangle meshes made to measure: pegs of any section
//! and blocks with holes, with the exact distance to each solid, so that how far one went
//! into the other is measured by the solids' own formulas and not by the meshes' queries
//! under test (`hapticctl experiment peg-in-hole`, the god-object's tests and benchmark).

use glam::{DQuat, DVec3};
use hapticd_core::haptics::signed_mesh::SignedMesh;

/// Millimetres.
pub const MM: f64 = 1e-3;
/// The creases' samples' spacing.
pub const SPACING: f64 = 0.1 * MM;

/// A right prism's cross-section: `sides` sides at `apothem` from its axis (y), a side's
/// middle on +x.
#[derive(Debug, Clone, Copy)]
pub struct Section {
    /// How many sides.
    pub sides: usize,
    /// The distance of each side from the axis, metres.
    pub apothem: f64,
}

impl Section {
    /// Its corners at height `y`, counter-clockwise seen from above.
    pub fn ring(&self, y: f64) -> Vec<DVec3> {
        let n = self.sides as f64;
        let radius = self.apothem / (std::f64::consts::PI / n).cos();
        (0..self.sides)
            .map(|i| {
                let angle = (i as f64 + 0.5) * std::f64::consts::TAU / n;
                DVec3::new(radius * angle.cos(), y, -radius * angle.sin())
            })
            .collect()
    }

    /// How deep `p` is inside the prism between heights `low` and `high` (0 outside),
    /// exactly, its `ring` at height 0 given.
    pub fn depth(&self, ring: &[DVec3], p: DVec3, low: f64, high: f64) -> f64 {
        let mut deepest = (p.y - low).min(high - p.y);
        for i in 0..self.sides {
            let normal = (ring[i] + ring[(i + 1) % self.sides]).normalize();
            deepest = deepest.min(self.apothem - DVec3::new(p.x, 0.0, p.z).dot(normal));
            if deepest <= 0.0 {
                return 0.0;
            }
        }
        deepest
    }

    /// How far `p` is outside the prism between heights `low` and `high` (0 inside),
    /// exactly, its `ring` at height 0 given.
    pub fn outside(&self, ring: &[DVec3], p: DVec3, low: f64, high: f64) -> f64 {
        let flat = DVec3::new(p.x, 0.0, p.z);
        let beside = (0..self.sides).any(|i| {
            let normal = (ring[i] + ring[(i + 1) % self.sides]).normalize();
            flat.dot(normal) > self.apothem
        });
        // Beside it, the nearest side's segment across.
        let across = if beside {
            (0..self.sides)
                .map(|i| {
                    let (a, b) = (ring[i], ring[(i + 1) % self.sides]);
                    let t = ((flat - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                    (flat - (a + (b - a) * t)).length()
                })
                .fold(f64::INFINITY, f64::min)
        } else {
            0.0
        };
        let along = (low - p.y).max(p.y - high).max(0.0);
        across.hypot(along)
    }
}

/// A mesh being built: triangles wound by which way each should face.
#[derive(Default)]
struct Builder {
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

impl Builder {
    /// A triangle facing `outward` (its winding chosen for it).
    fn triangle(&mut self, a: DVec3, b: DVec3, c: DVec3, outward: DVec3) {
        let n = self.vertices.len() as u32;
        let (b, c) = if (b - a).cross(c - a).dot(outward) >= 0.0 {
            (b, c)
        } else {
            (c, b)
        };
        self.vertices.extend([a, b, c]);
        self.triangles.push([n, n + 1, n + 2]);
    }

    /// The band of quads between two rings, facing away from (or towards, `inward`) the axis.
    fn band(&mut self, lower: &[DVec3], upper: &[DVec3], inward: bool) {
        let n = lower.len();
        for i in 0..n {
            let j = (i + 1) % n;
            let middle = (lower[i] + lower[j]) / 2.0;
            let out = DVec3::new(middle.x, 0.0, middle.z) * if inward { -1.0 } else { 1.0 };
            self.triangle(lower[i], lower[j], upper[j], out);
            self.triangle(lower[i], upper[j], upper[i], out);
        }
    }

    /// The side of a prism of `section` from height `low` to `high`, in layers no taller
    /// than `step`, facing away from (or towards, `inward`) the axis.
    fn side(&mut self, section: Section, (low, high): (f64, f64), step: f64, inward: bool) {
        let layers = ((high - low) / step).ceil().max(1.0) as usize;
        let at = |k: usize| low + (high - low) * k as f64 / layers as f64;
        for k in 0..layers {
            self.band(&section.ring(at(k)), &section.ring(at(k + 1)), inward);
        }
    }

    /// The flat ring at height `y` between sections of `sides` sides at apothems `inner`
    /// (0: a disc) and `outer`, in rings no wider than `step`, facing `outward`.
    fn flat(
        &mut self,
        sides: usize,
        (inner, outer): (f64, f64),
        y: f64,
        step: f64,
        outward: DVec3,
    ) {
        let rings = ((outer - inner) / step).ceil().max(1.0) as usize;
        let ring = |k: usize| {
            let apothem = inner + (outer - inner) * k as f64 / rings as f64;
            Section { sides, apothem }.ring(y)
        };
        for k in 0..rings {
            let (near, far) = (ring(k), ring(k + 1));
            if k == 0 && inner == 0.0 {
                let centre = DVec3::new(0.0, y, 0.0);
                for i in 0..sides {
                    self.triangle(centre, far[i], far[(i + 1) % sides], outward);
                }
                continue;
            }
            for i in 0..sides {
                let j = (i + 1) % sides;
                self.triangle(far[i], far[j], near[j], outward);
                self.triangle(far[i], near[j], near[i], outward);
            }
        }
    }

    fn mesh(&self) -> SignedMesh {
        SignedMesh::new(&self.vertices, &self.triangles, SPACING).expect("a closed surface")
    }
}

/// A peg of `section` and `length`, its frame at its middle.
pub fn peg(section: Section, length: f64) -> SignedMesh {
    fine_peg(section, length, f64::INFINITY)
}

/// A peg as [`peg`] gives, its faces cut into triangles no wider than about `step`.
pub fn fine_peg(section: Section, length: f64, step: f64) -> SignedMesh {
    let mut b = Builder::default();
    let half = length / 2.0;
    b.side(section, (-half, half), step, false);
    for (y, outward) in [(-half, -DVec3::Y), (half, DVec3::Y)] {
        b.flat(section.sides, (0.0, section.apothem), y, step, outward);
    }
    b.mesh()
}

/// A block of `outer` section and `height` whose top is at y = 0, a hole of `hole` section
/// and `depth` down from its top.
pub struct Block {
    /// Its outside.
    pub outer: Section,
    /// Its hole's.
    pub hole: Section,
    /// Its height, metres.
    pub height: f64,
    /// Its hole's depth, metres.
    pub depth: f64,
}

impl Block {
    /// Its mesh, each face as few triangles as make it.
    pub fn mesh(&self) -> SignedMesh {
        self.fine_mesh(f64::INFINITY)
    }

    /// The mesh as [`Block::mesh`] gives it, its faces cut into triangles no wider than
    /// about `step`.
    pub fn fine_mesh(&self, step: f64) -> SignedMesh {
        let mut b = Builder::default();
        let (outer, hole, sides) = (self.outer, self.hole, self.outer.sides);
        b.side(outer, (-self.height, 0.0), step, false);
        b.flat(sides, (0.0, outer.apothem), -self.height, step, -DVec3::Y);
        b.flat(sides, (hole.apothem, outer.apothem), 0.0, step, DVec3::Y);
        b.side(hole, (-self.depth, 0.0), step, true);
        b.flat(sides, (0.0, hole.apothem), -self.depth, step, DVec3::Y);
        b.mesh()
    }

    /// How deep `p` is inside the block's solid (0 outside), exactly, its sections'
    /// `rings` at height 0 given.
    pub fn depth(&self, rings: &[Vec<DVec3>; 2], p: DVec3) -> f64 {
        match self.outer.depth(&rings[0], p, -self.height, 0.0) {
            0.0 => 0.0,
            inside => inside.min(self.hole.outside(&rings[1], p, -self.depth, 1.0)),
        }
    }
}

/// How deep a peg and its block are in each other, by the exact formulas of both solids at
/// points 50 µm apart along every edge of both.
pub struct Overlap {
    peg_points: Vec<DVec3>,
    block_points: Vec<DVec3>,
    peg_ring: Vec<DVec3>,
    block_rings: [Vec<DVec3>; 2],
}

impl Overlap {
    /// For the peg of `section` as `peg` meshes it and the block as `solid` meshes it.
    pub fn new(
        (peg, section): (&SignedMesh, Section),
        (solid, block): (&SignedMesh, &Block),
    ) -> Self {
        // Only the block's edges around its hole can reach a peg in or over it.
        let near_hole = |p: &DVec3| DVec3::new(p.x, 0.0, p.z).length() < 1.5 * block.hole.apothem;
        Self {
            peg_points: edge_points(peg, 0.05 * MM),
            block_points: edge_points(solid, 0.05 * MM)
                .into_iter()
                .filter(near_hole)
                .collect(),
            peg_ring: section.ring(0.0),
            block_rings: [block.outer.ring(0.0), block.hole.ring(0.0)],
        }
    }

    /// The deepest a point of either went into the other, metres, with the block where it
    /// is made and the peg (`section`, `length` long) at `pose` in the block's frame.
    pub fn at(
        &self,
        block: &Block,
        (section, length): (Section, f64),
        (at, turn): (DVec3, DQuat),
    ) -> f64 {
        let into_block = (self.peg_points.iter())
            .map(|&p| block.depth(&self.block_rings, turn * p + at))
            .fold(0.0, f64::max);
        let back = turn.inverse();
        let into_peg = (self.block_points.iter())
            .map(|&p| section.depth(&self.peg_ring, back * (p - at), -length / 2.0, length / 2.0))
            .fold(0.0, f64::max);
        into_block.max(into_peg)
    }
}

/// Points every `step` along each edge of `mesh`'s triangles, in its frame.
pub fn edge_points(mesh: &SignedMesh, step: f64) -> Vec<DVec3> {
    let mut points = Vec::new();
    for [a, b, c] in mesh.triangles() {
        for (p, q) in [(a, b), (b, c), (c, a)] {
            let n = ((q - p).length() / step).ceil().max(1.0) as usize;
            points.extend((0..n).map(|i| p.lerp(q, i as f64 / n as f64)));
        }
    }
    points.sort_unstable_by(|x, y| x.to_array().partial_cmp(&y.to_array()).unwrap());
    points.dedup();
    points
}

/// A square peg 10 mm wide and 20 mm long, and its block: a hole 0.2 mm wider and 15 mm
/// deep, 30 mm across and 25 mm tall.
pub fn square_peg_and_block() -> (SignedMesh, Section, Block) {
    let section = Section {
        sides: 4,
        apothem: 5.0 * MM,
    };
    let block = Block {
        outer: Section {
            sides: 4,
            apothem: 15.0 * MM,
        },
        hole: Section {
            sides: 4,
            apothem: 5.1 * MM,
        },
        height: 25.0 * MM,
        depth: 15.0 * MM,
    };
    (peg(section, 20.0 * MM), section, block)
}

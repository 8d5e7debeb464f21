//! The rest state's step system, factored: M + s·K₀ over the free nodes (K₀ the stiffness
//! at rest, s = β·dt + dt² for the step it is made for), as L·D·Lᵀ in a fill-reducing order
//! (approximate minimum degree over the nodes, each node's three directions kept together,
//! factored a node's 3 × 3 block at a time: 20 250 elements in 1.4 s where a number at a
//! time took 6.3 s).
//! Made once, outside the tick; solving with it allocates nothing. It preconditions the
//! step's solve: where the elements have turned little, it is nearly the step's own system,
//! and one or two iterations suffice.

use std::collections::BTreeMap;

use glam::{DMat3, DVec3, Mat3A, Vec3A};

use crate::body::SoftBody;
use crate::element::MOST_NODES;

/// No node: an index past every node.
const NONE: usize = usize::MAX;

/// Why a factor could not be made.
#[derive(Debug, Clone, PartialEq)]
pub enum FactorError {
    /// The ordering refused the system's pattern.
    Ordering(String),
    /// A pivot was not positive: the system is not positive definite (a material or step
    /// that is not physical).
    NotPositive,
}

/// The factored rest system.
#[derive(Debug, Clone)]
pub struct Factor {
    /// The step factor s it was made for.
    pub stiff: f64,
    /// The material's λ and μ it was made of, Pa.
    lame: [f64; 2],
    /// Each node's place in the factor's order, NONE for a pinned node.
    place: Vec<usize>,
    /// L and D.
    lower: Lower,
    /// The unknowns, by node in the factor's order, to solve in.
    work: Work,
}

/// L·D·Lᵀ by 3×3 blocks, a node's three directions together.
#[derive(Debug, Clone)]
struct Lower {
    /// Within each node: its entries of L below the diagonal, (1, 0), (2, 0) and (2, 1).
    within: Vec<[f64; 3]>,
    /// Below each node's block, its column's blocks: starts, rows (nodes) and the blocks
    /// (column b of a block is L's column 3J + b, rows 3I to 3I + 2). In single precision:
    /// they are most of what a solve reads, and a large body's solve waits on memory (a
    /// step of 20 250 tetrahedra at 60 Hz: 14.9 ms in double, 12.2 ms in single, median of
    /// `cargo bench -p hapticd-e2e --bench soft -- multirate`); a preconditioner needs no
    /// more digits.
    starts: Vec<usize>,
    rows: Vec<usize>,
    blocks: Vec<Mat3A>,
    /// D⁻¹, by node.
    inverse_pivots: Vec<DVec3>,
}

/// The unknowns a solve works on: in single-precision SIMD lanes where the system's pivots
/// spread little (a solve of 2 058 tetrahedra's rest system took 53 µs in lanes, 93 µs in
/// double, the fastest of 5 000 side by side), in double where they spread beyond
/// [`SINGLE_SPREAD`].
#[derive(Debug, Clone)]
enum Work {
    Single(Vec<Vec3A>),
    Double(Vec<DVec3>),
}

/// The largest ratio of the largest pivot to the smallest solved in single precision. A
/// tick's system spreads 12–20 (1 kHz), a physics step's 19–111 (60 Hz), a static solve's
/// with its pins 497; one of a body pinned since its factor was made, solved statically,
/// 7.7·10¹²: its free motions weigh nothing beside its stiffness, in single precision
/// their part of a solve was lost, and a search that should end at 10⁻¹⁸ ran its 9 900
/// iterations out at 0.06.
const SINGLE_SPREAD: f64 = 1e6;

impl Factor {
    /// The factor of `body`'s rest system for steps of factor `stiff` (β·dt + dt²).
    pub fn new(body: &SoftBody, stiff: f64) -> Result<Factor, FactorError> {
        let nodes = body.positions.len();
        // The free nodes' graph, for their order.
        let free: Vec<usize> = (0..nodes).filter(|&i| !body.pinned[i]).collect();
        let mut index = vec![NONE; nodes];
        for (k, &i) in free.iter().enumerate() {
            index[i] = k;
        }
        let entries = rest_system(body, stiff, &index);
        let mut neighbours = vec![Vec::new(); free.len()];
        for &(a, b) in entries.keys() {
            if a / 3 != b / 3 {
                neighbours[a / 3].push(b / 3);
            }
        }
        let (mut starts, mut rows) = (vec![0], Vec::new());
        for list in &mut neighbours {
            list.sort_unstable();
            list.dedup();
            rows.extend_from_slice(list);
            starts.push(rows.len());
        }
        let (order, _, _) = amd::order(free.len(), &starts, &rows, &amd::Control::default())
            .map_err(|status| FactorError::Ordering(format!("{status:?}")))?;
        // Node order[k] is the factor's k-th: its unknowns 3k to 3k + 2.
        let mut place = vec![NONE; nodes];
        let mut moved = vec![0; free.len()];
        for (k, &node) in order.iter().enumerate() {
            place[free[node]] = k;
            moved[node] = k;
        }
        // The permuted system's node columns, the upper triangle's blocks (row ≤ column).
        let nodes_free = free.len();
        let mut by_column: Vec<BTreeMap<usize, DMat3>> = vec![BTreeMap::new(); nodes_free];
        for (&(a, b), &v) in &entries {
            let (row, column) = (moved[a / 3], moved[b / 3]);
            if row <= column {
                by_column[column]
                    .entry(row)
                    .or_insert(DMat3::ZERO)
                    .col_mut(b % 3)[a % 3] = v;
            }
        }
        let columns: Vec<Vec<(usize, DMat3)>> = by_column
            .into_iter()
            .map(|c| c.into_iter().collect())
            .collect();
        let (block_starts, block_rows, unit, pivots) = block_ldl(&columns)?;
        // Each node's pivot block is W·D·Wᵀ, and below it L̃·W: the scalar L·D·Lᵀ in this
        // order.
        let (within, diagonal): (Vec<[f64; 3]>, Vec<DVec3>) = pivots.into_iter().unzip();
        let smallest = diagonal
            .iter()
            .map(|d| d.min_element())
            .fold(f64::MAX, f64::min);
        let largest = diagonal.iter().map(|d| d.max_element()).fold(0.0, f64::max);
        let mut blocks = Vec::with_capacity(unit.len());
        for (j, [l10, l20, l21]) in within.iter().copied().enumerate() {
            let w = DMat3::from_cols(
                DVec3::new(1.0, l10, l20),
                DVec3::new(0.0, 1.0, l21),
                DVec3::Z,
            );
            for block in &unit[block_starts[j]..block_starts[j + 1]] {
                blocks.push(Mat3A::from((*block * w).as_mat3()));
            }
        }
        let work = match largest <= SINGLE_SPREAD * smallest {
            true => Work::Single(vec![Vec3A::ZERO; nodes_free]),
            false => Work::Double(vec![DVec3::ZERO; nodes_free]),
        };
        Ok(Factor {
            stiff,
            lame: body.lame,
            place,
            lower: Lower {
                within,
                starts: block_starts,
                rows: block_rows,
                blocks,
                inverse_pivots: diagonal.iter().map(|d| d.recip()).collect(),
            },
            work,
        })
    }

    /// Whether it was made of `body`'s material for steps of factor `stiff`, to the rounding
    /// of a period counted in nanoseconds (a physics thread's 60 Hz is 16 666 667 ns, not
    /// 1/60 s).
    pub fn made_for(&self, body: &SoftBody, stiff: f64) -> bool {
        (self.stiff - stiff).abs() <= 1e-6 * stiff && self.lame == body.lame
    }

    /// Whether node `i` was free when it was made (a pinned node has no unknowns in it).
    pub fn holds(&self, i: usize) -> bool {
        self.place[i] != NONE
    }

    /// The blocks a solve reads, each twice: what it costs.
    pub fn work(&self) -> usize {
        2 * (self.lower.blocks.len() + self.lower.within.len())
    }

    /// `out` = (M + s·K₀)⁻¹·`rhs` over the free nodes; zero at pinned ones.
    pub fn solve(&mut self, rhs: &[DVec3], out: &mut [DVec3]) {
        match &mut self.work {
            Work::Single(x) => self.lower.solve(&self.place, x, rhs, out),
            Work::Double(x) => self.lower.solve(&self.place, x, rhs, out),
        }
    }
}

impl Lower {
    /// `out` = (L·D·Lᵀ)⁻¹·`rhs` in unknowns `x`, each node at its `place` in the order.
    fn solve<U: Unknowns>(&self, place: &[usize], x: &mut [U], rhs: &[DVec3], out: &mut [DVec3]) {
        for (i, &k) in place.iter().enumerate() {
            if k != NONE {
                x[k] = U::of(rhs[i]);
            }
        }
        // L, then D, then Lᵀ, a node at a time.
        for j in 0..x.len() {
            let [l10, l20, l21] = self.within[j];
            let mut xj = x[j].back();
            xj.y -= l10 * xj.x;
            xj.z -= l20 * xj.x + l21 * xj.y;
            let xj = U::of(xj);
            x[j] = xj;
            for p in self.starts[j]..self.starts[j + 1] {
                let row = &mut x[self.rows[p]];
                *row = row.less(&self.blocks[p], xj);
            }
        }
        for j in (0..x.len()).rev() {
            let (column, rows) = (self.starts[j], self.starts[j + 1]);
            let below = x[j].scaled(self.inverse_pivots[j]).less_transposed(
                &self.blocks[column..rows],
                &self.rows[column..rows],
                x,
            );
            let mut xj = below.back();
            let [l10, l20, l21] = self.within[j];
            xj.y -= l21 * xj.z;
            xj.x -= l10 * xj.y + l20 * xj.z;
            x[j] = U::of(xj);
        }
        for (i, &k) in place.iter().enumerate() {
            out[i] = if k == NONE { DVec3::ZERO } else { x[k].back() };
        }
    }
}

/// A node's three unknowns as a solve carries them.
trait Unknowns: Copy {
    /// Of double-precision values.
    fn of(v: DVec3) -> Self;
    /// As double-precision values.
    fn back(self) -> DVec3;
    /// Each times its pivot's inverse in `d`.
    fn scaled(self, d: DVec3) -> Self;
    /// Less `block`·`x`.
    fn less(self, block: &Mat3A, x: Self) -> Self;
    /// Less Σ `blocks[p]`ᵀ·`x[rows[p]]`.
    fn less_transposed(self, blocks: &[Mat3A], rows: &[usize], x: &[Self]) -> Self;
}

impl Unknowns for Vec3A {
    fn of(v: DVec3) -> Self {
        Vec3A::from(v.as_vec3())
    }

    fn back(self) -> DVec3 {
        self.as_dvec3()
    }

    fn scaled(self, d: DVec3) -> Self {
        self * Vec3A::from(d.as_vec3())
    }

    fn less(self, block: &Mat3A, x: Self) -> Self {
        self - *block * x
    }

    fn less_transposed(self, blocks: &[Mat3A], rows: &[usize], x: &[Self]) -> Self {
        // Each column of the blocks times its rows' unknowns lane by lane, the lanes summed
        // at the end: no block is turned over.
        let mut sums = [Vec3A::ZERO; 3];
        for (b, &row) in blocks.iter().zip(rows) {
            let xi = x[row];
            sums[0] += b.x_axis * xi;
            sums[1] += b.y_axis * xi;
            sums[2] += b.z_axis * xi;
        }
        self - Vec3A::from(sums.map(|s| s.element_sum()))
    }
}

impl Unknowns for DVec3 {
    fn of(v: DVec3) -> Self {
        v
    }

    fn back(self) -> DVec3 {
        self
    }

    fn scaled(self, d: DVec3) -> Self {
        self * d
    }

    fn less(self, block: &Mat3A, x: Self) -> Self {
        self - block.as_dmat3() * x
    }

    fn less_transposed(self, blocks: &[Mat3A], rows: &[usize], x: &[Self]) -> Self {
        let mut sum = DVec3::ZERO;
        for (b, &row) in blocks.iter().zip(rows) {
            sum += b.as_dmat3().transpose() * x[row];
        }
        self - sum
    }
}

/// The rest system M + s·K₀ of `body`'s free nodes (`index`: each node's place among them,
/// NONE if pinned), by unknown (3·place + direction), both triangles.
fn rest_system(body: &SoftBody, stiff: f64, index: &[usize]) -> BTreeMap<(usize, usize), f64> {
    let mut entries = BTreeMap::new();
    let n = body.mesh.order.nodes();
    let mut unit = [DVec3::ZERO; MOST_NODES];
    let mut column = [DVec3::ZERO; MOST_NODES];
    for e in 0..body.mesh.element_count() {
        let nodes = body.mesh.element(e);
        // Each column of the element's stiffness: its response to one node moved one way.
        for b in 0..n {
            for db in 0..3 {
                unit[..n].fill(DVec3::ZERO);
                unit[b][db] = 1.0;
                body.stiffness_times(e, &unit, &mut column);
                let col = index[nodes[b] as usize];
                if col == NONE {
                    continue;
                }
                for a in 0..n {
                    let row = index[nodes[a] as usize];
                    if row == NONE {
                        continue;
                    }
                    for (da, value) in column[a].to_array().into_iter().enumerate() {
                        *entries.entry((3 * row + da, 3 * col + db)).or_insert(0.0) +=
                            stiff * value;
                    }
                }
            }
        }
    }
    for (i, &k) in index.iter().enumerate() {
        if k != NONE {
            for d in 0..3 {
                *entries.entry((3 * k + d, 3 * k + d)).or_insert(0.0) += body.masses[i];
            }
        }
    }
    entries
}

/// L̃·P·L̃ᵀ of the symmetric matrix of 3×3 blocks whose upper triangle `columns` holds
/// (each node column's rows, ascending, and blocks), L̃ unit lower triangular by blocks and
/// P block diagonal, up-looking a node's row at a time along the elimination tree: L̃'s
/// column starts, rows and blocks (its identity diagonal left out), and each block of P as
/// its own W·D·Wᵀ ([`small_ldl`]). A node's three directions go together, so each step of
/// the walk moves nine numbers, not one.
type BlockLdl = (Vec<usize>, Vec<usize>, Vec<DMat3>, Vec<([f64; 3], DVec3)>);

fn block_ldl(columns: &[Vec<(usize, DMat3)>]) -> Result<BlockLdl, FactorError> {
    let n = columns.len();
    // The elimination tree and each column's count.
    let (mut parent, mut flag, mut count) = (vec![NONE; n], vec![NONE; n], vec![0usize; n]);
    for k in 0..n {
        flag[k] = k;
        for &(mut i, _) in &columns[k] {
            while i < k && flag[i] != k {
                if parent[i] == NONE {
                    parent[i] = k;
                }
                count[i] += 1;
                flag[i] = k;
                i = parent[i];
            }
        }
    }
    let mut starts = vec![0; n + 1];
    for k in 0..n {
        starts[k + 1] = starts[k] + count[k];
    }
    let (mut rows, mut blocks) = (vec![0; starts[n]], vec![DMat3::ZERO; starts[n]]);
    let (mut pivots, mut inverses) = (Vec::with_capacity(n), vec![DMat3::ZERO; n]);
    let (mut y, mut pattern) = (vec![DMat3::ZERO; n], vec![0; n]);
    count.fill(0);
    for k in 0..n {
        // Row k of L̃: the nodes above the diagonal it reaches, along the tree.
        let mut top = n;
        flag[k] = k;
        for &(mut i, block) in &columns[k] {
            y[i] += block.transpose();
            let mut len = 0;
            while flag[i] != k {
                pattern[len] = i;
                len += 1;
                flag[i] = k;
                i = parent[i];
            }
            while len > 0 {
                top -= 1;
                len -= 1;
                pattern[top] = pattern[len];
            }
        }
        let mut pivot = y[k];
        y[k] = DMat3::ZERO;
        for &i in &pattern[top..n] {
            let yi = y[i];
            y[i] = DMat3::ZERO;
            let end = starts[i] + count[i];
            for p in starts[i]..end {
                y[rows[p]] -= yi * blocks[p].transpose();
            }
            let l = yi * inverses[i];
            pivot -= l * yi.transpose();
            rows[end] = k;
            blocks[end] = l;
            count[i] += 1;
        }
        pivots.push(small_ldl(&pivot).ok_or(FactorError::NotPositive)?);
        inverses[k] = pivot.inverse();
    }
    Ok((starts, rows, blocks, pivots))
}

/// W·D·Wᵀ of the symmetric 3×3 block `p`, W unit lower triangular: W's entries below its
/// diagonal, (1, 0), (2, 0) and (2, 1), and D; None unless every pivot is positive.
fn small_ldl(p: &DMat3) -> Option<([f64; 3], DVec3)> {
    let at = |r: usize, c: usize| p.col(c)[r];
    let d0 = at(0, 0);
    let (l10, l20) = (at(1, 0) / d0, at(2, 0) / d0);
    let d1 = at(1, 1) - l10 * l10 * d0;
    let l21 = (at(2, 1) - l20 * l10 * d0) / d1;
    let d2 = at(2, 2) - l20 * l20 * d0 - l21 * l21 * d1;
    let positive = [d0, d1, d2].iter().all(|&d| d > 0.0);
    positive.then_some(([l10, l20, l21], DVec3::new(d0, d1, d2)))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::element::Order;
    use crate::lattice::cut_box;
    use crate::material::Material;

    /// A rubber block 3 × 2 × 2.5 cm cut at 1 cm, its bottom face pinned, and the step
    /// factor of a device tick for it.
    pub(crate) fn pinned_block(order: Order) -> (SoftBody, f64) {
        let mesh = cut_box(DVec3::ZERO, DVec3::new(0.03, 0.02, 0.025), 0.01, order);
        let material = Material {
            young: 1e5,
            poisson: 0.45,
            density: 1100.0,
            damping: 0.002,
        };
        let mut body = SoftBody::new(mesh, material);
        body.pin_below(1, -0.02);
        (body, material.step_factor(0.001))
    }

    /// Loads of unit size on `nodes` nodes, each its own way.
    pub(crate) fn unit_loads(nodes: usize) -> Vec<DVec3> {
        (0..nodes)
            .map(|i| {
                let t = i as f64;
                DVec3::new(t.sin(), (1.3 * t).cos(), (0.7 * t).sin())
            })
            .collect()
    }

    /// The factor solves the rest system it was made of: (M + s·K₀)·x = b to the rounding of
    /// single precision, for both orders, with a face pinned. A tick's system is solved in
    /// single precision (deterministic): b's unit entries come back within 1.4·10⁻⁶
    /// (linear) and 7.5·10⁻⁶ (quadratic), where its blocks alone in single left 2.7·10⁻⁷
    /// and 5.7·10⁻⁷.
    #[test]
    fn the_factor_solves_the_rest_system() {
        for order in [Order::Linear, Order::Quadratic] {
            let (body, stiff) = pinned_block(order);
            let mut factor = Factor::new(&body, stiff).unwrap();
            let nodes = body.positions.len();
            let b = unit_loads(nodes);
            let mut x = vec![DVec3::ZERO; nodes];
            factor.solve(&b, &mut x);
            let mut back = vec![DVec3::ZERO; nodes];
            body.system_times(stiff, &x, &mut back);
            for i in 0..nodes {
                let want = if body.pinned[i] { DVec3::ZERO } else { b[i] };
                assert!(
                    (back[i] - want).length() < 2e-5,
                    "{order:?} {i}: {} vs {want}",
                    back[i]
                );
            }
        }
    }
}

//! The rest state's step system, factored: M + s·K₀ over the free nodes (K₀ the stiffness
//! at rest, s = β·dt + dt² for the step it is made for), as L·D·Lᵀ in a fill-reducing order
//! (approximate minimum degree over the nodes, each node's three directions kept together).
//! Made once, outside the tick; solving with it allocates nothing. It preconditions the
//! step's solve: where the elements have turned little, it is nearly the step's own system,
//! and one or two iterations suffice.

use std::collections::BTreeMap;

use glam::DVec3;

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
    /// Each node's first unknown in the factor's order, NONE for a pinned node.
    unknown: Vec<usize>,
    /// L's columns (without its unit diagonal): starts, rows and values.
    starts: Vec<usize>,
    rows: Vec<usize>,
    values: Vec<f64>,
    /// D.
    pivots: Vec<f64>,
    /// A vector of unknowns, to solve in.
    work: Vec<f64>,
}

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
        // Unknown 3k + d in the factor is direction d of node order[k].
        let mut unknown = vec![NONE; nodes];
        let mut place = vec![0; 3 * free.len()];
        for (k, &node) in order.iter().enumerate() {
            unknown[free[node]] = 3 * k;
            for d in 0..3 {
                place[3 * node + d] = 3 * k + d;
            }
        }
        // The permuted system's columns, whole (both triangles).
        let n = 3 * free.len();
        let mut columns: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for (&(a, b), &v) in &entries {
            columns[place[b]].push((place[a], v));
        }
        let (starts, rows, values, pivots) = ldl(&columns)?;
        Ok(Factor {
            stiff,
            unknown,
            starts,
            rows,
            values,
            pivots,
            work: vec![0.0; n],
        })
    }

    /// `out` = (M + s·K₀)⁻¹·`rhs` over the free nodes; zero at pinned ones.
    pub fn solve(&mut self, rhs: &[DVec3], out: &mut [DVec3]) {
        for (i, &u) in self.unknown.iter().enumerate() {
            if u != NONE {
                self.work[u..u + 3].copy_from_slice(&rhs[i].to_array());
            }
        }
        let x = &mut self.work;
        for j in 0..x.len() {
            let xj = x[j];
            for p in self.starts[j]..self.starts[j + 1] {
                x[self.rows[p]] -= self.values[p] * xj;
            }
        }
        for (xj, d) in x.iter_mut().zip(&self.pivots) {
            *xj /= d;
        }
        for j in (0..x.len()).rev() {
            let mut xj = x[j];
            for p in self.starts[j]..self.starts[j + 1] {
                xj -= self.values[p] * x[self.rows[p]];
            }
            x[j] = xj;
        }
        for (i, &u) in self.unknown.iter().enumerate() {
            out[i] = if u == NONE {
                DVec3::ZERO
            } else {
                DVec3::from_slice(&x[u..u + 3])
            };
        }
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

/// L·D·Lᵀ of the symmetric matrix of `columns` (each column's rows and values, both
/// triangles), up-looking row by row along its elimination tree: L's column starts, rows
/// and values (its unit diagonal left out), and D.
type Ldl = (Vec<usize>, Vec<usize>, Vec<f64>, Vec<f64>);

fn ldl(columns: &[Vec<(usize, f64)>]) -> Result<Ldl, FactorError> {
    let n = columns.len();
    // The elimination tree and each column's count.
    let (mut parent, mut flag, mut count) = (vec![NONE; n], vec![NONE; n], vec![0usize; n]);
    for k in 0..n {
        flag[k] = k;
        for &(mut i, _) in &columns[k] {
            if i >= k {
                continue;
            }
            while flag[i] != k {
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
    let (mut rows, mut values) = (vec![0; starts[n]], vec![0.0; starts[n]]);
    let mut pivots = vec![0.0; n];
    let (mut y, mut pattern) = (vec![0.0; n], vec![0; n]);
    count.fill(0);
    for k in 0..n {
        // Row k of L: the nonzeros of column k above the diagonal, along the tree.
        let mut top = n;
        flag[k] = k;
        for &(mut i, v) in &columns[k] {
            if i > k {
                continue;
            }
            y[i] += v;
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
        let mut d = y[k];
        y[k] = 0.0;
        for &i in &pattern[top..n] {
            let yi = y[i];
            y[i] = 0.0;
            let end = starts[i] + count[i];
            for p in starts[i]..end {
                y[rows[p]] -= values[p] * yi;
            }
            let l = yi / pivots[i];
            d -= l * yi;
            rows[end] = k;
            values[end] = l;
            count[i] += 1;
        }
        if d.is_nan() || d <= 0.0 {
            return Err(FactorError::NotPositive);
        }
        pivots[k] = d;
    }
    Ok((starts, rows, values, pivots))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::Order;
    use crate::lattice::cut_box;
    use crate::material::Material;

    /// The factor solves the rest system it was made of: (M + s·K₀)·x = b to rounding, for
    /// both orders, with a face pinned.
    #[test]
    fn the_factor_solves_the_rest_system() {
        for order in [Order::Linear, Order::Quadratic] {
            let mesh = cut_box(DVec3::ZERO, DVec3::new(0.03, 0.02, 0.025), 0.01, order);
            let material = Material {
                young: 1e5,
                poisson: 0.45,
                density: 1100.0,
                damping: 0.002,
            };
            let mut body = SoftBody::new(mesh, material);
            body.pin_below(1, -0.02);
            let stiff = 0.002 * 0.001 + 1e-6;
            let mut factor = Factor::new(&body, stiff).unwrap();
            let nodes = body.positions.len();
            let b: Vec<DVec3> = (0..nodes)
                .map(|i| {
                    let t = i as f64;
                    DVec3::new(t.sin(), (1.3 * t).cos(), (0.7 * t).sin())
                })
                .collect();
            let mut x = vec![DVec3::ZERO; nodes];
            factor.solve(&b, &mut x);
            let mut back = vec![DVec3::ZERO; nodes];
            body.system_times(stiff, &x, &mut back);
            for i in 0..nodes {
                let want = if body.pinned[i] { DVec3::ZERO } else { b[i] };
                assert!(
                    (back[i] - want).length() < 1e-9,
                    "{order:?} {i}: {} vs {want}",
                    back[i]
                );
            }
        }
    }
}

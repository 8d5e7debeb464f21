//! The factored rest system's answer corrected for the nodes held on obstacles: the
//! capacitance-matrix method. A held node may not move along the directions it is held in
//! (all three while it sticks, its face's normal while it slides), so the step's unknowns
//! are the rest; the factor, made with those nodes free, answers as if they moved, and a
//! finger dragged across a block took five iterations a tick on the mean and up to 14. With
//! W = A⁻¹·Cᵀ (A the factored system, C the held directions) and G = C·W,
//!
//! Z·t = A⁻¹·t − W·G⁻¹·(C·A⁻¹·t)
//!
//! solves the system with those directions held exactly. W is kept by node: the three
//! columns of A⁻¹ at a held node (three solves, made the first step it is held, as many
//! nodes a step as [`COLUMN_WORK`] allows, and kept while slots last), from which any
//! direction there is a sum; G is made anew for each
//! solve of a step, as its held directions stand. The same drag then took 2.2 iterations on
//! the mean and 6 at most (`make bench`'s `linear_tick_under_a_dragged_finger` case).

use glam::{DMat3, DQuat, DVec3};

use crate::contact::Held;
use crate::factor::Factor;

/// No node.
const NONE: usize = usize::MAX;

/// The most nodes whose columns are kept.
const MOST_SLOTS: usize = 32;

/// The work a step may give to making columns, in blocks of the factor read: a node's
/// three solves of 2 058 tetrahedra's system (16 381 blocks) take it all, a small body's
/// many nodes' fit.
pub const COLUMN_WORK: usize = 100_000;

/// The most memory kept columns may take, bytes: a body of 9 261 nodes (48 000 tetrahedra)
/// keeps 6 nodes' columns in it.
const MOST_MEMORY: usize = 4 << 20;

/// The columns of the factored system at the nodes held, and the held directions' system.
#[derive(Debug, Clone)]
pub struct Capacitance {
    /// Each slot's node, NONE while empty.
    owners: Vec<usize>,
    /// The step each slot's node was last held.
    used: Vec<u64>,
    /// Each node's slot, NONE if it has none.
    slot_of: Vec<usize>,
    /// Slot s's columns at node i: `columns[s·nodes + i]`, the 3×3 block of A⁻¹ in row i,
    /// column of the slot's node (in the rest frame, where the factor works).
    columns: Vec<DMat3>,
    /// The held directions of this solve: slot and unit direction (rest frame).
    held: Vec<(usize, DVec3)>,
    /// G = C·W, factored (Cholesky, lower triangle, row by row), and its right-hand side.
    gram: Vec<f64>,
    weights: Vec<f64>,
    /// Each slot's share of the correction, W's columns at its node weighed.
    shares: Vec<DVec3>,
    /// A unit load, and one column, to make columns in.
    unit: Vec<DVec3>,
    column: Vec<DVec3>,
    /// Steps taken, to tell which slot was held longest ago.
    steps: u64,
}

impl Capacitance {
    /// Room for a body of `nodes` nodes.
    pub fn new(nodes: usize) -> Capacitance {
        let slots = MOST_SLOTS.min(MOST_MEMORY / (nodes.max(1) * size_of::<DMat3>()));
        let most = 3 * slots;
        Capacitance {
            owners: vec![NONE; slots],
            used: vec![0; slots],
            slot_of: vec![NONE; nodes],
            columns: vec![DMat3::ZERO; slots * nodes],
            held: Vec::with_capacity(most),
            gram: vec![0.0; most * most],
            weights: vec![0.0; most],
            shares: vec![DVec3::ZERO; slots],
            unit: vec![DVec3::ZERO; nodes],
            column: vec![DVec3::ZERO; nodes],
            steps: 0,
        }
    }

    /// Forget every column (made of a factor no longer used).
    pub fn forget(&mut self) {
        self.owners.fill(NONE);
        self.slot_of.fill(NONE);
    }

    /// At a step's start with nodes `held`: mark theirs used, and make the columns of held
    /// nodes that have none (three solves through `factor` each), in the slots held longest
    /// ago: as many as [`COLUMN_WORK`] allows, one at least, so a finger that lands on many
    /// nodes of a large body spreads their cost over as many steps.
    pub fn step(&mut self, factor: &mut Factor, held: &[Held]) {
        self.steps += 1;
        for h in held {
            if let Some(&s) = self.slot_of.get(h.node).filter(|&&s| s != NONE) {
                self.used[s] = self.steps;
            }
        }
        let each = 3 * factor.work();
        let mut left = COLUMN_WORK.max(each);
        for h in held {
            if left < each {
                break;
            }
            if self.slot_of[h.node] != NONE || !factor.holds(h.node) {
                continue;
            }
            let Some(slot) = (0..self.owners.len())
                .filter(|&s| self.used[s] < self.steps)
                .min_by_key(|&s| self.used[s])
            else {
                break;
            };
            self.make_columns(factor, h.node, slot);
            left -= each;
        }
    }

    /// Make node `node`'s columns in slot `slot`.
    fn make_columns(&mut self, factor: &mut Factor, node: usize, slot: usize) {
        if self.owners[slot] != NONE {
            self.slot_of[self.owners[slot]] = NONE;
        }
        let nodes = self.slot_of.len();
        for d in 0..3 {
            self.unit.fill(DVec3::ZERO);
            self.unit[node][d] = 1.0;
            factor.solve(&self.unit, &mut self.column);
            for (block, c) in self.columns[slot * nodes..(slot + 1) * nodes]
                .iter_mut()
                .zip(&self.column)
            {
                *block.col_mut(d) = *c;
            }
        }
        (self.owners[slot], self.used[slot], self.slot_of[node]) = (node, self.steps, slot);
    }

    /// For a solve with nodes `held`, turned by `turns`: its held directions and their G.
    pub fn prepare(&mut self, held: &[Held], turns: &[DQuat]) {
        self.held.clear();
        for h in held {
            let s = self.slot_of[h.node];
            if s == NONE {
                continue;
            }
            if h.stuck {
                self.held
                    .extend([DVec3::X, DVec3::Y, DVec3::Z].map(|d| (s, d)));
            } else {
                self.held.push((s, turns[h.node].conjugate() * h.normal));
            }
        }
        let (m, nodes) = (self.held.len(), self.slot_of.len());
        for a in 0..m {
            let (sa, ca) = self.held[a];
            for b in 0..=a {
                let (sb, cb) = self.held[b];
                self.gram[a * m + b] = ca.dot(self.columns[sb * nodes + self.owners[sa]] * cb);
            }
        }
        // Cholesky. The held nodes differ and each one's directions are independent, so G
        // is positive definite; should rounding say otherwise, the projection alone serves.
        for j in 0..m {
            let mut d = self.gram[j * m + j];
            for k in 0..j {
                d -= self.gram[j * m + k].powi(2);
            }
            if d <= 0.0 {
                self.held.clear();
                return;
            }
            let pivot = d.sqrt();
            self.gram[j * m + j] = pivot;
            for i in j + 1..m {
                let mut v = self.gram[i * m + j];
                for k in 0..j {
                    v -= self.gram[i * m + k] * self.gram[j * m + k];
                }
                self.gram[i * m + j] = v / pivot;
            }
        }
    }

    /// `weights` = G⁻¹·`weights`, by the factored G.
    fn solve_gram(&mut self) {
        let m = self.held.len();
        for i in 0..m {
            let mut v = self.weights[i];
            for k in 0..i {
                v -= self.gram[i * m + k] * self.weights[k];
            }
            self.weights[i] = v / self.gram[i * m + i];
        }
        for i in (0..m).rev() {
            let mut v = self.weights[i];
            for k in i + 1..m {
                v -= self.gram[k * m + i] * self.weights[k];
            }
            self.weights[i] = v / self.gram[i * m + i];
        }
    }

    /// Correct `y` = A⁻¹·t (rest frame) to Z·t: nothing along the held directions, the
    /// rest as the system with them held answers.
    pub fn correct(&mut self, y: &mut [DVec3]) {
        let (m, nodes) = (self.held.len(), self.slot_of.len());
        if m == 0 {
            return;
        }
        for (w, &(s, c)) in self.weights.iter_mut().zip(&self.held) {
            *w = c.dot(y[self.owners[s]]);
        }
        // G·λ = C·y.
        self.solve_gram();
        self.shares.fill(DVec3::ZERO);
        for (&(s, c), &w) in self.held.iter().zip(&self.weights) {
            self.shares[s] += c * w;
        }
        for (s, share) in self.shares.iter().enumerate() {
            if *share == DVec3::ZERO {
                continue;
            }
            let columns = &self.columns[s * nodes..(s + 1) * nodes];
            for (yi, block) in y.iter_mut().zip(columns) {
                *yi -= *block * *share;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::Order;
    use crate::factor::tests::{pinned_block, unit_loads};

    /// Corrected, the factor solves the system with the held directions held: a stuck node
    /// and a sliding one on a block pinned at its base get nothing along what holds them,
    /// and every other direction's equation is met to single precision's rounding (that of
    /// the factor itself: 1.4·10⁻⁶ for unit loads).
    #[test]
    fn the_corrected_factor_solves_the_system_with_the_held_directions_held() {
        let (body, stiff) = pinned_block(Order::Linear);
        let mut factor = Factor::new(&body, stiff).unwrap();
        let nodes = body.positions.len();
        let top: Vec<usize> = (0..nodes)
            .filter(|&i| body.positions[i].y > 0.0199)
            .take(2)
            .collect();
        let normal = DVec3::new(0.3, 1.0, 0.2).normalize();
        let held: Vec<Held> = top
            .iter()
            .zip([true, false])
            .map(|(&node, stuck)| Held {
                node,
                obstacle: 0,
                normal,
                speed: 0.0,
                stuck,
                kinetic: !stuck,
                surface: DVec3::ZERO,
                friction: DVec3::ZERO,
            })
            .collect();
        let mut capacitance = Capacitance::new(nodes);
        // A small body's nodes' columns are cheap: both are made in the first step.
        assert!(3 * factor.work() * 2 <= COLUMN_WORK);
        capacitance.step(&mut factor, &held);
        assert_eq!(capacitance.owners.iter().filter(|&&o| o != NONE).count(), 2);
        capacitance.prepare(&held, &vec![DQuat::IDENTITY; nodes]);
        assert_eq!(
            capacitance.held.len(),
            4,
            "three directions stuck, one sliding"
        );

        let mut t = unit_loads(nodes);
        t[top[0]] = DVec3::ZERO;
        let along = normal * normal.dot(t[top[1]]);
        t[top[1]] -= along;
        let mut y = vec![DVec3::ZERO; nodes];
        factor.solve(&t, &mut y);
        capacitance.correct(&mut y);
        let mut back = vec![DVec3::ZERO; nodes];
        body.system_times(stiff, &y, &mut back);

        let size = y.iter().map(|v| v.length()).fold(0.0, f64::max);
        assert!(y[top[0]].length() < 1e-6 * size, "stuck: {}", y[top[0]]);
        assert!(normal.dot(y[top[1]]).abs() < 1e-6 * size, "slid in");
        let mut worst: f64 = 0.0;
        for i in 0..nodes {
            let mut miss = if body.pinned[i] {
                DVec3::ZERO
            } else {
                back[i] - t[i]
            };
            if i == top[0] {
                miss = DVec3::ZERO;
            } else if i == top[1] {
                miss -= normal * normal.dot(miss);
            }
            worst = worst.max(miss.length());
        }
        println!("the held system's equations met within {worst:e}");
        assert!(worst < 2e-5, "{worst}");

        // Uncorrected, the factor answers as if the held nodes moved.
        let mut free = vec![DVec3::ZERO; nodes];
        factor.solve(&t, &mut free);
        assert!(free[top[0]].length() > 1e-3 * size);
    }
}

//! The least-distance problem of a rigid body's small motion: the shortest y in six
//! dimensions that meets every linear constraint gᵢ·y ≥ hᵢ, solved exactly by Lawson and
//! Hanson's reduction to non-negative least squares (Solving Least Squares Problems, 1974,
//! ch. 23): find u ≥ 0 minimising |E·u − f| with E's columns (gᵢ, hᵢ) and f = (0, …, 0, 1);
//! then y = Σ λᵢ·gᵢ with λ = u / (1 − h·u), the constraints' multipliers.
//!
//! The non-negative least squares is their active-set method: a constraint joins the set
//! that the residual pulls on most, and the set's least squares (at most seven columns of
//! seven rows, by Gram–Schmidt) is cut back along the way to the first multiplier that would
//! go negative. It ends in finitely many steps with the exact answer, however nearly
//! parallel the constraints (a peg's edge along a rim's gives rows a few degrees apart,
//! which Gauss–Seidel crawls over). [rt]: no allocation.

/// The dimensions of a rigid body's motion: translation and rotation.
pub const DIM: usize = 6;
/// Rows of the least squares: the motion's, then the constraints' right-hand side.
const ROWS: usize = DIM + 1;

/// Constraints a problem may hold.
pub const MOST: usize = 64;

/// A least-distance problem of up to [`MOST`] constraints.
#[derive(Debug, Clone)]
pub struct LeastDistance {
    /// Each constraint's column (gᵢ, hᵢ).
    columns: [[f64; ROWS]; MOST],
    count: usize,
    /// Steps taken by the last solve.
    steps: usize,
}

impl Default for LeastDistance {
    fn default() -> Self {
        Self {
            columns: [[0.0; ROWS]; MOST],
            count: 0,
            steps: 0,
        }
    }
}

/// The answer of a solve: the shortest y, and each constraint's multiplier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shortest {
    /// The shortest y meeting every constraint.
    pub y: [f64; DIM],
    /// λ ≥ 0 with y = Σ λᵢ gᵢ, zero for a constraint met with room to spare.
    pub multipliers: [f64; MOST],
}

impl LeastDistance {
    /// [rt] Forget the constraints.
    pub fn clear(&mut self) {
        self.count = 0;
    }

    /// [rt] Add g·y ≥ h; false when [`MOST`] are held already.
    pub fn push(&mut self, g: [f64; DIM], h: f64) -> bool {
        if self.count == MOST {
            return false;
        }
        let column = &mut self.columns[self.count];
        column[..DIM].copy_from_slice(&g);
        column[DIM] = h;
        self.count += 1;
        true
    }

    /// Steps the last solve took (for measurement).
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// [rt] The shortest y meeting every constraint, or None when none does (or the solve
    /// ran out of its `most_steps`).
    pub fn solve(&mut self, most_steps: usize) -> Option<Shortest> {
        let m = self.count;
        let columns = &self.columns[..m];
        let scale = columns
            .iter()
            .flat_map(|c| c.iter())
            .fold(0.0f64, |a, &b| a.max(b.abs()))
            .max(1.0);
        let tolerance = 1e-13 * scale;
        let mut u = [0.0f64; MOST];
        let mut passive = [false; MOST];
        // Constraints that, joining, would take no share (rounding, where the residual's
        // pull on them is all but nil): passed over until the set changes.
        let mut refused = [false; MOST];
        let mut order = [0usize; ROWS];
        let mut active = 0usize;
        let mut residual = [0.0f64; ROWS];
        residual[DIM] = 1.0;
        self.steps = 0;
        loop {
            // The constraint the residual pulls on most joins, if any pulls.
            let mut best = None;
            let mut most = tolerance;
            for (j, c) in columns.iter().enumerate() {
                if passive[j] || refused[j] {
                    continue;
                }
                let w = dot(c, &residual);
                if w > most {
                    (best, most) = (Some(j), w);
                }
            }
            let Some(j) = best else { break };
            if active == ROWS {
                break;
            }
            passive[j] = true;
            order[active] = j;
            active += 1;
            let mut joining = true;
            loop {
                self.steps += 1;
                if self.steps > most_steps {
                    return None;
                }
                let Some(z) = least_squares(columns, &order[..active]) else {
                    // The newcomer adds nothing the set spans: it leaves again, passed over.
                    active -= 1;
                    passive[order[active]] = false;
                    refused[order[active]] = true;
                    break;
                };
                if z[..active].iter().all(|&v| v > 0.0) {
                    for (k, &j) in order[..active].iter().enumerate() {
                        u[j] = z[k];
                    }
                    refused = [false; MOST];
                    break;
                }
                // A newcomer the least squares gives no share would leave at once and be
                // picked again for ever: it is passed over instead.
                if std::mem::take(&mut joining) && z[active - 1] <= 0.0 {
                    active -= 1;
                    passive[j] = false;
                    refused[j] = true;
                    break;
                }
                // Along the way from u to z, as far as every multiplier stays non-negative.
                let mut alpha = 1.0f64;
                for (k, &j) in order[..active].iter().enumerate() {
                    if z[k] <= 0.0 {
                        alpha = alpha.min(u[j] / (u[j] - z[k]));
                    }
                }
                for (k, &j) in order[..active].iter().enumerate() {
                    u[j] += alpha * (z[k] - u[j]);
                }
                // Those that reached zero leave the set.
                let mut kept = 0;
                for k in 0..active {
                    let j = order[k];
                    if u[j] <= tolerance {
                        u[j] = 0.0;
                        passive[j] = false;
                    } else {
                        order[kept] = j;
                        kept += 1;
                    }
                }
                active = kept;
            }
            residual = [0.0; ROWS];
            residual[DIM] = 1.0;
            for &j in &order[..active] {
                for (r, c) in residual.iter_mut().zip(&columns[j]) {
                    *r -= c * u[j];
                }
            }
        }
        // residual = f − E·u; its last entry is 1 − h·u, zero when no y meets them all.
        let last = residual[DIM];
        if last.is_nan() || last <= tolerance {
            return None;
        }
        let mut y = [0.0; DIM];
        for (k, r) in y.iter_mut().zip(&residual) {
            *k = -r / last;
        }
        let mut multipliers = [0.0; MOST];
        for (l, &v) in multipliers.iter_mut().zip(&u[..m]) {
            *l = v / last;
        }
        Some(Shortest { y, multipliers })
    }
}

fn dot(a: &[f64; ROWS], b: &[f64; ROWS]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The least-squares coefficients of f = (0, …, 0, 1) on the columns `set` (by modified
/// Gram–Schmidt, twice over for orthogonality); None when the last of them lies (nearly) in
/// the span of the others.
fn least_squares(columns: &[[f64; ROWS]], set: &[usize]) -> Option<[f64; ROWS]> {
    let n = set.len();
    let mut q = [[0.0f64; ROWS]; ROWS];
    let mut r = [[0.0f64; ROWS]; ROWS];
    for (k, &j) in set.iter().enumerate() {
        let mut v = columns[j];
        let norm = dot(&v, &v).sqrt();
        for _ in 0..2 {
            for i in 0..k {
                let p = dot(&q[i], &v);
                r[i][k] += p;
                for (a, b) in v.iter_mut().zip(&q[i]) {
                    *a -= p * b;
                }
            }
        }
        let length = dot(&v, &v).sqrt();
        if length.is_nan() || length <= 1e-10 * norm {
            return None;
        }
        r[k][k] = length;
        for (a, b) in q[k].iter_mut().zip(&v) {
            *a = b / length;
        }
    }
    // R·z = Qᵀ·f, f's only entry its last.
    let mut z = [0.0f64; ROWS];
    for k in (0..n).rev() {
        let mut s = q[k][DIM];
        for i in k + 1..n {
            s -= r[k][i] * z[i];
        }
        z[k] = s / r[k][k];
    }
    Some(z)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }

    #[test]
    fn one_constraint_is_met_at_its_plane() {
        let mut p = LeastDistance::default();
        p.push([0.0, 2.0, 0.0, 0.0, 0.0, 0.0], 3.0);
        let s = p.solve(100).unwrap();
        // 2·y₁ ≥ 3: y₁ = 1.5, from λ = 0.75 along g.
        assert!((s.y[1] - 1.5).abs() < 1e-15, "{:?}", s.y);
        assert!((s.multipliers[0] - 0.75).abs() < 1e-15);
        // One met already leaves y at zero.
        p.clear();
        p.push([0.0, 2.0, 0.0, 0.0, 0.0, 0.0], -3.0);
        assert_eq!(p.solve(100).unwrap().y, [0.0; DIM]);
    }

    /// Three contacts along one edge of a tilted peg on a block's top, as a tick of the
    /// assembly benchmark found them (their columns in the spring's metric): nearly
    /// dependent, the third would join with no share and leave again, over and over, until
    /// the solve ran out of steps and the proxy stood still for good.
    #[test]
    fn three_contacts_along_one_edge_are_solved_in_a_few_steps() {
        let columns = [
            [
                0.0,
                0.022360679774997897,
                0.0,
                -5.555265576009995e-5,
                0.0,
                -0.002295414566016973,
                0.0017047742285310136,
            ],
            [
                0.0,
                0.022360679774997897,
                0.0,
                -0.0001111069703266518,
                0.0,
                -0.0022954146042548722,
                0.0017047935005406471,
            ],
            [
                0.0,
                0.022360679774997897,
                0.0,
                0.00011111028793955558,
                0.0,
                -0.00229541445130327,
                0.0017047164091993816,
            ],
        ];
        let mut p = LeastDistance::default();
        for c in columns {
            assert!(p.push(c[..DIM].try_into().unwrap(), c[DIM]));
        }
        let s = p.solve(100).expect("solved");
        assert!(p.steps() <= 6, "{} steps", p.steps());
        for (c, l) in columns.iter().zip(s.multipliers) {
            let along: f64 = c[..DIM].iter().zip(&s.y).map(|(a, b)| a * b).sum();
            assert!(along >= c[DIM] - 1e-12, "{along} < {}", c[DIM]);
            assert!(l >= 0.0 && l * (along - c[DIM]) < 1e-12);
        }
    }

    /// Copies of the same few constraints, rounded a hair apart (a flat face's contacts all
    /// on one plane): a newcomer the residual barely pulls on is passed over, not picked
    /// again for ever.
    #[test]
    fn copies_of_a_few_constraints_end_in_few_steps() {
        let mut seed = 5;
        let base: [([f64; DIM], f64); 3] = std::array::from_fn(|_| {
            (
                std::array::from_fn(|_| lcg(&mut seed)),
                0.3 * lcg(&mut seed),
            )
        });
        let mut p = LeastDistance::default();
        for k in 0..MOST {
            let (g, h) = base[k % 3];
            let g = g.map(|v| v * (1.0 + 1e-13 * lcg(&mut seed)));
            assert!(p.push(g, h + 1e-14 * lcg(&mut seed)));
        }
        let s = p.solve(4 * MOST).expect("solved");
        assert!(p.steps() <= 2 * MOST, "{} steps", p.steps());
        for (g, h) in base {
            let along: f64 = g.iter().zip(&s.y).map(|(a, b)| a * b).sum();
            assert!(along >= h - 1e-9, "{along} < {h}");
        }
    }

    /// The answer against the conditions that make it the only one (Karush–Kuhn–Tucker, a
    /// certificate of the optimum of a convex problem): every constraint met, multipliers
    /// not negative and zero where a constraint has room, and y their sum; for random
    /// problems of up to 64 constraints, half of them within a few degrees of each other,
    /// each met by some point (so that one exists).
    #[test]
    fn random_problems_meet_the_optimality_conditions() {
        let mut seed = 11;
        let mut most = 0;
        for trial in 0..400 {
            let mut p = LeastDistance::default();
            let m = 1 + (trial * 7) % MOST;
            let base: [f64; DIM] = std::array::from_fn(|_| lcg(&mut seed));
            let inside: [f64; DIM] = std::array::from_fn(|_| 4.0 * lcg(&mut seed));
            let spread = if trial % 2 == 0 { 0.05 } else { 1.0 };
            let mut rows = Vec::new();
            for _ in 0..m {
                let g: [f64; DIM] = std::array::from_fn(|k| base[k] + spread * lcg(&mut seed));
                let at: f64 = g.iter().zip(&inside).map(|(a, b)| a * b).sum();
                let h = at - (lcg(&mut seed) + 0.5) * 0.1;
                rows.push((g, h));
                assert!(p.push(g, h));
            }
            let s = p.solve(10_000).unwrap_or_else(|| panic!("trial {trial}"));
            most = most.max(p.steps());
            let mut sum = [0.0; DIM];
            for (i, (g, h)) in rows.iter().enumerate() {
                let along: f64 = g.iter().zip(&s.y).map(|(a, b)| a * b).sum();
                let l = s.multipliers[i];
                assert!(along >= h - 1e-9, "trial {trial}: {along} < {h}");
                assert!(l >= 0.0);
                assert!(
                    l * (along - h) < 1e-9 * (1.0 + l),
                    "trial {trial}: slack {l}"
                );
                for (total, v) in sum.iter_mut().zip(g) {
                    *total += l * v;
                }
            }
            for (total, y) in sum.iter().zip(&s.y) {
                assert!((total - y).abs() < 1e-9 * (1.0 + y.abs()), "trial {trial}");
            }
        }
        eprintln!("at most {most} steps");
    }
}

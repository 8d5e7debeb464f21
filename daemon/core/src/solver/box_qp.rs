//! Exact primal active-set solver for small box-constrained convex QPs:
//! minimise ½ xᵀQx + cᵀx subject to l ≤ x ≤ u, Q symmetric positive definite.
//!
//! Each iteration solves the equality problem on the free variables by an LDLᵀ factorisation and walks
//! toward its solution, stopping at the first bound it meets (which joins the working set);
//! at the working set's optimum, the bound with the most negative multiplier is released.
//! The iterate stays feasible throughout, so even a solve cut short by the iteration cap
//! respects every bound. Warm starts keep the working set of the previous call, which in a
//! 1 kHz loop usually is already optimal: one factorisation and a multiplier check.

use super::linalg::{ldlt_factor, ldlt_solve};
use crate::kinematics::MAX_STRINGS_PER_EFFECTOR;

/// Most variables a problem may have.
pub const MAX_VARS: usize = MAX_STRINGS_PER_EFFECTOR;

/// A square matrix of the largest problem size; problems use the leading n×n block.
pub type Matrix = [[f64; MAX_VARS]; MAX_VARS];

/// A vector of the largest problem size.
pub type Vector = [f64; MAX_VARS];

/// Where a variable is in the working set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// Between its bounds.
    Free,
    /// Held at its lower bound.
    Lower,
    /// Held at its upper bound.
    Upper,
}

/// One problem: the leading `n` entries of each array.
#[derive(Debug, Clone, Copy)]
pub struct BoxQp<'a> {
    /// Quadratic term Q (both triangles filled).
    pub q: &'a Matrix,
    /// Linear term c.
    pub c: &'a Vector,
    /// Lower bounds l.
    pub lower: &'a Vector,
    /// Upper bounds u (each ≥ its lower bound).
    pub upper: &'a Vector,
    /// Number of variables.
    pub n: usize,
}

/// Working set and iterate, kept between calls for warm starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActiveSet {
    bounds: [Bound; MAX_VARS],
    x: Vector,
}

impl Default for ActiveSet {
    /// A cold start: every variable at its lower bound.
    fn default() -> Self {
        Self {
            bounds: [Bound::Lower; MAX_VARS],
            x: [0.0; MAX_VARS],
        }
    }
}

impl ActiveSet {
    /// The current solution.
    pub fn x(&self) -> &Vector {
        &self.x
    }

    /// The current working set.
    pub fn bounds(&self) -> &[Bound; MAX_VARS] {
        &self.bounds
    }
}

/// How a solve went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QpOutcome {
    /// Active-set iterations (factorisations) used.
    pub iterations: usize,
    /// False when the iteration cap or a singular Q stopped it; the iterate is still feasible.
    pub converged: bool,
}

/// Solve `problem`, starting from and updating `state`.
pub fn solve(problem: &BoxQp, state: &mut ActiveSet) -> QpOutcome {
    let BoxQp {
        lower, upper, n, ..
    } = *problem;
    let x = &mut state.x;
    let bounds = &mut state.bounds;
    let scale = start_iterate(problem, x, bounds);
    let tolerance = 1e-11 * scale;
    let max_iterations = 4 * n + 8;
    let mut free = [0usize; MAX_VARS];
    for iteration in 1..=max_iterations {
        let nf = free_variables(bounds, n, &mut free);
        let (mut a, mut y) = free_system(problem, x, bounds, &free[..nf]);
        if nf > 0 {
            if !ldlt_factor(&mut a, nf, 0.0) {
                return QpOutcome {
                    iterations: iteration,
                    converged: false,
                };
            }
            ldlt_solve(&a, nf, &mut y);
        }
        let (alpha, blocking) = first_blocking(problem, x, &y, &free[..nf]);
        for r in 0..nf {
            let i = free[r];
            x[i] = (x[i] + alpha * (y[r] - x[i])).clamp(lower[i], upper[i]);
        }
        if let Some((i, bound)) = blocking {
            bounds[i] = bound;
            x[i] = if bound == Bound::Lower {
                lower[i]
            } else {
                upper[i]
            };
            continue;
        }
        match most_negative_multiplier(problem, x, bounds, tolerance) {
            Some(i) => bounds[i] = Bound::Free,
            None => {
                return QpOutcome {
                    iterations: iteration,
                    converged: true,
                };
            }
        }
    }
    QpOutcome {
        iterations: max_iterations,
        converged: false,
    }
}

/// [rt] Put each variable where `bounds` holds it; the problem's scale, for the tolerance.
#[inline]
fn start_iterate(problem: &BoxQp, x: &mut Vector, bounds: &[Bound; MAX_VARS]) -> f64 {
    let BoxQp {
        q,
        c,
        lower,
        upper,
        n,
    } = *problem;
    let mut scale = 1.0f64;
    for i in 0..n {
        x[i] = match bounds[i] {
            Bound::Lower => lower[i],
            Bound::Upper => upper[i],
            Bound::Free => x[i].clamp(lower[i], upper[i]),
        };
        scale = scale
            .max(c[i].abs())
            .max(q[i][i] * lower[i].abs().max(upper[i].abs()));
    }
    scale
}

/// [rt] The free variables of the first `n` of `bounds`, in order, into `free`; how many.
#[inline]
fn free_variables(bounds: &[Bound; MAX_VARS], n: usize, free: &mut [usize; MAX_VARS]) -> usize {
    let mut nf = 0;
    for i in 0..n {
        if bounds[i] == Bound::Free {
            free[nf] = i;
            nf += 1;
        }
    }
    nf
}

/// [rt] The equality problem on the `free` variables, the others held at `x`: matrix and rhs.
#[inline]
fn free_system(
    problem: &BoxQp,
    x: &Vector,
    bounds: &[Bound; MAX_VARS],
    free: &[usize],
) -> (Matrix, Vector) {
    let BoxQp { q, c, n, .. } = *problem;
    let mut a: Matrix = [[0.0; MAX_VARS]; MAX_VARS];
    let mut y: Vector = [0.0; MAX_VARS];
    for r in 0..free.len() {
        let i = free[r];
        for s in 0..=r {
            a[r][s] = q[i][free[s]];
        }
        let mut rhs = -c[i];
        for j in 0..n {
            if bounds[j] != Bound::Free {
                rhs -= q[i][j] * x[j];
            }
        }
        y[r] = rhs;
    }
    (a, y)
}

/// [rt] How far the `free` variables may walk from `x` toward `y`, and the bound stopping them.
#[inline]
fn first_blocking(
    problem: &BoxQp,
    x: &Vector,
    y: &Vector,
    free: &[usize],
) -> (f64, Option<(usize, Bound)>) {
    let BoxQp { lower, upper, .. } = *problem;
    let mut alpha = 1.0;
    let mut blocking = None;
    for r in 0..free.len() {
        let i = free[r];
        let d = y[r] - x[i];
        if y[r] < lower[i] {
            let t = (lower[i] - x[i]) / d;
            if t < alpha {
                alpha = t;
                blocking = Some((i, Bound::Lower));
            }
        } else if y[r] > upper[i] {
            let t = (upper[i] - x[i]) / d;
            if t < alpha {
                alpha = t;
                blocking = Some((i, Bound::Upper));
            }
        }
    }
    (alpha, blocking)
}

/// [rt] The bound variable to release: the most negative multiplier, below `-tolerance`.
#[inline]
fn most_negative_multiplier(
    problem: &BoxQp,
    x: &Vector,
    bounds: &[Bound; MAX_VARS],
    tolerance: f64,
) -> Option<usize> {
    let BoxQp { q, c, n, .. } = *problem;
    let mut worst = (-tolerance, None);
    for i in 0..n {
        if bounds[i] == Bound::Free {
            continue;
        }
        let gradient: f64 = c[i] + (0..n).map(|j| q[i][j] * x[j]).sum::<f64>();
        let multiplier = if bounds[i] == Bound::Lower {
            gradient
        } else {
            -gradient
        };
        if multiplier < worst.0 {
            worst = (multiplier, Some(i));
        }
    }
    worst.1
}

//! String tensions for a wrench (thesis 3.5.4, eq. 3.16):
//! minimise |S½(Wτ − f)|² + λ|τ|² subject to τmin ≤ τ ≤ τmax.
//!
//! S weights the torque rows (`torque_weight`; 1 reproduces eq. 3.16 as written). λ > 0
//! makes the quadratic term positive definite, so tensions are unique and continuous in the
//! grip position; at λ = 0 the problem may have a whole segment of optima (internal tension
//! of a redundant mechanism), and the solver picks the one of least norm by adding a
//! vanishing regularisation.

use super::box_qp::{self, ActiveSet, BoxQp, MAX_VARS, Matrix, Vector};
use super::geometry::StringGeometry;
use crate::kinematics::Wrench;

/// Settings of the tension problem (thesis eq. 3.16).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TensionSettings {
    /// λ: weight of |τ|²; λ > 0 makes tensions unique and continuous in position.
    pub lambda: f64,
    /// Weight of the torque rows of the wrench error, 1/m² (1 = every component weighted 1).
    pub torque_weight: f64,
}

/// Regularisation relative to the mean diagonal of WᵀW that stands in for λ = 0.
const MIN_REGULARISATION: f64 = 1e-10;

/// Tensions computed for one effector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TensionSolution {
    /// Tensions in the effector's string order (first `count` entries), newtons.
    pub tensions: [f64; MAX_VARS],
    /// Number of strings.
    pub count: usize,
    /// The wrench W τ those tensions produce (no torque for 3 DOF).
    pub wrench: Wrench,
    /// Active-set iterations used.
    pub iterations: usize,
    /// Whether the QP reached its optimum (the tensions respect the limits either way).
    pub converged: bool,
}

impl TensionSolution {
    /// The tensions as a slice.
    pub fn tensions(&self) -> &[f64] {
        &self.tensions[..self.count]
    }
}

/// Warm-started tension solver of one effector.
#[derive(Debug, Clone)]
pub struct TensionSolver {
    count: usize,
    lower: Vector,
    upper: Vector,
    settings: TensionSettings,
    state: ActiveSet,
}

impl TensionSolver {
    /// A solver for strings with the given (min, max) tension limits.
    pub fn new(limits: impl IntoIterator<Item = (f64, f64)>, settings: TensionSettings) -> Self {
        let mut solver = Self {
            count: 0,
            lower: [0.0; MAX_VARS],
            upper: [0.0; MAX_VARS],
            settings,
            state: ActiveSet::default(),
        };
        for (lo, hi) in limits {
            assert!(solver.count < MAX_VARS, "too many strings");
            solver.lower[solver.count] = lo;
            solver.upper[solver.count] = hi;
            solver.count += 1;
        }
        solver
    }

    /// Current settings.
    pub fn settings(&self) -> TensionSettings {
        self.settings
    }

    /// Change λ or the torque weight (takes effect at the next solve).
    pub fn set_settings(&mut self, settings: TensionSettings) {
        self.settings = settings;
    }

    /// Tensions that best produce `target` at `geometry` (its torque counts for 6 DOF).
    #[inline]
    pub fn solve(&mut self, geometry: &StringGeometry, target: &Wrench) -> TensionSolution {
        let target = target.to_array();
        debug_assert_eq!(geometry.count(), self.count);
        let (n, dof) = (self.count, geometry.dof());
        let weight = |r: usize| {
            if r < 3 {
                1.0
            } else {
                self.settings.torque_weight
            }
        };
        let mut q: Matrix = [[0.0; MAX_VARS]; MAX_VARS];
        let mut c: Vector = [0.0; MAX_VARS];
        let mut trace = 0.0;
        for i in 0..n {
            let wi = geometry.column(i);
            for j in 0..=i {
                let wj = geometry.column(j);
                let v: f64 = (0..dof).map(|r| weight(r) * wi[r] * wj[r]).sum();
                q[i][j] = v;
                q[j][i] = v;
            }
            c[i] = -(0..dof).map(|r| weight(r) * wi[r] * target[r]).sum::<f64>();
            trace += q[i][i];
        }
        let regularisation = self
            .settings
            .lambda
            .max(MIN_REGULARISATION * trace / n.max(1) as f64);
        for (i, row) in q.iter_mut().enumerate().take(n) {
            row[i] += regularisation;
        }
        let problem = BoxQp {
            q: &q,
            c: &c,
            lower: &self.lower,
            upper: &self.upper,
            n,
        };
        let outcome = box_qp::solve(&problem, &mut self.state);
        let tensions = *self.state.x();
        TensionSolution {
            tensions,
            count: n,
            wrench: geometry.wrench(&tensions[..n]),
            iterations: outcome.iterations,
            converged: outcome.converged,
        }
    }
}

//! The tension problem of eq. 3.16 handed to Clarabel, a general-purpose interior-point
//! solver: the independent reference for the active-set solver.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};
use hapticd_core::solver::geometry::StringGeometry;

/// W as rows (dof × m).
pub fn w_rows(g: &StringGeometry) -> Vec<Vec<f64>> {
    (0..g.dof())
        .map(|r| (0..g.count()).map(|i| g.column(i)[r]).collect())
        .collect()
}

/// min |Wτ − f|² + λ|τ|² subject to lo ≤ τ ≤ hi, every wrench component weighted 1.
pub fn clarabel_tensions(
    g: &StringGeometry,
    f: &[f64],
    lambda: f64,
    (lo, hi): (&[f64], &[f64]),
    settings: DefaultSettings<f64>,
) -> (SolverStatus, Vec<f64>) {
    let (n, m) = (g.dof(), g.count());
    let w = w_rows(g);
    let mut p = vec![vec![0.0; m]; m];
    let mut q = vec![0.0; m];
    let mut a = vec![vec![0.0; m]; 2 * m];
    let mut b = vec![0.0; 2 * m];
    for (i, row) in p.iter_mut().enumerate() {
        for (j, entry) in row.iter_mut().enumerate().skip(i) {
            *entry =
                (0..n).map(|r| w[r][i] * w[r][j]).sum::<f64>() + if i == j { lambda } else { 0.0 };
        }
        q[i] = -(0..n).map(|r| w[r][i] * f[r]).sum::<f64>();
        a[i][i] = 1.0;
        b[i] = hi[i];
        a[m + i][i] = -1.0;
        b[m + i] = -lo[i];
    }
    let cones = [NonnegativeConeT(2 * m)];
    let mut solver = DefaultSolver::new(
        &CscMatrix::from(&p),
        &q,
        &CscMatrix::from(&a),
        &b,
        &cones,
        settings,
    )
    .expect("QP set up");
    solver.solve();
    (solver.solution.status, solver.solution.x.clone())
}

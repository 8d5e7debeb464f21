//! The complete-presentation region (thesis 3.5.2): where the strings can present a wrench
//! in every direction. That is force closure (eq. 3.15): every `dof` of the string vectors
//! are linearly independent, and some strictly positive combination of all of them is zero.

use super::box_qp::{self, ActiveSet, BoxQp, MAX_VARS, Matrix, Vector};
use super::geometry::StringGeometry;

/// Smallest |det| of `dof` unit string vectors still counted as independent.
const MIN_DETERMINANT: f64 = 1e-9;
/// Largest |Wα| / |α| (unit columns) still counted as a positive null combination.
const MAX_NULL_RESIDUAL: f64 = 1e-6;

/// Whether the strings at `geometry` are force-closed (grip inside the complete region).
pub fn is_force_closed(geometry: &StringGeometry) -> bool {
    let (n, m) = (geometry.dof(), geometry.count());
    if m < n + 1 {
        return false;
    }
    let columns = normalised_columns(geometry);
    all_subsets_independent(&columns, n, m) && has_positive_null_combination(&columns, n, m)
}

/// Columns of W with torque rows divided by the largest lever arm (so both halves are of
/// comparable size), then scaled to unit length. Neither scaling changes closure.
fn normalised_columns(geometry: &StringGeometry) -> [[f64; 6]; MAX_VARS] {
    let (n, m) = (geometry.dof(), geometry.count());
    let mut columns = [[0.0; 6]; MAX_VARS];
    let mut arm: f64 = 0.0;
    for i in 0..m {
        let torque = &geometry.column(i)[3..n.max(3)];
        arm = arm.max(torque.iter().map(|t| t * t).sum::<f64>().sqrt());
    }
    for (i, column) in columns.iter_mut().enumerate().take(m) {
        *column = *geometry.column(i);
        if arm > 0.0 {
            for t in &mut column[3..n.max(3)] {
                *t /= arm;
            }
        }
        let norm = column[..n].iter().map(|v| v * v).sum::<f64>().sqrt();
        for v in &mut column[..n] {
            *v /= norm;
        }
    }
    columns
}

/// Every choice of `n` of the `m` columns is linearly independent.
fn all_subsets_independent(columns: &[[f64; 6]; MAX_VARS], n: usize, m: usize) -> bool {
    let mut pick = [0usize; 6];
    for (k, p) in pick.iter_mut().enumerate().take(n) {
        *p = k;
    }
    loop {
        let mut a = [[0.0; 6]; 6];
        for (c, &i) in pick.iter().enumerate().take(n) {
            for r in 0..n {
                a[r][c] = columns[i][r];
            }
        }
        if determinant(&mut a, n).abs() < MIN_DETERMINANT {
            return false;
        }
        // Next combination in lexicographic order.
        let Some(k) = (0..n).rev().find(|&k| pick[k] < m - n + k) else {
            return true;
        };
        pick[k] += 1;
        for j in k + 1..n {
            pick[j] = pick[j - 1] + 1;
        }
    }
}

/// Determinant by Gaussian elimination with partial pivoting (destroys `a`).
fn determinant(a: &mut [[f64; 6]; 6], n: usize) -> f64 {
    let mut det = 1.0;
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))
            .unwrap_or(col);
        if a[pivot][col] == 0.0 {
            return 0.0;
        }
        if pivot != col {
            a.swap(pivot, col);
            det = -det;
        }
        det *= a[col][col];
        for row in col + 1..n {
            let factor = a[row][col] / a[col][col];
            for k in col..n {
                a[row][k] -= factor * a[col][k];
            }
        }
    }
    det
}

/// Some α with every αᵢ ≥ 1 has Wα ≈ 0: minimise |Wα|² over α ≥ 1 with the box QP.
fn has_positive_null_combination(columns: &[[f64; 6]; MAX_VARS], n: usize, m: usize) -> bool {
    let mut q: Matrix = [[0.0; MAX_VARS]; MAX_VARS];
    for i in 0..m {
        for j in 0..m {
            q[i][j] = (0..n).map(|r| columns[i][r] * columns[j][r]).sum();
        }
        // Keeps Q definite; small enough not to mask a residual of MAX_NULL_RESIDUAL.
        q[i][i] += 1e-16;
    }
    let c: Vector = [0.0; MAX_VARS];
    let lower: Vector = [1.0; MAX_VARS];
    let upper: Vector = [1e6; MAX_VARS];
    let mut state = ActiveSet::default();
    let problem = BoxQp {
        q: &q,
        c: &c,
        lower: &lower,
        upper: &upper,
        n: m,
    };
    box_qp::solve(&problem, &mut state);
    let alpha = state.x();
    let mut residual = [0.0; 6];
    for (column, a) in columns.iter().zip(alpha).take(m) {
        for r in 0..n {
            residual[r] += column[r] * a;
        }
    }
    let norm_alpha = alpha[..m].iter().map(|a| a * a).sum::<f64>().sqrt();
    let norm_residual = residual[..n].iter().map(|v| v * v).sum::<f64>().sqrt();
    norm_residual <= MAX_NULL_RESIDUAL * norm_alpha
}

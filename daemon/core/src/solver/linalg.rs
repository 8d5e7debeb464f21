//! Fixed-size dense linear algebra for the small symmetric positive-definite systems of the
//! solvers.

/// Factor the leading `n`×`n` block of the symmetric matrix `a` in place as L D Lᵀ (L unit
/// lower triangular): L below the diagonal, 1/D on it. Only the lower triangle is read.
/// Returns `false` when a pivot of D falls below `min_pivot` (not positive definite).
///
/// LDLᵀ rather than Cholesky: no square roots, and one division per pivot, which keeps
/// the dependent chain of slow instructions short in these tiny systems.
pub fn ldlt_factor<const N: usize>(a: &mut [[f64; N]; N], n: usize, min_pivot: f64) -> bool {
    let mut d = [0.0; N];
    for j in 0..n {
        let mut pivot = a[j][j];
        for k in 0..j {
            pivot -= a[j][k] * a[j][k] * d[k];
        }
        if pivot.is_nan() || pivot <= min_pivot {
            return false;
        }
        d[j] = pivot;
        let inverse = 1.0 / pivot;
        a[j][j] = inverse;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k] * d[k];
            }
            a[i][j] = s * inverse;
        }
    }
    true
}

/// Solve L D Lᵀ x = b in place for the factor made by [`ldlt_factor`].
pub fn ldlt_solve<const N: usize>(f: &[[f64; N]; N], n: usize, b: &mut [f64; N]) {
    for i in 0..n {
        for k in 0..i {
            b[i] -= f[i][k] * b[k];
        }
    }
    for i in 0..n {
        b[i] *= f[i][i];
    }
    for i in (0..n).rev() {
        for k in i + 1..n {
            b[i] -= f[k][i] * b[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_known_system() {
        // A = [[4, 2, 0], [2, 5, 1], [0, 1, 3]], x = [1, -2, 3] → b = A x.
        let a0 = [[4.0, 2.0, 0.0], [2.0, 5.0, 1.0], [0.0, 1.0, 3.0]];
        let x = [1.0, -2.0, 3.0];
        let mut b = [0.0; 3];
        for i in 0..3 {
            b[i] = (0..3).map(|j| a0[i][j] * x[j]).sum();
        }
        let mut a = a0;
        assert!(ldlt_factor(&mut a, 3, 0.0));
        ldlt_solve(&a, 3, &mut b);
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-12, "{b:?}");
        }
    }

    #[test]
    fn rejects_an_indefinite_matrix() {
        let mut a = [[1.0, 2.0], [2.0, 1.0]];
        assert!(!ldlt_factor(&mut a, 2, 0.0));
    }
}

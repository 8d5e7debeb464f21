//! Fixed-size dense linear algebra for the small symmetric systems of the solvers.

/// Factor the leading `n`×`n` block of the symmetric matrix `a` in place into its lower
/// Cholesky factor L (a = L Lᵀ). Only the lower triangle is read. Returns `false` when the
/// block is not numerically positive definite (a pivot falls below `min_pivot`).
pub fn cholesky_factor<const N: usize>(a: &mut [[f64; N]; N], n: usize, min_pivot: f64) -> bool {
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        if !(d > min_pivot) {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k];
            }
            a[i][j] = s / d;
        }
    }
    true
}

/// Solve L Lᵀ x = b in place for the factor made by [`cholesky_factor`].
pub fn cholesky_solve<const N: usize>(l: &[[f64; N]; N], n: usize, b: &mut [f64; N]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * b[k];
        }
        b[i] = s / l[i][i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k][i] * b[k];
        }
        b[i] = s / l[i][i];
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
        assert!(cholesky_factor(&mut a, 3, 0.0));
        cholesky_solve(&a, 3, &mut b);
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-12, "{b:?}");
        }
    }

    #[test]
    fn rejects_an_indefinite_matrix() {
        let mut a = [[1.0, 2.0], [2.0, 1.0]];
        assert!(!cholesky_factor(&mut a, 2, 0.0));
    }
}

//! Small dense linear algebra in f64 on fixed-size arrays: Cholesky solve for the
//! Levenberg-Marquardt step and the cyclic Jacobi eigen-decomposition for the
//! identifiability analysis. Sizes are bounded by [`crate::capacity::MAX_FREE`].

use crate::capacity::MAX_FREE;

/// Square matrix of the largest supported size; only the leading `n x n` block is used.
pub type Mat = [[f64; MAX_FREE]; MAX_FREE];
/// Vector of the largest supported size.
pub type Vector = [f64; MAX_FREE];

/// Solve `a x = b` for symmetric positive definite `a` (leading `n x n` block).
/// Returns `None` when `a` is not numerically positive definite.
pub fn cholesky_solve(a: &Mat, b: &Vector, n: usize) -> Option<Vector> {
    let mut l = [[0.0f64; MAX_FREE]; MAX_FREE];
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s.is_nan() || s <= 0.0 || !s.is_finite() {
                    return None;
                }
                l[i][i] = libm::sqrt(s);
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut y = [0.0f64; MAX_FREE];
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s / l[i][i];
    }
    let mut x = [0.0f64; MAX_FREE];
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    Some(x)
}

/// Eigen-decomposition of a symmetric matrix by cyclic Jacobi rotations.
/// Returns eigenvalues (ascending) and eigenvectors as columns `vecs[row][k]`.
pub fn symmetric_eigen(a: &Mat, n: usize) -> (Vector, Mat) {
    let mut m = *a;
    let mut v = [[0.0f64; MAX_FREE]; MAX_FREE];
    for (i, row) in v.iter_mut().enumerate().take(n) {
        row[i] = 1.0;
    }
    for _sweep in 0..60 {
        let mut off = 0.0;
        let mut diag = 0.0;
        for i in 0..n {
            diag += m[i][i] * m[i][i];
            for j in i + 1..n {
                off += m[i][j] * m[i][j];
            }
        }
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if m[p][q] == 0.0 {
                    continue;
                }
                let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
                let t = if theta >= 0.0 {
                    1.0 / (theta + libm::sqrt(1.0 + theta * theta))
                } else {
                    -1.0 / (-theta + libm::sqrt(1.0 + theta * theta))
                };
                let c = 1.0 / libm::sqrt(1.0 + t * t);
                let s = t * c;
                for k in 0..n {
                    let mkp = m[k][p];
                    let mkq = m[k][q];
                    m[k][p] = c * mkp - s * mkq;
                    m[k][q] = s * mkp + c * mkq;
                }
                for k in 0..n {
                    let mpk = m[p][k];
                    let mqk = m[q][k];
                    m[p][k] = c * mpk - s * mqk;
                    m[q][k] = s * mpk + c * mqk;
                }
                for row in v.iter_mut().take(n) {
                    let vkp = row[p];
                    let vkq = row[q];
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
    }
    // Sort ascending (selection sort on at most MAX_FREE entries).
    let mut vals = [0.0f64; MAX_FREE];
    for (i, val) in vals.iter_mut().enumerate().take(n) {
        *val = m[i][i];
    }
    for i in 0..n {
        let mut min = i;
        for j in i + 1..n {
            if vals[j] < vals[min] {
                min = j;
            }
        }
        if min != i {
            vals.swap(i, min);
            for row in v.iter_mut().take(n) {
                row.swap(i, min);
            }
        }
    }
    (vals, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_a_known_system() {
        let mut a = [[0.0; MAX_FREE]; MAX_FREE];
        a[0][0] = 4.0;
        a[0][1] = 2.0;
        a[1][0] = 2.0;
        a[1][1] = 3.0;
        let mut b = [0.0; MAX_FREE];
        b[0] = 2.0;
        b[1] = 1.0;
        // Exact solution of [[4,2],[2,3]] x = [2,1] is x = [0.5, 0].
        let x = cholesky_solve(&a, &b, 2).unwrap();
        assert!((x[0] - 0.5).abs() < 1e-12 && x[1].abs() < 1e-12);
        a[1][1] = 1.0; // det = 0: not positive definite
        assert!(cholesky_solve(&a, &b, 2).is_none());
    }

    #[test]
    fn eigen_of_a_rank_one_plus_identity() {
        // a = I + u u^T with u = (1, 1, 1): eigenvalues 1, 1, 4; eigenvector of 4 is u/sqrt 3.
        let mut a = [[0.0; MAX_FREE]; MAX_FREE];
        for (i, row) in a.iter_mut().enumerate().take(3) {
            for (j, x) in row.iter_mut().enumerate().take(3) {
                *x = if i == j { 2.0 } else { 1.0 };
            }
        }
        let (vals, vecs) = symmetric_eigen(&a, 3);
        assert!((vals[0] - 1.0).abs() < 1e-12);
        assert!((vals[1] - 1.0).abs() < 1e-12);
        assert!((vals[2] - 4.0).abs() < 1e-12);
        for row in vecs.iter().take(3) {
            assert!((row[2].abs() - 1.0 / libm::sqrt(3.0)).abs() < 1e-9);
        }
    }
}

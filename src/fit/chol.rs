//! Envelope (skyline) Cholesky factorization `N = L L^T` of a symmetric positive definite
//! matrix, dense storage, work limited to each row's envelope (from its first nonzero
//! column to the diagonal), which `L` inherits from `N`. With variables ordered along the
//! mesh (see [`super::param::Param::new`]) the envelope is narrow.

/// A lower-triangular factor in dense row-major storage with row envelopes.
#[derive(Clone, Debug)]
pub struct Cholesky {
    n: usize,
    l: Vec<f64>,
    first: Vec<usize>,
}

impl Cholesky {
    /// Factors `a` (`n x n`, row-major, symmetric; only the lower triangle is read).
    /// Returns the failing row when a pivot is not positive (the matrix is not positive
    /// definite).
    pub fn factor(n: usize, mut a: Vec<f64>) -> Result<Cholesky, usize> {
        let first: Vec<usize> =
            (0..n).map(|i| (0..i).find(|&j| a[i * n + j] != 0.0).unwrap_or(i)).collect();
        for i in 0..n {
            let fi = first[i];
            for j in fi..i {
                let k0 = fi.max(first[j]);
                let (ri, rj) = (i * n, j * n);
                let mut s = a[ri + j];
                for k in k0..j {
                    s -= a[ri + k] * a[rj + k];
                }
                a[ri + j] = s / a[rj + j];
            }
            let ri = i * n;
            let mut s = a[ri + i];
            for k in fi..i {
                s -= a[ri + k] * a[ri + k];
            }
            if s <= 0.0 || !s.is_finite() {
                return Err(i);
            }
            a[ri + i] = s.sqrt();
        }
        Ok(Cholesky { n, l: a, first })
    }

    /// Dimension.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Solves `L z = b` in place.
    pub fn solve_lower(&self, b: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            let ri = i * n;
            let mut s = b[i];
            for k in self.first[i]..i {
                s -= self.l[ri + k] * b[k];
            }
            b[i] = s / self.l[ri + i];
        }
    }

    /// Solves `L^T z = b` in place.
    pub fn solve_upper(&self, b: &mut [f64]) {
        let n = self.n;
        for i in (0..n).rev() {
            let ri = i * n;
            b[i] /= self.l[ri + i];
            let bi = b[i];
            for k in self.first[i]..i {
                b[k] -= self.l[ri + k] * bi;
            }
        }
    }

    /// Solves `N z = b` in place.
    pub fn solve(&self, b: &mut [f64]) {
        self.solve_lower(b);
        self.solve_upper(b);
    }

    /// `L` as a dense row-major matrix (for tests).
    pub fn lower(&self) -> &[f64] {
        &self.l
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factor_rebuilds_a_banded_matrix_and_solves() {
        let n = 9;
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            a[i * n + i] = 4.0 + i as f64;
            if i >= 2 {
                a[i * n + i - 2] = 1.0;
                a[(i - 2) * n + i] = 1.0;
            }
        }
        let c = Cholesky::factor(n, a.clone()).unwrap();
        let l = c.lower();
        for i in 0..n {
            for j in 0..=i {
                let s: f64 = (0..=j).map(|k| l[i * n + k] * l[j * n + k]).sum();
                assert!((s - a[i * n + j]).abs() < 1e-12, "({i},{j})");
            }
        }
        let x: Vec<f64> = (0..n).map(|i| i as f64 - 3.0).collect();
        let mut b: Vec<f64> = (0..n).map(|i| (0..n).map(|j| a[i * n + j] * x[j]).sum()).collect();
        c.solve(&mut b);
        for i in 0..n {
            assert!((b[i] - x[i]).abs() < 1e-12);
        }
    }

    #[test]
    fn indefinite_matrix_is_refused() {
        let a = vec![1.0, 2.0, 2.0, 1.0];
        assert_eq!(Cholesky::factor(2, a).unwrap_err(), 1);
    }
}

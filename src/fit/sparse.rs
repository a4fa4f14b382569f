//! Sparse symmetric positive definite systems for the fit: assembly from triplets and a
//! supernodal Cholesky factorization `A = L L^T` by `faer` (fill-reducing ordering chosen by
//! faer's symbolic analysis), with the symbolic part reused when only the values change.
//!
//! Only the lower triangle is stored and read. A failed factorization (a matrix that is not
//! numerically positive definite) is reported, never papered over: callers decide whether a
//! ridge is meaningful.

use faer::linalg::solvers::SolveCore;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{Argsort, Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Conj, MatMut, Side};

/// The sparsity pattern of a symmetric matrix (lower triangle) with the order in which
/// values are given, and its symbolic Cholesky analysis.
#[derive(Clone, Debug)]
pub struct Pattern {
    n: usize,
    pairs: Vec<(usize, usize)>,
    symbolic: SymbolicSparseColMat<usize>,
    argsort: Argsort<usize>,
    llt: SymbolicLlt<usize>,
}

/// Why a sparse factorization failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SparseError {
    /// The matrix is not (numerically) positive definite.
    #[error("the system matrix is not positive definite")]
    NotPositiveDefinite,
    /// faer refused the structure (out of memory or an index overflow).
    #[error("sparse factorization failed: {0}")]
    Structure(String),
}

impl Pattern {
    /// A pattern of an `n x n` matrix from its entries `(row, col)`; entries with
    /// `row < col` are mirrored to the lower triangle and duplicates are summed later.
    pub fn new(n: usize, entries: &[(usize, usize)]) -> Result<Pattern, SparseError> {
        let pairs: Vec<(usize, usize)> =
            entries.iter().map(|&(r, c)| if r >= c { (r, c) } else { (c, r) }).collect();
        let idx: Vec<Pair<usize, usize>> = pairs.iter().map(|&(r, c)| Pair::new(r, c)).collect();
        let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(n, n, &idx)
            .map_err(|e| SparseError::Structure(format!("{e:?}")))?;
        let llt = SymbolicLlt::try_new(symbolic.as_ref(), Side::Lower)
            .map_err(|e| SparseError::Structure(format!("{e:?}")))?;
        Ok(Pattern { n, pairs, symbolic, argsort, llt })
    }

    /// The matrix order.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of entries (values expected by [`factor`](Self::factor)).
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// Whether the pattern has no entries.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// Factors the matrix whose entries, in the order given to [`new`](Self::new), are
    /// `values` (duplicates summed).
    pub fn factor(&self, values: &[f64]) -> Result<Factor, SparseError> {
        assert_eq!(values.len(), self.pairs.len(), "one value per pattern entry");
        let mat = SparseColMat::new_from_argsort(self.symbolic.clone(), &self.argsort, values)
            .map_err(|e| SparseError::Structure(format!("{e:?}")))?;
        let llt = Llt::try_new_with_symbolic(self.llt.clone(), mat.as_ref(), Side::Lower)
            .map_err(|_| SparseError::NotPositiveDefinite)?;
        Ok(Factor { n: self.n, llt })
    }
}

/// A numeric factorization `A = L L^T`.
#[derive(Clone, Debug)]
pub struct Factor {
    n: usize,
    llt: Llt<usize, f64>,
}

impl Factor {
    /// The matrix order.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Solves `A x = b` in place (`b` has `n` entries).
    pub fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        self.solve_many(b, n, 1);
    }

    /// Solves `A X = B` in place for `cols` right-hand sides stored column after column in
    /// `b` (`n * cols` entries).
    pub fn solve_many(&self, b: &mut [f64], n: usize, cols: usize) {
        assert_eq!(n, self.n);
        assert_eq!(b.len(), n * cols);
        if n == 0 || cols == 0 {
            return;
        }
        let m = MatMut::from_column_major_slice_mut(b, n, cols);
        self.llt.solve_in_place_with_conj(Conj::No, m);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_small_spd_system_and_rebuilds_the_right_hand_side() {
        // Tridiagonal 2, -1 plus a corner coupling; entries given in both triangles and
        // with duplicates to check mirroring and summation.
        let n = 6;
        let mut entries = Vec::new();
        let mut vals = Vec::new();
        for i in 0..n {
            entries.push((i, i));
            vals.push(1.5);
            entries.push((i, i));
            vals.push(1.5);
            if i + 1 < n {
                entries.push((i, i + 1));
                vals.push(-1.0);
            }
        }
        entries.push((n - 1, 0));
        vals.push(0.25);
        let p = Pattern::new(n, &entries).unwrap();
        let f = p.factor(&vals).unwrap();
        let x_true: Vec<f64> = (0..n).map(|i| i as f64 - 2.5).collect();
        let mut b = vec![0.0; n];
        for (&(r, c), &v) in entries.iter().zip(&vals) {
            b[r] += v * x_true[c];
            if r != c {
                b[c] += v * x_true[r];
            }
        }
        f.solve(&mut b);
        for (a, e) in b.iter().zip(&x_true) {
            assert!((a - e).abs() < 1e-12, "{a} vs {e}");
        }
    }

    #[test]
    fn an_indefinite_matrix_is_reported() {
        let p = Pattern::new(2, &[(0, 0), (1, 1), (1, 0)]).unwrap();
        assert_eq!(p.factor(&[1.0, 1.0, 2.0]).unwrap_err(), SparseError::NotPositiveDefinite);
    }
}

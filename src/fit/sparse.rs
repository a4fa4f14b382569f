//! Sparse symmetric positive definite systems for the fit: assembly from triplets and a
//! supernodal Cholesky factorization `A = L L^T` by `faer` (fill-reducing ordering chosen by
//! faer's symbolic analysis), with the symbolic part reused when only the values change.
//!
//! The numeric factorization and each solve run on one thread ([`FACTOR_PAR`]): the fit's
//! systems (a few thousand to a few tens of thousands of unknowns, supernodes of a few
//! dozen columns) are too small for faer's parallel supernodal code to pay off. Measured
//! on the `fit_frame` bench's systems (2 cores): 1,421 unknowns factor in 1.4 ms on one
//! thread against 4.7 ms in parallel, 12,500 unknowns in 29 ms against 58 ms. Parallelism
//! comes from the caller instead: [`Factor::solve_many`] solves blocks of right-hand sides
//! on rayon's workers.
//!
//! Only the lower triangle is stored and read. A failed factorization (a matrix that is not
//! numerically positive definite) is reported, never papered over: callers decide whether a
//! ridge is meaningful.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, LltRef, SymbolicCholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use rayon::prelude::*;
use std::sync::Arc;

/// faer's parallelism for the numeric factorization and the solves (see the module docs).
pub const FACTOR_PAR: Par = Par::Seq;

/// Right-hand sides solved together by [`Factor::solve_many`]: 32 columns of a 10,000-row
/// system take 2.5 MB, which stays in cache while the factor is swept.
pub const SOLVE_BLOCK: usize = 32;

/// The sparsity pattern of a symmetric matrix (lower triangle) with the order in which
/// values are given, and its symbolic Cholesky analysis.
#[derive(Clone, Debug)]
pub struct Pattern {
    n: usize,
    /// Position in the compressed columns of each given entry (duplicates share one).
    pos: Vec<usize>,
    symbolic: SymbolicSparseColMat<usize>,
    llt: Arc<SymbolicCholesky<usize>>,
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
    ///
    /// The compressed columns are built by a counting sort on the column and a marker per
    /// row (linear in the number of entries; finite-element assembly repeats most entries
    /// several times), rows sorted within each column.
    ///
    /// # Panics
    /// Panics if an entry lies outside `n x n`.
    pub fn new(n: usize, entries: &[(usize, usize)]) -> Result<Pattern, SparseError> {
        let lower = |&(r, c): &(usize, usize)| if r >= c { (r, c) } else { (c, r) };
        let mut start = vec![0usize; n + 1];
        for e in entries {
            let (r, c) = lower(e);
            assert!(r < n, "entry ({r}, {c}) outside a {n} x {n} matrix");
            start[c + 1] += 1;
        }
        for c in 0..n {
            start[c + 1] += start[c];
        }
        // Entries bucketed by column, in their given order.
        let mut by_col = vec![0usize; entries.len()];
        let mut fill = start.clone();
        for (i, e) in entries.iter().enumerate() {
            let c = lower(e).1;
            by_col[fill[c]] = i;
            fill[c] += 1;
        }
        let mut pos = vec![0usize; entries.len()];
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx: Vec<usize> = Vec::new();
        let mut mark = vec![usize::MAX; n];
        let mut slot = vec![0usize; n];
        let mut rows: Vec<usize> = Vec::new();
        col_ptr.push(0);
        for c in 0..n {
            rows.clear();
            for &i in &by_col[start[c]..start[c + 1]] {
                let r = lower(&entries[i]).0;
                if mark[r] != c {
                    mark[r] = c;
                    rows.push(r);
                }
            }
            rows.sort_unstable();
            for &r in &rows {
                slot[r] = row_idx.len();
                row_idx.push(r);
            }
            for &i in &by_col[start[c]..start[c + 1]] {
                pos[i] = slot[lower(&entries[i]).0];
            }
            col_ptr.push(row_idx.len());
        }
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let llt = factorize_symbolic_cholesky(
            symbolic.as_ref(),
            Side::Lower,
            Default::default(),
            Default::default(),
        )
        .map_err(|e| SparseError::Structure(format!("{e:?}")))?;
        Ok(Pattern { n, pos, symbolic, llt: Arc::new(llt) })
    }

    /// The matrix order.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of entries (values expected by [`factor`](Self::factor)).
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// Whether the pattern has no entries.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Factors the matrix whose entries, in the order given to [`new`](Self::new), are
    /// `values` (duplicates summed in the order given).
    pub fn factor(&self, values: &[f64]) -> Result<Factor, SparseError> {
        assert_eq!(values.len(), self.pos.len(), "one value per pattern entry");
        let mut csc = vec![0.0; self.symbolic.row_idx().len()];
        for (&p, &v) in self.pos.iter().zip(values) {
            csc[p] += v;
        }
        let mat = SparseColMatRef::new(self.symbolic.as_ref(), &csc);
        let mut values = Vec::new();
        values
            .try_reserve_exact(self.llt.len_val())
            .map_err(|e| SparseError::Structure(e.to_string()))?;
        values.resize(self.llt.len_val(), 0.0f64);
        let scratch = self.llt.factorize_numeric_llt_scratch::<f64>(FACTOR_PAR, Default::default());
        let mut mem =
            MemBuffer::try_new(scratch).map_err(|e| SparseError::Structure(format!("{e:?}")))?;
        self.llt
            .factorize_numeric_llt::<f64>(
                &mut values,
                mat,
                Side::Lower,
                LltRegularization::default(),
                FACTOR_PAR,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|_| SparseError::NotPositiveDefinite)?;
        Ok(Factor { n: self.n, symbolic: Arc::clone(&self.llt), values })
    }
}

/// A numeric factorization `A = L L^T`.
#[derive(Clone, Debug)]
pub struct Factor {
    n: usize,
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// `L`'s values in the symbolic structure's layout.
    values: Vec<f64>,
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
        // Blocks of columns: each block's working set stays in cache while the supernodes
        // are swept, and the blocks are solved in parallel.
        let llt = LltRef::new(&self.symbolic, &self.values);
        b.par_chunks_mut(n * SOLVE_BLOCK).for_each_init(
            || MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(SOLVE_BLOCK, FACTOR_PAR)),
            |mem, blk| {
                let c = blk.len() / n;
                let m = MatMut::from_column_major_slice_mut(blk, n, c);
                llt.solve_in_place_with_conj(Conj::No, m, FACTOR_PAR, MemStack::new(mem));
            },
        );
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

    proptest::proptest! {
        /// Random diagonally dominant matrices given as shuffled, mirrored and repeated
        /// entries: the solve matches the matrix assembled densely.
        #[test]
        fn assembly_sums_duplicates_in_any_order(
            n in 1usize..12,
            raw in proptest::collection::vec((0usize..12, 0usize..12, -1.0f64..1.0), 0..60),
        ) {
            let mut entries: Vec<(usize, usize)> = Vec::new();
            let mut vals = Vec::new();
            let mut dense = vec![0.0; n * n];
            for &(r, c, v) in &raw {
                let (r, c) = (r % n, c % n);
                entries.push((r, c));
                vals.push(v);
                let (a, b) = if r >= c { (r, c) } else { (c, r) };
                dense[a * n + b] += v;
                if a != b {
                    dense[b * n + a] += v;
                }
            }
            for i in 0..n {
                entries.push((i, i));
                vals.push(2.0 * raw.len() as f64 + 1.0);
                dense[i * n + i] += 2.0 * raw.len() as f64 + 1.0;
            }
            let f = Pattern::new(n, &entries).unwrap().factor(&vals).unwrap();
            let x_true: Vec<f64> = (0..n).map(|i| i as f64 * 0.5 - 1.0).collect();
            let mut b: Vec<f64> =
                (0..n).map(|i| (0..n).map(|j| dense[i * n + j] * x_true[j]).sum()).collect();
            f.solve(&mut b);
            for (a, e) in b.iter().zip(&x_true) {
                proptest::prop_assert!((a - e).abs() < 1e-10, "{} vs {}", a, e);
            }
        }
    }

    #[test]
    fn many_right_hand_sides_in_blocks_match_one_at_a_time() {
        let n = 7;
        let mut entries = Vec::new();
        let mut vals = Vec::new();
        for i in 0..n {
            entries.push((i, i));
            vals.push(4.0);
            if i > 0 {
                entries.push((i, i - 1));
                vals.push(-1.0);
            }
        }
        let f = Pattern::new(n, &entries).unwrap().factor(&vals).unwrap();
        let cols = 2 * SOLVE_BLOCK + 3;
        let mut many: Vec<f64> = (0..n * cols).map(|i| (i % 11) as f64 - 5.0).collect();
        let mut single = many.clone();
        f.solve_many(&mut many, n, cols);
        for c in 0..cols {
            f.solve(&mut single[c * n..(c + 1) * n]);
        }
        assert_eq!(many, single);
    }

    #[test]
    fn an_indefinite_matrix_is_reported() {
        let p = Pattern::new(2, &[(0, 0), (1, 1), (1, 0)]).unwrap();
        assert_eq!(p.factor(&[1.0, 1.0, 2.0]).unwrap_err(), SparseError::NotPositiveDefinite);
    }
}

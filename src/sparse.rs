//! Sparse symmetric positive definite systems (the fit's bending systems, the editor's
//! select-all solve): assembly from triplets and a supernodal Cholesky factorization
//! `A = L L^T` by `faer` (fill-reducing ordering chosen by faer's symbolic analysis), with
//! the symbolic part reused when only the values change.
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
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par, Side};
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
        let mut cols = Columns::new(n);
        for c in 0..n {
            let here = &by_col[start[c]..start[c + 1]];
            cols.push(c, here.iter().map(|&i| lower(&entries[i]).0));
            for &i in here {
                pos[i] = cols.slot[lower(&entries[i]).0];
            }
        }
        cols.analyse(pos)
    }

    /// The pattern of `sum_t S_t^T B_t S_t`-like matrices whose blocks are dense over
    /// `cliques[t]`, given in the order of [`lower_clique_entries`] and, with
    /// `diagonal`, the `n` diagonal entries after them: the same pattern (and the same
    /// positions) as [`new`](Self::new) on those entries, built without listing them.
    ///
    /// Each clique must be strictly ascending, so that its lower-triangle pairs are
    /// `(c[z1], c[z2])` for `z2 <= z1`. The compressed columns are built column by column
    /// from the cliques that contain the column (a marker per row, rows sorted), and each
    /// clique's entries get their positions from its columns in turn.
    ///
    /// # Panics
    /// Panics if a clique is not strictly ascending or holds an index `>= n`.
    pub fn from_cliques(
        n: usize,
        cliques: &[Vec<usize>],
        diagonal: bool,
    ) -> Result<Pattern, SparseError> {
        // Offsets of each clique's entries, and the cliques of each column.
        let mut offset = Vec::with_capacity(cliques.len() + 1);
        let mut total = 0usize;
        let mut count = vec![0usize; n + 1];
        for c in cliques {
            assert!(c.windows(2).all(|w| w[0] < w[1]), "clique not strictly ascending");
            offset.push(total);
            total += c.len() * (c.len() + 1) / 2;
            for &v in c {
                assert!(v < n, "clique index {v} outside a {n} x {n} matrix");
                count[v + 1] += 1;
            }
        }
        for v in 0..n {
            count[v + 1] += count[v];
        }
        // (clique, position of the column in it), per column.
        let mut member = vec![(0u32, 0u32); count[n]];
        let mut fill = count.clone();
        for (t, c) in cliques.iter().enumerate() {
            for (z, &v) in c.iter().enumerate() {
                member[fill[v]] = (t as u32, z as u32);
                fill[v] += 1;
            }
        }
        let mut pos = vec![0usize; total + if diagonal { n } else { 0 }];
        let mut cols = Columns::new(n);
        for col in 0..n {
            let here = &member[count[col]..count[col + 1]];
            let rows = here.iter().flat_map(|&(t, z)| &cliques[t as usize][z as usize..]);
            cols.push(col, rows.copied().chain(diagonal.then_some(col)));
            // Entry (c[z1], c[z2]) with z2 = z sits at offset + z1 (z1 + 1) / 2 + z2.
            for &(t, z) in here {
                let (c, z2) = (&cliques[t as usize], z as usize);
                for (z1, &r) in c.iter().enumerate().skip(z2) {
                    pos[offset[t as usize] + z1 * (z1 + 1) / 2 + z2] = cols.slot[r];
                }
            }
            if diagonal {
                pos[total + col] = cols.slot[col];
            }
        }
        cols.analyse(pos)
    }

    /// The matrix order.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of entries (values expected by [`factor`](Self::factor)).
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// Number of values of the Cholesky factor [`factor`](Self::factor) will store (from the
    /// symbolic analysis, before any numeric work): a bound on its memory.
    pub fn factor_len(&self) -> usize {
        self.llt.len_val()
    }

    /// Whether the pattern has no entries.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Factors the matrix whose entries, in the order given to [`new`](Self::new), are
    /// `values` (duplicates summed in the order given).
    pub fn factor(&self, values: &[f64]) -> Result<Factor, SparseError> {
        self.refactor(values, None)
    }

    /// [`factor`](Self::factor), reusing the buffers of `spare`, an earlier factor of this
    /// pattern (an iteration that factors a matrix per step allocates, zero-fills and
    /// faults in the factor's pages once instead of every step). A factor of another
    /// pattern is dropped.
    pub fn refactor(&self, values: &[f64], spare: Option<Factor>) -> Result<Factor, SparseError> {
        assert_eq!(values.len(), self.pos.len(), "one value per pattern entry");
        let (mut lvals, mut csc) = match spare {
            Some(f) if Arc::ptr_eq(&f.symbolic, &self.llt) => (f.values, f.csc),
            _ => (Vec::new(), Vec::new()),
        };
        csc.clear();
        csc.resize(self.symbolic.row_idx().len(), 0.0);
        for (&p, &v) in self.pos.iter().zip(values) {
            csc[p] += v;
        }
        let mat = SparseColMatRef::new(self.symbolic.as_ref(), &csc);
        let mut values = std::mem::take(&mut lvals);
        values.clear();
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
        Ok(Factor { n: self.n, symbolic: Arc::clone(&self.llt), values, csc })
    }
}

/// Compressed lower columns built one column at a time ([`Pattern::new`] and
/// [`Pattern::from_cliques`]): each column's rows are deduplicated with a marker per row,
/// sorted, and appended to `row_idx`; `slot[r]` is then row `r`'s place in it.
struct Columns {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// The last column that listed each row.
    mark: Vec<usize>,
    /// Each row's place in `row_idx`, for the column just pushed.
    slot: Vec<usize>,
    /// Scratch: the rows of the current column.
    rows: Vec<usize>,
}

impl Columns {
    fn new(n: usize) -> Columns {
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let (mark, slot) = (vec![usize::MAX; n], vec![0usize; n]);
        Columns { n, col_ptr, row_idx: Vec::new(), mark, slot, rows: Vec::new() }
    }

    /// Appends column `col` (the next one) with `rows`, repeats allowed.
    fn push(&mut self, col: usize, rows: impl IntoIterator<Item = usize>) {
        debug_assert_eq!(col + 1, self.col_ptr.len(), "columns pushed in order");
        self.rows.clear();
        for r in rows {
            if self.mark[r] != col {
                self.mark[r] = col;
                self.rows.push(r);
            }
        }
        self.rows.sort_unstable();
        for &r in &self.rows {
            self.slot[r] = self.row_idx.len();
            self.row_idx.push(r);
        }
        self.col_ptr.push(self.row_idx.len());
    }

    /// The symbolic analysis of the columns, with each entry's position `pos`.
    fn analyse(self, pos: Vec<usize>) -> Result<Pattern, SparseError> {
        let n = self.n;
        let symbolic = SymbolicSparseColMat::new_checked(n, n, self.col_ptr, None, self.row_idx);
        let llt = factorize_symbolic_cholesky(
            symbolic.as_ref(),
            Side::Lower,
            Default::default(),
            Default::default(),
        )
        .map_err(|e| SparseError::Structure(format!("{e:?}")))?;
        Ok(Pattern { n, pos, symbolic, llt: Arc::new(llt) })
    }
}

/// The lower-triangle entries of dense blocks over strictly ascending `cliques`, clique
/// after clique: `(c[z1], c[z2])` for `z2 <= z1`, `z1` then `z2` ascending (the order
/// [`Pattern::from_cliques`] expects its values in).
pub fn lower_clique_entries(cliques: &[Vec<usize>]) -> Vec<(usize, usize)> {
    let count: usize = cliques.iter().map(|c| c.len() * (c.len() + 1) / 2).sum();
    let mut entries = Vec::with_capacity(count);
    for c in cliques {
        for (z1, &a) in c.iter().enumerate() {
            entries.extend(c[..=z1].iter().map(|&b| (a, b)));
        }
    }
    entries
}

/// A numeric factorization `A = L L^T`.
#[derive(Clone, Debug)]
pub struct Factor {
    n: usize,
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// `L`'s values in the symbolic structure's layout.
    values: Vec<f64>,
    /// The matrix's compressed values (kept for [`Pattern::refactor`]).
    csc: Vec<f64>,
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

/// `L^-1 P B` for one block of sparse right-hand sides, kept on the nodes it reaches only
/// (see [`Factor::inverse_gram`]).
struct Reached {
    /// The block's columns (indices into the caller's list).
    cols: Vec<usize>,
    /// Nodes of `L` where the block is not zero, ascending.
    nodes: Vec<usize>,
    /// Row of each reached node's first entry in `vals`.
    offs: Vec<usize>,
    /// The reached rows, `rows x cols.len()`, column-major.
    vals: Vec<f64>,
    rows: usize,
}

impl Reached {
    fn mat(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.vals, self.rows, self.cols.len())
    }
}

impl Factor {
    /// The column groups of `L`: supernodes, or single columns of a simplicial factor.
    /// Returns each node's first column (and `n` at the end).
    fn node_starts(&self) -> Vec<usize> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => {
                let mut v: Vec<usize> = s.supernode_begin().to_vec();
                v.push(self.n);
                v
            }
            SymbolicCholeskyRaw::Simplicial(_) => (0..=self.n).collect(),
        }
    }

    /// The Gram matrix `B^T A^-1 B` (row-major, `k x k`) of `k` sparse columns `b_j`, given
    /// as `(row, value)` lists in the matrix's own order.
    ///
    /// With `A = P^T L L^T P`, `B^T A^-1 B = G^T G` for `G = L^-1 P B`, and a column of `G`
    /// is zero outside the nodes of `L` that its right-hand side reaches (the nodes of its
    /// nonzero rows and their ancestors in the elimination tree): for right-hand sides with
    /// a few nonzeros, such as the landmark rows of a fit, a small part of `L`. So the
    /// columns are grouped by where they start ([`SOLVE_BLOCK`] per block), each block is
    /// forward-substituted skipping the nodes where it is still zero (which leaves every
    /// value as the full substitution computes it), and `G^T G` is summed block pair by
    /// block pair over the nodes both blocks reach. Neither the backward substitution nor
    /// the dense `A^-1 B` is formed.
    pub fn inverse_gram(&self, cols: &[Vec<(usize, f64)>]) -> Vec<f64> {
        let (n, k) = (self.n, cols.len());
        let mut gram = vec![0.0; k * k];
        if n == 0 || k == 0 {
            return gram;
        }
        let inv: Vec<usize> = match self.symbolic.perm() {
            Some(p) => p.arrays().1.to_vec(),
            None => (0..n).collect(),
        };
        let starts = self.node_starts();
        let mut node_of = vec![0usize; n];
        for s in 0..starts.len() - 1 {
            node_of[starts[s]..starts[s + 1]].fill(s);
        }
        // Columns ordered by the first node they touch: nodes are numbered in postorder,
        // so columns in one subtree come together and their blocks reach few nodes.
        let first = |b: &Vec<(usize, f64)>| {
            b.iter().filter(|e| e.1 != 0.0).map(|&(r, _)| node_of[inv[r]]).min()
        };
        let mut order: Vec<(usize, usize)> =
            cols.iter().enumerate().map(|(j, b)| (first(b).unwrap_or(usize::MAX), j)).collect();
        order.sort_unstable();
        let blocks: Vec<Vec<usize>> =
            order.chunks(SOLVE_BLOCK).map(|c| c.iter().map(|&(_, j)| j).collect()).collect();
        let reached: Vec<Reached> = blocks
            .into_par_iter()
            .map_init(
                || vec![0.0f64; n * SOLVE_BLOCK],
                |x, block| self.forward_block(x, &starts, &inv, cols, block),
            )
            .collect();
        let pairs: Vec<(usize, usize)> =
            (0..reached.len()).flat_map(|i| (i..reached.len()).map(move |j| (i, j))).collect();
        let products: Vec<Mat<f64>> =
            pairs.par_iter().map(|&(i, j)| node_products(&reached[i], &reached[j])).collect();
        for (&(i, j), p) in pairs.iter().zip(&products) {
            for (a, &ca) in reached[i].cols.iter().enumerate() {
                for (b, &cb) in reached[j].cols.iter().enumerate() {
                    gram[ca * k + cb] = p[(a, b)];
                    gram[cb * k + ca] = p[(a, b)];
                }
            }
        }
        gram
    }

    /// Forward substitution `L y = P b` of one block of columns in the scratch `x`
    /// (`n x SOLVE_BLOCK`, left zero on return), skipping nodes where the block is zero.
    fn forward_block(
        &self,
        x: &mut [f64],
        starts: &[usize],
        inv: &[usize],
        cols: &[Vec<(usize, f64)>],
        block: Vec<usize>,
    ) -> Reached {
        let n = self.n;
        let c = block.len();
        let x = &mut x[..n * c];
        for (a, &j) in block.iter().enumerate() {
            for &(r, v) in &cols[j] {
                x[a * n + inv[r]] += v;
            }
        }
        let mut nodes = Vec::new();
        let nonzero = |x: &[f64], lo: usize, hi: usize| {
            (0..c).any(|a| x[a * n + lo..a * n + hi].iter().any(|&v| v != 0.0))
        };
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sym) => {
                let llt = SupernodalLltRef::new(sym, &self.values);
                let mut tmp: Vec<f64> = Vec::new();
                for s in 0..starts.len() - 1 {
                    let (lo, hi) = (starts[s], starts[s + 1]);
                    if !nonzero(x, lo, hi) {
                        continue;
                    }
                    nodes.push(s);
                    let node = llt.supernode(s);
                    let size = hi - lo;
                    let (top, bot) = node.val().split_at_row(size);
                    let pattern = node.pattern();
                    let mut xm = MatMut::from_column_major_slice_mut(x, n, c);
                    solve_lower_triangular_in_place(
                        top,
                        xm.as_mut().subrows_mut(lo, size),
                        Par::Seq,
                    );
                    if pattern.is_empty() {
                        continue;
                    }
                    tmp.clear();
                    tmp.resize(pattern.len() * c, 0.0);
                    let mut t = MatMut::from_column_major_slice_mut(&mut tmp, pattern.len(), c);
                    matmul(
                        t.as_mut(),
                        Accum::Replace,
                        bot,
                        xm.as_ref().subrows(lo, size),
                        1.0,
                        Par::Seq,
                    );
                    for a in 0..c {
                        for (idx, &i) in pattern.iter().enumerate() {
                            x[a * n + i] -= t[(idx, a)];
                        }
                    }
                }
            }
            SymbolicCholeskyRaw::Simplicial(sym) => {
                let l = sym.factor();
                let (cp, ri) = (l.col_ptr(), l.row_idx());
                for j in 0..n {
                    if !nonzero(x, j, j + 1) {
                        continue;
                    }
                    nodes.push(j);
                    let d = self.values[cp[j]];
                    for a in 0..c {
                        let xj = x[a * n + j] / d;
                        x[a * n + j] = xj;
                        for p in cp[j] + 1..cp[j + 1] {
                            x[a * n + ri[p]] -= self.values[p] * xj;
                        }
                    }
                }
            }
        }
        let mut offs = Vec::with_capacity(nodes.len());
        let mut rows = 0;
        for &s in &nodes {
            offs.push(rows);
            rows += starts[s + 1] - starts[s];
        }
        let mut vals = vec![0.0; rows * c];
        for a in 0..c {
            for (&s, &o) in nodes.iter().zip(&offs) {
                let (lo, hi) = (starts[s], starts[s + 1]);
                vals[a * rows + o..a * rows + o + hi - lo]
                    .copy_from_slice(&x[a * n + lo..a * n + hi]);
            }
            x[a * n..(a + 1) * n].fill(0.0);
        }
        Reached { cols: block, nodes, offs, vals, rows }
    }
}

/// `G_I^T G_J` over the nodes both blocks reach, one product per run of nodes that are
/// consecutive in both blocks' storage.
fn node_products(bi: &Reached, bj: &Reached) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(bi.cols.len(), bj.cols.len());
    let (gi, gj) = (bi.mat(), bj.mat());
    let (mut p, mut q) = (0, 0);
    while p < bi.nodes.len() && q < bj.nodes.len() {
        match bi.nodes[p].cmp(&bj.nodes[q]) {
            std::cmp::Ordering::Less => p += 1,
            std::cmp::Ordering::Greater => q += 1,
            std::cmp::Ordering::Equal => {
                let (p0, q0) = (p, q);
                while p + 1 < bi.nodes.len()
                    && q + 1 < bj.nodes.len()
                    && bi.nodes[p + 1] == bj.nodes[q + 1]
                {
                    p += 1;
                    q += 1;
                }
                let end_i = if p + 1 < bi.nodes.len() { bi.offs[p + 1] } else { bi.rows };
                let len = end_i - bi.offs[p0];
                matmul(
                    out.as_mut(),
                    Accum::Add,
                    gi.subrows(bi.offs[p0], len).transpose(),
                    gj.subrows(bj.offs[q0], len),
                    1.0,
                    Par::Seq,
                );
                p += 1;
                q += 1;
            }
        }
    }
    out
}

#[cfg(test)]
#[path = "sparse_tests.rs"]
mod tests;

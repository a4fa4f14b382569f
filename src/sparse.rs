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
mod tests {
    use super::*;

    /// `refactor` with a spare factor gives exactly the fresh factor's solution, for new
    /// values (the spare's old values do not leak), and drops a spare of another pattern.
    #[test]
    fn refactor_reuses_buffers_and_gives_the_fresh_result() {
        let n = 5;
        let entries: Vec<(usize, usize)> = (0..n)
            .flat_map(|i| [(i, i)].into_iter().chain((i + 1 < n).then_some((i + 1, i))))
            .collect();
        let vals = |d: f64| -> Vec<f64> {
            entries.iter().map(|&(r, c)| if r == c { d } else { -1.0 }).collect()
        };
        let p = Pattern::new(n, &entries).unwrap();
        let other = Pattern::new(n, &entries).unwrap();
        let solve = |f: &Factor| {
            let mut b: Vec<f64> = (0..n).map(|i| i as f64 + 1.0).collect();
            f.solve(&mut b);
            b
        };
        let first = p.factor(&vals(4.0)).unwrap();
        let fresh = p.factor(&vals(3.0)).unwrap();
        let reused = p.refactor(&vals(3.0), Some(first)).unwrap();
        assert_eq!(solve(&reused), solve(&fresh));
        let foreign = other.refactor(&vals(3.0), Some(reused)).unwrap();
        assert_eq!(solve(&foreign), solve(&fresh));
    }

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
        /// Random overlapping cliques: the pattern built from the cliques is the pattern
        /// built from their listed entries (same columns, same positions), with and without
        /// the diagonal, and factors the same values to the same factor.
        #[test]
        fn clique_patterns_equal_entry_patterns(
            n in 1usize..30,
            raw in proptest::collection::vec(proptest::collection::vec(0usize..30, 1..8), 0..12),
            diagonal in proptest::bool::ANY,
        ) {
            let cliques: Vec<Vec<usize>> = raw
                .iter()
                .map(|c| {
                    let mut c: Vec<usize> = c.iter().map(|&v| v % n).collect();
                    c.sort_unstable();
                    c.dedup();
                    c
                })
                .collect();
            let mut entries = lower_clique_entries(&cliques);
            if diagonal {
                entries.extend((0..n).map(|i| (i, i)));
            }
            let a = Pattern::from_cliques(n, &cliques, diagonal).unwrap();
            let b = Pattern::new(n, &entries).unwrap();
            proptest::prop_assert_eq!(&a.pos, &b.pos);
            proptest::prop_assert_eq!(a.symbolic.col_ptr(), b.symbolic.col_ptr());
            proptest::prop_assert_eq!(a.symbolic.row_idx(), b.symbolic.row_idx());
            // Values that make the matrix positive definite: 1 off the diagonal, and a
            // diagonal larger than any row sum.
            if diagonal {
                let vals: Vec<f64> = entries
                    .iter()
                    .enumerate()
                    .map(|(i, &(r, c))| if i >= entries.len() - n { 100.0 } else if r == c { 2.0 } else { 0.5 })
                    .collect();
                let (fa, fb) = (a.factor(&vals).unwrap(), b.factor(&vals).unwrap());
                proptest::prop_assert_eq!(fa.values, fb.values);
            }
        }

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

    /// A 2D grid system (`g x g` unknowns): each unknown coupled to those within `reach`
    /// steps in both directions, diagonally dominant.
    fn grid_system(g: usize, reach: usize) -> (usize, Vec<(usize, usize)>, Vec<f64>) {
        let n = g * g;
        let (mut entries, mut vals) = (Vec::new(), Vec::new());
        let side = 2 * reach + 1;
        for i in 0..g {
            for j in 0..g {
                let p = i * g + j;
                entries.push((p, p));
                vals.push((side * side) as f64);
                for di in 0..=reach {
                    for dj in 0..side {
                        let (ii, jj) = (i + di, (j + dj).wrapping_sub(reach));
                        if (di, dj) <= (0, reach) || ii >= g || jj >= g {
                            continue;
                        }
                        entries.push((p, ii * g + jj));
                        vals.push(-1.0);
                    }
                }
            }
        }
        (n, entries, vals)
    }

    /// `B^T A^-1 B` by sparse forward substitution equals the product with full solves,
    /// for simplicial and supernodal factors and for columns in any order (some empty).
    #[test]
    fn inverse_gram_matches_full_solves() {
        let mut kinds = Vec::new();
        for (g, reach) in [(4, 1), (9, 1), (20, 2), (30, 3)] {
            let (n, entries, vals) = grid_system(g, reach);
            let f = Pattern::new(n, &entries).unwrap().factor(&vals).unwrap();
            kinds.push(matches!(f.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)));
            let k = 2 * SOLVE_BLOCK + 5;
            let cols: Vec<Vec<(usize, f64)>> = (0..k)
                .map(|j| {
                    if j % 17 == 5 {
                        return Vec::new();
                    }
                    let c = (j * 7919) % n;
                    let mut col = vec![(c, 1.0 + j as f64 * 0.01)];
                    if c + 1 < n {
                        col.push((c + 1, -0.5));
                    }
                    col.push(((c * 31 + 3) % n, 0.25));
                    col
                })
                .collect();
            let gram = f.inverse_gram(&cols);
            let mut dense = vec![0.0; n * k];
            for (j, col) in cols.iter().enumerate() {
                for &(r, v) in col {
                    dense[j * n + r] += v;
                }
            }
            f.solve_many(&mut dense, n, k);
            for i in 0..k {
                for j in 0..k {
                    let want: f64 = cols[i].iter().map(|&(r, v)| v * dense[j * n + r]).sum();
                    let got = gram[i * k + j];
                    assert!(
                        (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                        "{i},{j}: {got} vs {want}"
                    );
                    assert_eq!(got, gram[j * k + i]);
                }
            }
        }
        assert!(kinds.contains(&true) && kinds.contains(&false), "both factor kinds: {kinds:?}");
    }
}

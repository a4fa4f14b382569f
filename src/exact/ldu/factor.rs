//! Computing the fraction-free LDU factoring (thesis ch. 6, Algorithms 6-13).
//!
//! # The elimination, in our formulation
//!
//! Each not-yet-pivoted ("active") row `t` of the input is kept as an integer row `W_t`
//! together with a rational scale `s_t`, so that the true Schur-complement row is `s_t W_t`.
//! A step with pivot `p = W_rho[gamma]` and, for each active row `t` with `c_t = W_t[gamma] != 0`:
//!
//! * records column `k` of `L D^-1`: the pivot row contributes `s_rho`, row `t` contributes
//!   `s_t c_t / p`; `D_kk` is the least common denominator of those values and `L_tk` their
//!   numerators over it (for Turner: Jeffrey's `D_kk = p_(k-1) p_k`, `L_kk = p_k`, `L_tk = c_t`);
//! * records `U_k = W_rho` (thesis Alg. 8 with `U_ii` the pivot);
//! * updates `W_t <- p W_t - c_t W_rho`, `s_t <- s_t / p` (Alg. 8), then simplifies:
//!   - `None`: nothing;
//!   - `Gcd`: divide `W_t` by the gcd of its entries and move the factor into `s_t`
//!     (Alg. 11; the L-column gcd of Alg. 12 is implied by taking the least common
//!     denominator above);
//!   - `Turner`: divide `W_t` exactly by the previous pivot `p_(k-1)` (Alg. 13, Bareiss).
//!     Rows not touched by a step are brought to the current Bareiss stage lazily, by the
//!     exact factor `p_k / p_s`, only when they are next used, so sparsity is kept.
//!
//! Rows never touched by a step are left alone (their `s_t` is unchanged), which is what
//! makes the factoring cheap on sparse matrices. The pivot is chosen among all active
//! nonzeros (full pivoting, Alg. 7): by default the one of least Markowitz cost
//! `(row nonzeros - 1)(column nonzeros - 1)`, ties broken by the smallest magnitude; or, as
//! in the thesis, simply the nonzero of smallest magnitude.

use super::{Ldu, LduOptions, Pivoting, Simplification};
use crate::exact::int::Int;
use crate::exact::matrix::{Rat, SparseIntMatrix};
use num_integer::Integer;
use num_traits::{One, Signed, Zero};

type Row = Vec<(usize, Int)>;

struct State {
    opts: LduOptions,
    rows: Vec<Row>,
    active: Vec<bool>,
    /// Scale `s_t = num / den` (None and GCD).
    s_num: Vec<Int>,
    s_den: Vec<Int>,
    /// Turner: the Bareiss stage of each row, and the pivots `p_0 = 1, p_1, ...`.
    stage: Vec<usize>,
    pivots: Vec<Int>,
    col_count: Vec<usize>,
    col_rows: Vec<Vec<usize>>,
    mark: Vec<usize>,
}

/// Factors `a` (see [`Ldu`] for the identity that the result satisfies).
pub(super) fn factor(a: &SparseIntMatrix, opts: LduOptions) -> Ldu {
    let (m, n) = (a.rows(), a.cols());
    let mut st = State {
        opts,
        rows: (0..m).map(|i| a.row(i).to_vec()).collect(),
        active: vec![true; m],
        s_num: vec![Int::one(); m],
        s_den: vec![Int::one(); m],
        stage: vec![0; m],
        pivots: vec![Int::one()],
        col_count: vec![0; n],
        col_rows: vec![Vec::new(); n],
        mark: vec![usize::MAX; m],
    };
    for (i, r) in st.rows.iter().enumerate() {
        for (c, _) in r {
            st.col_count[*c] += 1;
            st.col_rows[*c].push(i);
        }
    }
    if opts.simplification == Simplification::Gcd {
        for t in 0..m {
            let g = content(&st.rows[t]);
            if g > Int::one() {
                for (_, v) in st.rows[t].iter_mut() {
                    *v = v.div_exact(&g);
                }
                st.s_num[t] = g;
            }
        }
    }

    let mut row_order = Vec::new();
    let mut col_order = Vec::new();
    let mut l_cols: Vec<Vec<(usize, Int)>> = Vec::new();
    let mut u_rows: Vec<Row> = Vec::new();
    let mut d = Vec::new();
    let mut touched: Vec<usize> = Vec::new();

    while let Some((rho, gamma)) = st.choose_pivot() {
        let k = row_order.len();
        if opts.simplification == Simplification::Turner {
            st.bring_to_stage(rho, k);
        }
        let p = value_at(&st.rows[rho], gamma).expect("pivot is stored").clone();
        // Active rows with a nonzero in the pivot column.
        touched.clear();
        for &t in &st.col_rows[gamma] {
            if t != rho && st.active[t] && st.mark[t] != k && value_at(&st.rows[t], gamma).is_some()
            {
                st.mark[t] = k;
                touched.push(t);
            }
        }
        touched.sort_unstable();
        st.col_rows[gamma] = Vec::new();

        let pivot_row = std::mem::take(&mut st.rows[rho]);
        st.active[rho] = false;
        for (c, _) in &pivot_row {
            st.col_count[*c] -= 1;
        }

        let mut l_col: Vec<(usize, Int)> = Vec::with_capacity(touched.len() + 1);
        match opts.simplification {
            Simplification::Turner => {
                let prev = st.pivots[k].clone();
                d.push(&prev * &p);
                l_col.push((rho, p.clone()));
                for &t in &touched {
                    st.bring_to_stage(t, k);
                    let c = value_at(&st.rows[t], gamma).expect("touched").clone();
                    st.eliminate(t, &pivot_row, &p, &c, gamma, Some(&prev));
                    st.stage[t] = k + 1;
                    l_col.push((t, c));
                }
                st.pivots.push(p.clone());
            }
            Simplification::None | Simplification::Gcd => {
                // Values of column k of L D^-1, then a common denominator.
                let mut vals: Vec<(usize, Rat)> = Vec::with_capacity(touched.len() + 1);
                vals.push((rho, Rat::new(st.s_num[rho].clone(), st.s_den[rho].clone())));
                for &t in &touched {
                    let c = value_at(&st.rows[t], gamma).expect("touched").clone();
                    let v = Rat::new(&st.s_num[t] * &c, &st.s_den[t] * &p);
                    vals.push((t, v));
                    st.eliminate(t, &pivot_row, &p, &c, gamma, None);
                    // s_t <- s_t / p
                    let mut den = &st.s_den[t] * &p;
                    let mut num = st.s_num[t].clone();
                    if den.is_negative() {
                        den = -den;
                        num = -num;
                    }
                    if opts.simplification == Simplification::Gcd {
                        let g = content(&st.rows[t]);
                        if g > Int::one() {
                            for (_, v) in st.rows[t].iter_mut() {
                                *v = v.div_exact(&g);
                            }
                            num = &num * &g;
                        }
                        let h = num.gcd_int(&den);
                        if h > Int::one() {
                            num = num.div_exact(&h);
                            den = den.div_exact(&h);
                        }
                    }
                    st.s_num[t] = num;
                    st.s_den[t] = den;
                }
                let mut dk = Int::one();
                for (_, v) in &vals {
                    dk = dk.lcm(v.denom());
                }
                for (t, v) in vals {
                    l_col.push((t, (v * Rat::from_integer(dk.clone())).to_integer()));
                }
                d.push(dk);
            }
        }
        row_order.push(rho);
        col_order.push(gamma);
        l_cols.push(l_col);
        u_rows.push(pivot_row);
    }
    assemble(m, n, row_order, col_order, l_cols, u_rows, d, opts.simplification)
}

impl State {
    /// Full pivoting over the active nonzeros (thesis Alg. 7, or Markowitz).
    fn choose_pivot(&self) -> Option<(usize, usize)> {
        if self.opts.pivoting == Pivoting::SymmetricMarkowitz {
            let diag = (0..self.rows.len())
                .filter(|&t| self.active[t] && !self.rows[t].is_empty())
                .filter(|&t| value_at(&self.rows[t], t).is_some())
                .min_by_key(|&t| (self.rows[t].len() - 1) * (self.col_count[t] - 1));
            if let Some(t) = diag {
                return Some((t, t));
            }
        }
        let mut best: Option<(usize, &Int, usize, usize)> = None; // (cost, value, row, col)
        for (t, r) in self.rows.iter().enumerate() {
            if !self.active[t] || r.is_empty() {
                continue;
            }
            for (c, v) in r {
                let cost = match self.opts.pivoting {
                    Pivoting::Markowitz | Pivoting::SymmetricMarkowitz => {
                        (r.len() - 1) * (self.col_count[*c] - 1)
                    }
                    Pivoting::SmallestMagnitude => 0,
                };
                let better = match &best {
                    None => true,
                    Some((bc, bv, _, _)) => {
                        cost < *bc || (cost == *bc && v.cmp_abs(bv) == std::cmp::Ordering::Less)
                    }
                };
                if better {
                    best = Some((cost, v, t, *c));
                }
            }
        }
        best.map(|(_, _, t, c)| (t, c))
    }

    /// Turner: multiplies row `t` by `p_k / p_stage` (exact by Sylvester's identity).
    fn bring_to_stage(&mut self, t: usize, k: usize) {
        let s = self.stage[t];
        if s == k {
            return;
        }
        let (num, den) = (&self.pivots[k], &self.pivots[s]);
        for (_, v) in self.rows[t].iter_mut() {
            *v = (&*v * num).div_exact(den);
        }
        self.stage[t] = k;
    }

    /// `W_t <- (p W_t - c W_rho) / div`, keeping the column bookkeeping up to date.
    fn eliminate(&mut self, t: usize, pr: &Row, p: &Int, c: &Int, gamma: usize, div: Option<&Int>) {
        let old = std::mem::take(&mut self.rows[t]);
        let mut out: Row = Vec::with_capacity(old.len() + pr.len());
        let (mut i, mut j) = (0, 0);
        while i < old.len() || j < pr.len() {
            let ci = old.get(i).map_or(usize::MAX, |e| e.0);
            let cj = pr.get(j).map_or(usize::MAX, |e| e.0);
            let (col, v, was_present) = if ci == cj {
                let v = Int::cross(p, &old[i].1, c, &pr[j].1);
                i += 1;
                j += 1;
                (ci, v, true)
            } else if ci < cj {
                let v = p * &old[i].1;
                i += 1;
                (ci, v, true)
            } else {
                let v = -(c * &pr[j].1);
                j += 1;
                (cj, v, false)
            };
            if v.is_zero() || col == gamma {
                if was_present {
                    self.col_count[col] -= 1;
                }
                continue;
            }
            if !was_present {
                self.col_count[col] += 1;
                self.col_rows[col].push(t);
            }
            let v = match div {
                Some(dv) => v.div_exact(dv),
                None => v,
            };
            out.push((col, v));
        }
        self.rows[t] = out;
    }
}

/// The entry of a sorted sparse row at column `c`.
fn value_at(r: &Row, c: usize) -> Option<&Int> {
    r.binary_search_by_key(&c, |e| e.0).ok().map(|k| &r[k].1)
}

/// Gcd of all entries of a row (0 for an empty row).
fn content(r: &Row) -> Int {
    let mut g = Int::zero();
    for (_, v) in r {
        g = g.gcd_int(v);
        if g.is_one() {
            break;
        }
    }
    g
}

/// Numbers rows and columns by pivot order and stores L, D, U by position.
#[allow(clippy::too_many_arguments)]
pub(super) fn assemble(
    m: usize,
    n: usize,
    mut row_perm: Vec<usize>,
    mut col_perm: Vec<usize>,
    l_cols: Vec<Vec<(usize, Int)>>,
    u_rows: Vec<Row>,
    d: Vec<Int>,
    simplification: Simplification,
) -> Ldu {
    let rank = row_perm.len();
    let mut row_pos = vec![usize::MAX; m];
    for (k, &r) in row_perm.iter().enumerate() {
        row_pos[r] = k;
    }
    for (r, pos) in row_pos.iter_mut().enumerate() {
        if *pos == usize::MAX {
            *pos = row_perm.len();
            row_perm.push(r);
        }
    }
    let mut col_pos = vec![usize::MAX; n];
    for (k, &c) in col_perm.iter().enumerate() {
        col_pos[c] = k;
    }
    for (c, pos) in col_pos.iter_mut().enumerate() {
        if *pos == usize::MAX {
            *pos = col_perm.len();
            col_perm.push(c);
        }
    }
    let mut l_rows: Vec<Row> = vec![Vec::new(); m];
    let l_cols: Vec<Row> = l_cols
        .into_iter()
        .enumerate()
        .map(|(k, col)| {
            let mut col: Row = col.into_iter().map(|(t, v)| (row_pos[t], v)).collect();
            col.sort_unstable_by_key(|e| e.0);
            for (i, v) in &col {
                l_rows[*i].push((k, v.clone()));
            }
            col
        })
        .collect();
    let u_rows = u_rows
        .into_iter()
        .map(|r| {
            let mut r: Row = r.into_iter().map(|(c, v)| (col_pos[c], v)).collect();
            r.sort_unstable_by_key(|e| e.0);
            r
        })
        .collect();
    Ldu { m, n, rank, row_perm, col_perm, l_rows, d, u_rows, l_cols, simplification }
}

//! A plain dense fraction-free (Bareiss / Turner) elimination, for comparison.
//!
//! Every step updates every remaining entry of the working matrix, zero or not:
//! `W_tj <- (p W_tj - W_tg W_kj) / p_prev` (thesis Alg. 6 with Alg. 13 on dense arrays,
//! smallest-magnitude full pivoting). [`super::Ldu::factor`] gives the same kind of factoring
//! while touching only the rows that have a nonzero in the pivot column; this module is the
//! baseline that the sparse code is measured against (and a cross-check of the rank).

use super::Ldu;
use crate::exact::int::Int;
use crate::exact::matrix::IntMatrix;
use num_traits::{One, Zero};

/// Factors `a` densely with Turner's simplification, returning the factoring in the same
/// form as [`Ldu::factor`].
pub fn factor_dense_turner(a: &IntMatrix) -> Ldu {
    let (m, n) = (a.rows(), a.cols());
    let mut w: Vec<Vec<Int>> = (0..m).map(|i| a.row(i).to_vec()).collect();
    let mut rows: Vec<usize> = (0..m).collect(); // remaining rows
    let mut cols: Vec<usize> = (0..n).collect(); // remaining columns
    let mut prev = Int::one();
    let (mut row_order, mut col_order) = (Vec::new(), Vec::new());
    let (mut l_cols, mut u_rows, mut d) = (Vec::new(), Vec::new(), Vec::new());
    loop {
        // Smallest-magnitude nonzero among the remaining rows and columns.
        let mut best: Option<(usize, usize)> = None;
        for (ri, &r) in rows.iter().enumerate() {
            for (ci, &c) in cols.iter().enumerate() {
                let v = &w[r][c];
                if !v.is_zero()
                    && best.is_none_or(|(br, bc)| v.cmp_abs(&w[rows[br]][cols[bc]]).is_lt())
                {
                    best = Some((ri, ci));
                }
            }
        }
        let Some((ri, ci)) = best else { break };
        let (rho, gamma) = (rows.swap_remove(ri), cols.swap_remove(ci));
        let p = w[rho][gamma].clone();
        let pivot_row = w[rho].clone();
        let mut l_col = vec![(rho, p.clone())];
        for &t in &rows {
            let c = w[t][gamma].clone();
            if !c.is_zero() {
                l_col.push((t, c.clone()));
            }
            for &j in &cols {
                let (x, y) = (&w[t][j], &pivot_row[j]);
                if x.is_zero() && y.is_zero() {
                    continue;
                }
                w[t][j] = Int::cross(&p, x, &c, y).div_exact(&prev);
            }
            w[t][gamma] = Int::zero();
        }
        let u: Vec<(usize, Int)> = std::iter::once(gamma)
            .chain(cols.iter().copied())
            .filter(|&j| !pivot_row[j].is_zero())
            .map(|j| (j, pivot_row[j].clone()))
            .collect();
        d.push(&prev * &p);
        prev = p;
        row_order.push(rho);
        col_order.push(gamma);
        l_cols.push(l_col);
        u_rows.push(u);
    }
    super::factor::assemble(
        m,
        n,
        row_order,
        col_order,
        l_cols,
        u_rows,
        d,
        super::Simplification::Turner,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::ldu::LduOptions;

    #[test]
    fn dense_and_sparse_agree_on_rank_and_both_rebuild() {
        let a = IntMatrix::from_i64_rows(
            4,
            &[
                vec![4, 9, 16, 29],
                vec![-1, -6, -19, -16],
                vec![1, 5, 15, 19],
                vec![5, 6, -1, -12],
                vec![5, 10, 15, 20],
            ],
        );
        let f = factor_dense_turner(&a);
        f.sanity_check().unwrap();
        assert!(f.reconstructs(&a.to_sparse()));
        assert_eq!(f.rank(), Ldu::factor(&a.to_sparse(), LduOptions::default()).rank());
    }
}

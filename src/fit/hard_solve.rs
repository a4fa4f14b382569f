//! The solve of the hard fit ([`super::hard`]): rows `a_i . x = b_i` over free points of a
//! minimal determining set, met exactly with few non-grid values.
//!
//! With `A` the rows restricted to the variable free points (fixed points moved to the
//! right-hand side) and `h` their current values:
//!
//! 1. *Nearest solution, in `f64`*: `x = h + A^T (A A^T + eps I)^-1 (b - A h)` (the
//!    minimum-norm correction, `eps = 1e-12 max diag(A A^T)` a ridge against dependent rows,
//!    [`RIDGE`]), rounded to multiples of `2^-bits`;
//! 2. *Exact residual*: one pivot variable per row absorbs the remaining residual
//!    `e = b - A x` exactly. Pivots are chosen row by row among the columns whose
//!    coefficient is at least [`PIVOT_SHARE`] of the row's largest, preferring columns that
//!    fewer rows use; rows coupled through pivots form groups, each an exact square system
//!    solved by Gaussian elimination over the rationals. A singular group is re-solved by
//!    an exact row reduction over every variable only its rows use, merged with the groups
//!    around it up to [`MAX_GROWTH`] times; rows still inconsistent then are reported.
//!    Groups beyond [`MAX_GROUP`] rows are refused: the landmarks are too dense for the
//!    mesh (every row coupled to the next through shared free points).

use super::param::grid_rat;
use crate::exact::{rat_to_f64, Rat};
use num_traits::Zero;
use std::collections::HashMap;

/// Relative ridge added to `A A^T` in the floating step.
pub const RIDGE: f64 = 1e-12;
/// A pivot's coefficient is at least this share of its row's largest (in magnitude).
pub const PIVOT_SHARE: f64 = 0.25;
/// How many times a dependent group is merged with its neighbours before giving up.
pub const MAX_GROWTH: usize = 3;
/// The most rows one exact group may hold: larger groups (landmarks so dense that their
/// rows are all coupled through shared free points) would make the exact elimination's
/// numbers grow without bound, so they are refused ([`Unmet::Coupled`]).
pub const MAX_GROUP: usize = 64;

/// Why [`solve_rows`] could not meet every row (row indices into its input).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Unmet {
    /// These rows are dependent and inconsistent (the smallest such group found).
    Dependent(Vec<usize>),
    /// These rows are coupled into one group larger than [`MAX_GROUP`].
    Coupled(Vec<usize>),
}

/// One constraint `sum c_j P_j = rhs` (both coordinates) over free points `P_j`.
#[derive(Clone, Debug)]
pub struct Row {
    /// Coefficients over free points (any free point; fixed ones are moved to the
    /// right-hand side).
    pub coefs: Vec<(usize, Rat)>,
    /// The right-hand side per coordinate.
    pub rhs: [Rat; 2],
}

/// The rows over variables: local column coefficients and reduced right-hand sides.
struct Local {
    cols: Vec<usize>,
    a: Vec<Vec<(usize, Rat)>>,
    b: Vec<[Rat; 2]>,
    col_rows: Vec<Vec<usize>>,
}

fn localize(rows: &[Row], values: &[Vec<Rat>], is_var: &[bool]) -> Local {
    let mut col_of: HashMap<usize, usize> = HashMap::new();
    let mut cols = Vec::new();
    let mut a = Vec::with_capacity(rows.len());
    let mut b = Vec::with_capacity(rows.len());
    for r in rows {
        let mut rhs = r.rhs.clone();
        let mut row = Vec::new();
        for (p, c) in &r.coefs {
            if is_var[*p] {
                let k = *col_of.entry(*p).or_insert_with(|| {
                    cols.push(*p);
                    cols.len() - 1
                });
                row.push((k, c.clone()));
            } else {
                for (x, v) in rhs.iter_mut().zip(&values[*p]) {
                    *x -= c * v;
                }
            }
        }
        a.push(row);
        b.push(rhs);
    }
    let mut col_rows = vec![Vec::new(); cols.len()];
    for (i, row) in a.iter().enumerate() {
        for (k, _) in row {
            col_rows[*k].push(i);
        }
    }
    Local { cols, a, b, col_rows }
}

/// The floating nearest-solution step (1), rounded to the grid, written into `values`.
fn float_step(l: &Local, values: &mut [Vec<Rat>], bits: u32) {
    let m = l.a.len();
    let h: Vec<[f64; 2]> =
        l.cols.iter().map(|&p| [rat_to_f64(&values[p][0]), rat_to_f64(&values[p][1])]).collect();
    let af: Vec<Vec<(usize, f64)>> =
        l.a.iter().map(|r| r.iter().map(|(k, c)| (*k, rat_to_f64(c))).collect()).collect();
    let mut g = vec![0.0; m * m];
    let mut pos: Vec<HashMap<usize, f64>> = vec![HashMap::new(); l.cols.len()];
    for (i, r) in af.iter().enumerate() {
        for &(k, c) in r {
            pos[k].insert(i, c);
        }
    }
    for col in &pos {
        for (&i, &ai) in col {
            for (&k, &ak) in col {
                g[i * m + k] += ai * ak;
            }
        }
    }
    let top = (0..m).map(|i| g[i * m + i]).fold(0.0, f64::max);
    let ridge = if top > 0.0 { RIDGE * top } else { 1.0 };
    for i in 0..m {
        g[i * m + i] += ridge;
    }
    let gm = faer::Mat::<f64>::from_fn(m, m, |i, k| g[i * m + k]);
    let Ok(chol) = gm.llt(faer::Side::Lower) else { return };
    let mut delta = vec![[0.0f64; 2]; l.cols.len()];
    for c in 0..2 {
        let mut y: Vec<f64> = (0..m)
            .map(|i| rat_to_f64(&l.b[i][c]) - af[i].iter().map(|&(k, a)| a * h[k][c]).sum::<f64>())
            .collect();
        {
            let mut ym = faer::MatMut::from_column_major_slice_mut(&mut y, m, 1);
            faer::linalg::solvers::Solve::solve_in_place(&chol, ym.as_mut());
        }
        for (i, r) in af.iter().enumerate() {
            for &(k, a) in r {
                delta[k][c] += a * y[i];
            }
        }
    }
    for (k, &p) in l.cols.iter().enumerate() {
        for c in 0..2 {
            let v = h[k][c] + delta[k][c];
            if delta[k][c] != 0.0 && v.is_finite() {
                values[p][c] = grid_rat(v, bits);
            }
        }
    }
}

/// The exact residuals `b_i - a_i . x` of the given rows.
fn residuals(l: &Local, values: &[Vec<Rat>], rows: &[usize]) -> Vec<[Rat; 2]> {
    rows.iter()
        .map(|&i| {
            let mut e = l.b[i].clone();
            for (k, c) in &l.a[i] {
                let v = &values[l.cols[*k]];
                e[0] -= c * &v[0];
                e[1] -= c * &v[1];
            }
            e
        })
        .collect()
}

/// Solves the square system `mat . x = rhs` exactly (`None` when singular).
fn solve_square(mut mat: Vec<Vec<Rat>>, mut rhs: Vec<[Rat; 2]>) -> Option<Vec<[Rat; 2]>> {
    let n = mat.len();
    for c in 0..n {
        let p = (c..n).find(|&r| !mat[r][c].is_zero())?;
        mat.swap(c, p);
        rhs.swap(c, p);
        for r in c + 1..n {
            if mat[r][c].is_zero() {
                continue;
            }
            let f = &mat[r][c] / &mat[c][c];
            for j in c..n {
                let t = &f * &mat[c][j];
                mat[r][j] -= t;
            }
            for k in 0..2 {
                let t = &f * &rhs[c][k];
                rhs[r][k] -= t;
            }
        }
    }
    let mut x = vec![[Rat::zero(), Rat::zero()]; n];
    for r in (0..n).rev() {
        let mut acc = rhs[r].clone();
        for j in r + 1..n {
            for k in 0..2 {
                acc[k] -= &mat[r][j] * &x[j][k];
            }
        }
        x[r] = [&acc[0] / &mat[r][r], &acc[1] / &mat[r][r]];
    }
    Some(x)
}

/// Exact row reduction of the rows `group` over the columns `safe`, applied to `values`.
/// `Err` when some row is a combination of the others with a different right-hand side.
fn reduce_group(
    l: &Local,
    values: &mut [Vec<Rat>],
    group: &[usize],
    safe: &[usize],
) -> Result<(), ()> {
    let at: HashMap<usize, usize> = safe.iter().enumerate().map(|(j, &k)| (k, j)).collect();
    let mut mat: Vec<Vec<Rat>> = group
        .iter()
        .map(|&i| {
            let mut r = vec![Rat::zero(); safe.len()];
            for (k, c) in &l.a[i] {
                if let Some(&j) = at.get(k) {
                    r[j] = c.clone();
                }
            }
            r
        })
        .collect();
    let mut rhs = residuals(l, values, group);
    let mut pivots: Vec<(usize, usize)> = Vec::new();
    let mut r = 0;
    for c in 0..safe.len() {
        let Some(p) = (r..mat.len()).find(|&i| !mat[i][c].is_zero()) else { continue };
        mat.swap(r, p);
        rhs.swap(r, p);
        let inv = mat[r][c].recip();
        for x in mat[r].iter_mut() {
            *x *= &inv;
        }
        for x in rhs[r].iter_mut() {
            *x *= &inv;
        }
        for i in 0..mat.len() {
            if i != r && !mat[i][c].is_zero() {
                let f = mat[i][c].clone();
                for j in c..safe.len() {
                    let t = &f * &mat[r][j];
                    mat[i][j] -= t;
                }
                for k in 0..2 {
                    let t = &f * &rhs[r][k];
                    rhs[i][k] -= t;
                }
            }
        }
        pivots.push((r, c));
        r += 1;
        if r == mat.len() {
            break;
        }
    }
    if rhs[r..].iter().any(|e| !e[0].is_zero() || !e[1].is_zero()) {
        return Err(());
    }
    for (r, c) in pivots {
        let v = &mut values[l.cols[safe[c]]];
        v[0] += &rhs[r][0];
        v[1] += &rhs[r][1];
    }
    Ok(())
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Meets every row exactly by changing variable free points (`is_var`) in `values` (see
/// the module docs). On `Err`, `values` may be partly changed.
pub fn solve_rows(
    rows: &[Row],
    values: &mut [Vec<Rat>],
    is_var: &[bool],
    bits: u32,
) -> Result<(), Unmet> {
    if rows.is_empty() {
        return Ok(());
    }
    let l = localize(rows, values, is_var);
    float_step(&l, values, bits);
    let m = rows.len();
    let all: Vec<usize> = (0..m).collect();
    let e = residuals(&l, values, &all);
    let open: Vec<usize> =
        all.iter().copied().filter(|&i| !e[i][0].is_zero() || !e[i][1].is_zero()).collect();
    if open.is_empty() {
        return Ok(());
    }
    // Pivots, rows with the fewest columns first.
    let mut order = all.clone();
    order.sort_by_key(|&i| (l.a[i].len(), i));
    let mut is_pivot = vec![false; l.cols.len()];
    let mut pivot: Vec<Option<usize>> = vec![None; m];
    for &i in &order {
        let mag: Vec<f64> = l.a[i].iter().map(|(_, c)| rat_to_f64(c).abs()).collect();
        let top = mag.iter().copied().fold(0.0, f64::max);
        let best = l.a[i]
            .iter()
            .zip(&mag)
            .filter(|((k, _), _)| !is_pivot[*k])
            .max_by(|((ka, _), &ma), ((kb, _), &mb)| {
                let ok = |x: f64| x >= PIVOT_SHARE * top;
                ok(ma)
                    .cmp(&ok(mb))
                    .then(l.col_rows[*kb].len().cmp(&l.col_rows[*ka].len()))
                    .then(ma.total_cmp(&mb))
            })
            .map(|((k, _), _)| *k);
        if let Some(k) = best {
            is_pivot[k] = true;
        }
        pivot[i] = best;
    }
    // Groups: a row joins the row whose pivot it uses.
    let mut owner: HashMap<usize, usize> = HashMap::new();
    for (i, p) in pivot.iter().enumerate() {
        if let Some(k) = p {
            owner.insert(*k, i);
        }
    }
    let mut parent: Vec<usize> = all.clone();
    for i in 0..m {
        for (k, _) in &l.a[i] {
            if let Some(&j) = owner.get(k) {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                parent[a] = b;
            }
        }
    }
    let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
    for i in 0..m {
        let root = find(&mut parent, i);
        groups.entry(root).or_default().push(i);
    }
    let mut groups: Vec<Vec<usize>> = groups.into_values().collect();
    groups.sort();
    if let Some(g) = groups.iter().find(|g| g.len() > MAX_GROUP) {
        return Err(Unmet::Coupled(g.clone()));
    }
    let mut singular: Vec<Vec<usize>> = Vec::new();
    for g in &groups {
        let rhs = residuals(&l, values, g);
        if rhs.iter().all(|e| e[0].is_zero() && e[1].is_zero()) {
            continue;
        }
        let piv: Option<Vec<usize>> = g.iter().map(|&i| pivot[i]).collect();
        let solved = piv.and_then(|piv| {
            let at: HashMap<usize, usize> = piv.iter().enumerate().map(|(j, &k)| (k, j)).collect();
            let mat: Vec<Vec<Rat>> = g
                .iter()
                .map(|&i| {
                    let mut r = vec![Rat::zero(); g.len()];
                    for (k, c) in &l.a[i] {
                        if let Some(&j) = at.get(k) {
                            r[j] = c.clone();
                        }
                    }
                    r
                })
                .collect();
            solve_square(mat, rhs).map(|x| (piv, x))
        });
        match solved {
            Some((piv, x)) => {
                for (k, d) in piv.iter().zip(x) {
                    let v = &mut values[l.cols[*k]];
                    v[0] += &d[0];
                    v[1] += &d[1];
                }
            }
            None => singular.push(g.clone()),
        }
    }
    for g in singular {
        let mut group = g.clone();
        let mut first_failure: Option<Vec<usize>> = None;
        for round in 0..=MAX_GROWTH {
            let mut in_group = vec![false; m];
            for &i in &group {
                in_group[i] = true;
            }
            let mut support: Vec<usize> =
                group.iter().flat_map(|&i| l.a[i].iter().map(|(k, _)| *k)).collect();
            support.sort_unstable();
            support.dedup();
            let safe: Vec<usize> = support
                .iter()
                .copied()
                .filter(|&k| l.col_rows[k].iter().all(|&i| in_group[i]))
                .collect();
            if reduce_group(&l, values, &group, &safe).is_ok() {
                first_failure = None;
                break;
            }
            first_failure.get_or_insert_with(|| group.clone());
            if round == MAX_GROWTH || group.len() == m || group.len() > MAX_GROUP {
                break;
            }
            let mut grown: Vec<usize> =
                support.iter().flat_map(|&k| l.col_rows[k].clone()).collect();
            grown.extend(&group);
            grown.sort_unstable();
            grown.dedup();
            group = grown;
        }
        if let Some(bad) = first_failure {
            return Err(Unmet::Dependent(bad));
        }
    }
    debug_assert!(residuals(&l, values, &all).iter().all(|e| e[0].is_zero() && e[1].is_zero()));
    Ok(())
}

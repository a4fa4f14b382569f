//! Select-all edits in the coordinates of a minimal determining set (issue "exact core at
//! scale", points 2 and 4).
//!
//! When every control point but the anchors is derived (`"neighborhood": "all"`, the
//! thesis's select-all), ECLES's general path factors the whole C1 system exactly
//! (thesis ch. 14, Alg. 16-17 over ch. 5): on a mesh of 100 triangles that takes seconds,
//! and its exact minimizer has denominators of thousands of bits that bounded mode then
//! rounds away. This module solves the same least-squares problem where the C1 conditions
//! hold by construction.
//!
//! **Parametrization.** A minimal determining set ([`crate::spline::mds`]; Lai & Schumaker
//! ch. 5 and 9) writes every control point as a fixed combination of free points,
//! `p_i = sum_j B_ij f_j`, and *every* choice of `f` gives an exactly C1 spline. Split the
//! free points into unknowns `x` (free, not anchors) and free anchors (known values
//! `a_F`); the dependent anchors give equations `C x = g` (`C`: their rows of `B` on the
//! unknowns, `g`: their values minus the free anchors' share).
//!
//! **The problem.** With hints `h_i` for the derived points `D` (all non-anchors) and unit
//! weights, as ECLES.Update uses them (thesis Alg. 4),
//!
//! ```text
//!   minimize  sum_{i in D} |r_i^T x - t_i|^2   subject to   C x = g,
//!   r_i = (B_ij)_{j unknown},   t_i = h_i - sum_{j free anchor} B_ij a_j,
//! ```
//!
//! which is the general path's problem written in `x` (same feasible set, same objective),
//! so it has the same unique minimizer. `N = sum_i r_i r_i^T` is positive definite: every
//! unknown is itself a derived point, whose row is the unit vector. The KKT solution is
//!
//! ```text
//!   y = N^-1 sum_i r_i t_i,   S = C N^-1 C^T,   S mu = C y - g,   x = y - N^-1 C^T mu,
//! ```
//!
//! one sparse Cholesky factorization of `N` ([`crate::sparse`]) and a dense `m x m` `S`
//! for `m` dependent anchors, both at selection time; each operation then costs two sparse
//! solves (x and y coordinates).
//!
//! **Exactness.** The solve is in `f64`, and it is only used in bounded mode, whose
//! contract it keeps: the free points are rounded to multiples of `2^-bits` and the
//! dependents recomputed exactly from them ([`crate::spline::Spline::bound_region`]), so C1
//! holds exactly (checked in rationals), sizes stay bounded, and anchors land within a
//! small tolerance. The `f64` minimizer differs from the exact one by the solve's rounding
//! (relative `1e-12`-ish for these well-conditioned systems, see the tests), far below the
//! `2^-24` grid; tests compare the two paths point by point.

use super::select::{rel_magnitude, Neighborhood};
use super::{exact, EditError, Editor, Mode, Selection};
use crate::exact::{rat_to_f64, Rat};
use crate::sparse::{Factor, Pattern};
use crate::spline::mds::{Mds, Role};
use crate::spline::ControlPoint;
use faer::{Mat, Side};
use std::sync::Arc;

/// Fewest control points for which a select-all edit in bounded mode takes this path
/// (below, the general path is fast enough and reports ECLES's exact diagnostics).
pub const GLOBAL_MIN_POINTS: usize = 400;

/// The select-all least-squares problem in determining-set coordinates, factored.
#[derive(Debug)]
pub struct GlobalSolve {
    /// Every point as `(free point, coefficient)` pairs.
    rows: Vec<Vec<(usize, f64)>>,
    /// Unknown index of each free non-anchor point (`usize::MAX` otherwise).
    col: Vec<usize>,
    /// Whether each point is free in the determining set.
    is_free: Vec<bool>,
    /// The unknowns' points.
    unknowns: Vec<usize>,
    /// The anchors, in the selection's order.
    anchors: Vec<usize>,
    /// Positions (in `anchors`) of the dependent anchors.
    dependent_anchors: Vec<usize>,
    /// `N`'s factorization.
    factor: Factor,
    /// `N^-1 C^T`, column after column (`m` columns of `unknowns.len()` entries).
    z: Vec<f64>,
    /// `S = C N^-1 C^T`, row-major `m x m`, and its Cholesky factor (lower, row-major).
    s_chol: Vec<f64>,
}

/// Why the select-all path does not apply (the caller then uses the general path).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GlobalError {
    /// The dependent anchors' equations are not independent (`S` is singular): the general
    /// path decides their solvability exactly.
    #[error("the anchors' equations in determining-set coordinates are dependent")]
    DependentAnchors,
    /// `N` could not be factored.
    #[error("select-all system: {0}")]
    Sparse(String),
}

impl GlobalSolve {
    /// Builds and factors the problem for a spline with `n` control points, its determining
    /// set `mds` and these anchors (every other point derived).
    pub fn new(mds: &Mds, n: usize, anchors: &[usize]) -> Result<GlobalSolve, GlobalError> {
        let mut rows: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for (p, row) in rows.iter_mut().enumerate() {
            if matches!(mds.role(p), Role::Free) {
                row.push((p, 1.0));
            }
        }
        // Dependents in evaluation order: each is a combination of points evaluated before.
        let mut acc = vec![0.0f64; n];
        let mut seen = vec![false; n];
        let mut touched: Vec<usize> = Vec::new();
        for &p in mds.order() {
            let Role::Dependent(formula) = mds.role(p) else { continue };
            for (j, c) in formula {
                let c = rat_to_f64(c);
                for &(f, b) in &rows[*j] {
                    if !std::mem::replace(&mut seen[f], true) {
                        touched.push(f);
                    }
                    acc[f] += c * b;
                }
            }
            touched.sort_unstable();
            let row: Vec<(usize, f64)> =
                touched.iter().map(|&f| (f, acc[f])).filter(|&(_, v)| v != 0.0).collect();
            for &f in &touched {
                acc[f] = 0.0;
                seen[f] = false;
            }
            touched.clear();
            rows[p] = row;
        }
        let mut is_anchor = vec![false; n];
        for &a in anchors {
            is_anchor[a] = true;
        }
        let mut col = vec![usize::MAX; n];
        let mut unknowns = Vec::new();
        for p in 0..n {
            if !is_anchor[p] && matches!(mds.role(p), Role::Free) {
                col[p] = unknowns.len();
                unknowns.push(p);
            }
        }
        let nu = unknowns.len();
        // N = sum over derived points of r r^T (lower triangle entries, duplicates summed).
        let mut entries: Vec<(usize, usize)> = Vec::new();
        let mut values: Vec<f64> = Vec::new();
        for (p, row) in rows.iter().enumerate() {
            if is_anchor[p] {
                continue;
            }
            let r: Vec<(usize, f64)> = row
                .iter()
                .filter(|(f, _)| col[*f] != usize::MAX)
                .map(|&(f, c)| (col[f], c))
                .collect();
            for (a, &(i, ci)) in r.iter().enumerate() {
                for &(j, cj) in &r[..=a] {
                    entries.push((i.max(j), i.min(j)));
                    values.push(ci * cj);
                }
            }
        }
        let factor = Pattern::new(nu, &entries)
            .and_then(|pat| pat.factor(&values))
            .map_err(|e| GlobalError::Sparse(e.to_string()))?;
        let dependent_anchors: Vec<usize> =
            (0..anchors.len()).filter(|&k| !matches!(mds.role(anchors[k]), Role::Free)).collect();
        let m = dependent_anchors.len();
        let mut z = vec![0.0; nu * m];
        for (k, &ai) in dependent_anchors.iter().enumerate() {
            for &(f, c) in &rows[anchors[ai]] {
                if col[f] != usize::MAX {
                    z[k * nu + col[f]] = c;
                }
            }
        }
        // C^T's columns are copied before the solve: S = C Z.
        let ct = z.clone();
        factor.solve_many(&mut z, nu, m);
        let s = Mat::<f64>::from_fn(m, m, |i, j| {
            (0..nu).map(|u| ct[i * nu + u] * z[j * nu + u]).sum::<f64>()
        });
        let llt = s.llt(Side::Lower).map_err(|_| GlobalError::DependentAnchors)?;
        let l = llt.L();
        // A well-posed S has a diagonal bounded away from zero relative to its size.
        let scale = (0..m).map(|i| s[(i, i)]).fold(0.0f64, f64::max);
        if (0..m).any(|i| l[(i, i)] * l[(i, i)] <= 1e-12 * scale) {
            return Err(GlobalError::DependentAnchors);
        }
        let s_chol: Vec<f64> = (0..m * m).map(|k| l[(k / m, k % m)]).collect();
        let anchors = anchors.to_vec();
        let is_free = (0..n).map(|p| matches!(mds.role(p), Role::Free)).collect();
        Ok(GlobalSolve {
            rows,
            col,
            is_free,
            unknowns,
            anchors,
            dependent_anchors,
            factor,
            z,
            s_chol,
        })
    }

    /// Number of unknowns (free points that are not anchors).
    pub fn unknowns(&self) -> usize {
        self.unknowns.len()
    }

    /// The values of every free point (`n` entries, non-free ones `NaN`) minimizing the
    /// distance of the derived points to `hints` with the anchors at `anchors` (one `[x, y]`
    /// per anchor, in the order given to [`GlobalSolve::new`]); `hints` holds one `[x, y]`
    /// per point (anchors' entries ignored).
    pub fn solve_free(&self, anchors: &[[f64; 2]], hints: &[[f64; 2]]) -> Vec<[f64; 2]> {
        let n = self.rows.len();
        let nu = self.unknowns.len();
        let mut free = vec![[f64::NAN; 2]; n];
        let mut is_anchor = vec![false; n];
        for (k, &a) in self.anchors.iter().enumerate() {
            is_anchor[a] = true;
            if self.is_free[a] {
                free[a] = anchors[k];
            }
        }
        // The free anchors' share of a row.
        let known = |row: &[(usize, f64)]| -> [f64; 2] {
            let mut s = [0.0; 2];
            for &(f, c) in row {
                if self.col[f] == usize::MAX {
                    s[0] += c * free[f][0];
                    s[1] += c * free[f][1];
                }
            }
            s
        };
        // rhs = sum_i r_i t_i, x coordinates then y coordinates.
        let mut y = vec![0.0; 2 * nu];
        for (p, row) in self.rows.iter().enumerate() {
            if is_anchor[p] {
                continue;
            }
            let k = known(row);
            let t = [hints[p][0] - k[0], hints[p][1] - k[1]];
            for &(f, c) in row {
                let u = self.col[f];
                if u != usize::MAX {
                    y[u] += c * t[0];
                    y[nu + u] += c * t[1];
                }
            }
        }
        self.factor.solve_many(&mut y, nu, 2);
        let m = self.dependent_anchors.len();
        if m > 0 {
            for c in 0..2 {
                // r = C y - g, then S mu = r by the Cholesky factor.
                let mut mu: Vec<f64> = self
                    .dependent_anchors
                    .iter()
                    .map(|&ai| {
                        let row = &self.rows[self.anchors[ai]];
                        let cy: f64 = row
                            .iter()
                            .filter(|(f, _)| self.col[*f] != usize::MAX)
                            .map(|&(f, w)| w * y[c * nu + self.col[f]])
                            .sum();
                        cy - (anchors[ai][c] - known(row)[c])
                    })
                    .collect();
                for i in 0..m {
                    let s: f64 = (0..i).map(|j| self.s_chol[i * m + j] * mu[j]).sum();
                    mu[i] = (mu[i] - s) / self.s_chol[i * m + i];
                }
                for i in (0..m).rev() {
                    let s: f64 = (i + 1..m).map(|j| self.s_chol[j * m + i] * mu[j]).sum();
                    mu[i] = (mu[i] - s) / self.s_chol[i * m + i];
                }
                for (k, &muk) in mu.iter().enumerate() {
                    for u in 0..nu {
                        y[c * nu + u] -= self.z[k * nu + u] * muk;
                    }
                }
            }
        }
        for (u, &p) in self.unknowns.iter().enumerate() {
            free[p] = [y[u], y[nu + u]];
        }
        free
    }

    /// The drag preview of a select-all selection over `n` points: positions are affine in
    /// the translation `v`, `p(v) = p0 + v_x gx + v_y gy`, for the derived points in order
    /// (two entries each). Returns `(p0, gx, gy)`.
    pub(super) fn preview_basis(
        &self,
        sel: &Selection,
        n: usize,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let base_a: Vec<[f64; 2]> =
            sel.base_anchors.iter().map(|a| [rat_to_f64(&a[0]), rat_to_f64(&a[1])]).collect();
        let eval = |v: [f64; 2]| -> Vec<f64> {
            let af: Vec<[f64; 2]> = base_a.iter().map(|a| [a[0] + v[0], a[1] + v[1]]).collect();
            let mut hf = vec![[0.0; 2]; n];
            for ((p, b), th) in sel.derived.iter().zip(&sel.base_derived).zip(&sel.theta) {
                hf[p.index()] = [rat_to_f64(&b[0]) + th * v[0], rat_to_f64(&b[1]) + th * v[1]];
            }
            let pos = self.positions(&self.solve_free(&af, &hf));
            sel.derived.iter().flat_map(|p| pos[p.index()]).collect()
        };
        let p0 = eval([0.0, 0.0]);
        let sub = |g: Vec<f64>| -> Vec<f64> { g.iter().zip(&p0).map(|(a, b)| a - b).collect() };
        let (gx, gy) = (sub(eval([1.0, 0.0])), sub(eval([0.0, 1.0])));
        (p0, gx, gy)
    }

    /// Every point's position from the free points' values (as [`GlobalSolve::solve_free`]
    /// returns them).
    pub fn positions(&self, free: &[[f64; 2]]) -> Vec<[f64; 2]> {
        self.rows
            .iter()
            .map(|row| {
                row.iter()
                    .fold([0.0; 2], |s, &(f, c)| [s[0] + c * free[f][0], s[1] + c * free[f][1]])
            })
            .collect()
    }
}

/// The select-all path inside the editor.
impl Editor {
    /// The select-all path's selection, when it applies ([`self`]): every point but the
    /// anchors derived, xy mode, bounded, no extra constraints, a large enough spline, and
    /// independent anchor equations. `None` sends the caller to the general path.
    pub(super) fn select_global(
        &self,
        anchors: &[usize],
        hood: &Neighborhood,
        mode: Mode,
    ) -> Option<Selection> {
        let n = self.spline.num_points();
        let (mds, _) = self.bounded.as_ref()?;
        let applies = matches!(hood, Neighborhood::All)
            && mode == Mode::Xy
            && self.extras.is_empty()
            && self.global_min.is_some_and(|m| n >= m);
        if !applies {
            return None;
        }
        let solve = GlobalSolve::new(mds, n, anchors).ok()?;
        let mut is_anchor = vec![false; n];
        for &a in anchors {
            is_anchor[a] = true;
        }
        let derived: Vec<usize> = (0..n).filter(|&p| !is_anchor[p]).collect();
        let theta = rel_magnitude(&self.index, anchors, &derived);
        let c1 = self.spline.c1_matrix();
        let relevant =
            (0..c1.rows()).filter(|&r| c1.row(r).iter().any(|(p, _)| !is_anchor[*p])).count();
        let params = self.spline.points();
        Some(Selection {
            anchors: ControlPoint::from_indices(anchors),
            base_anchors: anchors.iter().map(|&a| params[a].clone()).collect(),
            base_derived: derived.iter().map(|&p| params[p].clone()).collect(),
            derived: ControlPoint::from_indices(&derived),
            theta,
            strong: true,
            mode,
            sessions: Vec::new(),
            global: Some(Arc::new(solve)),
            plans: Vec::new(),
            relevant,
            rank: n - mds.num_free(),
            preview: None,
        })
    }

    /// The select-all path's operation: the `f64` minimizer in determining-set coordinates,
    /// its free points rounded to the bounded grid, the dependents recomputed exactly.
    pub(super) fn apply_global(
        &mut self,
        solve: &GlobalSolve,
        anchors: &[Vec<Rat>],
        hints: &[Vec<Rat>],
    ) -> Result<(), EditError> {
        let sel = self.selection.as_ref().ok_or(EditError::NoSelection)?;
        let n = self.spline.num_points();
        let af: Vec<[f64; 2]> =
            anchors.iter().map(|a| [rat_to_f64(&a[0]), rat_to_f64(&a[1])]).collect();
        let mut hf = vec![[0.0; 2]; n];
        for (p, h) in sel.derived.iter().zip(hints) {
            hf[p.index()] = [rat_to_f64(&h[0]), rat_to_f64(&h[1])];
        }
        let free = solve.solve_free(&af, &hf);
        let mut exact_anchor: Vec<Option<&Vec<Rat>>> = vec![None; n];
        for (a, v) in sel.anchors.iter().zip(anchors) {
            exact_anchor[a.index()] = Some(v);
        }
        let (mut idx, mut vals, mut approx) = (Vec::new(), Vec::new(), Vec::new());
        for (p, f) in free.iter().enumerate() {
            if f[0].is_nan() && f[1].is_nan() {
                continue; // a dependent point
            }
            let v = match exact_anchor[p] {
                Some(a) => a.clone(),
                None => vec![exact(f[0])?, exact(f[1])?],
            };
            idx.push(p);
            vals.push(v);
            approx.push(*f);
        }
        let (mds, bits) = self.bounded.as_ref().expect("the select-all path is bounded");
        // Nothing has changed yet: the writes below cannot fail.
        self.spline.write_points(&idx, vals, &approx);
        self.spline.bound_region(mds, &vec![true; n], *bits);
        Ok(())
    }
}

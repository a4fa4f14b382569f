//! The fitting parameterization: control points as an affine function of the free points of
//! a minimal determining set (MDS, [`crate::spline::mds`]).
//!
//! ECLES's affine map (thesis Alg. 4 and 15, [`crate::ecles::AffineMap`]) writes the derived
//! points as `P_D = H hints + J P_A + c`. When the anchors are the free points of an MDS and
//! the derived points its dependents, `R_ED` has full column rank, `H = 0`, and `J` is the
//! MDS's own formulas: each dependent is a fixed rational combination of points evaluated
//! before it. So the map `x -> P(x)` is computed locally, in evaluation order, without a
//! global elimination (building `J` by ECLES's exact solves costs tens of seconds on a
//! 100-triangle mesh, the MDS map microseconds), and every choice of `x` gives a C1 spline.
//!
//! Variables are a subset of the free points (all of them, or those near the landmarks); the
//! other free points keep their current values. `x` is stored coordinate-major: the `nv`
//! x-coordinates of the variables, then their `nv` y-coordinates.

use crate::exact::{rat_to_f64, Rat};
use crate::spline::mds::{Mds, Role};
use crate::spline::Spline;
use num_traits::Zero;
use rayon::prelude::*;

/// `v` rounded to the nearest multiple of `2^-bits`, as an exact rational.
pub fn grid_rat(v: f64, bits: u32) -> Rat {
    let scaled = (v * (bits as f64).exp2()).round();
    if scaled.abs() < 9.0e15 {
        Rat::new(
            crate::exact::Int::from(scaled as i64),
            crate::exact::Int::from_i128(1i128 << bits),
        )
    } else {
        crate::spline::mds::round_to_grid(&crate::exact::rat_from_f64(v).expect("finite"), bits)
    }
}

/// The affine map from variables to all control points, in `f64`.
#[derive(Clone, Debug)]
pub struct Param {
    /// Variable free points, in variable order.
    pub vars: Vec<usize>,
    /// For each control point, its variable index if it is one.
    pub var_of: Vec<Option<usize>>,
    /// Dependents in evaluation order with their formulas.
    deps: Vec<(usize, Vec<(usize, f64)>)>,
    /// Current values of all points (the fixed free points are read from here).
    base: Vec<[f64; 2]>,
    /// [`Param::rows`], computed on first use.
    rows: std::sync::OnceLock<Vec<Vec<(usize, f64)>>>,
}

impl Param {
    /// The map for a spline and its MDS; `is_var[p]` marks the free points that vary (other
    /// marks are ignored). Variables are ordered along the longer side of the mesh's
    /// bounding box, which keeps the envelope of the normal matrix narrow.
    pub fn new(s: &Spline, mds: &Mds, is_var: &[bool]) -> Param {
        let n = s.num_points();
        let base: Vec<[f64; 2]> = (0..n).map(|p| s.point_f64(p)).collect();
        let (lo, hi) = s.mesh().bbox();
        let axis = usize::from(hi[1] - lo[1] > hi[0] - lo[0]);
        let mut vars: Vec<usize> =
            (0..n).filter(|&p| is_var[p] && matches!(mds.role(p), Role::Free)).collect();
        vars.sort_by(|&a, &b| base[a][axis].total_cmp(&base[b][axis]).then(a.cmp(&b)));
        let mut var_of = vec![None; n];
        for (k, &p) in vars.iter().enumerate() {
            var_of[p] = Some(k);
        }
        let deps = mds
            .order()
            .iter()
            .map(|&p| match mds.role(p) {
                Role::Dependent(f) => (p, f.iter().map(|(j, c)| (*j, rat_to_f64(c))).collect()),
                Role::Free => unreachable!("the order lists dependents only"),
            })
            .collect();
        Param { vars, var_of, deps, base, rows: std::sync::OnceLock::new() }
    }

    /// Number of variable points (`x` has `2 nv` entries).
    pub fn nv(&self) -> usize {
        self.vars.len()
    }

    /// The current variable values.
    pub fn x0(&self) -> Vec<f64> {
        let nv = self.nv();
        let mut x = vec![0.0; 2 * nv];
        for (k, &p) in self.vars.iter().enumerate() {
            x[k] = self.base[p][0];
            x[nv + k] = self.base[p][1];
        }
        x
    }

    /// All control points for variables `x` (into `out`, `n` entries).
    pub fn points_into(&self, x: &[f64], out: &mut [[f64; 2]]) {
        let nv = self.nv();
        out.copy_from_slice(&self.base);
        for (k, &p) in self.vars.iter().enumerate() {
            out[p] = [x[k], x[nv + k]];
        }
        for (p, f) in &self.deps {
            let mut acc = [0.0; 2];
            for &(j, c) in f {
                acc[0] += c * out[j][0];
                acc[1] += c * out[j][1];
            }
            out[*p] = acc;
        }
    }

    /// Pulls a gradient with respect to all control points back to the variables
    /// (`g` is consumed as scratch; `gx` receives `2 nv` entries).
    pub fn backprop(&self, g: &mut [[f64; 2]], gx: &mut [f64]) {
        for (p, f) in self.deps.iter().rev() {
            let gp = g[*p];
            if gp != [0.0, 0.0] {
                for &(j, c) in f {
                    g[j][0] += c * gp[0];
                    g[j][1] += c * gp[1];
                }
            }
        }
        let nv = self.nv();
        for (k, &p) in self.vars.iter().enumerate() {
            gx[k] = g[p][0];
            gx[nv + k] = g[p][1];
        }
    }

    /// The linear part of the map, row by row: for each control point, its sparse
    /// coefficients on the variables (empty for fixed points). Computed once (the objective,
    /// the smoother and Newton's structure all read it).
    pub fn rows(&self) -> &[Vec<(usize, f64)>] {
        self.rows.get_or_init(|| self.compute_rows())
    }

    fn compute_rows(&self) -> Vec<Vec<(usize, f64)>> {
        let n = self.base.len();
        let mut rows: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for (k, &p) in self.vars.iter().enumerate() {
            rows[p] = vec![(k, 1.0)];
        }
        let mut acc = vec![0.0; self.nv()];
        let mut touched: Vec<usize> = Vec::new();
        for (p, f) in &self.deps {
            for &(j, c) in f {
                for &(k, v) in &rows[j] {
                    if acc[k] == 0.0 {
                        touched.push(k);
                    }
                    acc[k] += c * v;
                }
            }
            touched.sort_unstable();
            touched.dedup();
            rows[*p] = touched.iter().map(|&k| (k, acc[k])).filter(|&(_, v)| v != 0.0).collect();
            for &k in &touched {
                acc[k] = 0.0;
            }
            touched.clear();
        }
        rows
    }

    /// The exact control points for variables `x`: variables rounded to multiples of
    /// `2^-bits`, fixed free points kept, dependents recomputed exactly by the MDS formulas,
    /// so the result is C1 exactly whatever rounding happened in `f64`.
    pub fn exact_points(&self, s: &Spline, mds: &Mds, x: &[f64], bits: u32) -> Vec<Vec<Rat>> {
        let mut vals = self.rounded_points(s, x, bits);
        let all = vec![true; vals.len()];
        mds.recompute(&mut vals, &all);
        vals
    }

    /// `s`'s control points with the variables set to `x` rounded to multiples of
    /// `2^-bits` (the first step of [`exact_points`](Self::exact_points)). The dependents
    /// are 0 until recomputed, e.g. by [`Spline::with_determined_points`] (their old values
    /// would be stale anyway, and copying them costs as much as the rest).
    pub fn rounded_points(&self, s: &Spline, x: &[f64], bits: u32) -> Vec<Vec<Rat>> {
        let nv = self.nv();
        let mut dependent = vec![false; s.num_points()];
        for (p, _) in &self.deps {
            dependent[*p] = true;
        }
        s.points()
            .par_iter()
            .enumerate()
            .map(|(p, old)| match self.var_of[p] {
                Some(k) => [x[k], x[nv + k]].iter().map(|&v| grid_rat(v, bits)).collect(),
                None if dependent[p] => vec![Rat::zero(); old.len()],
                None => old.clone(),
            })
            .collect()
    }
}

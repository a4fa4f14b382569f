//! A certified fold-free test: `det J > 0` on whole triangles, from the Bernstein
//! coefficients of the Jacobian determinant (issue 16 point 2; the spline form is that of
//! the 2017 thesis, ch. 12, eq. 12.1-12.2, and its derivative as in [`super::eval`]).
//!
//! # The determinant as a Bernstein polynomial
//!
//! On triangle `T = (v0, v1, v2)` with barycentric coordinates `b`, a degree-`d` patch is
//! `phi = sum_{|a|=d} B^d_a(b) q_a`. In the affine parameters `(b1, b2)`
//! (`p = v0 + b1 e1 + b2 e2`, `e_i = v_i - v0`, `E = [e1 e2]`):
//!
//! ```text
//!   D_(b1,b2) phi = d sum_{|m|=d-1} B^{d-1}_m(b) [D1_m  D2_m],
//!   D1_m = q_(m+e1) - q_(m+e0),   D2_m = q_(m+e2) - q_(m+e0),
//! ```
//!
//! and `J = D phi = D_(b1,b2) phi E^-1`, so `det J = d^2 P(b) / det E` with
//!
//! ```text
//!   P(b) = det(sum_m B_m D1_m, sum_n B_n D2_n) = sum_{m,n} B_m B_n D1_m x D2_n
//!        = sum_{|g|=2d-2} B^{2d-2}_g(b) c_g,
//!   c_g  = sum_{m+n=g} [C(m) C(n) / C(g)] (D1_m x D2_n),
//! ```
//!
//! using `B^{d-1}_m B^{d-1}_n = C(m) C(n) / C(m+n) B^{2d-2}_{m+n}` (`C` the multinomial
//! coefficients, `x` the 2D cross product). The sum over ordered pairs `(m, n)` is the
//! symmetric mixed determinant `(1/2)(D1_m x D2_n + D1_n x D2_m)` of the blocks
//! `J_m = [D1_m D2_m]` summed twice. The weights `C(m) C(n) / C(g)` over `m + n = g` sum to
//! 1 (Vandermonde), so each `c_g` is an average of mixed determinants; for an affine map
//! every `c_g` equals `det J`. Bernstein polynomials are non-negative and sum to 1, so
//! `min_g c_g <= P <= max_g c_g` on `T`, and the corner coefficients (`g = (2d-2) e_i`) are
//! the values at the vertices.
//!
//! # Subdivision
//!
//! When `min c_g <= 0` is not conclusive, the triangle is bisected at the midpoint of its
//! longest edge (in reference coordinates) by de Casteljau's algorithm: along every row of
//! constant index of the opposite vertex, the coefficients form a univariate Bernstein
//! polynomial, split at `1/2`. The two halves have their own Bernstein coefficients; a
//! piece is *certified* when all of them exceed the error bound, a piece whose corner value
//! is below minus the error bound *proves a fold* (`det J < 0` at that point), and pieces
//! at [`CertifyOptions::max_depth`] stay *undecided*. The coefficients converge to the
//! values quadratically in the piece size, so depth 12 (1/64 of the edge) decides all but
//! near-tangential cases (`det J` touching 0).
//!
//! # Rounding
//!
//! Mesh vertices are exact (they lie on the snapping grid). Let `u = 2^-53` and
//! `gamma_k = k u / (1 - k u)` (Higham, *Accuracy and Stability of Numerical Algorithms*,
//! ch. 3). Underflow is ignored (coordinates are pixels).
//!
//! * *Inputs.* Each patch coordinate `q~` is within `rho |q~|` of the true value
//!   (`rho = 0` for `f64` iterates, [`RAT_ROUNDING`] for rationals rounded by
//!   [`crate::exact::rat_to_f64`]). The true differences then lie within `H = 2 rho max|q~|` of the exact
//!   differences of the rounded points, and since the weights sum to 1 each `c_g` moves by
//!   at most `4 H D + 2 H^2` (`D` the largest computed difference).
//! * *Coefficients.* Each monomial of `c_g` carries one rounding for each difference, one
//!   for each product and the subtraction of the cross product, one for the weight (a
//!   quotient of exact integers) and one for its product, and `N_g - 1` for the sum of the
//!   `N_g` terms: `k = 6 + N_g`. So `|c~_g - c_g| <= gamma_k S_g` with
//!   `S_g = sum w (|D1.x D2.y| + |D1.y D2.x|)` computed alongside.
//! * *Subdivision.* A child coefficient is a convex combination of the parent's computed
//!   coefficients after at most `2d - 2` roundings (sums; halving is exact), so the child's
//!   error is the parent's plus `gamma_(2d-2) max |c~|`.
//! * *Scaling* by `d^2 / det E`: `det E` is computed with an error of at most
//!   `gamma_4 (|e1.x e2.y| + |e2.x e1.y|)` and the bound is rounded outward.
//!
//! Every bound is multiplied by `1 + 1e-12`, which covers the `O(100 u)` relative error of
//! computing the bounds themselves in `f64`. The property tests compare the `f64`
//! coefficients with the exact rational ones ([`crate::exact::Rat`]).
//!
//! # The sampled minimum
//!
//! Besides the certified bound every command reports one sampled minimum: `det J` at the
//! barycentric lattice of level [`SAMPLE_LEVEL`] of every triangle (vertices included),
//! computed here, so `check`, `field --jacobian`, `edit` and the editor print the same
//! number.

use super::layout::{local_index, multi_indices};
use super::Spline;
use rayon::prelude::*;

/// Level of the barycentric sample lattice of the common sampled minimum: the points
/// `(i, j, L - i - j) / L`, vertices included (45 per triangle).
pub const SAMPLE_LEVEL: usize = 8;

/// Relative error of [`crate::exact::rat_to_f64`] (at most one ulp, `2^-52`), used as the input error of
/// control points rounded from exact rationals.
pub const RAT_ROUNDING: f64 = f64::EPSILON;

/// Unit roundoff `u = 2^-53`.
const U: f64 = f64::EPSILON / 2.0;

/// Safety factor on every computed error bound (see the module docs).
const SAFETY: f64 = 1.0 + 1e-12;

fn gamma(k: usize) -> f64 {
    let ku = k as f64 * U;
    ku / (1.0 - ku)
}

/// Options of the certificate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CertifyOptions {
    /// Most bisection levels per triangle (the pieces at this depth that are neither
    /// certified nor folded make the triangle [`Status::Undecided`]).
    pub max_depth: usize,
    /// Most pieces examined per triangle: bounds the time on degenerate maps (`det J`
    /// identically 0 would otherwise visit all `2^(max_depth + 1)` pieces). Beyond it the
    /// triangle is undecided, with the minima of the pieces left as its bound.
    pub max_pieces: usize,
}

impl Default for CertifyOptions {
    fn default() -> Self {
        CertifyOptions { max_depth: 12, max_pieces: 400 }
    }
}

/// What the certificate proves on one triangle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Status {
    /// `det J > 0` on the whole triangle.
    Certified,
    /// A point with `det J < 0` was found.
    Fold,
    /// Neither within the depth limit (or non-finite input).
    #[default]
    Undecided,
}

/// The result of one triangle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriangleBound {
    /// A lower bound of `det J` on the triangle (`-inf` when nothing can be said).
    pub lower_bound: f64,
    /// The smallest `det J` at the [`SAMPLE_LEVEL`] lattice.
    pub sampled_min: f64,
    /// Where the sampled minimum is (reference coordinates).
    pub sampled_at: [f64; 2],
    /// Certified, fold or undecided.
    pub status: Status,
    /// For a fold: a point (reference coordinates) where `det J < 0` is proven.
    pub fold_at: Option<[f64; 2]>,
    /// Pieces examined (1 when the plain coefficients decide).
    pub pieces: usize,
}

/// The certificate of a whole spline.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DetJ {
    /// A lower bound of `det J` over the whole domain.
    pub lower_bound: f64,
    /// The smallest `det J` at the [`SAMPLE_LEVEL`] lattice of every triangle.
    pub sampled_min: f64,
    /// True only when every triangle is [`Status::Certified`].
    pub fold_free: bool,
    /// Triangles with a proven fold.
    pub folding: Vec<usize>,
    /// Triangles neither certified nor proven to fold.
    pub undecided: Vec<usize>,
    /// Triangle and reference point of the sampled minimum.
    pub worst: Option<(usize, [f64; 2])>,
}

impl DetJ {
    /// Combines per-triangle results (triangle `t` is `bounds[t]`).
    pub fn from_bounds(bounds: &[TriangleBound]) -> DetJ {
        let mut out = DetJ {
            lower_bound: f64::INFINITY,
            sampled_min: f64::INFINITY,
            fold_free: true,
            ..Default::default()
        };
        for (t, b) in bounds.iter().enumerate() {
            // NaN bounds (non-finite input) count as -inf.
            let lb = if b.lower_bound.is_nan() { f64::NEG_INFINITY } else { b.lower_bound };
            out.lower_bound = out.lower_bound.min(lb);
            if b.sampled_min < out.sampled_min || (b.sampled_min.is_nan() && out.worst.is_none()) {
                out.sampled_min = b.sampled_min;
                out.worst = Some((t, b.sampled_at));
            }
            match b.status {
                Status::Certified => {}
                Status::Fold => out.folding.push(t),
                Status::Undecided => out.undecided.push(t),
            }
        }
        out.fold_free = out.folding.is_empty() && out.undecided.is_empty();
        out
    }
}

/// One piece of the subdivision: its coefficients live in the scratch buffer slot of its
/// stack position.
#[derive(Clone, Copy, Debug)]
struct Piece {
    verts: [[f64; 2]; 3],
    err: f64,
    depth: usize,
}

/// Reusable tables and scratch space for one degree: [`Certifier::triangle`] allocates
/// nothing (after the first call at a given depth limit).
#[derive(Clone, Debug)]
pub struct Certifier {
    d: usize,
    /// Degree of `det J`: `2d - 2`.
    k: usize,
    /// For each `m` of degree `d - 1`: local indices of `m + e0`, `m + e1`, `m + e2`.
    up: Vec<[usize; 3]>,
    /// `(g, m, n, weight)` for all ordered pairs, grouped by `g`.
    pairs: Vec<(u32, u32, u32, f64)>,
    /// Per coefficient `g`: `gamma_(6 + N_g)`.
    gam: Vec<f64>,
    /// Local indices of the three corner coefficients.
    corners: [usize; 3],
    /// Per sample: barycentrics and `B^{d-1}_m(b)` for every `m`.
    samples: Vec<([f64; 3], Vec<f64>)>,
    d1: Vec<[f64; 2]>,
    d2: Vec<[f64; 2]>,
    coef: Vec<f64>,
    abs: Vec<f64>,
    /// Coefficient slots of the subdivision stack.
    buf: Vec<f64>,
    stack: Vec<Piece>,
    row: Vec<f64>,
    left: Vec<f64>,
    right: Vec<f64>,
}

fn multinomial(m: &[usize; 3]) -> u128 {
    let fact = |n: usize| (1..=n as u128).product::<u128>();
    fact(m[0] + m[1] + m[2]) / (fact(m[0]) * fact(m[1]) * fact(m[2]))
}

impl Certifier {
    /// Tables for degree `d` (1 to 15).
    pub fn new(d: usize) -> Certifier {
        assert!((1..=15).contains(&d), "degree {d} out of range");
        let k = 2 * d - 2;
        let mi = multi_indices(d - 1);
        let up = difference_indices(d);
        let nk = (k + 1) * (k + 2) / 2;
        let mut pairs = Vec::with_capacity(mi.len() * mi.len());
        let mut count = vec![0usize; nk];
        for (a, m) in mi.iter().enumerate() {
            for (b, n) in mi.iter().enumerate() {
                let g = [m[0] + n[0], m[1] + n[1], m[2] + n[2]];
                let gi = local_index(k, g[0], g[1]);
                // A quotient of exact integers (below 2^53): one rounding.
                let w = (multinomial(m) * multinomial(n)) as f64 / multinomial(&g) as f64;
                pairs.push((gi as u32, a as u32, b as u32, w));
                count[gi] += 1;
            }
        }
        pairs.sort_by_key(|p| p.0);
        let gam = count.iter().map(|&n| gamma(6 + n)).collect();
        let corners = [local_index(k, k, 0), local_index(k, 0, k), local_index(k, 0, 0)];
        let l = SAMPLE_LEVEL;
        let mut samples = Vec::new();
        for i in 0..=l {
            for j in 0..=l - i {
                let b = [i as f64 / l as f64, j as f64 / l as f64, (l - i - j) as f64 / l as f64];
                let w = mi
                    .iter()
                    .map(|m| {
                        multinomial(m) as f64
                            * b[0].powi(m[0] as i32)
                            * b[1].powi(m[1] as i32)
                            * b[2].powi(m[2] as i32)
                    })
                    .collect();
                samples.push((b, w));
            }
        }
        Certifier {
            d,
            k,
            up,
            pairs,
            gam,
            corners,
            samples,
            d1: vec![[0.0; 2]; mi.len()],
            d2: vec![[0.0; 2]; mi.len()],
            coef: vec![0.0; nk],
            abs: vec![0.0; nk],
            buf: Vec::new(),
            stack: Vec::new(),
            row: vec![0.0; k + 1],
            left: vec![0.0; k + 1],
            right: vec![0.0; k + 1],
        }
    }

    /// The degree `d` of the patches.
    pub fn degree(&self) -> usize {
        self.d
    }

    /// Number of Bernstein coefficients of `det J` (degree `2d - 2`).
    pub fn num_coefficients(&self) -> usize {
        self.coef.len()
    }

    /// Differences, coefficients of `P` (in `self.coef`) and their error bound.
    /// `None` for non-finite input.
    fn p_coefficients(&mut self, pts: &[[f64; 2]], rho: f64) -> Option<f64> {
        let mut qmax = 0.0f64;
        for p in pts {
            if !p[0].is_finite() || !p[1].is_finite() {
                return None;
            }
            qmax = qmax.max(p[0].abs()).max(p[1].abs());
        }
        let mut dmax = 0.0f64;
        for ((u, d1), d2) in self.up.iter().zip(&mut self.d1).zip(&mut self.d2) {
            let (a, b, c) = (pts[u[0]], pts[u[1]], pts[u[2]]);
            *d1 = [b[0] - a[0], b[1] - a[1]];
            *d2 = [c[0] - a[0], c[1] - a[1]];
            dmax = dmax.max(d1[0].abs()).max(d1[1].abs()).max(d2[0].abs()).max(d2[1].abs());
        }
        self.coef.iter_mut().for_each(|c| *c = 0.0);
        self.abs.iter_mut().for_each(|c| *c = 0.0);
        for &(g, m, n, w) in &self.pairs {
            let (a, b) = (self.d1[m as usize], self.d2[n as usize]);
            let (x, y) = (a[0] * b[1], a[1] * b[0]);
            self.coef[g as usize] += w * (x - y);
            self.abs[g as usize] += w * (x.abs() + y.abs());
        }
        let mut err = 0.0f64;
        for (s, g) in self.abs.iter().zip(&self.gam) {
            err = err.max(g * s);
        }
        let h = 2.0 * rho * qmax;
        let dm = dmax * (1.0 + 2.0 * U);
        err += 4.0 * h * dm + 2.0 * h * h;
        if !err.is_finite() {
            return None;
        }
        Some(err * SAFETY)
    }

    /// The Bernstein coefficients of `det J` on a triangle (degree `2d - 2`, in
    /// [`multi_indices`] order) and a bound on their error against the exact coefficients
    /// of the true control points; see [`Certifier::triangle`] for the arguments.
    /// `None` for non-finite input or a degenerate triangle.
    pub fn det_coefficients(
        &mut self,
        tri: [[f64; 2]; 3],
        pts: &[[f64; 2]],
        input_rel_err: f64,
    ) -> Option<(Vec<f64>, f64)> {
        let err = self.p_coefficients(pts, input_rel_err)?;
        let (de, de_err) = det_e(tri);
        if de.abs() <= de_err {
            return None;
        }
        let s = (self.d * self.d) as f64 / de;
        let lo = (self.d * self.d) as f64 / (de.abs() - de_err);
        let c: Vec<f64> = self.coef.iter().map(|c| c * s).collect();
        let cmax = c.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        // |c s~ - c s| <= |c s| (2u + de_err / (|de| - de_err)) and the input error scales by lo.
        let e = (err * lo + cmax * (gamma(2) + de_err / (de.abs() - de_err)) * (1.0 + 4.0 * U))
            * SAFETY;
        Some((c, e))
    }

    /// Certifies `det J > 0` on the triangle with vertices `tri` (reference coordinates)
    /// whose patch has the control points `pts` (`(d+1)(d+2)/2`, in [`multi_indices`]
    /// order). `input_rel_err` bounds the relative error of each coordinate of `pts`
    /// against the control points meant: 0 when `pts` are the points themselves (an
    /// optimizer's iterate), [`RAT_ROUNDING`] when they were rounded from exact rationals.
    pub fn triangle(
        &mut self,
        tri: [[f64; 2]; 3],
        pts: &[[f64; 2]],
        input_rel_err: f64,
        opts: &CertifyOptions,
    ) -> TriangleBound {
        self.triangle_above(tri, pts, input_rel_err, 0.0, opts)
    }

    /// [`triangle`](Self::triangle) proving the stronger `det J > floor` (`floor >= 0`):
    /// a piece is settled only when its Bernstein coefficients, less their error, clear
    /// `floor` (in the polynomial's units, rounded up), so [`Status::Certified`] comes with
    /// `lower_bound > floor`. Pieces that cannot clear it are subdivided like undecided
    /// ones. An optimizer uses a positive floor for the margin that must survive rounding
    /// its iterate to exact values.
    pub fn triangle_above(
        &mut self,
        tri: [[f64; 2]; 3],
        pts: &[[f64; 2]],
        input_rel_err: f64,
        floor: f64,
        opts: &CertifyOptions,
    ) -> TriangleBound {
        assert!(floor >= 0.0, "the floor is not negative");
        assert_eq!(pts.len(), self.up.len() + self.d + 1, "patch size of degree {}", self.d);
        let undecided = TriangleBound {
            lower_bound: f64::NEG_INFINITY,
            sampled_min: f64::NAN,
            sampled_at: tri[0],
            status: Status::Undecided,
            fold_at: None,
            pieces: 0,
        };
        let Some(err) = self.p_coefficients(pts, input_rel_err) else {
            return undecided;
        };
        let (de, de_err) = det_e(tri);
        if de.is_nan() || de.abs() <= de_err {
            return undecided;
        }
        let dd = (self.d * self.d) as f64;
        // det J > floor  <=  P' > floor (|det E| + err) / d^2 (rounded up).
        let pfloor = floor * (de.abs() + de_err) / dd * (1.0 + 4.0 * U);
        // Sampled minimum: det J = d^2 det(sum_m B_m [D1_m D2_m]) / det E.
        let (mut smin, mut sat) = (f64::INFINITY, [0.0; 3]);
        for (b, w) in &self.samples {
            let mut j = [0.0f64; 4];
            for ((wm, a), c) in w.iter().zip(&self.d1).zip(&self.d2) {
                j[0] += wm * a[0];
                j[1] += wm * c[0];
                j[2] += wm * a[1];
                j[3] += wm * c[1];
            }
            let v = dd * (j[0] * j[3] - j[1] * j[2]) / de;
            if v < smin {
                (smin, sat) = (v, *b);
            }
        }
        let sampled_at =
            [0, 1].map(|a| sat[0] * tri[0][a] + sat[1] * tri[1][a] + sat[2] * tri[2][a]);
        // Work with P' = sign(det E) P, so det J has the sign of P'.
        let nk = self.coef.len();
        if de < 0.0 {
            self.coef.iter_mut().for_each(|c| *c = -*c);
        }
        let slots = opts.max_depth + 2;
        if self.buf.len() < slots * nk {
            self.buf.resize(slots * nk, 0.0);
        }
        self.buf[..nk].copy_from_slice(&self.coef);
        self.stack.clear();
        self.stack.push(Piece { verts: tri, err, depth: 0 });
        let (mut plow, mut status, mut fold_at, mut pieces) =
            (f64::INFINITY, Status::Certified, None, 0usize);
        let step = gamma(self.k) * SAFETY;
        while let Some(piece) = self.stack.pop() {
            pieces += 1;
            let pos = self.stack.len();
            let c = &self.buf[pos * nk..(pos + 1) * nk];
            let (mut cmin, mut cmax) = (f64::INFINITY, 0.0f64);
            for &x in c {
                cmin = cmin.min(x);
                cmax = cmax.max(x.abs());
            }
            if cmin - piece.err > pfloor {
                plow = plow.min(cmin - piece.err);
                continue;
            }
            if let Some(i) = (0..3).find(|&i| c[self.corners[i]] + piece.err <= 0.0) {
                status = Status::Fold;
                fold_at = Some(piece.verts[i]);
                plow = plow.min(cmin - piece.err);
                // The rest of the stack is not examined further: their own minima bound it.
                for (s, p) in self.stack.iter().enumerate() {
                    let m =
                        self.buf[s * nk..(s + 1) * nk].iter().fold(f64::INFINITY, |a, &x| a.min(x));
                    plow = plow.min(m - p.err);
                }
                break;
            }
            if pieces >= opts.max_pieces {
                status = Status::Undecided;
                plow = plow.min(cmin - piece.err);
                for (s, p) in self.stack.iter().enumerate() {
                    let m =
                        self.buf[s * nk..(s + 1) * nk].iter().fold(f64::INFINITY, |a, &x| a.min(x));
                    plow = plow.min(m - p.err);
                }
                break;
            }
            if piece.depth >= opts.max_depth {
                status = Status::Undecided;
                plow = plow.min(cmin - piece.err);
                continue;
            }
            let child_err = piece.err + step * cmax;
            let [va, vb] = self.split(pos, &piece.verts);
            self.stack.push(Piece { verts: va, err: child_err, depth: piece.depth + 1 });
            self.stack.push(Piece { verts: vb, err: child_err, depth: piece.depth + 1 });
        }
        // det J = d^2 P' / |det E|, rounded outward.
        let lower_bound = if plow >= 0.0 {
            dd * plow / (de.abs() + de_err) * (1.0 - 4.0 * U)
        } else {
            dd * plow / (de.abs() - de_err) * (1.0 + 4.0 * U)
        };
        TriangleBound { lower_bound, sampled_min: smin, sampled_at, status, fold_at, pieces }
    }

    /// Bisects the piece in slot `pos` at the midpoint of its longest edge: the first child
    /// (which keeps the edge's first vertex) goes to slot `pos`, the second to `pos + 1`.
    fn split(&mut self, pos: usize, v: &[[f64; 2]; 3]) -> [[[f64; 2]; 3]; 2] {
        let k = self.k;
        let nk = self.coef.len();
        let len2 = |a: usize, b: usize| (v[a][0] - v[b][0]).powi(2) + (v[a][1] - v[b][1]).powi(2);
        // Edge (a, b) opposite r.
        let (a, b, r) = [(0, 1, 2), (1, 2, 0), (2, 0, 1)]
            .into_iter()
            .max_by(|x, y| len2(x.0, x.1).total_cmp(&len2(y.0, y.1)))
            .expect("three edges");
        let (lo, hi) = self.buf.split_at_mut((pos + 1) * nk);
        let parent = &mut lo[pos * nk..];
        let second = &mut hi[..nk];
        let idx = |ea: usize, eb: usize, er: usize| {
            let mut e = [0usize; 3];
            (e[a], e[b], e[r]) = (ea, eb, er);
            local_index(k, e[0], e[1])
        };
        for l in 0..=k {
            let n = k - l;
            for s in 0..=n {
                self.row[s] = parent[idx(n - s, s, l)];
            }
            self.left[0] = self.row[0];
            self.right[n] = self.row[n];
            for lev in 1..=n {
                for s in 0..=n - lev {
                    self.row[s] = (self.row[s] + self.row[s + 1]) * 0.5;
                }
                self.left[lev] = self.row[0];
                self.right[n - lev] = self.row[n - lev];
            }
            for s in 0..=n {
                let i = idx(n - s, s, l);
                parent[i] = self.left[s];
                second[i] = self.right[s];
            }
        }
        let mid = [(v[a][0] + v[b][0]) * 0.5, (v[a][1] + v[b][1]) * 0.5];
        let (mut va, mut vb) = (*v, *v);
        va[b] = mid;
        vb[a] = mid;
        [va, vb]
    }
}

/// `det E` of the triangle and a bound on its rounding error.
fn det_e(tri: [[f64; 2]; 3]) -> (f64, f64) {
    let e1 = [tri[1][0] - tri[0][0], tri[1][1] - tri[0][1]];
    let e2 = [tri[2][0] - tri[0][0], tri[2][1] - tri[0][1]];
    let (x, y) = (e1[0] * e2[1], e2[0] * e1[1]);
    (x - y, gamma(4) * (x.abs() + y.abs()) * SAFETY)
}

/// For each `m` with `|m| = d - 1` (in [`multi_indices`] order), the patch-local indices of
/// `q_(m+e0)`, `q_(m+e1)`, `q_(m+e2)`: the points whose differences `D1_m`, `D2_m` give the
/// derivative patches (module docs).
pub(super) fn difference_indices(d: usize) -> Vec<[usize; 3]> {
    multi_indices(d - 1)
        .iter()
        .map(|m| {
            [0, 1, 2].map(|c| {
                let mut n = *m;
                n[c] += 1;
                local_index(d, n[0], n[1])
            })
        })
        .collect()
}

/// Every control point of `s` rounded to `f64` ([`Spline::point_f64`]), in parallel.
fn rounded_points(s: &Spline) -> Vec<[f64; 2]> {
    (0..s.num_points()).into_par_iter().map(|p| s.point_f64(p)).collect()
}

/// The vertices of triangle `t` and its patch points gathered from `q` (all control points).
fn patch(s: &Spline, q: &[[f64; 2]], t: usize, pts: &mut Vec<[f64; 2]>) -> [[f64; 2]; 3] {
    let m = s.mesh();
    pts.clear();
    pts.extend(s.layout().patches()[t].iter().map(|&p| q[p]));
    m.triangle(t).map(|v| m.vertex(v))
}

/// Whether `det J > 0` is proven on every triangle of `s` for the `f64` control points `q`
/// (global numbering, treated as exact: an optimizer's iterate), in parallel; stops at the
/// first triangle that is not certified.
pub fn certify_points(s: &Spline, q: &[[f64; 2]], opts: &CertifyOptions) -> bool {
    certify_points_above(s, q, 0.0, opts)
}

/// [`certify_points`] proving `det J > floor` on every triangle
/// ([`Certifier::triangle_above`]).
pub fn certify_points_above(s: &Spline, q: &[[f64; 2]], floor: f64, opts: &CertifyOptions) -> bool {
    (0..s.mesh().num_triangles()).into_par_iter().all(|t| {
        let mut pts = Vec::new();
        let tri = patch(s, q, t, &mut pts);
        CERTIFIER.with(|c| {
            let mut c = c.borrow_mut();
            if c.as_ref().is_none_or(|c| c.degree() != s.degree()) {
                *c = Some(Certifier::new(s.degree()));
            }
            let c = c.as_mut().expect("set above");
            matches!(c.triangle_above(tri, &pts, 0.0, floor, opts).status, Status::Certified)
        })
    })
}

thread_local! {
    /// One reusable certifier per thread for [`certify_points`].
    static CERTIFIER: std::cell::RefCell<Option<Certifier>> = const { std::cell::RefCell::new(None) };
}

/// [`Certifier::triangle`] for triangle `t` of `s` with the `f64` patch points `points`
/// (treated as exact: e.g. an optimizer's iterate). Allocates its tables; inside a loop
/// keep one [`Certifier`] instead.
pub fn triangle_bound(
    s: &Spline,
    t: usize,
    points: &[[f64; 2]],
    opts: &CertifyOptions,
) -> TriangleBound {
    let m = s.mesh();
    let tri = m.triangle(t).map(|v| m.vertex(v));
    Certifier::new(s.degree()).triangle(tri, points, 0.0, opts)
}

/// The certificate of every triangle of `s`, from its exact control points (rounded to
/// `f64` with [`RAT_ROUNDING`] accounted for), in parallel.
pub fn certify_triangles(s: &Spline, opts: &CertifyOptions) -> Vec<TriangleBound> {
    certify_rounded(s, &rounded_points(s), opts)
}

fn certify_rounded(s: &Spline, q: &[[f64; 2]], opts: &CertifyOptions) -> Vec<TriangleBound> {
    (0..s.mesh().num_triangles())
        .into_par_iter()
        .map_init(
            || (Certifier::new(s.degree()), Vec::new()),
            |(c, pts), t| {
                let tri = patch(s, q, t, pts);
                c.triangle(tri, pts, RAT_ROUNDING, opts)
            },
        )
        .collect()
}

/// The certificate of `s`: [`certify_triangles`] combined by [`DetJ::from_bounds`].
pub fn certify(s: &Spline, opts: &CertifyOptions) -> DetJ {
    DetJ::from_bounds(&certify_triangles(s, opts))
}

/// Per-triangle certificates kept up to date as control points change (the editor
/// re-certifies only the triangles around the points a drag moved).
#[derive(Clone, Debug)]
pub struct CertCache {
    opts: CertifyOptions,
    bounds: Vec<TriangleBound>,
    /// For each control point, the triangles whose patch contains it.
    point_tris: Vec<Vec<u32>>,
    certifier: Certifier,
    /// Every control point rounded to `f64` (only the changed ones are converted again).
    q: Vec<[f64; 2]>,
    pts: Vec<[f64; 2]>,
    mark: Vec<bool>,
}

impl CertCache {
    /// Certifies every triangle of `s`.
    pub fn new(s: &Spline, opts: CertifyOptions) -> CertCache {
        let mut point_tris = vec![Vec::new(); s.num_points()];
        for (t, p) in s.layout().patches().iter().enumerate() {
            for &i in p {
                if point_tris[i].last() != Some(&(t as u32)) {
                    point_tris[i].push(t as u32);
                }
            }
        }
        let q = rounded_points(s);
        CertCache {
            bounds: certify_rounded(s, &q, &opts),
            q,
            opts,
            point_tris,
            certifier: Certifier::new(s.degree()),
            pts: Vec::new(),
            mark: vec![false; s.mesh().num_triangles()],
        }
    }

    /// Re-certifies every triangle (after a change of unknown extent).
    pub fn refresh_all(&mut self, s: &Spline) {
        self.q = rounded_points(s);
        self.bounds = certify_rounded(s, &self.q, &self.opts);
    }

    /// Re-certifies the triangles containing any of `points` (control point indices);
    /// returns how many were redone. `s` must have the layout the cache was built for.
    pub fn refresh_points(&mut self, s: &Spline, points: &[usize]) -> usize {
        let mut todo = Vec::new();
        for &p in points {
            self.q[p] = s.point_f64(p);
            for &t in &self.point_tris[p] {
                if !std::mem::replace(&mut self.mark[t as usize], true) {
                    todo.push(t as usize);
                }
            }
        }
        for &t in &todo {
            let tri = patch(s, &self.q, t, &mut self.pts);
            self.bounds[t] = self.certifier.triangle(tri, &self.pts, RAT_ROUNDING, &self.opts);
            self.mark[t] = false;
        }
        todo.len()
    }

    /// The per-triangle results.
    pub fn bounds(&self) -> &[TriangleBound] {
        &self.bounds
    }

    /// The combined certificate.
    pub fn summary(&self) -> DetJ {
        DetJ::from_bounds(&self.bounds)
    }
}

#[cfg(test)]
#[path = "jacobian_tests.rs"]
mod tests;

//! The fitting objective and its analytic gradient.
//!
//! For variables `x` (see [`super::param`]) with control points `P(x)`:
//!
//! ```text
//!   F(x) = sum_i w_i rho(|phi(s_i) - t_i|)                    data (pixels^2)
//!        + lambda_bend sum_T E_T(phi)                          bending (thin-plate)
//!        + mu sum_T |T|/n_s sum_samples beta(det J(sample))   fold barrier
//! ```
//!
//! * `rho` is squares `r^2`, Huber (`r^2` up to `delta`, then `2 delta r - delta^2`) or
//!   Cauchy (`c^2 ln(1 + r^2/c^2)`); all three have curvature 2 at `r = 0`, so the normal
//!   matrix of the squares problem preconditions every loss.
//! * `E_T` is the exact bending energy of each coordinate on triangle `T`
//!   ([`super::basis::bending_matrix`]).
//! * `beta` keeps `det J` above a floor `f`: with `u = det - f` and `U = tau - f`,
//!   `beta = (U/u - 1)^2` for `0 < u < U`, 0 above `tau`, growing without bound towards the
//!   floor; below `u = U/20` it continues as its second-order Taylor polynomial (so line
//!   searches that overshoot see a finite, steep wall instead of a pole). `det J` is sampled
//!   at the level-`k` barycentric points of each triangle (vertices, edges and interior).
//!
//! `phi(s_i)` is a fixed row over the control points (the source points do not move), so the
//! data term's gradient is exact and cheap; the barrier's is `d det / d q` from the two
//! derivative rows. Gradients are pulled back to `x` through the MDS map.

use super::basis::{frame, sample_points, value_row, Bending, DerivativeStencil, Row};
use super::param::Param;
use crate::spline::Spline;
use rayon::prelude::*;

mod assembly;
pub use assembly::{lower_entries, BendingSystem, BendingValues};

/// The robust loss of the data term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Loss {
    /// `r^2`.
    Squares,
    /// Huber with threshold `delta` (pixels).
    Huber(f64),
    /// Cauchy (Lorentzian) with scale `c` (pixels).
    Cauchy(f64),
}

/// The kind of a [`Loss`], without its scale: what `--loss` and the Python `loss=` keyword
/// name (`squares` or `l2`, `huber`, `cauchy`; see [`LossKind::from_str`](std::str::FromStr)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LossKind {
    /// [`Loss::Squares`].
    Squares,
    /// [`Loss::Huber`].
    Huber,
    /// [`Loss::Cauchy`].
    Cauchy,
}

impl LossKind {
    /// The names of the kinds, in the order of the variants
    /// ([`LossKind::from_str`](std::str::FromStr) also takes `l2` for `squares`).
    pub const NAMES: [&'static str; 3] = ["squares", "huber", "cauchy"];

    /// The name used in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LossKind::Squares => "squares",
            LossKind::Huber => "huber",
            LossKind::Cauchy => "cauchy",
        }
    }
}

impl std::str::FromStr for LossKind {
    type Err = LossError;
    /// `squares` (or `l2`), `huber` or `cauchy`, exactly.
    fn from_str(name: &str) -> Result<LossKind, LossError> {
        match name {
            "squares" | "l2" => Ok(LossKind::Squares),
            "huber" => Ok(LossKind::Huber),
            "cauchy" => Ok(LossKind::Cauchy),
            other => Err(LossError::Unknown(other.to_string())),
        }
    }
}

/// Why a loss could not be made from a name and a scale.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LossError {
    /// The name is none of [`LossKind::NAMES`] (nor `l2`).
    #[error("unknown loss `{0}` (use squares, huber or cauchy)")]
    Unknown(String),
    /// Huber and Cauchy need a finite scale `> 0`.
    #[error("the {} loss needs a finite scale > 0 (pixels), got {scale}", kind.name())]
    Scale {
        /// The loss.
        kind: LossKind,
        /// The scale given.
        scale: f64,
    },
}

impl Loss {
    /// The loss of kind `kind` with scale `scale` (pixels; used by Huber and Cauchy, which
    /// need it finite and positive).
    pub fn new(kind: LossKind, scale: f64) -> Result<Loss, LossError> {
        let scaled = |f: fn(f64) -> Loss| {
            if scale.is_finite() && scale > 0.0 {
                Ok(f(scale))
            } else {
                Err(LossError::Scale { kind, scale })
            }
        };
        match kind {
            LossKind::Squares => Ok(Loss::Squares),
            LossKind::Huber => scaled(Loss::Huber),
            LossKind::Cauchy => scaled(Loss::Cauchy),
        }
    }

    /// The loss named `name` (`squares` or `l2`, `huber`, `cauchy`) with scale `scale`
    /// ([`Loss::new`] of the [`LossKind`] named).
    pub fn from_name(name: &str, scale: f64) -> Result<Loss, LossError> {
        Loss::new(name.parse()?, scale)
    }

    /// Its kind.
    pub fn kind(self) -> LossKind {
        match self {
            Loss::Squares => LossKind::Squares,
            Loss::Huber(_) => LossKind::Huber,
            Loss::Cauchy(_) => LossKind::Cauchy,
        }
    }

    /// `(rho(r), rho'(r) / r)`.
    #[inline]
    pub fn eval(self, r: f64) -> (f64, f64) {
        match self {
            Loss::Squares => (r * r, 2.0),
            Loss::Huber(d) => {
                if r <= d {
                    (r * r, 2.0)
                } else {
                    (2.0 * d * r - d * d, 2.0 * d / r)
                }
            }
            Loss::Cauchy(c) => {
                let q = 1.0 + r * r / (c * c);
                (c * c * q.ln(), 2.0 / q)
            }
        }
    }

    /// The name used in reports and on the command line.
    pub fn name(self) -> &'static str {
        self.kind().name()
    }
}

/// A determinant floor that is not a finite number below 1 (the floor given).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("the determinant floor must be a number below 1, got {0}")]
pub struct FloorError(pub f64);

/// The fold barrier's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Barrier {
    /// The floor `f` that `det J` must stay above.
    pub floor: f64,
    /// Where the barrier starts (`tau > f`).
    pub tau: f64,
    /// Its weight `mu` (per unit of reference area).
    pub mu: f64,
}

impl Barrier {
    /// The width of the barrier's active band above its floor: `tau = floor + BAND`.
    pub const BAND: f64 = 0.2;

    /// The barrier keeping `det J` above `floor` (a number below 1), active from
    /// `floor + BAND`, with unit weight.
    pub fn with_floor(floor: f64) -> Result<Barrier, FloorError> {
        if !(floor.is_finite() && floor < 1.0) {
            return Err(FloorError(floor));
        }
        Ok(Barrier { floor, tau: floor + Self::BAND, mu: 1.0 })
    }

    /// The barrier for a map whose natural scale of area is `det_a` (the determinant of
    /// the landmarks' affine map): floor and threshold times `min(1, det_a)`. A map that
    /// shrinks the frame as a whole (`det_a < 1`, e.g. a landmark set from a large image to
    /// a small one) is held to the same *relative* compression as a map of scale 1
    /// (`beta` depends on `(tau - f) / (det - f)` only, so it is `beta(det / det_a)`); an
    /// absolute floor above `det_a` would fight the data everywhere. Maps that enlarge keep
    /// the absolute floor.
    pub fn relative_to(self, det_a: f64) -> Barrier {
        let k = if det_a.is_finite() && det_a > 0.0 { det_a.min(1.0) } else { 1.0 };
        Barrier { floor: self.floor * k, tau: self.tau * k, mu: self.mu }
    }

    /// `(beta, beta')` at `det`.
    #[inline]
    pub fn eval(&self, det: f64) -> (f64, f64) {
        let (b, d1, _) = self.eval2(det);
        (b, d1)
    }

    /// `(beta, beta', beta'')` at `det` (`beta''` > 0 where the barrier is active: it is
    /// convex).
    #[inline]
    pub fn eval2(&self, det: f64) -> (f64, f64, f64) {
        if det >= self.tau {
            return (0.0, 0.0, 0.0);
        }
        let big_u = self.tau - self.floor;
        let ue = big_u / 20.0;
        let at = |u: f64| {
            let v = big_u / u - 1.0;
            let d1 = 2.0 * v * (-big_u / (u * u));
            let d2 = 2.0 * (big_u / (u * u)).powi(2) + 2.0 * v * (2.0 * big_u / (u * u * u));
            (v * v, d1, d2)
        };
        let u = det - self.floor;
        if u >= ue {
            at(u)
        } else {
            let (b, d1, d2) = at(ue);
            let h = u - ue;
            (b + d1 * h + 0.5 * d2 * h * h, d1 + d2 * h, d2)
        }
    }
}

/// A data row over the variables: `(a_i, r_i, t_i)` with `phi(s_i) = a_i^T x + r_i`.
pub type VariableRow = (Vec<(usize, f64)>, [f64; 2], [f64; 2]);

/// One landmark's row: `phi(s) = sum w_p P_p`, its target and weight.
#[derive(Clone, Debug)]
pub struct DataRow {
    /// The row over control points.
    pub row: Row,
    /// Target point.
    pub target: [f64; 2],
    /// Weight.
    pub weight: f64,
    /// The triangle whose patch gives the row (the one the source was located in).
    pub triangle: usize,
}

/// One triangle's share of the objective.
#[derive(Clone, Debug)]
pub(super) struct TriTerm {
    /// The patch's control points (file order).
    pub(super) patch: Vec<usize>,
    /// The bending matrix `K_T` (row-major, patch order).
    pub(super) k: Vec<f64>,
    /// Per sample: `d/dx` and `d/dy` rows over the patch.
    pub(super) samples: Vec<[Vec<f64>; 2]>,
    /// Area per sample.
    pub(super) sample_weight: f64,
}

/// One triangle's bending block over the variables ([`Objective::triangle_blocks`]).
pub(super) struct TriangleBlock {
    /// Variables the patch depends on.
    pub(super) local: Vec<usize>,
    /// `S_T` (patch points x local variables, row-major).
    pub(super) st: Vec<f64>,
    /// `S_T^T K_T S_T` (local x local).
    pub(super) bend: Vec<f64>,
}

/// The terms of `F` at some `x`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Terms {
    /// Data term.
    pub data: f64,
    /// Bending energy (before `lambda`).
    pub bend: f64,
    /// Barrier term (before `mu`).
    pub barrier: f64,
    /// Smallest sampled `det J`.
    pub min_det: f64,
    /// The total `F`.
    pub total: f64,
}

/// Every triangle's share of the objective that does not depend on the parameterization
/// (bending matrix, `det J` sample rows): it needs the spline's mesh and degree only, so a
/// caller can build it alongside the determining set.
pub(super) struct TriangleTerms(Vec<TriTerm>);

impl TriangleTerms {
    /// The terms of every triangle of `s`, `det J` sampled at level `det_level`.
    pub(super) fn new(s: &Spline, det_level: usize) -> TriangleTerms {
        let pts = sample_points(det_level);
        let bending = Bending::new(s.degree());
        let stencil = DerivativeStencil::new(s.degree(), &pts);
        // Each triangle's terms depend on that triangle only: built in parallel, in order.
        let tris = (0..s.mesh().num_triangles())
            .into_par_iter()
            .map(|t| {
                let patch = s.layout().patches()[t].clone();
                let v = s.mesh().triangle(t).map(|i| s.mesh().vertex(i));
                let area = 0.5
                    * ((v[1][0] - v[0][0]) * (v[2][1] - v[0][1])
                        - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]))
                        .abs();
                TriTerm {
                    k: bending.matrix(s, t),
                    samples: stencil.rows(frame(s, t).gradients()),
                    sample_weight: area / pts.len() as f64,
                    patch,
                }
            })
            .collect();
        TriangleTerms(tris)
    }
}

/// The objective over one parameterization; see the module docs.
#[derive(Clone, Debug)]
pub struct Objective {
    /// The parameterization.
    pub param: Param,
    rows: Vec<DataRow>,
    tris: Vec<TriTerm>,
    /// The data loss.
    pub loss: Loss,
    /// `lambda_bend`.
    pub bend: f64,
    /// The barrier (None: off).
    pub barrier: Option<Barrier>,
    /// The area `|Omega|` that scale-free bending weights refer to (`None`: the mesh's,
    /// [`area`](Self::area)); see [`super::smooth`].
    pub bend_area: Option<f64>,
}

impl Objective {
    /// Builds the objective. `det_level` is the sample level `k` of the barrier.
    pub fn new(
        s: &Spline,
        param: Param,
        rows: Vec<DataRow>,
        loss: Loss,
        bend: f64,
        barrier: Option<Barrier>,
        det_level: usize,
    ) -> Objective {
        let terms = TriangleTerms::new(s, det_level);
        Objective::with_terms(param, rows, loss, bend, barrier, terms)
    }

    /// [`new`](Self::new) with the triangles' terms already built (for the same spline's
    /// mesh and degree, and the same `det_level`).
    pub(super) fn with_terms(
        param: Param,
        rows: Vec<DataRow>,
        loss: Loss,
        bend: f64,
        barrier: Option<Barrier>,
        terms: TriangleTerms,
    ) -> Objective {
        Objective { param, rows, tris: terms.0, loss, bend, barrier, bend_area: None }
    }

    /// The triangles' terms.
    pub(super) fn tris(&self) -> &[TriTerm] {
        &self.tris
    }

    /// The data rows.
    pub fn rows(&self) -> &[DataRow] {
        &self.rows
    }

    /// Multiplies each data row's weight by `scale[i]`.
    pub fn scale_weights(&mut self, scale: &[f64]) {
        for (r, s) in self.rows.iter_mut().zip(scale) {
            r.weight *= s;
        }
    }

    /// The data rows' residual lengths `|phi(s_i) - t_i|` at `x`.
    pub fn residual_lengths(&self, x: &[f64]) -> Vec<f64> {
        self.mapped(x)
            .iter()
            .zip(&self.rows)
            .map(|(m, r)| (m[0] - r.target[0]).hypot(m[1] - r.target[1]))
            .collect()
    }

    /// `F(x)` and its terms; with `grad`, also `dF/dx` (`2 nv` entries).
    pub fn eval(&self, x: &[f64], grad: Option<&mut [f64]>) -> Terms {
        let n = self.param.var_of.len();
        let mut p = vec![[0.0f64; 2]; n];
        self.param.points_into(x, &mut p);
        let want = grad.is_some();
        let mut g = if want { vec![[0.0f64; 2]; n] } else { Vec::new() };
        let mut t = Terms { min_det: f64::INFINITY, ..Terms::default() };
        for r in &self.rows {
            let mut v = [0.0; 2];
            for &(j, w) in &r.row {
                v[0] += w * p[j][0];
                v[1] += w * p[j][1];
            }
            let e = [v[0] - r.target[0], v[1] - r.target[1]];
            let (rho, psi) = self.loss.eval(e[0].hypot(e[1]));
            t.data += r.weight * rho;
            if want {
                let f = r.weight * psi;
                for &(j, w) in &r.row {
                    g[j][0] += f * w * e[0];
                    g[j][1] += f * w * e[1];
                }
            }
        }
        let mut q = [[0.0f64; 2]; 64];
        for tri in &self.tris {
            let m = tri.patch.len();
            let q = &mut q[..m];
            for (a, &j) in tri.patch.iter().enumerate() {
                q[a] = p[j];
            }
            if self.bend > 0.0 {
                for r in 0..m {
                    let mut kq = [0.0; 2];
                    for c in 0..m {
                        let kv = tri.k[r * m + c];
                        kq[0] += kv * q[c][0];
                        kq[1] += kv * q[c][1];
                    }
                    t.bend += q[r][0] * kq[0] + q[r][1] * kq[1];
                    if want {
                        g[tri.patch[r]][0] += 2.0 * self.bend * kq[0];
                        g[tri.patch[r]][1] += 2.0 * self.bend * kq[1];
                    }
                }
            }
            for [dx, dy] in &tri.samples {
                let (j, det) = sample_jacobian(dx, dy, q);
                t.min_det = t.min_det.min(det);
                if let Some(b) = &self.barrier {
                    let (beta, db) = b.eval(det);
                    if beta != 0.0 || db != 0.0 {
                        t.barrier += tri.sample_weight * beta;
                        if want {
                            let f = b.mu * tri.sample_weight * db;
                            for a in 0..m {
                                let gp = &mut g[tri.patch[a]];
                                let da = det_gradient(dx[a], dy[a], &j);
                                gp[0] += f * da[0];
                                gp[1] += f * da[1];
                            }
                        }
                    }
                }
            }
        }
        let mu = self.barrier.map_or(0.0, |b| b.mu);
        t.total = t.data + self.bend * t.bend + mu * t.barrier;
        if let Some(gx) = grad {
            self.param.backprop(&mut g, gx);
        }
        t
    }

    /// The normal matrix `N` of the squares problem without barrier, one coordinate:
    /// `sum_i w_i a_i a_i^T + lambda sum_T S_T^T K_T S_T` (`nv x nv`, row-major), where `a_i`
    /// is landmark `i`'s row over the variables and `S_T` the patch rows. `F`'s Hessian is
    /// `2 N` per coordinate for squares.
    pub fn normal_matrix(&self) -> Vec<f64> {
        self.normal_matrix_weighted(None)
    }

    /// [`normal_matrix`](Self::normal_matrix) with each data row's weight multiplied by
    /// `scale[i]` (iteratively reweighted least squares).
    pub fn normal_matrix_weighted(&self, scale: Option<&[f64]>) -> Vec<f64> {
        let nv = self.param.nv();
        let rows = self.param.rows();
        let mut nm = vec![0.0; nv * nv];
        let mut dense = vec![0.0; nv];
        let mut touched: Vec<usize> = Vec::new();
        for (i, r) in self.rows.iter().enumerate() {
            let weight = r.weight * scale.map_or(1.0, |s| s[i]);
            for &(j, w) in &r.row {
                for &(k, v) in &rows[j] {
                    if dense[k] == 0.0 {
                        touched.push(k);
                    }
                    dense[k] += w * v;
                }
            }
            touched.sort_unstable();
            touched.dedup();
            for &a in &touched {
                for &b in &touched {
                    nm[a * nv + b] += weight * dense[a] * dense[b];
                }
            }
            for &k in &touched {
                dense[k] = 0.0;
            }
            touched.clear();
        }
        if self.bend > 0.0 {
            let bend = self.bend;
            self.bending_entries(|a, b, v| nm[a * nv + b] += bend * v);
        }
        nm
    }

    /// The domain's area (sum of the triangle areas).
    pub fn area(&self) -> f64 {
        self.tris.iter().map(|t| t.sample_weight * t.samples.len() as f64).sum()
    }

    /// The area scale-free bending weights refer to: [`bend_area`](Self::bend_area) when
    /// set, else [`area`](Self::area).
    pub fn reference_area(&self) -> f64 {
        self.bend_area.unwrap_or_else(|| self.area())
    }

    /// Each data row over the variables: `(a_i, r_i, t_i)` with `phi(s_i) = a_i^T x + r_i`
    /// per coordinate (`r_i` is the share of the fixed points).
    pub fn variable_rows(&self) -> Vec<VariableRow> {
        let prow = self.param.rows();
        let nv = self.param.nv();
        let mut p0 = vec![[0.0f64; 2]; self.param.var_of.len()];
        self.param.points_into(&vec![0.0; 2 * nv], &mut p0);
        let mut acc = vec![0.0; nv];
        let mut touched: Vec<usize> = Vec::new();
        self.rows
            .iter()
            .map(|r| {
                let mut r0 = [0.0; 2];
                for &(j, w) in &r.row {
                    r0[0] += w * p0[j][0];
                    r0[1] += w * p0[j][1];
                    for &(k, v) in &prow[j] {
                        if acc[k] == 0.0 {
                            touched.push(k);
                        }
                        acc[k] += w * v;
                    }
                }
                touched.sort_unstable();
                touched.dedup();
                let row = touched.iter().map(|&k| (k, acc[k])).filter(|e| e.1 != 0.0).collect();
                for &k in &touched {
                    acc[k] = 0.0;
                }
                touched.clear();
                (row, r0, r.target)
            })
            .collect()
    }

    /// `phi(s_i)` for every data row at variables `x`.
    pub fn mapped(&self, x: &[f64]) -> Vec<[f64; 2]> {
        let mut p = vec![[0.0f64; 2]; self.param.var_of.len()];
        self.param.points_into(x, &mut p);
        self.rows
            .iter()
            .map(|r| {
                let mut v = [0.0; 2];
                for &(j, w) in &r.row {
                    v[0] += w * p[j][0];
                    v[1] += w * p[j][1];
                }
                v
            })
            .collect()
    }
}

/// `J` and `det J` at a sample whose derivative rows over the patch are `dx`, `dy`, for patch
/// points `q`.
#[inline]
pub(super) fn sample_jacobian(dx: &[f64], dy: &[f64], q: &[[f64; 2]]) -> ([[f64; 2]; 2], f64) {
    let mut j = [[0.0f64; 2]; 2];
    for ((a, b), p) in dx.iter().zip(dy).zip(q) {
        j[0][0] += a * p[0];
        j[0][1] += b * p[0];
        j[1][0] += a * p[1];
        j[1][1] += b * p[1];
    }
    (j, j[0][0] * j[1][1] - j[0][1] * j[1][0])
}

/// `d det J / d q_a` (both coordinates) for a patch point with derivative weights `dx`, `dy`.
#[inline]
pub(super) fn det_gradient(dx: f64, dy: f64, j: &[[f64; 2]; 2]) -> [f64; 2] {
    [dx * j[1][1] - dy * j[1][0], dy * j[0][0] - dx * j[0][1]]
}

/// The data row of a source point: `Err(())` when it lies outside the mesh.
pub fn data_row(s: &Spline, src: [f64; 2], target: [f64; 2], weight: f64) -> Option<DataRow> {
    let (t, b) = s.mesh().locate(src, None)?;
    Some(DataRow { row: value_row(s, t, b), target, weight, triangle: t })
}

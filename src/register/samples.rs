//! The samples of the image term: moving-image pixels `y_i` with their values `m_i`, where
//! they fall in the mesh, and the image term `E(phi(y_1), ..., phi(y_N))` with its gradient.
//!
//! At pyramid level `l` the samples are the moving level's pixel centres inside its mask (a
//! regular subset of them when there are more than [`SampleOptions::max_samples`]), at
//! their level-0 positions ([`super::image::Level::to_full`]); `m_i` is the level smoothed by
//! `[1, 4, 1] / 6` (the fixed side's interpolant blurs the same way). The fixed level is
//! sampled at `phi(y_i)` ([`super::image::Level::sample_full`]), and the chain rule gives
//! `dE / d phi(y_i) = dE/df_i grad F(phi(y_i))`.
//!
//! On the spline, `phi(y_i) = sum_m B^d_m(b_i) q_m` over the control points `q_m` of the
//! triangle holding `y_i` (barycentric `b_i`; the mesh lives in MOVING's pixels, so `b_i`
//! does not change while the spline does). So `dE/dq_m = sum_i B^d_m(b_i) dE/dphi(y_i)`, and
//! the gradient is pulled back to the free points through the determining set
//! ([`crate::fit::param::Param::backprop`]).

use super::image::Level;
use super::metric::{evaluate, Metric, Scale};
use crate::spline::layout::{local_index, multi_indices};
use crate::spline::Spline;
use rayon::prelude::*;

/// How samples are drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleOptions {
    /// At most this many samples per level (a regular subset of the pixels beyond it).
    pub max_samples: usize,
}

impl Default for SampleOptions {
    fn default() -> Self {
        SampleOptions { max_samples: 1 << 15 }
    }
}

/// The moving samples of one level.
#[derive(Clone, Debug)]
pub struct SampleSet {
    /// Level-0 positions `y_i` in MOVING's pixels.
    pub pos: Vec<[f64; 2]>,
    /// Moving values `m_i`.
    pub m: Vec<f64>,
    /// The metric's scale (ranges and variance).
    pub scale: Scale,
}

impl SampleSet {
    /// The samples of `moving` (masked pixels only), with the scale against `fixed`.
    pub fn new(moving: &Level, fixed: &Level, opts: SampleOptions) -> SampleSet {
        let smooth = moving.image.smoothed141();
        let (w, h) = (smooth.w, smooth.h);
        let inside = |x: usize, y: usize| moving.mask.as_ref().is_none_or(|m| m.on[y * w + x]);
        let count = moving.mask.as_ref().map_or(w * h, |m| m.count());
        let stride =
            ((count as f64 / opts.max_samples.max(1) as f64).sqrt().ceil() as usize).max(1);
        let (mut pos, mut m) = (Vec::new(), Vec::new());
        for y in (stride / 2..h).step_by(stride) {
            for x in (stride / 2..w).step_by(stride) {
                if inside(x, y) {
                    pos.push(moving.to_full([x as f64, y as f64]));
                    m.push(smooth.at(x, y) as f64);
                }
            }
        }
        let n = m.len().max(1) as f64;
        let mean = m.iter().sum::<f64>() / n;
        let var_m = m.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
        let m_range =
            m.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let (flo, fhi) = fixed.image.range(fixed.mask.as_ref());
        SampleSet { pos, m, scale: Scale { var_m, m_range, f_range: (flo as f64, fhi as f64) } }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }
}

/// The image term at mapped positions `u_i = phi(y_i)`.
#[derive(Clone, Debug, Default)]
pub struct ImageTerm {
    /// The metric's value.
    pub value: f64,
    /// `dE / d u_i` (when asked for).
    pub d_u: Vec<[f64; 2]>,
    /// Samples inside the fixed image (and its mask).
    pub valid: usize,
}

/// Which samples count in the image term throughout one optimizer run: those whose mapped
/// position lay inside FIXED (and its mask) when the run started.
///
/// A sample that enters or leaves FIXED while the map changes would switch its term on or
/// off at once, and the cost would jump: on the textured pair of `tests/it/register.rs`, one
/// sample of 16,000 entering at FIXED's border raised `ncc` by 5 % (3.72e-4 to 3.89e-4),
/// L-BFGS's line search stopped on the jump ("converged" with half the iterations left),
/// and the map ended 0.082 px from the truth against 0.064 px. Within a run the samples
/// therefore stay those of its start: one that leaves FIXED reads its border values
/// continued outward ([`Level::sample_clamped`]), one that enters does not count until the
/// next run. The cost is then as smooth as the interpolant. Weighting the samples down
/// across a band along the border instead (continuous too) let the optimizer lower the cost
/// by pushing ill-matched samples out of the image: on the `mi` cell pair of
/// `benches/register_compare.py` the map folded (det J >= -0.13).
pub type Membership = Vec<bool>;

/// The samples of `set` inside `fixed` (and its mask) at mapped positions `u`
/// ([`Membership`]).
pub fn membership(fixed: &Level, u: &[[f64; 2]]) -> Membership {
    u.par_iter().with_min_len(4096).map(|&p| fixed.sample_full(p).is_some()).collect()
}

/// Evaluates the metric of `set` against `fixed` at mapped positions `u`: over the samples
/// inside FIXED and its mask, or, with `keep`, over the samples it names, continued beyond
/// FIXED's border ([`Membership`]).
pub fn image_term(
    metric: Metric,
    fixed: &Level,
    set: &SampleSet,
    u: &[[f64; 2]],
    grad: bool,
    keep: Option<&[bool]>,
) -> ImageTerm {
    let sampled: Vec<Option<(f64, [f64; 2])>> = match keep {
        None => u.par_iter().with_min_len(4096).map(|&p| fixed.sample_full(p)).collect(),
        Some(k) => u
            .par_iter()
            .zip(k)
            .with_min_len(4096)
            .map(|(&p, &on)| on.then(|| fixed.sample_clamped(p)))
            .collect(),
    };
    let ok: Vec<bool> = sampled.iter().map(Option::is_some).collect();
    let f: Vec<f64> = sampled.iter().map(|s| s.map_or(0.0, |v| v.0)).collect();
    let e = evaluate(metric, &set.m, &f, &ok, &set.scale);
    let d_u = if grad {
        sampled
            .iter()
            .zip(&e.d_f)
            .map(|(s, &d)| s.map_or([0.0, 0.0], |(_, g)| [d * g[0], d * g[1]]))
            .collect()
    } else {
        Vec::new()
    };
    ImageTerm { value: e.value, d_u, valid: e.valid }
}

/// Where the samples fall on a spline's mesh: per triangle, its samples' Bernstein values
/// and the control points of its patch in Bernstein order.
///
/// The mesh lives in MOVING's pixels, so a sample's barycentric coordinates, and with them
/// its `(d+1)(d+2)/2` Bernstein values `B^d_m(b_i)`, never change while the spline does:
/// they are computed once here (21 values, 168 bytes, per sample at degree 5), and every
/// evaluation of [`SplineSamples::map`] and [`SplineSamples::pull`] is a plain weighted
/// sum. (Recomputing them in every evaluation was its largest cost.)
#[derive(Clone, Debug)]
pub struct SplineSamples {
    /// Per triangle: `(sample indices, Bernstein values)`, the values of the triangle's
    /// `k`-th sample at `k * nb .. (k + 1) * nb`.
    tris: Vec<(Vec<usize>, Vec<f64>)>,
    /// Per triangle: the control point of each Bernstein coefficient ([`multi_indices`] order).
    patch: Vec<Vec<usize>>,
    /// Bernstein values per sample, `(d+1)(d+2)/2`.
    nb: usize,
    /// Samples outside the mesh (they never count).
    pub outside: usize,
    n: usize,
}

impl SplineSamples {
    /// Locates every sample of `set` in `s`'s mesh and computes its Bernstein values.
    pub fn new(s: &Spline, set: &SampleSet) -> SplineSamples {
        let mesh = s.mesh();
        let nt = mesh.num_triangles();
        let mut located: Vec<(Vec<usize>, Vec<[f64; 3]>)> = vec![(Vec::new(), Vec::new()); nt];
        let mut outside = 0;
        let mut hint = None;
        for (i, &p) in set.pos.iter().enumerate() {
            match mesh.locate(p, hint) {
                Some((t, b)) => {
                    hint = Some(t);
                    located[t].0.push(i);
                    located[t].1.push(b);
                }
                None => outside += 1,
            }
        }
        let d = s.degree();
        let mi = multi_indices(d);
        let patch = (0..nt)
            .map(|t| {
                let pp = &s.layout().patches()[t];
                mi.iter().map(|m| pp[local_index(d, m[0], m[1])]).collect()
            })
            .collect();
        let fact = |k: usize| (1..=k).map(|v| v as f64).product::<f64>();
        let coefs: Vec<(f64, [usize; 3])> =
            mi.iter().map(|m| (fact(d) / (fact(m[0]) * fact(m[1]) * fact(m[2])), *m)).collect();
        let nb = coefs.len();
        let tris = located
            .into_par_iter()
            .map(|(idx, bs)| {
                let mut pw = vec![[0.0; 3]; d + 1];
                let mut w = vec![0.0; bs.len() * nb];
                for (b, out) in bs.iter().zip(w.chunks_exact_mut(nb)) {
                    basis(&coefs, *b, &mut pw, out);
                }
                (idx, w)
            })
            .collect();
        SplineSamples { tris, patch, nb, outside, n: set.len() }
    }

    /// `phi(y_i)` for every sample, for control points `pts` (samples outside the mesh get
    /// NaN, which every image reads as outside).
    pub fn map(&self, pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
        let mut u = vec![[f64::NAN; 2]; self.n];
        let nb = self.nb;
        let parts: Vec<Vec<(usize, [f64; 2])>> = self
            .tris
            .par_iter()
            .zip(&self.patch)
            .map(|((idx, ws), patch)| {
                let q: Vec<[f64; 2]> = patch.iter().map(|&p| pts[p]).collect();
                idx.iter()
                    .zip(ws.chunks_exact(nb))
                    .map(|(&i, w)| {
                        let mut v = [0.0; 2];
                        for (wk, qk) in w.iter().zip(&q) {
                            v[0] += wk * qk[0];
                            v[1] += wk * qk[1];
                        }
                        (i, v)
                    })
                    .collect()
            })
            .collect();
        for part in parts {
            for (i, v) in part {
                u[i] = v;
            }
        }
        u
    }

    /// `sum_i B_m(b_i)^2 v_i` per control point and coordinate (the Gauss-Newton diagonal
    /// of a term whose Hessian in `u_i` is `diag(v_i)`).
    pub fn pull_squared(&self, v: &[[f64; 2]], n_points: usize) -> Vec<[f64; 2]> {
        let mut out = vec![[0.0; 2]; n_points];
        for ((idx, ws), patch) in self.tris.iter().zip(&self.patch) {
            for (&i, w) in idx.iter().zip(ws.chunks_exact(self.nb)) {
                for (wk, &p) in w.iter().zip(patch) {
                    out[p][0] += wk * wk * v[i][0];
                    out[p][1] += wk * wk * v[i][1];
                }
            }
        }
        out
    }

    /// `dE/dq_m = sum_i B_m(b_i) dE/du_i`, over all control points (`n_points` entries).
    pub fn pull(&self, d_u: &[[f64; 2]], n_points: usize) -> Vec<[f64; 2]> {
        let nb = self.nb;
        let local: Vec<Vec<[f64; 2]>> = self
            .tris
            .par_iter()
            .map(|(idx, ws)| {
                let mut g = vec![[0.0; 2]; nb];
                for (&i, w) in idx.iter().zip(ws.chunks_exact(nb)) {
                    let d = d_u[i];
                    if d == [0.0, 0.0] {
                        continue;
                    }
                    for (gk, wk) in g.iter_mut().zip(w) {
                        gk[0] += wk * d[0];
                        gk[1] += wk * d[1];
                    }
                }
                g
            })
            .collect();
        let mut out = vec![[0.0; 2]; n_points];
        for (g, patch) in local.iter().zip(&self.patch) {
            for (gk, &p) in g.iter().zip(patch) {
                out[p][0] += gk[0];
                out[p][1] += gk[1];
            }
        }
        out
    }
}

/// Bernstein values `B^d_m(b)` into `out`, one per entry of `coefs` (`multinomial(m)` and
/// `m`), with `pw` (`d + 1` rows) holding the powers `b_j^k`.
#[inline]
fn basis(coefs: &[(f64, [usize; 3])], b: [f64; 3], pw: &mut [[f64; 3]], out: &mut [f64]) {
    for (k, row) in pw.iter_mut().enumerate() {
        *row = [b[0].powi(k as i32), b[1].powi(k as i32), b[2].powi(k as i32)];
    }
    for (o, (c, m)) in out.iter_mut().zip(coefs) {
        *o = c * pw[m[0]][0] * pw[m[1]][1] * pw[m[2]][2];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Mesh, MeshOptions};

    #[test]
    fn mapped_samples_agree_with_the_spline_and_pull_is_the_transpose() {
        let mesh = Mesh::grid(2, 2, 20.0, 20.0, MeshOptions::default()).unwrap();
        let s = Spline::identity(mesh, 5).unwrap();
        let pos = vec![[1.0, 2.0], [13.5, 7.25], [19.0, 19.0], [25.0, 3.0]];
        let set = SampleSet {
            m: vec![0.0; 4],
            pos: pos.clone(),
            scale: Scale { var_m: 1.0, m_range: (0.0, 1.0), f_range: (0.0, 1.0) },
        };
        let ss = SplineSamples::new(&s, &set);
        assert_eq!(ss.outside, 1);
        let pts: Vec<[f64; 2]> = (0..s.num_points())
            .map(|p| {
                let v = s.point_f64(p);
                [v[0] + 0.01 * v[1] * v[1], v[1] - 0.02 * v[0]]
            })
            .collect();
        let u = ss.map(&pts);
        for (i, p) in pos.iter().enumerate().take(3) {
            let (t, b) = s.mesh().locate(*p, None).unwrap();
            let row = crate::fit::basis::value_row(&s, t, b);
            let e = row
                .iter()
                .fold([0.0, 0.0], |a, &(j, w)| [a[0] + w * pts[j][0], a[1] + w * pts[j][1]]);
            assert!((e[0] - u[i][0]).abs() < 1e-9 && (e[1] - u[i][1]).abs() < 1e-9);
        }
        assert!(u[3][0].is_nan());
        // <pull(d), q> = <d, map(q)> for the linear map q -> u.
        let d = vec![[0.3, -0.2], [1.0, 0.5], [-0.7, 0.1], [0.0, 0.0]];
        let g = ss.pull(&d, s.num_points());
        let lhs: f64 = g.iter().zip(&pts).map(|(a, b)| a[0] * b[0] + a[1] * b[1]).sum();
        let rhs: f64 = d.iter().zip(&u).take(3).map(|(a, b)| a[0] * b[0] + a[1] * b[1]).sum();
        assert!((lhs - rhs).abs() < 1e-9 * (1.0 + rhs.abs()));
    }

    /// The bug behind an early stop of L-BFGS (`Membership`): a sample crossing FIXED's
    /// border switched its term on at once, and the cost jumped. With the run's membership
    /// kept, the cost is continuous across the border and its gradient matches finite
    /// differences there.
    #[test]
    fn a_sample_crossing_the_border_does_not_make_the_cost_jump() {
        use super::super::image::{Channel, Level};
        let (w, h) = (24usize, 20usize);
        // A textured image whose border column differs from the sample's own value.
        let data: Vec<f32> = (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f32, (k / w) as f32);
                0.5 + 0.3 * (0.7 * x).sin() * (0.5 * y).cos()
            })
            .collect();
        let fixed = Level { image: Channel { w, h, data }, mask: None, level: 0 };
        let pos: Vec<[f64; 2]> =
            (0..60).map(|k| [1.0 + (k % 10) as f64 * 2.0, 1.0 + (k / 10) as f64 * 3.0]).collect();
        let m: Vec<f64> = pos.iter().map(|p| fixed.sample_full(*p).unwrap().0 + 0.01).collect();
        let set = SampleSet {
            m,
            pos: pos.clone(),
            scale: Scale { var_m: 0.02, m_range: (0.2, 0.8), f_range: (0.2, 0.8) },
        };
        // Sample 0 maps to just inside the left border, then just outside it.
        let at = |x0: f64| {
            let mut u = pos.clone();
            u[0] = [x0, 5.0];
            u
        };
        let (inside, outside) = (at(-0.5 + 1e-9), at(-0.5 - 1e-9));
        let keep = membership(&fixed, &inside);
        assert!(keep[0] && !membership(&fixed, &outside)[0]);
        for metric in [Metric::Ssd, Metric::Ncc, Metric::Mi] {
            let hard = |u: &[[f64; 2]]| image_term(metric, &fixed, &set, u, false, None).value;
            let kept = |u: &[[f64; 2]]| image_term(metric, &fixed, &set, u, true, Some(&keep));
            // Without the membership the cost jumps as the sample leaves.
            assert!((hard(&inside) - hard(&outside)).abs() > 1e-4, "{metric:?}");
            // With it the cost is continuous, and the sample keeps counting outside.
            let (a, b) = (kept(&inside), kept(&outside));
            assert!((a.value - b.value).abs() < 1e-7, "{metric:?}: {} vs {}", a.value, b.value);
            assert_eq!((a.valid, b.valid), (60, 60));
            // Its gradient inside the image matches finite differences.
            let (hx, x0) = (1e-6, 2.3);
            let g = kept(&at(x0)).d_u[0][0];
            let num = (kept(&at(x0 + hx)).value - kept(&at(x0 - hx)).value) / (2.0 * hx);
            assert!((g - num).abs() < 1e-5 * (1.0 + num.abs()), "{metric:?}: {g} vs {num}");
        }
    }
}

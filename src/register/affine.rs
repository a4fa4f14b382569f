//! The pre-alignment: an affine (or translation) map from the images alone, before the
//! spline stage, as elastix runs an affine stage before its B-spline stage.
//!
//! The map is `A(y) = c + R (t + (I + B) (y - c) / R)` with `c` MOVING's centre and `R` half
//! its diagonal, over the six numbers `theta = (B_11, B_12, B_21, B_22, t_1, t_2)`. Scaled
//! this way every parameter moves the image by about `R theta` pixels, so the problem is
//! well conditioned for L-BFGS. It starts at `B = 0` and `t = (c_F - c) / R`: the two
//! images' centres on each other (elastix's geometric-centre initialization). The metric
//! is minimized coarse to fine over the pyramid ([`crate::fit::optim::minimize`], argmin's
//! L-BFGS); `dE/dtheta = sum_i dE/du_i du_i/dtheta` with `du/dB_jk = (y - c)_k e_j` and
//! `du/dt_j = R e_j`.

use super::image::Level;
use super::metric::Metric;
use super::samples::{image_term, SampleOptions, SampleSet};
use super::{LevelReport, Progress};
use crate::fit::optim::{minimize, MinimizeOptions};
use serde::Serialize;
use std::time::Instant;

/// Which pre-alignment runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Prealign {
    /// Six parameters.
    Affine,
    /// Translation only.
    Translation,
    /// None: the spline starts at the identity (or at `--init`).
    None,
}

impl std::str::FromStr for Prealign {
    type Err = String;
    fn from_str(s: &str) -> Result<Prealign, String> {
        match s {
            "affine" => Ok(Prealign::Affine),
            "translation" => Ok(Prealign::Translation),
            "none" => Ok(Prealign::None),
            other => {
                Err(format!("unknown pre-alignment `{other}` (use affine, translation or none)"))
            }
        }
    }
}

/// The pre-alignment's parameterization (module docs).
#[derive(Clone, Copy, Debug)]
pub struct AffineFrame {
    c: [f64; 2],
    r: f64,
}

impl AffineFrame {
    /// The frame of a moving image of `w x h` pixels.
    pub fn new(w: usize, h: usize) -> AffineFrame {
        let c = [0.5 * (w as f64 - 1.0), 0.5 * (h as f64 - 1.0)];
        AffineFrame { c, r: 0.5 * (w as f64).hypot(h as f64) }
    }

    /// The start: centres on each other (fixed image `fw x fh`).
    pub fn start(&self, fw: usize, fh: usize) -> [f64; 6] {
        let cf = [0.5 * (fw as f64 - 1.0), 0.5 * (fh as f64 - 1.0)];
        [0.0, 0.0, 0.0, 0.0, (cf[0] - self.c[0]) / self.r, (cf[1] - self.c[1]) / self.r]
    }

    /// `A(y)`.
    #[inline]
    pub fn apply(&self, th: &[f64; 6], y: [f64; 2]) -> [f64; 2] {
        let d = [y[0] - self.c[0], y[1] - self.c[1]];
        [
            self.c[0] + self.r * th[4] + (1.0 + th[0]) * d[0] + th[1] * d[1],
            self.c[1] + self.r * th[5] + th[2] * d[0] + (1.0 + th[3]) * d[1],
        ]
    }

    /// `A` as `[[a, b, c], [d, e, f]]`, `A(x, y) = (a x + b y + c, d x + e y + f)`.
    pub fn matrix(&self, th: &[f64; 6]) -> [[f64; 3]; 2] {
        let m = [[1.0 + th[0], th[1]], [th[2], 1.0 + th[3]]];
        let o = self.apply(th, [0.0, 0.0]);
        [[m[0][0], m[0][1], o[0]], [m[1][0], m[1][1], o[1]]]
    }

    /// `dE/dtheta` from `dE/du_i` at the samples `y_i`.
    fn pull(&self, pos: &[[f64; 2]], d_u: &[[f64; 2]]) -> [f64; 6] {
        let mut g = [0.0; 6];
        for (y, d) in pos.iter().zip(d_u) {
            let e = [y[0] - self.c[0], y[1] - self.c[1]];
            g[0] += d[0] * e[0];
            g[1] += d[0] * e[1];
            g[2] += d[1] * e[0];
            g[3] += d[1] * e[1];
            g[4] += d[0] * self.r;
            g[5] += d[1] * self.r;
        }
        g
    }
}

/// The samples per level of the pre-alignment (it has six unknowns).
const AFFINE_SAMPLES: usize = 1 << 14;

/// Runs the pre-alignment over the pyramids (coarsest level first); returns `theta` and a
/// report per level.
#[allow(clippy::too_many_arguments)]
pub fn prealign(
    kind: Prealign,
    metric: Metric,
    fixed: &[Level],
    moving: &[Level],
    frame: &AffineFrame,
    max_iters: u64,
    (progress, cancel): (Option<&Progress>, &crate::cancel::Cancel),
) -> ([f64; 6], Vec<LevelReport>) {
    let mut th = frame.start(fixed[0].image.w, fixed[0].image.h);
    let mut reports = Vec::new();
    if kind == Prealign::None {
        return (th, reports);
    }
    // The finest level adds little to six parameters: levels 1 and up when there are.
    let finest = usize::from(fixed.len() > 1);
    for l in (finest..fixed.len()).rev() {
        let t0 = Instant::now();
        let set =
            SampleSet::new(&moving[l], &fixed[l], SampleOptions { max_samples: AFFINE_SAMPLES });
        let free: &[usize] = if kind == Prealign::Affine { &[0, 1, 2, 3, 4, 5] } else { &[4, 5] };
        let base = th;
        let full = |x: &[f64]| {
            let mut t = base;
            for (k, &i) in free.iter().enumerate() {
                t[i] = x[k];
            }
            t
        };
        let eval = |x: &[f64]| {
            let t = full(x);
            let u: Vec<[f64; 2]> = set.pos.iter().map(|&y| frame.apply(&t, y)).collect();
            let term = image_term(metric, &fixed[l], &set, &u, true, None);
            if term.valid == 0 {
                return (f64::INFINITY, vec![0.0; x.len()]);
            }
            let g = frame.pull(&set.pos, &term.d_u);
            (term.value, free.iter().map(|&i| g[i]).collect())
        };
        let x0: Vec<f64> = free.iter().map(|&i| th[i]).collect();
        let before = eval(&x0).0;
        let cb = progress.map(|p| {
            let p = p.clone();
            let stage = format!("affine level {l}");
            std::sync::Arc::new(move |it: u64, c: f64| p(&stage, it, c))
                as crate::fit::optim::Progress
        });
        // A first step of about 2 coarse pixels (theta moves the image by R theta).
        let first_step = Some(2.0 * (1u64 << l) as f64 / frame.r);
        let opts =
            MinimizeOptions { max_iters, tol_grad: 1e-9, tol_cost: 1e-10, memory: 6, first_step };
        let m = minimize(&eval, x0, &opts, cb, cancel);
        th = full(&m.x);
        reports.push(LevelReport {
            stage: "affine".into(),
            level: l as u32,
            samples: set.len(),
            variables: free.len(),
            iterations: m.iterations,
            evaluations: m.evaluations,
            termination: m.termination,
            metric_before: before,
            metric_after: m.cost,
            time_ms: t0.elapsed().as_secs_f64() * 1e3,
            triangles: None,
        });
    }
    (th, reports)
}

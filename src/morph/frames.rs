//! Rendering a morph's frames (both maps' certified inverse plans, resampling, dissolve)
//! and certifying their maps (see the parent module for the maps and the blends).

use super::job::{source, Job};
use super::{exact, frame_times_exact, FrameStats, Morph, MorphError};
use crate::exact::matrix::{rat_to_f64, Rat};
use crate::spline::Spline;
use crate::warp::remap::{CurvatureBounds, RemapPlan};
use image::{DynamicImage, ImageBuffer};
use rayon::prelude::*;
use serde::Serialize;

impl Morph {
    /// The frame at time `t` (any real `t`; `0` is `A`, `1` is `B`), of `A`'s size and the
    /// working type.
    pub fn frame(&self, t: f64) -> Result<DynamicImage, MorphError> {
        self.frame_exact(&exact(t)?)
    }

    /// [`Morph::frame`] at an exact `t` (`alpha_shape` is evaluated exactly).
    pub fn frame_exact(&self, t: &Rat) -> Result<DynamicImage, MorphError> {
        Ok(self.frame_with_stats(t)?.0)
    }

    /// [`Morph::frame_exact`] with its [`FrameStats`].
    pub fn frame_with_stats(&self, t: &Rat) -> Result<(DynamicImage, FrameStats), MorphError> {
        super::check_background(self.opts.background, &self.a, &self.a)?;
        let (_, c) = self.weights(rat_to_f64(t))?;
        let s = self.opts.shape.at_exact(t);
        let (w, h) = (self.a.width(), self.a.height());
        let (sa, sb) = self.frame_maps(&s)?;
        let ro = self.opts.remap;
        let [ca, cb] = self.curvature.get_or_init(|| {
            let (ca, cb) = rayon::join(
                || CurvatureBounds::new(&self.phi_ab),
                || CurvatureBounds::new(&self.phi_ba),
            );
            [ca, cb]
        });
        let sf = rat_to_f64(&s);
        // Both plans even at c = 0 or 1: each image fills in where the other has no pixels.
        let (pa, pb) = rayon::join(
            || Some(RemapPlan::new_scaled(&sa, w, h, ro, ca, sf)),
            || Some(RemapPlan::new_scaled(&sb, w, h, ro, cb, 1.0 - sf)),
        );
        let job = Job {
            pa: pa.as_ref(),
            pb: pb.as_ref(),
            c: c as f32,
            interp: self.opts.interp,
            bg: self.opts.background,
            mode: self.opts.mode,
            w: w as usize,
            h: h as usize,
            band_rows: ro.band_rows.max(1) as usize,
        };
        macro_rules! go {
            ($v:ident) => {{
                let (DynamicImage::$v(x), DynamicImage::$v(y)) = (&self.a, &self.b) else {
                    unreachable!("both images have the working type")
                };
                let nc = self.a.color().channel_count() as usize;
                let (out, st) = job.run(
                    source(x.as_raw(), x.width(), x.height(), nc),
                    source(y.as_raw(), y.width(), y.height(), nc),
                );
                (DynamicImage::$v(ImageBuffer::from_raw(w, h, out).expect("sizes match")), st)
            }};
        }
        Ok(match &self.a {
            DynamicImage::ImageLuma8(_) => go!(ImageLuma8),
            DynamicImage::ImageLumaA8(_) => go!(ImageLumaA8),
            DynamicImage::ImageRgb8(_) => go!(ImageRgb8),
            DynamicImage::ImageRgba8(_) => go!(ImageRgba8),
            DynamicImage::ImageLuma16(_) => go!(ImageLuma16),
            DynamicImage::ImageLumaA16(_) => go!(ImageLumaA16),
            DynamicImage::ImageRgb16(_) => go!(ImageRgb16),
            DynamicImage::ImageRgba16(_) => go!(ImageRgba16),
            DynamicImage::ImageRgb32F(_) => go!(ImageRgb32F),
            _ => go!(ImageRgba32F),
        })
    }

    /// Frames at `t = k / (n - 1)`, `k = 0 .. n`, in parallel; `progress` is called once per
    /// finished frame (from any thread).
    pub fn frames(
        &self,
        n: usize,
        progress: &(dyn Fn() + Sync),
    ) -> Result<Vec<DynamicImage>, MorphError> {
        if n < 2 {
            return Err(MorphError::Frames(n));
        }
        self.frames_at(&frame_times_exact(n), progress)
    }

    /// Frames at the given exact times (for caricatures: times outside `[0, 1]`), in
    /// parallel; `progress` is called once per finished frame.
    pub fn frames_at(
        &self,
        times: &[Rat],
        progress: &(dyn Fn() + Sync),
    ) -> Result<Vec<DynamicImage>, MorphError> {
        times
            .par_iter()
            .map(|t| {
                let f = self.frame_exact(t);
                progress();
                f
            })
            .collect()
    }

    /// One certificate for every frame with shape weight `s` in `[0, 1]`
    /// ([`crate::spline::trace`]): `phi_{A->t} = (1 - s) id + s phi_ab` folds for no such `s`
    /// when `det J > 0` is certified for `phi_ab` and `tr J > 0` on its whole domain, and
    /// `phi_{B->t} = s S + (1 - s) phi_ba` when `det J > 0` for `phi_ba` and
    /// `tr(K^T J) > 0`, `K` the linear part of `S`. Returns the two verdicts; `false` only
    /// means "not proven this way" (check the frames one by one with
    /// [`Morph::check_frame`]).
    pub fn certify_blends(&self) -> [bool; 2] {
        use crate::spline::jacobian::{certify, CertifyOptions, RAT_ROUNDING};
        use crate::spline::trace::certify_trace;
        let [a, b, _, _] = self.sim.coefficients();
        let kt = [[a, b], [-b, a]];
        let one = |sp: &Spline, m: [[f64; 2]; 2]| {
            certify(sp, &CertifyOptions::default()).fold_free && certify_trace(sp, m, RAT_ROUNDING)
        };
        let (fa, fb) =
            rayon::join(|| one(&self.phi_ab, [[1.0, 0.0], [0.0, 1.0]]), || one(&self.phi_ba, kt));
        [fa, fb]
    }

    /// The certificates of frame `t`'s two maps: `det J > 0` proven on the whole domain
    /// ([`crate::spline::jacobian::certify`]) and `A`'s frame proven covered
    /// ([`crate::fit::frame::covers_frame`]), for `phi_{A->t}` and `phi_{B->t}`.
    pub fn check_frame(&self, t: &Rat) -> Result<FrameCheck, MorphError> {
        use crate::spline::jacobian::{certify, CertifyOptions};
        let s = self.opts.shape.at_exact(t);
        let (sa, sb) = self.frame_maps(&s)?;
        let (w, h) = (f64::from(self.a.width()), f64::from(self.a.height()));
        let one = |sp: &Spline| {
            let d = certify(sp, &CertifyOptions::default());
            let c = crate::fit::frame::covers_frame(sp, [-0.5, -0.5], [w - 0.5, h - 0.5]);
            (d.fold_free, d.lower_bound, c)
        };
        let ((fa, la, ca), (fb, lb, cb)) = rayon::join(|| one(&sa), || one(&sb));
        Ok(FrameCheck { fold_free: [fa, fb], det_j_lower_bound: [la, lb], covers_frame: [ca, cb] })
    }
}

/// What [`Morph::check_frame`] proves for `phi_{A->t}` and `phi_{B->t}` (in that order).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FrameCheck {
    /// `det J > 0` certified on the map's whole domain.
    pub fold_free: [bool; 2],
    /// The certified lower bounds of `det J`.
    pub det_j_lower_bound: [f64; 2],
    /// The map is proven to cover `A`'s frame.
    pub covers_frame: [bool; 2],
}

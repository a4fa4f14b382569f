//! One morph frame's resampling: both images pulled back through their plans and
//! cross-dissolved, in parallel bands of rows (see the parent module for the math).
//!
//! Where both preimages exist the frame is `(1 - c) A(phi_{A->t}^-1 q) + c B(phi_{B->t}^-1 q)`.
//! A preimage may lie in the fit's margin, outside its image's pixels
//! `[-0.5, w - 0.5] x [-0.5, h - 0.5]` (sampling clamps to the edge there). Such a pixel
//! shows the other image alone when that one's preimage is on real pixels, and the dissolve
//! of the edge-clamped samples only when neither is: a smaller `B` then shows `A` around it
//! instead of smeared edge pixels, and no pixel shows the background.

use super::FrameStats;
use crate::warp::remap::RemapPlan;
use crate::warp::sample::{self, Source, Texel};
use crate::warp::Interp;
use rayon::prelude::*;

/// One frame's resampling: both plans and the blend.
pub(super) struct Job<'p, 's> {
    pub(super) pa: Option<&'p RemapPlan<'s>>,
    pub(super) pb: Option<&'p RemapPlan<'s>>,
    pub(super) c: f32,
    pub(super) interp: Interp,
    pub(super) bg: f64,
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) band_rows: usize,
}

pub(super) fn source<T>(data: &[T], w: u32, h: u32, nc: usize) -> Source<'_, T> {
    Source { data, w: w as usize, h: h as usize, nc }
}

fn fill<T: Texel>(src: &Source<'_, T>, pos: &[[f64; 2]], out: &mut [T], interp: Interp, bg: f64) {
    match src.nc {
        1 => sample::fill_pixels::<T, 1>(src, pos, out, interp, bg),
        2 => sample::fill_pixels::<T, 2>(src, pos, out, interp, bg),
        3 => sample::fill_pixels::<T, 3>(src, pos, out, interp, bg),
        _ => sample::fill_pixels::<T, 4>(src, pos, out, interp, bg),
    }
}

/// `[w - 0.5, h - 0.5]`: the far corner of an image's pixel rectangle.
fn rect<T>(s: &Source<'_, T>) -> [f64; 2] {
    [s.w as f64 - 0.5, s.h as f64 - 0.5]
}

/// Whether `q` lies on the image's pixels `[-0.5, w - 0.5] x [-0.5, h - 0.5]`.
fn within(q: [f64; 2], r: [f64; 2]) -> bool {
    q[0] >= -0.5 && q[1] >= -0.5 && q[0] <= r[0] && q[1] <= r[1]
}

impl Job<'_, '_> {
    /// The frame's samples and its statistics (uncovered pixels, Newton solves).
    pub(super) fn run<T: Texel + Default>(
        &self,
        a: Source<'_, T>,
        b: Source<'_, T>,
    ) -> (Vec<T>, FrameStats) {
        let nc = a.nc;
        let band_px = self.band_rows * self.w;
        let mut out = vec![T::default(); self.w * self.h * nc];
        let (uncovered, newton_solves) = out
            .par_chunks_mut(band_px * nc)
            .enumerate()
            .map_init(
                || {
                    (
                        vec![[0.0f64; 2]; band_px],
                        vec![[0.0f64; 2]; band_px],
                        vec![T::default(); band_px * nc],
                    )
                },
                |(pos_a, pos_b, tmp), (band, dst)| {
                    let n = dst.len() / nc;
                    let (mut has_a, mut has_b) = (false, false);
                    let mut newton = 0;
                    if let Some(p) = self.pa {
                        newton += p.fill_band(band, pos_a).newton_solves;
                        fill(&a, &pos_a[..n], dst, self.interp, self.bg);
                        has_a = true;
                    }
                    if let Some(p) = self.pb {
                        newton += p.fill_band(band, pos_b).newton_solves;
                        let tmp = &mut tmp[..n * nc];
                        fill(&b, &pos_b[..n], tmp, self.interp, self.bg);
                        has_b = true;
                        if !has_a {
                            dst.copy_from_slice(tmp);
                        } else {
                            let c = self.c;
                            let (ra, rb) = (rect(&a), rect(&b));
                            for i in 0..n {
                                let (qa, qb) = (pos_a[i], pos_b[i]);
                                let (va, vb) = (!qa[0].is_nan(), !qb[0].is_nan());
                                let (ina, inb) = (va && within(qa, ra), vb && within(qb, rb));
                                // Prefer real pixels to edge-clamped ones (module docs).
                                let (ua, ub) = if ina || inb { (ina, inb) } else { (va, vb) };
                                let px = &mut dst[i * nc..(i + 1) * nc];
                                let pb = &tmp[i * nc..(i + 1) * nc];
                                match (ua, ub) {
                                    (true, true) => {
                                        for (o, v) in px.iter_mut().zip(pb) {
                                            *o = T::from_f32(
                                                (1.0 - c) * o.to_f32() + c * v.to_f32(),
                                            );
                                        }
                                    }
                                    (false, true) => px.copy_from_slice(pb),
                                    _ => {}
                                }
                            }
                        }
                    }
                    debug_assert!(has_a || has_b);
                    let uncovered = (0..n)
                        .filter(|&i| {
                            (!has_a || pos_a[i][0].is_nan()) && (!has_b || pos_b[i][0].is_nan())
                        })
                        .count();
                    (uncovered, newton)
                },
            )
            .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1));
        (out, FrameStats { uncovered, newton_solves, pixels: self.w * self.h })
    }
}

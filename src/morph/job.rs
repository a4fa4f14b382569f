//! One morph frame's resampling: both images pulled back through their plans and
//! cross-dissolved, in parallel bands of rows (see the parent module for the math).
//!
//! Where both preimages exist the frame is `(1 - c) A(phi_{A->t}^-1 q) + c B(phi_{B->t}^-1 q)`.
//! A preimage may lie in the fit's margin, outside its image's pixels
//! `[-0.5, w - 0.5] x [-0.5, h - 0.5]`. Such a pixel shows the other image alone when that
//! one's preimage is on real pixels: a smaller `B` then shows `A` around it instead of
//! smeared edge pixels. Where neither preimage is on its image's pixels, the frame shows
//! what the edge mode says ([`crate::warp::edge`]): the background with alpha 0
//! ([`EdgeMode::Constant`], the default, as a warp does), the dissolve of the edge-clamped
//! samples ([`EdgeMode::Edge`]) or of the mirrored ones ([`EdgeMode::Reflect`]). A frame
//! made from one image only (`t = 0` or `1`) samples it in that mode.
//!
//! **Feathering.** Switching from the dissolve to one image where the other's preimage leaves
//! its pixels would leave a seam: the two images' values differ there (the two halfway maps
//! are not the same map), so the frame would step along the curve where the preimage crosses
//! the image border. Each image therefore gets a coverage weight
//!
//! ```text
//!   f(p) = smoothstep(min(1, d(p) / F)),   smoothstep(u) = 3u^2 - 2u^3,
//! ```
//!
//! `d(p)` the distance (in that image's pixels) from the preimage `p` to the image's border,
//! `F` = [`FEATHER_PX`] (at most a quarter of the image's smaller side), and the frame is the
//! normalized blend
//!
//! ```text
//!   ((1 - c) f_A A + c f_B B) / ((1 - c) f_A + c f_B),
//! ```
//!
//! which is the plain dissolve wherever both preimages are `F` or more inside their images
//! (`f_A = f_B = 1`: the same arithmetic, the same values), moves smoothly (C1 in `d`) to one
//! image as the other's preimage approaches its border, and equals the hard switch beyond it.
//! For colour weights outside `[0, 1]` (caricature ranges) the normalization could divide by
//! numbers near 0, so those frames keep the hard switch.

use super::FrameStats;
use crate::warp::edge::sample_mode;
use crate::warp::fill;
use crate::warp::remap::RemapPlan;
use crate::warp::sample::{Source, Texel};
use crate::warp::{EdgeMode, Interp};
use rayon::prelude::*;

/// One frame's resampling: both plans and the blend.
pub(super) struct Job<'p, 's> {
    pub(super) pa: Option<&'p RemapPlan<'s>>,
    pub(super) pb: Option<&'p RemapPlan<'s>>,
    pub(super) c: f32,
    pub(super) interp: Interp,
    pub(super) bg: f64,
    pub(super) mode: EdgeMode,
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) band_rows: usize,
}

pub(super) fn source<T>(data: &[T], w: u32, h: u32, nc: usize) -> Source<'_, T> {
    Source { data, w: w as usize, h: h as usize, nc }
}

/// The background pixel: `bg` in every colour channel, alpha 0.
fn background<T: Texel>(px: &mut [T], bg: f64) {
    let nc = px.len();
    for (c, o) in px.iter_mut().enumerate() {
        *o = T::from_f32(if (nc == 2 || nc == 4) && c == nc - 1 { 0.0 } else { bg as f32 });
    }
}

/// `[w - 0.5, h - 0.5]`: the far corner of an image's pixel rectangle.
fn rect<T>(s: &Source<'_, T>) -> [f64; 2] {
    [s.w as f64 - 0.5, s.h as f64 - 0.5]
}

/// Width (source pixels) of the band inside each image's border over which its weight in
/// the dissolve falls smoothly to 0 (module docs: **Feathering**).
pub const FEATHER_PX: f64 = 8.0;

/// The feather width of a `w x h` image: [`FEATHER_PX`], at most a quarter of its smaller side.
fn feather_width(w: usize, h: usize) -> f64 {
    FEATHER_PX.min(w.min(h) as f64 / 4.0).max(0.5)
}

/// The coverage weight of the module docs for a preimage at depth `d` ([`depth`]) with
/// feather width `f`, for an output pixel `e` from the frame's edge (the band is never wider
/// than `e`): 0 outside the image or for a missing preimage, 1 from `min(f, e)` inside.
fn coverage(d: f64, f: f64, e: f64) -> f32 {
    if d.is_nan() || d <= 0.0 {
        return 0.0;
    }
    let u = (d / f.min(e)).min(1.0);
    (u * u * (3.0 - 2.0 * u)) as f32
}

/// Distance (pixels) from `q` inside the pixel rectangle `[-0.5, r]` to its border
/// (negative outside, NaN for a missing preimage).
fn depth(q: [f64; 2], r: [f64; 2]) -> f64 {
    (q[0] + 0.5).min(q[1] + 0.5).min(r[0] - q[0]).min(r[1] - q[1])
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
                    let mut outside = 0;
                    let both = self.pa.is_some() && self.pb.is_some();
                    // With both images, each is sampled edge-clamped and the dissolve below
                    // decides; one image alone is sampled in the edge mode.
                    let one = if both { EdgeMode::Edge } else { self.mode };
                    if let Some(p) = self.pa {
                        newton += p.fill_band(band, pos_a).newton_solves;
                        fill(&a, &pos_a[..n], dst, self.interp, self.bg, one);
                        has_a = true;
                    }
                    if let Some(p) = self.pb {
                        newton += p.fill_band(band, pos_b).newton_solves;
                        let tmp = &mut tmp[..n * nc];
                        fill(&b, &pos_b[..n], tmp, self.interp, self.bg, one);
                        has_b = true;
                        if !has_a {
                            dst.copy_from_slice(tmp);
                        } else {
                            let c = self.c;
                            let (ra, rb) = (rect(&a), rect(&b));
                            let (fwa, fwb) = (feather_width(a.w, a.h), feather_width(b.w, b.h));
                            let feather = (0.0..=1.0).contains(&c);
                            for i in 0..n {
                                let (qa, qb) = (pos_a[i], pos_b[i]);
                                let px = &mut dst[i * nc..(i + 1) * nc];
                                let pb = &tmp[i * nc..(i + 1) * nc];
                                let (da, db) = (depth(qa, ra), depth(qb, rb));
                                // Most pixels are deep inside both images: the plain dissolve
                                // below, without the weights.
                                let edge = !(da >= fwa && db >= fwb);
                                if feather && edge && da > 0.0 && db > 0.0 {
                                    let x = (i % self.w) as f64;
                                    let y = (band * self.band_rows + i / self.w) as f64;
                                    let e = (x + 0.5)
                                        .min(y + 0.5)
                                        .min(self.w as f64 - 0.5 - x)
                                        .min(self.h as f64 - 0.5 - y);
                                    let (ka, kb) = (coverage(da, fwa, e), coverage(db, fwb, e));
                                    // Normalized feathered dissolve (module docs).
                                    let (wa, wb) = ((1.0 - c) * ka, c * kb);
                                    let sum = wa + wb;
                                    for (o, v) in px.iter_mut().zip(pb) {
                                        *o = T::from_f32((wa * o.to_f32() + wb * v.to_f32()) / sum);
                                    }
                                    continue;
                                }
                                let (va, vb) = (!qa[0].is_nan(), !qb[0].is_nan());
                                // On the image's pixels (a NaN depth compares false).
                                let (ina, inb) = (da >= 0.0, db >= 0.0);
                                // Neither preimage on its image's pixels: the edge mode
                                // (module docs; `Edge` is the dissolve below).
                                if !(ina || inb) && (va || vb) {
                                    match self.mode {
                                        EdgeMode::Constant => {
                                            background(px, self.bg);
                                            outside += 1;
                                            continue;
                                        }
                                        EdgeMode::Reflect => {
                                            let (i, m, g) = (self.interp, self.mode, self.bg);
                                            let mut sb = [T::from_f32(0.0); 4];
                                            let sb = &mut sb[..nc];
                                            if va {
                                                sample_mode(&a, qa, i, m, g, px);
                                            }
                                            if vb {
                                                sample_mode(&b, qb, i, m, g, sb);
                                            }
                                            match (va, vb) {
                                                (true, true) => {
                                                    for (o, v) in px.iter_mut().zip(sb.iter()) {
                                                        *o = T::from_f32(
                                                            (1.0 - c) * o.to_f32() + c * v.to_f32(),
                                                        );
                                                    }
                                                }
                                                (false, true) => px.copy_from_slice(sb),
                                                _ => {}
                                            }
                                            continue;
                                        }
                                        EdgeMode::Edge => {}
                                    }
                                }
                                // Prefer real pixels to edge-clamped ones (module docs).
                                let (ua, ub) = if ina || inb { (ina, inb) } else { (va, vb) };
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
                    (uncovered + outside, newton)
                },
            )
            .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1));
        (out, FrameStats { uncovered, newton_solves, pixels: self.w * self.h })
    }
}

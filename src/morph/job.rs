//! One morph frame's resampling: both images pulled back through their plans and
//! cross-dissolved, in parallel bands of rows (see the parent module for the math).

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

impl Job<'_, '_> {
    pub(super) fn run<T: Texel + Default>(&self, a: Source<'_, T>, b: Source<'_, T>) -> Vec<T> {
        let nc = a.nc;
        let band_px = self.band_rows * self.w;
        let mut out = vec![T::default(); self.w * self.h * nc];
        out.par_chunks_mut(band_px * nc).enumerate().for_each_init(
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
                if let Some(p) = self.pa {
                    p.fill_band(band, pos_a);
                    fill(&a, &pos_a[..n], dst, self.interp, self.bg);
                    has_a = true;
                }
                if let Some(p) = self.pb {
                    p.fill_band(band, pos_b);
                    let tmp = &mut tmp[..n * nc];
                    fill(&b, &pos_b[..n], tmp, self.interp, self.bg);
                    has_b = true;
                    if !has_a {
                        dst.copy_from_slice(tmp);
                    } else {
                        let c = self.c;
                        for i in 0..n {
                            let (ina, inb) = (!pos_a[i][0].is_nan(), !pos_b[i][0].is_nan());
                            let px = &mut dst[i * nc..(i + 1) * nc];
                            let pb = &tmp[i * nc..(i + 1) * nc];
                            match (ina, inb) {
                                (true, true) => {
                                    for (o, v) in px.iter_mut().zip(pb) {
                                        *o = T::from_f32((1.0 - c) * o.to_f32() + c * v.to_f32());
                                    }
                                }
                                (false, true) => px.copy_from_slice(pb),
                                _ => {}
                            }
                        }
                    }
                }
                debug_assert!(has_a || has_b);
            },
        );
        out
    }
}

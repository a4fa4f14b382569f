//! Filling an output rectangle from a plan's pieces (see the parent module): rasterize
//! every piece that reaches the rectangle, in lattice order, then solve the pixels left
//! around border and unbounded pieces by Newton's method.

use super::geometry::{bbox, clip_box};
use super::raster::{raster, Gap};
use super::{BandScratch, Rect, RemapPlan, RemapStats};
use crate::warp::sample::fast_floor;

impl RemapPlan<'_> {
    /// The preimages of the pixel centres of the output rectangle `rect` into `out`
    /// (row-major, `rect.w` per row; `[NaN, NaN]` where there is none), marking in `folds`
    /// (same layout) the pixels drawn from folded pieces; `scratch` holds the work buffers
    /// from call to call.
    ///
    /// Each pixel's preimage is a function of the pixel and the plan's pieces alone (the
    /// rasterized value does not depend on the rectangle, see [`raster`], and Newton's
    /// fallback does not seed from a neighbour), so rectangles that tile the output give
    /// exactly what one pass over it gives, and a plan made by [`RemapPlan::new_window`]
    /// gives, inside its window, exactly what the whole plan gives.
    pub fn fill_rect(
        &self,
        rect: Rect,
        out: &mut [[f64; 2]],
        folds: Option<&mut [bool]>,
        scratch: &mut BandScratch,
    ) -> RemapStats {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (detected just above).
            return unsafe { self.fill_rect_avx2(rect, out, folds, scratch) };
        }
        self.fill_rect_any(rect, out, folds, scratch)
    }

    /// [`RemapPlan::fill_rect`] compiled for AVX2: the same operations (Rust never fuses
    /// or reorders floating-point operations, whatever the target features), so the same
    /// values, with the rasterizer's pixel loop on 256-bit registers.
    ///
    /// # Safety
    ///
    /// The CPU supports AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn fill_rect_avx2(
        &self,
        rect: Rect,
        out: &mut [[f64; 2]],
        folds: Option<&mut [bool]>,
        scratch: &mut BandScratch,
    ) -> RemapStats {
        self.fill_rect_any(rect, out, folds, scratch)
    }

    #[inline(always)]
    pub(super) fn fill_rect_any(
        &self,
        rect: Rect,
        out: &mut [[f64; 2]],
        folds: Option<&mut [bool]>,
        scratch: &mut BandScratch,
    ) -> RemapStats {
        let w = self.w as usize;
        let rows_total = self.h as usize;
        let (x0, y0) = (rect.x0 as usize, rect.y0 as usize);
        let (ww, rows) = (rect.w as usize, rect.h as usize);
        assert!(
            x0 + ww <= w && y0 + rows <= rows_total,
            "rectangle {rect:?} outside the {w}x{rows_total} output"
        );
        let out = &mut out[..rows * ww];
        // All bits set is a NaN (exponent all ones, mantissa non-zero), and a byte fill
        // runs at memset speed where the pair `[NAN, NAN]` is a 16-byte pattern loop.
        bytemuck::cast_slice_mut::<[f64; 2], u8>(out).fill(0xFF);
        let mut st = RemapStats::default();
        let (ylo, yhi) = (y0 as f64 - 1.0, (y0 + rows) as f64 + 1.0);
        // Blocks whose image misses the rectangle by more than a gap width (at most half a
        // pixel, `MAX_GAP`) draw nothing in it: skipped before their squares are looked at.
        let (xlo, xhi) = (x0 as f64 - 1.0, (x0 + ww) as f64 + 1.0);
        let BandScratch { near, mask, tried, gaps } = scratch;
        gaps.clear();
        near.clear();
        near.extend(
            self.rows
                .iter()
                .enumerate()
                .filter(|(_, r)| r.y[1] >= ylo && r.y[0] <= yhi)
                .map(|r| r.0),
        );
        let near = &*near;
        // Which pixels the last piece drawn there is folded (only when there are folds).
        let any_fold = near.iter().any(|&j| self.rows[j].folded);
        let mut mask = any_fold.then(|| {
            mask.clear();
            mask.resize(rows * ww, false);
            &mut mask[..]
        });
        for r in near.iter().map(|&j| &self.rows[j]) {
            for b in &r.blocks {
                if b.y[1] < ylo || b.y[0] > yhi || b.x[1] < xlo || b.x[0] > xhi {
                    continue;
                }
                let n = b.k + 1;
                let mut written = 0;
                for j in 0..b.k {
                    let py = b.p0[1] + j as f64 * b.step[1];
                    for i in 0..b.k {
                        let o = b.off + j * n + i;
                        let qq = [r.pool[o], r.pool[o + 1], r.pool[o + n], r.pool[o + n + 1]];
                        let (qlo, qhi) = (
                            qq.iter().map(|v| v[1]).fold(f64::INFINITY, f64::min),
                            qq.iter().map(|v| v[1]).fold(f64::NEG_INFINITY, f64::max),
                        );
                        if qhi < ylo || qlo > yhi {
                            continue;
                        }
                        // No pixel centre in the sub-rectangle's image (both halves are
                        // inside its bounding box): nothing to draw.
                        let (xlo, xhi) = (
                            qq.iter().map(|v| v[0]).fold(f64::INFINITY, f64::min),
                            qq.iter().map(|v| v[0]).fold(f64::NEG_INFINITY, f64::max),
                        );
                        let m = b.gap + 1e-7;
                        if fast_floor(xhi + m) < xlo - m || fast_floor(qhi + m) < qlo - m {
                            continue;
                        }
                        let px = b.p0[0] + i as f64 * b.step[0];
                        let pp = [
                            [px, py],
                            [px + b.step[0], py],
                            [px, py + b.step[1]],
                            [px + b.step[0], py + b.step[1]],
                        ];
                        // Edges opposite each vertex of the halves (0, 1, 3) and (0, 3, 2):
                        // right, diagonal, top; bottom, left, diagonal. Only the block's outer
                        // edges can meet a neighbour of another size (the inner ones share
                        // the block's grid points), so only they are searched for gaps.
                        // Edges shared with a whole neighbour block cannot leave a gap
                        // (`mark_conforming`).
                        let [cl, cr, ct, cb] = b.conform;
                        let (l, r, t, bo) = (
                            i == 0 && !cl,
                            i + 1 == b.k && !cr,
                            j == 0 && !ct,
                            j + 1 == b.k && !cb,
                        );
                        for (h, edges) in [([0, 1, 3], [r, false, t]), ([0, 3, 2], [bo, l, false])]
                        {
                            written += raster(
                                &h.map(|c| pp[c]),
                                &h.map(|c| qq[c]),
                                out,
                                rect,
                                w,
                                mask.as_deref_mut().map(|m| (m, b.folded)),
                                edges.contains(&true).then_some(Gap {
                                    width: b.gap,
                                    edges,
                                    found: &mut *gaps,
                                }),
                            );
                        }
                    }
                }
                if b.folded {
                    if written > 0 {
                        let (lo, hi) = bbox(&r.pool[b.off..b.off + n * n]);
                        st.merge(&RemapStats {
                            fold_box: Some(clip_box(lo, hi, w, rows_total)),
                            ..Default::default()
                        });
                    }
                } else if written > 0 {
                    st.max_error_bound = st.max_error_bound.max(b.bound);
                }
            }
            for t in &r.tris {
                if t.y[1] < ylo || t.y[0] > yhi {
                    continue;
                }
                let written = raster(
                    &t.p,
                    &t.q,
                    out,
                    rect,
                    w,
                    mask.as_deref_mut().map(|m| (m, t.folded)),
                    Some(Gap { width: t.gap, edges: t.outer, found: &mut *gaps }),
                );
                if t.folded {
                    if written > 0 {
                        let (lo, hi) = bbox(&t.q);
                        st.merge(&RemapStats {
                            fold_box: Some(clip_box(lo, hi, w, rows_total)),
                            ..Default::default()
                        });
                    }
                } else if written > 0 {
                    st.max_error_bound = st.max_error_bound.max(t.bound);
                }
            }
        }
        // Newton for the unfilled pixels of compressed pieces and near border pieces (each
        // pixel tried once). Compressed pieces first: their seeds are certified close
        // ([`super::refine::SEED_BOUND`]), a border piece's may be far from a pixel in its box.
        let boxes = || {
            near.iter()
                .flat_map(|&j| &self.rows[j].newton)
                .filter(|b| b.r[3] >= ylo && b.r[1] <= yhi)
        };
        tried.clear();
        if boxes().next().is_some() {
            tried.resize(rows * ww, false);
        }
        let ordered = boxes().filter(|b| b.compressed).chain(boxes().filter(|b| !b.compressed));
        for b in ordered {
            let r = b.r;
            let ya = r[1].ceil().max(y0 as f64) as usize;
            let yb = (r[3].floor() as isize).min((y0 + rows) as isize - 1);
            let xa = r[0].ceil().max(x0 as f64) as usize;
            let xb = (r[2].floor() as isize).min((x0 + ww) as isize - 1);
            for y in ya as isize..=yb {
                let y = y as usize;
                for x in xa as isize..=xb {
                    let k = (y - y0) * ww + x as usize - x0;
                    let o = &mut out[k];
                    if !o[0].is_nan() || tried[k] {
                        continue;
                    }
                    tried[k] = true;
                    let q = [x as f64, y as f64];
                    let seeded = self.map.invert_from(q, b.seed.at(q), b.seed.tri);
                    if seeded.is_some() {
                        st.newton_seeded += 1;
                        st.newton_compressed += usize::from(b.compressed);
                        if b.folded {
                            // Reversed throughout: the preimage near the seed is on the fold.
                            if let Some(m) = mask.as_deref_mut() {
                                m[k] = true;
                            }
                            let c = clip_box(q, q, w, rows_total);
                            st.merge(&RemapStats { fold_box: Some(c), ..Default::default() });
                        }
                    }
                    match seeded.or_else(|| self.map.invert_from_buckets(q)) {
                        Some(pm) => {
                            *o = pm.p;
                            st.newton_solves += 1;
                            st.max_error_bound = st.max_error_bound.max(pm.error_bound);
                        }
                        None => st.newton_failed += 1,
                    }
                }
            }
        }
        // Pixels in the thin gaps that T-junctions leave between pieces (a square split
        // finer than its neighbour), within a gap width of a piece and still without a
        // value: Newton from that piece's affine inverse, the first piece in lattice order
        // (so the seed is the pixel's and the plan's alone). No other seeds: the seed is
        // within about the tolerance of a preimage if there is one.
        if !gaps.is_empty() && tried.is_empty() {
            tried.resize(rows * ww, false);
        }
        for &(k, seed) in gaps.iter() {
            let k = k as usize;
            if !out[k][0].is_nan() || tried[k] {
                continue;
            }
            tried[k] = true;
            let q = [(x0 + k % ww) as f64, (y0 + k / ww) as f64];
            match self.map.invert_from(q, seed, None) {
                Some(pm) => {
                    out[k] = pm.p;
                    st.newton_solves += 1;
                    st.newton_seeded += 1;
                    st.newton_gaps += 1;
                    st.max_error_bound = st.max_error_bound.max(pm.error_bound);
                }
                None => st.newton_failed += 1,
            }
        }
        st.folded = mask.as_ref().map_or(0, |m| m.iter().filter(|&&f| f).count());
        if let Some(f) = folds {
            match &mask {
                Some(m) => f[..rows * ww].copy_from_slice(m),
                None => f[..rows * ww].fill(false),
            }
        }
        st.outside = count_nan(out);
        st.pixels = rows * ww;
        st.interpolated = rows * ww - st.outside - st.newton_solves;
        st
    }
}

/// The number of positions without a value (`x` NaN), eight at a time, the comparisons
/// summed branch-free.
fn count_nan(out: &[[f64; 2]]) -> usize {
    let mut chunks = out.chunks_exact(8);
    let mut n = 0usize;
    for c in &mut chunks {
        let mut k = 0u32;
        for p in c {
            k += u32::from(p[0].is_nan());
        }
        n += k as usize;
    }
    n + chunks.remainder().iter().filter(|p| p[0].is_nan()).count()
}

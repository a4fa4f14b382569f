//! Rasterizing one lattice triangle's image into a band of output rows: every covered pixel
//! centre gets the preimage under the triangle's affine map (see the parent module).

use super::geometry::bbox;
use super::Rect;
use crate::warp::sample::fast_floor;

#[inline(always)]
fn fast_ceil(x: f64) -> f64 {
    -fast_floor(-x)
}

/// Rasterizes the image `q` of the reference triangle `p` into the window `win` of the
/// output (`out`: `win.h` rows of `win.w` pixels, row-major; the whole output is `w` pixels
/// wide): each covered pixel centre of the window gets `L^-1(q)`. Returns the number of
/// pixels written.
///
/// A pixel's value does not depend on the window: the covered span of each row is found
/// with the whole output's clipping, and the value at column `x` is `start + (x - x0) px`
/// from the span's first column `x0`, whatever part of the span the window keeps. So
/// windows that tile the output get exactly the values of one whole-output pass.
#[inline(always)]
pub(super) fn raster(
    p: &[[f64; 2]; 3],
    q: &[[f64; 2]; 3],
    out: &mut [[f64; 2]],
    win: Rect,
    w: usize,
    mut fold_mask: Option<(&mut [bool], bool)>,
    gap: Option<Gap<'_>>,
) -> usize {
    let (wx0, wy0, ww) = (win.x0 as usize, win.y0 as usize, win.w as usize);
    let rows = win.h as usize;
    let wx1 = wx0 + ww; // exclusive
                        // The pixel centres of the bounding box first: most pieces of a finely split block
                        // cover none, and then the setup (a division) is skipped.
    let (lo, hi) = bbox(q);
    // The margin of the gap search: the box grows by it.
    let m = gap.as_ref().map_or(0.0, |g| g.width) + 1e-7;
    let ya = fast_ceil(lo[1] - m).max(wy0 as f64) as usize;
    let yb = (fast_floor(hi[1] + m) as isize).min((wy0 + rows) as isize - 1);
    let xa = fast_ceil(lo[0] - m).max(0.0) as usize;
    let xb = (fast_floor(hi[0] + m) as isize).min(w as isize - 1);
    if yb < ya as isize || xb < xa as isize || xb < wx0 as isize || xa >= wx1 {
        return 0;
    }
    let (e1, e2) = ([q[1][0] - q[0][0], q[1][1] - q[0][1]], [q[2][0] - q[0][0], q[2][1] - q[0][1]]);
    let det = e1[0] * e2[1] - e2[0] * e1[1];
    if det == 0.0 || !det.is_finite() {
        return 0;
    }
    let rdet = 1.0 / det;
    let inv = [[e2[1] * rdet, -e2[0] * rdet], [-e1[1] * rdet, e1[0] * rdet]];
    let (pe1, pe2) =
        ([p[1][0] - p[0][0], p[1][1] - p[0][1]], [p[2][0] - p[0][0], p[2][1] - p[0][1]]);
    // lambda_k(x, y) = c_k + bx_k x + by_k y (lambda_0 = 1 - lambda_1 - lambda_2). Where
    // bx_k != 0, lambda_k >= -eps is the half-line x >= or <= alpha_k + beta_k y, so a row's
    // span costs a few multiply-adds; p(x, y) is affine too.
    let eps = 1e-9;
    let c1 = -inv[0][0] * q[0][0] - inv[0][1] * q[0][1];
    let c2 = -inv[1][0] * q[0][0] - inv[1][1] * q[0][1];
    let c = [1.0 - c1 - c2, c1, c2];
    let bx = [-inv[0][0] - inv[1][0], inv[0][0], inv[1][0]];
    let by = [-inv[0][1] - inv[1][1], inv[0][1], inv[1][1]];
    let (xaf, xbf) = (xa as f64, xb as f64);
    let rb = bx.map(|b| if b == 0.0 { 0.0 } else { 1.0 / b });
    let (lower, upper, flat) = span_lines([xaf, xbf], c, bx, by, rb, [eps; 3]);
    // The gap search's lines: `lambda_k >= -eps - width |grad lambda_k|`, each edge moved
    // out by `width` pixels.
    let grown = gap.as_ref().map(|g| {
        let e = [0, 1, 2].map(|k| {
            if g.edges[k] {
                eps + g.width * (bx[k] * bx[k] + by[k] * by[k]).sqrt()
            } else {
                eps
            }
        });
        span_lines([xaf, xbf], c, bx, by, rb, e)
    });
    // p = p0 + lambda_1 pe1 + lambda_2 pe2 = pc + px x + py y.
    let px = [bx[1] * pe1[0] + bx[2] * pe2[0], bx[1] * pe1[1] + bx[2] * pe2[1]];
    let py = [by[1] * pe1[0] + by[2] * pe2[0], by[1] * pe1[1] + by[2] * pe2[1]];
    let pc = [p[0][0] + c[1] * pe1[0] + c[2] * pe2[0], p[0][1] + c[1] * pe1[1] + c[2] * pe2[1]];
    let mut written = 0;
    let mut gap = gap;
    for y in ya..=yb as usize {
        let yf = y as f64;
        let span = row_span(&lower, &upper, &flat, [xaf, xbf], yf, eps);
        if let (Some(g), Some((lo, up, fl))) = (gap.as_mut(), grown.as_ref()) {
            // Pixels of the grown span, outside the triangle's own, still without a value.
            if let Some((g0, g1)) = row_span(lo, up, fl, [xaf, xbf], yf, eps) {
                // The grown span minus the own one: a few pixels at either end.
                let (a, b) = match span {
                    Some((x0, x1)) => (g0..x0.min(g1 + 1), (x1 + 1).max(g0)..g1 + 1),
                    None => (g0..g1 + 1, 0..0),
                };
                let row = (y - wy0) * ww;
                for x in a.chain(b) {
                    if x < wx0 || x >= wx1 || !out[row + x - wx0][0].is_nan() {
                        continue;
                    }
                    let xf = x as f64;
                    let seed = [pc[0] + py[0] * yf + px[0] * xf, pc[1] + py[1] * yf + px[1] * xf];
                    g.found.push(((row + x - wx0) as u32, seed));
                }
            }
        }
        let Some((x0, x1)) = span else { continue };
        // The window's part of the span [x0, x1].
        let (xs, xe) = (x0.max(wx0), x1.min(wx1 - 1));
        if xe < xs {
            continue;
        }
        let row = &mut out[(y - wy0) * ww..(y - wy0 + 1) * ww];
        let start =
            [pc[0] + py[0] * yf + px[0] * x0 as f64, pc[1] + py[1] * yf + px[1] * x0 as f64];
        // The offsets from `x0` convert to `f64` exactly either way; through `i32` (below
        // 2^31, every real image) in one instruction where `usize` takes a sequence.
        let seg = row[xs - wx0..=xe - wx0].iter_mut();
        if xe - x0 <= i32::MAX as usize {
            for (k, o) in (xs - x0..).zip(seg) {
                let kf = f64::from(k as i32);
                *o = [start[0] + kf * px[0], start[1] + kf * px[1]];
            }
        } else {
            for (k, o) in (xs - x0..).zip(seg) {
                let kf = k as f64;
                *o = [start[0] + kf * px[0], start[1] + kf * px[1]];
            }
        }
        written += xe + 1 - xs;
        if let Some((mask, folded)) = fold_mask.as_mut() {
            mask[(y - wy0) * ww + xs - wx0..=(y - wy0) * ww + xe - wx0].fill(*folded);
        }
    }
    written
}

/// The lines bounding a triangle's rows: `lambda_k(x, y) = c_k + bx_k x + by_k y >= -e_k`
/// (`rb_k = 1 / bx_k`).
/// Since `sum_k bx_k = 0` and not all `bx_k` vanish, there are at most two lower lines
/// (`x >= a + b y`), two upper lines and one flat line (`c + b y >= -e`); unused slots hold
/// neutral lines (`x >= xa`, `x <= xb`, `0 >= -eps`), so each row costs a fixed, branch-free
/// handful of operations.
type Lines = ([[f64; 2]; 2], [[f64; 2]; 2], [f64; 3]);

#[inline(always)]
fn span_lines(
    x: [f64; 2],
    c: [f64; 3],
    bx: [f64; 3],
    by: [f64; 3],
    rb: [f64; 3],
    e: [f64; 3],
) -> Lines {
    let (mut lower, mut upper, mut flat) = ([[x[0], 0.0]; 2], [[x[1], 0.0]; 2], [0.0f64, 0.0, 0.0]);
    let (mut nl, mut nu) = (0, 0);
    for k in 0..3 {
        if bx[k] == 0.0 {
            flat = [c[k], by[k], e[k]];
        } else {
            let line = [(-e[k] - c[k]) * rb[k], -by[k] * rb[k]];
            if bx[k] > 0.0 {
                lower[nl & 1] = line;
                nl += 1;
            } else {
                upper[nu & 1] = line;
                nu += 1;
            }
        }
    }
    (lower, upper, flat)
}

/// The columns `x0 ..= x1` of row `y` inside the lines (`None`: none).
#[inline(always)]
fn row_span(
    lower: &[[f64; 2]; 2],
    upper: &[[f64; 2]; 2],
    flat: &[f64; 3],
    x: [f64; 2],
    y: f64,
    eps: f64,
) -> Option<(usize, usize)> {
    let lo_x = x[0].max(lower[0][0] + lower[0][1] * y).max(lower[1][0] + lower[1][1] * y);
    let hi_x = x[1].min(upper[0][0] + upper[0][1] * y).min(upper[1][0] + upper[1][1] * y);
    if hi_x < lo_x || flat[0] + flat[1] * y < -flat[2].max(eps) {
        return None;
    }
    // Here `x[0] <= lo_x <= hi_x <= x[1]` (finite, non-negative): ceil and floor straight to
    // integers, the values of `fast_ceil` and `fast_floor` without their float round trip.
    let (t0, t1) = (lo_x as i64, hi_x as i64);
    let (x0, x1) = (t0 + i64::from((t0 as f64) < lo_x), t1 - i64::from((t1 as f64) > hi_x));
    (x1 >= x0).then_some((x0 as usize, x1 as usize))
}

/// The gap search of [`raster`]: the pixels within `width` output pixels of the
/// triangle's image across the edges `edges` (edge `k` is the one opposite vertex `k`),
/// outside the triangle and still without a preimage, with the triangle's affine inverse
/// there (Newton's seed), as `(index in the window, seed)`.
pub(super) struct Gap<'a> {
    pub width: f64,
    pub edges: [bool; 3],
    pub found: &'a mut Vec<(u32, [f64; 2])>,
}

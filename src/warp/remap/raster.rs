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
#[inline]
pub(super) fn raster(
    p: &[[f64; 2]; 3],
    q: &[[f64; 2]; 3],
    out: &mut [[f64; 2]],
    win: Rect,
    w: usize,
    mut fold_mask: Option<(&mut [bool], bool)>,
) -> usize {
    let (wx0, wy0, ww) = (win.x0 as usize, win.y0 as usize, win.w as usize);
    let rows = win.h as usize;
    let wx1 = wx0 + ww; // exclusive
                        // The pixel centres of the bounding box first: most pieces of a finely split block
                        // cover none, and then the setup (a division) is skipped.
    let (lo, hi) = bbox(q);
    let ya = fast_ceil(lo[1] - 1e-7).max(wy0 as f64) as usize;
    let yb = (fast_floor(hi[1] + 1e-7) as isize).min((wy0 + rows) as isize - 1);
    let xa = fast_ceil(lo[0] - 1e-7).max(0.0) as usize;
    let xb = (fast_floor(hi[0] + 1e-7) as isize).min(w as isize - 1);
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
    // Since sum_k bx_k = 0 and not all bx_k vanish, there are at most two lower lines, two
    // upper lines and one flat line; unused slots hold neutral lines (x >= xa, x <= xb,
    // 0 >= -eps), so each row costs a fixed, branch-free handful of operations.
    let (xaf, xbf) = (xa as f64, xb as f64);
    let (mut lower, mut upper, mut flat) = ([[xaf, 0.0]; 2], [[xbf, 0.0]; 2], [0.0f64, 0.0]);
    let (mut nl, mut nu) = (0, 0);
    for k in 0..3 {
        if bx[k] == 0.0 {
            flat = [c[k], by[k]];
        } else {
            let rb = 1.0 / bx[k];
            let line = [(-eps - c[k]) * rb, -by[k] * rb];
            if bx[k] > 0.0 {
                lower[nl & 1] = line;
                nl += 1;
            } else {
                upper[nu & 1] = line;
                nu += 1;
            }
        }
    }
    // p = p0 + lambda_1 pe1 + lambda_2 pe2 = pc + px x + py y.
    let px = [bx[1] * pe1[0] + bx[2] * pe2[0], bx[1] * pe1[1] + bx[2] * pe2[1]];
    let py = [by[1] * pe1[0] + by[2] * pe2[0], by[1] * pe1[1] + by[2] * pe2[1]];
    let pc = [p[0][0] + c[1] * pe1[0] + c[2] * pe2[0], p[0][1] + c[1] * pe1[1] + c[2] * pe2[1]];
    let mut written = 0;
    for y in ya..=yb as usize {
        let yf = y as f64;
        let lo_x = xaf.max(lower[0][0] + lower[0][1] * yf).max(lower[1][0] + lower[1][1] * yf);
        let hi_x = xbf.min(upper[0][0] + upper[0][1] * yf).min(upper[1][0] + upper[1][1] * yf);
        if hi_x < lo_x || flat[0] + flat[1] * yf < -eps {
            continue;
        }
        let (x0, x1) = (fast_ceil(lo_x), fast_floor(hi_x));
        if x1 < x0 {
            continue;
        }
        let (x0, x1) = (x0 as usize, x1 as usize);
        // The window's part of the span [x0, x1].
        let (xs, xe) = (x0.max(wx0), x1.min(wx1 - 1));
        if xe < xs {
            continue;
        }
        let row = &mut out[(y - wy0) * ww..(y - wy0 + 1) * ww];
        let start =
            [pc[0] + py[0] * yf + px[0] * x0 as f64, pc[1] + py[1] * yf + px[1] * x0 as f64];
        for (k, o) in (xs - x0..).zip(row[xs - wx0..=xe - wx0].iter_mut()) {
            let kf = k as f64;
            *o = [start[0] + kf * px[0], start[1] + kf * px[1]];
        }
        written += xe + 1 - xs;
        if let Some((mask, folded)) = fold_mask.as_mut() {
            mask[(y - wy0) * ww + xs - wx0..=(y - wy0) * ww + xe - wx0].fill(*folded);
        }
    }
    written
}

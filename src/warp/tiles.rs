//! Warping an image tile by tile, each tile reading only the input its preimages need: the
//! building block of out-of-core and distributed warps (the Python package's
//! `trimorph.dask.warp` runs one task per output tile).
//!
//! **Map direction.** As everywhere in [`crate::warp`]: the output is `O(q) = I(phi^-1(q))`,
//! input and output of one size `W x H`, pixel `(i, j)` at the point `(i, j)`.
//!
//! **Which input a tile needs.** Let `R` be the box of a tile's pixel centres. On a mesh
//! triangle `T` the map is a Bezier patch with `|J| <= L_T`
//! ([`EvalCache::jacobian_bound`](crate::spline::eval::EvalCache::jacobian_bound); `L` the
//! largest over the mesh). Cut `T` into `k^2` pieces (the `k`-fold subdivision, about
//! [`TilePlanner::with_resolution`]'s resolution across): every point of a piece `tau` is
//! within `rho` of one of its corners (`rho` its circumradius when no angle is obtuse,
//! else its diameter), so `phi(tau)` lies in the box of its corners' images grown by
//! `L_T rho`, and inside the box `C_T` of
//! the triangle's control points (convex hull property;
//! [`EvalCache::patch_bbox`](crate::spline::eval::EvalCache::patch_bbox)). With `D(R, e)`
//! the union of the reference boxes of the pieces whose image box and whose `C_T` both come
//! within `e` of `R`:
//!
//! * a pixel solved by Newton's method has `|phi(p) - q|` far below a pixel, so `p` lies in
//!   `D(R, 1)`;
//! * a pixel drawn from a lattice piece with an error bound has `|phi(p~) - q| <= sqrt 2 L
//!   tol` (the bound of [`super::remap`] with `|A^-1|^-1 <= sqrt 2 L`), so `p~` lies in
//!   `D(R, sqrt 2 L tol + 1)`;
//! * a pixel drawn from a folded piece without a bound (a square of side at most 1 px
//!   across a crease) lies in the piece's image, whose corners are within `sqrt 2 L` of it,
//!   and `p~` lies in the piece, within `sqrt 2` of a corner: in `D(R, sqrt 2 L + 1)` grown
//!   by `sqrt 2`.
//!
//! So the tile reads `D(R, L (sqrt 2 + 2 tol) + 1)` grown by `sqrt 2 + tol` and by
//! [`READ_MARGIN`] (the interpolation kernel), clipped to the image:
//! [`TilePlanner::input_rect`]. The lattice squares whose pieces can reach `R` meet
//! `D(R, sqrt 2 L c + 2 L + 2)` (`c` the lattice cell: a piece's image has a diameter of at
//! most `sqrt 2 L c`; a Newton box reaches 1 px beyond its piece's image):
//! [`TilePlanner::lattice_window`]. These bounds use straight segments inside the mesh,
//! so they hold for convex meshes (Delaunay meshes are); on other meshes a tile depends on
//! the whole input.
//!
//! **Bit-identity.** A tile's plan ([`RemapPlan::new_window`]) has exactly the whole plan's
//! pieces for the squares it covers, and a pixel's preimage is a function of the pixel and
//! those pieces ([`RemapPlan::fill_rect`]); sampling a window at `p - origin` (an exact
//! subtraction) with the interpolation margin inside the window takes the same taps and the
//! same arithmetic as sampling the whole image at `p`. So [`warp_tile_into`] writes exactly
//! the pixels [`super::warp_samples_into`] writes for the whole image. It checks the margin
//! on every preimage and fails with [`TileError::Window`] rather than return other values.

use super::remap::reach::{lattice_reach, triangle_part, Part};
use super::remap::{mesh_is_convex, BandScratch, RemapOptions, RemapPlan};
use super::sample::{fast_floor, Source};
use super::{fill, EdgeMode, LayoutError, Samples, SamplesMut, WarpError, WarpOptions, WarpReport};
use crate::spline::Spline;
use rayon::prelude::*;

pub use super::remap::Rect;

/// Pixels of input kept around a tile's preimages: bicubic reads from `floor(x) - 1` to
/// `floor(x) + 2`, and bilinear's interior test looks at `floor(x) + 1`; one more pixel
/// keeps both away from the window's edge.
pub const READ_MARGIN: f64 = 3.0;

/// Errors of [`warp_tile_into`].
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TileError {
    /// A rectangle is not inside the image.
    #[error("{what} {rect:?} is not inside the {width}x{height} image")]
    Outside {
        /// `tile` or `window`.
        what: &'static str,
        /// The rectangle.
        rect: Rect,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// A preimage needs input outside the window given (the window must contain
    /// [`TilePlanner::input_rect`] of the tile).
    #[error(
        "the preimage ({x}, {y}) of output pixel ({px}, {py}) needs input outside the window \
         {window:?} (give at least TilePlanner::input_rect of the tile)"
    )]
    Window {
        /// Output column.
        px: u32,
        /// Output row.
        py: u32,
        /// Preimage x.
        x: f64,
        /// Preimage y.
        y: f64,
        /// The window given.
        window: Rect,
    },
}

/// A piece of a mesh triangle (one of the `k^2` triangles of its `k`-fold subdivision):
/// a box containing its image, and its reference box.
#[derive(Clone, Copy, Debug)]
struct Piece {
    /// A box containing the piece's image: its corners' images grown by `L_T rho`.
    q: ([f64; 2], [f64; 2]),
    dom: ([f64; 2], [f64; 2]),
    /// The whole triangle's image box (its control points').
    img: ([f64; 2], [f64; 2]),
}

/// Which input and which lattice squares each output tile of a `W x H` warp needs (see the
/// module docs for the bounds).
#[derive(Clone, Debug)]
pub struct TilePlanner {
    size: (u32, u32),
    pieces: Vec<Piece>,
    /// Bound on `|J|` over the mesh.
    lip: f64,
    cell: f64,
    tol: f64,
    convex: bool,
}

/// Union of boxes.
fn grow(acc: &mut Option<([f64; 2], [f64; 2])>, b: ([f64; 2], [f64; 2])) {
    let (lo, hi) = acc.get_or_insert(b);
    for a in 0..2 {
        lo[a] = lo[a].min(b.0[a]);
        hi[a] = hi[a].max(b.1[a]);
    }
}

/// Default resolution of a planner (reference pixels per piece side).
pub const RESOLUTION: f64 = 32.0;

impl TilePlanner {
    /// The planner of `s` for a `size = (W, H)` image warped with `opts`, at the default
    /// [`RESOLUTION`].
    pub fn new(s: &Spline, size: (u32, u32), opts: &RemapOptions) -> TilePlanner {
        TilePlanner::with_resolution(s, size, opts, RESOLUTION)
    }

    /// The planner with mesh triangles cut into pieces about `resolution` reference pixels
    /// across: the input a tile needs is found to within about a piece (times the
    /// stretching), and planning evaluates `phi` about `2 A / resolution^2` times for a
    /// mesh of area `A`. A tenth of the tile side is a good choice.
    ///
    /// A piece's image lies in its corners' images grown by `L_T rho` (`L_T` the triangle's
    /// [`jacobian_bound`](crate::spline::eval::EvalCache::jacobian_bound), the segments from
    /// the corners stay in the triangle); a tile needs the piece only if that box comes
    /// within the reach of the module docs of the tile.
    pub fn with_resolution(
        s: &Spline,
        size: (u32, u32),
        opts: &RemapOptions,
        resolution: f64,
    ) -> TilePlanner {
        TilePlanner::build(s, size, opts, resolution, None)
    }

    /// [`TilePlanner::with_resolution`] for the tiles inside `region` only (other tiles
    /// must not be asked): triangles whose image box is far from the region are skipped,
    /// so one tile's planner costs what the triangles near it cost.
    pub fn near(
        s: &Spline,
        size: (u32, u32),
        opts: &RemapOptions,
        resolution: f64,
        region: Rect,
    ) -> TilePlanner {
        TilePlanner::build(s, size, opts, resolution, Some(region))
    }

    fn build(
        s: &Spline,
        size: (u32, u32),
        opts: &RemapOptions,
        resolution: f64,
        region: Option<Rect>,
    ) -> TilePlanner {
        let m = s.mesh();
        let cache = s.eval_cache();
        let res = if resolution.is_finite() && resolution >= 1.0 { resolution } else { RESOLUTION };
        let cell = opts.lattice_cell();
        let bounds: Vec<f64> = (0..m.num_triangles()).map(|t| cache.jacobian_bound(t)).collect();
        let lip = bounds.iter().copied().fold(0.0, f64::max);
        let convex = mesh_is_convex(m);
        // The largest reach a query uses (the lattice window's), for skipping triangles.
        let reach = lattice_reach(lip, cell) + 1.0;
        // The pixel centres planned for: the region's, or the whole output's.
        let target = match region {
            Some(r) => (
                [r.x0 as f64, r.y0 as f64],
                [(r.x0 + r.w.max(1)) as f64 - 1.0, (r.y0 + r.h.max(1)) as f64 - 1.0],
            ),
            None => ([0.0, 0.0], [size.0.max(1) as f64 - 1.0, size.1.max(1) as f64 - 1.0]),
        };
        let keep = |img: ([f64; 2], [f64; 2])| match region {
            Some(r) if convex => {
                let (lo, hi) = img;
                lo[0] <= (r.x0 + r.w) as f64 + reach
                    && hi[0] >= r.x0 as f64 - reach
                    && lo[1] <= (r.y0 + r.h) as f64 + reach
                    && hi[1] >= r.y0 as f64 - reach
            }
            _ => true,
        };
        let mut pieces = Vec::new();
        for (t, &lt) in bounds.iter().enumerate() {
            let img = cache.patch_bbox(t);
            if !keep(img) {
                continue;
            }
            let v = m.triangle(t).map(|x| m.vertex(x));
            let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
            let (e0, e1, e2) = (dist(v[1], v[2]), dist(v[0], v[2]), dist(v[0], v[1]));
            let diam = e0.max(e1).max(e2);
            // Every point of a triangle is within `rho` of a corner: the circumradius when
            // no angle is obtuse (the circumcentre is the farthest point), else the diameter.
            let sq = [e0 * e0, e1 * e1, e2 * e2];
            let obtuse = sq[0] > sq[1] + sq[2] || sq[1] > sq[0] + sq[2] || sq[2] > sq[0] + sq[1];
            let area2 = ((v[1][0] - v[0][0]) * (v[2][1] - v[0][1])
                - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]))
                .abs();
            let rho = if obtuse || area2 == 0.0 {
                diam
            } else {
                (e0 * e1 * e2 / (2.0 * area2)).min(diam)
            };
            let k = ((diam / res).ceil() as usize).clamp(1, 4096);
            let kf = k as f64;
            // Pieces `(i, j)` of the k-fold subdivision: the point `v0 + (i e1 + j e2) / k`
            // with `e1 = v1 - v0`, `e2 = v2 - v0`. On a convex mesh only those meeting the
            // part of the triangle that can map near the planned region are made (far-field
            // ring triangles are thousands of pieces across, of which a frame needs a strip).
            let (mut ia, mut ib, mut ja, mut jb) = (0usize, k, 0usize, k);
            if convex {
                match triangle_part(s, t, target, reach + 1.0) {
                    Part::Outside => continue,
                    Part::Unbounded => {}
                    Part::Box(lo, hi) => {
                        let (e1, e2) = (
                            [v[1][0] - v[0][0], v[1][1] - v[0][1]],
                            [v[2][0] - v[0][0], v[2][1] - v[0][1]],
                        );
                        let det = e1[0] * e2[1] - e2[0] * e1[1];
                        if det != 0.0 && det.is_finite() {
                            let (mut umin, mut umax, mut wmin, mut wmax) = (
                                f64::INFINITY,
                                f64::NEG_INFINITY,
                                f64::INFINITY,
                                f64::NEG_INFINITY,
                            );
                            for c in [lo, [hi[0], lo[1]], [lo[0], hi[1]], hi] {
                                let d = [c[0] - v[0][0], c[1] - v[0][1]];
                                let u = (d[0] * e2[1] - e2[0] * d[1]) / det;
                                let w = (e1[0] * d[1] - d[0] * e1[1]) / det;
                                (umin, umax) = (umin.min(u), umax.max(u));
                                (wmin, wmax) = (wmin.min(w), wmax.max(w));
                            }
                            // One piece of slack on each side for rounding.
                            let idx = |x: f64, up: bool| {
                                let y =
                                    if up { (x * kf).ceil() + 1.0 } else { (x * kf).floor() - 1.0 };
                                y.clamp(0.0, kf) as usize
                            };
                            (ia, ib, ja, jb) = (
                                idx(umin, false),
                                idx(umax, true),
                                idx(wmin, false),
                                idx(wmax, true),
                            );
                        }
                    }
                }
            }
            let at = |i: usize, j: usize| {
                let b = [(k - i - j) as f64 / kf, i as f64 / kf, j as f64 / kf];
                let p = [0, 1].map(|a| b[0] * v[0][a] + b[1] * v[1][a] + b[2] * v[2][a]);
                (p, cache.value(t, b))
            };
            // Pieces are similar to the triangle: `rho / k` for each.
            let r = lt * rho / kf;
            // The corners of the pieces made: `i in ia..=ib`, `j in ja..=jb`, `i + j <= k`.
            let nj = jb + 1 - ja;
            let corners: Vec<Option<([f64; 2], [f64; 2])>> = (ia..=ib)
                .flat_map(|i| (ja..=jb).map(move |j| (i, j)))
                .map(|(i, j)| (i + j <= k).then(|| at(i, j)))
                .collect();
            let corner = |i: usize, j: usize| corners[(i - ia) * nj + j - ja].expect("inside");
            let mut push = |c: [(usize, usize); 3]| {
                let [a, b, c] = c.map(|(i, j)| corner(i, j));
                let lo = [0, 1].map(|x| a.0[x].min(b.0[x]).min(c.0[x]));
                let hi = [0, 1].map(|x| a.0[x].max(b.0[x]).max(c.0[x]));
                let qlo = [0, 1].map(|x| a.1[x].min(b.1[x]).min(c.1[x]) - r);
                let qhi = [0, 1].map(|x| a.1[x].max(b.1[x]).max(c.1[x]) + r);
                pieces.push(Piece { q: (qlo, qhi), dom: (lo, hi), img });
            };
            for i in ia..ib {
                for j in ja..jb.min(k - i) {
                    push([(i, j), (i + 1, j), (i, j + 1)]);
                    if i + j + 2 <= k {
                        push([(i + 1, j), (i, j + 1), (i + 1, j + 1)]);
                    }
                }
            }
        }
        TilePlanner { size, pieces, lip, cell, tol: opts.inverse.tolerance, convex }
    }

    /// The bound `L` on `|J|` over the mesh.
    pub fn jacobian_bound(&self) -> f64 {
        self.lip
    }

    /// `D(R, reach)`: the reference boxes of the triangles whose image box comes within
    /// `reach` of the tile's pixel centres (all triangles on a non-convex mesh).
    fn domain(&self, tile: Rect, reach: f64) -> Option<([f64; 2], [f64; 2])> {
        if tile.is_empty() {
            return None;
        }
        let r_lo = [tile.x0 as f64 - reach, tile.y0 as f64 - reach];
        let r_hi = [(tile.x0 + tile.w - 1) as f64 + reach, (tile.y0 + tile.h - 1) as f64 + reach];
        let mut acc = None;
        for p in &self.pieces {
            let (qlo, qhi) = p.q;
            let meets =
                qlo[0] <= r_hi[0] && qhi[0] >= r_lo[0] && qlo[1] <= r_hi[1] && qhi[1] >= r_lo[1];
            let (lo, hi) = p.img;
            let meets = meets
                && lo[0] <= r_hi[0]
                && hi[0] >= r_lo[0]
                && lo[1] <= r_hi[1]
                && hi[1] >= r_lo[1];
            if meets || !self.convex {
                grow(&mut acc, p.dom);
            }
        }
        acc
    }

    /// The reference box whose lattice squares can draw into `tile` (`None`: none can, the
    /// tile is all background).
    pub fn lattice_window(&self, tile: Rect) -> Option<([f64; 2], [f64; 2])> {
        self.domain(tile, lattice_reach(self.lip, self.cell))
            .map(|(lo, hi)| ([lo[0] - 1.0, lo[1] - 1.0], [hi[0] + 1.0, hi[1] + 1.0]))
    }

    /// The input pixels the warp of `tile` reads in [`EdgeMode::Constant`] (the default),
    /// clipped to the image (`None`: none, the tile is all background).
    pub fn input_rect(&self, tile: Rect) -> Option<Rect> {
        self.input_rect_for(tile, EdgeMode::Constant)
    }

    /// The input pixels the warp of `tile` reads in `mode`, clipped to the image (`None`:
    /// none, the tile is all background). In [`EdgeMode::Edge`] preimages beyond the image
    /// read its edge pixels, so their box is first projected onto the image: a tile whose
    /// preimages all lie beyond one side reads the strip along that side. Reflect is not
    /// planned (see [`warp_tile_into`]); it is treated as constant here.
    pub fn input_rect_for(&self, tile: Rect, mode: EdgeMode) -> Option<Rect> {
        let sq2 = std::f64::consts::SQRT_2;
        let reach = self.lip * (sq2 + 2.0 * self.tol) + 1.0;
        let (mut lo, mut hi) = self.domain(tile, reach)?;
        if mode == EdgeMode::Edge {
            let (wm, hm) = (self.size.0 as f64 - 1.0, self.size.1 as f64 - 1.0);
            lo = [lo[0].clamp(0.0, wm), lo[1].clamp(0.0, hm)];
            hi = [hi[0].clamp(0.0, wm), hi[1].clamp(0.0, hm)];
        }
        let pad = sq2 + self.tol + READ_MARGIN;
        let (w, h) = (self.size.0 as f64, self.size.1 as f64);
        let x0 = (lo[0] - pad).floor().clamp(0.0, w);
        let y0 = (lo[1] - pad).floor().clamp(0.0, h);
        let x1 = ((hi[0] + pad).ceil() + 1.0).clamp(0.0, w);
        let y1 = ((hi[1] + pad).ceil() + 1.0).clamp(0.0, h);
        if x1 <= x0 || y1 <= y0 {
            return None;
        }
        Some(Rect { x0: x0 as u32, y0: y0 as u32, w: (x1 - x0) as u32, h: (y1 - y0) as u32 })
    }

    /// The image size planned for.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }
}

fn inside(r: Rect, (w, h): (u32, u32)) -> bool {
    r.x0 as u64 + r.w as u64 <= w as u64 && r.y0 as u64 + r.h as u64 <= h as u64
}

/// Whether sampling the window at `p - origin` takes the taps sampling the whole image at
/// `p` takes: the kernel's reach stays inside the window wherever the window does not end
/// at the image's edge.
fn in_window(p: [f64; 2], win: Rect, (w, h): (u32, u32)) -> bool {
    let ok = |v: f64, lo: u32, n: u32, full: u32| {
        let f = fast_floor(v);
        (lo == 0 || f - 1.0 >= lo as f64) && (lo + n == full || f + 2.0 < (lo + n) as f64)
    };
    ok(p[0], win.x0, win.w, w) && ok(p[1], win.y0, win.h, h)
}

/// Where a tile and its input window lie in the image, for [`warp_tile_into`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileLayout {
    /// The whole image, `(W, H)` (input and output alike).
    pub size: (u32, u32),
    /// The output pixels to compute.
    pub tile: Rect,
    /// The input pixels given; must contain [`TilePlanner::input_rect`] of the tile.
    pub window: Rect,
    /// Channels per pixel, 1 to 4 (as [`super::Layout::channels`]).
    pub channels: usize,
}

/// Warps the output pixels of `layout.tile` given only the input pixels of
/// `layout.window`: `pages` hold the window's samples (`window.w * window.h * channels`
/// each, interleaved, row-major), `outs` receive the tile's (`tile.w * tile.h * channels`).
/// The result is bit-identical to the tile's pixels in [`super::warp_samples_into`] of the
/// whole image (see the module docs); `opts` must be the same.
pub fn warp_tile_into(
    s: &Spline,
    layout: TileLayout,
    pages: &[Samples<'_>],
    outs: &mut [SamplesMut<'_>],
    opts: &WarpOptions,
) -> Result<WarpReport, WarpError> {
    let TileLayout { size, tile, window, channels } = layout;
    if opts.mode == EdgeMode::Reflect {
        return Err(WarpError::ReflectTiled);
    }
    let nc = channels;
    if !(1..=4).contains(&nc) {
        return Err(LayoutError::Channels(nc).into());
    }
    for (what, rect) in [("tile", tile), ("window", window)] {
        if !inside(rect, size) {
            let (width, height) = size;
            return Err(TileError::Outside { what, rect, width, height }.into());
        }
    }
    let same_types = pages.len() == outs.len()
        && pages.iter().zip(outs.iter()).all(|(p, o)| {
            matches!(
                (p, o),
                (Samples::U8(_), SamplesMut::U8(_))
                    | (Samples::U16(_), SamplesMut::U16(_))
                    | (Samples::F32(_), SamplesMut::F32(_))
            )
        });
    if !same_types {
        return Err(LayoutError::Mismatch { inputs: pages.len(), outputs: outs.len() }.into());
    }
    if let Some(first) = pages.first() {
        super::check_background(opts.background, first)?;
    }
    let lens = pages.iter().map(|p| (p.len(), window)).chain(outs.iter().map(|o| (o.len(), tile)));
    for (index, (found, r)) in lens.enumerate() {
        let expected = r.len() * nc;
        if found != expected {
            let (width, height, channels) = (r.w, r.h, nc);
            return Err(
                LayoutError::Length { index, found, expected, width, height, channels }.into()
            );
        }
    }
    if tile.is_empty() || pages.is_empty() {
        return Ok(WarpReport::default());
    }
    let res = (tile.w.max(tile.h) as f64 / 8.0).max(RESOLUTION);
    let planner = TilePlanner::near(s, size, &opts.remap, res, tile);
    let tw = tile.w as usize;
    let mut pos = vec![[f64::NAN; 2]; tile.len()];
    let mut stats = WarpReport { pixels: tile.len(), outside: tile.len(), ..Default::default() };
    if let Some(lw) = planner.lattice_window(tile) {
        let plan = RemapPlan::new_window(s, size.0, size.1, opts.remap, Some(lw));
        let band = plan.band_rows() as usize;
        stats = pos
            .par_chunks_mut(band * tw)
            .enumerate()
            .map_init(BandScratch::default, |sc, (b, chunk)| {
                let y0 = tile.y0 + (b * band) as u32;
                let rows = (chunk.len() / tw) as u32;
                let r = Rect { x0: tile.x0, y0, w: tile.w, h: rows };
                plan.fill_rect(r, chunk, None, sc)
            })
            .reduce(WarpReport::default, |mut a, b| {
                a.merge(&b);
                a
            });
    }
    // Check the margin, then move the preimages into the window's coordinates (exact:
    // subtracting an integer no larger than a non-negative double).
    let origin = [window.x0 as f64, window.y0 as f64];
    // In the constant mode a preimage all of whose taps lie outside the image (more than
    // two pixels beyond it, the bicubic reach) reads only the background: it needs no input,
    // and `NaN` gives the same pixel (background, alpha 0; `edge::sample_mode`).
    let (fw, fh) = (size.0 as f64, size.1 as f64);
    let beyond = |p: &[f64; 2]| p[0] < -2.0 || p[1] < -2.0 || p[0] > fw + 1.0 || p[1] > fh + 1.0;
    for (k, p) in pos.iter_mut().enumerate() {
        if opts.mode == EdgeMode::Constant && !p[0].is_nan() && beyond(p) {
            *p = [f64::NAN, f64::NAN];
        }
        if p[0].is_nan() {
            continue;
        }
        if !in_window(*p, window, size) {
            let (px, py) = (tile.x0 + (k % tw) as u32, tile.y0 + (k / tw) as u32);
            return Err(TileError::Window { px, py, x: p[0], y: p[1], window }.into());
        }
        *p = [p[0] - origin[0], p[1] - origin[1]];
    }
    let (ww, wh) = (window.w as usize, window.h as usize);
    let (interp, bg, mode) = (opts.interp, opts.background, opts.mode);
    for (page, out) in pages.iter().zip(outs.iter_mut()) {
        let rows = 32usize;
        match (page, out) {
            (Samples::U8(d), SamplesMut::U8(o)) => {
                let src = Source { data: d, w: ww, h: wh, nc };
                o.par_chunks_mut(rows * tw * nc)
                    .zip(pos.par_chunks(rows * tw))
                    .for_each(|(o, p)| fill(&src, p, o, interp, bg, mode));
            }
            (Samples::U16(d), SamplesMut::U16(o)) => {
                let src = Source { data: d, w: ww, h: wh, nc };
                o.par_chunks_mut(rows * tw * nc)
                    .zip(pos.par_chunks(rows * tw))
                    .for_each(|(o, p)| fill(&src, p, o, interp, bg, mode));
            }
            (Samples::F32(d), SamplesMut::F32(o)) => {
                let src = Source { data: d, w: ww, h: wh, nc };
                o.par_chunks_mut(rows * tw * nc)
                    .zip(pos.par_chunks(rows * tw))
                    .for_each(|(o, p)| fill(&src, p, o, interp, bg, mode));
            }
            _ => unreachable!("sample types are checked above"),
        }
    }
    Ok(stats)
}

#[cfg(test)]
mod tests;

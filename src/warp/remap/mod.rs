//! Preimages of every pixel centre of an output image, fast and with an error bound.
//!
//! Solving `phi(p) = q` by Newton at each of 16 million pixels costs seconds. Evaluating
//! `phi` forward is much cheaper, so this module covers the reference domain with a lattice
//! of squares ([`RemapOptions::cell`] pixels, split in two triangles each), maps the
//! lattice forward, and rasterizes the deformed triangles into the output: a pixel centre
//! `q` inside the image `(Q0, Q1, Q2)` of a lattice triangle `(P0, P1, P2)` gets
//! `p~ = sum lambda_i P_i`, with `lambda` the barycentric coordinates of `q` in
//! `(Q0, Q1, Q2)`; that is, `p~ = L^-1(q)` for the affine interpolant `L` of `phi`.
//!
//! **The bound.** For a point `p` of a triangle and `|D^2 phi[u, u]| <= M |u|^2` on it
//! (Taylor with integral remainder; `phi` is C1 and piecewise polynomial, so this holds
//! across mesh edges too):
//!
//! ```text
//!   |phi(p) - L(p)| <= M/2 sum_i lambda_i |P_i - p|^2 <= M R^2 / 2 = M (a^2 + b^2) / 8
//! ```
//!
//! for a right triangle with legs `a, b` (circumradius `R`). With `A` the linear part of
//! `L` and `|J - A| <= M diam` on the triangle, `|J^-1| <= K = |A^-1| / (1 - |A^-1| M diam)`,
//! so `|p~ - phi^-1(q)| <= K M (a^2 + b^2) / 8` (to first order in this tiny defect; reported
//! times [`FIRST_ORDER_SLACK`](crate::warp::inverse::FIRST_ORDER_SLACK), 1.01). A triangle is rasterized when its bound is at most the tolerance (0.01 px by
//! default); otherwise its square is split in four, down to squares of 1 px
//! ([`NEWTON_SIDE`]), whose halves that still miss the bound leave their pixels to Newton's
//! method. `M` comes from
//! [`EvalCache::second_derivative_bounds_uniform`](crate::spline::eval::EvalCache::second_derivative_bounds_uniform)
//! over small sub-triangles, kept in a grid of buckets over the reference domain.
//!
//! The bound also certifies `det J != 0` on the piece (`|J - A| < |A^-1|^-1`), so a piece
//! keeps one orientation throughout: pieces with `det J > 0` everywhere in the output mean
//! `phi` does not fold there.
//!
//! **Borders and folds.** Squares with a corner outside the mesh are split to the smallest
//! size (1 px); the output pixels around such pieces are then solved by Newton
//! ([`InverseMap`]) one by one, as are smallest pieces that still miss the bound. Newton
//! starts from the piece's affine inverse `L^-1(q)` (within a fraction of a pixel of the
//! preimage, so it converges in one or two iterations), then from the forward samples
//! ([`InverseMap::invert_from_buckets`]); never from a neighbouring pixel's preimage, so that
//! a pixel's preimage does not depend on which pixels are computed with it (tiles,
//! [`crate::warp::tiles`]). Pieces with reversed
//! orientation (`det J < 0`) and smallest pieces across a crease (`det J = 0`) are drawn and
//! counted as folded ([`RemapStats::folded`], [`RemapStats::fold_box`]). Where `phi` is not
//! injective a pixel has several preimages and shows the layer rasterized last (lattice
//! order, row by row), or where no rasterized layer covers it, the first one Newton solves
//! (compressed pieces below); never a blend.
//!
//! **Compressed pieces.** The bound's `K` grows where `phi` compresses (`|A^-1|` large), so
//! the legs `a ~ sqrt(8 tol / (K M))` shrink while the image of a piece shrinks as `a / K`:
//! near a fold a block would need ten or more forward evaluations per output pixel. A
//! square whose block would need more than [`DENSE`] (3) per pixel of its image is split
//! without trying the block until its affine inverse is within [`SEED_BOUND`] (0.5 px) of
//! `phi^-1` (and both halves pass the perturbation test, so `det J` has one sign on it);
//! then Newton solves the pixels of its image from that affine inverse, in two or three
//! iterations, before any other Newton box ([`RemapStats::newton_compressed`]). Such a
//! piece shows only where no rasterized piece covers the pixel (the first such piece in
//! lattice order); a reversed one marks its pixels as folded. On the folded test map this
//! more than halves the block points (52,429 to 21,614) and cuts the time by a third.
//!
//! **Gaps.** Squares are refined independently, so a square split finer than its
//! neighbour meets it in a T-junction: along their shared side, the coarse piece's edge is
//! the chord `phi(a) phi(b)` and the fine pieces follow `phi` at more points, and a pixel
//! centre can fall in the sliver between the two polygons (at most `M l^2 / 8` wide, see
//! [`gap_width`]). Every piece is therefore searched, across its outer edges, for pixels
//! within its gap width that no piece covers; those are solved by Newton from the piece's
//! affine inverse ([`RemapStats::newton_gaps`]), so the covered region has no cracks.
//!
//! **Time.** A lattice square of side `c` ([`RemapOptions::cell`], 32 px) is split at most
//! `log2(c)` times, so it yields at most `(4^(log2 c + 1) - 1) / 3 = (4 c^2 - 1) / 3`
//! squares (1,365 for 32 px), each costing five forward evaluations plus at most one failed
//! block attempt of `(k + 1)^2 <= (2 s + 1)^2` evaluations for side `s` (stopped at the first
//! strip that fails); over the `log2 c + 1` levels that is at most about `4 (log2 c + 1)`
//! evaluations per reference pixel (24 for 32 px), whatever `phi` does. Each output pixel is
//! then tried by Newton at most once, for at most `max_iter (1 + 12)` iterations (seed,
//! forward samples; 325 with the default 25); a seeded solve takes one or two. So
//! the worst case is linear in the pixels, and a fold costs Newton only for the pixels next
//! to its crease (a band about a pixel wide) and for strongly compressed pieces (by choice,
//! where that is cheaper than interpolating), not for the folded region.
//!
//! Coordinates: output pixel `(i, j)` is the point `q = (i, j)` of the deformed plane;
//! preimages are in mesh (input pixel) units.

mod fill;
mod geometry;
mod raster;
mod stats;

pub use geometry::CurvatureBounds;
pub use stats::RemapStats;

use super::inverse::{InverseMap, InverseOptions};
use crate::spline::Spline;
use geometry::{affine_inverse_norm, bbox, bucket_for, signed_area, CurvatureGrid, Lattice};
use rayon::prelude::*;

/// Options of the fast preimage computation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RemapOptions {
    /// Newton options; `inverse.tolerance` is the guaranteed error bound (pixels).
    pub inverse: InverseOptions,
    /// Side of the coarse lattice squares (reference pixels; 32 by default).
    pub cell: f64,
    /// Rows of output per band (bands are processed in parallel; 32 by default).
    pub band_rows: u32,
}

impl Default for RemapOptions {
    fn default() -> Self {
        RemapOptions { inverse: InverseOptions::default(), cell: 32.0, band_rows: 32 }
    }
}

/// A rectangle of output pixels: columns `x0 .. x0 + w`, rows `y0 .. y0 + h` (pixel
/// `(i, j)` is the point `(i, j)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Rect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// Columns.
    pub w: u32,
    /// Rows.
    pub h: u32,
}

impl Rect {
    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.w as usize * self.h as usize
    }

    /// No pixels.
    pub fn is_empty(&self) -> bool {
        self.w == 0 || self.h == 0
    }
}

impl RemapOptions {
    /// The side of the lattice squares a plan uses: [`RemapOptions::cell`], or 8 px when
    /// that is not a finite number of at least 1/16 px.
    pub fn lattice_cell(&self) -> f64 {
        if self.cell.is_finite() && self.cell >= MIN_SQUARE {
            self.cell
        } else {
            8.0
        }
    }
}

/// Whether the mesh covers a convex region (its boundary is its vertices' convex hull).
pub(crate) fn mesh_is_convex(m: &crate::mesh::Mesh) -> bool {
    geometry::is_convex(m)
}

/// Smallest lattice square option (reference pixels).
const MIN_SQUARE: f64 = 0.0625;

/// Side (reference pixels) at or below which a square is not split further: its halves that
/// miss the bound, and squares across the border of the mesh, leave their output pixels to
/// Newton's method seeded from the piece's affine inverse. Below a pixel, splitting costs at
/// least five forward evaluations per square for less than a pixel of output, while a
/// seeded Newton solve costs about two iterations per pixel.
const NEWTON_SIDE: f64 = 1.0;

/// The smallest `1 - |A^-1| M diam` accepted for a piece: below it the perturbation bound
/// `K = |A^-1| / (1 - |A^-1| M diam)` on `|J^-1|` more than doubles `|A^-1|`, so the piece is
/// split instead (smaller pieces shrink `M diam` linearly and the bound quadratically).
const MIN_SHRINK: f64 = 0.5;

/// Forward evaluations per output pixel above which a square's pixels are left to Newton's
/// method instead of a `k x k` block ([`Refiner::compressed`]): a seeded Newton solve costs
/// about three evaluations of `phi` and `J`, a block's grid point one evaluation and two
/// rasterized triangles.
const DENSE: f64 = 3.0;

/// Largest error bound (reference pixels) of the affine seed with which a compressed
/// square's pixels go to Newton; larger squares are split first, so Newton starts within
/// this distance and takes two or three iterations.
const SEED_BOUND: f64 = 0.5;

/// What [`Refiner::compressed`] decided for a square (a return value on the stack, so the
/// boxes stay inline: boxing them would allocate per square).
#[allow(clippy::large_enum_variant)]
enum Compressed {
    /// Not compressed (or not certified free of folds): the usual refinement.
    No,
    /// Compressed, but the affine seed is too far: split without trying a block.
    Split,
    /// Compressed: Newton solves the pixels of the halves' images.
    Newton([NewtonBox; 2]),
}

/// Margin on the leg length chosen for a `k x k` split (10 %): the split aims for legs whose
/// bound is below the tolerance with this slack, so the pieces usually pass on the first try
/// despite the first-order slack and `K > |A^-1|` ([`MIN_SHRINK`]).
const SPLIT_MARGIN: f64 = 1.1;

/// The affine inverse of a piece, `p = c + m q`, as Newton's seed for the pixels around it
/// (`tri`: a mesh triangle near the preimage, for locating the seed).
#[derive(Clone, Copy, Debug)]
struct Seed {
    c: [f64; 2],
    m: [[f64; 2]; 2],
    tri: Option<usize>,
}

impl Seed {
    /// `L^-1` of the triangle `p -> q`; a constant seed at `p[0]` if `q` is degenerate.
    fn affine(p: [[f64; 2]; 3], q: [[f64; 2]; 3], tri: Option<usize>) -> Seed {
        let (e1, e2) =
            ([q[1][0] - q[0][0], q[1][1] - q[0][1]], [q[2][0] - q[0][0], q[2][1] - q[0][1]]);
        let det = e1[0] * e2[1] - e2[0] * e1[1];
        if det == 0.0 || !det.is_finite() {
            return Seed::point(p[0], tri);
        }
        // lambda_(1,2) = E^-1 (q - q0), p = p0 + [P1 - P0, P2 - P0] lambda.
        let inv = [[e2[1] / det, -e2[0] / det], [-e1[1] / det, e1[0] / det]];
        let (f1, f2) =
            ([p[1][0] - p[0][0], p[1][1] - p[0][1]], [p[2][0] - p[0][0], p[2][1] - p[0][1]]);
        let m = [0, 1].map(|r| {
            [0, 1].map(|c| {
                let (a, b) = if r == 0 { (f1[0], f2[0]) } else { (f1[1], f2[1]) };
                a * inv[0][c] + b * inv[1][c]
            })
        });
        let c = [0, 1].map(|r| p[0][r] - m[r][0] * q[0][0] - m[r][1] * q[0][1]);
        Seed { c, m, tri }
    }

    fn point(p: [f64; 2], tri: Option<usize>) -> Seed {
        Seed { c: p, m: [[0.0; 2]; 2], tri }
    }

    #[inline]
    fn at(&self, q: [f64; 2]) -> [f64; 2] {
        [0, 1].map(|r| self.c[r] + self.m[r][0] * q[0] + self.m[r][1] * q[1])
    }
}

/// Output box `[x0, y0, x1, y1]` whose unfilled pixels Newton solves, from `seed`.
#[derive(Clone, Copy, Debug)]
struct NewtonBox {
    r: [f64; 4],
    seed: Seed,
    /// The box covers a piece where `phi` compresses so much that interpolation would need
    /// several forward evaluations per output pixel ([`Refiner::compressed`]).
    compressed: bool,
    /// The compressed piece is reversed (`det J < 0` on all of it): its pixels are marked
    /// as drawn from a fold.
    folded: bool,
}

/// An accepted lattice triangle (from the splitting path): reference vertices, images.
#[derive(Clone, Copy, Debug)]
struct Tri {
    p: [[f64; 2]; 3],
    q: [[f64; 2]; 3],
    /// Output rows spanned.
    y: [f64; 2],
    bound: f64,
    /// Width of the gaps its edges may leave to finer neighbours ([`gap_width`]).
    gap: f64,
    /// Which edges (opposite each vertex) are sides of its lattice square, not the
    /// diagonal shared with the other half.
    outer: [bool; 3],
    folded: bool,
}

/// A lattice square cut into `k x k` equal rectangles (each in two triangles) that all meet
/// the bound; the images of its `(k+1)^2` grid points are in [`Pieces::pool`].
#[derive(Clone, Copy, Debug)]
struct Block {
    p0: [f64; 2],
    step: [f64; 2],
    k: usize,
    off: usize,
    y: [f64; 2],
    bound: f64,
    /// Width of the gaps its outer edges may leave to neighbours ([`gap_width`]).
    gap: f64,
    /// The image is reversed (det J < 0 on the whole block).
    folded: bool,
}

/// Largest gap (output pixels) between the image of a piece's edge of length `leg` and a
/// neighbour's finer polygon along the same edge: both interpolate the curve `phi(edge)`,
/// whose distance from any chord over a reference segment of length `l` is at most
/// `M l^2 / 8` (`M`: the bound on `|D^2 phi|`, [`Refiner::m2`]). The gap between the two
/// polygons is swept by the segments joining their points of equal parameter, and a point
/// at fraction `s` along such a segment is within `s (d_1 + d_2)` of the first polygon and
/// `(1 - s) (d_1 + d_2)` of the second, so within `d_1` of the first or `d_2` of the
/// second: growing each piece by its own `M leg^2 / 8` covers every gap. Kept at most half
/// a pixel (gaps next to folds), with 1 % and `1e-7` px of margin for rounding.
fn gap_width(m2: f64, leg: f64) -> f64 {
    (m2 * leg * leg / 8.0 * 1.01 + 1e-7).min(MAX_GAP)
}

/// Largest gap width searched around a piece (output pixels, [`gap_width`]).
const MAX_GAP: f64 = 0.5;

/// A lattice corner's image and the mesh triangle it lies in (`None`: outside the mesh).
type Corner = Option<([f64; 2], usize)>;

/// The mesh triangle of the first corner of the half `h` that has one.
fn qt_tri(qt: &[Corner; 4], h: &[usize]) -> Option<usize> {
    h.iter().find_map(|&i| qt[i].map(|c| c.1))
}

/// The pieces of one lattice row, with the output rows they span.
struct Pieces {
    blocks: Vec<Block>,
    /// Images of the blocks' grid points.
    pool: Vec<[f64; 2]>,
    tris: Vec<Tri>,
    /// Output boxes whose unfilled pixels Newton must solve.
    newton: Vec<NewtonBox>,
    /// Smallest and largest output `y` of the pieces.
    y: [f64; 2],
}

impl Default for Pieces {
    fn default() -> Self {
        Pieces {
            blocks: Vec::new(),
            pool: Vec::new(),
            tris: Vec::new(),
            newton: Vec::new(),
            y: [f64::INFINITY, f64::NEG_INFINITY],
        }
    }
}

/// A plan for the preimages of a `w x h` output: the forward lattice, refined and binned.
pub struct RemapPlan<'a> {
    map: InverseMap<'a>,
    opts: RemapOptions,
    w: u32,
    h: u32,
    /// Per lattice row, its accepted pieces.
    rows: Vec<Pieces>,
    bands: usize,
}

/// A reference triangle's shape, as far as [`Refiner::tri_bound`] needs it: the same
/// figures for every congruent copy (the halves of a block's sub-rectangles).
struct HalfShape {
    /// adj(Pe), Pe the edge matrix `[P1 - P0, P2 - P0]` (columns).
    adj: [[f64; 2]; 2],
    /// Signed area (twice) of the triangle.
    area: f64,
    diam: f64,
    /// Squared circumradius.
    r2: f64,
}

impl HalfShape {
    fn new(p: [[f64; 2]; 3]) -> HalfShape {
        let pe = [[p[1][0] - p[0][0], p[2][0] - p[0][0]], [p[1][1] - p[0][1], p[2][1] - p[0][1]]];
        let d2 = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2);
        let l = d2(p[0], p[1]).max(d2(p[0], p[2])).max(d2(p[1], p[2]));
        HalfShape {
            adj: [[pe[1][1], -pe[0][1]], [-pe[1][0], pe[0][0]]],
            area: signed_area(p),
            diam: l.sqrt(),
            r2: l / 4.0,
        }
    }

    /// [`Refiner::tri_bound`] for a copy of this shape with image `q` (signed area `sq`),
    /// the same arithmetic as [`affine_inverse_norm`] and `tri_bound` with the reference
    /// figures precomputed.
    #[inline]
    fn bound(&self, q: [[f64; 2]; 3], sq: f64, m2: f64) -> Option<f64> {
        let (sp, adj) = (self.area, self.adj);
        if sp * sq == 0.0 || !(sp * sq).is_finite() {
            return None;
        }
        if m2 == 0.0 {
            return Some(0.0);
        }
        let qe = [[q[1][0] - q[0][0], q[2][0] - q[0][0]], [q[1][1] - q[0][1], q[2][1] - q[0][1]]];
        let b = [0, 1].map(|r| [0, 1].map(|c| qe[r][0] * adj[0][c] + qe[r][1] * adj[1][c]));
        let det = b[0][0] * b[1][1] - b[0][1] * b[1][0];
        let fro2 = b[0][0] * b[0][0] + b[0][1] * b[0][1] + b[1][0] * b[1][0] + b[1][1] * b[1][1];
        let smax = ((fro2 + ((fro2 * fro2 - 4.0 * det * det).max(0.0)).sqrt()) / 2.0).sqrt();
        let ainv = smax / sq.abs();
        let shrink = 1.0 - ainv * m2 * self.diam;
        if shrink <= MIN_SHRINK {
            return None;
        }
        Some(crate::warp::inverse::FIRST_ORDER_SLACK * ainv / shrink * m2 * self.r2 / 2.0)
    }
}

struct Refiner<'s> {
    s: &'s Spline,
    curv: &'s CurvatureGrid,
    /// `M = scale * curv.bound + add` ([`CurvatureBounds`]; `1, 0` for `s`'s own grid).
    scale: f64,
    add: f64,
    tol: f64,
    /// [`DENSE`] (infinite in tests that turn the compressed path off).
    dense: f64,
}

impl Refiner<'_> {
    /// The bound on `|D^2 phi|` over the box.
    fn m2(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        let m = self.curv.bound(lo, hi);
        if self.scale == 1.0 && self.add == 0.0 {
            m
        } else {
            self.scale * m + self.add
        }
    }

    fn eval(&self, p: [f64; 2], hint: Option<usize>) -> Corner {
        let (t, b) = self.s.mesh().locate(p, hint)?;
        Some((self.s.eval_cache().value(t, b), t))
    }

    /// Bound of interpolating over the triangle, or `None` if it must be split.
    fn tri_bound(&self, p: [[f64; 2]; 3], q: [[f64; 2]; 3], m2: f64) -> Option<f64> {
        self.tri_bound_with(p, affine_inverse_norm(p, q)?, m2)
    }

    /// [`Refiner::tri_bound`] given the triangle's `|A^-1|`.
    fn tri_bound_with(&self, p: [[f64; 2]; 3], ainv: f64, m2: f64) -> Option<f64> {
        if m2 == 0.0 {
            return Some(0.0);
        }
        let d2 = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2);
        let (l01, l02, l12) = (d2(p[0], p[1]), d2(p[0], p[2]), d2(p[1], p[2]));
        let diam = l01.max(l02).max(l12).sqrt();
        let shrink = 1.0 - ainv * m2 * diam;
        if shrink <= MIN_SHRINK {
            return None;
        }
        // Largest of sum lambda_i |P_i - p|^2 is the squared circumradius for right and
        // obtuse-free lattice triangles: the hypotenuse squared over 4.
        let r2 = l01.max(l02).max(l12) / 4.0;
        Some(crate::warp::inverse::FIRST_ORDER_SLACK * ainv / shrink * m2 * r2 / 2.0)
    }

    /// Whether the square (all corners inside, not crossing the border; images `q`) is one
    /// where `phi` compresses so strongly that its `k x k` block ([`Refiner::block`]) would
    /// need more than [`DENSE`] forward evaluations per output pixel of its image. Such a
    /// square's output pixels are cheaper by Newton: [`Compressed::Newton`] with a box per
    /// half, seeded from the half's affine inverse, once that seed is within [`SEED_BOUND`]
    /// of the preimage; [`Compressed::Split`] (split without trying the block) until then.
    ///
    /// Only squares whose halves have the same orientation and pass the perturbation test
    /// of [`Refiner::tri_bound`] (`|J - A| <= M diam < |A^-1|^-1 / 2` on each half) go to
    /// Newton, so `det J` keeps one sign throughout the square: a box either has no fold or
    /// is reversed all over (its pixels are then counted and marked as folded), and
    /// Newton's seed lies in a region where `|J^-1| <= 2 |A^-1|`.
    fn compressed(
        &self,
        p: [[f64; 2]; 4],
        q: [[f64; 2]; 4],
        m2: f64,
        side: f64,
        tri: Option<usize>,
    ) -> Compressed {
        if m2 == 0.0 {
            return Compressed::No;
        }
        let halves = [[0, 1, 3], [0, 3, 2]];
        let (mut ainv, mut area, mut sign) = ([0.0f64; 2], 0.0f64, 0.0f64);
        for (h, a) in halves.iter().zip(&mut ainv) {
            let (pt, qt) = (h.map(|i| p[i]), h.map(|i| q[i]));
            let sg = (signed_area(pt) * signed_area(qt)).signum();
            let Some(n) = affine_inverse_norm(pt, qt) else { return Compressed::No };
            if sign != 0.0 && sg != sign {
                return Compressed::No;
            }
            (sign, *a) = (sg, n);
            area += signed_area(qt).abs() / 2.0;
        }
        // The block's k (as in `block`), and its grid points per output pixel.
        let leg = (4.0 * self.tol / (SPLIT_MARGIN * ainv[0].max(ainv[1]) * m2)).sqrt();
        let k = (side / leg).ceil().max(1.0);
        if k <= 1.0 || (k + 1.0) * (k + 1.0) <= self.dense * area {
            return Compressed::No;
        }
        for (h, &a) in halves.iter().zip(&ainv) {
            match self.tri_bound_with(h.map(|i| p[i]), a, m2) {
                Some(b) if b <= SEED_BOUND => {}
                _ => return Compressed::Split,
            }
        }
        // The image of a half lies within its corners' box grown by the largest distance of
        // an edge's image from its chord, `M l^2 / 8` for the diagonal `l^2 = 2 side^2`.
        let grow = m2 * side * side / 4.0 * 1.01 + 1e-7;
        Compressed::Newton(halves.map(|h| {
            let (pt, qt) = (h.map(|i| p[i]), h.map(|i| q[i]));
            let (lo, hi) = bbox(&qt);
            NewtonBox {
                r: [lo[0] - grow, lo[1] - grow, hi[0] + grow, hi[1] + grow],
                seed: Seed::affine(pt, qt, tri),
                compressed: true,
                folded: sign < 0.0,
            }
        }))
    }

    /// Tries to cut the square (all corners inside, not crossing the border) into `k x k`
    /// rectangles that all meet the bound, `k` chosen from the bound itself.
    fn block(&self, p: [[f64; 2]; 4], qt: [Corner; 4], m2: f64, out: &mut Pieces) -> bool {
        let q = qt.map(|c| c.map(|c| c.0).unwrap_or([0.0; 2]));
        let (sx, sy) = (p[1][0] - p[0][0], p[2][1] - p[0][1]);
        let k = if m2 == 0.0 {
            1
        } else {
            // |A^-1| of the two halves; a leg `a` meets the bound when K M a^2 / 4 <= tol.
            let ainv = [[0, 1, 3], [0, 3, 2]]
                .iter()
                .map(|h| affine_inverse_norm(h.map(|i| p[i]), h.map(|i| q[i])))
                .try_fold(0.0f64, |a, b| Some(a.max(b?)));
            let Some(ainv) = ainv else { return false };
            let leg = (4.0 * self.tol / (SPLIT_MARGIN * ainv * m2)).sqrt();
            (sx.max(sy) / leg).ceil().max(1.0) as usize
        };
        if k > 1 && (sx.max(sy) / k as f64) < MIN_SQUARE.max(0.5) {
            return false;
        }
        let off = out.pool.len();
        let step = [sx / k as f64, sy / k as f64];
        let mut hint = qt[0].map(|c| c.1);
        // Every sub-rectangle's halves have the same reference shape, so what `tri_bound`
        // derives from it (adj(Pe), its area, diameter, circumradius) is computed once.
        let halves = [[0, 1, 3], [0, 3, 2]];
        let pr = [[0.0, 0.0], [step[0], 0.0], [0.0, step[1]], [step[0], step[1]]];
        let shape = halves.map(|h| HalfShape::new(h.map(|c| pr[c])));
        let mut worst = 0.0f64;
        let mut sign = 0.0f64;
        let n = k + 1;
        // Row by row: each strip of rectangles is checked as soon as its two rows of grid
        // points are mapped, so a block that fails costs only the rows up to the failure.
        for j in 0..=k {
            for i in 0..=k {
                let c = match (i == 0 || i == k, j == 0 || j == k) {
                    (true, true) => qt[(i / k) + 2 * (j / k)],
                    _ => self
                        .eval([p[0][0] + i as f64 * step[0], p[0][1] + j as f64 * step[1]], hint),
                };
                let Some((v, t)) = c else {
                    out.pool.truncate(off);
                    return false;
                };
                hint = Some(t);
                out.pool.push(v);
            }
            let Some(j) = j.checked_sub(1) else { continue };
            for i in 0..k {
                let b = off + j * n + i;
                let qq = [out.pool[b], out.pool[b + 1], out.pool[b + n], out.pool[b + n + 1]];
                for (h, sh) in halves.iter().zip(&shape) {
                    let qt = h.map(|c| qq[c]);
                    let sq = signed_area(qt);
                    let sg = (sh.area * sq).signum();
                    if sign == 0.0 {
                        sign = sg;
                    }
                    match sh.bound(qt, sq, m2) {
                        Some(bd) if bd <= self.tol && sg == sign => worst = worst.max(bd),
                        _ => {
                            out.pool.truncate(off);
                            return false;
                        }
                    }
                }
            }
        }
        let (lo, hi) = bbox(&out.pool[off..]);
        out.blocks.push(Block {
            p0: p[0],
            step,
            k,
            off,
            y: [lo[1], hi[1]],
            bound: worst,
            gap: gap_width(m2, step[0].max(step[1])),
            folded: sign < 0.0,
        });
        true
    }

    /// Refines the square with corners `p = [p00, p10, p01, p11]` (images `q`).
    fn square(&self, p: [[f64; 2]; 4], qt: [Corner; 4], out: &mut Pieces) {
        let q = qt.map(|c| c.map(|c| c.0));
        let side = (p[1][0] - p[0][0]).max(p[2][1] - p[0][1]);
        let (lo, hi) = bbox(&p);
        let m2 = self.m2(lo, hi);
        let smallest = side <= NEWTON_SIDE;
        let all = q.iter().all(Option::is_some);
        let none = q.iter().all(Option::is_none);
        // Corners inside and no border edge through it: the whole square is in the mesh.
        // Corners outside and no border edge through it: the whole square is outside.
        let crossing = (none || self.curv.concave) && self.curv.crosses_border(lo, hi);
        if none && !crossing {
            return;
        }
        let mut try_block = all && !crossing && !smallest;
        if try_block {
            let qv = q.map(|v| v.unwrap_or([0.0; 2]));
            match self.compressed(p, qv, m2, side, qt_tri(&qt, &[0, 1, 2, 3])) {
                Compressed::No => {}
                Compressed::Split => try_block = false,
                Compressed::Newton(boxes) => {
                    out.newton.extend(boxes);
                    return;
                }
            }
        }
        if try_block && self.block(p, qt, m2, out) {
            return;
        }
        if all && !crossing {
            let qv = q.map(|v| v.unwrap_or([0.0; 2]));
            let qt_all = qt;
            let halves = [[0, 1, 3], [0, 3, 2]];
            let bounds = halves.map(|h| {
                let (pt, qt) = (h.map(|i| p[i]), h.map(|i| qv[i]));
                self.tri_bound(pt, qt, m2).filter(|b| *b <= self.tol)
            });
            if smallest || bounds.iter().all(Option::is_some) {
                // At the smallest size: halves that meet the bound or fold are drawn; any
                // other half is left to Newton, pixel by pixel.
                // The diagonal is the edge opposite vertex 1 of (0, 1, 3), 2 of (0, 3, 2).
                let outer = [[true, false, true], [true, true, false]];
                for (k, h) in halves.iter().enumerate() {
                    let (pt, qt) = (h.map(|i| p[i]), h.map(|i| qv[i]));
                    let outer = outer[k];
                    let folded = signed_area(pt) * signed_area(qt) <= 0.0;
                    let (lo, hi) = bbox(&qt);
                    let gap = gap_width(m2, side);
                    match bounds[k] {
                        Some(b) => out.tris.push(Tri {
                            p: pt,
                            q: qt,
                            y: [lo[1], hi[1]],
                            bound: b,
                            gap,
                            outer,
                            folded,
                        }),
                        None if folded => out.tris.push(Tri {
                            p: pt,
                            q: qt,
                            y: [lo[1], hi[1]],
                            bound: f64::INFINITY,
                            gap,
                            outer,
                            folded,
                        }),
                        None => {
                            let tri = qt_tri(&qt_all, h);
                            out.newton.push(NewtonBox {
                                r: [lo[0] - 1.0, lo[1] - 1.0, hi[0] + 1.0, hi[1] + 1.0],
                                seed: Seed::affine(pt, qt, tri),
                                compressed: false,
                                folded: false,
                            })
                        }
                    }
                }
                return;
            }
        }
        if smallest {
            // A piece across the border of the mesh: Newton for the pixels around it, from
            // the affine inverse of three corners inside, or else from a corner inside.
            let inside: Vec<usize> = (0..4).filter(|&i| qt[i].is_some()).collect();
            if let Some(&first) = inside.first() {
                let imgs: Vec<[f64; 2]> = q.iter().flatten().copied().collect();
                let (l, h) = bbox(&imgs);
                let tri = qt[first].map(|c| c.1);
                let seed = if inside.len() >= 3 {
                    let c = [inside[0], inside[1], inside[2]];
                    Seed::affine(c.map(|i| p[i]), c.map(|i| qt[i].map_or([0.0; 2], |v| v.0)), tri)
                } else {
                    Seed::point(p[first], tri)
                };
                let r = [l[0] - 1.0, l[1] - 1.0, h[0] + 1.0, h[1] + 1.0];
                out.newton.push(NewtonBox { r, seed, compressed: false, folded: false });
            }
            return;
        }
        let mid = |a: [f64; 2], b: [f64; 2]| [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
        let (top, left, right, bottom) =
            (mid(p[0], p[1]), mid(p[0], p[2]), mid(p[1], p[3]), mid(p[2], p[3]));
        let centre = mid(p[0], p[3]);
        let hint = qt.iter().flatten().map(|c| c.1).next();
        let [mt, ml, mc, mr, mb] = [top, left, centre, right, bottom].map(|x| self.eval(x, hint));
        self.square([p[0], top, left, centre], [qt[0], mt, ml, mc], out);
        self.square([top, p[1], centre, right], [mt, qt[1], mc, mr], out);
        self.square([left, centre, p[2], bottom], [ml, mc, qt[2], mb], out);
        self.square([centre, right, bottom, p[3]], [mc, mr, mb, qt[3]], out);
    }
}

impl<'a> RemapPlan<'a> {
    /// Maps the lattice forward, refines it under the bound and bins the triangles by band.
    pub fn new(s: &'a Spline, w: u32, h: u32, opts: RemapOptions) -> RemapPlan<'a> {
        RemapPlan::new_window(s, w, h, opts, None)
    }

    /// [`RemapPlan::new`] for the lattice squares that meet the reference box `window`
    /// (`(lo, hi)`; `None`: all of them) only. The lattice and every square's pieces are
    /// those of the whole plan (each square is refined from its own corners alone, and the
    /// corners are located in the mesh without a hint from their neighbours), so
    /// [`RemapPlan::fill_rect`] gives exactly the whole plan's preimages on every output
    /// pixel all of whose pieces come from squares meeting `window`
    /// ([`crate::warp::tiles`] chooses the window so that a tile's pixels are such).
    pub fn new_window(
        s: &'a Spline,
        w: u32,
        h: u32,
        opts: RemapOptions,
        window: Option<([f64; 2], [f64; 2])>,
    ) -> RemapPlan<'a> {
        let lat = Lattice::new(s, opts.lattice_cell());
        let (ia, ib, ja, jb) = lat.span(window);
        // Curvature bounds for the squares covered (all of the mesh without a window).
        let covered = window.map(|_| (lat.at(ia, ja), lat.at(ib, jb)));
        let curv = CurvatureGrid::new(s, bucket_for(s.mesh()), covered);
        RemapPlan::with_grid(s, w, h, opts, window, &curv, 1.0, 0.0, DENSE)
    }

    /// [`RemapPlan::new`] with the curvature bounds of `base` scaled by `factor`, plus the
    /// bound `E` of [`EvalCache::second_derivative_excess_bound`] on `s - factor * base`
    /// (`|D^2 s| <= |factor| M_base + E`), so the plan's error bound holds for any `s`.
    /// Where `s - factor * base` is affine, as for a morph's frame `(1 - f) id + f base`
    /// (exact blends, rounded to `f64`), `E` is a few rounding errors and the plan is a fresh
    /// one's up to them, without recomputing the local bounds (the costliest step of a
    /// plan). On another mesh, `s`'s own bounds are computed instead.
    ///
    /// [`EvalCache::second_derivative_excess_bound`]: crate::spline::eval::EvalCache::second_derivative_excess_bound
    pub fn new_scaled(
        s: &'a Spline,
        w: u32,
        h: u32,
        opts: RemapOptions,
        base: &CurvatureBounds,
        factor: f64,
    ) -> RemapPlan<'a> {
        let add = s.eval_cache().second_derivative_excess_bound(base.cache(), factor);
        let scale = factor.abs() * (1.0 + 4.0 * f64::EPSILON);
        if !add.is_finite() || !scale.is_finite() || base.bucket() != bucket_for(s.mesh()) {
            return RemapPlan::new(s, w, h, opts);
        }
        RemapPlan::with_grid(s, w, h, opts, None, base.grid(), scale, add, DENSE)
    }

    /// [`RemapPlan::new`] with compressed squares refined like any other
    /// ([`Refiner::compressed`] off), for tests that compare the two.
    #[cfg(test)]
    fn without_compressed(s: &'a Spline, w: u32, h: u32, opts: RemapOptions) -> RemapPlan<'a> {
        let curv = CurvatureGrid::new(s, bucket_for(s.mesh()), None);
        RemapPlan::with_grid(s, w, h, opts, None, &curv, 1.0, 0.0, f64::INFINITY)
    }

    /// The plan with the curvature bounds `scale * curv + add` (`curv` covers at least the
    /// squares meeting `window`), leaving squares denser than `dense` evaluations per output
    /// pixel to Newton ([`Refiner::compressed`]).
    #[allow(clippy::too_many_arguments)]
    fn with_grid(
        s: &'a Spline,
        w: u32,
        h: u32,
        opts: RemapOptions,
        window: Option<([f64; 2], [f64; 2])>,
        curv: &CurvatureGrid,
        scale: f64,
        add: f64,
        dense: f64,
    ) -> RemapPlan<'a> {
        let lat = Lattice::new(s, opts.lattice_cell());
        let opts = RemapOptions { cell: lat.cell, band_rows: opts.band_rows.max(1), ..opts };
        let map = InverseMap::new(s, opts.inverse);
        let (ia, ib, ja, jb) = lat.span(window);
        let (mx, my) = (ib + 1 - ia.min(ib), jb + 1 - ja.min(jb));
        let at = |i, j| lat.at(i, j);
        let refiner = Refiner { s, curv, scale, add, tol: opts.inverse.tolerance, dense };
        let pts: Vec<[f64; 2]> = (ja..=jb).flat_map(|j| (ia..=ib).map(move |i| at(i, j))).collect();
        // Each corner located without a hint, so that its value (which triangle evaluates a
        // point on an edge) does not depend on which squares the plan covers.
        let vals: Vec<Corner> = pts.par_iter().map(|&p| refiner.eval(p, None)).collect();
        let (nx, ny) = (mx, my);
        let rows: Vec<Pieces> = (0..ny.saturating_sub(1))
            .into_par_iter()
            .map(|j| {
                let mut out = Pieces::default();
                for i in 0..nx - 1 {
                    let k = j * nx + i;
                    let (p, q) = (
                        [pts[k], pts[k + 1], pts[k + nx], pts[k + nx + 1]],
                        [vals[k], vals[k + 1], vals[k + nx], vals[k + nx + 1]],
                    );
                    if p[1][0] > p[0][0] && p[2][1] > p[0][1] {
                        refiner.square(p, q, &mut out);
                    }
                }
                // Keep what can reach the output, and note the rows spanned.
                let (wf, hf) = (w as f64, h as f64);
                out.tris.retain(|t| t.y[1] >= -0.5 && t.y[0] <= hf);
                out.blocks.retain(|b| b.y[1] >= -0.5 && b.y[0] <= hf);
                out.newton.retain(|b| {
                    let r = b.r;
                    r[3] >= 0.0 && r[1] <= hf && r[2] >= 0.0 && r[0] <= wf
                });
                for y in out.tris.iter().map(|t| t.y).chain(out.blocks.iter().map(|b| b.y)) {
                    out.y = [out.y[0].min(y[0]), out.y[1].max(y[1])];
                }
                for r in out.newton.iter().map(|b| b.r) {
                    out.y = [out.y[0].min(r[1]), out.y[1].max(r[3])];
                }
                out
            })
            .collect();
        let bands = (h as usize).div_ceil(opts.band_rows as usize);
        RemapPlan { map, opts, w, h, rows, bands }
    }

    /// Triangles rasterized and Newton boxes (for diagnostics).
    pub fn debug_counts(&self) -> String {
        let tris: usize = self.rows.iter().map(|r| r.tris.len()).sum();
        let blocks: usize = self.rows.iter().map(|r| r.blocks.len()).sum();
        let pool: usize = self.rows.iter().map(|r| r.pool.len()).sum();
        let boxes: usize = self.rows.iter().map(|r| r.newton.len()).sum();
        format!("{blocks} blocks ({pool} points), {tris} tris, {boxes} newton boxes")
    }

    /// Output width and height.
    pub fn size(&self) -> (u32, u32) {
        (self.w, self.h)
    }

    /// Rows per band ([`RemapPlan::fill_band`] fills one band).
    pub fn band_rows(&self) -> u32 {
        self.opts.band_rows
    }

    /// Number of bands covering the output.
    pub fn num_bands(&self) -> usize {
        self.bands
    }

    /// Fills the preimages of the pixel rows of band `band` (rows `band * band_rows ..`) into
    /// `out` (row-major, `w` per row; `[NaN, NaN]` where there is none).
    pub fn fill_band(&self, band: usize, out: &mut [[f64; 2]]) -> RemapStats {
        self.fill_band_folds(band, out, None)
    }

    /// [`RemapPlan::fill_band`], also marking in `folds` (same layout as `out`) the pixels
    /// drawn from folded pieces, whose preimages carry no error bound.
    pub fn fill_band_folds(
        &self,
        band: usize,
        out: &mut [[f64; 2]],
        folds: Option<&mut [bool]>,
    ) -> RemapStats {
        self.fill_band_with(band, out, folds, &mut BandScratch::default())
    }

    /// [`RemapPlan::fill_band_folds`] with the band's work buffers in `scratch`, kept by the
    /// caller from band to band (one per thread) so that filling a band allocates nothing
    /// once the buffers have grown to a band's size.
    pub fn fill_band_with(
        &self,
        band: usize,
        out: &mut [[f64; 2]],
        folds: Option<&mut [bool]>,
        scratch: &mut BandScratch,
    ) -> RemapStats {
        let y0 = band as u32 * self.opts.band_rows;
        let rows = self.opts.band_rows.min(self.h - y0);
        self.fill_rect(Rect { x0: 0, y0, w: self.w, h: rows }, out, folds, scratch)
    }
}

/// Work buffers of [`RemapPlan::fill_band_with`], reused from band to band.
#[derive(Debug, Default)]
pub struct BandScratch {
    /// Indices of the lattice rows whose pieces reach the band.
    near: Vec<usize>,
    /// Which pixels of the band were last drawn from a folded piece.
    mask: Vec<bool>,
    /// Which pixels of the band Newton has tried.
    tried: Vec<bool>,
    /// Pixels in the gaps between pieces, with their seeds ([`raster::Gap`]).
    gaps: Vec<(u32, [f64; 2])>,
}

/// The preimage of every pixel centre of a `w x h` output (row-major; `[NaN, NaN]` where
/// there is none), with statistics. Parallel over bands of rows.
pub fn preimage_grid(
    s: &Spline,
    w: u32,
    h: u32,
    opts: RemapOptions,
) -> (Vec<[f64; 2]>, RemapStats) {
    let plan = RemapPlan::new(s, w, h, opts);
    let band = plan.band_rows() as usize * w as usize;
    let mut out = vec![[0.0f64; 2]; w as usize * h as usize];
    let stats = out
        .par_chunks_mut(band.max(1))
        .enumerate()
        .map_init(BandScratch::default, |sc, (b, chunk)| plan.fill_band_with(b, chunk, None, sc))
        .reduce(RemapStats::default, |mut a, b| {
            a.merge(&b);
            a
        });
    (out, stats)
}

#[cfg(test)]
mod tests;

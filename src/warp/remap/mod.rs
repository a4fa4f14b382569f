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
//! ([`NEWTON_SIDE`](refine::NEWTON_SIDE)), whose halves that still miss the bound leave their pixels to Newton's
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
//! square whose block would need more than [`DENSE`](refine::DENSE) (3) per pixel of its image is split
//! without trying the block until its affine inverse is within [`SEED_BOUND`](refine::SEED_BOUND) (0.5 px) of
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
pub(crate) mod reach;
mod refine;
mod stats;

pub use geometry::CurvatureBounds;
pub use stats::RemapStats;

use super::inverse::{InverseMap, InverseOptions};
use crate::memory::OverBudget;
use crate::spline::Spline;
use geometry::{bucket_for, CurvatureGrid, Lattice};
use rayon::prelude::*;
use refine::{Refiner, DENSE};

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
    /// Output columns and rows spanned by the images of its grid points.
    x: [f64; 2],
    y: [f64; 2],
    bound: f64,
    /// Width of the gaps its outer edges may leave to neighbours ([`gap_width`]).
    gap: f64,
    /// The image is reversed (det J < 0 on the whole block).
    folded: bool,
    /// Lattice column of the square when the block is the whole square undivided (`k = 1`,
    /// its corners the lattice corners' images), else `u32::MAX`.
    whole: u32,
    /// Outer edges (left, right, top, bottom) shared with such a whole neighbour of the
    /// same orientation: the same segment between the same corner images, so no gap can
    /// open there and the gap search skips them (`mark_conforming`).
    conform: [bool; 4],
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

/// Marks the outer edges that two whole-square blocks (`k = 1`, kept in the plan, of one
/// orientation) share,
/// `rows[j]` holding lattice row `j` of `cols` squares. Both blocks rasterize that edge
/// as the same segment, between the corner images that both took from the one evaluation
/// of each lattice corner; a pixel centre on either side of it, or on it, is inside one of
/// the two triangles up to the rasterizer's barycentric slack (`1e-9`, far above the
/// rounding of the barycentric coordinates), so no gap opens there and the gap search
/// ([`raster::Gap`]) is skipped on it. Any other outer edge (a neighbour split finer, a
/// triangle, a Newton box, a square outside the mesh, or one dropped from the plan) keeps
/// the search.
fn mark_conforming(rows: &mut [Pieces], cols: usize) {
    // Per lattice square: 0 none, 1 a whole block, 2 a whole folded block. Only blocks of
    // one orientation count as sharing an edge: where a fold's crease runs along the edge,
    // both images lie on one side of it and the search must look across.
    let whole: Vec<Vec<u8>> = rows
        .iter()
        .map(|r| {
            let mut v = vec![0u8; cols];
            for b in r.blocks.iter().filter(|b| (b.whole as usize) < cols) {
                v[b.whole as usize] = 1 + u8::from(b.folded);
            }
            v
        })
        .collect();
    let at = |j: usize, i: usize| whole.get(j).and_then(|r| r.get(i)).copied().unwrap_or(0);
    for (j, r) in rows.iter_mut().enumerate() {
        for b in r.blocks.iter_mut().filter(|b| (b.whole as usize) < cols) {
            let (i, me) = (b.whole as usize, 1 + u8::from(b.folded));
            b.conform = [
                i > 0 && at(j, i - 1) == me,
                at(j, i + 1) == me,
                j > 0 && at(j - 1, i) == me,
                at(j + 1, i) == me,
            ];
        }
    }
}

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
    /// Some piece is folded (a filled rectangle then keeps a mask of folded pixels).
    folded: bool,
}

impl Default for Pieces {
    fn default() -> Self {
        Pieces {
            blocks: Vec::new(),
            pool: Vec::new(),
            tris: Vec::new(),
            newton: Vec::new(),
            y: [f64::INFINITY, f64::NEG_INFINITY],
            folded: false,
        }
    }
}

impl Pieces {
    /// Releases the capacity that dropping the out-of-reach pieces left.
    fn shrink(&mut self) {
        self.blocks.shrink_to_fit();
        self.pool.shrink_to_fit();
        self.tris.shrink_to_fit();
        self.newton.shrink_to_fit();
    }

    /// Bytes held by the row's tables.
    fn bytes(&self) -> u64 {
        use std::mem::size_of;
        (self.blocks.capacity() * size_of::<Block>()
            + self.pool.capacity() * size_of::<[f64; 2]>()
            + self.tris.capacity() * size_of::<Tri>()
            + self.newton.capacity() * size_of::<NewtonBox>()
            + size_of::<Pieces>()) as u64
    }
}

/// Bytes a plan holds per lattice point while it is built: the point and its image with
/// its triangle ([`Corner`]).
const LATTICE_POINT_BYTES: u64 =
    (std::mem::size_of::<[f64; 2]>() + std::mem::size_of::<Corner>()) as u64;

/// Bytes of one bucket of the curvature grid (its bound and its list of border edges).
const BUCKET_BYTES: u64 = (std::mem::size_of::<f64>() + std::mem::size_of::<Vec<u32>>()) as u64;

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

impl<'a> RemapPlan<'a> {
    /// Maps the lattice forward, refines it under the bound and bins the triangles by band.
    ///
    /// Only the lattice squares that can draw into the output are mapped and refined
    /// ([`reach`]: on a mesh with far-field rings, a few thousand of a million), with the
    /// same pieces as a plan over the whole mesh, so the preimages are the same.
    pub fn new(s: &'a Spline, w: u32, h: u32, opts: RemapOptions) -> RemapPlan<'a> {
        RemapPlan::new_within(s, w, h, opts, u64::MAX).expect("no plan exceeds an unbounded budget")
    }

    /// [`RemapPlan::new`] over every lattice square of the mesh (the plan before the
    /// reach window), for tests that compare the two.
    #[cfg(test)]
    pub(crate) fn whole(s: &'a Spline, w: u32, h: u32, opts: RemapOptions) -> RemapPlan<'a> {
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
        RemapPlan::new_window_within(s, w, h, opts, window, u64::MAX)
            .expect("no plan exceeds an unbounded budget")
    }

    /// [`RemapPlan::new`] within `budget` bytes for the plan's own tables: the lattice and
    /// curvature grid are counted before they are allocated, the pieces as each lattice
    /// row is refined (the rows still to be refined are skipped once the budget is
    /// passed). Warps pass what the process's budget ([`crate::memory`]) leaves beside
    /// their pixel buffers.
    pub fn new_within(
        s: &'a Spline,
        w: u32,
        h: u32,
        opts: RemapOptions,
        budget: u64,
    ) -> Result<RemapPlan<'a>, OverBudget> {
        let window = match reach::plan_window(s, w, h, opts.lattice_cell()) {
            reach::Reach::All => None,
            reach::Reach::Window(lo, hi) => Some((lo, hi)),
            // No square draws into the output: the plan of one corner square, whose pieces
            // are dropped as out of reach.
            reach::Reach::Nothing => Some(s.mesh().bbox()).map(|(lo, _)| (lo, lo)),
        };
        RemapPlan::new_window_within(s, w, h, opts, window, budget)
    }

    /// [`RemapPlan::new_window`] within `budget` bytes ([`RemapPlan::new_within`]).
    pub fn new_window_within(
        s: &'a Spline,
        w: u32,
        h: u32,
        opts: RemapOptions,
        window: Option<([f64; 2], [f64; 2])>,
        budget: u64,
    ) -> Result<RemapPlan<'a>, OverBudget> {
        let lat = Lattice::new(s, opts.lattice_cell());
        let (ia, ib, ja, jb) = lat.span(window);
        // Curvature bounds for the squares covered (all of the mesh without a window).
        let covered = window.map(|_| (lat.at(ia, ja), lat.at(ib, jb)));
        let bucket = bucket_for(s.mesh());
        let points = (ib + 1 - ia.min(ib)) as u64 * (jb + 1 - ja.min(jb)) as u64;
        let fixed = points.saturating_mul(LATTICE_POINT_BYTES).saturating_add(
            CurvatureGrid::stored_for(s, bucket, covered).saturating_mul(BUCKET_BYTES),
        );
        let what = || format!("the inverse-map plan of a {w} x {h} warp ({points} lattice points)");
        crate::memory::check_against(budget, fixed, what)?;
        let curv = CurvatureGrid::new(s, bucket, covered);
        RemapPlan::with_grid(s, w, h, opts, window, &curv, 1.0, 0.0, DENSE, budget - fixed).map_err(
            |used| OverBudget { what: what(), needed: fixed.saturating_add(used), limit: budget },
        )
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
        RemapPlan::with_grid(s, w, h, opts, None, base.grid(), scale, add, DENSE, u64::MAX)
            .expect("no plan exceeds an unbounded budget")
    }

    /// [`RemapPlan::new`] with compressed squares refined like any other
    /// ([`Refiner::compressed`] off), for tests that compare the two.
    #[cfg(test)]
    fn without_compressed(s: &'a Spline, w: u32, h: u32, opts: RemapOptions) -> RemapPlan<'a> {
        let curv = CurvatureGrid::new(s, bucket_for(s.mesh()), None);
        RemapPlan::with_grid(s, w, h, opts, None, &curv, 1.0, 0.0, f64::INFINITY, u64::MAX)
            .expect("no plan exceeds an unbounded budget")
    }

    /// The plan with the curvature bounds `scale * curv + add` (`curv` covers at least the
    /// squares meeting `window`), leaving squares denser than `dense` evaluations per output
    /// pixel to Newton ([`Refiner::compressed`]). The pieces may hold at most `budget`
    /// bytes: past that the remaining rows are skipped and the bytes held are the error.
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
        budget: u64,
    ) -> Result<RemapPlan<'a>, u64> {
        let used = std::sync::atomic::AtomicU64::new(0);
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
                if used.load(std::sync::atomic::Ordering::Relaxed) > budget {
                    return out;
                }
                for i in 0..nx - 1 {
                    let k = j * nx + i;
                    let (p, q) = (
                        [pts[k], pts[k + 1], pts[k + nx], pts[k + nx + 1]],
                        [vals[k], vals[k + 1], vals[k + nx], vals[k + nx + 1]],
                    );
                    if p[1][0] > p[0][0] && p[2][1] > p[0][1] {
                        let counts = (out.blocks.len(), out.tris.len(), out.newton.len());
                        refiner.square(p, q, &mut out);
                        let whole = (out.blocks.len(), out.tris.len(), out.newton.len())
                            == (counts.0 + 1, counts.1, counts.2)
                            && out.blocks[counts.0].k == 1
                            && out.blocks[counts.0].p0 == p[0]
                            && out.blocks[counts.0].step == [p[1][0] - p[0][0], p[2][1] - p[0][1]];
                        if whole {
                            out.blocks[counts.0].whole = i as u32;
                        }
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
                out.folded = out.blocks.iter().any(|b| b.folded)
                    || out.tris.iter().any(|t| t.folded)
                    || out.newton.iter().any(|b| b.folded);
                out.shrink();
                used.fetch_add(out.bytes(), std::sync::atomic::Ordering::Relaxed);
                out
            })
            .collect();
        let used = used.into_inner();
        if used > budget {
            return Err(used);
        }
        let mut rows = rows;
        mark_conforming(&mut rows, nx.saturating_sub(1));
        let bands = (h as usize).div_ceil(opts.band_rows as usize);
        Ok(RemapPlan { map, opts, w, h, rows, bands })
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
    let never = crate::cancel::Cancel::never();
    preimage_grid_watched(s, w, h, opts, &|_| {}, &never).expect("never cancelled")
}

/// [`preimage_grid`] that reports the rows finished to `progress` (from any thread) and
/// stops, with [`crate::cancel::Cancelled`], once `cancel` is set (looked at before each
/// band of rows).
pub fn preimage_grid_watched(
    s: &Spline,
    w: u32,
    h: u32,
    opts: RemapOptions,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &crate::cancel::Cancel,
) -> Result<(Vec<[f64; 2]>, RemapStats), crate::cancel::Cancelled> {
    let plan = RemapPlan::new(s, w, h, opts);
    let band = plan.band_rows() as usize * w as usize;
    let mut out = vec![[0.0f64; 2]; w as usize * h as usize];
    let stats = out
        .par_chunks_mut(band.max(1))
        .enumerate()
        .map_init(BandScratch::default, |sc, (b, chunk)| {
            if cancel.is_cancelled() {
                return RemapStats::default();
            }
            let st = plan.fill_band_with(b, chunk, None, sc);
            progress((chunk.len() / (w as usize).max(1)) as u64);
            st
        })
        .reduce(RemapStats::default, |mut a, b| {
            a.merge(&b);
            a
        });
    cancel.check()?;
    Ok((out, stats))
}

#[cfg(test)]
pub(crate) mod tests;

//! Refining one lattice square under the bound (see the parent module): a `k x k` block
//! when every piece meets the bound, Newton boxes for strongly compressed squares, halves
//! at the smallest size, and otherwise four sub-squares.

use super::geometry::{affine_inverse_norm, bbox, signed_area, CurvatureGrid};
use super::{gap_width, qt_tri, Block, Corner, NewtonBox, Pieces, Seed, Tri, MIN_SQUARE};
use crate::spline::Spline;

/// The two halves `(p00, p10, p11)` and `(p00, p11, p01)` of a square with corners
/// `[p00, p10, p01, p11]`.
const HALVES: [[usize; 3]; 2] = [[0, 1, 3], [0, 3, 2]];

/// Side (reference pixels) at or below which a square is not split further: its halves that
/// miss the bound, and squares across the border of the mesh, leave their output pixels to
/// Newton's method seeded from the piece's affine inverse. Below a pixel, splitting costs at
/// least five forward evaluations per square for less than a pixel of output, while a
/// seeded Newton solve costs about two iterations per pixel.
pub(super) const NEWTON_SIDE: f64 = 1.0;

/// The smallest `1 - |A^-1| M diam` accepted for a piece: below it the perturbation bound
/// `K = |A^-1| / (1 - |A^-1| M diam)` on `|J^-1|` more than doubles `|A^-1|`, so the piece is
/// split instead (smaller pieces shrink `M diam` linearly and the bound quadratically).
pub(super) const MIN_SHRINK: f64 = 0.5;

/// Forward evaluations per output pixel above which a square's pixels are left to Newton's
/// method instead of a `k x k` block ([`Refiner::compressed`]): a seeded Newton solve costs
/// about three evaluations of `phi` and `J`, a block's grid point one evaluation and two
/// rasterized triangles.
pub(super) const DENSE: f64 = 3.0;

/// Largest error bound (reference pixels) of the affine seed with which a compressed
/// square's pixels go to Newton; larger squares are split first, so Newton starts within
/// this distance and takes two or three iterations.
pub(super) const SEED_BOUND: f64 = 0.5;

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
pub(super) const SPLIT_MARGIN: f64 = 1.1;

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

pub(super) struct Refiner<'s> {
    pub(super) s: &'s Spline,
    pub(super) curv: &'s CurvatureGrid,
    /// `M = scale * curv.bound + add` ([`CurvatureBounds`]; `1, 0` for `s`'s own grid).
    pub(super) scale: f64,
    pub(super) add: f64,
    pub(super) tol: f64,
    /// [`DENSE`] (infinite in tests that turn the compressed path off).
    pub(super) dense: f64,
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

    pub(super) fn eval(&self, p: [f64; 2], hint: Option<usize>) -> Corner {
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
        ainv: [Option<f64>; 2],
        m2: f64,
        side: f64,
        tri: Option<usize>,
    ) -> Compressed {
        if m2 == 0.0 {
            return Compressed::No;
        }
        let halves = HALVES;
        let [Some(a0), Some(a1)] = ainv else { return Compressed::No };
        let ainv = [a0, a1];
        let (mut area, mut sign) = (0.0f64, 0.0f64);
        for h in &halves {
            let (pt, qt) = (h.map(|i| p[i]), h.map(|i| q[i]));
            let sg = (signed_area(pt) * signed_area(qt)).signum();
            if sign != 0.0 && sg != sign {
                return Compressed::No;
            }
            sign = sg;
            area += signed_area(qt).abs() / 2.0;
        }
        // The block's k, and its grid points per output pixel.
        let k = self.split_count(a0.max(a1), m2, side) as f64;
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

    /// The `k` of a `k x k` block of a square of side `side` whose halves have
    /// `|A^-1| <= ainv`: a leg `a` meets the bound when `K M a^2 / 4 <= tol`, aimed with
    /// [`SPLIT_MARGIN`] of slack.
    fn split_count(&self, ainv: f64, m2: f64, side: f64) -> usize {
        let leg = (4.0 * self.tol / (SPLIT_MARGIN * ainv * m2)).sqrt();
        (side / leg).ceil().max(1.0) as usize
    }

    /// Tries to cut the square (all corners inside, not crossing the border) into `k x k`
    /// rectangles that all meet the bound, `k` chosen from the bound itself (`ainv`: the
    /// halves' `|A^-1|`, `None` if one is degenerate).
    fn block(
        &self,
        p: [[f64; 2]; 4],
        qt: [Corner; 4],
        ainv: [Option<f64>; 2],
        m2: f64,
        out: &mut Pieces,
    ) -> bool {
        let (sx, sy) = (p[1][0] - p[0][0], p[2][1] - p[0][1]);
        let k = if m2 == 0.0 {
            1
        } else {
            let [Some(a0), Some(a1)] = ainv else { return false };
            self.split_count(a0.max(a1), m2, sx.max(sy))
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
            x: [lo[0], hi[0]],
            y: [lo[1], hi[1]],
            bound: worst,
            gap: gap_width(m2, step[0].max(step[1])),
            folded: sign < 0.0,
            whole: u32::MAX,
            conform: [false; 4],
        });
        true
    }

    /// Refines the square with corners `p = [p00, p10, p01, p11]` (images `q`).
    pub(super) fn square(&self, p: [[f64; 2]; 4], qt: [Corner; 4], out: &mut Pieces) {
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
        let mut ainv = [None; 2];
        if try_block {
            let qv = q.map(|v| v.unwrap_or([0.0; 2]));
            ainv = HALVES.map(|h| affine_inverse_norm(h.map(|i| p[i]), h.map(|i| qv[i])));
            match self.compressed(p, qv, ainv, m2, side, qt_tri(&qt, &[0, 1, 2, 3])) {
                Compressed::No => {}
                Compressed::Split => try_block = false,
                Compressed::Newton(boxes) => {
                    out.newton.extend(boxes);
                    return;
                }
            }
        }
        if try_block && self.block(p, qt, ainv, m2, out) {
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

//! The local model of [`super::match_images`] (`--model local`): each match must agree with
//! its own neighbourhood, not with one map of the whole image.
//!
//! Cells, nuclei or any objects that move independently have no common affine map or
//! homography: a global RANSAC keeps the largest group that happens to move together and
//! drops the rest. The local model instead asks, for each putative match `i` (`s_i -> d_i`):
//! *is there a smooth, orientation-preserving local map through `i` that enough of its
//! neighbours follow?*
//!
//! 1. `N_i` = the [`LocalOptions::neighbours`] matches nearest to `s_i` in image A
//!    (Euclidean distance between sources; ties by index).
//! 2. Hypotheses: for every pair `j < k` of `N_i`, the affine map through `i, j, k` (exact,
//!    [`Affine2::fit`]). A hypothesis is *plausible* when its linear part `L` keeps the
//!    orientation, `det L > 0`, and its singular values lie in
//!    `[1 / max_stretch, max_stretch]` ([`LocalOptions::max_stretch`]): a local piece of a
//!    smooth, fold-free deformation. Its support is the set of `m` in `N_i` with
//!    `|L s_m + b - d_m| <= threshold` (the RANSAC threshold, pixels). The best hypothesis
//!    has the most support, ties broken by the smaller sum of squared residuals. The search
//!    is exhaustive (`K (K - 1) / 2` hypotheses for `K` neighbours), so there is no sampling
//!    and no seed.
//! 3. The best hypothesis must be followed by at least [`LocalOptions::min_support`]
//!    matches counting `i` (with the default 4: the three that define the map and at least
//!    one more that confirms it).
//! 4. Leave one out: the least-squares affine map of the supporters alone (without `i`)
//!    must be plausible and predict `d_i` within the threshold. This is what rejects a false
//!    match whose hypothesis happens to pass near a few true matches of another object
//!    (an affine map through two close true matches and one far false match follows the
//!    true matches' motion along the line between them).
//! 5. The reported local map of `i` is the least-squares fit of `i` and its supporters (the
//!    exact hypothesis when that fit is not plausible), and `i` is kept when its residual
//!    under it is within the threshold.
//!
//! Kept matches linked by support form *groups* (connected components, by union-find): on
//! a time-lapse, roughly one group per object that moves on its own. The residual reported
//! for a kept match is the one under its refitted local map.

use super::models::{Affine2, PointModel};

/// Settings of the local model.
#[derive(Clone, Debug, PartialEq)]
pub struct LocalOptions {
    /// Neighbours of each match that may support it (default 12, at least 3).
    pub neighbours: usize,
    /// Matches (counting the match itself) that must follow its local map (default 4, at
    /// least 4: a map through three matches is always followed by those three).
    pub min_support: usize,
    /// Largest stretch (singular value, or its inverse) of a plausible local map (default 4).
    pub max_stretch: f64,
}

impl Default for LocalOptions {
    fn default() -> Self {
        Self { neighbours: 12, min_support: 4, max_stretch: 4.0 }
    }
}

/// The result of [`local_filter`].
#[derive(Clone, Debug, PartialEq)]
pub struct LocalFit {
    /// Kept matches, ascending indices.
    pub inliers: Vec<usize>,
    /// The refitted local map of each kept match (same order as `inliers`).
    pub models: Vec<Affine2>,
    /// Each kept match's residual under its local map, pixels (same order).
    pub residuals: Vec<f64>,
    /// Sizes of the groups of kept matches linked by support, largest first.
    pub groups: Vec<usize>,
}

/// Whether `a` is a plausible local piece (see the module documentation).
fn plausible(a: &Affine2, max_stretch: f64) -> bool {
    let l = a.a;
    let det = l[0][0] * l[1][1] - l[0][1] * l[1][0];
    if det.is_nan() || det <= 0.0 {
        return false;
    }
    // Singular values of a 2 x 2 matrix: s1 s2 = det, s1^2 + s2^2 = |L|_F^2.
    let f2 = l.iter().flatten().map(|v| v * v).sum::<f64>();
    let disc = (f2 * f2 - 4.0 * det * det).max(0.0).sqrt();
    let (big, small) = (((f2 + disc) / 2.0).sqrt(), ((f2 - disc) / 2.0).max(0.0).sqrt());
    big <= max_stretch && small * max_stretch >= 1.0
}

fn residual2(a: &Affine2, s: [f64; 2], d: [f64; 2]) -> f64 {
    let m = PointModel::apply(a, s);
    (m[0] - d[0]).powi(2) + (m[1] - d[1]).powi(2)
}

/// The `k` matches nearest to match `i` by source position (not `i` itself).
fn nearest(src: &[[f64; 2]], i: usize, k: usize, out: &mut Vec<(f64, usize)>) {
    out.clear();
    let p = src[i];
    out.extend(
        src.iter()
            .enumerate()
            .filter(|&(m, _)| m != i)
            .map(|(m, q)| ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2), m)),
    );
    let k = k.min(out.len());
    if k < out.len() {
        out.select_nth_unstable_by(k, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        out.truncate(k);
    }
    out.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
}

/// Keeps the matches `src[k] -> dst[k]` that agree with their neighbourhood (see the module
/// documentation); `threshold` is the inlier residual in pixels.
pub fn local_filter(
    src: &[[f64; 2]],
    dst: &[[f64; 2]],
    threshold: f64,
    opts: &LocalOptions,
) -> LocalFit {
    use rayon::prelude::*;
    let n = src.len().min(dst.len());
    let t2 = threshold * threshold;
    let k = opts.neighbours.max(3);
    let need = opts.min_support.max(4);
    // Per match: (local map, residual, supporters) when kept.
    let per: Vec<Option<(Affine2, f64, Vec<usize>)>> = (0..n)
        .into_par_iter()
        .map_init(Vec::new, |near, i| {
            nearest(&src[..n], i, k, near);
            let nb: Vec<usize> = near.iter().map(|&(_, m)| m).collect();
            let support_of = |a: &Affine2| -> (usize, f64) {
                nb.iter().fold((0, 0.0), |(c, s), &m| {
                    let r = residual2(a, src[m], dst[m]);
                    if r <= t2 {
                        (c + 1, s + r)
                    } else {
                        (c, s)
                    }
                })
            };
            let mut best: Option<(Affine2, usize, f64)> = None;
            for (x, &j) in nb.iter().enumerate() {
                for &l in &nb[x + 1..] {
                    let Some(a) =
                        Affine2::fit(&[src[i], src[j], src[l]], &[dst[i], dst[j], dst[l]])
                    else {
                        continue;
                    };
                    if !plausible(&a, opts.max_stretch) {
                        continue;
                    }
                    let (c, s) = support_of(&a);
                    if best.as_ref().is_none_or(|b| c > b.1 || (c == b.1 && s < b.2)) {
                        best = Some((a, c, s));
                    }
                }
            }
            let (hypothesis, count, _) = best?;
            if count + 1 < need {
                return None;
            }
            let members = |a: &Affine2| -> Vec<usize> {
                nb.iter().copied().filter(|&m| residual2(a, src[m], dst[m]) <= t2).collect()
            };
            // Leave one out: the supporters alone must predict match i.
            let sup = members(&hypothesis);
            let (s, d): (Vec<[f64; 2]>, Vec<[f64; 2]>) =
                sup.iter().map(|&m| (src[m], dst[m])).unzip();
            let predicted = Affine2::fit(&s, &d).filter(|a| plausible(a, opts.max_stretch))?;
            if residual2(&predicted, src[i], dst[i]) > t2 {
                return None;
            }
            // The reported map: the least-squares fit of i and its supporters.
            let (s, d): (Vec<[f64; 2]>, Vec<[f64; 2]>) =
                std::iter::once(i).chain(sup.iter().copied()).map(|m| (src[m], dst[m])).unzip();
            let model = Affine2::fit(&s, &d)
                .filter(|a| plausible(a, opts.max_stretch))
                .unwrap_or(hypothesis);
            let r2 = residual2(&model, src[i], dst[i]);
            (r2 <= t2).then(|| (model, r2.sqrt(), sup))
        })
        .collect();
    // Groups: union-find over kept matches linked by support.
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for (i, kept) in per.iter().enumerate() {
        let Some((_, _, sup)) = kept else { continue };
        for &m in sup {
            if per[m].is_some() {
                let (a, b) = (find(&mut parent, i), find(&mut parent, m));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    let mut fit = LocalFit { inliers: vec![], models: vec![], residuals: vec![], groups: vec![] };
    let mut sizes = vec![0usize; n];
    for (i, kept) in per.into_iter().enumerate() {
        let Some((model, r, _)) = kept else { continue };
        fit.inliers.push(i);
        fit.models.push(model);
        fit.residuals.push(r);
        sizes[find(&mut parent, i)] += 1;
    }
    fit.groups = sizes.into_iter().filter(|&s| s > 0).collect();
    fit.groups.sort_unstable_by(|a, b| b.cmp(a));
    fit
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// Three "cells" that move independently (two translations and a rotation), plus gross
    /// outliers: the local filter keeps every cell's matches and drops the outliers.
    #[test]
    fn independent_motions_are_all_kept_and_outliers_dropped() {
        let mut rng = SplitMix64::new(7);
        let mut u =
            |lo: f64, hi: f64| lo + (hi - lo) * (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let cells: [([f64; 2], Affine2); 3] = [
            ([100.0, 100.0], Affine2 { a: Affine2::IDENTITY.a, b: [14.0, -3.0] }),
            ([300.0, 120.0], Affine2 { a: Affine2::IDENTITY.a, b: [-30.0, 26.0] }),
            ([200.0, 320.0], Affine2 { a: [[0.98, -0.17], [0.17, 0.98]], b: [58.0, -28.0] }),
        ];
        let (mut src, mut dst, mut truth) = (vec![], vec![], vec![]);
        for (c, (centre, map)) in cells.iter().enumerate() {
            for _ in 0..10 {
                let p = [centre[0] + u(-25.0, 25.0), centre[1] + u(-25.0, 25.0)];
                src.push(p);
                dst.push(map.apply(p));
                truth.push(Some(c));
            }
        }
        for _ in 0..8 {
            let p = [u(0.0, 400.0), u(0.0, 400.0)];
            src.push(p);
            dst.push([u(0.0, 400.0), u(0.0, 400.0)]);
            truth.push(None);
        }
        let fit = local_filter(&src, &dst, 3.0, &LocalOptions::default());
        let expected: Vec<usize> = (0..src.len()).filter(|&k| truth[k].is_some()).collect();
        assert_eq!(fit.inliers, expected);
        assert_eq!(fit.groups, vec![10, 10, 10]);
        assert!(fit.residuals.iter().all(|&r| r < 1e-9), "{:?}", fit.residuals);
        // A global affine RANSAC cannot follow three independent motions.
        let (_, global) =
            super::super::models::ransac_affine(&src, &dst, &Default::default()).unwrap();
        assert!(global.len() <= 20, "{}", global.len());
    }

    /// A mirrored or strongly stretched neighbourhood is not a plausible local map.
    #[test]
    fn folds_and_stretches_are_implausible() {
        let id = Affine2::IDENTITY;
        assert!(plausible(&id, 4.0));
        let mirror = Affine2 { a: [[-1.0, 0.0], [0.0, 1.0]], b: [0.0, 0.0] };
        assert!(!plausible(&mirror, 4.0));
        let stretch = Affine2 { a: [[5.0, 0.0], [0.0, 1.0]], b: [0.0, 0.0] };
        assert!(!plausible(&stretch, 4.0) && plausible(&stretch, 5.0));
        let squash = Affine2 { a: [[0.2, 0.0], [0.0, 1.0]], b: [0.0, 0.0] };
        assert!(!plausible(&squash, 4.0));
    }

    /// A match with fewer than `min_support - 1` followers is dropped, even if exact.
    #[test]
    fn lonely_matches_are_dropped() {
        let src = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]];
        let dst = src;
        assert!(local_filter(&src, &dst, 3.0, &LocalOptions::default()).inliers.is_empty());
        let four = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]];
        let fit = local_filter(&four, &four, 3.0, &LocalOptions::default());
        assert_eq!(fit.inliers, vec![0, 1, 2, 3]);
        assert_eq!(fit.groups, vec![4]);
    }
}

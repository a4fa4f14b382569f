//! The landmarks' least-squares affine map, and landmark pairs that cross each other.
//!
//! `A = argmin sum_i w_i |A s_i - t_i|^2` (6 unknowns, solved from the centred 3 x 3 normal
//! equations per coordinate). A pair of nearby landmarks *crosses* when its target vector
//! points against the affine map's image of its source vector,
//! `(t_j - t_i) . L (s_j - s_i) < 0` (`L` the linear part of `A`): the pair's order along
//! that direction is reversed, which no map close to `A` achieves without folding between
//! them. Such pairs are what a fit with the fold barrier cannot follow; [`crossing_pairs`]
//! names them.

use super::error::FitError;
use super::landmarks::Landmark;

/// The weighted least-squares affine map of the landmarks, or why there is none (fewer than
/// three, or all sources on one line).
pub fn affine_ls(lms: &[Landmark]) -> Result<[[f64; 3]; 2], FitError> {
    if lms.is_empty() {
        return Err(FitError::NoLandmarks);
    }
    if lms.len() < 3 {
        return Err(FitError::Landmarks(format!(
            "{} landmark{}: a fit without a given deformation needs at least 3 landmarks not \
             on one line",
            lms.len(),
            if lms.len() == 1 { "" } else { "s" }
        )));
    }
    // Centre for conditioning, then solve the 3x3 normal equations per coordinate.
    let sw: f64 = lms.iter().map(|l| l.weight).sum();
    let c = [0, 1].map(|a| lms.iter().map(|l| l.weight * l.src[a]).sum::<f64>() / sw);
    let mut n = [[0.0f64; 2]; 2];
    let mut r = [[0.0f64; 2]; 2];
    let mut tbar = [0.0f64; 2];
    for l in lms {
        let u = [l.src[0] - c[0], l.src[1] - c[1]];
        for a in 0..2 {
            tbar[a] += l.weight * l.dst[a] / sw;
            for b in 0..2 {
                n[a][b] += l.weight * u[a] * u[b];
            }
        }
    }
    for l in lms {
        let u = [l.src[0] - c[0], l.src[1] - c[1]];
        for k in 0..2 {
            for a in 0..2 {
                r[k][a] += l.weight * (l.dst[k] - tbar[k]) * u[a];
            }
        }
    }
    let det = n[0][0] * n[1][1] - n[0][1] * n[1][0];
    let scale = n[0][0] + n[1][1];
    if det.is_nan() || det <= 1e-9 * scale * scale {
        return Err(FitError::Landmarks(
            "all landmark sources lie on one line, so they determine no map of the plane; \
             add landmarks off that line"
                .into(),
        ));
    }
    let inv = [[n[1][1] / det, -n[0][1] / det], [-n[1][0] / det, n[0][0] / det]];
    let mut a = [[0.0f64; 3]; 2];
    for k in 0..2 {
        for j in 0..2 {
            a[k][j] = r[k][0] * inv[0][j] + r[k][1] * inv[1][j];
        }
        a[k][2] = tbar[k] - a[k][0] * c[0] - a[k][1] * c[1];
    }
    Ok(a)
}

/// The weighted least-squares affine map of the landmarks (see [`affine_ls`]), refused when
/// it reverses orientation (a mirror image).
pub fn affine_fit(lms: &[Landmark]) -> Result<[[f64; 3]; 2], FitError> {
    let a = affine_ls(lms)?;
    let da = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    if da.is_nan() || da <= 0.0 {
        return Err(FitError::Landmarks(format!(
            "the landmarks' best affine map reverses orientation (determinant {da:.3}): the \
             targets are a mirror image of the sources; flip the image or fix the landmark \
             columns"
        )));
    }
    Ok(a)
}

/// How many nearest neighbours of each landmark [`crossing_pairs`] examines.
pub const CROSSING_NEIGHBOURS: usize = 6;

/// Nearby landmark pairs `(i, j)`, `i < j`, that cross each other (see the module docs):
/// each landmark against its [`CROSSING_NEIGHBOURS`] nearest sources. Empty when the
/// landmarks have no affine map.
pub fn crossing_pairs(lms: &[Landmark]) -> Vec<(usize, usize)> {
    let Ok(mut a) = affine_ls(lms) else { return Vec::new() };
    // A mirrored least-squares map (the crossing pairs themselves can flip it) says nothing
    // about the order to keep: compare with the identity then.
    if a[0][0] * a[1][1] - a[0][1] * a[1][0] <= 0.0 {
        a = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    }
    let src: Vec<[f64; 2]> = lms.iter().map(|l| l.src).collect();
    let mut out = Vec::new();
    for (i, near) in nearest_neighbours(&src, CROSSING_NEIGHBOURS).into_iter().enumerate() {
        let li = &lms[i];
        for &(dist, j) in &near {
            if dist == 0.0 {
                continue;
            }
            let lj = &lms[j];
            let ds = [lj.src[0] - li.src[0], lj.src[1] - li.src[1]];
            let ls = [a[0][0] * ds[0] + a[0][1] * ds[1], a[1][0] * ds[0] + a[1][1] * ds[1]];
            let dt = [lj.dst[0] - li.dst[0], lj.dst[1] - li.dst[1]];
            if dt[0] * ls[0] + dt[1] * ls[1] < 0.0 {
                out.push((i.min(j), i.max(j)));
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// For each point, its `k` nearest other points as `(squared distance, index)`, nearest
/// first, ties broken by index: the same lists as sorting all the others by
/// `(distance, index)` and keeping `k`, found through a uniform grid of about four points
/// per cell (or per cell along a line of points). Around each point the search grows ring by ring of cells; once the `k`-th
/// squared distance is below `(r s)^2` (`s` the cell size, `r` the rings searched), no point
/// outside them can come nearer, since each lies at least `r s` away. Linear in the number
/// of points for spread points (a full sort per point was quadratic: 100,000 landmarks took
/// minutes).
fn nearest_neighbours(p: &[[f64; 2]], k: usize) -> Vec<Vec<(f64, usize)>> {
    let n = p.len();
    if n == 0 || k == 0 {
        return vec![Vec::new(); n];
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for q in p {
        for c in 0..2 {
            lo[c] = lo[c].min(q[c]);
            hi[c] = hi[c].max(q[c]);
        }
    }
    let (w, h) = ((hi[0] - lo[0]).max(1e-9), (hi[1] - lo[1]).max(1e-9));
    // About four points per cell, spread over an area or along a line.
    let s = (4.0 * w * h / n as f64).sqrt().max(4.0 * w.max(h) / n as f64);
    let (nx, ny) = ((w / s).floor() as usize + 1, (h / s).floor() as usize + 1);
    let cell = |q: &[f64; 2]| {
        (((q[0] - lo[0]) / s).floor() as usize).min(nx - 1)
            + nx * (((q[1] - lo[1]) / s).floor() as usize).min(ny - 1)
    };
    // Points bucketed by cell (counting sort).
    let mut start = vec![0usize; nx * ny + 1];
    for q in p {
        start[cell(q) + 1] += 1;
    }
    for c in 0..nx * ny {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut order = vec![0usize; n];
    for (i, q) in p.iter().enumerate() {
        let c = cell(q);
        order[fill[c]] = i;
        fill[c] += 1;
    }
    let by = |x: &(f64, usize), y: &(f64, usize)| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1));
    let mut out = Vec::with_capacity(n);
    let mut near: Vec<(f64, usize)> = Vec::new();
    for (i, q) in p.iter().enumerate() {
        let c = cell(q);
        let (cx, cy) = ((c % nx) as i64, (c / nx) as i64);
        near.clear();
        let mut r = 0i64;
        loop {
            // The cells of ring r around (cx, cy), inside the grid: its top and bottom rows,
            // then its left and right columns between them.
            let mut visit = |gx: i64, gy: i64| {
                if gx < 0 || gy < 0 || gx >= nx as i64 || gy >= ny as i64 {
                    return;
                }
                let g = gx as usize + nx * gy as usize;
                for &j in &order[start[g]..start[g + 1]] {
                    if j != i {
                        let d = [p[j][0] - q[0], p[j][1] - q[1]];
                        near.push((d[0] * d[0] + d[1] * d[1], j));
                    }
                }
            };
            let (x0, x1) = ((cx - r).max(0), (cx + r).min(nx as i64 - 1));
            for gy in [cy - r, cy + r].into_iter().take(if r == 0 { 1 } else { 2 }) {
                for gx in x0..=x1 {
                    visit(gx, gy);
                }
            }
            for gy in (cy - r + 1).max(0)..=(cy + r - 1).min(ny as i64 - 1) {
                visit(cx - r, gy);
                visit(cx + r, gy);
            }
            let everything = r >= nx.max(ny) as i64;
            if near.len() >= k {
                near.select_nth_unstable_by(k - 1, by);
                near.truncate(k);
                let reach = r as f64 * s;
                if everything || near[k - 1].0 < reach * reach {
                    break;
                }
            } else if everything {
                break;
            }
            r += 1;
        }
        near.sort_by(by);
        out.push(near.clone());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lm(s: [f64; 2], t: [f64; 2]) -> Landmark {
        Landmark { name: None, src: s, dst: t, weight: 1.0 }
    }

    #[test]
    fn a_swapped_pair_crosses_and_a_smooth_field_does_not() {
        let mut lms = vec![
            lm([200.0, 120.0], [260.0, 120.0]),
            lm([240.0, 120.0], [190.0, 120.0]),
            lm([50.0, 50.0], [50.0, 50.0]),
            lm([450.0, 200.0], [450.0, 200.0]),
            lm([60.0, 220.0], [61.0, 221.0]),
        ];
        assert_eq!(crossing_pairs(&lms), vec![(0, 1)]);
        lms[1].dst = [245.0, 121.0];
        lms[0].dst = [203.0, 119.0];
        assert!(crossing_pairs(&lms).is_empty());
    }

    /// The partial selection of the nearest neighbours finds the pairs a full sort by
    /// distance finds (the implementation before it), on noisy landmarks with swapped
    /// targets and on a lattice, where many distances tie.
    #[test]
    fn nearest_neighbour_selection_matches_a_full_sort() {
        use rand::{rngs::SmallRng, Rng, SeedableRng};
        let reference = |lms: &[Landmark]| {
            let Ok(mut a) = affine_ls(lms) else { return Vec::new() };
            if a[0][0] * a[1][1] - a[0][1] * a[1][0] <= 0.0 {
                a = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
            }
            let mut out = Vec::new();
            for (i, li) in lms.iter().enumerate() {
                let mut near: Vec<(f64, usize)> = lms
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(j, lj)| ((lj.src[0] - li.src[0]).hypot(lj.src[1] - li.src[1]), j))
                    .collect();
                near.sort_by(|x, y| x.0.total_cmp(&y.0));
                for &(dist, j) in near.iter().take(CROSSING_NEIGHBOURS) {
                    let lj = &lms[j];
                    let ds = [lj.src[0] - li.src[0], lj.src[1] - li.src[1]];
                    let ls = [a[0][0] * ds[0] + a[0][1] * ds[1], a[1][0] * ds[0] + a[1][1] * ds[1]];
                    let dt = [lj.dst[0] - li.dst[0], lj.dst[1] - li.dst[1]];
                    if dist != 0.0 && dt[0] * ls[0] + dt[1] * ls[1] < 0.0 {
                        out.push((i.min(j), i.max(j)));
                    }
                }
            }
            out.sort_unstable();
            out.dedup();
            out
        };
        let mut rng = SmallRng::seed_from_u64(9);
        for trial in 0..20 {
            let n = 3 + trial * 7;
            let lattice = trial % 2 == 1;
            let mut lms: Vec<Landmark> = (0..n)
                .map(|i| {
                    let s = if lattice {
                        [(i % 6) as f64 * 10.0, (i / 6) as f64 * 10.0]
                    } else {
                        [rng.gen_range(0.0..300.0), rng.gen_range(0.0..200.0)]
                    };
                    lm(s, [s[0] + rng.gen_range(-4.0..4.0), s[1] + rng.gen_range(-4.0..4.0)])
                })
                .collect();
            for _ in 0..n / 5 {
                let (i, j) = (rng.gen_range(0..n), rng.gen_range(0..n));
                let t = lms[i].dst;
                lms[i].dst = lms[j].dst;
                lms[j].dst = t;
            }
            assert_eq!(crossing_pairs(&lms), reference(&lms), "trial {trial}");
        }
    }

    /// The grid search finds exactly the lists a full sort finds: spread points, clusters,
    /// duplicates, a line, and fewer points than neighbours asked for.
    #[test]
    fn grid_nearest_neighbours_equal_a_full_sort() {
        use rand::{rngs::SmallRng, Rng, SeedableRng};
        let brute = |p: &[[f64; 2]], k: usize| -> Vec<Vec<(f64, usize)>> {
            (0..p.len())
                .map(|i| {
                    let mut v: Vec<(f64, usize)> = (0..p.len())
                        .filter(|&j| j != i)
                        .map(|j| ((p[j][0] - p[i][0]).powi(2) + (p[j][1] - p[i][1]).powi(2), j))
                        .collect();
                    v.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                    v.truncate(k);
                    v
                })
                .collect()
        };
        let mut rng = SmallRng::seed_from_u64(5);
        let mut sets: Vec<Vec<[f64; 2]>> = vec![
            vec![],
            vec![[1.0, 1.0]],
            vec![[1.0, 1.0], [1.0, 1.0], [2.0, 3.0]],
            (0..50).map(|i| [i as f64 * 3.0, 7.0]).collect(),
        ];
        for _ in 0..6 {
            let n = rng.gen_range(10..400);
            sets.push(
                (0..n)
                    .map(|i| {
                        if i % 3 == 0 {
                            // A tight cluster, with exact duplicates.
                            [500.0 + (i % 7) as f64 * 0.25, 40.0 + (i % 5) as f64 * 0.25]
                        } else {
                            [rng.gen_range(0.0..4096.0), rng.gen_range(0.0..300.0)]
                        }
                    })
                    .collect(),
            );
        }
        for (t, p) in sets.iter().enumerate() {
            for k in [1, 6, 20] {
                assert_eq!(nearest_neighbours(p, k), brute(p, k), "set {t}, k {k}");
            }
        }
    }

    #[test]
    fn the_affine_map_of_affine_landmarks_is_exact() {
        let f = |p: [f64; 2]| [1.1 * p[0] - 0.2 * p[1] + 3.0, 0.3 * p[0] + 0.9 * p[1] - 1.0];
        let lms: Vec<Landmark> = [[0.0, 0.0], [10.0, 0.0], [0.0, 7.0], [5.0, 5.0]]
            .iter()
            .map(|&p| lm(p, f(p)))
            .collect();
        let a = affine_fit(&lms).unwrap();
        let want = [[1.1, -0.2, 3.0], [0.3, 0.9, -1.0]];
        for r in 0..2 {
            for c in 0..3 {
                assert!((a[r][c] - want[r][c]).abs() < 1e-12, "{a:?}");
            }
        }
    }
}

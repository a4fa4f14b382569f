//! The certified inverse on hard maps (issue 18): a folded map and a strongly bent one,
//! checked pixel by pixel against Newton's method, and the seeds of the Newton fallback.

use super::*;
use crate::warp::inverse::InverseOptions;

/// The maps written by `examples/warp_maps.rs` (see its doc comment).
fn load(name: &str) -> Spline {
    let text = match name {
        "folded" => include_str!("../../../tests/data/warp_folded_150x225.json"),
        _ => include_str!("../../../tests/data/warp_bent_2048.json"),
    };
    crate::io::deformation::from_str(text).expect("test map").0
}

/// Every band of the plan: preimages, fold mask, statistics.
fn fill_all(plan: &RemapPlan<'_>) -> (Vec<[f64; 2]>, Vec<bool>, RemapStats) {
    let (w, h) = plan.size();
    let n = w as usize * h as usize;
    let (mut pos, mut folds) = (vec![[0.0; 2]; n], vec![false; n]);
    let band = plan.band_rows() as usize * w as usize;
    let mut st = RemapStats::default();
    for (b, (p, f)) in pos.chunks_mut(band).zip(folds.chunks_mut(band)).enumerate() {
        st.merge(&plan.fill_band_folds(b, p, Some(f)));
    }
    (pos, folds, st)
}

/// For every `step`-th pixel with a certified preimage `p~` (not drawn from a folded piece),
/// Newton's method started at `p~` converges to a preimage `p*` with `|p~ - p*| <= tol`
/// (plus Newton's own bound); pixels without a preimage have none for per-pixel Newton
/// either, unless their centre is within `2 tol` of the deformed border. Returns the number of
/// pixels checked.
fn check_bound(s: &Spline, w: u32, h: u32, step: usize) -> (RemapStats, usize) {
    check_plan(s, &RemapPlan::new(s, w, h, RemapOptions::default()), step)
}

/// [`check_bound`] for a given plan of `s`.
fn check_plan(s: &Spline, plan: &RemapPlan<'_>, step: usize) -> (RemapStats, usize) {
    let tol = 0.01;
    let w = plan.size().0;
    let (pos, folds, st) = fill_all(plan);
    assert!(st.max_error_bound <= tol, "{st:?}");
    let map = InverseMap::new(s, InverseOptions { tolerance: 1e-6, ..Default::default() });
    let mut checked = 0;
    for k in (0..pos.len()).step_by(step) {
        let q = [(k % w as usize) as f64, (k / w as usize) as f64];
        let f = pos[k];
        if f[0].is_nan() {
            if let Some(n) = map.invert(q, None) {
                // Only next to the deformed border: a nudge of 2 tol loses the preimage.
                let near =
                    [[2.0 * tol, 0.0], [-2.0 * tol, 0.0], [0.0, 2.0 * tol], [0.0, -2.0 * tol]]
                        .iter()
                        .any(|d| map.invert([q[0] + d[0], q[1] + d[1]], Some(&n)).is_none());
                assert!(near, "{q:?}: no fast preimage, Newton finds {:?}", n.p);
            }
            continue;
        }
        if folds[k] {
            continue;
        }
        let Some(n) = map.invert_from(q, f, None) else {
            // Outside the deformed border by less than the tolerance (Newton's fallback at
            // the default tolerance accepts a point on the border): `f` is within `2 tol` of
            // the reference border, and `phi(f)` within the tolerance of `q`.
            let m = s.mesh();
            let near = [[2.0 * tol, 0.0], [-2.0 * tol, 0.0], [0.0, 2.0 * tol], [0.0, -2.0 * tol]]
                .iter()
                .any(|d| m.locate([f[0] + d[0], f[1] + d[1]], None).is_none());
            let (t, b) = m.locate(f, None).expect("fast preimage inside the mesh");
            let (v, j) = (s.eval_cache().value(t, b), s.eval_cache().jacobian(t, b));
            let det = (j[0][0] * j[1][1] - j[0][1] * j[1][0]).abs();
            let jinv = j.iter().flatten().map(|x| x * x).sum::<f64>().sqrt() / det;
            let e = (v[0] - q[0]).hypot(v[1] - q[1]) * jinv;
            assert!(near && e <= 2.0 * tol, "{q:?}: Newton from {f:?} fails, {e} px off");
            continue;
        };
        let e = (f[0] - n.p[0]).hypot(f[1] - n.p[1]);
        assert!(e <= tol + n.error_bound, "{q:?}: {f:?} vs {:?} ({e})", n.p);
        checked += 1;
    }
    (st, checked)
}

#[test]
fn folded_map_meets_the_bound_outside_the_fold() {
    let s = load("folded");
    let (st, checked) = check_bound(&s, 150, 225, 1);
    assert!(st.folded > 0 && st.fold_box.is_some(), "{st:?}");
    assert!(checked > 15_000, "{checked}");
}

/// Issue 18: the folded map once left whole regions to per-pixel Newton (0.6 s for
/// 150 x 225), each from unrelated seeds; now Newton solves the pixels next to the crease
/// and those of strongly compressed pieces, and almost all of them from the piece's affine
/// inverse.
#[test]
fn folded_map_leaves_few_pixels_to_newton() {
    let s = load("folded");
    let plan = RemapPlan::new(&s, 150, 225, RemapOptions::default());
    let (_, _, st) = fill_all(&plan);
    assert!(st.newton_solves - st.newton_compressed + st.newton_failed <= st.pixels / 20, "{st:?}");
    assert!(st.newton_seeded * 100 >= st.newton_solves * 99, "{st:?}");
    assert!(st.newton_compressed > 1000, "{st:?}");
    assert_eq!(st.interpolated + st.newton_solves + st.outside, st.pixels);
}

/// Issue 18: where `phi` compresses, a block needs several forward evaluations per output
/// pixel; those pixels now go to Newton (seeded from the square's affine inverse). The
/// plan has less than half the block points it had, and the same pixels have preimages.
#[test]
fn compressed_pieces_go_to_newton_and_lose_no_pixel() {
    let s = load("folded");
    let opts = RemapOptions::default();
    let (fast, slow) =
        (RemapPlan::new(&s, 150, 225, opts), RemapPlan::without_compressed(&s, 150, 225, opts));
    let points = |p: &RemapPlan<'_>| p.rows.iter().map(|r| r.pool.len()).sum::<usize>();
    assert!(points(&fast) * 2 < points(&slow), "{} vs {}", points(&fast), points(&slow));
    let ((a, fa, sa), (b, fb, sb)) = (fill_all(&fast), fill_all(&slow));
    assert_eq!(sb.newton_compressed, 0);
    assert!(sa.max_error_bound <= 0.01 && sb.max_error_bound <= 0.01, "{sa:?} {sb:?}");
    for k in 0..a.len() {
        // The bug this names: a pixel of a compressed box first tried (and failed) from a
        // border piece's far seed was left without a preimage; compressed boxes go first.
        assert_eq!(a[k][0].is_nan(), b[k][0].is_nan(), "pixel {}, {}", k % 150, k / 150);
        // Where neither shows a fold, the two preimages are the same point up to the bound
        // (a fold's layers may differ: a rasterized layer covers a Newton one).
        if !a[k][0].is_nan() && !fa[k] && !fb[k] && (a[k][0] - b[k][0]).abs() < 1.0 {
            assert!((a[k][0] - b[k][0]).hypot(a[k][1] - b[k][1]) <= 0.02, "pixel {k}");
        }
    }
}

/// A reversed compressed piece solved by Newton counts and marks its pixels as folded:
/// with those pieces as the plan's only Newton boxes, the pixels they give a preimage (that
/// the rasterized pieces do not) are marked.
#[test]
fn reversed_compressed_pieces_are_marked_folded() {
    let s = load("folded");
    let mut plan = RemapPlan::new(&s, 150, 225, RemapOptions::default());
    let reversed = |b: &NewtonBox| b.compressed && b.folded;
    let reversed = &reversed;
    assert!(plan.rows.iter().flat_map(|r| &r.newton).any(reversed));
    // Newton boxes of reversed compressed pieces only, then none.
    for r in &mut plan.rows {
        r.newton.retain(reversed);
    }
    let (pos, folds, st) = fill_all(&plan);
    for r in &mut plan.rows {
        r.newton.clear();
    }
    let (without, _, _) = fill_all(&plan);
    let only: Vec<usize> =
        (0..pos.len()).filter(|&k| !pos[k][0].is_nan() && without[k][0].is_nan()).collect();
    assert!(!only.is_empty());
    for k in only {
        assert!(folds[k], "pixel {}, {} not marked: {st:?}", k % 150, k / 150);
    }
}

#[test]
fn bent_map_meets_the_bound_against_per_pixel_newton() {
    let s = load("bent");
    // A prime stride samples every row and column phase.
    let (st, checked) = check_bound(&s, 2048, 2048, 211);
    assert_eq!(st.folded, 0);
    assert!(checked > 19_000, "{checked}");
    // And the fast preimages are the per-pixel Newton solutions from scratch.
    let plan = RemapPlan::new(&s, 2048, 2048, RemapOptions::default());
    let mut band = vec![[0.0; 2]; plan.band_rows() as usize * 2048];
    let map = InverseMap::new(&s, InverseOptions::default());
    for b in [0, 17, plan.num_bands() - 1] {
        plan.fill_band(b, &mut band);
        for (k, f) in band.iter().enumerate().step_by(97) {
            let q = [(k % 2048) as f64, (b * plan.band_rows() as usize + k / 2048) as f64];
            match map.invert(q, None) {
                Some(n) => assert!((f[0] - n.p[0]).hypot(f[1] - n.p[1]) <= 0.02, "{q:?}"),
                None => assert!(f[0].is_nan() || q[0] < 60.0 || q[0] > 1988.0, "{q:?}"),
            }
        }
    }
}

#[test]
fn the_affine_seed_inverts_its_triangle() {
    let p = [[1.0, 2.0], [4.0, 2.5], [1.5, 6.0]];
    let q = [[10.0, -3.0], [13.0, -1.0], [9.0, 2.0]];
    let seed = Seed::affine(p, q, Some(3));
    for i in 0..3 {
        let v = seed.at(q[i]);
        assert!((v[0] - p[i][0]).abs() < 1e-12 && (v[1] - p[i][1]).abs() < 1e-12, "{v:?}");
    }
    let mid = seed.at([(q[0][0] + q[1][0]) / 2.0, (q[0][1] + q[1][1]) / 2.0]);
    assert!((mid[0] - 2.5).abs() < 1e-12 && (mid[1] - 2.25).abs() < 1e-12);
    // A degenerate image falls back to the first corner.
    let flat = Seed::affine(p, [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], None);
    assert_eq!(flat.at([5.0, 7.0]), p[0]);
}

/// Issue 18 (no allocation per band): one [`BandScratch`] reused over every band, in an
/// order that alternates bands with folds and Newton boxes and bands without, gives exactly
/// what a fresh buffer per band gives (no stale fold mask or Newton marks).
#[test]
fn reused_band_buffers_give_the_same_preimages_as_fresh_ones() {
    let s = load("folded");
    let plan = RemapPlan::new(&s, 150, 225, RemapOptions { band_rows: 8, ..Default::default() });
    let (fresh, fresh_folds, fresh_st) = fill_all(&plan);
    assert!(fresh_st.folded > 0 && fresh_st.newton_solves > 0, "{fresh_st:?}");
    let w = 150usize;
    let band = plan.band_rows() as usize * w;
    let (mut pos, mut folds) = (vec![[0.0; 2]; fresh.len()], vec![true; fresh.len()]);
    let mut scratch = BandScratch::default();
    let mut st = RemapStats::default();
    let n = plan.num_bands();
    // Odd bands from the bottom up, then even bands from the top down.
    let order: Vec<usize> = (1..n).step_by(2).rev().chain((0..n).step_by(2)).collect();
    let mut seen = vec![false; n];
    for b in order {
        seen[b] = true;
        let (lo, hi) = (b * band, ((b + 1) * band).min(fresh.len()));
        st.merge(&plan.fill_band_with(b, &mut pos[lo..hi], Some(&mut folds[lo..hi]), &mut scratch));
    }
    assert!(seen.iter().all(|&v| v));
    assert_eq!(st, fresh_st);
    assert_eq!(folds, fresh_folds);
    for (k, (a, b)) in pos.iter().zip(&fresh).enumerate() {
        assert!(a == b || (a[0].is_nan() && b[0].is_nan()), "pixel {k}: {a:?} vs {b:?}");
    }
}

use crate::spline::tests::blend_with_identity;

/// Issue 17: a morph frame's plan reuses the fitted map's curvature bounds, scaled by the
/// shape weight. The plan still meets the bound pixel by pixel (against Newton), and is as
/// tight as a fresh one: the same pieces up to the rounding margin, so (almost) the same
/// pixels interpolated.
#[test]
fn scaled_curvature_bounds_of_a_blend_meet_the_bound_and_are_tight() {
    let psi = load("bent");
    let base = CurvatureBounds::new(&psi);
    let o = RemapOptions::default();
    for (n, d) in [(1i64, 2i64), (9, 10), (1, 5)] {
        let f = crate::exact::Rat::new(n.into(), d.into());
        let s = blend_with_identity(&psi, &f);
        let plan = RemapPlan::new_scaled(&s, 1024, 1024, o, &base, n as f64 / d as f64);
        let (st, checked) = check_plan(&s, &plan, 97);
        assert!(checked > 10_000 && st.folded == 0, "{n}/{d}: {checked} {st:?}");
        let (_, _, fst) = fill_all(&RemapPlan::new(&s, 1024, 1024, o));
        let slack = st.pixels / 1000;
        assert!(st.interpolated + slack >= fst.interpolated, "{n}/{d}: {st:?} vs {fst:?}");
        assert!(st.newton_solves <= fst.newton_solves + slack, "{n}/{d}: {st:?} vs {fst:?}");
    }
}

/// A spline that is not a multiple of the base plus an affine map gets a large excess
/// bound: the plan is coarser but still certified.
#[test]
fn scaled_curvature_bounds_stay_certified_for_an_unrelated_map() {
    let psi = load("folded");
    let base = CurvatureBounds::new(&psi);
    let plan = RemapPlan::new_scaled(&psi, 150, 225, RemapOptions::default(), &base, 0.0);
    let (st, checked) = check_plan(&psi, &plan, 1);
    assert!(st.folded > 0 && checked > 10_000, "{st:?} {checked}");
}

/// On another mesh the base's bounds do not apply: the plan is a fresh one.
#[test]
fn scaled_curvature_bounds_of_another_mesh_give_a_fresh_plan() {
    let base = CurvatureBounds::new(&load("bent"));
    let s = load("folded");
    let plan = RemapPlan::new_scaled(&s, 150, 225, RemapOptions::default(), &base, 0.5);
    let fresh = RemapPlan::new(&s, 150, 225, RemapOptions::default());
    let (a, b) = (fill_all(&plan), fill_all(&fresh));
    assert_eq!(
        a.0.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>(),
        b.0.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>()
    );
    assert_eq!(a.1, b.1);
}

/// Issue 18 (found on issue 17's morph frames): on the blend `(id + folded) / 2` a fresh
/// plan left pixel (108, 145) without a preimage, although Newton finds one at (128, 147):
/// its centre lay in the sliver between a lattice square's edge and the finer polygon of its
/// split neighbour along the same edge (a T-junction). Such pixels are now found by growing
/// each piece by its gap width and solved by Newton from the piece's affine inverse; every
/// pixel of the blends meets the bound against per-pixel Newton.
#[test]
fn t_junction_gaps_between_pieces_are_solved() {
    let folded = load("folded");
    let mut gaps = 0;
    for (n, d) in [(1i64, 2i64), (1, 3), (3, 4)] {
        let s = blend_with_identity(&folded, &crate::exact::Rat::new(n.into(), d.into()));
        let plan = RemapPlan::new(&s, 150, 225, RemapOptions::default());
        let (pos, _, st) = fill_all(&plan);
        if (n, d) == (1, 2) {
            let p = pos[145 * 150 + 108];
            assert!((p[0] - 128.0).hypot(p[1] - 147.0) <= 0.02, "{p:?} {st:?}");
        }
        gaps += st.newton_gaps;
        assert!(st.newton_gaps <= st.newton_seeded && st.newton_seeded <= st.newton_solves);
        let (st, checked) = check_plan(&s, &plan, 1);
        assert!(checked > 20_000, "{n}/{d}: {checked} {st:?}");
    }
    assert!(gaps > 0);
}

/// Issue 18: the AVX2 build of `fill_rect` (what `fill_rect` runs on this machine) gives
/// bit for bit the preimages, fold marks and statistics of the portable build, on the
/// folded map (folds, Newton boxes, gaps) and the bent one, in bands and in windows.
#[test]
fn avx2_fill_equals_the_portable_fill_bit_for_bit() {
    #[cfg(target_arch = "x86_64")]
    {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        for (name, w, h) in [("folded", 150u32, 225u32), ("bent", 2048, 2048)] {
            let s = load(name);
            let plan = RemapPlan::new(&s, w, h, RemapOptions::default());
            let rects = [
                Rect { x0: 0, y0: 0, w, h: plan.band_rows().min(h) },
                Rect { x0: 0, y0: h / 2, w, h: plan.band_rows().min(h - h / 2) },
                Rect { x0: w / 3, y0: h / 5, w: w / 2, h: 40 },
            ];
            for r in rects {
                let n = (r.w * r.h) as usize;
                let (mut a, mut b) = (vec![[0.0; 2]; n], vec![[1.0; 2]; n]);
                let (mut fa, mut fb) = (vec![false; n], vec![true; n]);
                let (mut sa, mut sb) = (BandScratch::default(), BandScratch::default());
                // SAFETY: AVX2 was detected above.
                let st_a = unsafe { plan.fill_rect_avx2(r, &mut a, Some(&mut fa), &mut sa) };
                let st_b = plan.fill_rect_any(r, &mut b, Some(&mut fb), &mut sb);
                assert_eq!(st_a, st_b, "{name} {r:?}");
                assert!(st_a.pixels > 0 && st_a.interpolated > 0, "{name} {r:?}: {st_a:?}");
                assert_eq!(fa, fb, "{name} {r:?}");
                let bits = |v: &[[f64; 2]]| -> Vec<u64> {
                    v.iter().flat_map(|p| [p[0].to_bits(), p[1].to_bits()]).collect()
                };
                assert!(bits(&a) == bits(&b), "{name} {r:?}: preimages differ");
            }
        }
    }
}

/// Issue 18: skipping the gap search on the edges two whole-square blocks share
/// (`mark_conforming`) changes nothing: the same preimages bit for bit, fold marks and
/// statistics as a plan that searches every outer edge, on the blends of the folded map
/// (T-junction gaps do occur there), the folded map and the bent one; and the skip is taken.
#[test]
fn shared_whole_square_edges_need_no_gap_search() {
    let folded = load("folded");
    let half = blend_with_identity(&folded, &crate::exact::Rat::new(1.into(), 2.into()));
    let bent = load("bent");
    let mut skipped = 0;
    for (s, w, h) in [(&half, 150u32, 225u32), (&folded, 150, 225), (&bent, 2048, 2048)] {
        let plan = RemapPlan::new(s, w, h, RemapOptions::default());
        let mut searched = RemapPlan::new(s, w, h, RemapOptions::default());
        for b in searched.rows.iter_mut().flat_map(|r| r.blocks.iter_mut()) {
            skipped += b.conform.iter().filter(|&&c| c).count();
            b.conform = [false; 4];
        }
        let (pos, folds, st) = fill_all(&plan);
        let (pos_all, folds_all, st_all) = fill_all(&searched);
        assert_eq!(st, st_all, "{w}x{h}");
        assert_eq!(folds, folds_all, "{w}x{h}");
        let bits = |v: &[[f64; 2]]| -> Vec<u64> {
            v.iter().flat_map(|p| [p[0].to_bits(), p[1].to_bits()]).collect()
        };
        assert!(bits(&pos) == bits(&pos_all), "{w}x{h}: preimages differ");
    }
    assert!(skipped > 500, "{skipped}");
}

/// A default frame fit (far-field rings, 16 times the frame) of the bundled time-lapse
/// tracks, scaled to a `side x side` frame.
pub(crate) fn ringed_fit(side: f64) -> Spline {
    let text = include_str!("../../../data/microscopy/timelapse/tracks_0_9.csv");
    let k = side / 511.0;
    let lms: Vec<crate::fit::landmarks::Landmark> = text
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').skip(1).map(|x| x.parse::<f64>().unwrap() * k).collect();
            crate::fit::landmarks::Landmark {
                name: None,
                src: [v[0], v[1]],
                dst: [v[2], v[3]],
                weight: 1.0,
            }
        })
        .collect();
    let f = crate::fit::frame::fit_frame(&lms, [side, side], &Default::default()).unwrap();
    assert!(f.frame.covers_frame);
    f.fit.spline
}

/// Issue 51: the plan of a default fit maps and refines only the lattice squares that can
/// reach the frame (the far-field rings made it about 256 times as many), and its
/// preimages and fold marks are bit-identical to the plan over the whole mesh.
#[test]
fn a_plan_over_far_rings_covers_only_the_frame_and_matches_the_whole_plan_bit_for_bit() {
    let s = ringed_fit(511.0);
    let (blo, bhi) = s.mesh().bbox();
    assert!(bhi[0] - blo[0] > 8000.0, "far rings present: {blo:?} {bhi:?}");
    let o = RemapOptions::default();
    for (w, h) in [(511, 511), (300, 200)] {
        let (near, whole) = (RemapPlan::new(&s, w, h, o), RemapPlan::whole(&s, w, h, o));
        let count =
            |p: &RemapPlan<'_>| p.rows.iter().map(|r| r.blocks.len() + r.tris.len()).sum::<usize>();
        let (a, b) = (fill_all(&near), fill_all(&whole));
        assert_eq!(a.0.len(), b.0.len());
        for (k, (x, y)) in a.0.iter().zip(&b.0).enumerate() {
            assert!(
                x[0].to_bits() == y[0].to_bits() && x[1].to_bits() == y[1].to_bits(),
                "pixel {k}: {x:?} vs {y:?}"
            );
        }
        assert_eq!(a.1, b.1);
        assert_eq!(format!("{:?}", a.2), format!("{:?}", b.2));
        assert_eq!(a.2.outside, 0, "the fit covers the frame");
        // Only squares near the frame are planned (the whole plan keeps every piece whose
        // rows meet the output's, across the rings' whole width).
        assert!(count(&near) * 5 < count(&whole), "{} vs {} pieces", count(&near), count(&whole));
        assert!(
            near.rows.len() * 10 < whole.rows.len(),
            "{} vs {} lattice rows",
            near.rows.len(),
            whole.rows.len()
        );
    }
    // The curvature grid stores the window's buckets only.
    let lat = Lattice::new(&s, 32.0);
    let Some((lo, hi)) = (match reach::plan_window(&s, 511, 511, 32.0) {
        reach::Reach::Window(lo, hi) => Some((lo, hi)),
        _ => None,
    }) else {
        panic!("a window on a convex mesh")
    };
    let (ia, ib, ja, jb) = lat.span(Some((lo, hi)));
    let covered = Some((lat.at(ia, ja), lat.at(ib, jb)));
    let part = CurvatureGrid::new(&s, bucket_for(s.mesh()), covered);
    let all = CurvatureGrid::new(&s, bucket_for(s.mesh()), None);
    assert!(part.stored() * 50 < all.stored(), "{} of {}", part.stored(), all.stored());
}

/// The window is exact on maps that fold and bend strongly too (no far rings there: the
/// window is most of the mesh, and every preimage is the whole plan's).
#[test]
fn windowed_plans_of_the_hard_maps_equal_the_whole_plans() {
    for (name, w, h) in [("folded", 150, 225), ("bent", 700, 500)] {
        let s = load(name);
        let o = RemapOptions::default();
        let (a, b) =
            (fill_all(&RemapPlan::new(&s, w, h, o)), fill_all(&RemapPlan::whole(&s, w, h, o)));
        assert!(
            a.0.iter()
                .zip(&b.0)
                .all(|(x, y)| x[0].to_bits() == y[0].to_bits() && x[1].to_bits() == y[1].to_bits()),
            "{name}"
        );
        assert_eq!(a.1, b.1, "{name}");
    }
}

/// Issue 51: a plan stays within the memory budget it is given, refusing cleanly (the
/// lattice counted before it is allocated, the pieces as rows are refined).
#[test]
fn a_plan_over_its_budget_is_refused_not_allocated() {
    let s = ringed_fit(511.0);
    let o = RemapOptions::default();
    // Too small for the lattice itself.
    let e = RemapPlan::new_within(&s, 511, 511, o, 1_000).err().expect("refused");
    assert!(e.what.contains("inverse-map plan of a 511 x 511 warp"), "{e}");
    assert_eq!(e.limit, 1_000);
    // Enough for the lattice, not for the pieces.
    let e = RemapPlan::new_within(&s, 511, 511, o, 40_000).err().expect("refused");
    assert!(e.needed > 40_000, "{e:?}");
    // Enough: the same plan as without a budget.
    let plan = RemapPlan::new_within(&s, 511, 511, o, 16 << 20).expect("fits in 16 MiB");
    let (a, b) = (fill_all(&plan), fill_all(&RemapPlan::new(&s, 511, 511, o)));
    assert!(a
        .0
        .iter()
        .zip(&b.0)
        .all(|(x, y)| x[0].to_bits() == y[0].to_bits() && x[1].to_bits() == y[1].to_bits()));
}

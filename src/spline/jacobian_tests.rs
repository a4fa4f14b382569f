//! Tests of the det J certificate: exact coefficients of affine and quadratic maps, folds,
//! subdivision, and random splines against exact rationals and dense sampling.

use super::*;
use crate::exact::{rat_from_f64, rat_int, Int, Rat};
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::tests::quadratic_points;
use num_traits::Zero;
use proptest::prelude::*;

fn spline_with(mesh: Mesh, d: usize, a: [[[i64; 2]; 2]; 2], b: [[i64; 2]; 2]) -> Spline {
    let id = Spline::identity(mesh.clone(), d).unwrap();
    let pts = quadratic_points(&id, a, b, [0, 0]);
    Spline::from_points(mesh, d, pts, None).unwrap()
}

fn patch_of(s: &Spline, t: usize) -> ([[f64; 2]; 3], Vec<[f64; 2]>) {
    let mut pts = Vec::new();
    let tri = patch(s, &rounded_points(s), t, &mut pts);
    (tri, pts)
}

/// The domain point `g / k` of triangle `tri`.
fn domain_point(tri: [[f64; 2]; 3], g: [usize; 3], k: usize) -> [f64; 2] {
    [0, 1].map(|a| (0..3).map(|i| g[i] as f64 * tri[i][a]).sum::<f64>() / k as f64)
}

const ZERO_A: [[[i64; 2]; 2]; 2] = [[[0; 2]; 2]; 2];

#[test]
fn identity_and_affine_maps_have_exact_constant_coefficients() {
    let mesh = Mesh::grid(3, 2, 30.0, 20.0, MeshOptions::default()).unwrap();
    for (b, det) in [([[1, 0], [0, 1]], 1.0), ([[2, 1], [0, 3]], 6.0), ([[0, -1], [1, 0]], 1.0)] {
        let s = spline_with(mesh.clone(), 4, ZERO_A, b);
        let mut c = Certifier::new(4);
        for t in 0..mesh.num_triangles() {
            let (tri, pts) = patch_of(&s, t);
            let (coef, err) = c.det_coefficients(tri, &pts, RAT_ROUNDING).unwrap();
            assert_eq!(coef.len(), 28, "degree 2d - 2 = 6");
            assert!(err < 1e-12 * det, "error bound {err}");
            for x in &coef {
                assert!((x - det).abs() <= err, "coefficient {x}, expected {det} +- {err}");
            }
            let tb = c.triangle(tri, &pts, RAT_ROUNDING, &CertifyOptions::default());
            assert_eq!(tb.status, Status::Certified);
            assert_eq!(tb.pieces, 1);
            assert!(tb.lower_bound <= det && tb.lower_bound > det * (1.0 - 1e-12));
            assert!((tb.sampled_min - det).abs() < 1e-12 * det);
        }
        let cert = certify(&s, &CertifyOptions::default());
        assert!(cert.fold_free && cert.folding.is_empty() && cert.undecided.is_empty());
    }
    // The identity at degree 4 on the 1/16 grid: every difference is dyadic, so exactly 1.
    let s = Spline::identity(mesh.clone(), 4).unwrap();
    let (tri, pts) = patch_of(&s, 0);
    let (coef, _) = Certifier::new(4).det_coefficients(tri, &pts, 0.0).unwrap();
    assert!(coef.iter().all(|&x| x == 1.0), "{coef:?}");
}

#[test]
fn a_quadratic_map_has_the_known_det_j_polynomial() {
    // phi = (x + x^2 / 8, y): det J = 1 + x / 4, linear, so each Bernstein coefficient of
    // degree 2d - 2 is its value at the domain point.
    let mesh = Mesh::grid(3, 3, 12.0, 12.0, MeshOptions::default()).unwrap();
    let id = Spline::identity(mesh.clone(), 5).unwrap();
    // quadratic_points takes integer matrices: build 8 phi and compare 64 det J.
    let pts = quadratic_points(&id, [[[1, 0], [0, 0]], [[0, 0], [0, 0]]], [[8, 0], [0, 8]], [0, 0]);
    let s = Spline::from_points(mesh.clone(), 5, pts, None).unwrap();
    let mut c = Certifier::new(5);
    let k = 8;
    for t in 0..mesh.num_triangles() {
        let (tri, pts) = patch_of(&s, t);
        let (coef, err) = c.det_coefficients(tri, &pts, RAT_ROUNDING).unwrap();
        for (g, x) in multi_indices(k).into_iter().zip(&coef) {
            let p = domain_point(tri, g, k);
            let want = 64.0 * (1.0 + 2.0 * p[0] / 8.0);
            assert!((x - want).abs() <= err + 1e-12 * want, "g {g:?}: {x} vs {want} (+- {err})");
        }
    }
    let cert = certify(&s, &CertifyOptions::default());
    assert!(cert.fold_free);
    assert!(cert.lower_bound <= 64.0 && cert.lower_bound > 64.0 * (1.0 - 1e-12));
    assert!((cert.sampled_min - 64.0).abs() < 1e-9);
}

#[test]
fn folds_are_proven() {
    // phi = (x - x^2 / 6, y) over [0, 6] x [0, 6]: det J = 1 - x / 3 folds for x > 3.
    let mesh = Mesh::grid(4, 2, 6.0, 6.0, MeshOptions::default()).unwrap();
    let s = spline_with(mesh.clone(), 5, [[[-1, 0], [0, 0]], [[0; 2]; 2]], [[6, 0], [0, 6]]);
    let bounds = certify_triangles(&s, &CertifyOptions::default());
    let det = |x: f64| 36.0 * (1.0 - x / 3.0);
    for (t, b) in bounds.iter().enumerate() {
        let xs = mesh.triangle(t).map(|v| mesh.vertex(v)[0]);
        let (lo, hi) = (
            xs.iter().cloned().fold(f64::INFINITY, f64::min),
            xs.iter().cloned().fold(0.0, f64::max),
        );
        assert!(b.lower_bound <= det(hi) + 1e-9, "triangle {t}");
        if hi < 3.0 {
            assert_eq!(b.status, Status::Certified, "triangle {t} in x {lo}..{hi}");
        } else if lo > 3.0 || hi > 3.0 + 1e-6 {
            assert_eq!(b.status, Status::Fold, "triangle {t} in x {lo}..{hi}");
            let p = b.fold_at.unwrap();
            assert!(det(p[0]) < 0.0, "fold at {p:?}");
        }
    }
    let cert = DetJ::from_bounds(&bounds);
    assert!(!cert.fold_free && !cert.folding.is_empty());
    assert_eq!(cert.worst.unwrap().1[0], 6.0, "the sampled minimum is at x = 6");
    assert!((cert.sampled_min - det(6.0)).abs() < 1e-9);

    // A mirror folds everywhere.
    let m = spline_with(mesh.clone(), 5, ZERO_A, [[-1, 0], [0, 1]]);
    let cert = certify(&m, &CertifyOptions::default());
    assert_eq!(cert.folding, (0..mesh.num_triangles()).collect::<Vec<_>>());
    assert!(cert.lower_bound <= -1.0 && cert.lower_bound > -1.0 - 1e-9);
}

#[test]
fn det_j_zero_on_an_edge_is_undecided_never_certified() {
    // phi = (x - x^2 / 4, y) over [0, 4] x [0, 2]: det J = 1 - x / 2 >= 0 left of x = 2,
    // zero on the edge x = 2.
    let mesh = Mesh::grid(2, 1, 4.0, 2.0, MeshOptions::default()).unwrap();
    let s = spline_with(mesh.clone(), 5, [[[-1, 0], [0, 0]], [[0; 2]; 2]], [[4, 0], [0, 4]]);
    let opts = CertifyOptions { max_depth: 8, ..Default::default() };
    for (t, b) in certify_triangles(&s, &opts).iter().enumerate() {
        let hi = mesh.triangle(t).map(|v| mesh.vertex(v)[0]).into_iter().fold(0.0, f64::max);
        let want = if hi <= 2.0 { Status::Undecided } else { Status::Fold };
        assert_eq!(b.status, want, "triangle {t}");
        assert!(b.lower_bound <= 0.0);
    }
}

/// The cubic `phi = ((x - y)^3 / 3 + x / 20, y)` on the unit triangle, degree 3 (blossom):
/// det J = (x - y)^2 + 1/20 > 0, but the plain coefficient at (0, 2, 2) is -1/3 + 1/20.
fn cubic_spline() -> Spline {
    let v = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    let mesh = Mesh::from_triangles(&v, &[[0, 1, 2]], MeshOptions::default()).unwrap();
    let id = Spline::identity(mesh.clone(), 3).unwrap();
    let vr: Vec<[Rat; 2]> = v.iter().map(|p| p.map(|x| rat_from_f64(x).unwrap())).collect();
    let mut pts = vec![Vec::new(); id.num_points()];
    for mi in multi_indices(3) {
        let args: Vec<&[Rat; 2]> =
            (0..3).flat_map(|i| std::iter::repeat_n(&vr[i], mi[i])).collect();
        let mut prod = rat_int(1);
        let (mut sx, mut sy) = (Rat::zero(), Rat::zero());
        for a in &args {
            prod *= &a[0] - &a[1];
            sx += &a[0];
            sy += &a[1];
        }
        let x = prod / rat_int(3) + sx / rat_int(60);
        pts[id.layout().point(0, mi)] = vec![x, sy / rat_int(3)];
    }
    Spline::from_points(mesh, 3, pts, None).unwrap()
}

#[test]
fn positive_det_j_with_a_negative_coefficient_is_certified_after_subdivision() {
    let s = cubic_spline();
    let (tri, pts) = patch_of(&s, 0);
    let (coef, _) = Certifier::new(3).det_coefficients(tri, &pts, RAT_ROUNDING).unwrap();
    let min = coef.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!((min - (-1.0 / 3.0 + 0.05)).abs() < 1e-12, "plain minimum {min}");
    let b = certify_triangles(&s, &CertifyOptions::default())[0];
    assert_eq!(b.status, Status::Certified);
    assert!(b.pieces > 1, "needs subdivision");
    assert!(b.lower_bound > 0.0 && b.lower_bound <= 0.05, "{}", b.lower_bound);
    assert!(b.sampled_min >= 0.05 - 1e-12);
    // The same through the f64 entry point.
    let c = triangle_bound(&s, 0, &pts, &CertifyOptions::default());
    assert_eq!(c.status, Status::Certified);
}

#[test]
fn a_floor_is_proven_only_where_det_j_clears_it() {
    // Affine maps: det J is the constant 6.
    let mesh = Mesh::grid(3, 2, 30.0, 20.0, MeshOptions::default()).unwrap();
    let s = spline_with(mesh, 4, ZERO_A, [[2, 1], [0, 3]]);
    let q = rounded_points(&s);
    let o = CertifyOptions::default();
    assert!(certify_points_above(&s, &q, 5.9, &o));
    assert!(!certify_points_above(&s, &q, 6.1, &o));
    assert!(certify_points_above(&s, &q, 0.0, &o) == certify_points(&s, &q, &o));
    // The cubic patch has min det J 0.05 (a negative Bernstein coefficient): a floor below
    // it is proven after subdivision, with the bound above the floor; one above is not.
    let s = cubic_spline();
    let (tri, pts) = patch_of(&s, 0);
    let mut c = Certifier::new(3);
    let b = c.triangle_above(tri, &pts, 0.0, 0.03, &o);
    assert_eq!(b.status, Status::Certified);
    assert!(b.lower_bound > 0.03 && b.lower_bound <= 0.05, "{}", b.lower_bound);
    assert_ne!(c.triangle_above(tri, &pts, 0.0, 0.06, &o).status, Status::Certified);
}

#[test]
fn non_finite_points_are_undecided() {
    let s = cubic_spline();
    let (tri, mut pts) = patch_of(&s, 0);
    pts[3][1] = f64::NAN;
    let b = Certifier::new(3).triangle(tri, &pts, 0.0, &CertifyOptions::default());
    assert_eq!(b.status, Status::Undecided);
    assert_eq!(b.lower_bound, f64::NEG_INFINITY);
    let cert = DetJ::from_bounds(&[b]);
    assert!(!cert.fold_free && cert.undecided == vec![0]);
}

#[test]
fn the_cache_redoes_only_the_triangles_of_changed_points() {
    let mesh = Mesh::grid(3, 3, 30.0, 30.0, MeshOptions::default()).unwrap();
    let s = Spline::identity(mesh.clone(), 5).unwrap();
    let mut cache = CertCache::new(&s, CertifyOptions::default());
    assert!(cache.summary().fold_free);
    // Move one vertex point (index of the first patch's corner) far: it folds nearby.
    let p = s.layout().patches()[0][0];
    let mut pts = s.points().to_vec();
    pts[p][0] = &pts[p][0] + rat_int(25);
    let s2 = Spline::from_points_unchecked(mesh.clone(), 5, pts, None).unwrap();
    let redone = cache.refresh_points(&s2, &[p]);
    let around =
        (0..mesh.num_triangles()).filter(|&t| s.layout().patches()[t].contains(&p)).count();
    assert_eq!(redone, around);
    assert_eq!(cache.summary(), certify(&s2, &CertifyOptions::default()));
    assert!(!cache.summary().fold_free);
}

/// Exact Bernstein coefficients of det J of triangle `t` (module docs' formula, in `Rat`).
fn exact_coefficients(s: &Spline, t: usize) -> Vec<Rat> {
    let d = s.degree();
    let k = 2 * d - 2;
    let m = s.mesh();
    let tri: Vec<[Rat; 2]> =
        m.triangle(t).iter().map(|&v| m.vertex(v).map(|x| rat_from_f64(x).unwrap())).collect();
    let q: Vec<&Vec<Rat>> = s.layout().patches()[t].iter().map(|&p| &s.points()[p]).collect();
    let mi = multi_indices(d - 1);
    let diff = |m: &[usize; 3], c: usize| -> [Rat; 2] {
        let (mut a, mut b) = (*m, *m);
        a[0] += 1;
        b[c] += 1;
        let (qa, qb) = (q[local_index(d, a[0], a[1])], q[local_index(d, b[0], b[1])]);
        [&qb[0] - &qa[0], &qb[1] - &qa[1]]
    };
    let e = |i: usize| [&tri[i][0] - &tri[0][0], &tri[i][1] - &tri[0][1]];
    let (e1, e2) = (e(1), e(2));
    let det_e = &e1[0] * &e2[1] - &e2[0] * &e1[1];
    let scale = rat_int((d * d) as i64) / det_e;
    let big = |x: u128| Rat::from_integer(Int::from(x as i64));
    let mut out = vec![Rat::zero(); (k + 1) * (k + 2) / 2];
    for a in &mi {
        for b in &mi {
            let g = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
            let w = big(multinomial(a) * multinomial(b)) / big(multinomial(&g));
            let (u, v) = (diff(a, 1), diff(b, 2));
            out[local_index(k, g[0], g[1])] += w * (&u[0] * &v[1] - &u[1] * &v[0]);
        }
    }
    out.into_iter().map(|c| c * &scale).collect()
}

fn xorshift(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    #[test]
    fn random_splines_agree_with_exact_coefficients_and_dense_sampling(
        seed in 1u64..u64::MAX, d in 2usize..=6, amp in 1i64..40,
    ) {
        let mesh = Mesh::grid(2, 2, 40.0, 30.0, MeshOptions::default()).unwrap();
        let id = Spline::identity(mesh.clone(), d).unwrap();
        let mut st = seed;
        let pts: Vec<Vec<Rat>> = id.points().iter().map(|p| {
            p.iter().map(|x| {
                let r = (xorshift(&mut st) % (2 * amp as u64 + 1)) as i64 - amp;
                x + Rat::new(Int::from(r), Int::from(7))
            }).collect()
        }).collect();
        let s = Spline::from_points_unchecked(mesh.clone(), d, pts, None).unwrap();
        let mut c = Certifier::new(d);
        let bounds = certify_triangles(&s, &CertifyOptions::default());
        let cache = s.eval_cache();
        for (t, b) in bounds.iter().enumerate() {
            let (tri, pts) = patch_of(&s, t);
            let (coef, err) = c.det_coefficients(tri, &pts, RAT_ROUNDING).unwrap();
            for (x, e) in coef.iter().zip(exact_coefficients(&s, t)) {
                let e = crate::exact::rat_to_f64(&e);
                // rat_to_f64 of the exact value is within one ulp of it.
                prop_assert!((x - e).abs() <= err + e.abs() * f64::EPSILON, "{x} vs {e} +- {err}");
            }
            let det = |b: [f64; 3]| { let j = cache.jacobian(t, b); j[0][0] * j[1][1] - j[0][1] * j[1][0] };
            let n = 40;
            let mut dense = f64::INFINITY;
            for i in 0..=n { for j in 0..=n - i {
                dense = dense.min(det([i as f64 / n as f64, j as f64 / n as f64, (n - i - j) as f64 / n as f64]));
            }}
            let tol = 1e-9 * (1.0 + dense.abs());
            prop_assert!(b.lower_bound <= dense + tol, "bound {} above the dense minimum {dense}", b.lower_bound);
            let l = SAMPLE_LEVEL;
            let mut sampled = f64::INFINITY;
            for i in 0..=l { for j in 0..=l - i {
                sampled = sampled.min(det([i as f64 / l as f64, j as f64 / l as f64, (l - i - j) as f64 / l as f64]));
            }}
            prop_assert!((b.sampled_min - sampled).abs() <= 1e-9 * (1.0 + sampled.abs()));
            match b.status {
                Status::Certified => prop_assert!(dense > -tol),
                Status::Fold => {
                    let p = b.fold_at.unwrap();
                    let v = det(cache.frame(t).bary(p));
                    prop_assert!(v < tol, "fold at {p:?} has det {v}");
                }
                Status::Undecided => {}
            }
        }
    }
}

#[test]
fn a_collapsed_map_is_undecided_within_the_piece_budget() {
    // Every control point at one place: det J is 0 everywhere, never conclusive.
    let mesh = Mesh::grid(1, 1, 8.0, 8.0, MeshOptions::default()).unwrap();
    let id = Spline::identity(mesh.clone(), 5).unwrap();
    let pts = vec![vec![rat_int(3), rat_int(4)]; id.num_points()];
    let s = Spline::from_points_unchecked(mesh, 5, pts, None).unwrap();
    let opts = CertifyOptions::default();
    for b in certify_triangles(&s, &opts) {
        assert_eq!(b.status, Status::Undecided);
        assert_eq!(b.pieces, opts.max_pieces);
        assert!(b.lower_bound <= 0.0 && b.sampled_min == 0.0);
    }
}

//! Spline tests against the oracles of `spline-facts.md`: counts, the dimension of the C1
//! space, polynomial reproduction, corner interpolation and gradient continuity.

use super::*;
use crate::exact::{rat_int, Ldu, LduOptions};
use crate::mesh::{Mesh, MeshOptions};
use proptest::prelude::*;

/// The 6-triangle strip of the C. elegans row of table 19.1: V=8, E=13, 5 interior edges.
pub(crate) fn strip() -> Mesh {
    let v: Vec<[f64; 2]> =
        (0..4).flat_map(|i| [[i as f64 * 2.0, 0.0], [i as f64 * 2.0 + 1.0, 1.5]]).collect();
    let t = vec![[0, 2, 1], [1, 2, 3], [2, 4, 3], [3, 4, 5], [4, 6, 5], [5, 6, 7]];
    Mesh::from_triangles(&v, &t, MeshOptions::default()).unwrap()
}

fn binom(n: usize, k: usize) -> i64 {
    if k > n {
        return 0;
    }
    (1..=k).fold(1i64, |acc, i| acc * (n + 1 - i) as i64 / i as i64)
}

#[test]
fn counts_match_table_19() {
    let s = Spline::identity(strip(), 5).unwrap();
    assert_eq!(s.num_points(), 96);
    assert_eq!(s.quads().len(), 25);
    let g = Mesh::grid(2, 2, 4.0, 4.0, MeshOptions::default()).unwrap();
    let s = Spline::identity(g, 5).unwrap();
    assert_eq!(s.num_points(), 121);
    assert_eq!(s.quads().len(), 40);
}

/// Bug found in review: `mesh --grid 300x300 --degree 15` tried to build 20 million exact
/// control points and aborted on allocation; it is a `TooLarge` error now, checked first.
#[test]
fn too_many_control_points_is_an_error_before_any_allocation() {
    let g = Mesh::grid(300, 300, 300.0, 300.0, MeshOptions::default()).unwrap();
    let want = 301 * 301 + (3 * 300 * 300 + 2 * 300) * 14 + 2 * 300 * 300 * 91;
    assert_eq!(super::control_point_count(&g, 15), want as u128);
    match Spline::identity(g.clone(), 15) {
        Err(SplineError::TooLarge { degree: 15, points }) => assert_eq!(points, want as u128),
        other => panic!("{other:?}"),
    }
    // The same mesh at degree 1 is fine.
    assert!(Spline::identity(g, 1).is_ok());
}

#[test]
fn counts_for_every_degree() {
    let m = strip();
    for d in 1..=8 {
        let s = Spline::identity(m.clone(), d).unwrap();
        assert_eq!(super::control_point_count(&m, d), s.num_points() as u128);
        let expect = 8 + (d - 1) * 13 + if d >= 3 { (d - 1) * (d - 2) / 2 * 6 } else { 0 };
        assert_eq!(s.num_points(), expect, "degree {d}");
        assert_eq!(s.quads().len(), d * 5);
    }
}

fn random_mesh(seed: u64, n: usize) -> Mesh {
    crate::mesh::xorshift_mesh(seed.wrapping_mul(2654435761).wrapping_add(17), n, 10_000, 100.0)
}

#[test]
fn rank_of_c1_conditions_matches_the_dimension_formula() {
    // dim S^1_d = C(d+2,2) + C(d,2) E_I - (C(d+2,2) - 3) V_I + sigma (sigma = 0 here).
    for (seed, n) in [(1, 9), (2, 14), (3, 20)] {
        let m = random_mesh(seed, n);
        for d in [4usize, 5, 6] {
            let s = Spline::identity(m.clone(), d).unwrap();
            let (ei, vi) = (m.num_interior_edges() as i64, m.num_interior_vertices() as i64);
            let c = binom(d + 2, 2);
            let dim = c + binom(d, 2) * ei - (c - 3) * vi;
            let rank = Ldu::factor(s.c1_matrix(), LduOptions::default()).rank() as i64;
            assert_eq!(rank, s.num_points() as i64 - dim, "seed {seed} degree {d}");
        }
    }
}

#[test]
fn identity_is_identity_and_c1() {
    let m = random_mesh(5, 30);
    let s = Spline::identity(m.clone(), 5).unwrap();
    assert!(s.check_c1().is_ok());
    assert!(s.c1_residuals().iter().all(|r| r[0].is_zero() && r[1].is_zero()));
    for t in 0..m.num_triangles() {
        let tri = m.triangle(t).map(|v| m.vertex(v));
        let c =
            [(tri[0][0] + tri[1][0] + tri[2][0]) / 3.0, (tri[0][1] + tri[1][1] + tri[2][1]) / 3.0];
        let (v, j, _) = s.eval_jacobian(c, None).unwrap();
        assert!((v[0] - c[0]).abs() < 1e-9 && (v[1] - c[1]).abs() < 1e-9);
        assert!(
            (j[0][0] - 1.0).abs() < 1e-9 && j[0][1].abs() < 1e-9 && (j[1][1] - 1.0).abs() < 1e-9
        );
    }
    let (lo, _) = m.bbox();
    assert_eq!(s.eval([lo[0] - 1.0, lo[1] - 1.0], None), None);
}

/// The control points of a global quadratic map f(p) = (p^T A0 p, p^T A1 p) + B p + c in
/// Bezier form of degree d: the blossom evaluated at i copies of v0, j of v1, k of v2.
/// Exact, from the exact nominal positions.
pub(crate) fn quadratic_points(
    s: &Spline,
    a: [[[i64; 2]; 2]; 2],
    b: [[i64; 2]; 2],
    c: [i64; 2],
) -> Vec<Vec<Rat>> {
    let d = s.degree();
    let m = s.mesh();
    let den = Int::from(m.grid_denominator());
    let vx = |v: usize| m.vertex_int(v).map(|x| Rat::new(Int::from(x), den.clone()));
    let mut pts = vec![Vec::new(); s.num_points()];
    let bil = |r: usize, x: &[Rat; 2], y: &[Rat; 2]| -> Rat {
        let mut acc = Rat::zero();
        for u in 0..2 {
            for w in 0..2 {
                acc += Rat::from_integer(Int::from(a[r][u][w])) * &x[u] * &y[w];
            }
        }
        acc
    };
    for t in 0..m.num_triangles() {
        let tv = m.triangle(t).map(vx);
        for mi in layout::multi_indices(d) {
            let p = s.layout().point(t, mi);
            let mut out = Vec::new();
            for r in 0..2 {
                // Blossom: (1/(d(d-1))) sum_{a != b} x_a^T A x_b + (1/d) sum_a B x_a + c.
                let mut quad = Rat::zero();
                if d >= 2 {
                    for u in 0..3 {
                        for w in 0..3 {
                            let pairs = if u == w {
                                mi[u] * mi[u].saturating_sub(1)
                            } else {
                                mi[u] * mi[w]
                            };
                            if pairs > 0 {
                                quad += bil(r, &tv[u], &tv[w]) * rat_int(pairs as i64);
                            }
                        }
                    }
                    quad /= rat_int((d * (d - 1)) as i64);
                }
                let mut lin = Rat::zero();
                for u in 0..3 {
                    for w in 0..2 {
                        lin += Rat::from_integer(Int::from(b[r][w]))
                            * &tv[u][w]
                            * rat_int(mi[u] as i64);
                    }
                }
                out.push(quad + lin / rat_int(d as i64) + rat_int(c[r]));
            }
            pts[p] = out;
        }
    }
    pts
}

#[test]
fn polynomial_maps_are_reproduced_and_c1_exactly() {
    let m = random_mesh(7, 25);
    let a = [[[1, 2], [0, -1]], [[0, 1], [3, 0]]];
    let b = [[2, -1], [1, 1]];
    let c = [5, -3];
    for d in [2usize, 3, 5] {
        let id = Spline::identity(m.clone(), d).unwrap();
        let pts = quadratic_points(&id, a, b, c);
        let s = Spline::from_points(m.clone(), d, pts, None).expect("a global polynomial is C1");
        let f = |p: [f64; 2]| {
            let q = |r: usize| {
                let aa = a[r];
                p[0] * (aa[0][0] as f64 * p[0] + aa[0][1] as f64 * p[1])
                    + p[1] * (aa[1][0] as f64 * p[0] + aa[1][1] as f64 * p[1])
                    + b[r][0] as f64 * p[0]
                    + b[r][1] as f64 * p[1]
                    + c[r] as f64
            };
            [q(0), q(1)]
        };
        let (lo, hi) = m.bbox();
        for k in 0..200 {
            let p = [
                lo[0] + (hi[0] - lo[0]) * ((k * 37 % 200) as f64 / 200.0),
                lo[1] + (hi[1] - lo[1]) * ((k * 91 % 200) as f64 / 200.0),
            ];
            let Some((v, j, _)) = s.eval_jacobian(p, None) else { continue };
            let e = f(p);
            let scale = 1.0 + e[0].abs().max(e[1].abs());
            assert!(
                (v[0] - e[0]).abs() < 1e-9 * scale && (v[1] - e[1]).abs() < 1e-9 * scale,
                "d {d}"
            );
            // Jacobian against central differences (tolerance for h = 1e-5 on a quadratic).
            let h = 1e-5;
            for axis in 0..2 {
                let mut p1 = p;
                let mut p0 = p;
                p1[axis] += h;
                p0[axis] -= h;
                let (f1, f0) = (f(p1), f(p0));
                for r in 0..2 {
                    let fd = (f1[r] - f0[r]) / (2.0 * h);
                    assert!((j[r][axis] - fd).abs() < 1e-6 * scale, "jacobian d {d}");
                }
            }
        }
        // Corners interpolate: phi(vertex) = its control point.
        for v in 0..m.num_vertices() {
            let val = s.eval(m.vertex(v), None).unwrap();
            let q = s.point_f64(v);
            assert!((val[0] - q[0]).abs() < 1e-9 * (1.0 + q[0].abs()));
        }
    }
}

#[test]
fn breaking_one_point_breaks_c1() {
    let m = random_mesh(9, 12);
    let s = Spline::identity(m.clone(), 5).unwrap();
    let mut pts = s.points().to_vec();
    // An edge-corner point takes part in conditions; move it alone.
    let q = s.quads()[0];
    pts[q.l][0] += rat_int(1);
    let mut s2 = s.clone();
    assert!(matches!(s2.set_points(pts), Err(SplineError::NotC1 { .. })));
    assert_eq!(s2.points(), s.points(), "a failed set_points leaves the spline unchanged");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    #[test]
    fn eval_many_agrees_with_eval(seed in 0u64..1000, n in 5usize..30) {
        let m = random_mesh(seed, n);
        let s = Spline::identity(m.clone(), 5).unwrap();
        let (lo, hi) = m.bbox();
        let pts: Vec<[f64; 2]> = (0..300)
            .map(|k| [lo[0] - 1.0 + (hi[0] - lo[0] + 2.0) * (k as f64 / 300.0), lo[1] + (hi[1] - lo[1]) * ((k * 7 % 300) as f64 / 300.0)])
            .collect();
        let mut out = vec![None; pts.len()];
        s.eval_many(&pts, &mut out);
        for (p, o) in pts.iter().zip(&out) {
            prop_assert_eq!(*o, s.eval(*p, None));
        }
    }
}

mod determining_set {
    use super::*;
    use crate::spline::mds::{Mds, Role};

    #[test]
    fn free_count_is_the_dimension_and_any_free_values_give_c1() {
        for (seed, n) in [(1u64, 9usize), (2, 14), (3, 25), (4, 40)] {
            let m = random_mesh(seed, n);
            for d in [5usize, 6, 7] {
                let s = Spline::identity(m.clone(), d).unwrap();
                let mds = Mds::new(&s).expect("generic meshes have a local MDS");
                let (ei, vi) = (m.num_interior_edges() as i64, m.num_interior_vertices() as i64);
                let c = binom(d + 2, 2);
                let dim = c + binom(d, 2) * ei - (c - 3) * vi;
                assert_eq!(mds.num_free() as i64, dim, "seed {seed} degree {d}");
                // Arbitrary free values: the recomputed spline is C1 exactly.
                let mut vals: Vec<Vec<Rat>> = (0..s.num_points())
                    .map(|p| {
                        vec![
                            rat_int((p * 7 % 13) as i64 - 6),
                            Rat::new(Int::from((p * 3 % 11) as i64), Int::from(4)),
                        ]
                    })
                    .collect();
                let mut reference = vals.clone();
                mds.recompute(&mut vals, &vec![true; s.num_points()]);
                // The integer path gives the very same reduced fractions as the rational one.
                mds.recompute_rational(&mut reference, &vec![true; s.num_points()]);
                assert_eq!(vals, reference, "seed {seed} degree {d}");
                for (a, b) in vals.iter().flatten().zip(reference.iter().flatten()) {
                    assert_eq!((a.numer(), a.denom()), (b.numer(), b.denom()));
                }
                Spline::from_points(m.clone(), d, vals, None).expect("C1 from free values");
                // The identity is reproduced from its own free points.
                let mut id = s.points().to_vec();
                for p in 0..id.len() {
                    if !matches!(mds.role(p), Role::Free) {
                        id[p] = vec![rat_int(999), rat_int(999)];
                    }
                }
                mds.recompute(&mut id, &vec![true; s.num_points()]);
                assert_eq!(id, s.points());
            }
        }
    }

    #[test]
    fn integer_recompute_falls_back_on_huge_values_with_the_same_result() {
        let m = random_mesh(7, 12);
        let s = Spline::identity(m.clone(), 5).unwrap();
        let mds = Mds::new(&s).unwrap();
        let huge = Rat::new(Int::from_i128(1i128 << 100) * Int::from(3), Int::from(7));
        let mut vals: Vec<Vec<Rat>> =
            s.points().iter().map(|p| vec![p[0].clone() + &huge, p[1].clone()]).collect();
        let mut reference = vals.clone();
        mds.recompute(&mut vals, &vec![true; s.num_points()]);
        mds.recompute_rational(&mut reference, &vec![true; s.num_points()]);
        assert_eq!(vals, reference);
        Spline::from_points(m, 5, vals, None).expect("a translated identity is C1");
    }

    #[test]
    fn check_c1_reports_the_first_violated_condition_with_big_and_small_numbers() {
        let m = random_mesh(8, 12);
        let s = Spline::identity(m.clone(), 5).unwrap();
        let q = s.quads()[s.quads().len() / 2];
        for shift in [
            Rat::new(Int::from(1), Int::from(3)),
            Rat::new(Int::from_i128(1i128 << 110), Int::from(3)),
        ] {
            let mut pts = s.points().to_vec();
            pts[q.l][1] += &shift;
            let err = Spline::from_points(m.clone(), 5, pts, None).unwrap_err();
            let first = s.quads().iter().position(|c| c.members().contains(&q.l)).unwrap();
            assert!(matches!(err, SplineError::NotC1 { quad, .. } if quad == first), "{err:?}");
        }
    }

    #[test]
    fn with_points_checks_c1_like_set_points() {
        let m = random_mesh(8, 13);
        let s = Spline::identity(m, 5).unwrap();
        // An affine image of the identity is C1: the same spline as set_points gives.
        let moved: Vec<Vec<Rat>> = s
            .points()
            .iter()
            .map(|p| vec![&p[0] * Rat::new(Int::from(3), Int::from(2)) + &p[1], p[1].clone()])
            .collect();
        let built = s.with_points(moved.clone()).unwrap();
        let mut set = s.clone();
        set.set_points(moved).unwrap();
        assert_eq!(built.points(), set.points());
        let c = s.mesh().triangle(0).map(|v| s.mesh().vertex(v));
        let mid = [(c[0][0] + c[1][0] + c[2][0]) / 3.0, (c[0][1] + c[1][1] + c[2][1]) / 3.0];
        assert!(built.eval(mid, None).is_some());
        assert_eq!(built.eval(mid, None), set.eval(mid, None));
        // One point off: refused with the first violated condition, as set_points does.
        let q = s.quads()[s.quads().len() / 3];
        let mut bad = s.points().to_vec();
        bad[q.l][0] += Rat::new(Int::from(1), Int::from(7));
        let e1 = s.with_points(bad.clone()).unwrap_err();
        let e2 = s.clone().set_points(bad).unwrap_err();
        assert_eq!(format!("{e1:?}"), format!("{e2:?}"));
        assert!(matches!(e1, SplineError::NotC1 { .. }));
    }

    #[test]
    fn determined_points_equal_recompute_then_with_points() {
        for (seed, d) in [(9u64, 5usize), (10, 6)] {
            let m = random_mesh(seed, 14);
            let s = Spline::identity(m.clone(), d).unwrap();
            let mds = Mds::new(&s).unwrap();
            // Free values off the identity, with other denominators and a huge one (the
            // numerators then overflow i128); the dependents' entries are garbage on purpose.
            let huge = Rat::new(Int::from_i128(1i128 << 110), Int::from(3));
            let vals: Vec<Vec<Rat>> = (0..s.num_points())
                .map(|p| match mds.role(p) {
                    Role::Free => vec![
                        &s.points()[p][0] + Rat::new(Int::from((p % 5) as i64), Int::from(1024)),
                        &s.points()[p][1] + if p == 3 { huge.clone() } else { rat_int(2) },
                    ],
                    Role::Dependent(_) => vec![rat_int(-77), rat_int(99)],
                })
                .collect();
            let mut reference = vals.clone();
            mds.recompute(&mut reference, &vec![true; s.num_points()]);
            let want = s.with_points(reference).unwrap();
            let got = s.with_determined_points(&mds, vals.clone()).unwrap();
            assert_eq!(got.points(), want.points(), "seed {seed} degree {d}");
            let c = m.triangle(1).map(|v| m.vertex(v));
            let mid = [(c[0][0] + c[1][0] + c[2][0]) / 3.0, (c[0][1] + c[1][1] + c[2][1]) / 3.0];
            assert_eq!(got.eval(mid, None), want.eval(mid, None));
            // A set built for another spline is refused, not trusted.
            let other = Spline::identity(random_mesh(seed + 100, 14), d).unwrap();
            let foreign = Mds::new(&other).unwrap();
            if !foreign.is_for(s.quads()) {
                assert_eq!(
                    s.with_determined_points(&foreign, vals.clone()).unwrap_err(),
                    SplineError::ForeignDeterminingSet
                );
            }
            assert!(matches!(
                s.with_determined_points(&mds, vals[1..].to_vec()),
                Err(SplineError::PointCount { .. })
            ));
        }
    }

    #[test]
    fn grid_meshes_and_low_degree() {
        let g = Mesh::grid(4, 3, 40.0, 30.0, MeshOptions::default()).unwrap();
        let s = Spline::identity(g, 5).unwrap();
        // Grid vertices have degree 6 with three lines through them: not singular.
        assert!(Mds::new(&s).is_ok());
        let s4 = Spline::identity(strip(), 4).unwrap();
        assert!(Mds::new(&s4).is_err());
    }
}

#[test]
fn second_derivative_bound_holds_and_vanishes_for_affine_maps() {
    let id = Spline::identity(strip(), 5).unwrap();
    for t in 0..id.mesh().num_triangles() {
        assert!(id.eval_cache().second_derivative_bound(t) < 1e-9);
    }
    // Perturb every control point (C1 does not matter for the bound).
    let s = perturbed(7, 1);
    let c = s.eval_cache();
    let h = 1e-3;
    for t in 0..s.mesh().num_triangles() {
        let m2 = c.second_derivative_bound(t);
        assert!(m2 > 0.0);
        let v = s.mesh().triangle(t).map(|i| s.mesh().vertex(i));
        let f = c.frame(t);
        for (k, ang) in [0.0f64, 0.7, 1.9, 2.6].iter().enumerate() {
            let u = [ang.cos(), ang.sin()];
            let b = [0.2 + 0.1 * k as f64, 0.3, 0.5 - 0.1 * k as f64];
            let p = [0, 1].map(|a| b[0] * v[0][a] + b[1] * v[1][a] + b[2] * v[2][a]);
            let at = |s: f64| c.value(t, f.bary([p[0] + s * u[0], p[1] + s * u[1]]));
            let (a, m, z) = (at(-h), at(0.0), at(h));
            let d2 = [0, 1].map(|r| (a[r] - 2.0 * m[r] + z[r]) / (h * h));
            assert!(d2[0].hypot(d2[1]) <= m2 * 1.001 + 1e-6, "t={t}: {d2:?} vs {m2}");
        }
    }
}

/// A degree-5 spline on [`strip`] whose control points are moved off the identity by a
/// fixed pseudo-random pattern (not C1: a curved map for bounds tests).
fn bent_strip() -> Spline {
    let id = Spline::identity(strip(), 5).unwrap();
    let pts: Vec<Vec<Rat>> = id
        .points()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let k = (i * 37 % 23) as i64 - 11;
            vec![&p[0] + rat_int(k) / rat_int(40), &p[1] + rat_int(k * k % 7) / rat_int(30)]
        })
        .collect();
    Spline::from_points_unchecked(strip(), 5, pts, None).unwrap()
}

#[test]
fn uniform_second_derivative_bounds_hold_on_each_sub_triangle() {
    let s = bent_strip();
    let c = s.eval_cache();
    let t = 2;
    let v = s.mesh().triangle(t).map(|i| s.mesh().vertex(i));
    let whole = c.second_derivative_bound(t);
    let subs = c.second_derivative_bounds_uniform(t, 4);
    assert_eq!(subs.len(), 16);
    let f = c.frame(t);
    let h = 1e-3;
    let mut tighter = false;
    for (b, bound) in &subs {
        tighter |= *bound < whole;
        // Finite differences at the centroid and near each vertex of the sub-triangle.
        for w in [[1.0, 1.0, 1.0], [4.0, 1.0, 1.0], [1.0, 4.0, 1.0], [1.0, 1.0, 4.0]] {
            let sw = w[0] + w[1] + w[2];
            let bc = [0, 1, 2].map(|k| (0..3).map(|j| w[j] / sw * b[j][k]).sum::<f64>());
            let p = [0, 1].map(|a| bc[0] * v[0][a] + bc[1] * v[1][a] + bc[2] * v[2][a]);
            for ang in [0.3f64, 1.2, 2.5] {
                let u = [ang.cos(), ang.sin()];
                let at = |x: f64| c.value(t, f.bary([p[0] + x * u[0], p[1] + x * u[1]]));
                let (l, m, r) = (at(-h), at(0.0), at(h));
                let d2 = [0, 1].map(|k| (l[k] - 2.0 * m[k] + r[k]) / (h * h));
                assert!(d2[0].hypot(d2[1]) <= bound * 1.001 + 1e-6, "{d2:?} > {bound}");
            }
        }
    }
    assert!(tighter, "some sub-triangle bound is below the whole-triangle bound");
    // The sub-triangle bounds never exceed the whole triangle's (same hull argument, finer).
    assert!(subs.iter().all(|(_, b)| *b <= whole * (1.0 + 1e-6) + 1e-12));
}

/// A perturbed spline on `strip()` (C1 does not matter for the bounds).
fn perturbed(seed: u64, scale: i64) -> Spline {
    let id = Spline::identity(strip(), 5).unwrap();
    let mut state = seed;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % 2001) as i64 - 1000
    };
    let pts: Vec<Vec<Rat>> = id
        .points()
        .iter()
        .map(|p| {
            let d = [next(), next()].map(|v| rat_int(v * scale) / rat_int(1000));
            vec![&p[0] + &d[0], &p[1] + &d[1]]
        })
        .collect();
    Spline::from_points_unchecked(strip(), 5, pts, None).unwrap()
}

/// `(1 - f) id + f psi`, exactly (a morph frame's map).
pub(crate) fn blend_with_identity(psi: &Spline, f: &Rat) -> Spline {
    let id = Spline::identity(psi.mesh().clone(), psi.degree()).unwrap();
    let one_minus = Rat::from_integer(1.into()) - f;
    let pts = id
        .points()
        .iter()
        .zip(psi.points())
        .map(|(a, b)| (0..2).map(|k| &one_minus * &a[k] + f * &b[k]).collect())
        .collect();
    psi.with_points_c1_by_construction(pts).unwrap()
}

#[test]
fn excess_bound_of_a_blend_with_the_identity_is_rounding_only() {
    let psi = perturbed(11, 3);
    let c = psi.eval_cache();
    let m: f64 = (0..psi.mesh().num_triangles()).map(|t| c.second_derivative_bound(t)).sum();
    assert!(m > 1e-3, "{m}");
    for (n, d) in [(1i64, 2i64), (3, 10), (-1, 3), (7, 5)] {
        let f = Rat::new(n.into(), d.into());
        let s = blend_with_identity(&psi, &f);
        let e = s.eval_cache().second_derivative_excess_bound(c, crate::exact::rat_to_f64(&f));
        assert!(e < 1e-9 * m, "f = {n}/{d}: E = {e}");
        // And `|f| M_psi + E` bounds the blend's own per-triangle bound.
        for t in 0..s.mesh().num_triangles() {
            let own = s.eval_cache().second_derivative_bound(t);
            let scaled = (n as f64 / d as f64).abs() * c.second_derivative_bound(t) + e;
            assert!(own <= scaled * (1.0 + 1e-9), "t={t}: {own} > {scaled}");
        }
    }
}

#[test]
fn excess_bound_covers_any_difference_and_refuses_other_meshes() {
    let (phi, psi) = (perturbed(5, 4), perturbed(99, 2));
    let (cp, cs) = (phi.eval_cache(), psi.eval_cache());
    for f in [0.0, 0.4, -1.3, 2.0] {
        let e = cp.second_derivative_excess_bound(cs, f);
        // The difference's own bound, from its control points.
        let tris: Vec<[[f64; 2]; 3]> =
            phi.mesh().triangles().iter().map(|t| t.map(|v| phi.mesh().vertex(v))).collect();
        let n = cp.per_patch();
        let pts: Vec<[f64; 2]> = (0..tris.len() * n)
            .map(|k| {
                let (q, o) = (cp.patch_point(k), cs.patch_point(k));
                [q[0] - f * o[0], q[1] - f * o[1]]
            })
            .collect();
        let diff = EvalCache::new(5, &tris, pts);
        let worst = (0..tris.len()).map(|t| diff.second_derivative_bound(t)).fold(0.0, f64::max);
        assert!(worst > 0.0 && worst <= e && e <= worst * 1.001 + 1e-9, "f={f}: {worst} vs {e}");
    }
    let other = Spline::identity(Mesh::grid(3, 3, 40.0, 30.0, MeshOptions::default()).unwrap(), 5);
    assert_eq!(cp.second_derivative_excess_bound(other.unwrap().eval_cache(), 1.0), f64::INFINITY);
}

/// The degree-5 path of the uniform bounds (coefficients shared between sub-triangles, the
/// lattice values interpolated along rows) gives the general path's bounds (a collocation inverse
/// per sub-triangle) up to rounding, sub-triangle for sub-triangle, on a bent spline and on
/// an affine one (zero Hessian: both give the tiny floor), for fine subdivisions too.
#[test]
fn cubic_uniform_bounds_match_the_general_path() {
    let id = Spline::identity(strip(), 5).unwrap();
    let bent = bent_strip();
    for s in [&bent, &id] {
        let c = s.eval_cache();
        for t in 0..s.mesh().num_triangles() {
            for n in [1, 2, 3, 5, 13, 64] {
                let fast = c.second_derivative_bounds_uniform_by(t, n, true);
                let slow = c.second_derivative_bounds_uniform_by(t, n, false);
                assert_eq!(fast.len(), n * n);
                assert_eq!(fast.len(), slow.len());
                for ((bf, mf), (bs, ms)) in fast.iter().zip(&slow) {
                    assert_eq!(bf, bs, "t={t} n={n}: the same sub-triangles in the same order");
                    let scale = mf.abs().max(1e-12);
                    assert!((mf - ms).abs() <= 1e-9 * scale, "t={t} n={n}: {mf} vs {ms}");
                }
            }
        }
    }
}

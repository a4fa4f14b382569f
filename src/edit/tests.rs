//! 2DSD editing tests: the worked example of thesis section 14.4, locality, z modes, and
//! long random edit sequences with an invariant checker after every operation.

use super::*;
use crate::ecles::ConstraintSystem;
use crate::exact::rat_int;
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::ZLayers;
use num_traits::One;
use proptest::prelude::*;

fn two_triangles() -> Mesh {
    // u = (c, a, b) above the shared edge a-b, v = (d, b, a) below it.
    let v = [[0.0, 0.0], [4.0, 0.0], [2.0, 3.0], [2.0, -3.0]];
    Mesh::from_triangles(&v, &[[2, 0, 1], [3, 1, 0]], MeshOptions::default()).unwrap()
}

#[test]
fn thesis_example_14_4() {
    let s = Spline::identity(two_triangles(), 5).unwrap();
    let anchor = s.layout().point(0, [0, 3, 2]);
    let mut ed = Editor::new(s);
    let sel = ed
        .select(&[ControlPoint(anchor)], &[], &Neighborhood::Radius(0), Mode::Xy)
        .unwrap()
        .clone();
    assert_eq!(sel.derived.len(), 4, "derived {:?}", sel.derived);
    assert_eq!(sel.session().unwrap().relevant().len(), 2);
    assert_eq!(sel.session().unwrap().fixed_relevant().len(), 2);
    assert!(sel.strong);
    // The derived points are the medial points q^u_122, q^v_122, q^u_131, q^v_131.
    let lay = ed.spline().layout();
    let mut expect = vec![lay.point(0, [1, 2, 2]), lay.point(0, [1, 3, 1])];
    // In v = (d, b, a) the same positions have the weights on a and b swapped.
    expect.push(lay.point(1, [1, 2, 2]));
    expect.push(lay.point(1, [1, 1, 3]));
    expect.sort_unstable();
    assert_eq!(sel.derived, ControlPoint::from_indices(&expect));
    ed.translate(&[rat_int(1), Rat::new(Int::from(-1), Int::from(3))]).unwrap();
    assert!(ed.spline().check_c1().is_ok());
    assert_eq!(ed.spline().points()[anchor][1], Rat::new(Int::from(-1), Int::from(3)));
}

fn random_mesh(seed: u64, n: usize) -> Mesh {
    crate::mesh::xorshift_mesh(seed.wrapping_mul(0x9E3779B97F4A7C15).wrapping_add(1), n, 6400, 64.0)
}

/// Checks the invariants after an operation: exact C1, untouched points bit-for-bit, and
/// gradient continuity across interior edges at sample points.
fn check_invariants(before: &Spline, after: &Spline, moved: &[usize]) {
    after.check_c1().expect("C1 exactly");
    let mut is_moved = vec![false; before.num_points()];
    for &m in moved {
        is_moved[m] = true;
    }
    for p in 0..before.num_points() {
        if !is_moved[p] {
            assert_eq!(before.points()[p], after.points()[p], "point {p} outside A and D moved");
        }
    }
    let m = after.mesh();
    let cache = after.eval_cache();
    for e in m.edges() {
        let (Some(u), Some(v)) = (e.tris[0], e.tris[1]) else { continue };
        let (a, b) = (m.vertex(e.v[0]), m.vertex(e.v[1]));
        for s in [0.13, 0.5, 0.77] {
            let p = [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])];
            let (ju, jv) = (
                cache.jacobian(u, cache.frame(u).bary(p)),
                cache.jacobian(v, cache.frame(v).bary(p)),
            );
            let scale = 1.0 + ju.iter().flatten().fold(0.0f64, |acc, x| acc.max(x.abs()));
            for r in 0..2 {
                for c in 0..2 {
                    assert!(
                        (ju[r][c] - jv[r][c]).abs() <= 1e-9 * scale,
                        "gradient jump across edge {:?}",
                        e.v
                    );
                }
            }
        }
    }
}

#[test]
fn single_anchor_edits_are_local() {
    let mesh = random_mesh(3, 40);
    let s = Spline::identity(mesh.clone(), 5).unwrap();
    let mut ed = Editor::new(s.clone());
    // An interior vertex.
    let v = (0..mesh.num_vertices()).find(|&v| !mesh.is_border_vertex(v)).unwrap();
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
    ed.translate(&[rat_int(2), rat_int(-1)]).unwrap();
    let sel = ed.selection().unwrap().clone();
    let mut moved = ControlPoint::indices(&sel.anchors);
    moved.extend(ControlPoint::indices(&sel.derived));
    check_invariants(&s, ed.spline(), &moved);
    // Locality: every changed point lies in a triangle that shares a vertex with the star of v.
    let star: Vec<usize> = mesh.vertex_triangles(v).to_vec();
    let near: std::collections::HashSet<usize> =
        star.iter().flat_map(|&t| mesh.triangle(t)).collect();
    let allowed: std::collections::HashSet<usize> = (0..mesh.num_triangles())
        .filter(|&t| mesh.triangle(t).iter().any(|x| near.contains(x)))
        .flat_map(|t| s.layout().patches()[t].clone())
        .collect();
    for p in 0..s.num_points() {
        if s.points()[p] != ed.spline().points()[p] {
            assert!(allowed.contains(&p), "point {p} changed outside the neighbourhood");
        }
    }
    assert_eq!(
        ed.spline().points()[v],
        vec![s.points()[v][0].clone() + rat_int(2), s.points()[v][1].clone() - rat_int(1)]
    );
}

#[test]
fn rotating_a_whole_vertex_disk_uses_the_exact_rotation() {
    let mesh = random_mesh(11, 30);
    let s = Spline::identity(mesh.clone(), 5).unwrap();
    let mut ed = Editor::new(s.clone());
    let v = (0..mesh.num_vertices()).find(|&v| !mesh.is_border_vertex(v)).unwrap();
    let mut anchors = vec![v];
    anchors.extend(ed.index().disks[v].iter().copied());
    let anchors = ControlPoint::from_indices(&anchors);
    let sel = ed.select(&anchors, &[], &Neighborhood::Radius(1), Mode::Xy).unwrap();
    // Many anchors share conditions: not strongly solvable, but exact rotations are affine.
    assert!(!sel.strong);
    let c = [s.points()[v][0].clone(), s.points()[v][1].clone()];
    ed.rotate(c.clone(), 0.3).unwrap();
    let (cs, sn) = rational_rotation(0.3);
    assert_eq!(&cs * &cs + &sn * &sn, Rat::one());
    assert!(ed.spline().check_c1().is_ok());
    let sel = ed.selection().unwrap().clone();
    let mut moved = ControlPoint::indices(&sel.anchors);
    moved.extend(ControlPoint::indices(&sel.derived));
    check_invariants(&s, ed.spline(), &moved);
}

#[test]
fn z_modes_edit_the_scalar_splines() {
    let mesh = random_mesh(5, 20);
    let mut s = Spline::identity(mesh.clone(), 5).unwrap();
    let n = s.num_points();
    s.set_z_layers(Some(ZLayers {
        range: [rat_int(-2), rat_int(2)],
        z0: vec![rat_int(-2); n],
        z1: vec![rat_int(2); n],
    }));
    let mut ed = Editor::new(s.clone());
    let v = (0..mesh.num_vertices()).find(|&v| !mesh.is_border_vertex(v)).unwrap();
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Z1).unwrap();
    ed.translate(&[rat_int(1)]).unwrap();
    let z = ed.spline().z_layers().unwrap();
    assert_eq!(z.z1[v], rat_int(3));
    assert_eq!(z.z0, vec![rat_int(-2); n]);
    assert_eq!(ed.spline().points(), s.points(), "xy untouched by a z edit");
    let sys = ConstraintSystem::homogeneous(s.c1_matrix().clone(), 1);
    let col: Vec<Vec<Rat>> = z.z1.iter().map(|x| vec![x.clone()]).collect();
    assert!(sys.is_satisfied(&col), "sigma1 is C1 exactly");
    // 2D operations are refused in z modes; wrong sizes too; the spline is unchanged.
    let before = ed.spline().clone();
    assert!(matches!(ed.rotate([rat_int(0), rat_int(0)], 0.1), Err(EditError::Mode(_))));
    assert!(matches!(ed.translate(&[rat_int(1), rat_int(1)]), Err(EditError::Argument(_))));
    assert_eq!(ed.spline().z_layers(), before.z_layers());
    // z modes need layers.
    let mut plain = Editor::new(Spline::identity(mesh, 5).unwrap());
    assert!(matches!(
        plain.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(1), Mode::Z0),
        Err(EditError::Mode(_))
    ));
}

#[test]
fn bad_selections_are_refused() {
    let mut ed = Editor::new(Spline::identity(random_mesh(2, 10), 5).unwrap());
    let n = ed.spline().num_points();
    assert_eq!(
        ed.select(&[], &[], &Neighborhood::All, Mode::Xy).unwrap_err(),
        EditError::NoAnchors
    );
    assert!(matches!(
        ed.select(&[ControlPoint(n)], &[], &Neighborhood::All, Mode::Xy),
        Err(EditError::PointIndex { .. })
    ));
    assert!(matches!(
        ed.select(&[ControlPoint(1), ControlPoint(1)], &[], &Neighborhood::All, Mode::Xy),
        Err(EditError::Ecles(_))
    ));
    assert!(matches!(
        ed.select(&[ControlPoint(1)], &[ControlPoint(1)], &Neighborhood::All, Mode::Xy),
        Err(EditError::Ecles(_))
    ));
    assert_eq!(ed.translate(&[rat_int(1), rat_int(1)]).unwrap_err(), EditError::NoSelection);
    ed.select(&[ControlPoint(1)], &[], &Neighborhood::Radius(1), Mode::Xy).unwrap();
    assert!(matches!(ed.rotate([rat_int(0), rat_int(0)], f64::NAN), Err(EditError::Argument(_))));
    assert!(matches!(
        ed.scale(&[rat_int(0), rat_int(0)], &rat_int(0)),
        Err(EditError::Argument(_))
    ));
}

#[derive(Clone, Debug)]
enum Op {
    Translate(i64, i64),
    Rotate(f64),
    Scale(i64),
}

fn op_strategy() -> impl Strategy<Value = Op> {
    prop_oneof![
        (-8i64..=8, -8i64..=8).prop_map(|(a, b)| Op::Translate(a, b)),
        (-1.0f64..1.0).prop_map(Op::Rotate),
        (12i64..=20).prop_map(Op::Scale),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]
    #[test]
    fn random_edit_sequences_keep_every_invariant(
        seed in 0u64..500,
        npts in 8usize..30,
        grid in any::<bool>(),
        ops in prop::collection::vec((prop::collection::vec(any::<prop::sample::Index>(), 1..3), 0usize..4, op_strategy()), 1..8),
    ) {
        let mesh = if grid { Mesh::grid(3, 2, 60.0, 40.0, MeshOptions::default()).unwrap() } else { random_mesh(seed, npts) };
        let mut ed = Editor::new(Spline::identity(mesh, 5).unwrap());
        for (anchors, radius, op) in ops {
            let n = ed.spline().num_points();
            let mut a: Vec<usize> = anchors.iter().map(|i| i.index(n)).collect();
            a.sort_unstable();
            a.dedup();
            let before = ed.spline().clone();
            let hood = if radius == 3 { Neighborhood::All } else { Neighborhood::Radius(radius) };
            if ed.select(&ControlPoint::from_indices(&a), &[], &hood, Mode::Xy).is_err() {
                prop_assert_eq!(ed.spline().points(), before.points());
                continue;
            }
            let sel = ed.selection().unwrap().clone();
            let c = [before.points()[a[0]][0].clone(), before.points()[a[0]][1].clone()];
            let res = match op {
                Op::Translate(x, y) => ed.translate(&[Rat::new(Int::from(x), Int::from(4)), Rat::new(Int::from(y), Int::from(4))]),
                Op::Rotate(ang) => ed.rotate(c.clone(), ang),
                Op::Scale(f) => ed.scale(&c, &Rat::new(Int::from(f), Int::from(16))),
            };
            let mut moved = ControlPoint::indices(&sel.anchors);
            moved.extend(ControlPoint::indices(&sel.derived));
            match res {
                Ok(()) => {
                    check_invariants(&before, ed.spline(), &moved);
                    if let Op::Translate(x, y) = op {
                        for p in ControlPoint::indices(&sel.anchors) {
                            prop_assert_eq!(&ed.spline().points()[p][0], &(&before.points()[p][0] + Rat::new(Int::from(x), Int::from(4))));
                            prop_assert_eq!(&ed.spline().points()[p][1], &(&before.points()[p][1] + Rat::new(Int::from(y), Int::from(4))));
                        }
                    }
                }
                Err(_) => prop_assert_eq!(ed.spline().points(), before.points()),
            }
        }
    }
}

mod extras {
    use super::*;
    use crate::edit::extra::Extra;

    fn grid_editor() -> (Editor, Mesh) {
        let mesh = Mesh::grid(4, 3, 80.0, 60.0, MeshOptions::default()).unwrap();
        (Editor::new(Spline::identity(mesh.clone(), 5).unwrap()), mesh)
    }

    fn vertex_at(m: &Mesh, x: f64, y: f64) -> usize {
        (0..m.num_vertices()).find(|&v| m.vertex(v) == [x, y]).unwrap()
    }

    #[test]
    fn pinned_points_stay_and_pinned_anchors_cannot_move() {
        let (mut ed, m) = grid_editor();
        let a = vertex_at(&m, 40.0, 20.0);
        let pinned = ed.index().disks[a][0];
        ed.add_constraint(Extra::pin(pinned, ed.spline().points()).unwrap()).unwrap();
        let before = ed.spline().clone();
        ed.select(&[ControlPoint(a)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
        ed.translate(&[rat_int(3), rat_int(1)]).unwrap();
        assert_eq!(ed.spline().points()[pinned], before.points()[pinned]);
        assert!(ed.spline().check_c1().is_ok());
        // Pinning the anchor itself: any nonzero move is unsolvable, the spline unchanged.
        ed.add_constraint(Extra::pin(a, ed.spline().points()).unwrap()).unwrap();
        let before = ed.spline().clone();
        ed.select(&[ControlPoint(a)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
        let err = ed.translate(&[rat_int(1), rat_int(0)]).unwrap_err();
        assert!(matches!(err, EditError::Ecles(EclesError::NotWeaklySolvable { .. })), "{err}");
        assert_eq!(ed.spline().points(), before.points());
        ed.translate(&[rat_int(0), rat_int(0)]).unwrap();
    }

    #[test]
    fn points_on_a_horizontal_line_stay_on_one() {
        let (mut ed, m) = grid_editor();
        let row: Vec<usize> =
            [0.0, 20.0, 40.0, 60.0, 80.0].iter().map(|&x| vertex_at(&m, x, 20.0)).collect();
        ed.add_constraint(Extra::line(row.clone(), 1, ed.spline().points()).unwrap()).unwrap();
        // A vertical line through points that are not aligned is refused.
        assert!(Extra::line(vec![row[0], row[1]], 0, ed.spline().points()).is_err());
        ed.select(&[ControlPoint(row[2])], &[], &Neighborhood::Radius(1), Mode::Xy).unwrap();
        ed.translate(&[rat_int(2), rat_int(5)]).unwrap();
        let y = &ed.spline().points()[row[0]][1];
        assert_eq!(y, &rat_int(25));
        for &p in &row {
            assert_eq!(&ed.spline().points()[p][1], y, "point {p} left the line");
        }
        assert!(ed.spline().check_c1().is_ok());
        assert_eq!(ed.spline().points()[row[2]][0], rat_int(42));
    }

    #[test]
    fn equal_displacements() {
        let (mut ed, m) = grid_editor();
        let (a, b) = (vertex_at(&m, 20.0, 20.0), vertex_at(&m, 60.0, 40.0));
        let before = ed.spline().clone();
        ed.add_constraint(Extra::equal_displacement(a, b, ed.spline().points()).unwrap()).unwrap();
        ed.select(&[ControlPoint(a)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
        ed.translate(&[Rat::new(Int::from(7), Int::from(3)), rat_int(-1)]).unwrap();
        for c in 0..2 {
            assert_eq!(
                &ed.spline().points()[b][c] - &before.points()[b][c],
                &ed.spline().points()[a][c] - &before.points()[a][c]
            );
        }
        assert!(ed.spline().check_c1().is_ok());
    }

    #[test]
    fn constraints_round_trip_through_json() {
        let (ed, m) = grid_editor();
        let pts = ed.spline().points();
        let row: Vec<usize> = [0.0, 20.0].iter().map(|&x| vertex_at(&m, x, 0.0)).collect();
        for e in [
            Extra::pin(3, pts).unwrap(),
            Extra::line(row.clone(), 1, pts).unwrap(),
            Extra::equal_displacement(1, 2, pts).unwrap(),
        ] {
            assert_eq!(Extra::from_json(&e.to_json(), pts).unwrap(), e);
        }
        let bad = serde_json::json!({"pin": 3, "at": ["1/3", "0"]});
        assert!(Extra::from_json(&bad, pts).is_err());
        assert!(Extra::from_json(&serde_json::json!({"glue": 1}), pts).is_err());
        assert!(Extra::pin(10_000, pts).is_err());
    }
}

mod bounded {
    use super::*;

    /// Anchors land within this distance of their targets in bounded mode with 24 bits
    /// (rounding of the free points, `2^-25` per coordinate, through the local formulas).
    const TOLERANCE: f64 = 1e-4;

    fn max_bits(s: &Spline) -> u64 {
        s.points()
            .iter()
            .flatten()
            .map(|r| {
                let r = r.reduced();
                r.numer().bits().max(r.denom().bits())
            })
            .max()
            .unwrap()
    }

    #[test]
    fn long_random_sessions_stay_bounded_and_exact() {
        for mesh in
            [random_mesh(21, 30), Mesh::grid(5, 5, 100.0, 100.0, MeshOptions::default()).unwrap()]
        {
            let mut ed = Editor::new(Spline::identity(mesh, 5).unwrap());
            ed.set_bounded(Some(24)).unwrap();
            let n = ed.spline().num_points();
            let mut x = 12345u64;
            let mut next = |m: u64| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x % m
            };
            let mut worst_anchor = 0.0f64;
            let mut sizes = Vec::new();
            for k in 0..150 {
                let a = next(n as u64) as usize;
                let before = ed.spline().clone();
                ed.select(
                    &[ControlPoint(a)],
                    &[],
                    &Neighborhood::Radius(next(3) as usize),
                    Mode::Xy,
                )
                .unwrap();
                let sel = ed.selection().unwrap().clone();
                let q = before.points()[a].clone();
                let target: Vec<f64>;
                match next(3) {
                    0 => {
                        let v = [
                            Rat::new(Int::from(next(33) as i64 - 16), Int::from(8)),
                            Rat::new(Int::from(next(33) as i64 - 16), Int::from(8)),
                        ];
                        target = (0..2).map(|c| rat_to_f64(&(&q[c] + &v[c]))).collect();
                        ed.translate(&v).unwrap();
                    }
                    1 => {
                        target = q.iter().map(rat_to_f64).collect();
                        ed.rotate([q[0].clone(), q[1].clone()], (next(100) as f64 - 50.0) / 100.0)
                            .unwrap();
                    }
                    _ => {
                        target = q.iter().map(rat_to_f64).collect();
                        ed.scale(&q, &Rat::new(Int::from(58 + next(13) as i64), Int::from(64)))
                            .unwrap();
                    }
                }
                let mut moved = ControlPoint::indices(&sel.anchors);
                moved.extend(ControlPoint::indices(&sel.derived));
                check_invariants(&before, ed.spline(), &moved);
                let got = ed.spline().point_f64(a);
                worst_anchor =
                    worst_anchor.max((got[0] - target[0]).abs().max((got[1] - target[1]).abs()));
                if k % 50 == 49 {
                    sizes.push(max_bits(ed.spline()));
                }
            }
            assert!(worst_anchor <= TOLERANCE, "anchor off by {worst_anchor}");
            // Sizes do not grow with the history.
            assert!(sizes.iter().all(|&b| b <= 400), "sizes {sizes:?}");
            assert!(sizes[2] <= sizes[0] + 64, "sizes {sizes:?}");
        }
    }
}

#[test]
fn preview_matches_the_exact_translation() {
    let mesh = random_mesh(8, 30);
    let mut ed = Editor::new(Spline::identity(mesh.clone(), 5).unwrap());
    let v = (0..mesh.num_vertices()).find(|&v| !mesh.is_border_vertex(v)).unwrap();
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
    let sel = ed.selection().unwrap().clone();
    let fast = ed.preview_translate([2.5, -1.25]).unwrap();
    ed.translate(&[Rat::new(Int::from(5), Int::from(2)), Rat::new(Int::from(-5), Int::from(4))])
        .unwrap();
    let ids: Vec<usize> = sel.anchors.iter().chain(&sel.derived).map(|p| p.index()).collect();
    for (p, f) in ids.iter().zip(&fast) {
        let e = ed.spline().point_f64(*p);
        for c in 0..2 {
            // Hints are rounded to 2^-20 in the exact path; the preview uses exact theta.
            assert!((e[c] - f[c]).abs() < 1e-5 * (1.0 + e[c].abs()), "point {p}: {e:?} vs {f:?}");
        }
    }
}

/// Found in review: meshes with the same integer vertex coordinates on different snapping
/// grids (so different vertices) counted as the same layout.
#[test]
fn same_layout_compares_the_snapping_grid() {
    let a = Mesh::grid(2, 2, 4.0, 4.0, MeshOptions { grid: 1 }).unwrap();
    let b = Mesh::grid(2, 2, 2.0, 2.0, MeshOptions { grid: 2 }).unwrap();
    assert!((0..a.num_vertices()).all(|v| a.vertex_int(v) == b.vertex_int(v)));
    let (sa, sb) = (Spline::identity(a, 5).unwrap(), Spline::identity(b, 5).unwrap());
    assert!(!crate::edit::same_layout(&sa, &sb));
    assert!(crate::edit::same_layout(&sa, &sa.clone()));
}

/// Bug (reliability pass): a rotation by exactly pi divided by zero (tan(pi/2) has no
/// rational approximation with a bounded denominator), so `edit` and the editor panicked.
#[test]
fn rotation_by_a_half_turn_is_exact_and_does_not_panic() {
    use std::f64::consts::PI;
    let minus_one = (-Rat::one(), Rat::zero());
    for a in [PI, -PI, 3.0 * PI, -3.0 * PI, 5.0 * PI] {
        assert_eq!(rational_rotation(a), minus_one, "angle {a}");
    }
    for a in [0.3, 1.5, 1.6, 2.9, 3.1, -2.0, 7.0, 100.0, -1e6] {
        let (c, s) = rational_rotation(a);
        assert_eq!(&c * &c + &s * &s, Rat::one(), "angle {a}");
        let (cf, sf) = (crate::exact::rat_to_f64(&c), crate::exact::rat_to_f64(&s));
        assert!((cf - a.cos()).abs() < 1e-4 && (sf - a.sin()).abs() < 1e-4, "angle {a}");
    }
    assert_eq!(rational_approx(1e300, 1 << 16), Rat::from_integer(Int::from(i64::MAX)));
    assert_eq!(rational_approx(f64::NAN, 1 << 16), Rat::zero());
}

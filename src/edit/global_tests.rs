//! The select-all path ([`super::global`]) against ECLES's general path.

use super::*;
use crate::exact::rat_int;
use crate::mesh::Mesh;
use crate::spline::mds::{round_to_grid, Role};

fn random_mesh(seed: u64, n: usize) -> Mesh {
    crate::mesh::xorshift_mesh(seed.wrapping_mul(0x9E3779B97F4A7C15).wrapping_add(1), n, 6400, 64.0)
}

/// Two editors over the same spline in bounded mode (24 bits): one on the select-all path,
/// one always on ECLES sessions.
fn pair(mesh: Mesh) -> (Editor, Editor) {
    let mut global = Editor::new(Spline::identity(mesh, 5).unwrap());
    global.set_bounded(Some(24)).unwrap();
    let mut general = global.clone();
    global.set_global_path(Some(0));
    general.set_global_path(None);
    (global, general)
}

/// The largest coordinate difference of two splines' control points (f64), the largest
/// among free points, and the number of free points whose exact values differ.
fn compare(a: &Spline, b: &Spline, mds: &crate::spline::mds::Mds) -> (f64, f64, usize) {
    let (mut worst, mut worst_free) = (0.0f64, 0.0f64);
    let mut differ = 0;
    for p in 0..a.num_points() {
        let (x, y) = (a.point_f64(p), b.point_f64(p));
        let d = (x[0] - y[0]).abs().max((x[1] - y[1]).abs());
        worst = worst.max(d);
        if matches!(mds.role(p), Role::Free) {
            worst_free = worst_free.max(d);
            if a.points()[p] != b.points()[p] {
                differ += 1;
            }
        }
    }
    (worst, worst_free, differ)
}

/// The control point nearest `q`.
fn nearest(s: &Spline, q: [f64; 2]) -> usize {
    (0..s.num_points())
        .min_by(|&a, &b| {
            let d = |i: usize| {
                let p = s.point_f64(i);
                (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)
            };
            d(a).total_cmp(&d(b))
        })
        .unwrap()
}

#[test]
fn select_all_in_determining_set_coordinates_matches_the_general_path() {
    // The f64 minimizer differs from the exact one by the solve's rounding: relative 1e-9
    // or so on these random meshes (skinny triangles give the dependents' formulas large
    // coefficients). After rounding to the bounded grid, free points agree within FREE_PX
    // (a few grid steps of 6e-8 px); the dependents follow from them exactly (C1 is checked
    // in rationals), so they differ by those steps times their formulas' coefficients,
    // which the general path's own rounding is subject to as well.
    const FREE_PX: f64 = 1e-6;
    let step = 2f64.powi(-24);
    for (seed, tris) in [(3u64, 20usize), (11, 40)] {
        let mesh = random_mesh(seed, tris);
        let s = Spline::identity(mesh.clone(), 5).unwrap();
        let mds = crate::spline::mds::Mds::new(&s).unwrap();
        let anchor = nearest(&s, [32.0, 32.0]);
        let inner = (0..s.num_points())
            .find(|&p| matches!(mds.role(p), Role::Dependent(_)) && p != anchor)
            .unwrap();
        // One anchor; then a free and a dependent anchor together.
        for anchors in [vec![anchor], vec![anchor, inner]] {
            for op in 0..3 {
                // Each operation from the same spline, so differences do not compound.
                let (mut g, mut e) = pair(mesh.clone());
                for ed in [&mut g, &mut e] {
                    ed.select(
                        &ControlPoint::from_indices(&anchors),
                        &[],
                        &Neighborhood::All,
                        Mode::Xy,
                    )
                    .unwrap();
                    match op {
                        0 => ed.translate(&[rat_int(3), Rat::new(Int::from(-7), Int::from(3))]),
                        1 => ed.rotate([rat_int(30), rat_int(30)], 0.2),
                        _ => ed.scale(
                            &[rat_int(0), rat_int(0)],
                            &Rat::new(Int::from(5), Int::from(4)),
                        ),
                    }
                    .unwrap();
                }
                assert!(g.selection().unwrap().is_global() && !e.selection().unwrap().is_global());
                g.spline().check_c1().expect("C1 exactly on the select-all path");
                let (worst, worst_free, differ) = compare(g.spline(), e.spline(), &mds);
                eprintln!(
                    "seed {seed}, {tris} points, anchors {anchors:?}, op {op}: max diff {worst:.3e} px, free points {:.2} grid steps, {differ} of {} free points differ",
                    worst_free / step,
                    mds.num_free()
                );
                assert!(worst_free <= FREE_PX, "free points differ by {worst_free} px");
                // Same reports: every condition relevant, the rank of the whole system.
                let (sg, se) = (g.selection().unwrap(), e.selection().unwrap());
                assert_eq!((sg.relevant(), sg.rank()), (se.relevant(), se.rank()));
                assert_eq!(sg.derived, se.derived);
            }
        }
    }
}

#[test]
fn the_select_all_preview_is_the_translation_before_rounding() {
    let (mut g, _) = pair(random_mesh(5, 30));
    let anchor = nearest(g.spline(), [20.0, 40.0]);
    g.select(&[ControlPoint(anchor)], &[], &Neighborhood::All, Mode::Xy).unwrap();
    let preview = g.preview_translate([2.5, -1.25]).unwrap();
    g.translate(&[Rat::new(Int::from(5), Int::from(2)), Rat::new(Int::from(-5), Int::from(4))])
        .unwrap();
    let sel = g.selection().unwrap().clone();
    for (k, p) in sel.anchors.iter().chain(&sel.derived).map(|p| p.index()).enumerate() {
        let q = g.spline().point_f64(p);
        let d = (q[0] - preview[k][0]).abs().max((q[1] - preview[k][1]).abs());
        assert!(d < 1e-5, "point {p}: preview {:?} vs {q:?}", preview[k]);
    }
}

#[test]
fn free_anchors_land_on_the_grid_and_dependents_follow_exactly() {
    let (mut g, _) = pair(random_mesh(9, 30));
    let mds = crate::spline::mds::Mds::new(g.spline()).unwrap();
    let anchor = (0..g.spline().num_points())
        .find(|&p| matches!(mds.role(p), Role::Free) && g.spline().point_f64(p)[0] > 20.0)
        .unwrap();
    let v = [Rat::new(Int::from(1), Int::from(3)), rat_int(2)];
    let target: Vec<Rat> = (0..2).map(|c| &g.spline().points()[anchor][c] + &v[c]).collect();
    g.select(&[ControlPoint(anchor)], &[], &Neighborhood::All, Mode::Xy).unwrap();
    g.translate(&v).unwrap();
    g.spline().check_c1().unwrap();
    // A free anchor is rounded to the bounded grid like every free point.
    for c in 0..2 {
        assert_eq!(g.spline().points()[anchor][c], round_to_grid(&target[c], 24));
    }
}

#[test]
fn small_splines_and_other_selections_keep_the_general_path() {
    let mut ed = Editor::new(Spline::identity(random_mesh(3, 20), 5).unwrap());
    ed.set_bounded(Some(24)).unwrap();
    let a = nearest(ed.spline(), [32.0, 32.0]);
    // The default threshold: this spline is smaller than GLOBAL_MIN_POINTS.
    assert!(ed.spline().num_points() < global::GLOBAL_MIN_POINTS);
    assert!(!ed.select(&[ControlPoint(a)], &[], &Neighborhood::All, Mode::Xy).unwrap().is_global());
    ed.set_global_path(Some(0));
    assert!(!ed
        .select(&[ControlPoint(a)], &[], &Neighborhood::Radius(2), Mode::Xy)
        .unwrap()
        .is_global());
    assert!(ed.select(&[ControlPoint(a)], &[], &Neighborhood::All, Mode::Xy).unwrap().is_global());
    // Unbounded edits stay exact: ECLES sessions.
    ed.set_bounded(None).unwrap();
    assert!(!ed.select(&[ControlPoint(a)], &[], &Neighborhood::All, Mode::Xy).unwrap().is_global());
}

#[test]
fn dependent_anchor_equations_fall_back_to_the_general_path() {
    // Every point of one vertex's ring 1 anchored: the dependent edge corners' equations
    // are implied by the free ones (S singular), so ECLES decides.
    let (mut g, _) = pair(random_mesh(7, 20));
    let s = g.spline().clone();
    let mds = crate::spline::mds::Mds::new(&s).unwrap();
    let mut anchors: Vec<usize> = Vec::new();
    for p in 0..s.num_points() {
        if let Role::Dependent(f) = mds.role(p) {
            if f.iter().all(|(j, _)| matches!(mds.role(*j), Role::Free)) {
                anchors.push(p);
                anchors.extend(f.iter().map(|(j, _)| *j));
                break;
            }
        }
    }
    anchors.sort_unstable();
    anchors.dedup();
    let sel = g.select(&ControlPoint::from_indices(&anchors), &[], &Neighborhood::All, Mode::Xy);
    let sel = sel.unwrap();
    assert!(!sel.is_global(), "anchors {anchors:?}");
    // A motion of all of them together keeps their relation: solvable on the general path.
    g.translate(&[rat_int(1), rat_int(1)]).unwrap();
    g.spline().check_c1().unwrap();
}

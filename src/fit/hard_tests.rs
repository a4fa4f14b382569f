//! Tests of the hard fit: `phi(s_i) = t_i` checked in exact rationals for the decimals as
//! written, on a grid mesh and on a Delaunay mesh through the sources; pins; C1; the
//! conflicting-pair and too-many-constraints diagnostics; the output size.

use super::hard::{bernstein_row, exact_landmark, locate_exact};
use super::landmarks::Landmark;
use super::report::ExactStep;
use super::{fit, FitError, FitOptions};
use crate::exact::{parse_rat, Rat};
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::{ControlPoint, Spline};
use num_traits::Zero;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// `v` with 4 decimals (the f64 nearest the 4-decimal text).
fn dec4(v: f64) -> f64 {
    format!("{v:.4}").parse().unwrap()
}

fn warp(p: [f64; 2]) -> [f64; 2] {
    [p[0] + 6.0 * (p[1] / 70.0).sin() + 2.0, p[1] + 5.0 * (p[0] / 90.0).cos()]
}

/// `n` landmarks in `[lo, hi]^2` with 4-decimal sources and targets.
fn landmarks4(n: usize, seed: u64, lo: f64, hi: f64) -> Vec<Landmark> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let s = [dec4(rng.gen_range(lo..hi)), dec4(rng.gen_range(lo..hi))];
            let t = warp(s).map(dec4);
            Landmark { name: Some(format!("l{i}")), src: s, dst: t, weight: 1.0 }
        })
        .collect()
}

/// `phi(s) = t` in exact rationals for the 4-decimal texts of every landmark.
fn assert_exact(s: &Spline, lms: &[Landmark]) {
    for l in lms {
        let (src, dst) = exact_landmark(l);
        // The exact values are the decimals as written.
        assert_eq!(src[0], parse_rat(&format!("{:.4}", l.src[0])).unwrap());
        assert_eq!(dst[1], parse_rat(&format!("{:.4}", l.dst[1])).unwrap());
        let (t, b) = locate_exact(s, &src).unwrap();
        let row = bernstein_row(s, t, &b);
        for c in 0..2 {
            let got = row.iter().fold(Rat::zero(), |a, (p, w)| a + w * &s.points()[*p][c]);
            assert_eq!(got, dst[c], "{:?} coordinate {c}", l.name);
        }
    }
    s.check_c1().unwrap();
}

fn grid_511() -> Spline {
    let mesh = Mesh::grid(12, 12, 511.0, 511.0, MeshOptions::default()).unwrap();
    Spline::identity(mesh, 5).unwrap()
}

#[test]
fn hard_fit_meets_four_decimal_landmarks_exactly_on_a_grid_mesh() {
    let s = grid_511();
    let lms = landmarks4(100, 21, 3.0, 508.0);
    let hard = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap();
    assert_exact(&hard.spline, &lms);
    assert_eq!(hard.report.method.exact, Some(ExactStep::Hard));
    assert!(hard.report.fit.max < 1e-9, "{:?}", hard.report.fit);
    // The output keeps the soft fit's size order (the old grid-rounded ECLES solve wrote
    // 27 MB for 97 landmarks).
    let soft = fit(&s, &lms, &FitOptions::default()).unwrap();
    let size = |s: &Spline| crate::io::deformation::to_string(s, None).len();
    let (hs, ss) = (size(&hard.spline), size(&soft.spline));
    eprintln!("hard {hs} bytes, soft {ss} bytes, {:.1} ms", hard.report.time_ms);
    assert!(hs < 2 * ss, "hard {hs} bytes vs soft {ss}");
}

#[test]
fn hard_fit_on_a_delaunay_mesh_through_the_sources_puts_targets_on_vertices() {
    let lms = landmarks4(60, 22, 5.0, 505.0);
    let mut pts: Vec<[f64; 2]> = vec![[0.0, 0.0], [511.0, 0.0], [0.0, 511.0], [511.0, 511.0]];
    pts.extend(lms.iter().map(|l| l.src));
    let mesh = Mesh::delaunay(&pts, MeshOptions { grid: 10000 }).unwrap();
    assert_eq!(mesh.snap_report().moved, 0);
    let s = Spline::identity(mesh, 5).unwrap();
    let f = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap();
    assert_exact(&f.spline, &lms);
    for l in &lms {
        // Each source is a vertex, and the vertex's corner point (index = vertex) is the
        // target itself.
        let (src, dst) = exact_landmark(l);
        let v = (0..s.mesh().num_vertices())
            .find(|&v| {
                let c = s.mesh().vertex_int(v);
                src[0] == Rat::new(c[0].into(), 10000.into())
                    && src[1] == Rat::new(c[1].into(), 10000.into())
            })
            .unwrap();
        assert_eq!(f.spline.points()[v], dst.to_vec(), "{:?}", l.name);
    }
}

#[test]
fn hard_fit_keeps_pinned_points_exactly_and_meets_the_landmarks() {
    let s = grid_511();
    let lms = landmarks4(30, 23, 50.0, 460.0);
    // A few corner points (free) and points beside them (often dependent).
    let pinned: Vec<usize> = vec![0, 13, 40, s.mesh().num_vertices() + 5, s.num_points() - 3];
    let pins = pinned.iter().copied().map(ControlPoint).collect();
    let opts = FitOptions { hard: true, pinned: pins, ..FitOptions::default() };
    let f = fit(&s, &lms, &opts).unwrap();
    for &p in &pinned {
        assert_eq!(f.spline.points()[p], s.points()[p], "pinned {p}");
    }
    assert_exact(&f.spline, &lms);
}

#[test]
fn duplicate_landmarks_are_one_constraint() {
    let s = grid_511();
    let mut lms = landmarks4(10, 24, 20.0, 490.0);
    let mut twin = lms[3].clone();
    twin.name = Some("twin".into());
    lms.push(twin);
    let f = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap();
    assert_exact(&f.spline, &lms);
}

/// Issue 23: contradictory landmarks must name both, not "landmark 0".
#[test]
fn one_source_with_two_targets_names_both_landmarks() {
    let s = grid_511();
    let mut lms = landmarks4(8, 25, 20.0, 490.0);
    lms.push(Landmark {
        name: Some("again".into()),
        src: lms[5].src,
        dst: [lms[5].dst[0] + 0.5, lms[5].dst[1]],
        weight: 1.0,
    });
    let e = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap_err();
    assert!(matches!(e, FitError::Conflicting { .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("landmark 5 (l5)") && msg.contains("landmark 8 (again)"), "{msg}");
}

/// Issue 23: too many landmarks in one triangle say so (not "landmark 0 conflicts").
#[test]
fn too_many_landmarks_in_a_triangle_say_so() {
    let s = grid_511();
    // 30 landmarks inside one triangle of the first grid cell (a 42.6 px cell).
    let mut rng = SmallRng::seed_from_u64(26);
    let lms: Vec<Landmark> = (0..30)
        .map(|i| {
            // Below the cell's diagonal (y < x): triangle [v00, v10, v11] of the first cell.
            let a = rng.gen_range(0.1..0.95);
            let b = rng.gen_range(0.05..0.9) * a * 0.9;
            let p = [dec4(40.0 * a + 1.0), dec4(40.0 * b + 1.0)];
            Landmark { name: Some(format!("c{i}")), src: p, dst: warp(p).map(dec4), weight: 1.0 }
        })
        .collect();
    let e = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap_err();
    assert!(matches!(e, FitError::TooManyConstraints { per_triangle: 21, .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("too many constraints") && msg.contains("finer mesh"), "{msg}");
    assert!(msg.contains("landmarks (landmark"), "{msg}");
}

/// Seven landmarks on one segment inside a triangle ask a quintic for 7 values: dependent
/// rows, found by the exact reduction and reported with the landmarks involved.
#[test]
fn collinear_landmarks_beyond_the_degree_are_too_many_constraints() {
    let s = grid_511();
    let lms: Vec<Landmark> = (0..7)
        .map(|i| {
            let p = [dec4(10.0 + 2.5 * i as f64), 5.0];
            let q = [p[0] + if i % 2 == 0 { 1.0 } else { -1.0 }, p[1]];
            Landmark { name: Some(format!("s{i}")), src: p, dst: q, weight: 1.0 }
        })
        .collect();
    let e = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap_err();
    assert!(matches!(e, FitError::TooManyConstraints { .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("cannot hold together") && msg.contains("(s"), "{msg}");
    // Six of them are fine.
    let f = fit(&s, &lms[..6], &FitOptions { hard: true, ..FitOptions::default() }).unwrap();
    assert_exact(&f.spline, &lms[..6]);
}

/// Issue 23: 1,000 landmarks on a 288-triangle mesh took 27 s and then blamed "landmark 0".
/// Their rows are all coupled through shared free points; the fit says the landmarks are
/// too dense for the mesh, naming them, instead of grinding through one huge elimination.
#[test]
fn landmarks_too_dense_for_the_mesh_are_refused_as_too_many_constraints() {
    let s = grid_511();
    let lms = landmarks4(1000, 27, 3.0, 508.0);
    let e = fit(&s, &lms, &FitOptions { hard: true, ..FitOptions::default() }).unwrap_err();
    assert!(matches!(e, FitError::TooManyConstraints { .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("too dense for this mesh") && msg.contains("more landmarks"), "{msg}");
    assert!(msg.contains("finer mesh, fewer landmarks, or the soft fit"), "{msg}");
}

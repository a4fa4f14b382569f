//! 2.5D tests: identity, separation of xy and z edits, layers followed exactly, C1 of the
//! layers after random z edits.

use super::organism::{worm, WormOptions};
use super::*;
use crate::ecles::ConstraintSystem;
use crate::edit::select::Neighborhood;
use crate::edit::{Editor, Mode};
use crate::exact::{rat_int, Rat};
use crate::spline::ControlPoint;
use proptest::prelude::*;

fn small_worm() -> Model {
    worm(&WormOptions { rings: 40, around: 12, ..Default::default() })
}

/// A prism scene around `m`: a 4 x 2 grid (16 triangles), degree 5, identity layers.
fn scene(m: &Model) -> Spline {
    let (mesh, [a, b]) = auto_mesh(m, 4, 2, 0.05).unwrap();
    let mut s = Spline::identity(mesh, 5).unwrap();
    let ab = [a, b].map(|v| Rat::new(((v * 16.0).floor() as i64).into(), 16.into()));
    let ab = [ab[0].clone() - rat_int(1), ab[1].clone() + rat_int(1)];
    let z = identity_layers(&s, ab[0].clone(), ab[1].clone()).unwrap();
    s.set_z_layers(Some(z));
    s
}

fn interior_vertex(s: &Spline) -> usize {
    let m = s.mesh();
    (0..m.num_vertices()).find(|&v| !m.is_border_vertex(v)).unwrap()
}

#[test]
fn the_identity_leaves_every_vertex_in_place() {
    let m = small_worm();
    let s = scene(&m);
    let b = bind(&m, &s).unwrap();
    assert!(b.outside.is_empty());
    let out = deform(&m, &b, &s);
    for (p, q) in m.vertices.iter().zip(&out) {
        for k in 0..3 {
            assert!((p[k] - q[k]).abs() <= 1e-9 * (1.0 + p[k].abs()), "{p:?} -> {q:?}");
        }
    }
}

#[test]
fn z_edits_never_move_x_or_y_and_xy_edits_never_move_z() {
    let m = small_worm();
    let s = scene(&m);
    let b = bind(&m, &s).unwrap();
    let before = deform(&m, &b, &s);
    let v = interior_vertex(&s);
    for mode in [Mode::Z0, Mode::Z1] {
        let mut ed = Editor::new(s.clone());
        ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), mode).unwrap();
        ed.translate(&[rat_int(25)]).unwrap();
        let after = deform(&m, &b, ed.spline());
        let mut z_moved = false;
        for (p, q) in before.iter().zip(&after) {
            assert_eq!((p[0], p[1]), (q[0], q[1]), "{mode:?} moved x or y");
            z_moved |= (p[2] - q[2]).abs() > 1e-6;
        }
        assert!(z_moved, "{mode:?} moved nothing");
    }
    let mut ed = Editor::new(s.clone());
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
    ed.translate(&[rat_int(30), rat_int(-20)]).unwrap();
    let after = deform(&m, &b, ed.spline());
    let mut xy_moved = false;
    for (p, q) in before.iter().zip(&after) {
        assert_eq!(p[2], q[2], "an xy edit moved z");
        xy_moved |= (p[0] - q[0]).abs() > 1e-6;
    }
    assert!(xy_moved);
}

#[test]
fn a_vertex_at_the_top_follows_sigma1_and_one_at_the_bottom_sigma0() {
    let m = small_worm();
    let s = scene(&m);
    let z = s.z_layers().unwrap();
    let (a, top) = (rat_to_f64(&z.range[0]), rat_to_f64(&z.range[1]));
    let probe = Model {
        vertices: vec![[300.0, 10.0, top], [520.0, -20.0, a], [700.0, 5.0, (a + top) / 2.0]],
        ..Default::default()
    };
    let v = interior_vertex(&s);
    let mut ed = Editor::new(s.clone());
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(3), Mode::Z1).unwrap();
    ed.translate(&[rat_int(40)]).unwrap();
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(3), Mode::Z0).unwrap();
    ed.translate(&[rat_int(-15)]).unwrap();
    let e = ed.spline();
    let b = bind(&probe, e).unwrap();
    let out = deform(&probe, &b, e);
    for (k, p) in probe.vertices.iter().enumerate() {
        let (t, beta, _) = b.at[k].unwrap();
        let [s0, s1] = e.eval_z(t as usize, beta).unwrap();
        let want = match k {
            0 => s1,
            1 => s0,
            _ => (s0 + s1) / 2.0,
        };
        assert_eq!(out[k][2], want, "vertex {k} at z = {}", p[2]);
    }
}

#[test]
fn vertices_outside_the_prisms_are_reported_and_kept() {
    let m = small_worm();
    let s = scene(&m);
    let z = s.z_layers().unwrap();
    let top = rat_to_f64(&z.range[1]);
    let probe = Model {
        vertices: vec![[300.0, 10.0, 0.0], [-1e4, 0.0, 0.0], [300.0, 10.0, top + 1.0]],
        ..Default::default()
    };
    let b = bind(&probe, &s).unwrap();
    assert_eq!(b.outside, vec![1, 2]);
    let out = deform(&probe, &b, &s);
    assert_eq!(out[1], probe.vertices[1]);
    assert!(matches!(
        bind(&probe, &Spline::identity(s.mesh().clone(), 5).unwrap()),
        Err(PrismError::NotPrism)
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(8))]
    /// After random z edits both layers still satisfy the C1 conditions exactly.
    #[test]
    fn layers_stay_c1_after_random_z_edits(ops in proptest::collection::vec((0usize..2, -40i64..40, 0usize..100), 1..4)) {
        let m = small_worm();
        let s = scene(&m);
        let inner: Vec<usize> = (0..s.mesh().num_vertices()).filter(|&v| !s.mesh().is_border_vertex(v)).collect();
        let mut ed = Editor::new(s.clone());
        for (layer, by, pick) in ops {
            let v = inner[pick % inner.len()];
            let mode = if layer == 0 { Mode::Z0 } else { Mode::Z1 };
            ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), mode).unwrap();
            ed.translate(&[rat_int(by)]).unwrap();
        }
        let z = ed.spline().z_layers().unwrap();
        let sys = ConstraintSystem::homogeneous(s.c1_matrix().clone(), 1);
        for layer in [&z.z0, &z.z1] {
            let col: Vec<Vec<Rat>> = layer.iter().map(|x| vec![x.clone()]).collect();
            prop_assert!(sys.is_satisfied(&col));
        }
        prop_assert_eq!(ed.spline().points(), s.points());
    }
}

#[test]
fn z_ranges_parse_exactly_and_refuse_bad_text() {
    let r: ZRange = "-1/2, 3".parse().unwrap();
    assert_eq!((r.lo(), r.hi()), (&Rat::new((-1).into(), 2.into()), &rat_int(3)));
    assert_eq!("1,2.5".parse::<ZRange>().unwrap().hi(), &Rat::new(5.into(), 2.into()));
    assert_eq!("1".parse::<ZRange>().unwrap_err(), ZRangeError::Malformed);
    assert_eq!("1,1".parse::<ZRange>().unwrap_err().to_string(), "need A < B");
    assert!(matches!("2,1".parse::<ZRange>(), Err(ZRangeError::Empty { .. })));
    let e = "x,1".parse::<ZRange>().unwrap_err();
    assert!(matches!(e, ZRangeError::Value(_)));
    assert!(e.to_string().starts_with("`x` is not an exact number"), "{e}");
    let s = scene(&small_worm());
    let z = r.layers(&s);
    assert_eq!(z, identity_layers(&s, r.lo().clone(), r.hi().clone()).unwrap());
}

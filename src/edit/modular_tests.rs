//! Large selections on ECLES's modular path ([`super::modular`]) against the fraction-free
//! sessions: the same selection and the same exact values.

use super::*;
use crate::ecles::ConstraintSystem;
use crate::exact::rat_int;
use crate::mesh::Mesh;
use crate::spline::ZLayers;

fn random_mesh(seed: u64, n: usize) -> Mesh {
    crate::mesh::xorshift_mesh(seed.wrapping_mul(0x9E3779B97F4A7C15).wrapping_add(1), n, 6400, 64.0)
}

/// Two editors over the same spline (exact, unbounded): one always on the modular path,
/// one always on sessions (a threshold never reached: sessions, with the canonical growth
/// of `D`).
fn pair(s: Spline) -> (Editor, Editor) {
    let mut modular = Editor::new(s);
    let mut ldu = modular.clone();
    modular.set_modular_path(Some(0));
    ldu.set_modular_path(Some(usize::MAX));
    (modular, ldu)
}

/// Both editors select the same way; the selections must agree.
fn select_both(
    eds: (&mut Editor, &mut Editor),
    anchors: &[usize],
    hood: &Neighborhood,
    mode: Mode,
) {
    let anchors = ControlPoint::from_indices(anchors);
    let a = eds.0.select(&anchors, &[], hood, mode).unwrap().clone();
    let b = eds.1.select(&anchors, &[], hood, mode).unwrap().clone();
    assert!(a.is_modular() && !b.is_modular());
    assert!(a.session().is_none() && b.session().is_some());
    assert_eq!(a.derived, b.derived, "the same growth of D");
    assert_eq!((a.strong, a.relevant(), a.rank()), (b.strong, b.relevant(), b.rank()));
    // Which redundant conditions are left out may differ (the LDU's pivot order, the
    // canonical set on the modular path); how many may not.
    let (ia, ib) =
        (a.independent_constraints(eds.0.spline()), b.independent_constraints(eds.1.spline()));
    assert_eq!((ia.len(), ib.len()), (a.rank(), a.rank()));
}

/// Whether two lists of exact points hold the same values. The values are kept unreduced
/// (no gcd per value during edits), so they are compared by cross products: `Ratio`'s own
/// comparison of unreduced values walks their continued fractions recursively, too deep for
/// a test thread's stack on these values.
fn same_points(a: &[Vec<Rat>], b: &[Vec<Rat>]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(p, q)| {
            p.len() == q.len()
                && p.iter().zip(q).all(|(x, y)| x.numer() * y.denom() == y.numer() * x.denom())
        })
}

/// A degree-5 identity spline over a random mesh, with flat 2.5D layers at z = -2 and 2.
fn layered_spline() -> (Mesh, Spline) {
    let mesh = random_mesh(5, 20);
    let mut s = Spline::identity(mesh.clone(), 5).unwrap();
    let n = s.num_points();
    let z = |v: i64| vec![rat_int(v); n];
    s.set_z_layers(Some(ZLayers { range: [rat_int(-2), rat_int(2)], z0: z(-2), z1: z(2) }));
    (mesh, s)
}

fn inner_vertex(m: &Mesh, k: usize) -> usize {
    (0..m.num_vertices()).filter(|&v| !m.is_border_vertex(v)).nth(k).unwrap()
}

/// Translate, rotate and scale, on a neighbourhood and on everything: the modular path's
/// values are the sessions' values exactly, and C1 holds exactly.
#[test]
fn modular_selections_give_the_sessions_values() {
    let mesh = random_mesh(11, 24);
    let (mut m, mut l) = pair(Spline::identity(mesh.clone(), 5).unwrap());
    let v = inner_vertex(&mesh, 2);
    let c = [rat_int(30), Rat::new(Int::from(61), Int::from(2))];
    for hood in [Neighborhood::Radius(3), Neighborhood::All] {
        select_both((&mut m, &mut l), &[v], &hood, Mode::Xy);
        for ed in [&mut m, &mut l] {
            ed.translate(&[rat_int(2), Rat::new(Int::from(-3), Int::from(7))]).unwrap();
            // A second operation on the same selection starts from the selection's state.
            ed.rotate(c.clone(), 0.15).unwrap();
        }
        assert!(same_points(m.spline().points(), l.spline().points()), "{hood:?}");
        assert!(m.spline().check_c1().is_ok());
        select_both((&mut m, &mut l), &[v, inner_vertex(&mesh, 5)], &hood, Mode::Xy);
        for ed in [&mut m, &mut l] {
            ed.scale(&c, &Rat::new(Int::from(11), Int::from(10))).unwrap();
        }
        assert!(same_points(m.spline().points(), l.spline().points()), "{hood:?}");
    }
}

/// Under extra constraints the coordinates split into two systems (x and y): two plans.
#[test]
fn split_selections_under_extra_constraints_agree() {
    let mesh = random_mesh(3, 20);
    let (mut m, mut l) = pair(Spline::identity(mesh.clone(), 5).unwrap());
    let (a, b) = (inner_vertex(&mesh, 0), inner_vertex(&mesh, 3));
    for ed in [&mut m, &mut l] {
        ed.add_constraint(Extra::pin(b, ed.spline().points()).unwrap()).unwrap();
    }
    select_both((&mut m, &mut l), &[a], &Neighborhood::Radius(4), Mode::Xy);
    assert_eq!(m.selection().unwrap().plans.len(), 2);
    for ed in [&mut m, &mut l] {
        ed.translate(&[rat_int(3), rat_int(-1)]).unwrap();
    }
    assert!(same_points(m.spline().points(), l.spline().points()));
}

/// z modes (one coordinate, the `z0` / `z1` layers).
#[test]
fn z_mode_selections_agree() {
    let (mesh, s) = layered_spline();
    let (mut m, mut l) = pair(s.clone());
    let v = inner_vertex(&mesh, 1);
    select_both((&mut m, &mut l), &[v], &Neighborhood::All, Mode::Z1);
    for ed in [&mut m, &mut l] {
        ed.translate(&[Rat::new(Int::from(5), Int::from(3))]).unwrap();
    }
    let (zm, zl) = (m.spline().z_layers().unwrap(), l.spline().z_layers().unwrap());
    assert!(same_points(&[zm.z0.clone(), zm.z1.clone()], &[zl.z0.clone(), zl.z1.clone()]));
    assert_eq!(zm.z1[v], Rat::new(Int::from(11), Int::from(3)));
    let sys = ConstraintSystem::homogeneous(s.c1_matrix().clone(), 1);
    let col: Vec<Vec<Rat>> = zm.z1.iter().map(|x| vec![x.clone()]).collect();
    assert!(sys.is_satisfied(&col), "z1 is C1 exactly");
    assert_eq!(m.spline().points(), s.points(), "xy untouched by a z edit");
}

/// An unsolvable operation on a modular selection is refused as on sessions and changes
/// nothing; the selection stays usable.
#[test]
fn a_refused_modular_operation_changes_nothing() {
    let mesh = random_mesh(7, 20);
    let (mut m, mut l) = pair(Spline::identity(mesh.clone(), 5).unwrap());
    let a = inner_vertex(&mesh, 0);
    for ed in [&mut m, &mut l] {
        ed.add_constraint(Extra::pin(a, ed.spline().points()).unwrap()).unwrap();
    }
    select_both((&mut m, &mut l), &[a], &Neighborhood::Radius(3), Mode::Xy);
    let before = m.spline().clone();
    let (em, el) = (
        m.translate(&[rat_int(1), rat_int(0)]).unwrap_err(),
        l.translate(&[rat_int(1), rat_int(0)]).unwrap_err(),
    );
    // The same refusal; which dependent condition it names may differ (the LDU's pivot
    // order, the canonical order on the modular path).
    for e in [&em, &el] {
        assert!(matches!(e, EditError::Ecles(EclesError::NotWeaklySolvable { .. })), "{e}");
    }
    assert_eq!(m.spline().points(), before.points());
    m.translate(&[rat_int(0), rat_int(0)]).unwrap();
    assert_eq!(m.spline().points(), before.points());
}

/// The drag preview of a modular selection follows the exact translation.
#[test]
fn modular_preview_follows_the_exact_translation() {
    let mesh = random_mesh(13, 24);
    let (mut m, mut l) = pair(Spline::identity(mesh.clone(), 5).unwrap());
    let v = inner_vertex(&mesh, 4);
    select_both((&mut m, &mut l), &[v], &Neighborhood::Radius(4), Mode::Xy);
    let d = [2.5, -1.25];
    let (pm, pl) = (m.preview_translate(d).unwrap(), l.preview_translate(d).unwrap());
    assert!(m.selection().unwrap().is_modular(), "the preview keeps the modular plan");
    for (a, b) in pm.iter().zip(&pl) {
        assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9, "{a:?} {b:?}");
    }
    m.translate(&[exact(d[0]).unwrap(), exact(d[1]).unwrap()]).unwrap();
    let sel = m.selection().unwrap();
    let idx: Vec<usize> = sel.anchors.iter().chain(&sel.derived).map(|p| p.index()).collect();
    for (k, &p) in idx.iter().enumerate() {
        let q = m.spline().point_f64(p);
        assert!((q[0] - pm[k][0]).abs() < 1e-6 && (q[1] - pm[k][1]).abs() < 1e-6, "{p}");
    }
}

/// The threshold: small selections stay on sessions by default, select-all on a mesh of
/// this size goes modular.
#[test]
fn the_default_threshold_chooses_by_size() {
    let mesh = random_mesh(11, 24);
    let mut ed = Editor::new(Spline::identity(mesh.clone(), 5).unwrap());
    let v = ControlPoint(inner_vertex(&mesh, 2));
    assert!(!ed.select(&[v], &[], &Neighborhood::Radius(1), Mode::Xy).unwrap().is_modular());
    let all = ed.select(&[v], &[], &Neighborhood::All, Mode::Xy).unwrap();
    assert!(all.relevant() * all.derived.len() >= MODULAR_MIN_ENTRIES);
    assert!(all.is_modular());
}

/// When an operation cannot be certified, the selection goes on with sessions built for the
/// same edit (xy, split under extra constraints, z): the values stay the sessions' values.
#[test]
fn the_fallback_to_sessions_keeps_the_edit() {
    let (mesh, s) = layered_spline();
    let v = inner_vertex(&mesh, 1);
    for (mode, pin) in [(Mode::Xy, false), (Mode::Xy, true), (Mode::Z0, false)] {
        let (mut m, mut l) = pair(s.clone());
        if pin {
            for ed in [&mut m, &mut l] {
                let b = inner_vertex(&mesh, 4);
                ed.add_constraint(Extra::pin(b, ed.spline().points()).unwrap()).unwrap();
            }
        }
        select_both((&mut m, &mut l), &[v], &Neighborhood::Radius(3), mode);
        let by: Vec<Rat> = match mode {
            Mode::Xy => vec![rat_int(1), Rat::new(Int::from(2), Int::from(3))],
            _ => vec![Rat::new(Int::from(-1), Int::from(5))],
        };
        m.translate(&by).unwrap();
        m.fall_back_to_sessions().unwrap();
        let sel = m.selection().unwrap();
        assert!(!sel.is_modular() && sel.sessions().len() == if pin { 2 } else { 1 });
        for ed in [&mut m, &mut l] {
            ed.translate(&by.iter().map(|x| x * rat_int(2)).collect::<Vec<_>>()).unwrap();
        }
        assert!(same_points(m.spline().points(), l.spline().points()), "{mode:?} {pin}");
        let (zm, zl) = (m.spline().z_layers().unwrap(), l.spline().z_layers().unwrap());
        assert!(
            same_points(std::slice::from_ref(&zm.z0), std::slice::from_ref(&zl.z0)),
            "{mode:?} {pin}"
        );
    }
}

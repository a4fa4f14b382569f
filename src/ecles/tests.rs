//! ECLES tests: thesis goldens and exact properties on random systems.

use super::*;
use crate::exact::ldu::{Ldu, LduOptions, Simplification};
use crate::exact::matrix::{rat_int, rat_to_big, IntMatrix, Rat, SparseIntMatrix};
use crate::exact::{reference, Int};
use num_rational::BigRational;
use num_traits::Zero;
use proptest::prelude::*;

fn col(v: &[i64]) -> Vec<Vec<Rat>> {
    v.iter().map(|x| vec![rat_int(*x)]).collect()
}

#[test]
fn pump_system() {
    let r = IntMatrix::from_i64_rows(4, &[vec![1, 1, -1, 0], vec![0, 0, -1, 1]]).to_sparse();
    let sys = ConstraintSystem::new(r, col(&[0, 5])).unwrap();
    let p = col(&[1, 2, 3, 8]);
    assert!(sys.is_satisfied(&p));
    // Anchor pump 0; pumps 1, 2, 3 derived: 3 unknowns, 2 constraints, least squares.
    let mut s = sys.initialize(&p, &[0], &[1, 2, 3], InitOptions::default()).unwrap();
    assert_eq!(s.relevant(), &[0, 1]);
    assert!(s.fixed_relevant().is_empty());
    assert_eq!(s.rank(), 2);
    s.update(&col(&[4]), None, None).unwrap();
    let out = s.derived_values();
    let mut full = p.clone();
    s.write_into(&mut full);
    assert!(sys.is_satisfied(&full));
    // Closest to (2, 3, 8) with p1 + 4 = p2, p3 = p2 + 5: minimize (p1-2)^2 + (p2-3)^2 + (p3-8)^2
    // over p1 = t, p2 = t + 4, p3 = t + 9: t = (2 + -1 + -1)/3 = 0.
    assert_eq!(out, col(&[0, 4, 9]));
}

/// Sections 8.3 / 9.2 as an ECLES edit: R = [A | -B], the last parameter anchored at 1.
fn thesis_9_2() -> (ConstraintSystem, Vec<Vec<Rat>>) {
    let a = [
        [4, 9, 16, 29, -142],
        [-1, -6, -19, -16, -42],
        [1, 5, 15, 19, -40],
        [5, 6, -1, -12, 128],
        [5, 10, 15, 20, -50],
    ];
    let rows: Vec<Vec<i64>> = a.iter().map(|r| r.to_vec()).collect();
    let r = IntMatrix::from_i64_rows(5, &rows).to_sparse();
    let sys = ConstraintSystem::homogeneous(r, 1);
    (sys, col(&[1, 1, 1, 1, 1]))
}

#[test]
fn thesis_least_squares_example_9_2() {
    let (sys, p) = thesis_9_2();
    let half = |v: i64| Rat::new(Int::from(v), Int::from(2));
    for method in [Simplification::None, Simplification::Gcd, Simplification::Turner] {
        let opts = InitOptions { strong: false, method, ..Default::default() };
        let mut s = sys.initialize(&p, &[4], &[0, 1, 2, 3], opts).unwrap();
        assert_eq!(s.rank(), 3);
        assert_eq!(s.redundant().len(), 2);
        s.update(&col(&[1]), Some(&col(&[1, 1, 1, 1])), None).unwrap();
        assert_eq!(
            s.derived_values(),
            vec![vec![half(3)], vec![half(-3)], vec![half(-23)], vec![half(23)]]
        );
    }
}

#[test]
fn failed_update_leaves_session_unchanged() {
    let (sys, p) = thesis_9_2();
    let mut s = sys.initialize(&p, &[4], &[0, 1, 2, 3], InitOptions::default()).unwrap();
    // Not strongly solvable? The anchor column -B lies in the column space of A (B is
    // consistent), so it is; the anchor at 2 scales B and stays solvable.
    s.check_strong().unwrap();
    let before = (s.anchor_values().to_vec(), s.derived_values());
    // Wrong sizes, bad weights: errors, nothing changes.
    assert!(matches!(s.update(&col(&[1, 2]), None, None), Err(EclesError::Dimension { .. })));
    let w = vec![rat_int(1), rat_int(0), rat_int(1), rat_int(1)];
    assert!(matches!(
        s.update(&col(&[2]), None, Some(&w)),
        Err(EclesError::NonPositiveWeight { index: 1, .. })
    ));
    assert_eq!((s.anchor_values().to_vec(), s.derived_values()), before);
    // An inconsistent system: two copies of one row with different constants.
    let r = IntMatrix::from_i64_rows(3, &[vec![1, 1, 0], vec![1, 1, 1]]).to_sparse();
    let sys2 = ConstraintSystem::new(r, col(&[0, 0])).unwrap();
    let p2 = col(&[0, 0, 0]);
    // Anchor 2, derived 0 and 1: rows differ only by p2, so moving p2 breaks them.
    let mut s2 = sys2.initialize(&p2, &[2], &[0, 1], InitOptions::default()).unwrap();
    assert_eq!(s2.rank(), 1);
    let strong =
        sys2.initialize(&p2, &[2], &[0, 1], InitOptions { strong: true, ..Default::default() });
    assert!(matches!(strong, Err(EclesError::NotStronglySolvable { .. })));
    let err = s2.update(&col(&[5]), None, None).unwrap_err();
    assert!(matches!(err, EclesError::NotWeaklySolvable { column: 0, .. }), "{err}");
    assert_eq!(s2.anchor_values(), &col(&[0])[..]);
    // Moving the anchor by zero is fine.
    s2.update(&col(&[0]), None, None).unwrap();
    assert_eq!(s2.derived_values(), col(&[0, 0]));
}

#[test]
fn bad_edits_are_rejected() {
    let (sys, p) = thesis_9_2();
    let o = InitOptions::default();
    assert_eq!(sys.initialize(&p, &[], &[0], o).unwrap_err(), EclesError::NoAnchors);
    assert!(matches!(
        sys.initialize(&p, &[4], &[4], o),
        Err(EclesError::AnchorAlsoDerived { index: 4 })
    ));
    assert!(matches!(sys.initialize(&p, &[9], &[0], o), Err(EclesError::IndexOutOfRange { .. })));
    assert!(matches!(sys.initialize(&p, &[4], &[0, 0], o), Err(EclesError::Duplicate { .. })));
    assert!(matches!(sys.initialize(&p[..2], &[4], &[0], o), Err(EclesError::Dimension { .. })));
}

/// A random consistent system with parameters in R^2: R (m x n, sparse, small entries),
/// P random, Q = R P.
/// (R, P, anchors, derived, new anchor values, weights)
type Case = (SparseIntMatrix, Vec<Vec<Rat>>, Vec<usize>, Vec<usize>, Vec<Vec<Rat>>, Vec<Rat>);

fn system_strategy() -> impl Strategy<Value = Case> {
    (1usize..7, 2usize..9).prop_flat_map(|(m, n)| {
        (
            prop::collection::vec(prop::collection::vec((0..n, -4i64..=4), 1..4), m),
            prop::collection::vec(-6i64..=6, n * 2),
            prop::collection::vec(0u8..4, n),
            prop::collection::vec(-6i64..=6, n * 2),
            prop::collection::vec(1i64..=4, n),
        )
            .prop_map(move |(rows, pv, roles, newv, w)| {
                let rows = rows
                    .into_iter()
                    .map(|r| r.into_iter().map(|(c, v)| (c, Int::from(v))).collect())
                    .collect();
                let r = SparseIntMatrix::from_rows(n, rows).unwrap();
                let p: Vec<Vec<Rat>> =
                    (0..n).map(|s| vec![rat_int(pv[2 * s]), rat_int(pv[2 * s + 1])]).collect();
                let mut anchors: Vec<usize> = (0..n).filter(|&s| roles[s] == 0).collect();
                if anchors.is_empty() {
                    anchors.push(0);
                }
                let derived: Vec<usize> = (0..n)
                    .filter(|&s| (roles[s] == 1 || roles[s] == 2) && !anchors.contains(&s))
                    .collect();
                let new_a: Vec<Vec<Rat>> = anchors
                    .iter()
                    .map(|&s| vec![rat_int(newv[2 * s]), rat_int(newv[2 * s + 1])])
                    .collect();
                let weights: Vec<Rat> =
                    derived.iter().map(|&s| Rat::new(Int::from(w[s]), Int::from(3))).collect();
                (r, p, anchors, derived, new_a, weights)
            })
    })
}

fn to_big_rows(m: &[Vec<Rat>]) -> Vec<Vec<BigRational>> {
    m.iter().map(|r| r.iter().map(rat_to_big).collect()).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]
    #[test]
    fn updates_are_exact_optimal_and_atomic((r, p, anchors, derived, new_a, weights) in system_strategy()) {
        let q = r.mul_rat(&p);
        let sys = ConstraintSystem::new(r.clone(), q).unwrap();
        let mut s = sys.initialize(&p, &anchors, &derived, InitOptions::default()).unwrap();
        let map = s.affine_map(Some(&weights)).unwrap();
        let hints: Vec<Vec<Rat>> = derived.iter().map(|&t| p[t].iter().map(|v| v + rat_int(1)).collect()).collect();
        let before = s.derived_values();
        match s.update(&new_a, Some(&hints), Some(&weights)) {
            Ok(()) => {
                let out = s.derived_values();
                let mut full = p.clone();
                s.write_into(&mut full);
                // Every constraint holds exactly; fixed parameters did not move.
                prop_assert!(sys.is_satisfied(&full));
                for t in 0..p.len() {
                    if !anchors.contains(&t) && !derived.contains(&t) {
                        prop_assert_eq!(&full[t], &p[t]);
                    }
                }
                // Lagrange condition, exactly: W (x'' - x') lies in the row space of R_ED,
                // i.e. R_ED^T lambda = W (x'' - x') is consistent.
                let (e, _) = sys.extract_relevant(&anchors, &derived);
                let mut cm = vec![None; p.len()];
                for (k, &t) in derived.iter().enumerate() { cm[t] = Some(k); }
                let red = r.select(&e, &cm, derived.len()).to_dense();
                let rt: Vec<Vec<(usize, Int)>> = (0..derived.len())
                    .map(|k| (0..e.len()).map(|i| (i, red.get(i, k).clone())).collect())
                    .collect();
                let rt = SparseIntMatrix::from_rows(e.len(), rt).unwrap();
                let f = Ldu::factor(&rt, LduOptions::default());
                if s.rank() < derived.len() {
                    for c in 0..2 {
                        let g: Vec<Rat> = (0..derived.len()).map(|k| &weights[k] * (&out[k][c] - &hints[k][c])).collect();
                        prop_assert!(f.is_consistent(&g), "not optimal");
                    }
                }
                // The exact affine map agrees with the update.
                prop_assert_eq!(map.apply(&new_a, &hints), out.clone());
                // The f64 map agrees to 1e-9 relative.
                let fm = map.to_f64();
                let af: Vec<f64> = new_a.iter().flatten().map(crate::exact::rat_to_f64).collect();
                let hf: Vec<f64> = hints.iter().flatten().map(crate::exact::rat_to_f64).collect();
                let mut o = vec![0.0; derived.len() * 2];
                fm.eval_into(&af, &hf, &mut o);
                for (x, y) in o.iter().zip(out.iter().flatten()) {
                    let y = crate::exact::rat_to_f64(y);
                    prop_assert!((x - y).abs() <= 1e-9 * (1.0 + y.abs()), "{x} vs {y}");
                }
            }
            Err(EclesError::NotWeaklySolvable { .. }) => {
                // Independently: [R_ED | b] has larger rank than R_ED for some coordinate.
                prop_assert_eq!(s.derived_values(), before.clone());
                let (e, fixed) = sys.extract_relevant(&anchors, &derived);
                let mut newp = p.clone();
                for (k, &a) in anchors.iter().enumerate() { newp[a] = new_a[k].clone(); }
                let mut found = false;
                for c in 0..2 {
                    let mut aug = Vec::new();
                    let mut plain = Vec::new();
                    for &i in &e {
                        let row: Vec<BigRational> = derived.iter().map(|&t| BigRational::from_integer(r.get(i, t).to_big())).collect();
                        let mut b = rat_to_big(&sys.rhs()[i][c]);
                        for &t in anchors.iter().chain(&fixed) {
                            b -= BigRational::from_integer(r.get(i, t).to_big()) * rat_to_big(&newp[t][c]);
                        }
                        let mut ar = row.clone();
                        ar.push(b);
                        aug.push(ar);
                        plain.push(row);
                    }
                    if reference::rank(&aug) > reference::rank(&plain) { found = true; }
                }
                prop_assert!(found, "reported unsolvable but the reference solves it");
                // The map's check for strong solvability must then fail too.
                prop_assert!(s.check_strong().is_err());
            }
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
        let _ = to_big_rows(&p);
        let _ = BigRational::zero();
    }
}

//! The modular exact path against the fraction-free reference (issue 24), through the
//! library's `Problem` API and the `trimorph solve` binary.

mod common;
use common::*;

use proptest::prelude::*;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use trimorph::ecles::problem::{Problem, SolvePath};
use trimorph::ecles::EclesError;
use trimorph::exact::{rat_to_string, Int, Rat};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::Spline;

/// `Problem::solve` on both paths: the same P, rank, relevant, fixed and (canonical)
/// redundant sets, every constraint exact; or the same kind of error.
fn assert_paths_agree(mut pr: Problem) {
    pr.path = SolvePath::FractionFree;
    let ff = pr.solve();
    let md = pr.solve_modular();
    match (ff, md) {
        (Ok(a), Ok(Some(b))) => {
            assert_eq!(a.p, b.p, "P bit for bit");
            assert_eq!(a.rank, b.rank);
            assert_eq!(a.relevant, b.relevant);
            assert_eq!(a.fixed_relevant, b.fixed_relevant);
            assert_eq!(a.redundant, b.redundant, "the canonical redundant set");
            assert!(a.all_constraints_hold && b.all_constraints_hold);
            assert_eq!((a.path, b.path), ("fraction_free", "modular"));
            let json = |s: &trimorph::ecles::problem::Solution| serde_json::to_value(s).unwrap();
            assert_eq!(json(&b)["P"], json(&a)["P"]);
        }
        (Ok(_), Ok(None)) => panic!("the modular path could not certify a solvable edit"),
        (Err(e1), Err(e2)) => {
            assert_eq!(std::mem::discriminant(&e1), std::mem::discriminant(&e2), "{e1} vs {e2}")
        }
        (a, b) => panic!("paths disagree: {a:?} vs {b:?}"),
    }
}

/// The JSON problem of an edit of a degree-5 C1 spline over a random Delaunay mesh.
fn c1_problem(points: usize, seed: u64, derived_fraction: f64, sparse: bool) -> String {
    let mut rng = SmallRng::seed_from_u64(seed);
    let pts: Vec<[f64; 2]> =
        (0..points).map(|_| [rng.gen_range(0.0..100.0), rng.gen_range(0.0..100.0)]).collect();
    let mesh = Mesh::delaunay(&pts, MeshOptions::default()).unwrap();
    let s = Spline::identity(mesh, 5).unwrap();
    let r = s.c1_matrix();
    let n = r.cols();
    let anchor = rng.gen_range(0..n);
    let derived: Vec<usize> =
        (0..n).filter(|&i| i != anchor && rng.gen_bool(derived_fraction)).collect();
    let r_json = if sparse {
        let rows: Vec<String> = (0..r.rows())
            .map(|i| {
                let e: Vec<String> = r.row(i).iter().map(|(j, v)| format!("[{j},{v}]")).collect();
                format!("[{}]", e.join(","))
            })
            .collect();
        format!("{{\"rows\": [{}]}}", rows.join(","))
    } else {
        let rows: Vec<String> = (0..r.rows())
            .map(|i| {
                let mut d = vec!["0".to_string(); n];
                for (j, v) in r.row(i) {
                    d[*j] = v.to_string();
                }
                format!("[{}]", d.join(","))
            })
            .collect();
        format!("[{}]", rows.join(","))
    };
    let p: Vec<String> = s
        .points()
        .iter()
        .map(|q| format!("[\"{}\",\"{}\"]", rat_to_string(&q[0]), rat_to_string(&q[1])))
        .collect();
    let a = &s.points()[anchor];
    let mv = |v: &Rat, k: i64| rat_to_string(&(v + Rat::new(Int::from(k), Int::from(7))));
    let weights: Vec<String> =
        derived.iter().step_by(3).map(|d| format!("\"{d}\": \"{}/2\"", 1 + d % 5)).collect();
    format!(
        "{{\"R\": {r_json}, \"P\": [{}], \"anchors\": {{\"{anchor}\": [\"{}\", \"{}\"]}}, \
         \"derived\": [{}], \"weights\": {{{}}}}}",
        p.join(","),
        mv(&a[0], 3),
        mv(&a[1], -2),
        derived.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(","),
        weights.join(",")
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// Real C1 systems of random meshes (rank deficient: interior vertices make C1
    /// conditions redundant), random derived sets and weights.
    #[test]
    fn c1_edits_agree_bit_for_bit(points in 5usize..9, seed in 0u64..10_000, frac in 0.3f64..1.0) {
        let text = c1_problem(points, seed, frac, seed % 2 == 0);
        assert_paths_agree(Problem::from_json(&text).unwrap());
    }

    /// Random sparse rank-deficient systems with a right-hand side, hints and weights;
    /// solvable or not (then both paths refuse with the same kind of error).
    #[test]
    fn random_sparse_edits_agree(seed in 0u64..100_000, m in 2usize..12, n in 3usize..14, strong in any::<bool>()) {
        let mut rng = SmallRng::seed_from_u64(seed);
        let mut rows: Vec<Vec<i64>> = (0..m)
            .map(|_| {
                let mut r = vec![0i64; n];
                for _ in 0..rng.gen_range(1..4) {
                    r[rng.gen_range(0..n)] = rng.gen_range(-6..=6);
                }
                r
            })
            .collect();
        for _ in 0..rng.gen_range(0..3) {
            let (a, b) = (rng.gen_range(0..rows.len()), rng.gen_range(0..rows.len()));
            let (ca, cb) = (rng.gen_range(-2..=2), rng.gen_range(-2..=2));
            let r: Vec<i64> = (0..n).map(|j| ca * rows[a][j] + cb * rows[b][j]).collect();
            rows.push(r);
        }
        let p: Vec<String> = (0..n).map(|j| format!("[\"{}/{}\"]", j as i64 - 4, 1 + j % 3)).collect();
        // Q = R P for a random P (so the current state is consistent), then the anchor moves.
        let pv: Vec<Rat> = (0..n).map(|j| Rat::new(Int::from(j as i64 - 4), Int::from(1 + (j % 3) as i64))).collect();
        let q: Vec<String> = rows.iter().map(|r| {
            let v = r.iter().zip(&pv).fold(Rat::from_integer(Int::from(0)), |acc, (c, x)| acc + Rat::from_integer(Int::from(*c)) * x);
            format!("[\"{}\"]", rat_to_string(&v))
        }).collect();
        let anchor = rng.gen_range(0..n);
        let derived: Vec<usize> = (0..n).filter(|&j| j != anchor && rng.gen_bool(0.7)).collect();
        let r_json: Vec<String> = rows.iter().map(|r| format!("[{}]", r.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(","))).collect();
        let text = format!(
            "{{\"R\": [{}], \"Q\": [{}], \"P\": [{}], \"anchors\": {{\"{anchor}\": [\"{}/3\"]}}, \"derived\": {:?}, \"strong\": {strong}}}",
            r_json.join(","), q.join(","), p.join(","), rng.gen_range(-9..9), derived
        );
        assert_paths_agree(Problem::from_json(&text).unwrap());
    }
}

/// The sparse `"R": {"rows": ...}` form reads as the same problem as the dense form.
#[test]
fn sparse_and_dense_forms_agree() {
    let dense = Problem::from_json(&c1_problem(7, 3, 0.8, false)).unwrap().solve().unwrap();
    let sparse = Problem::from_json(&c1_problem(7, 3, 0.8, true)).unwrap().solve().unwrap();
    assert_eq!(dense, sparse);
}

/// Bad sparse rows name the element.
#[test]
fn sparse_form_errors_name_the_element() {
    let base = |r: &str| {
        format!("{{\"R\": {r}, \"P\": [[1], [2]], \"anchors\": {{\"0\": [1]}}, \"derived\": [1]}}")
    };
    for (r, path) in [
        ("{\"rows\": [[[0, 1], [5, 1]]]}", "R.rows[0][1][0]"),
        ("{\"rows\": [[[0, 1], [0, 2]]]}", "R.rows[0]"),
        ("{\"rows\": [[[0, 0.5]]]}", "R.rows[0][0][1]"),
        ("{\"rows\": [[0, 1]]}", "R.rows[0][0]"),
        ("{\"cols\": 2}", "R"),
        ("{\"rows\": 3}", "R.rows"),
    ] {
        match Problem::from_json(&base(r)) {
            Err(trimorph::ecles::problem::ProblemError::Key { path: p, .. }) => {
                assert_eq!(p, path, "{r}")
            }
            other => panic!("{r}: {other:?}"),
        }
    }
}

/// `trimorph solve` on a select-all C1 edit large enough for `"auto"` to take the modular
/// path: the output names the path, and equals the forced fraction-free output.
#[test]
fn cli_auto_picks_modular_and_matches_fraction_free() {
    let dir = tempfile::tempdir().unwrap();
    let text = c1_problem(14, 11, 1.0, true);
    let pr = Problem::from_json(&text).unwrap();
    let (e, _) = pr.system.extract_relevant(&pr.anchors, &pr.derived);
    assert!(e.len() * pr.derived.len() >= trimorph::ecles::problem::MODULAR_MIN_ENTRIES);
    let f = dir.path().join("p.json");
    std::fs::write(&f, &text).unwrap();
    let o = trimorph(&["solve", s(&f)]);
    ok(&o);
    let auto: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(auto["path"], "modular");
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["path"] = "fraction_free".into();
    std::fs::write(&f, v.to_string()).unwrap();
    let o = trimorph(&["solve", s(&f)]);
    ok(&o);
    let ff: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(ff["path"], "fraction_free");
    for key in
        ["P", "P_float", "rank", "relevant", "fixed_relevant", "redundant", "all_constraints_hold"]
    {
        assert_eq!(auto[key], ff[key], "{key}");
    }
    assert!(!auto["redundant"].as_array().unwrap().is_empty(), "a rank-deficient system");
    let _ = EclesError::NoAnchors;
}

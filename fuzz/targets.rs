//! The bodies of the fuzz targets, shared by the fuzz crate (`fuzz/fuzz_targets/*.rs`) and
//! the regression test (`tests/fuzz_regressions.rs`), so a saved input replays through
//! exactly the code the fuzzer ran. Each function must return (errors are fine) and never
//! panic; `ldu_rebuild` also asserts the exact rebuild of the matrix from its factors.

#![allow(dead_code)]

use std::path::Path;
use trimorph::exact::{Int, Ldu, LduOptions, Pivoting, Simplification, SparseIntMatrix};

/// The names of all targets, in the order of `fuzz/Cargo.toml`.
pub const TARGETS: &[&str] = &[
    "deformation_json",
    "solve_json",
    "model_obj",
    "model_ply",
    "landmarks_csv",
    "landmarks_bigwarp",
    "edit_script",
    "ldu_rebuild",
];

/// Runs the target called `name` on `data`.
pub fn run(name: &str, data: &[u8]) {
    match name {
        "deformation_json" => deformation_json(data),
        "solve_json" => solve_json(data),
        "model_obj" => model_obj(data),
        "model_ply" => model_ply(data),
        "landmarks_csv" => landmarks_csv(data),
        "landmarks_bigwarp" => landmarks_bigwarp(data),
        "edit_script" => edit_script(data),
        "ldu_rebuild" => ldu_rebuild(data),
        other => panic!("unknown fuzz target {other}"),
    }
}

fn text(data: &[u8]) -> Option<&str> {
    std::str::from_utf8(data).ok()
}

/// A deformation file: parse, and when it loads, serialize it and parse it back.
pub fn deformation_json(data: &[u8]) {
    let Some(t) = text(data) else { return };
    if let Ok((s, last)) = trimorph::io::deformation::from_str(t) {
        let again = trimorph::io::deformation::to_string(&s, last.as_ref());
        let (s2, _) = trimorph::io::deformation::from_str(&again)
            .expect("a written deformation must load again");
        assert_eq!(s.points(), s2.points(), "the round trip changed the control points");
        let _ = trimorph::io::deformation::constraints_from_str(t, &s);
    }
}

/// A `trimorph solve` problem: parse and solve.
pub fn solve_json(data: &[u8]) {
    let Some(t) = text(data) else { return };
    if let Ok(p) = trimorph::ecles::problem::Problem::from_json(t) {
        if let Ok(sol) = p.solve() {
            let _ = sol.to_json();
        }
    }
}

/// An OBJ model (the reader of `model bind`, `render --model`, `warp --model`).
pub fn model_obj(data: &[u8]) {
    if let Ok(m) = trimorph::io::model::parse_model(data, Path::new("fuzz.obj")) {
        let _ = m.validate();
    }
}

/// A PLY model, read both as a model and as a coloured mesh (`warp --mesh`).
pub fn model_ply(data: &[u8]) {
    if let Ok(m) = trimorph::io::model::parse_model(data, Path::new("fuzz.ply")) {
        let _ = m.validate();
    }
    let _ = trimorph::io::colormesh::read_ply(data, Path::new("fuzz.ply"));
}

/// Landmark CSV (`name,src_x,src_y,dst_x,dst_y[,weight]`), with a write / read round trip.
pub fn landmarks_csv(data: &[u8]) {
    use trimorph::fit::landmarks as lm;
    let Some(t) = text(data) else { return };
    if let Ok(l) = lm::parse_csv(t) {
        if let Ok(out) = lm::to_csv(&l) {
            let back = lm::parse_csv(&out).expect("written landmarks must load again");
            assert_eq!(back.len(), l.len());
        }
    }
}

/// Fiji BigWarp landmark CSV, both column orders.
pub fn landmarks_bigwarp(data: &[u8]) {
    use trimorph::fit::landmarks as lm;
    let Some(t) = text(data) else { return };
    for swap in [false, true] {
        if let Ok(l) = lm::parse_bigwarp(t, swap) {
            if let Ok(out) = lm::to_bigwarp(&l, swap) {
                let back = lm::parse_bigwarp(&out, swap).expect("written landmarks must load");
                assert_eq!(back.len(), l.len());
            }
        }
    }
    let _ = lm::parse(t, lm::LandmarkFormat::detect(Some("csv"), t));
}

/// An edit script applied to a small quintic spline over a 2 x 2 grid of 8 x 8 pixels.
pub fn edit_script(data: &[u8]) {
    use trimorph::edit::Editor;
    use trimorph::mesh::{Mesh, MeshOptions};
    use trimorph::spline::Spline;
    let Some(t) = text(data) else { return };
    let mesh = Mesh::grid(2, 2, 8.0, 8.0, MeshOptions { grid: 16 }).expect("grid mesh");
    let spline = Spline::identity(mesh, 5).expect("identity spline");
    let mut ed = Editor::new(spline);
    ed.set_bounded(Some(24)).expect("bounded editing");
    let before = ed.spline().clone();
    let Ok(script) = trimorph::edit::script::Script::from_json_str(t) else { return };
    match script.run(&mut ed) {
        Ok(_) => ed.spline().check_c1().expect("an accepted edit keeps C1 exactly"),
        Err(_) => {
            assert!(ed.spline().points() == before.points(), "a refused script changes nothing")
        }
    }
}

/// Decodes bytes into a small integer matrix and its options: byte 0 = rows (1..=8), byte 1
/// = cols (1..=8), byte 2 = options, then one signed byte per entry (missing entries are 0;
/// entries are scaled by byte 3 for larger values).
pub fn ldu_matrix(data: &[u8]) -> Option<(SparseIntMatrix, LduOptions)> {
    let (&r, rest) = data.split_first()?;
    let (&c, rest) = rest.split_first()?;
    let (&o, rest) = rest.split_first()?;
    let (&scale, rest) = rest.split_first()?;
    let (m, n) = (1 + r as usize % 8, 1 + c as usize % 8);
    let simplification =
        [Simplification::None, Simplification::Gcd, Simplification::Turner][o as usize % 3];
    let pivoting = [Pivoting::Markowitz, Pivoting::SmallestMagnitude, Pivoting::SymmetricMarkowitz]
        [(o as usize / 3) % 3];
    let mult = 1 + (scale as i64 % 16).pow(4);
    // Symmetric pivoting is meant for symmetric matrices: mirror the lower triangle.
    let sym = pivoting == Pivoting::SymmetricMarkowitz;
    let n = if sym { m } else { n };
    let entry = |i: usize, j: usize| {
        let (i, j) = if sym && j > i { (j, i) } else { (i, j) };
        *rest.get(i * n + j).unwrap_or(&0) as i8 as i64 * mult
    };
    let rows = (0..m)
        .map(|i| {
            (0..n)
                .filter_map(|j| {
                    let v = entry(i, j);
                    (v != 0).then(|| (j, Int::from(v)))
                })
                .collect()
        })
        .collect();
    let a = SparseIntMatrix::from_rows(n, rows).ok()?;
    Some((a, LduOptions { simplification, pivoting }))
}

/// The exact fraction-free LDU: factor a small integer matrix and rebuild it exactly.
pub fn ldu_rebuild(data: &[u8]) {
    let Some((a, opts)) = ldu_matrix(data) else { return };
    let f = Ldu::factor(&a, opts);
    f.sanity_check().expect("the factors' invariants hold");
    assert!(f.reconstructs(&a), "A is not rebuilt from its factors: {a:?} with {opts:?}");
    assert!(f.rank() <= a.rows().min(a.cols()));
}

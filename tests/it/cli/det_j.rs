//! The det J certificate from outside: `check`, `field --jacobian` and `edit` report the
//! same sampled minimum and certified lower bound, and `edit` warns about folds.

use crate::common;
use common::*;

use serde_json::{json, Value};
use std::path::Path;

/// The two numbers of a `det J: sampled minimum A (...), certified lower bound B; ...` line.
fn det_j_numbers(text: &str) -> (f64, f64, String) {
    let line = text
        .lines()
        .find(|l| l.starts_with("det J: sampled minimum "))
        .unwrap_or_else(|| panic!("no det J line in\n{text}"));
    let rest = &line["det J: sampled minimum ".len()..];
    let sampled: f64 = rest.split_whitespace().next().unwrap().parse().unwrap();
    let lb = line.split("certified lower bound ").nth(1).unwrap();
    let lb: f64 = lb.split(';').next().unwrap().parse().unwrap();
    (sampled, lb, line.to_string())
}

fn edit(def: &Path, script: &Value, out: &Path) -> std::process::Output {
    let sp = def.with_extension("script.json");
    std::fs::write(&sp, script.to_string()).unwrap();
    trimorph(&["edit", s(def), "--script", s(&sp), "-o", s(out)])
}

#[test]
fn check_field_and_edit_report_the_same_det_j_for_a_fold() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "3x3", "--size", "60,60", "-o", s(&id)]));
    // Drag the vertex at (20, 20) past its neighbour at (40, 20), locally: a fold.
    let folded = dir.path().join("folded.json");
    let o = edit(
        &id,
        &json!([{"anchors": {"near": [[20, 20]]}, "neighborhood": 1, "op": "translate", "by": [30, 0]}]),
        &folded,
    );
    ok(&o);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("is not certified fold-free") && stderr.contains("folding triangles"),
        "{stderr}"
    );
    let (e_sampled, e_lb, e_line) = det_j_numbers(&String::from_utf8_lossy(&o.stdout));
    assert!(e_line.contains("NOT certified fold-free"), "{e_line}");

    let c = trimorph(&["check", s(&folded)]);
    ok(&c);
    let rep: Value = serde_json::from_slice(&c.stdout).unwrap();
    assert_eq!(rep["fold_free"], false);
    assert_eq!(rep["folds"], true);
    assert!(!rep["folding_triangles"].as_array().unwrap().is_empty());
    let (c_sampled, c_lb) =
        (rep["min_jacobian_det"].as_f64().unwrap(), rep["det_j_lower_bound"].as_f64().unwrap());
    assert!(c_sampled < 0.0 && c_lb <= c_sampled, "{c_lb} {c_sampled}");

    let f = trimorph(&[
        "field",
        s(&folded),
        "-o",
        s(&dir.path().join("f.npy")),
        "--jacobian",
        s(&dir.path().join("j.png")),
    ]);
    ok(&f);
    let (f_sampled, f_lb, f_line) = det_j_numbers(&String::from_utf8_lossy(&f.stdout));

    // An empty script re-reports the folded file.
    let again = edit(&folded, &json!([]), &dir.path().join("again.json"));
    ok(&again);
    let (a_sampled, a_lb, _) = det_j_numbers(&String::from_utf8_lossy(&again.stdout));

    for (name, sampled, lb) in
        [("edit", e_sampled, e_lb), ("field", f_sampled, f_lb), ("edit again", a_sampled, a_lb)]
    {
        assert_eq!(sampled, c_sampled, "{name}: sampled minimum");
        assert_eq!(lb, c_lb, "{name}: lower bound");
    }
    let folding: Vec<String> =
        rep["folding_triangles"].as_array().unwrap().iter().map(|t| t.to_string()).collect();
    assert!(f_line.contains(&format!("folding triangles [{}]", folding.join(", "))), "{f_line}");

    // The identity is certified, with no warning.
    let o = edit(&id, &json!([]), &dir.path().join("same.json"));
    ok(&o);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("fold"));
    let (sampled, lb, line) = det_j_numbers(&String::from_utf8_lossy(&o.stdout));
    assert!(line.ends_with("; certified fold-free"), "{line}");
    assert!((sampled - 1.0).abs() < 1e-12 && lb <= 1.0 && lb > 1.0 - 1e-9);
}

#[test]
fn check_reports_a_non_finite_control_point() {
    let dir = tempfile::tempdir().unwrap();
    let id = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", s(&id)]));
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&id).unwrap()).unwrap();
    let huge = format!("1{}", "0".repeat(400));
    doc["exact"]["points"][7][1] = huge.clone().into();
    let bad = dir.path().join("huge.json");
    std::fs::write(&bad, doc.to_string()).unwrap();
    let o = trimorph(&["check", s(&bad)]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("control point 7")
            && err.contains("y coordinate")
            && err.contains("huge.json"),
        "{err}"
    );
}

//! Tests of the streaming problem reader ([`super`]).

use crate::ecles::problem::{Problem, ProblemError, SolvePath};
use serde_json::{json, Value};

/// The problem's content as text, to compare two readings.
fn fingerprint(p: &Problem) -> String {
    let r = p.system.matrix();
    let rows: Vec<String> = (0..r.rows()).map(|i| format!("{:?}", r.row(i))).collect();
    format!(
        "{rows:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {} {:?} {:?}",
        p.system.rhs(),
        p.p,
        p.anchors,
        p.anchor_values,
        p.derived,
        p.hints,
        p.weights,
        p.strong,
        p.method,
        p.path
    )
}

fn key_path(text: &str) -> String {
    match Problem::from_json(text) {
        Err(ProblemError::Key { path, .. }) => path,
        other => panic!("{text}: expected a key error, got {other:?}"),
    }
}

fn message(text: &str) -> String {
    Problem::from_json(text).unwrap_err().to_string()
}

const BASE: &str = r#"{"R": {"rows": [[[0, 1], [1, 1], [2, -1]], [[3, 1], [2, -1]]]},
    "Q": [[0, 0], [5, "1/2"]], "P": [[1, 0], [2, 0], [3, 0], [8, "1/2"]],
    "anchors": {"0": [4, "0.25"]}, "derived": [1, 2, 3], "hints": {"3": [9, 1]},
    "weights": {"2": "3/2"}, "strong": false, "method": "gcd", "path": "modular"}"#;

/// Keys in any order, dense and sparse `R`, text and reader: one problem.
#[test]
fn key_order_forms_and_readers_give_one_problem() {
    let a = Problem::from_json(BASE).unwrap();
    let doc: Value = serde_json::from_str(BASE).unwrap();
    let obj = doc.as_object().unwrap();
    // The keys in reverse order.
    let mut rev = String::from("{");
    for (i, (k, v)) in obj.iter().rev().enumerate() {
        rev += &format!("{}{k:?}: {v}", if i > 0 { ", " } else { "" });
    }
    rev.push('}');
    let b = Problem::from_json(&rev).unwrap();
    assert_eq!(fingerprint(&a), fingerprint(&b));
    // Dense R, with zeros and a string coefficient.
    let mut dense = doc.clone();
    dense["R"] = json!([[1, 1, -1, 0], [0, 0, "-1", 1]]);
    let c = Problem::from_json(&dense.to_string()).unwrap();
    assert_eq!(fingerprint(&a), fingerprint(&c));
    let d = Problem::from_reader(BASE.as_bytes()).unwrap();
    assert_eq!(fingerprint(&a), fingerprint(&d));
    assert_eq!(a.path, SolvePath::Modular);
    assert_eq!(a.solve().unwrap(), c.solve().unwrap());
}

/// Keys the problem does not use are skipped, with their objects' keys still checked.
#[test]
fn unknown_keys_are_skipped_but_checked_for_duplicates() {
    let with = BASE.replacen('{', r#"{"comment": {"a": [1, {"b": null}], "c": "x"}, "#, 1);
    let a = Problem::from_json(&with).unwrap();
    assert_eq!(fingerprint(&a), fingerprint(&Problem::from_json(BASE).unwrap()));
    let dup = BASE.replacen('{', r#"{"comment": {"a": 1, "a": 2}, "#, 1);
    let e = message(&dup);
    assert!(e.starts_with("not valid JSON: duplicate key \"a\" at line 1 column"), "{e}");
    let top = BASE.replacen('{', r#"{"P": [[0, 0]], "#, 1);
    assert!(message(&top).contains("duplicate key \"P\""));
    let sparse =
        r#"{"R": {"rows": [], "rows": []}, "P": [[1]], "anchors": {"0": [1]}, "derived": []}"#;
    assert!(message(sparse).contains("duplicate key \"rows\""));
}

/// Errors the streaming reader finds where it reads, and those that need several keys,
/// name their element.
#[test]
fn streaming_errors_name_the_element() {
    let cases = [
        // Sparse R before P: the column is checked against n after the last key.
        (
            r#"{"R": {"rows": [[[0, 1]], [[1, 2], [5, 1]]]}, "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#,
            "R.rows[1][1][0]",
        ),
        (
            r#"{"R": {"rows": [[[0, 1], [1]]]}, "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#,
            "R.rows[0][1]",
        ),
        (
            r#"{"R": {"rows": [[[0, 1, 2]]]}, "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#,
            "R.rows[0][0]",
        ),
        (
            r#"{"R": {"rows": [[[0, 1], [0, 2]]]}, "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#,
            "R.rows[0]",
        ),
        (
            r#"{"R": {"rows": [[[-1, 1]]]}, "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#,
            "R.rows[0][0][0]",
        ),
        (
            r#"{"R": {"rows": [[[0, "1/2"]]]}, "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#,
            "R.rows[0][0][1]",
        ),
        (r#"{"R": {"cols": []}, "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#, "R"),
        (r#"{"R": 7, "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#, "R"),
        (
            r#"{"R": [[1, 1]], "Q": [[1, 2]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#,
            "Q[0]",
        ),
        (r#"{"R": [[1, 1]], "P": [[1], [2, 3]], "anchors": {"0": [1]}, "derived": [1]}"#, "P[1]"),
        (
            r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1, 2]}, "derived": [1]}"#,
            "anchors.\"0\"",
        ),
        (r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": 5, "derived": [1]}"#, "anchors"),
        (
            r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1.5]}"#,
            "derived[0]",
        ),
        (
            r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1], "strong": 1}"#,
            "strong",
        ),
        (
            r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1], "path": "fast"}"#,
            "path",
        ),
        (
            r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1], "weights": {"1": [2]}}"#,
            "weights.\"1\"",
        ),
        (r#"5"#, "(top level)"),
        (r#""x""#, "(top level)"),
        (r#"null"#, "(top level)"),
    ];
    for (text, path) in cases {
        assert_eq!(key_path(text), path, "{text}");
    }
    // What was found is quoted, cut at 40 characters.
    let long = format!(
        r#"{{"R": [[1, 1]], "P": [[1], ["{}"]], "anchors": {{"0": [1]}}, "derived": [1]}}"#,
        "x".repeat(100)
    );
    let e = message(&long);
    assert!(e.starts_with("P[1][0]: "), "{e}");
    let e = message(
        r#"{"R": [[1, 1]], "P": [[1], [{"a": 1}]], "anchors": {"0": [1]}, "derived": [1]}"#,
    );
    assert_eq!(e, "P[1][0]: expected a number or a \"p/q\" string, found an object");
    let e = message(
        r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1], "strong": 1}"#,
    );
    assert_eq!(e, "strong: expected true or false, found 1");
}

/// Syntax errors are JSON errors, also after valid keys and after the last brace; a problem
/// error met first is reported as itself.
#[test]
fn syntax_errors_stay_json_errors() {
    for bad in ["", "{", "{\"R\": [[1, 1]], \"P\": [[1], [2]]", "{} x", &format!("{BASE} 1")] {
        assert!(matches!(Problem::from_json(bad), Err(ProblemError::Json(_))), "{bad:?}");
        assert!(
            matches!(Problem::from_reader(bad.as_bytes()), Err(ProblemError::Json(_))),
            "{bad:?}"
        );
    }
    // Text that is not JSON is a JSON error even where a wrong value comes first (found by
    // review: the first streaming reader reported the value); from a reader, what is met
    // first is reported.
    for (text, path) in [
        (r#"{"P": [[true]], "R": ["#, "P[0][0]"),
        (r#"{"P": "x", "P": [[1]]}"#, "P"),
        ("[1,]", "(top level)"),
    ] {
        assert!(matches!(Problem::from_json(text), Err(ProblemError::Json(_))), "{text}");
        match Problem::from_reader(text.as_bytes()) {
            Err(ProblemError::Key { path: p, .. }) => assert_eq!(p, path, "{text}"),
            other => panic!("{text}: {other:?}"),
        }
    }
    let dup = Problem::from_json(r#"{"P": "x", "P": [[1]]}"#).unwrap_err().to_string();
    assert!(dup.contains("duplicate key \"P\""), "{dup}");
}

/// `null` means absent for the optional keys.
#[test]
fn null_optional_keys_are_absent() {
    let t = r#"{"R": [[1, -1]], "Q": null, "P": [[1], [2]], "anchors": {"0": [3]}, "derived": [1],
        "hints": null, "weights": null, "strong": null, "method": null, "path": null}"#;
    let p = Problem::from_json(t).unwrap();
    assert_eq!(p.path, SolvePath::Auto);
    assert!(!p.strong);
    assert_eq!(p.solve().unwrap().to_json()["P"], json!([["3"], ["3"]]));
}

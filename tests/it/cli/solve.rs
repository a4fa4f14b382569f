//! `trimorph solve`, `demo` and `bench bitgrowth` from outside, through the binary.

use crate::common;
use common::*;

use num_bigint::BigInt;
use num_rational::BigRational;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn example(name: &str) -> String {
    format!("{}/examples/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn rat(v: &Value) -> BigRational {
    match v {
        Value::String(s) => match s.split_once('/') {
            Some((p, q)) => BigRational::new(p.parse().unwrap(), q.parse().unwrap()),
            None => BigRational::from_integer(s.parse().unwrap()),
        },
        Value::Number(n) => {
            // Integers only in these inputs.
            BigRational::from_integer(n.to_string().parse::<BigInt>().unwrap())
        }
        other => panic!("not a number: {other}"),
    }
}

/// Checks R P = Q exactly on the solver's output, from the input file.
fn assert_constraints_hold(input: &Value, out: &Value) {
    let p: Vec<Vec<BigRational>> = out["P"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_array().unwrap().iter().map(rat).collect())
        .collect();
    // Lowest terms: re-formatting each value gives the same string.
    for (row, orig) in p.iter().zip(out["P"].as_array().unwrap()) {
        for (v, s) in row.iter().zip(orig.as_array().unwrap()) {
            let text =
                if v.denom() == &BigInt::from(1) { v.numer().to_string() } else { v.to_string() };
            assert_eq!(Value::String(text), *s);
        }
    }
    let d = p[0].len();
    for (i, row) in input["R"].as_array().unwrap().iter().enumerate() {
        for c in 0..d {
            let mut lhs = BigRational::from_integer(0.into());
            for (j, coef) in row.as_array().unwrap().iter().enumerate() {
                lhs += rat(coef) * &p[j][c];
            }
            let q = input.get("Q").map_or(BigRational::from_integer(0.into()), |q| rat(&q[i][c]));
            assert_eq!(lhs, q, "constraint {i} coordinate {c}");
        }
    }
}

fn read_json(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn pump_example_solves_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pump.out.json");
    let o = trimorph(&["solve", &example("pump.json"), "-o", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = read_json(&out);
    assert_eq!(v["P"], serde_json::json!([["4"], ["0"], ["4"], ["9"]]));
    assert_eq!(v["rank"], 2);
    assert_eq!(v["relevant"], serde_json::json!([0, 1]));
    assert_eq!(v["fixed_relevant"], serde_json::json!([]));
    assert_eq!(v["redundant"], serde_json::json!([]));
    assert_eq!(v["P_float"][1][0].as_f64(), Some(0.0));
    assert_constraints_hold(&read_json(Path::new(&example("pump.json"))), &v);
}

#[test]
fn thesis_least_squares_golden() {
    let o = trimorph(&["solve", &example("thesis_8_3.json")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["P"], serde_json::json!([["3/2"], ["-3/2"], ["-23/2"], ["23/2"], ["1"]]));
    assert_eq!(v["rank"], 3);
    assert_eq!(v["redundant"].as_array().unwrap().len(), 2);
    assert_constraints_hold(&read_json(Path::new(&example("thesis_8_3.json"))), &v);
}

#[test]
fn parallelogram_in_the_plane() {
    let o = trimorph(&["solve", &example("parallelogram_2d.json")]);
    assert!(o.status.success());
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["P"][0], serde_json::json!(["1", "1/2"]));
    assert_constraints_hold(&read_json(Path::new(&example("parallelogram_2d.json"))), &v);
}

#[test]
fn unsolvable_edit_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.json");
    // An earlier output must survive a failed run.
    std::fs::write(&out, "earlier").unwrap();
    let o = trimorph(&["solve", &example("unsolvable.json"), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err: Value = serde_json::from_slice(&o.stderr).expect("JSON error object on stderr");
    assert_eq!(err["condition"], "weak_solvability");
    assert_eq!(err["error"], "not_solvable");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "earlier");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temp files left");

    let fresh = dir.path().join("fresh.json");
    let o = trimorph(&["solve", &example("unsolvable.json"), "-o", fresh.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!fresh.exists());
}

#[test]
fn strong_solvability_failure_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("strong.json");
    let mut v = read_json(Path::new(&example("unsolvable.json")));
    v["strong"] = Value::Bool(true);
    v["anchors"] = serde_json::json!({"2": [0, 0]});
    std::fs::write(&f, v.to_string()).unwrap();
    let o = trimorph(&["solve", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err: Value = serde_json::from_slice(&o.stderr).unwrap();
    assert_eq!(err["condition"], "strong_solvability");
    // Without "strong", the same (zero) move is weakly solvable.
    v["strong"] = Value::Bool(false);
    std::fs::write(&f, v.to_string()).unwrap();
    assert!(trimorph(&["solve", f.to_str().unwrap()]).status.success());
}

#[test]
fn bad_input_exits_1_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("{\"R\": [[1, 1]], \"P\": [[1], [2]]", "invalid_json"),
        (
            "{\"R\": [[1, 1]], \"P\": [[1], [\"x\"]], \"anchors\": {\"0\": [1]}, \"derived\": []}",
            "P[1][0]",
        ),
        ("{\"R\": [[1, 1]], \"P\": [[1], [2]], \"anchors\": {}, \"derived\": [1]}", "no anchors"),
        (
            "{\"R\": [[1, 1]], \"P\": [[1], [2]], \"anchors\": {\"0\": [1]}, \"derived\": [0]}",
            "both an anchor and derived",
        ),
        ("", "invalid_json"),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        let f = dir.path().join(format!("bad{i}.json"));
        std::fs::write(&f, text).unwrap();
        let out = dir.path().join(format!("out{i}.json"));
        let o = trimorph(&["solve", f.to_str().unwrap(), "-o", out.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(1), "{text}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(needle), "{text}: {err}");
        assert!(!out.exists());
    }
    let o = trimorph(&["solve", "/nonexistent/problem.json"]);
    assert_eq!(o.status.code(), Some(1));
}

#[test]
fn demo_runs_on_bundled_data() {
    let dir = tempfile::tempdir().unwrap();
    let o = trimorph(&["demo", "-o", dir.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("every constraint holds exactly: true"));
    assert!(!text.contains("holds exactly: false"));
    assert!(text.contains("nonzero residuals: 0"), "{text}");
    assert!(text.contains("trimorph warp"), "{text}");
    for f in [
        "pump.solution.json",
        "identity.json",
        "edited.json",
        "before.png",
        "after.png",
        "edits.json",
        "warped.png",
    ] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
}

#[test]
fn bitgrowth_writes_csv_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let o = trimorph(&[
        "bench",
        "bitgrowth",
        "--quick",
        "--trials",
        "2",
        "--only",
        "fig7_1",
        "-o",
        dir.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(dir.path().join("bitgrowth.csv")).unwrap();
    assert!(csv.starts_with("experiment,method,x,mean_bits"));
    assert!(csv.lines().any(|l| l.starts_with("fig7_1,none,")));
    let png = std::fs::read(dir.path().join("fig7_1.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let bad =
        trimorph(&["bench", "bitgrowth", "--only", "nothing", "-o", dir.path().to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(1));
}

/// Bug (issue 54): `--trials 4294967295` tried to allocate 103 GB and aborted. It is refused
/// before any work, naming the limit.
#[test]
fn bitgrowth_refuses_more_trials_than_it_can_hold() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let o =
        trimorph(&["bench", "bitgrowth", "--trials", "4294967295", "-o", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("--trials must be at most 10000"), "{err}");
    assert!(!out.join("bitgrowth.csv").exists());
}

/// Bug: `trimorph demo | head -3` panicked with "failed printing to stdout: Broken pipe".
#[test]
fn closed_stdout_is_not_a_crash() {
    use std::process::Stdio;
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_trimorph"))
        .args(["demo", "-o", dir.path().to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
}

/// Bug found in review: clap's usage errors exited 2, the code reserved for unsolvable edits,
/// so a script testing `$? == 2` took a typo for an unsolvable edit. Usage errors exit 1 now;
/// `--help` and `--version` exit 0.
#[test]
fn usage_errors_exit_1_not_the_unsolvable_code() {
    for args in [&["solve"][..], &["no-such-command"], &["solve", "x.json", "--no-such-flag"], &[]]
    {
        let o = trimorph(args);
        assert_eq!(o.status.code(), Some(1), "{args:?}");
        assert!(!o.stderr.is_empty(), "{args:?}: a usage message on stderr");
    }
    for args in [&["--help"][..], &["--version"], &["solve", "--help"]] {
        let o = trimorph(args);
        assert_eq!(o.status.code(), Some(0), "{args:?}");
        assert!(!o.stdout.is_empty(), "{args:?}: printed on stdout");
    }
}

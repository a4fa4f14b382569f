//! The catalogue of bad inputs (`docs/errors.md`): for every row, the bad file is written
//! into a temporary folder, the command is run, and the test asserts the row's exit code, that
//! stderr names the file, and that stderr holds every `fragment` the row's "what trimorph
//! says" cell lists (`FILE` stands for the file's path). Every row of the table must have a
//! case here and every case a row, so the document cannot drift from the program.
//!
//! It also asserts that the command wrote nothing: every file and folder under the fixture's
//! folder, with its size and modification time, is as it was before the command ran.
//!
//! Set `TRIMORPH_PRINT_ERRORS=1` to print every case's stderr.

#[path = "bad_inputs/cases.rs"]
mod cases;
#[path = "bad_inputs/cases_54.rs"]
mod cases_54;
use crate::common;
#[path = "bad_inputs/files.rs"]
mod files;

use cases::{cases, Fixture};
use std::collections::BTreeMap;
use std::path::Path;

/// Cases whose command keeps what it finished before the failure, by design: a frame
/// sequence (`fit --frames`) keeps the frames fitted before the failing one, so that a
/// second run resumes there (`src/cli/fit_batch.rs`).
const KEEPS_DONE_WORK: &[&str] = &["frames_lost"];

/// A row of the table in `docs/errors.md`.
struct Row {
    exit: i32,
    fragments: Vec<String>,
}

fn doc_rows() -> BTreeMap<String, Row> {
    let doc = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/errors.md");
    let text = std::fs::read_to_string(&doc).expect("docs/errors.md");
    let mut rows = BTreeMap::new();
    for line in text.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        assert_eq!(cells.len(), 4, "docs/errors.md: row `{line}` needs 4 cells");
        let id = cells[0].trim_matches('`').to_string();
        let fragments: Vec<String> =
            cells[2].split('`').skip(1).step_by(2).map(str::to_string).collect();
        assert!(!fragments.is_empty(), "docs/errors.md: row {id} lists no `fragment`");
        let exit = cells[3].parse().unwrap_or_else(|_| panic!("row {id}: exit `{}`", cells[3]));
        assert!(rows.insert(id.clone(), Row { exit, fragments }).is_none(), "row {id} twice");
    }
    rows
}

#[test]
fn every_bad_input_gets_a_clear_message_and_a_nonzero_exit() {
    let dir = tempfile::tempdir().unwrap();
    let fx = Fixture::new(dir.path());
    let rows = doc_rows();
    let cases = cases();
    let print = std::env::var_os("TRIMORPH_PRINT_ERRORS").is_some();
    let mut failures = Vec::new();
    for case in &cases {
        let (args, file) = (case.setup)(&fx, case.id);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let before = listing(&fx.dir);
        let o = common::trimorph(&args);
        if listing(&fx.dir) != before && !KEEPS_DONE_WORK.contains(&case.id) {
            failures.push(format!("{}: the folder changed (a failed command wrote)", case.id));
        }
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        let code = o.status.code();
        if print {
            println!("{} -> {code:?}\n{err}", case.id);
        }
        let path = file.display().to_string();
        let Some(row) = rows.get(case.id) else {
            failures.push(format!("{}: no row in docs/errors.md", case.id));
            continue;
        };
        if code != Some(row.exit) {
            failures.push(format!("{}: exit {code:?}, documented {}: {err}", case.id, row.exit));
        }
        if err.contains("panicked") {
            failures.push(format!("{}: panic: {err}", case.id));
        }
        // An empty path: the message names an option, not a file.
        if !path.is_empty() && !err.contains(&path) {
            failures.push(format!("{}: stderr does not name {path}: {err}", case.id));
        }
        for f in &row.fragments {
            let f = f.replace("FILE", &path);
            if !err.contains(&f) {
                failures.push(format!("{}: stderr lacks `{f}`: {err}", case.id));
            }
        }
    }
    for id in rows.keys() {
        if !cases.iter().any(|c| c.id == id) {
            failures.push(format!("{id}: documented but not tested"));
        }
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}

/// Every path under `dir` with its size and modification time (folders too).
fn listing(dir: &Path) -> Vec<(std::path::PathBuf, u64, Option<std::time::SystemTime>)> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let m = std::fs::symlink_metadata(&p).unwrap();
            if m.is_dir() {
                todo.push(p.clone());
            }
            out.push((p, m.len(), m.modified().ok()));
        }
    }
    out.sort();
    out
}

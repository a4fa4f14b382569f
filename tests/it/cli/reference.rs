//! The command-line reference `docs/cli/*.md` (`trimorph::cli::reference`) is current, and
//! each page's help text is what `trimorph <command> --help` prints.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;
use trimorph::cli::reference::pages;

const REGENERATE: &str = "run `cargo run --example cli_docs` to regenerate docs/cli/";

fn docs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/cli")
}

#[test]
fn the_committed_pages_are_current() {
    let dir = docs_dir();
    let pages = pages();
    let mut stale = Vec::new();
    for (name, text) in &pages {
        match std::fs::read_to_string(dir.join(name)) {
            Ok(on_disk) if on_disk == *text => {}
            Ok(_) => stale.push(format!("{name} differs")),
            Err(e) => stale.push(format!("{name}: {e}")),
        }
    }
    let generated: BTreeSet<&str> = pages.iter().map(|(n, _)| n.as_str()).collect();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if path.extension().is_some_and(|e| e == "md") && !generated.contains(name.as_str()) {
            stale.push(format!("{name} is no longer generated"));
        }
    }
    assert!(stale.is_empty(), "docs/cli/ is out of date ({}); {REGENERATE}", stale.join(", "));
}

/// The text between a page's ```` ```text ```` fence lines.
fn fenced(page: &str) -> &str {
    let start = page.find("```text\n").expect("a text fence") + "```text\n".len();
    let len = page[start..].find("\n```\n").expect("the fence's end");
    &page[start..start + len]
}

/// What `trimorph <words> --help` prints on standard output (not a terminal).
fn help_of(words: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_trimorph"))
        .args(words)
        .arg("--help")
        // Without clap's `wrap_help` feature neither matters; with it, $COLUMNS would set
        // the width on a pipe.
        .env_remove("COLUMNS")
        .env_remove("LINES")
        .output()
        .unwrap();
    assert!(out.status.success(), "trimorph {words:?} --help failed: {out:?}");
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn every_page_holds_the_binarys_help() {
    let pages = pages();
    let mut checked = Vec::new();
    for (name, page) in &pages {
        // `model-bind.md` is `trimorph model bind`; `index.md` is `trimorph`.
        let stem = name.strip_suffix(".md").unwrap();
        let words: Vec<&str> = if stem == "index" { Vec::new() } else { stem.split('-').collect() };
        let printed = help_of(&words);
        assert!(!printed.contains('\x1b'), "trimorph {words:?} --help is styled");
        assert_eq!(
            fenced(page),
            printed.trim_end_matches('\n'),
            "{name} is not `trimorph {} --help`; {REGENERATE}",
            words.join(" ")
        );
        checked.push(stem.to_string());
    }
    for must in ["index", "fit", "warp", "model-bind", "model", "bench-bitgrowth"] {
        assert!(checked.iter().any(|c| c == must), "no page for {must}: {checked:?}");
    }
}

/// clap is built without its `wrap_help` feature, so `--help` ignores the terminal and
/// `$COLUMNS`: the pages hold what every user sees.
#[test]
fn help_does_not_depend_on_columns() {
    let narrow = Command::new(env!("CARGO_BIN_EXE_trimorph"))
        .args(["fit", "--help"])
        .env("COLUMNS", "40")
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8(narrow.stdout).unwrap(),
        help_of(&["fit"]),
        "`trimorph fit --help` depends on $COLUMNS (clap's `wrap_help` feature?), while the \
         pages are laid out for 100 columns"
    );
}

//! The crate's floors, checked: every top-level module has a floor, and no module's code
//! names (`crate::x`) a module on its own floor or above. The table is the one of
//! `docs/architecture.md`; tests inside a module (`#[cfg(test)]` and `*tests.rs` files) may
//! reach higher, as integration tests do.

use std::path::{Path, PathBuf};

/// The floors, from the ground up. A module may use only modules on lower floors.
const FLOORS: &[&[&str]] = &[
    &["alloc", "cancel", "geom", "json", "memory", "rng", "sparse", "timing", "mesh"],
    &["exact"],
    &["ecles"],
    &["spline"],
    &["edit", "prism", "warp"],
    &["fit", "bundled"],
    &["io", "register"],
    &["render"],
    &["morph"],
    &["jobs"],
    &["server"],
    &["cli"],
];

fn floor(module: &str) -> Option<usize> {
    FLOORS.iter().position(|f| f.contains(&module))
}

/// The `.rs` files of a top-level module: `src/m.rs` and everything under `src/m/`.
fn files(src: &Path, module: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let single = src.join(format!("{module}.rs"));
    if single.exists() {
        out.push(single);
    }
    let mut stack = vec![src.join(module)];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out
}

/// The modules named as `crate::NAME` in the code of `text` (comments, doc comments and
/// everything from the first `#[cfg(test)]` on left out).
fn named(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let code = line.trim_start();
        if code.starts_with("#[cfg(test)]") {
            break;
        }
        if code.starts_with("//") {
            continue;
        }
        let code = code.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(at) = rest.find("crate::") {
            rest = &rest[at + "crate::".len()..];
            let name: String =
                rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            if !name.is_empty() {
                out.push((i + 1, name));
            }
        }
    }
    out
}

#[test]
fn every_module_has_a_floor() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    for line in lib.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("pub mod ").or_else(|| line.strip_prefix("mod ")) {
            let name = rest.trim_end_matches(';');
            if name == "layers" {
                continue;
            }
            assert!(floor(name).is_some(), "module `{name}` has no floor in src/layers.rs");
        }
    }
}

#[test]
fn no_module_uses_one_on_its_floor_or_above() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut bad = Vec::new();
    for (k, level) in FLOORS.iter().enumerate() {
        for module in level.iter() {
            for file in files(&src, module) {
                let name = file.file_name().unwrap().to_string_lossy().to_string();
                if name == "tests.rs" || name.ends_with("_tests.rs") {
                    continue;
                }
                let text = std::fs::read_to_string(&file).unwrap();
                for (line, used) in named(&text) {
                    let Some(f) = floor(&used) else { continue };
                    if used != *module && f >= k {
                        bad.push(format!(
                            "{}:{line}: `{module}` (floor {}) uses `{used}` (floor {})",
                            file.display(),
                            k + 1,
                            f + 1
                        ));
                    }
                }
            }
        }
    }
    assert!(bad.is_empty(), "imports that run up or sideways:\n{}", bad.join("\n"));
}

/// The scan sees paths in code and skips comments and tests.
#[test]
fn the_scan_reads_code_only() {
    let text = "use crate::fit::Fit;\n// crate::cli\n/// [`crate::jobs`]\nlet x = crate::io::read(); // crate::server\n#[cfg(test)]\nuse crate::cli;";
    let names: Vec<String> = named(text).into_iter().map(|(_, n)| n).collect();
    assert_eq!(names, ["fit", "io"]);
}

//! Property test of [`super::files`] (issue 54): for every command, an output given the path
//! of one of its inputs, or of another of its outputs, is refused naming both roles, however
//! the path is spelled. Every subcommand of the command line is either in [`LINES`] or in
//! [`NO_FILES`], so a new command cannot skip the rule unnoticed.

use super::super::Cli;
use clap::{CommandFactory, Parser};
use proptest::prelude::*;
use std::path::Path;

/// A command line with file slots `{0}`, `{1}`, ...: each slot's role and whether it is an
/// output (in the order the command lists them, [`super::files`]). Output folders (a
/// morph's, a frame sequence's) are fixed names: the files written into them are listed,
/// not the folder.
struct Line {
    args: &'static str,
    slots: &'static [(&'static str, bool)],
}

const IN: bool = false;
const OUT: bool = true;

/// Every command that reads and writes files, each way of giving its files.
const LINES: &[Line] = &[
    Line { args: "solve {0} -o {1}", slots: &[("SYSTEM", IN), ("--output", OUT)] },
    Line {
        args: "mesh --points {0} --outline {1} -o {2}",
        slots: &[("--points", IN), ("--outline", IN), ("--output", OUT)],
    },
    Line { args: "mesh --obj {0} -o {1}", slots: &[("--obj", IN), ("--output", OUT)] },
    Line {
        args: "mesh --landmarks {0} --size 40,40 -o {1}",
        slots: &[("--landmarks", IN), ("--output", OUT)],
    },
    Line {
        args: "edit {0} --script {1} -o {2}",
        slots: &[("DEFORMATION", IN), ("--script", IN), ("--output", OUT)],
    },
    Line {
        args: "render {0} --background {1} --landmarks {2} -o {3}",
        slots: &[("DEFORMATION", IN), ("--background", IN), ("--landmarks", IN), ("--output", OUT)],
    },
    Line {
        args: "render {0} --model {1} -o {2}",
        slots: &[("DEFORMATION", IN), ("--model", IN), ("--output", OUT)],
    },
    Line {
        args: "model bind --model {0} --mesh {1} -o {2}",
        slots: &[("--model", IN), ("--mesh", IN), ("--output", OUT)],
    },
    Line { args: "colormesh {0} -o {1}", slots: &[("IMAGE", IN), ("--output", OUT)] },
    Line {
        args: "warp {0} --image {1} -o {2}",
        slots: &[("DEFORMATION", IN), ("--image", IN), ("--output", OUT)],
    },
    Line {
        args: "warp {0} --points {1} -o {2}",
        slots: &[("DEFORMATION", IN), ("--points", IN), ("--output", OUT)],
    },
    Line {
        args: "warp {0} --mesh {1} -o {2}",
        slots: &[("DEFORMATION", IN), ("--mesh", IN), ("--output", OUT)],
    },
    Line {
        args: "warp {0} --model {1} -o {2}",
        slots: &[("DEFORMATION", IN), ("--model", IN), ("--output", OUT)],
    },
    Line {
        args: "morph {0} {1} --landmarks {2} -o morph-out --gif {3} --apng {4}",
        slots: &[
            ("image A", IN),
            ("image B", IN),
            ("--landmarks", IN),
            ("--gif", OUT),
            ("--apng", OUT),
        ],
    },
    Line {
        args: "morph {0} {1} --phi-ab {2} --phi-ba {3} -o morph-out --gif {4}",
        slots: &[
            ("image A", IN),
            ("image B", IN),
            ("--phi-ab", IN),
            ("--phi-ba", IN),
            ("--gif", OUT),
        ],
    },
    Line {
        args: "field {0} -o {1} --jacobian {2}",
        slots: &[("DEFORMATION", IN), ("--output", OUT), ("--jacobian", OUT)],
    },
    Line {
        args: "match {0} {1} -o {2}",
        slots: &[("image A", IN), ("image B", IN), ("--output", OUT)],
    },
    Line {
        args: "fit {0} --landmarks {1} -o {2} --report {3}",
        slots: &[("DEFORMATION", IN), ("--landmarks", IN), ("--output", OUT), ("--report", OUT)],
    },
    Line {
        args: "fit --size 40,40 --landmarks-src {0} --landmarks-dst {1} -o {2}",
        slots: &[("--landmarks-src", IN), ("--landmarks-dst", IN), ("--output", OUT)],
    },
    Line {
        args:
            "fit --model {0} --model-file {1} --frames {2} --landmarks {3} -o fit-out --report {4}",
        slots: &[
            ("--model", IN),
            ("--model-file", IN),
            ("--frames", IN),
            ("--landmarks", IN),
            ("--report", OUT),
        ],
    },
    Line {
        args: "register {0} {1} --mask-fixed {2} --mask-moving {3} --landmarks {4} --init {5} \
               -o {6} --warped {7} --report {8} --overlay {9}",
        slots: &[
            ("FIXED", IN),
            ("MOVING", IN),
            ("--mask-fixed", IN),
            ("--mask-moving", IN),
            ("--landmarks", IN),
            ("--init", IN),
            ("--output", OUT),
            ("--warped", OUT),
            ("--report", OUT),
            ("--overlay", OUT),
        ],
    },
];

/// Subcommands that read no file and write none, or write only into a folder of their own
/// ([`super::files`] lists nothing for them).
const NO_FILES: &[&str] = &["demo", "check", "editor", "model worm", "bench bitgrowth"];

/// The command line `line` with slot `i` at `paths[i]`.
fn argv(line: &Line, paths: &[String]) -> Vec<String> {
    let mut a = vec!["trimorph".to_string()];
    for w in line.args.split_whitespace() {
        match w.strip_prefix('{').and_then(|w| w.strip_suffix('}')) {
            Some(i) => a.push(paths[i.parse::<usize>().unwrap()].clone()),
            None => a.push(w.to_string()),
        }
    }
    a
}

/// `path` (a file `NAME` in `dir`) spelled another way: as given, through `.`, through
/// `sub/..`, or relative to the working directory's absolute path.
fn spell(dir: &Path, name: &str, how: usize) -> String {
    match how % 3 {
        0 => dir.join(name).display().to_string(),
        1 => format!("{}/./{name}", dir.display()),
        _ => format!("{}/sub/../{name}", dir.display()),
    }
}

fn folder() -> &'static (tempfile::TempDir, Vec<String>) {
    static F: std::sync::OnceLock<(tempfile::TempDir, Vec<String>)> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("sub")).unwrap();
        // Every input exists (its identity is its inode); outputs are named only.
        let names: Vec<String> = (0..10).map(|i| format!("f{i}.dat")).collect();
        for n in &names[..6] {
            std::fs::write(d.path().join(n), b"x").unwrap();
        }
        (d, names)
    })
}

#[test]
fn every_subcommand_is_covered() {
    let mut names = Vec::new();
    for c in Cli::command().get_subcommands() {
        let subs: Vec<String> = c.get_subcommands().map(|s| s.get_name().to_string()).collect();
        if subs.is_empty() {
            names.push(c.get_name().to_string());
        } else {
            names.extend(subs.iter().map(|s| format!("{} {s}", c.get_name())));
        }
    }
    for n in names.iter().filter(|n| n.as_str() != "help" && !n.ends_with(" help")) {
        let listed = LINES.iter().any(|l| l.args.starts_with(&format!("{n} ")));
        assert!(listed || NO_FILES.contains(&n.as_str()), "`{n}`: no line in LINES or NO_FILES");
    }
}

/// Every line parses, and with distinct files passes the rule.
#[test]
fn distinct_files_pass() {
    let (d, names) = folder();
    for line in LINES {
        let paths: Vec<String> =
            (0..line.slots.len()).map(|i| spell(d.path(), &names[i], 0)).collect();
        let cli = Cli::try_parse_from(argv(line, &paths))
            .unwrap_or_else(|e| panic!("{}: {e}", line.args));
        assert!(super::files(&cli.command).check().is_ok(), "{}", line.args);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// An output on an input or on another output, spelled any way, is refused naming both.
    #[test]
    fn an_output_on_an_input_or_another_output_is_refused(
        line in 0..LINES.len(),
        pick in any::<(prop::sample::Index, prop::sample::Index)>(),
        how in 0..3usize,
    ) {
        let line = &LINES[line];
        let (d, names) = folder();
        let outs: Vec<usize> = (0..line.slots.len()).filter(|&i| line.slots[i].1).collect();
        let out = outs[pick.0.index(outs.len())];
        let others: Vec<usize> = (0..line.slots.len()).filter(|&i| i != out).collect();
        let other = others[pick.1.index(others.len())];
        // Inputs take the existing files f0..; outputs the later names.
        let name = |i: usize| names[if line.slots[i].1 { 6 + outs.iter().position(|&o| o == i).unwrap() } else { i }].clone();
        let paths: Vec<String> = (0..line.slots.len())
            .map(|i| if i == out { spell(d.path(), &name(other), how) } else { spell(d.path(), &name(i), 0) })
            .collect();
        let cli = Cli::try_parse_from(argv(line, &paths)).unwrap_or_else(|e| panic!("{}: {e}", line.args));
        let e = super::files(&cli.command).check().expect_err(line.args);
        let roles = [e.role.as_str(), e.other_role.as_str()];
        let (a, b) = (line.slots[out].0, line.slots[other].0);
        prop_assert!(roles == [a, b] || roles == [b, a], "{}: {e} (expected {a} and {b})", line.args);
    }
}

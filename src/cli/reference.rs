//! The command-line reference pages `docs/cli/*.md`, generated from the clap definition of
//! [`Cli`] so that the docs and `trimorph <command> --help` cannot drift apart.
//!
//! [`pages`] renders one Markdown page per subcommand (nested ones too, e.g. `model bind`
//! as `model-bind.md`; a command with subcommands gets a page linking its children) and an
//! `index.md` listing every command. Each page holds the command's `--help` text exactly as
//! the binary prints it. `cargo run --example cli_docs` writes the pages into `docs/cli/`;
//! the test `tests/it/cli/reference.rs` checks that the committed pages are current and that their
//! help text equals the binary's `--help` output.
//!
//! ```
//! let pages = trimorph::cli::reference::pages();
//! let (_, fit) = pages.iter().find(|(name, _)| name == "fit.md").unwrap();
//! assert!(fit.starts_with("# trimorph fit\n"));
//! assert!(fit.contains("Usage: trimorph fit"));
//! assert!(pages.iter().any(|(name, _)| name == "model-bind.md"));
//! assert!(pages.iter().any(|(name, _)| name == "index.md"));
//! ```

use super::Cli;
use clap::{Command, CommandFactory};
use std::fmt::Write as _;

/// The terminal width clap lays help out for. clap is built without its `wrap_help`
/// feature: it does not wrap help text, does not ask the terminal or `$COLUMNS`, and lays
/// out for 100 columns (where a description starts) -- the binary's `--help` and these pages
/// alike. Fixing the width here keeps the pages the same should `wrap_help` be enabled.
const WIDTH: usize = 100;

/// One command of the tree: its words after `trimorph` (e.g. `["model", "bind"]`) and the
/// built clap command.
struct Entry<'a> {
    path: Vec<&'a str>,
    cmd: &'a Command,
}

impl Entry<'_> {
    /// `model-bind.md`.
    fn file(&self) -> String {
        format!("{}.md", self.path.join("-"))
    }

    /// `trimorph model bind`.
    fn title(&self) -> String {
        format!("trimorph {}", self.path.join(" "))
    }
}

/// The subcommands of `cmd` other than clap's generated `help`.
fn children(cmd: &Command) -> impl Iterator<Item = &Command> {
    cmd.get_subcommands().filter(|c| c.get_name() != "help")
}

/// Every command below `cmd`, depth first in declaration order.
fn collect<'a>(cmd: &'a Command, path: &[&'a str], out: &mut Vec<Entry<'a>>) {
    for c in children(cmd) {
        let mut p = path.to_vec();
        p.push(c.get_name());
        out.push(Entry { path: p.clone(), cmd: c });
        collect(c, &p, out);
    }
}

/// The one-paragraph about text of a command (empty when it has none).
fn about(cmd: &Command) -> String {
    cmd.get_about().map(|a| a.to_string()).unwrap_or_default()
}

/// What `trimorph <words> --help` prints, as plain text (no styles), taken the way the
/// binary takes it: by parsing that command line. (clap prints the long help only when the
/// command has some long text; `trimorph --help` itself is the short help.)
fn help(words: &[&str]) -> String {
    let argv = std::iter::once("trimorph").chain(words.iter().copied()).chain(["--help"]);
    match Cli::command().term_width(WIDTH).try_get_matches_from(argv) {
        // `to_string` drops the styles (no ANSI escapes).
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelp => e.render().to_string(),
        other => panic!("trimorph {} --help did not print help: {other:?}", words.join(" ")),
    }
}

/// `text` inside a ```` ```text ```` fence, ending in exactly one newline.
fn fence(text: &str) -> String {
    format!("```text\n{}\n```\n", text.trim_end_matches('\n'))
}

/// A Markdown list linking the children of `e` (empty when it has none).
fn child_list(entries: &[Entry], e: &Entry) -> String {
    let mut s = String::new();
    for c in entries
        .iter()
        .filter(|c| c.path.len() == e.path.len() + 1 && c.path[..e.path.len()] == e.path[..])
    {
        let _ = writeln!(s, "- [`{}`]({}): {}", c.title(), c.file(), about(c.cmd));
    }
    s
}

/// The page of one command.
fn page(entries: &[Entry], e: &Entry) -> String {
    let mut s = format!("# {}\n\n", e.title());
    let about = e.cmd.get_long_about().or(e.cmd.get_about()).map(|a| a.to_string());
    if let Some(a) = about {
        let _ = write!(s, "{}\n\n", a.trim_end());
    }
    let list = child_list(entries, e);
    if !list.is_empty() {
        let _ = write!(s, "Subcommands:\n\n{list}\n");
    }
    let _ = write!(
        s,
        "`{} --help`:\n\n{}\n[All commands](index.md)\n",
        e.title(),
        fence(&help(&e.path))
    );
    s
}

/// The command-line reference as Markdown pages: `(file name, contents)`, the file names
/// relative to `docs/cli/`.
///
/// There is one page per subcommand of `trimorph`, nested ones included, named by its words
/// joined with `-` (`fit.md`, `model.md`, `model-bind.md`, `bench-bitgrowth.md`; clap's
/// generated `help` subcommand gets none). A page has the heading `# trimorph <command>`,
/// the command's about text, for a command with subcommands a list linking them, and the
/// command's help: what `trimorph <command> --help` prints, as plain text (no ANSI styles;
/// clap does not wrap it, so a paragraph is one line), in a `text` fence. `index.md` comes
/// first: every command with its one-paragraph about text and a link, then `trimorph
/// --help`.
///
/// The output depends only on the clap definition (no terminal, no environment), so the
/// pages are the same on every machine; `cargo run --example cli_docs` writes them.
pub fn pages() -> Vec<(String, String)> {
    let mut root = Cli::command();
    // The whole tree, for the commands' names and about texts ([`help`] gets each help text).
    root.build();
    let mut entries = Vec::new();
    collect(&root, &[], &mut entries);

    let mut index = String::from(
        "# trimorph command reference\n\n\
         Generated from the command-line definition by `cargo run --example cli_docs`; do not \
         edit by hand. Each page holds the command's `--help` text.\n\n",
    );
    for e in &entries {
        let indent = "  ".repeat(e.path.len() - 1);
        let _ = writeln!(index, "{indent}- [`{}`]({}): {}", e.title(), e.file(), about(e.cmd));
    }
    let _ = write!(index, "\n`trimorph --help`:\n\n{}", fence(&help(&[])));

    let mut out = vec![("index.md".to_string(), index)];
    out.extend(entries.iter().map(|e| (e.file(), page(&entries, e))));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_command_has_one_page_and_the_index_links_them_all() {
        let pages = pages();
        let names: Vec<&str> = pages.iter().map(|(n, _)| n.as_str()).collect();
        for n in ["index.md", "fit.md", "warp.md", "model.md", "model-bind.md", "model-worm.md"] {
            assert!(names.contains(&n), "{n} missing from {names:?}");
        }
        assert!(names.contains(&"bench-bitgrowth.md"));
        assert!(!names.iter().any(|n| n.starts_with("help")), "{names:?}");
        let mut sorted = names.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), names.len(), "duplicate page names");
        let index = &pages[0].1;
        for n in &names[1..] {
            assert!(index.contains(&format!("]({n})")), "index does not link {n}");
        }
    }

    #[test]
    fn pages_are_plain_text_in_one_fence() {
        for (name, text) in pages() {
            assert!(!text.contains('\x1b'), "{name} holds an ANSI escape");
            assert_eq!(text.matches("```").count(), 2, "{name}: one fence, no ``` in the help");
            assert!(text.ends_with('\n') && !text.ends_with("\n\n"), "{name}");
        }
    }

    #[test]
    fn a_parent_page_links_its_children() {
        let pages = pages();
        let model = &pages.iter().find(|(n, _)| n == "model.md").unwrap().1;
        assert!(model.contains("](model-bind.md)") && model.contains("](model-worm.md)"));
        let bind = &pages.iter().find(|(n, _)| n == "model-bind.md").unwrap().1;
        assert!(bind.starts_with("# trimorph model bind\n"));
        assert!(bind.contains("Usage: trimorph model bind"));
        assert!(bind.contains("--max-memory"), "the global option is listed");
    }
}

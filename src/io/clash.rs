//! One rule for every command's files: no output may be one of the command's inputs, or
//! another of its outputs.
//!
//! Outputs are written atomically ([`super::write_atomic`]), so a failed command destroys
//! nothing; but a command that succeeds while writing over its own input (`fit -o L.csv
//! --landmarks L.csv`, `match A B -o A`) or writes two outputs to one file (`fit -o X
//! --report X`, keeping only the second) loses data silently. Each command lists its files
//! by role before it reads anything ([`CommandFiles`]), and [`CommandFiles::check`] refuses a
//! clash naming both roles and paths.
//!
//! **Same file.** Two paths name the same file when both exist and have the same device and
//! inode (hard links, symbolic links, `./a` and `a` alike), or, when one does not exist yet,
//! when their folders resolve to the same folder ([`std::fs::canonicalize`]) and their file
//! names are equal. `-` (standard input or output) is never a file.

use std::collections::hash_map::{Entry, HashMap};
use std::path::{Path, PathBuf};

/// An output that is also an input, or another output, of the same command.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{role} {path} is the same file as {kind} {other_role} {other}: {why}; choose another name",
    path = .path.display(),
    other = .other.display(),
    kind = if *.other_is_input { "the input" } else { "the output" },
    why = if *.other_is_input {
        "writing it would replace the input this command reads"
    } else {
        "the command would write one file twice and keep only the last"
    }
)]
pub struct Clash {
    /// The output's role (e.g. `--report`).
    pub role: String,
    /// The output's path.
    pub path: PathBuf,
    /// The other file's role.
    pub other_role: String,
    /// The other file's path.
    pub other: PathBuf,
    /// Whether the other file is an input.
    pub other_is_input: bool,
}

/// The files a command reads and writes, by role (an option's name, or an argument's).
#[derive(Debug, Clone, Default)]
pub struct CommandFiles {
    inputs: Vec<(String, PathBuf)>,
    outputs: Vec<(String, PathBuf)>,
}

impl CommandFiles {
    /// No files yet.
    pub fn new() -> CommandFiles {
        CommandFiles::default()
    }

    /// Adds an input (nothing for `None`).
    pub fn input(mut self, role: &str, path: Option<&Path>) -> CommandFiles {
        if let Some(p) = path {
            self.inputs.push((role.to_string(), p.to_path_buf()));
        }
        self
    }

    /// Adds an output (nothing for `None`).
    pub fn output(mut self, role: &str, path: Option<&Path>) -> CommandFiles {
        if let Some(p) = path {
            self.outputs.push((role.to_string(), p.to_path_buf()));
        }
        self
    }

    /// Refuses the first output that is an input or an earlier output (see the module docs).
    ///
    /// ```
    /// use std::path::Path;
    /// use trimorph::io::clash::CommandFiles;
    /// let files = CommandFiles::new()
    ///     .input("--landmarks", Some(Path::new("l.csv")))
    ///     .output("-o", Some(Path::new("./l.csv")));
    /// let e = files.check().unwrap_err();
    /// assert!(e.to_string().starts_with("-o ./l.csv is the same file as the input --landmarks l.csv"));
    /// ```
    pub fn check(&self) -> Result<(), Clash> {
        // Each file's identity once (a morph lists up to 10,000 frames).
        let mut seen: HashMap<FileKey, (&str, &Path, bool)> = HashMap::new();
        for (role, path) in &self.inputs {
            if !is_stdio(path) {
                seen.entry(key(path)).or_insert((role, path, true));
            }
        }
        for (role, path) in &self.outputs {
            if is_stdio(path) {
                continue;
            }
            match seen.entry(key(path)) {
                Entry::Occupied(o) => {
                    let (other_role, other, other_is_input) = *o.get();
                    return Err(Clash {
                        role: role.clone(),
                        path: path.clone(),
                        other_role: other_role.to_string(),
                        other: other.to_path_buf(),
                        other_is_input,
                    });
                }
                Entry::Vacant(v) => {
                    v.insert((role, path, false));
                }
            }
        }
        Ok(())
    }
}

fn is_stdio(p: &Path) -> bool {
    p.as_os_str() == "-"
}

/// A file's identity: its device and inode when it exists, else its resolved path (an
/// existing file and a missing one are never the same file).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum FileKey {
    Inode(u64, u64),
    Path(PathBuf),
}

fn key(p: &Path) -> FileKey {
    #[cfg(unix)]
    if let Ok(m) = std::fs::metadata(p) {
        use std::os::unix::fs::MetadataExt;
        return FileKey::Inode(m.dev(), m.ino());
    }
    FileKey::Path(resolved(p))
}

/// Whether `a` and `b` name the same file (see the module docs).
pub fn same_file(a: &Path, b: &Path) -> bool {
    key(a) == key(b)
}

/// The path with its folder resolved (symbolic links, `.`, `..`), or made absolute
/// lexically when the folder does not exist.
fn resolved(p: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(p) {
        return c;
    }
    let parent = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = p.file_name().map(PathBuf::from).unwrap_or_default();
    match std::fs::canonicalize(&parent) {
        Ok(d) => d.join(name),
        Err(_) => std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clashes_are_found_through_links_dots_and_missing_files() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let a = d.join("a.csv");
        std::fs::write(&a, "x").unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        let dotted = d.join("sub").join("..").join("a.csv");
        assert!(same_file(&a, &dotted));
        #[cfg(unix)]
        {
            let link = d.join("link.csv");
            std::os::unix::fs::symlink(&a, &link).unwrap();
            assert!(same_file(&a, &link));
            let hard = d.join("hard.csv");
            std::fs::hard_link(&a, &hard).unwrap();
            assert!(same_file(&hard, &a));
        }
        // Not written yet: same folder and name.
        let (n1, n2) = (d.join("new.json"), d.join("sub").join("..").join("new.json"));
        assert!(same_file(&n1, &n2));
        assert!(!same_file(&n1, &a) && !same_file(&d.join("sub/new.json"), &n1));
        let e = CommandFiles::new()
            .input("--landmarks", Some(&a))
            .output("-o", Some(&d.join("out.json")))
            .output("--report", Some(&n1))
            .output("--warped", Some(&n2))
            .check()
            .unwrap_err();
        assert_eq!(
            (e.role.as_str(), e.other_role.as_str(), e.other_is_input),
            ("--warped", "--report", false)
        );
        assert!(e.to_string().contains("write one file twice"), "{e}");
        let ok = CommandFiles::new()
            .input("-", Some(Path::new("-")))
            .output("-o", Some(Path::new("-")))
            .output("--report", Some(&n1))
            .input("--landmarks", None);
        assert!(ok.check().is_ok());
    }
}

//! Confining the editor's file loads and saves to the folder it was started in.
//!
//! A path from the page must be relative, must not contain `..`, a root or a drive
//! prefix, and must resolve (following symbolic links) to a place inside the root. For a
//! save the file may not exist yet: its folder must exist and resolve inside the root, and
//! the file itself may not be a symbolic link, whatever it points to: a write follows a
//! link, and a dangling one (`x.json -> ../outside/x.json`) does not "exist", so checking
//! where it resolves is not enough.

use super::ServerError;
use std::path::{Component, Path, PathBuf};

/// The absolute path of `rel` inside `root`, or a `Forbidden` error. With `for_write` the
/// file itself need not exist (its folder must).
pub fn confine(root: &Path, rel: &str, for_write: bool) -> Result<PathBuf, ServerError> {
    let forbid = |why: &str| ServerError::Forbidden(format!("path `{rel}`: {why}"));
    if rel.is_empty() || rel.len() > 4096 || rel.contains('\0') {
        return Err(forbid("empty, too long or with a NUL byte"));
    }
    let p = Path::new(rel);
    for c in p.components() {
        match c {
            Component::Normal(_) | Component::CurDir => {}
            Component::ParentDir => return Err(forbid("`..` is not allowed")),
            Component::RootDir | Component::Prefix(_) => {
                return Err(forbid("only paths relative to the editor's folder are allowed"))
            }
        }
    }
    let root =
        root.canonicalize().map_err(|e| ServerError::Io(format!("the editor's folder: {e}")))?;
    let full = root.join(p);
    let is_link = full.symlink_metadata().is_ok_and(|m| m.file_type().is_symlink());
    if for_write && is_link {
        return Err(forbid("it is a symbolic link: the editor writes only plain files"));
    }
    let resolved = if for_write && !full.exists() {
        let name = full.file_name().ok_or_else(|| forbid("no file name"))?.to_owned();
        let parent = full.parent().ok_or_else(|| forbid("no folder"))?;
        let parent = parent
            .canonicalize()
            .map_err(|_| ServerError::NotFound(format!("folder of `{rel}` does not exist")))?;
        parent.join(name)
    } else {
        full.canonicalize().map_err(|_| ServerError::NotFound(format!("`{rel}` does not exist")))?
    };
    if !resolved.starts_with(&root) {
        return Err(forbid("it leads outside the editor's folder"));
    }
    if resolved.is_dir() {
        return Err(forbid("it is a folder"));
    }
    Ok(resolved)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn traversal_absolute_and_symlink_escapes_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("root");
        std::fs::create_dir_all(root.join("sub")).unwrap();
        std::fs::write(root.join("sub/a.json"), "{}").unwrap();
        std::fs::write(dir.path().join("secret.txt"), "x").unwrap();
        assert!(confine(&root, "sub/a.json", false).is_ok());
        assert!(confine(&root, "./sub/a.json", false).is_ok());
        assert!(confine(&root, "new.json", true).is_ok());
        assert!(matches!(confine(&root, "new.json", false), Err(ServerError::NotFound(_))));
        for bad in ["../secret.txt", "sub/../../secret.txt", "/etc/passwd", "", "sub"] {
            assert!(
                matches!(confine(&root, bad, false), Err(ServerError::Forbidden(_))),
                "{bad} must be forbidden"
            );
        }
        assert!(matches!(confine(&root, "../x.json", true), Err(ServerError::Forbidden(_))));
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(dir.path().join("secret.txt"), root.join("link")).unwrap();
            std::os::unix::fs::symlink(dir.path(), root.join("out")).unwrap();
            assert!(matches!(confine(&root, "link", false), Err(ServerError::Forbidden(_))));
            assert!(matches!(confine(&root, "out/new.json", true), Err(ServerError::Forbidden(_))));
        }
    }

    /// Bug: a symlink whose target did not exist yet (`dangling -> ../outside/x.json`) was
    /// written through: `exists()` is false for it, so only its folder was checked. A link
    /// inside the root is refused for writing too; reading through it stays allowed.
    #[cfg(unix)]
    #[test]
    fn a_dangling_or_inner_symlink_is_never_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("root");
        std::fs::create_dir_all(&root).unwrap();
        std::fs::create_dir_all(dir.path().join("outside")).unwrap();
        std::os::unix::fs::symlink(dir.path().join("outside/x.json"), root.join("dangling"))
            .unwrap();
        assert!(matches!(confine(&root, "dangling", true), Err(ServerError::Forbidden(_))));
        std::fs::write(root.join("a.json"), "{}").unwrap();
        std::os::unix::fs::symlink(root.join("a.json"), root.join("inner")).unwrap();
        assert!(matches!(confine(&root, "inner", true), Err(ServerError::Forbidden(_))));
        assert!(confine(&root, "inner", false).is_ok());
        assert!(!dir.path().join("outside/x.json").exists());
    }
}

//! All-or-nothing output folders: a command that writes a set of files into one folder (the
//! frames of `trimorph morph`) writes them into a temporary sibling folder first and swaps it
//! into place only when every file is written.
//!
//! A [`Staged`] folder is `.NAME.PID-N.stage` beside the output folder `NAME` (same file
//! system, so the swap is a rename). [`Staged::commit`] then
//! * renames the stage to `NAME` when there is no such folder yet;
//! * when `NAME` holds only files of the command's own naming pattern (the `owned` test) and
//!   temporary files of [`super::write_atomic`], exchanges the two folders in one step
//!   (`renameat2(RENAME_EXCHANGE)` on Linux; elsewhere two renames, with a moment in which
//!   `NAME` is absent but never mixed) and removes the old files: the output is the old set or
//!   the new set, never a mix, and no stale file of an earlier, longer run is left;
//! * when `NAME` also holds other files (the user's), which must stay where they are, moves the
//!   new files in one by one (each a rename) and then removes the owned files the new run did
//!   not write. Only a kill during those renames (milliseconds) can leave a mix here.
//!
//! A failed command drops its [`Staged`] folder, which removes it: the output folder is
//! untouched. A killed command leaves its stage behind; the next [`Staged::begin`] beside the
//! same folder removes the stages of processes that no longer run (only the owned and
//! temporary files in them, then the empty folder).

use super::{temp_writer, IoError};
use std::fs;
use std::path::{Path, PathBuf};

/// Which file names of an output folder belong to the command (it may replace and remove
/// them); every other name is the user's and is never touched.
pub type Owned = fn(&str) -> bool;

/// A folder being written in place of an output folder (see the module documentation).
#[derive(Debug)]
pub struct Staged {
    target: PathBuf,
    stage: PathBuf,
    owned: Owned,
    done: bool,
}

/// How [`Staged::commit`] put the new files in place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Committed {
    /// The output folder did not exist; the stage was renamed to it.
    Created,
    /// The folders were exchanged and the old files removed.
    Swapped,
    /// The folder holds other files: the new files were moved in one by one and the owned
    /// files the run did not write were removed.
    Merged,
}

fn werr(path: &Path) -> impl Fn(std::io::Error) -> IoError + '_ {
    move |source| IoError::Write { path: path.to_path_buf(), source }
}

/// `NAME` of `.NAME.PID-N.stage` or `.NAME.PID-N.old`, with the writer's process id.
fn stage_of(file_name: &str) -> Option<(&str, u32)> {
    let stem = file_name.strip_prefix('.')?;
    let stem = stem.strip_suffix(".stage").or_else(|| stem.strip_suffix(".old"))?;
    let (name, tail) = stem.rsplit_once('.')?;
    let (pid, n) = tail.split_once('-')?;
    n.parse::<u64>().ok()?;
    Some((name, pid.parse().ok()?))
}

/// Removes the owned and temporary files of `dir`, then `dir` if it is empty.
fn clear(dir: &Path, owned: Owned) {
    if let Ok(entries) = fs::read_dir(dir) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if (owned(&name) || temp_writer(&name).is_some())
                && e.file_type().is_ok_and(|t| t.is_file())
            {
                let _ = fs::remove_file(e.path());
            }
        }
    }
    let _ = fs::remove_dir(dir);
}

impl Staged {
    /// Creates the stage beside `target` (and the folder holding `target`, if needed), after
    /// removing stages that killed runs left beside it.
    pub fn begin(target: &Path, owned: Owned) -> Result<Staged, IoError> {
        let target = match fs::symlink_metadata(target) {
            // The folder a link names is the one replaced; the link stays.
            Ok(_) => fs::canonicalize(target).map_err(werr(target))?,
            Err(_) => target.to_path_buf(),
        };
        if target.exists() && !target.is_dir() {
            let e = std::io::Error::other("exists and is not a folder");
            return Err(werr(&target)(e));
        }
        let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned()) else {
            let e = std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a folder name");
            return Err(werr(&target)(e));
        };
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        fs::create_dir_all(&parent).map_err(werr(&parent))?;
        if let Ok(entries) = fs::read_dir(&parent) {
            for e in entries.flatten() {
                let f = e.file_name().to_string_lossy().into_owned();
                if let Some((n, pid)) = stage_of(&f) {
                    if n == name && pid != std::process::id() && !super::process_runs(pid) {
                        clear(&e.path(), owned);
                    }
                }
            }
        }
        static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let stage = parent.join(format!(".{name}.{}-{n}.stage", std::process::id()));
        fs::create_dir(&stage).map_err(werr(&stage))?;
        Ok(Staged { target, stage, owned, done: false })
    }

    /// Where to write the file `name` of the output (inside the stage).
    pub fn path(&self, name: &str) -> PathBuf {
        self.stage.join(name)
    }

    /// The output folder (the final target of a symbolic link).
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Puts the staged files in place of the output folder's (see the module documentation).
    pub fn commit(mut self) -> Result<Committed, IoError> {
        self.done = true;
        let result = self.put_in_place();
        if result.is_err() {
            clear(&self.stage, |_| true);
        }
        result
    }

    fn put_in_place(&self) -> Result<Committed, IoError> {
        let (target, stage, owned) = (&self.target, &self.stage, self.owned);
        let entries = match fs::read_dir(target) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                fs::rename(stage, target).map_err(werr(target))?;
                return Ok(Committed::Created);
            }
            Err(e) => return Err(werr(target)(e)),
        };
        let names: Vec<(String, bool)> = entries
            .flatten()
            .map(|e| {
                let is_file = e.file_type().is_ok_and(|t| t.is_file());
                (e.file_name().to_string_lossy().into_owned(), is_file)
            })
            .collect();
        let ours =
            |(n, is_file): &(String, bool)| *is_file && (owned(n) || temp_writer(n).is_some());
        if names.iter().all(ours) {
            exchange(stage, target).map_err(werr(target))?;
            clear(stage, owned);
            return Ok(Committed::Swapped);
        }
        let new: Vec<String> = fs::read_dir(stage)
            .map_err(werr(stage))?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        for n in &new {
            fs::rename(stage.join(n), target.join(n)).map_err(werr(&target.join(n)))?;
        }
        for (n, is_file) in &names {
            if *is_file && owned(n) && !new.contains(n) {
                let _ = fs::remove_file(target.join(n));
            }
        }
        let _ = fs::remove_dir(stage);
        Ok(Committed::Merged)
    }
}

impl Drop for Staged {
    /// An uncommitted stage (the command failed) is removed; the output folder is untouched.
    fn drop(&mut self) {
        if !self.done {
            clear(&self.stage, |_| true);
        }
    }
}

/// Exchanges the folders `a` and `b` (both exist).
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use rustix::fs::{renameat_with, RenameFlags, CWD};
        match renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE) {
            Ok(()) => return Ok(()),
            // Old kernels and some file systems have no exchange: two renames below.
            Err(e) if e == rustix::io::Errno::INVAL || e == rustix::io::Errno::NOSYS => {}
            Err(e) => return Err(e.into()),
        }
    }
    let old = a.with_extension("old");
    fs::rename(b, &old)?;
    if let Err(e) = fs::rename(a, b) {
        let _ = fs::rename(&old, b);
        return Err(e);
    }
    fs::rename(&old, a)
}

/// Folders made for a command's output files (`mkdir -p` of their parents), removed again,
/// deepest first and only when still empty, unless [`MadeFolders::keep`] is called: a command
/// that fails leaves no folder behind (issue 54: `morph --gif NEW/x.gif` failed after the
/// fits when `NEW` did not exist, though the morph makes its `-o` folder).
#[derive(Debug, Default)]
pub struct MadeFolders {
    made: Vec<PathBuf>,
    keep: bool,
}

impl MadeFolders {
    /// Makes the folder of `file` and the missing folders above it.
    pub fn parent_of(&mut self, file: &Path) -> Result<(), IoError> {
        let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) else {
            return Ok(());
        };
        let mut missing = Vec::new();
        let mut d = dir;
        while !d.as_os_str().is_empty() && fs::symlink_metadata(d).is_err() {
            missing.push(d.to_path_buf());
            match d.parent() {
                Some(p) => d = p,
                None => break,
            }
        }
        let made = fs::create_dir_all(dir);
        self.made.extend(missing);
        made.map_err(|source| IoError::Write { path: dir.to_path_buf(), source })
    }

    /// Keeps the folders made (the command succeeded).
    pub fn keep(mut self) {
        self.keep = true;
    }
}

impl Drop for MadeFolders {
    fn drop(&mut self) {
        if !self.keep {
            for d in &self.made {
                let _ = fs::remove_dir(d);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(name: &str) -> bool {
        name.starts_with("frame_") && name.ends_with(".png")
    }

    fn list(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    fn run(target: &Path, n: usize) -> Committed {
        let st = Staged::begin(target, frames).unwrap();
        for k in 0..n {
            fs::write(st.path(&format!("frame_{k}.png")), format!("run {n}")).unwrap();
        }
        st.commit().unwrap()
    }

    #[test]
    fn a_shorter_run_replaces_every_frame_of_a_longer_one() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        assert_eq!(run(&out, 4), Committed::Created);
        assert_eq!(run(&out, 2), Committed::Swapped);
        assert_eq!(list(&out), ["frame_0.png", "frame_1.png"]);
        assert_eq!(fs::read_to_string(out.join("frame_1.png")).unwrap(), "run 2");
        assert_eq!(list(dir.path()), ["out"], "no stage left");
    }

    #[test]
    fn user_files_stay_and_stale_frames_go() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        run(&out, 3);
        fs::write(out.join("notes.txt"), "mine").unwrap();
        assert_eq!(run(&out, 1), Committed::Merged);
        assert_eq!(list(&out), ["frame_0.png", "notes.txt"]);
        assert_eq!(fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
        assert_eq!(list(dir.path()), ["out"]);
    }

    #[test]
    fn a_dropped_stage_leaves_the_folder_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        run(&out, 2);
        {
            let st = Staged::begin(&out, frames).unwrap();
            fs::write(st.path("frame_0.png"), "half").unwrap();
        }
        assert_eq!(list(&out), ["frame_0.png", "frame_1.png"]);
        assert_eq!(fs::read_to_string(out.join("frame_0.png")).unwrap(), "run 2");
        assert_eq!(list(dir.path()), ["out"]);
    }

    #[test]
    fn stages_of_killed_runs_are_removed_and_names_are_recognised() {
        let dir = tempfile::tempdir().unwrap();
        // A pid above the kernel's maximum (2^22) never runs.
        let dead = dir.path().join(".out.4194400-0.stage");
        fs::create_dir(&dead).unwrap();
        fs::write(dead.join("frame_0.png"), "x").unwrap();
        let st = Staged::begin(&dir.path().join("out"), frames).unwrap();
        if cfg!(target_os = "linux") {
            assert!(!dead.exists());
        }
        drop(st);
        assert_eq!(stage_of(".out.12-3.stage"), Some(("out", 12)));
        assert_eq!(stage_of(".a.b.12-3.old"), Some(("a.b", 12)));
        assert_eq!(stage_of(".out.12-3.tmp"), None);
        assert_eq!(stage_of("out.12-3.stage"), None);
    }

    #[test]
    fn a_file_in_the_way_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("out");
        fs::write(&f, "a file").unwrap();
        let e = Staged::begin(&f, frames).unwrap_err().to_string();
        assert!(e.contains("not a folder"), "{e}");
    }
}

//! File input and output shared by the commands.
//!
//! Every output is written to a temporary file in the destination folder and then renamed
//! over the destination, so a reader never sees a half-written file and a failed command
//! never destroys an earlier output.

/// Most pixels of a raster computed point by point: displacement fields (`.npy`, `.tif`,
/// ITK, NGFF), Jacobian maps and pictures of a warped mesh. One limit for all of them, the
/// command line and the Python bindings alike.
pub const MAX_RASTER_PIXELS: u64 = 100_000_000;

pub mod clash;
pub mod colormesh;
pub mod deformation;
pub(crate) mod folder;
pub mod frames;
pub mod image_use;
pub mod itk;
pub mod landmarks;
pub mod model;
pub mod ngff;
pub mod obj;
mod pnm;
pub mod points;
pub mod raster;
mod tiff_checks;

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Errors of file input and output, with the path involved.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// Reading failed.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Writing failed.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder
/// (`.NAME.PID-N.tmp`), flushed and synced, then renamed over `path`. On error the temporary
/// file is removed and `path` is untouched.
///
/// What already exists at `path` is respected (see [`Destination`]):
/// * a regular file: the new file gets its permission bits (a `0600` file stays `0600`);
/// * a symbolic link: the link's final target is replaced (temporary file and rename beside
///   the target), so the link stays a link and its target gets the new content;
/// * a file that is not a regular file (a FIFO, a character or block device, a socket): the
///   bytes are written into it in place, without a temporary file or a rename (a rename would
///   replace, say, `/dev/stdout` or a named pipe with a regular file).
///
/// A process killed between creating and renaming its temporary file leaves it behind. The
/// first write into a folder in each process removes such leftovers (see
/// [`remove_stale_temps`]), so an interrupted batch that is run again tidies up after itself.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes).map_err(|source| IoError::Write { path: path.to_path_buf(), source })?;
    f.commit()
}

/// A file written piece by piece (through [`Write`], buffered) and put in place as
/// [`write_atomic`] puts its bytes: into a temporary file `.NAME.PID-N.tmp` beside the
/// destination, flushed, synced and renamed over it by [`AtomicFile::commit`]. Until then the
/// destination is untouched; an `AtomicFile` dropped without a commit (a failed command)
/// removes its temporary file. The destination is looked at when the file is created (see
/// [`Destination`]): a FIFO or device is written in place, without a temporary file.
///
/// A write error is remembered: `commit` then fails with it, even when the writer that saw
/// it ignored it (an encoder writing its trailer while it is dropped), so a file is never put
/// in place with a hole in it.
#[derive(Debug)]
pub struct AtomicFile {
    /// The path as given (for messages).
    path: PathBuf,
    out: std::io::BufWriter<fs::File>,
    /// The temporary file and the file it replaces (`None`: written in place).
    rename: Option<(PathBuf, PathBuf)>,
    mode: Option<fs::Permissions>,
    failed: Option<std::io::Error>,
    done: bool,
    /// Bytes passed to `write` so far, and how far writeback has been started.
    written: u64,
    kicked: u64,
}

/// Writeback of a temporary file is started every this many bytes ([`AtomicFile`]). At
/// 4 MiB, `trimorph solve`'s 2.9 MB output (the 400 x 800 benchmark) started none, and its
/// commit (flush, fsync, rename) took 4.2 ms; at 1 MiB, 1.7 ms.
const WRITEBACK_STEP: u64 = 1 << 20;

/// Buffer of an [`AtomicFile`]: large enough that an encoder's small writes become few
/// system calls.
const ATOMIC_BUFFER: usize = 256 << 10;

impl AtomicFile {
    /// Opens the temporary file for `path` (or `path` itself when it is a FIFO or device).
    pub fn create(path: &Path) -> Result<AtomicFile, IoError> {
        let werr = |source| IoError::Write { path: path.to_path_buf(), source };
        let (file, rename, mode) = match destination(path).map_err(werr)? {
            Destination::Special => {
                (fs::OpenOptions::new().write(true).open(path).map_err(werr)?, None, None)
            }
            Destination::File { target, mode } => {
                let dir = match target.parent() {
                    Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                    _ => PathBuf::from("."),
                };
                let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned())
                else {
                    let e =
                        std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name");
                    return Err(werr(e));
                };
                tidy_once(&dir);
                let tmp = dir.join(temp_name(&name));
                let f =
                    fs::OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(werr)?;
                (f, Some((tmp, target)), mode)
            }
        };
        Ok(AtomicFile {
            path: path.to_path_buf(),
            out: std::io::BufWriter::with_capacity(ATOMIC_BUFFER, file),
            rename,
            mode,
            failed: None,
            done: false,
            written: 0,
            kicked: 0,
        })
    }

    /// Flushes and syncs the file and renames it over the destination. On error the
    /// temporary file is removed and the destination is untouched.
    pub fn commit(mut self) -> Result<(), IoError> {
        let path = self.path.clone();
        let werr = |source| IoError::Write { path: path.clone(), source };
        if let Some(e) = self.failed.take() {
            return Err(werr(e));
        }
        self.out.flush().map_err(werr)?;
        let Some((tmp, target)) = &self.rename else {
            self.done = true;
            return Ok(());
        };
        let f = self.out.get_ref();
        if let Some(perm) = &self.mode {
            f.set_permissions(perm.clone()).map_err(werr)?;
        }
        f.sync_all().map_err(werr)?;
        fs::rename(tmp, target).map_err(werr)?;
        self.done = true;
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let r = self.out.write(buf);
        if let Ok(n) = r {
            self.written += n as u64;
            self.start_writeback();
        }
        self.remember(r)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let r = self.out.flush();
        self.remember(r)
    }
}

/// Seeking works on a temporary file (a regular file); a destination written in place (a
/// FIFO or device, [`AtomicFile::seekable`] false) refuses it with the system's error.
impl std::io::Seek for AtomicFile {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        let r = self.out.seek(pos);
        self.remember(r)
    }
}

impl AtomicFile {
    /// Starts the writeback of what the kernel holds of a temporary file, every
    /// [`WRITEBACK_STEP`] bytes (`sync_file_range` with `SYNC_FILE_RANGE_WRITE`: it starts
    /// the disk writes and returns; it waits for nothing and guarantees nothing). The fsync
    /// of [`AtomicFile::commit`] then finds most of the file on its way to the disk: on a
    /// 16 MiB TIFF it waited 6.5 ms, the time of writing the whole file after the last byte.
    /// Durability is the fsync's alone, as before; this only moves the work earlier.
    fn start_writeback(&mut self) {
        let held = self.written.saturating_sub(self.out.buffer().len() as u64);
        if self.rename.is_none() || held < self.kicked + WRITEBACK_STEP {
            return;
        }
        #[cfg(target_os = "linux")]
        {
            use std::os::fd::AsRawFd;
            let fd = self.out.get_ref().as_raw_fd();
            let (from, len) = (self.kicked as i64, (held - self.kicked) as i64);
            // SAFETY: `fd` is the open descriptor of the file this `AtomicFile` owns (it
            // stays open for the call); sync_file_range reads no memory of ours and changes
            // no byte of the file, and its failure (an unsupported filesystem) is ignored,
            // since the fsync at commit still does all that durability needs.
            unsafe {
                let _ = libc::sync_file_range(fd, from, len, libc::SYNC_FILE_RANGE_WRITE);
            }
        }
        self.kicked = held;
    }

    /// Whether the file is a temporary regular file (so [`std::io::Seek`] works), not a FIFO
    /// or device written in place.
    pub fn seekable(&self) -> bool {
        self.rename.is_some()
    }

    /// Keeps the first error of a write (an interrupted call is retried, not an error).
    fn remember<T>(&mut self, r: std::io::Result<T>) -> std::io::Result<T> {
        if let Err(e) = &r {
            if e.kind() != std::io::ErrorKind::Interrupted {
                self.failed.get_or_insert_with(|| std::io::Error::new(e.kind(), e.to_string()));
            }
        }
        r
    }
}

impl Drop for AtomicFile {
    /// An uncommitted file is removed (the destination is untouched).
    fn drop(&mut self) {
        if let (false, Some((tmp, _))) = (self.done, &self.rename) {
            let _ = fs::remove_file(tmp);
        }
    }
}

/// A fresh temporary name for the file `name`, `.NAME.PID-N.tmp` (unique per process and
/// call, so concurrent writers never share a temporary file). Files of this form are the
/// ones [`remove_stale_temps`] and [`folder::Staged`] treat as leftovers of a writer.
pub fn temp_name(name: &str) -> String {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!(".{name}.{}-{n}.tmp", std::process::id())
}

/// What [`write_atomic`] finds at an output path.
#[derive(Debug, PartialEq)]
pub enum Destination {
    /// A FIFO, device or socket (or what a symbolic link resolves to is one): written in place.
    Special,
    /// A regular file, or nothing yet: `target` is the path to replace (the final target of a
    /// symbolic link, the path itself otherwise), `mode` the permissions to keep.
    File {
        /// The file that is replaced.
        target: PathBuf,
        /// The permissions of the existing file, if there is one.
        mode: Option<fs::Permissions>,
    },
}

/// Looks at `path` before writing it (see [`write_atomic`]). A dangling symbolic link is
/// followed to the file it names, which is created. The kind of file is asked of the system
/// through the whole link chain (so `/dev/stdout`, a link to `/proc/self/fd/1`, counts as the
/// pipe or terminal it is).
pub fn destination(path: &Path) -> std::io::Result<Destination> {
    let Ok(meta) = fs::symlink_metadata(path) else {
        return Ok(Destination::File { target: path.to_path_buf(), mode: None });
    };
    let link = meta.file_type().is_symlink();
    let file = |mode| -> std::io::Result<Destination> {
        let target = if link { resolve_link(path)? } else { path.to_path_buf() };
        Ok(Destination::File { target, mode })
    };
    match fs::metadata(path) {
        Ok(m) if m.is_file() => file(Some(m.permissions())),
        // A folder: the rename fails with the system's message.
        Ok(m) if m.is_dir() => Ok(Destination::File { target: path.to_path_buf(), mode: None }),
        Ok(_) => Ok(Destination::Special),
        Err(_) => file(None),
    }
}

/// The final target of the symbolic link `path` (relative links are read from the link's
/// folder); at most 40 links are followed, as the kernel does.
fn resolve_link(path: &Path) -> std::io::Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let next = fs::read_link(&p)?;
                p = match p.parent() {
                    Some(dir) if next.is_relative() => dir.join(next),
                    _ => next,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(std::io::Error::other("too many levels of symbolic links"))
}

/// How long a leftover temporary file must have been untouched before
/// [`remove_stale_temps`] removes it, even when its writer is gone.
pub const STALE_AFTER: std::time::Duration = std::time::Duration::from_secs(60);

/// Runs [`remove_stale_temps`] on `dir` the first time this process writes there.
fn tidy_once(dir: &Path) {
    use std::collections::HashSet;
    use std::sync::{Mutex, OnceLock};
    static DONE: OnceLock<Mutex<HashSet<PathBuf>>> = OnceLock::new();
    let key = fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    let first =
        DONE.get_or_init(Default::default).lock().map(|mut done| done.insert(key)).unwrap_or(false);
    if first {
        remove_stale_temps(dir, STALE_AFTER);
    }
}

/// The writer's process id if `file_name` has the form of a [`write_atomic`] temporary file,
/// `.NAME.PID-N.tmp`.
fn temp_writer(file_name: &str) -> Option<u32> {
    let stem = file_name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (_, tail) = stem.rsplit_once('.')?;
    let (pid, n) = tail.split_once('-')?;
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

/// Removes the temporary files that [`write_atomic`] calls left in `dir` when their process
/// was killed: files named `.NAME.PID-N.tmp` whose process no longer runs and that nobody
/// modified for `min_age`. The age check keeps files of a live writer on another machine
/// (a shared folder) safe. Only Linux can tell whether a process runs (`/proc/PID`);
/// elsewhere nothing is removed. Returns the number of files removed; errors (an unreadable
/// folder, a file removed meanwhile) are ignored, as tidying must never fail a write.
pub fn remove_stale_temps(dir: &Path, min_age: std::time::Duration) -> usize {
    let Ok(entries) = fs::read_dir(dir) else { return 0 };
    let me = std::process::id();
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(temp_writer) else { continue };
        if pid == me || process_runs(pid) {
            continue;
        }
        let age = entry.metadata().and_then(|m| m.modified()).ok().and_then(|t| t.elapsed().ok());
        if age.is_some_and(|a| a >= min_age)
            && entry.file_type().is_ok_and(|t| t.is_file())
            && fs::remove_file(entry.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

/// Whether process `pid` runs on this machine; `true` when that cannot be told.
fn process_runs(pid: u32) -> bool {
    if cfg!(target_os = "linux") && Path::new("/proc/self").exists() {
        Path::new("/proc").join(pid.to_string()).exists()
    } else {
        true
    }
}

/// JSON text that stays readable for matrices: objects have one key per line, arrays of
/// arrays one row per line, everything else is compact.
pub fn json_rows(v: &serde_json::Value) -> String {
    let v = &sorted_keys(v);
    fn go(v: &serde_json::Value, indent: usize, out: &mut String) {
        use serde_json::Value;
        let pad = "  ".repeat(indent + 1);
        match v {
            Value::Object(map) if !map.is_empty() => {
                out.push_str("{\n");
                for (i, (k, val)) in map.iter().enumerate() {
                    out.push_str(&format!("{pad}{}: ", Value::String(k.clone())));
                    go(val, indent + 1, out);
                    out.push_str(if i + 1 < map.len() { ",\n" } else { "\n" });
                }
                out.push_str(&format!("{}}}", "  ".repeat(indent)));
            }
            Value::Array(rows) if rows.iter().any(Value::is_array) => {
                out.push_str("[\n");
                for (j, r) in rows.iter().enumerate() {
                    out.push_str(&format!(
                        "{pad}{r}{}\n",
                        if j + 1 < rows.len() { "," } else { "" }
                    ));
                }
                out.push_str(&format!("{}]", "  ".repeat(indent)));
            }
            other => out.push_str(&other.to_string()),
        }
    }
    let mut out = String::new();
    go(v, 0, &mut out);
    out.push('\n');
    out
}

/// Reads a whole text file (or standard input for `-`).
pub fn read_text(path: &Path) -> Result<String, IoError> {
    let mut s = String::new();
    if path.as_os_str() == "-" {
        std::io::Read::read_to_string(&mut std::io::stdin(), &mut s)
            .map_err(|source| IoError::Read { path: path.to_path_buf(), source })?;
    } else {
        s = fs::read_to_string(path)
            .map_err(|source| IoError::Read { path: path.to_path_buf(), source })?;
    }
    Ok(strip_bom(s))
}

/// The text without a leading UTF-8 byte-order mark (editors on Windows write one; it is
/// not part of the JSON or CSV content).
pub fn strip_bom(s: String) -> String {
    match s.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => s,
    }
}

/// A copy of `v` with the keys of every object in sorted order. `serde_json`'s
/// `preserve_order` feature (enabled by the `zarrs` dependency) makes maps keep insertion
/// order; [`json_rows`] sorts, so the files it writes keep the key order they always had.
pub fn sorted_keys(v: &serde_json::Value) -> serde_json::Value {
    use serde_json::Value;
    match v {
        Value::Object(m) => {
            let mut keys: Vec<&String> = m.keys().collect();
            keys.sort();
            Value::Object(keys.into_iter().map(|k| (k.clone(), sorted_keys(&m[k]))).collect())
        }
        Value::Array(a) => Value::Array(a.iter().map(sorted_keys).collect()),
        other => other.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bug (reliability pass): a UTF-8 byte-order mark made every JSON file fail with
    /// "expected value at line 1 column 1".
    #[test]
    fn a_byte_order_mark_is_not_content() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bom.json");
        fs::write(&p, "\u{feff}{\"a\": 1}").unwrap();
        let text = read_text(&p).unwrap();
        assert_eq!(text, "{\"a\": 1}");
        assert!(serde_json::from_str::<serde_json::Value>(&text).is_ok());
        assert_eq!(strip_bom("x\u{feff}".into()), "x\u{feff}");
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.json");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(fs::read_to_string(&p).unwrap(), "two");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    /// Leftovers of a killed run (`tests/it/cli/nothing_lost.rs` kills batches with SIGKILL) were
    /// never removed; now the next write into the folder removes those of dead processes.
    #[test]
    fn stale_temps_of_dead_writers_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        // A pid above the kernel's maximum (2^22) never runs.
        let dead = dir.path().join(".out.json.4194400-3.tmp");
        let live = dir.path().join(format!(".out.json.{}-9.tmp", std::process::id()));
        let other = dir.path().join(".notes.txt.tmp");
        for f in [&dead, &live, &other] {
            fs::write(f, b"partial").unwrap();
        }
        // Too fresh: kept.
        assert_eq!(remove_stale_temps(dir.path(), std::time::Duration::from_secs(3600)), 0);
        assert!(dead.exists());
        let removed = remove_stale_temps(dir.path(), std::time::Duration::ZERO);
        if cfg!(target_os = "linux") {
            assert_eq!(removed, 1);
            assert!(!dead.exists());
        }
        assert!(live.exists() && other.exists(), "only dead writers' temporaries go");
    }

    #[test]
    fn temp_names_are_recognised() {
        assert_eq!(temp_writer(".out.json.123-0.tmp"), Some(123));
        assert_eq!(temp_writer(".a.b.c.png.77-12.tmp"), Some(77));
        assert_eq!(temp_writer(".out.json.tmp"), None);
        assert_eq!(temp_writer("out.json.123-0.tmp"), None);
        assert_eq!(temp_writer(".out.json.x-0.tmp"), None);
        assert_eq!(temp_writer(".out.json.12-x.tmp"), None);
    }

    #[cfg(unix)]
    #[test]
    fn destinations_are_told_apart() {
        use std::os::unix::fs::symlink;
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let f = d.join("f.json");
        fs::write(&f, "x").unwrap();
        assert!(matches!(destination(&f).unwrap(), Destination::File { mode: Some(_), .. }));
        let none = d.join("none.json");
        assert_eq!(destination(&none).unwrap(), Destination::File { target: none, mode: None });
        // A chain of two links, the second relative, ends at f.json.
        fs::create_dir(d.join("sub")).unwrap();
        symlink("../f.json", d.join("sub/l1")).unwrap();
        symlink(d.join("sub/l1"), d.join("l2")).unwrap();
        let Destination::File { target, .. } = destination(&d.join("l2")).unwrap() else {
            panic!("a link to a file is a file")
        };
        assert_eq!(fs::canonicalize(target).unwrap(), fs::canonicalize(&f).unwrap());
        symlink("l3", d.join("l3")).unwrap();
        assert!(destination(&d.join("l3")).is_err(), "a link loop is an error");
        // Character devices are special (read only: nothing is written here).
        if Path::new("/dev/null").exists() {
            assert_eq!(destination(Path::new("/dev/null")).unwrap(), Destination::Special);
        }
    }

    #[test]
    fn an_atomic_file_appears_only_when_committed() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("anim.gif");
        fs::write(&p, "old").unwrap();
        {
            let mut f = AtomicFile::create(&p).unwrap();
            f.write_all(b"half").unwrap();
        }
        assert_eq!(fs::read_to_string(&p).unwrap(), "old", "dropped: untouched");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file left");
        let mut f = AtomicFile::create(&p).unwrap();
        for k in 0..1000 {
            write!(f, "{k},").unwrap();
        }
        assert_eq!(fs::read_to_string(&p).unwrap(), "old", "not before the commit");
        f.commit().unwrap();
        let text = fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("0,1,2,") && text.ends_with("998,999,"));
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    /// A file of several writeback steps, written in odd-sized pieces (some buffered, some
    /// passed straight through) and patched by a seek, arrives whole: starting the
    /// writeback early changes no byte, and `kicked` follows what the kernel holds.
    #[test]
    fn a_large_atomic_file_with_early_writeback_arrives_whole() {
        use std::io::{Seek, SeekFrom};
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.tif");
        let want: Vec<u8> =
            (0..(3 * WRITEBACK_STEP + 12_345)).map(|i| (i * 7 % 251) as u8).collect();
        let mut f = AtomicFile::create(&p).unwrap();
        assert!(f.seekable());
        let mut at = 0;
        for (k, size) in [17usize, 300_000, 1 << 20, 5, 3 << 20].iter().cycle().enumerate() {
            let end = (at + size + k).min(want.len());
            f.write_all(&want[at..end]).unwrap();
            at = end;
            if at == want.len() {
                break;
            }
        }
        assert!(
            f.kicked >= 2 * WRITEBACK_STEP && f.kicked <= f.written,
            "{} {}",
            f.kicked,
            f.written
        );
        f.seek(SeekFrom::Start(4)).unwrap();
        f.write_all(&want[4..8]).unwrap();
        f.commit().unwrap();
        assert!(fs::read(&p).unwrap() == want);
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    /// An encoder that ignores an error of its last write (the GIF trailer, written when the
    /// encoder is dropped) must not leave a truncated file: the commit fails with the error.
    #[test]
    fn an_ignored_write_error_fails_the_commit() {
        let full = Path::new("/dev/full");
        if !cfg!(target_os = "linux") || !full.exists() {
            return;
        }
        let mut f = AtomicFile::create(full).unwrap();
        let _ = f.write_all(&vec![7u8; 2 * ATOMIC_BUFFER]);
        let e = f.commit().unwrap_err().to_string();
        assert!(e.contains("/dev/full"), "{e}");
    }

    #[test]
    fn failed_write_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("missing-dir").join("out.json");
        assert!(write_atomic(&p, b"x").is_err());
        assert!(!p.exists());
    }
}

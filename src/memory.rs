//! The process's memory budget: every large buffer is checked against it before it is
//! allocated, so that an input that would need more memory than the machine has (an image
//! bomb, a huge mesh) is refused with a clear message instead of aborting the process.
//!
//! The budget is one number of bytes for the whole process. It is not an allocator: callers
//! that are about to allocate large buffers add up what they will hold at the same time
//! (an image's decoded pages, a warp's input and output pages, a morph's frames) and ask
//! [`check`] first. Small and transient allocations are not counted, so the budget is set
//! with headroom: the default is [`DEFAULT_FRACTION`] of the memory the process may use,
//! the smallest of
//!
//! * the machine's physical memory (`MemTotal` in `/proc/meminfo`),
//! * the cgroup limit (`/sys/fs/cgroup/memory.max`, cgroup v2; v1's
//!   `memory/memory.limit_in_bytes`), as in a container or a Slurm job,
//! * the process's address-space and data limits (`ulimit -v`, `ulimit -d`; from
//!   `/proc/self/limits`).
//!
//! Where none of these can be read (not Linux), [`FALLBACK_LIMIT`] is taken as the memory.
//! The budget can be set for the process with [`set_limit`] (`trimorph --max-memory`), or
//! with the environment variable `TRIMORPH_MAX_MEMORY` (read once, at the first query; the
//! same syntax as [`parse_size`]).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

/// The part of the usable memory that the default budget allows (one half: the budget
/// counts only the large buffers, and the rest of a command, its allocator and the other
/// processes of the machine need the other half).
pub const DEFAULT_FRACTION: f64 = 0.5;

/// The memory assumed where the machine cannot tell (not Linux): 8 GiB.
pub const FALLBACK_LIMIT: u64 = 8 << 30;

/// Environment variable that sets the budget (same syntax as [`parse_size`]).
pub const ENV_VAR: &str = "TRIMORPH_MAX_MEMORY";

/// The budget set by [`set_limit`]; 0 = not set (the environment or the default applies).
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// A buffer, or a set of buffers held at once, would exceed the memory budget.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{what} needs {} of memory, over the budget of {} (raise it with --max-memory or {ENV_VAR}, or make the input smaller)",
    format_size(*.needed),
    format_size(*.limit)
)]
pub struct OverBudget {
    /// What needs the memory (e.g. "decoding 4 pages of 32768 x 32768 RGB16").
    pub what: String,
    /// Bytes needed.
    pub needed: u64,
    /// The budget in bytes.
    pub limit: u64,
}

/// A size that [`parse_size`] cannot read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("memory size {0:?}: expected a number of bytes with an optional unit K, M, G or T (powers of 1024), e.g. 512M or 4G, at least 1M")]
pub struct SizeError(pub String);

/// Reads a memory size: a whole or decimal number with an optional unit `K`, `M`, `G`, `T`
/// (powers of 1024; a trailing `B` or `iB` is allowed, case is ignored). At least 1 MiB.
///
/// ```
/// use trimorph::memory::parse_size;
/// assert_eq!(parse_size("4G").unwrap(), 4 << 30);
/// assert_eq!(parse_size("1.5GiB").unwrap(), 3 << 29);
/// assert_eq!(parse_size("2097152").unwrap(), 2 << 20);
/// assert!(parse_size("lots").is_err());
/// assert!(parse_size("10K").is_err()); // below 1 MiB
/// ```
pub fn parse_size(text: &str) -> Result<u64, SizeError> {
    let bad = || SizeError(text.to_string());
    let t = text.trim().to_ascii_uppercase();
    let t = t.strip_suffix("IB").or_else(|| t.strip_suffix('B')).unwrap_or(&t);
    let (num, shift) = match t.chars().last() {
        Some('K') => (&t[..t.len() - 1], 10),
        Some('M') => (&t[..t.len() - 1], 20),
        Some('G') => (&t[..t.len() - 1], 30),
        Some('T') => (&t[..t.len() - 1], 40),
        _ => (t, 0),
    };
    let v: f64 = num.trim().parse().map_err(|_| bad())?;
    let bytes = v * (1u64 << shift) as f64;
    if !bytes.is_finite() || bytes < (1u64 << 20) as f64 || bytes >= u64::MAX as f64 {
        return Err(bad());
    }
    Ok(bytes as u64)
}

/// A size for messages: bytes in the largest binary unit that keeps it at least 1, with
/// one decimal (e.g. "2.7 GiB").
pub fn format_size(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Sets the process's budget in bytes (`None`: back to the environment or the default).
pub fn set_limit(bytes: Option<u64>) {
    LIMIT.store(bytes.unwrap_or(0), Ordering::Relaxed);
}

/// The process's budget in bytes: the one set by [`set_limit`], else `TRIMORPH_MAX_MEMORY`,
/// else [`default_limit`].
pub fn limit() -> u64 {
    match LIMIT.load(Ordering::Relaxed) {
        0 => *ENV_OR_DEFAULT.get_or_init(|| {
            std::env::var(ENV_VAR)
                .ok()
                .and_then(|v| parse_size(&v).ok())
                .unwrap_or_else(default_limit)
        }),
        v => v,
    }
}

static ENV_OR_DEFAULT: OnceLock<u64> = OnceLock::new();

/// The default budget: [`DEFAULT_FRACTION`] of [`usable_memory`].
pub fn default_limit() -> u64 {
    (usable_memory() as f64 * DEFAULT_FRACTION) as u64
}

/// The memory this process may use: the smallest of physical memory, the cgroup limit and
/// the address-space / data limits ([`FALLBACK_LIMIT`] where none can be read).
pub fn usable_memory() -> u64 {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let mut found: Vec<u64> = Vec::new();
    if let Some(m) = read("/proc/meminfo").and_then(|t| meminfo_total(&t)) {
        found.push(m);
    }
    for p in ["/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"] {
        // "max" (no limit) and v1's huge sentinel values simply do not parse or lose.
        if let Some(v) = read(p).and_then(|t| t.trim().parse::<u64>().ok()) {
            found.push(v);
        }
    }
    if let Some(t) = read("/proc/self/limits") {
        found.extend(rlimits(&t));
    }
    found.into_iter().min().unwrap_or(FALLBACK_LIMIT)
}

/// `MemTotal` of `/proc/meminfo`, in bytes.
fn meminfo_total(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// The soft address-space and data limits of `/proc/self/limits`, in bytes (absent when
/// "unlimited").
fn rlimits(text: &str) -> Vec<u64> {
    text.lines()
        .filter(|l| l.starts_with("Max address space") || l.starts_with("Max data size"))
        .filter_map(|l| {
            // "Max address space   4294967296   unlimited   bytes": soft limit first.
            l.split_whitespace().find_map(|w| w.parse::<u64>().ok())
        })
        .collect()
}

/// Checks that `bytes` (the large buffers about to be held at once) fit in the budget;
/// `what` describes them for the message and is only called on failure.
pub fn check(bytes: u64, what: impl FnOnce() -> String) -> Result<(), OverBudget> {
    check_against(limit(), bytes, what)
}

/// [`check`] against a given budget.
pub fn check_against(
    limit: u64,
    bytes: u64,
    what: impl FnOnce() -> String,
) -> Result<(), OverBudget> {
    if bytes > limit {
        return Err(OverBudget { what: what(), needed: bytes, limit });
    }
    Ok(())
}

/// Bytes of `count` items of `size` bytes each, saturating (a product that overflows is
/// over any budget).
pub fn bytes_of(count: u64, size: u64) -> u64 {
    count.saturating_mul(size)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_read_with_units_and_refuse_nonsense() {
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("512mb").unwrap(), 512 << 20);
        assert_eq!(parse_size(" 2 GiB ").unwrap(), 2 << 30);
        assert_eq!(parse_size("1T").unwrap(), 1 << 40);
        for bad in ["", "G", "-1G", "NaN", "1e400", "0", "1X", "4 G B"] {
            assert!(parse_size(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn sizes_print_in_binary_units() {
        assert_eq!(format_size(512), "512 bytes");
        assert_eq!(format_size(3 << 29), "1.5 GiB");
        assert_eq!(format_size(2_900_000_000), "2.7 GiB");
    }

    #[test]
    fn limits_are_read_from_proc_files() {
        let meminfo = "MemTotal:       24567896 kB\nMemFree:         1000 kB\n";
        assert_eq!(meminfo_total(meminfo), Some(24567896 * 1024));
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max data size             unlimited            unlimited            bytes\n\
                      Max address space         4294967296           unlimited            bytes\n";
        assert_eq!(rlimits(limits), vec![4294967296]);
        assert!(usable_memory() > 0);
    }

    #[test]
    fn check_refuses_over_the_limit_and_names_what() {
        let e = check_against(64 << 20, 65 << 20, || "a test buffer".into()).unwrap_err();
        assert_eq!(e.limit, 64 << 20);
        let msg = e.to_string();
        assert!(msg.contains("a test buffer needs 65.0 MiB"), "{msg}");
        assert!(msg.contains("--max-memory"), "{msg}");
        assert!(check_against(64 << 20, 64 << 20, || unreachable!()).is_ok());
        assert_eq!(bytes_of(u64::MAX, 2), u64::MAX);
    }

    #[test]
    fn a_set_limit_wins_and_unsetting_restores_the_default() {
        // Other unit tests run in parallel in this process: only a limit larger than any
        // of them needs is set here.
        set_limit(Some(1 << 60));
        assert_eq!(limit(), 1 << 60);
        set_limit(None);
        assert!(limit() >= 1 << 20 && limit() < 1 << 60);
    }
}

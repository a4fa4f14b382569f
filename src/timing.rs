//! Wall-time phases of a job (`--timings`, reports): a phase marked again adds up, so a
//! phase done batch after batch is one row.
//!
//! ```
//! use trimorph::timing::Phases;
//! let mut ph = Phases::new();
//! ph.mark("read");
//! ph.mark("work");
//! ph.mark("read");
//! assert_eq!(ph.rows().iter().map(|r| r.0).collect::<Vec<_>>(), ["read", "work"]);
//! ```

use std::time::Instant;

/// Phase timings: the wall time since the previous mark (or the start) goes to each mark's
/// phase.
#[derive(Clone, Debug)]
pub struct Phases {
    start: Instant,
    last: Instant,
    rows: Vec<(&'static str, f64)>,
}

impl Default for Phases {
    fn default() -> Phases {
        Phases::new()
    }
}

impl Phases {
    /// Starts the clock.
    pub fn new() -> Phases {
        let now = Instant::now();
        Phases { start: now, last: now, rows: Vec::new() }
    }

    /// Adds the time since the last mark to the phase `name`.
    pub fn mark(&mut self, name: &'static str) {
        let now = Instant::now();
        self.add(name, (now - self.last).as_secs_f64() * 1e3);
        self.last = now;
    }

    /// Adds `ms` to the phase `name` (a phase measured elsewhere) without moving the clock.
    pub fn add(&mut self, name: &'static str, ms: f64) {
        match self.rows.iter_mut().find(|(n, _)| *n == name) {
            Some(row) => row.1 += ms,
            None => self.rows.push((name, ms)),
        }
    }

    /// The phases in the order first marked, with their milliseconds.
    pub fn rows(&self) -> &[(&'static str, f64)] {
        &self.rows
    }

    /// Milliseconds since the start.
    pub fn total_ms(&self) -> f64 {
        self.start.elapsed().as_secs_f64() * 1e3
    }

    /// `name ms, name ms, ...; total ms`, one decimal.
    pub fn line(&self) -> String {
        let parts: Vec<String> = self.rows.iter().map(|(n, ms)| format!("{n} {ms:.1}")).collect();
        format!("{}; total {:.1}", parts.join(", "), self.total_ms())
    }
}

/// Phase lines on stderr for profiling a library call, printed only when the environment
/// variable `TRIMORPH_TRACE` is set (as `trimorph solve` does): `trace <what>: <phase> <ms>`,
/// the wall time since the previous mark. Costs one environment look-up when off.
///
/// ```
/// use trimorph::timing::Trace;
/// let mut t = Trace::new("example");
/// t.mark("first phase"); // prints only with TRIMORPH_TRACE set
/// assert_eq!(t.enabled(), std::env::var_os("TRIMORPH_TRACE").is_some());
/// ```
#[derive(Debug)]
pub struct Trace {
    what: &'static str,
    last: Option<(Instant, f64)>,
}

/// The CPU time of the whole process, all threads (milliseconds); 0 where it cannot be read.
fn process_cpu_ms() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } == 0 {
            return ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6;
        }
    }
    0.0
}

impl Trace {
    /// Starts the clock if `TRIMORPH_TRACE` is set.
    pub fn new(what: &'static str) -> Trace {
        let last = std::env::var_os("TRIMORPH_TRACE").map(|_| (Instant::now(), process_cpu_ms()));
        Trace { what, last }
    }

    /// Whether lines are printed.
    pub fn enabled(&self) -> bool {
        self.last.is_some()
    }

    /// Prints the time since the previous mark (or the start) as the phase `phase`, with the
    /// process's CPU time over the same span (all threads: a phase that keeps `n` cores busy
    /// shows about `n` times its wall time).
    pub fn mark(&mut self, phase: &str) {
        if let Some((last, cpu)) = self.last {
            let (now, cpu_now) = (Instant::now(), process_cpu_ms());
            eprintln!(
                "trace {}: {phase} {:.2} ms (cpu {:.2} ms)",
                self.what,
                (now - last).as_secs_f64() * 1e3,
                cpu_now - cpu
            );
            self.last = Some((now, cpu_now));
        }
    }
}

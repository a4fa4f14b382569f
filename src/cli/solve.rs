//! `trimorph solve`: an ECLES problem ([`crate::ecles::problem`]) solved by
//! [`crate::jobs::solve`]; this layer prints the job's JSON error object and maps it to the
//! exit code, and prints the `TRIMORPH_TRACE` lines.

use super::{Exit, EXIT_INPUT, EXIT_UNSOLVABLE};
use crate::jobs::solve::{run as run_job, SolveError, SolveOutput, SolveStep};
use anyhow::Result;
use std::path::Path;

/// The command line's error for a failed job: the JSON object on stderr and its exit for
/// the problem's own faults; a write error as it is.
fn failure(e: SolveError) -> anyhow::Error {
    let Some(obj) = e.json() else {
        return match e {
            SolveError::Write(e) => e.into(),
            SolveError::Output(e) => e.into(),
            other => other.into(),
        };
    };
    eprintln!("{obj}");
    let message = obj["message"].as_str().unwrap_or("error").to_string();
    let code = if e.is_unsolvable() { EXIT_UNSOLVABLE } else { EXIT_INPUT };
    Exit { code, message, printed: true }.into()
}

/// A line on stderr when `TRIMORPH_TRACE` is set.
fn trace(step: SolveStep) {
    if std::env::var_os("TRIMORPH_TRACE").is_some() {
        eprintln!("trace: {step}");
    }
}

/// `trimorph solve SYSTEM [-o OUT]`.
pub fn run(system: &Path, output: Option<&Path>) -> Result<()> {
    let mut stdout;
    let output = match output {
        Some(path) => SolveOutput::File(path.to_path_buf()),
        None => {
            stdout = std::io::BufWriter::with_capacity(1 << 18, std::io::stdout());
            SolveOutput::Writer(&mut stdout)
        }
    };
    run_job(system, output, &mut trace).map_err(failure)?;
    Ok(())
}

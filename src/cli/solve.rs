//! `trimorph solve`: an ECLES problem ([`crate::ecles::problem`]) solved, errors as JSON.

use super::{Exit, EXIT_INPUT, EXIT_UNSOLVABLE};
use crate::ecles::problem::{error_json, Problem, ProblemError, Solution};
use crate::ecles::EclesError;
use crate::io::{read_text, AtomicFile, IoError};
use anyhow::Result;
use serde_json::json;
use std::io::Write;
use std::path::Path;

/// Prints a JSON error object on stderr and returns the matching exit.
fn fail(code: i32, obj: serde_json::Value) -> anyhow::Error {
    eprintln!("{obj}");
    let message = obj["message"].as_str().unwrap_or("error").to_string();
    Exit { code, message, printed: true }.into()
}

/// Reads and solves a problem, mapping errors to the CLI's exits (JSON object on stderr).
fn solve_problem(text: &str, source: &str) -> Result<Solution> {
    let t0 = std::time::Instant::now();
    let problem = Problem::from_json(text).map_err(|e| {
        let kind = match e {
            ProblemError::Json(_) => "invalid_json",
            ProblemError::Key { .. } => "invalid_input",
            ProblemError::Edit(_) => "invalid_edit",
        };
        fail(
            EXIT_INPUT,
            json!({ "error": kind, "file": source, "message": format!("{source}: {e}") }),
        )
    })?;
    trace(&format!("parsed in {:.3} s", t0.elapsed().as_secs_f64()));
    let solution = problem.solve().map_err(|e| {
        let code = match e {
            EclesError::NotWeaklySolvable { .. } | EclesError::NotStronglySolvable { .. } => {
                EXIT_UNSOLVABLE
            }
            _ => EXIT_INPUT,
        };
        let mut obj = error_json(&e);
        obj["file"] = json!(source);
        fail(code, obj)
    })?;
    trace(&format!("solved ({}) in {:.3} s", solution.path, t0.elapsed().as_secs_f64()));
    Ok(solution)
}

/// A line on stderr when `TRIMORPH_TRACE` is set.
fn trace(msg: &str) {
    if std::env::var_os("TRIMORPH_TRACE").is_some() {
        eprintln!("trace: {msg}");
    }
}

/// `trimorph solve SYSTEM [-o OUT]`.
pub fn run(system: &Path, output: Option<&Path>) -> Result<()> {
    let text = read_text(system).map_err(|e| {
        fail(EXIT_INPUT, json!({ "error": "io", "file": system.display().to_string(), "message": e.to_string() }))
    })?;
    let t0 = std::time::Instant::now();
    let solution = solve_problem(&text, &system.display().to_string())?;
    match output {
        Some(path) => {
            let mut f = AtomicFile::create(path)?;
            let written = solution.write_json(&mut f);
            written.map_err(|source| IoError::Write { path: path.to_path_buf(), source })?;
            f.commit()?;
        }
        None => {
            let mut out = std::io::BufWriter::with_capacity(1 << 18, std::io::stdout());
            solution.write_json(&mut out)?;
            out.flush()?;
        }
    }
    trace(&format!("written after {:.3} s", t0.elapsed().as_secs_f64()));
    Ok(())
}

//! `trimorph solve` and `trimorph demo`.

use super::{Exit, EXIT_INPUT, EXIT_UNSOLVABLE};
use crate::ecles::problem::{error_json, Problem, ProblemError};
use crate::ecles::EclesError;
use crate::io::{read_text, write_atomic};
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

pub(super) fn solve_text(text: &str, source: &str) -> Result<serde_json::Value> {
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
    Ok(solution.to_json())
}

/// JSON with one key per line and one row per line for arrays of rows.
pub fn compact_pretty(v: &serde_json::Value) -> String {
    crate::io::json_rows(v)
}

/// `trimorph solve SYSTEM [-o OUT]`.
pub fn run(system: &Path, output: Option<&Path>) -> Result<()> {
    let text = read_text(system).map_err(|e| {
        fail(EXIT_INPUT, json!({ "error": "io", "file": system.display().to_string(), "message": e.to_string() }))
    })?;
    let out = solve_text(&text, &system.display().to_string())?;
    let body = compact_pretty(&out);
    match output {
        Some(path) => write_atomic(path, body.as_bytes())?,
        None => std::io::stdout().lock().write_all(body.as_bytes())?,
    }
    Ok(())
}

pub(super) const PUMP: &str = include_str!("../../examples/pump.json");
pub(super) const THESIS: &str = include_str!("../../examples/thesis_8_3.json");
pub(super) const PARALLELOGRAM: &str = include_str!("../../examples/parallelogram_2d.json");

//! The file job behind `trimorph solve`: an ECLES problem file ([`Problem`]) read, solved
//! ([`Problem::solve`]) and its solution written, atomically into a file
//! ([`AtomicFile`]) or streamed to a writer (standard output).
//!
//! Errors are [`SolveError`]: each names the problem file and its kind
//! ([`SolveErrorKind`], the `"error"` key of the JSON object `trimorph solve` prints), and
//! [`SolveError::json`] gives that object for the problem's own faults (read, parse,
//! solve); failing to write the solution is an ordinary error. Nothing here prints: the
//! steps' wall times go to a callback ([`SolveStep`], the `TRIMORPH_TRACE` lines).

use crate::ecles::problem::{error_json, Problem, ProblemError, Solution};
use crate::ecles::EclesError;
use crate::io::{read_text, AtomicFile, IoError};
use serde_json::{json, Value};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Where the solution goes.
pub enum SolveOutput<'w> {
    /// A file, written atomically (an earlier file survives a failed run).
    File(PathBuf),
    /// A stream (flushed at the end), e.g. buffered standard output.
    Writer(&'w mut (dyn Write + Send)),
}

/// A step of the job done, with the seconds since the problem was read (the
/// `TRIMORPH_TRACE` lines of `trimorph solve`: `trace: {step}`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SolveStep {
    /// The problem is parsed.
    Parsed {
        /// Seconds since the text was read.
        secs: f64,
    },
    /// The problem is solved, by the solver `path` (`"fraction_free"` or `"modular"`).
    Solved {
        /// The solver that ran.
        path: &'static str,
        /// Seconds since the text was read.
        secs: f64,
    },
    /// The solution is written.
    Written {
        /// Seconds since the text was read.
        secs: f64,
    },
}

impl std::fmt::Display for SolveStep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SolveStep::Parsed { secs } => write!(f, "parsed in {secs:.3} s"),
            SolveStep::Solved { path, secs } => write!(f, "solved ({path}) in {secs:.3} s"),
            SolveStep::Written { secs } => write!(f, "written after {secs:.3} s"),
        }
    }
}

/// The kind of a [`SolveError`]: the `"error"` key of its JSON object ([`Self::name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolveErrorKind {
    /// The problem file cannot be read (`"io"`).
    Io,
    /// The problem is not valid JSON (`"invalid_json"`).
    InvalidJson,
    /// A key is missing or holds a value of the wrong kind (`"invalid_input"`).
    InvalidInput,
    /// The edit is malformed: indices, sizes, weights (`"invalid_edit"`).
    InvalidEdit,
    /// The edit is not (weakly or strongly) solvable (`"not_solvable"`).
    NotSolvable,
    /// The solution cannot be written (`"output"`; no JSON object).
    Output,
}

impl SolveErrorKind {
    /// The kind's name, as the JSON object's `"error"` key spells it.
    pub fn name(self) -> &'static str {
        match self {
            SolveErrorKind::Io => "io",
            SolveErrorKind::InvalidJson => "invalid_json",
            SolveErrorKind::InvalidInput => "invalid_input",
            SolveErrorKind::InvalidEdit => "invalid_edit",
            SolveErrorKind::NotSolvable => "not_solvable",
            SolveErrorKind::Output => "output",
        }
    }
}

/// Why the solve job failed.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// The problem file cannot be read.
    #[error("{source}")]
    Read {
        /// The problem file.
        file: PathBuf,
        /// The cause (its text names the file).
        #[source]
        source: IoError,
    },
    /// The problem cannot be parsed: not JSON, a wrong key, a malformed edit.
    #[error("{}: {source}", file.display())]
    Parse {
        /// The problem file.
        file: PathBuf,
        /// The cause.
        #[source]
        source: ProblemError,
    },
    /// The edit cannot be made: not solvable, or malformed.
    #[error("{}: {source}", file.display())]
    Solve {
        /// The problem file.
        file: PathBuf,
        /// The cause.
        #[source]
        source: EclesError,
    },
    /// The solution file cannot be written (nothing is put in its place).
    #[error(transparent)]
    Write(IoError),
    /// Writing the solution to the stream failed.
    #[error(transparent)]
    Output(std::io::Error),
}

impl SolveError {
    /// The kind (the JSON object's `"error"` key).
    pub fn kind(&self) -> SolveErrorKind {
        match self {
            SolveError::Read { .. } => SolveErrorKind::Io,
            SolveError::Parse { source, .. } => match source {
                ProblemError::Json(_) => SolveErrorKind::InvalidJson,
                ProblemError::Key { .. } => SolveErrorKind::InvalidInput,
                ProblemError::Edit(_) => SolveErrorKind::InvalidEdit,
            },
            SolveError::Solve { source, .. } if unsolvable(source) => SolveErrorKind::NotSolvable,
            SolveError::Solve { .. } => SolveErrorKind::InvalidEdit,
            SolveError::Write(_) | SolveError::Output(_) => SolveErrorKind::Output,
        }
    }

    /// Whether the edit is not solvable (the command line's exit code 2).
    pub fn is_unsolvable(&self) -> bool {
        self.kind() == SolveErrorKind::NotSolvable
    }

    /// The problem file, for the problem's own faults (read, parse, solve).
    pub fn file(&self) -> Option<&Path> {
        match self {
            SolveError::Read { file, .. }
            | SolveError::Parse { file, .. }
            | SolveError::Solve { file, .. } => Some(file),
            SolveError::Write(_) | SolveError::Output(_) => None,
        }
    }

    /// The JSON object `trimorph solve` prints on standard error for the problem's own
    /// faults: `{"error": KIND, "file": FILE, "message": ...}`, and for the solve's errors
    /// the keys of [`error_json`] (`"condition"`, `"constraint"`, ...) with `"file"` last.
    /// `None` when the solution could not be written (an ordinary error).
    pub fn json(&self) -> Option<Value> {
        match self {
            SolveError::Read { file, source } => Some(json!({
                "error": self.kind().name(),
                "file": file.display().to_string(),
                "message": source.to_string(),
            })),
            SolveError::Parse { file, .. } => Some(json!({
                "error": self.kind().name(),
                "file": file.display().to_string(),
                "message": self.to_string(),
            })),
            SolveError::Solve { file, source } => {
                let mut obj = error_json(source);
                obj["file"] = json!(file.display().to_string());
                Some(obj)
            }
            SolveError::Write(_) | SolveError::Output(_) => None,
        }
    }
}

fn unsolvable(e: &EclesError) -> bool {
    matches!(e, EclesError::NotWeaklySolvable { .. } | EclesError::NotStronglySolvable { .. })
}

/// Parses and solves the problem `text` read from `file` (errors name `file`); `on_step`
/// hears the steps with the seconds since `t0`.
fn solve_read(
    text: &str,
    file: &Path,
    t0: Instant,
    on_step: &mut dyn FnMut(SolveStep),
) -> Result<Solution, SolveError> {
    let problem = Problem::from_json(text)
        .map_err(|source| SolveError::Parse { file: file.to_path_buf(), source })?;
    on_step(SolveStep::Parsed { secs: t0.elapsed().as_secs_f64() });
    let solution =
        problem.solve().map_err(|source| SolveError::Solve { file: file.to_path_buf(), source })?;
    on_step(SolveStep::Solved { path: solution.path, secs: t0.elapsed().as_secs_f64() });
    Ok(solution)
}

/// Reads the problem file `problem` (`-` for standard input) and solves it.
pub fn solve_file(
    problem: &Path,
    on_step: &mut dyn FnMut(SolveStep),
) -> Result<Solution, SolveError> {
    let text =
        read_text(problem).map_err(|source| SolveError::Read { file: problem.into(), source })?;
    solve_read(&text, problem, Instant::now(), on_step)
}

/// Writes `solution` (its JSON text, [`Solution::write_json`]) into the file `path`
/// atomically: on error nothing is put in its place.
pub fn write_solution(solution: &Solution, path: &Path) -> Result<(), SolveError> {
    let mut f = AtomicFile::create(path).map_err(SolveError::Write)?;
    solution
        .write_json(&mut f)
        .map_err(|source| SolveError::Write(IoError::Write { path: path.to_path_buf(), source }))?;
    f.commit().map_err(SolveError::Write)
}

/// Runs the job: reads the problem file `problem` (`-` for standard input), solves it and
/// writes the solution to `output`. `on_step` hears each step done (module docs). Returns
/// the solution.
pub fn run(
    problem: &Path,
    output: SolveOutput<'_>,
    on_step: &mut dyn FnMut(SolveStep),
) -> Result<Solution, SolveError> {
    let text =
        read_text(problem).map_err(|source| SolveError::Read { file: problem.into(), source })?;
    let t0 = Instant::now();
    let solution = solve_read(&text, problem, t0, on_step)?;
    drop(text);
    match output {
        SolveOutput::File(path) => write_solution(&solution, &path)?,
        SolveOutput::Writer(w) => {
            let mut w = w;
            solution.write_json(&mut w).map_err(SolveError::Output)?;
            w.flush().map_err(SolveError::Output)?;
        }
    }
    on_step(SolveStep::Written { secs: t0.elapsed().as_secs_f64() });
    Ok(solution)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PUMP: &str = r#"{"R": [[1,1,-1,0],[0,0,-1,1]], "Q": [[0],[5]], "P": [[1],[2],[3],[8]],
        "anchors": {"0": [4]}, "derived": [1, 2, 3]}"#;

    fn problem(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn fails(path: &Path) -> SolveError {
        run(path, SolveOutput::Writer(&mut Vec::new()), &mut |_| {}).unwrap_err()
    }

    #[test]
    fn solves_into_a_file_or_a_stream_with_the_same_bytes_and_every_step() {
        let dir = tempfile::tempdir().unwrap();
        let p = problem(dir.path(), "pump.json", PUMP);
        let mut steps = Vec::new();
        let mut streamed = Vec::new();
        let s = run(&p, SolveOutput::Writer(&mut streamed), &mut |s| steps.push(s)).unwrap();
        assert_eq!(streamed, s.to_json_text().into_bytes());
        assert!(matches!(
            steps[..],
            [SolveStep::Parsed { .. }, SolveStep::Solved { .. }, SolveStep::Written { .. }]
        ));
        assert!(steps[1].to_string().starts_with(&format!("solved ({}) in ", s.path)));
        let out = dir.path().join("out.json");
        run(&p, SolveOutput::File(out.clone()), &mut |_| {}).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), streamed);
        assert_eq!(solve_file(&p, &mut |_| {}).unwrap(), s);
    }

    #[test]
    fn errors_have_their_kind_file_and_json_object() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.json");
        let e = fails(&missing);
        assert_eq!(e.kind(), SolveErrorKind::Io);
        assert_eq!(e.file(), Some(missing.as_path()));
        let obj = e.json().unwrap();
        assert_eq!(obj["error"], "io");
        assert_eq!(obj["file"], missing.display().to_string());
        assert!(obj["message"].as_str().unwrap().starts_with("cannot read "));

        let cases = [
            (r#"{"R": [[1, 1]], "P": [[1], [2]]"#, SolveErrorKind::InvalidJson),
            (
                r#"{"R": [[1, 1]], "P": [[1], ["x"]], "anchors": {"0": [1]}, "derived": []}"#,
                SolveErrorKind::InvalidInput,
            ),
            (
                r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [0]}"#,
                SolveErrorKind::InvalidEdit,
            ),
        ];
        for (text, kind) in cases {
            let p = problem(dir.path(), "bad.json", text);
            let e = fails(&p);
            assert_eq!(e.kind(), kind, "{text}");
            assert!(!e.is_unsolvable());
            let obj = e.json().unwrap();
            assert_eq!(obj["error"], kind.name());
            assert_eq!(obj["file"], p.display().to_string());
            assert!(e.to_string().starts_with(&format!("{}: ", p.display())), "{e}");
            match &e {
                // A parse error's message names the file; the solver's is its own text.
                SolveError::Parse { .. } => assert_eq!(obj["message"], e.to_string()),
                SolveError::Solve { source, .. } => assert_eq!(obj["message"], source.to_string()),
                other => panic!("{other:?}"),
            }
        }

        // Not solvable: the ECLES error's object, with the file.
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/unsolvable.json"),
        )
        .unwrap();
        let p = problem(dir.path(), "unsolvable.json", &text);
        let e = fails(&p);
        assert!(e.is_unsolvable() && e.kind() == SolveErrorKind::NotSolvable);
        let SolveError::Solve { source, .. } = &e else { panic!("{e:?}") };
        let mut expected = error_json(source);
        expected["file"] = json!(p.display().to_string());
        assert_eq!(e.json().unwrap(), expected);
        assert_eq!(expected["error"], "not_solvable");
        assert_eq!(expected["condition"], "weak_solvability");
    }

    #[test]
    fn a_failed_write_is_an_output_error_and_leaves_the_earlier_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = problem(dir.path(), "pump.json", PUMP);
        let e = run(&p, SolveOutput::File(dir.path().join("no/such/dir/out.json")), &mut |_| {})
            .unwrap_err();
        assert_eq!(e.kind(), SolveErrorKind::Output);
        assert!(e.json().is_none() && e.file().is_none());
        assert!(matches!(e, SolveError::Write(_)));
        // An unsolvable edit writes nothing over an earlier output.
        let out = dir.path().join("out.json");
        std::fs::write(&out, "earlier").unwrap();
        let bad = problem(dir.path(), "bad.json", r#"{"R": [[1, 1]], "P": [[1], [2]]"#);
        assert!(run(&bad, SolveOutput::File(out.clone()), &mut |_| {}).is_err());
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "earlier");
    }
}

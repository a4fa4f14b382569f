//! General parameter editing from JSON: the input and output of `trimorph solve`.
//!
//! Input keys (fixed; others are ignored):
//!
//! | key | meaning |
//! |---|---|
//! | `"R"` | `m` rows of `n` integers (numbers or decimal strings), or the sparse form `{"rows": [[[col, val], ...], ...]}`: per row, its nonzeros as `[column, value]` pairs (0-based columns, any order, each column at most once) |
//! | `"Q"` | `m` rows of `d` numbers (default zeros, `d` taken from `"P"`) |
//! | `"P"` | `n` rows of `d` current values |
//! | `"anchors"` | object, parameter index -> row of `d` new values |
//! | `"derived"` | array of parameter indices |
//! | `"hints"` | optional object, derived index -> row (default: the current value) |
//! | `"weights"` | optional object, derived index -> positive number (default 1) |
//! | `"strong"` | bool (default false): require strong solvability |
//! | `"method"` | `"none"`, `"gcd"` or `"turner"` (default `"turner"`) |
//! | `"path"` | `"auto"` (default), `"modular"` or `"fraction_free"`: which exact solver runs |
//!
//! Every value may be a JSON number (read exactly from its decimal text: `0.1` is 1/10) or a
//! string `"p/q"`, `"p"` or a decimal. The keys may come in any order; the text is read in
//! one streaming pass straight into exact values, never as a JSON tree (`super::input`,
//! [`Problem::from_json`], [`Problem::from_reader`]). The output holds `"P"` (all `n` rows as exact strings
//! in lowest terms), `"P_float"`, `"rank"`, `"relevant"`, `"fixed_relevant"` and
//! `"redundant"` (constraint and parameter indices, 0-based), and `"path"`: the solver that
//! ran, `"fraction_free"` (the LDU of thesis ch. 6-9) or `"modular"` (the multi-modular
//! path of [`super::modular`], chosen by `"auto"` when `|E| x |D|` is at least
//! [`MODULAR_MIN_ENTRIES`]). Both give the same output apart from `"path"`: the same
//! `"P"` and `"rank"` (the minimizer is unique) and the same canonical `"redundant"` set
//! (each redundant constraint depends on the relevant ones before it; see
//! [`super::modular`]).

pub use super::input::ProblemError;
use super::input::{key_err, read, Raw, RawR, PATHS};
use super::{ConstraintSystem, EclesError, InitOptions};
use crate::exact::ldu::Simplification;
use crate::exact::matrix::{Rat, ScaledVec, SparseIntMatrix};
use crate::exact::Int;
use num_traits::{Signed, Zero};
use rayon::prelude::*;

pub use super::output::error_json;

/// Smallest `|E| x |D|` (relevant constraints times derived parameters) for which `"auto"`
/// runs the modular path: below it the fraction-free LDU is as fast and needs no primes.
pub const MODULAR_MIN_ENTRIES: usize = 20_000;

/// Which exact solver runs (input key `"path"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SolvePath {
    /// By size (see [`MODULAR_MIN_ENTRIES`]).
    #[default]
    Auto,
    /// Multi-modular with exact verification, falling back to fraction-free when it cannot
    /// certify its answer.
    Modular,
    /// The fraction-free LDU (the reference).
    FractionFree,
}

/// A parsed editing problem.
#[derive(Clone, Debug)]
pub struct Problem {
    /// The constraints `R P = Q`.
    pub system: ConstraintSystem,
    /// Current values of all parameters (`n` rows of `d`).
    pub p: Vec<Vec<Rat>>,
    /// Anchor indices (ascending).
    pub anchors: Vec<usize>,
    /// New anchor values, in the order of `anchors`.
    pub anchor_values: Vec<Vec<Rat>>,
    /// Derived indices, in the input order.
    pub derived: Vec<usize>,
    /// Hints for the derived parameters, in the order of `derived`.
    pub hints: Vec<Vec<Rat>>,
    /// Weights of the derived parameters, in the order of `derived`.
    pub weights: Vec<Rat>,
    /// Whether strong solvability is required.
    pub strong: bool,
    /// Simplification method of the factoring.
    pub method: Simplification,
    /// Which solver runs.
    pub path: SolvePath,
}

/// The result of [`Problem::solve`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Solution {
    /// All parameters after the edit, in lowest terms (both paths reduce their values).
    pub p: Vec<Vec<Rat>>,
    /// Rank of `R_ED`.
    pub rank: usize,
    /// Relevant constraints.
    pub relevant: Vec<usize>,
    /// Fixed relevant parameters.
    pub fixed_relevant: Vec<usize>,
    /// Redundant relevant constraints.
    pub redundant: Vec<usize>,
    /// Whether every constraint (relevant or not) holds after the edit.
    pub all_constraints_hold: bool,
    /// The solver that ran: `"fraction_free"` or `"modular"`.
    pub path: &'static str,
}

/// Largest bit size of a weight's numerator and denominator (weights from about 1e-38 to
/// 1e38 pass; a weight of 1e10000 made a 3.5 KB problem take minutes).
pub const MAX_WEIGHT_BITS: u64 = 128;

impl Problem {
    /// Runs ECLES Initialize and one Update. Errors are the ECLES errors (unsolvable edits
    /// are `NotStronglySolvable` / `NotWeaklySolvable`).
    pub fn solve(&self) -> Result<Solution, EclesError> {
        let modular = match self.path {
            SolvePath::Modular => true,
            SolvePath::FractionFree => false,
            SolvePath::Auto => {
                let (e, _) = self.system.extract_relevant(&self.anchors, &self.derived);
                e.len() * self.derived.len() >= MODULAR_MIN_ENTRIES
            }
        };
        if modular {
            if let Some(s) = self.solve_modular()? {
                return Ok(s);
            }
        }
        self.solve_fraction_free()
    }

    /// The modular path; `Ok(None)` when it could not certify its answer.
    pub fn solve_modular(&self) -> Result<Option<Solution>, EclesError> {
        let Some(e) = self.system.edit_modular(
            &self.p,
            &self.anchors,
            &self.derived,
            &self.anchor_values,
            &self.hints,
            &self.weights,
            self.strong,
        )?
        else {
            return Ok(None);
        };
        let mut p = self.p.clone();
        for (&s, v) in self.anchors.iter().zip(&self.anchor_values) {
            p[s] = v.clone();
        }
        // The final exact check of every constraint runs on the unreduced values (no gcd),
        // beside the reduction to lowest terms (both in parallel).
        let t0 = std::time::Instant::now();
        let ((all_constraints_hold, t_check), cols) = rayon::join(
            || {
                let mut raw_p = p.clone();
                let raw: Vec<Vec<Rat>> =
                    e.derived_values.iter().map(ScaledVec::to_rats_raw).collect();
                let mut cells: Vec<_> = raw.into_iter().map(Vec::into_iter).collect();
                for &s in &self.derived {
                    raw_p[s] =
                        cells.iter_mut().map(|c| c.next().expect("one per derived")).collect();
                }
                (self.system.is_satisfied_fast(&raw_p), t0.elapsed().as_secs_f64())
            },
            || {
                let cols: Vec<Vec<Rat>> =
                    e.derived_values.par_iter().map(ScaledVec::to_rats).collect();
                cols
            },
        );
        if std::env::var_os("TRIMORPH_TRACE").is_some() {
            eprintln!(
                "trace: every constraint checked after {t_check:.3} s; lowest terms beside it, both done in {:.3} s",
                t0.elapsed().as_secs_f64()
            );
        }
        let mut cells: Vec<_> = cols.into_iter().map(Vec::into_iter).collect();
        for &s in &self.derived {
            p[s] = cells.iter_mut().map(|c| c.next().expect("one per derived")).collect();
        }
        Ok(Some(Solution {
            all_constraints_hold,
            p,
            rank: e.rank,
            relevant: e.relevant,
            fixed_relevant: e.fixed_relevant,
            redundant: e.redundant,
            path: "modular",
        }))
    }

    /// The fraction-free path (the reference): ECLES Initialize and one Update.
    pub fn solve_fraction_free(&self) -> Result<Solution, EclesError> {
        let opts = InitOptions { strong: self.strong, method: self.method, ..Default::default() };
        let mut s = self.system.initialize(&self.p, &self.anchors, &self.derived, opts)?;
        s.update(&self.anchor_values, Some(&self.hints), Some(&self.weights))?;
        let mut p = self.p.clone();
        s.write_into(&mut p);
        let mut redundant = s.redundant();
        if !redundant.is_empty() {
            // The canonical set (the same as the modular path's); the LDU's own set is as
            // valid and is kept if no prime certifies the canonical one.
            if let Some(c) = self.system.canonical_redundant(s.relevant(), &self.derived) {
                debug_assert_eq!(c.len(), redundant.len());
                redundant = c;
            }
        }
        Ok(Solution {
            all_constraints_hold: self.system.is_satisfied(&p),
            p,
            rank: s.rank(),
            relevant: s.relevant().to_vec(),
            fixed_relevant: s.fixed_relevant().to_vec(),
            redundant,
            path: "fraction_free",
        })
    }
}

impl Problem {
    /// The problem from every key as read ([`super::input`]), after the checks that need
    /// several keys (sizes against `n`, `d` and `m`, indices, the derived set), in the order
    /// `P`, `R`, `Q`, `anchors`, `derived`, `hints`, `weights`.
    pub(super) fn from_raw(raw: Raw) -> Result<Problem, ProblemError> {
        let p = raw.p.ok_or_else(|| key_err("P", "missing (n rows of current values)"))?;
        let n = p.len();
        let d = p.first().map_or(1, Vec::len);
        if d == 0 {
            return Err(key_err("P[0]", "rows must have at least one value"));
        }
        if let Some((i, _)) = p.iter().enumerate().find(|(_, r)| r.len() != d) {
            return Err(key_err(format!("P[{i}]"), format!("expected {d} values like P[0]")));
        }
        let sparse = match raw.r.ok_or_else(|| key_err("R", "missing (m rows of n integers)"))? {
            RawR::Dense(rows) => {
                let mut out = Vec::with_capacity(rows.len());
                for (i, (len, nz)) in rows.into_iter().enumerate() {
                    if len != n {
                        return Err(key_err(
                            format!("R[{i}]"),
                            format!("expected {n} values, found {len}"),
                        ));
                    }
                    out.push(nz);
                }
                out
            }
            RawR::Sparse(rows) => {
                let mut out = Vec::with_capacity(rows.len());
                for (i, mut r) in rows.into_iter().enumerate() {
                    if let Some(k) = r.iter().position(|e| e.0 >= n) {
                        return Err(key_err(
                            format!("R.rows[{i}][{k}][0]"),
                            format!("column {} is out of range (there are {n} parameters)", r[k].0),
                        ));
                    }
                    r.sort_by_key(|e| e.0);
                    if let Some(w) = r.windows(2).find(|w| w[0].0 == w[1].0) {
                        return Err(key_err(
                            format!("R.rows[{i}]"),
                            format!("column {} is given twice", w[0].0),
                        ));
                    }
                    r.retain(|e| !e.1.is_zero());
                    out.push(r);
                }
                out
            }
        };
        let m = sparse.len();
        let r = SparseIntMatrix::from_rows(n, sparse).expect("columns checked");
        let q = match raw.q.flatten() {
            None => vec![vec![Rat::zero(); d]; m],
            Some(q) => {
                if let Some((i, r)) = q.iter().enumerate().find(|(_, r)| r.len() != d) {
                    return Err(key_err(
                        format!("Q[{i}]"),
                        format!("expected {d} values, found {}", r.len()),
                    ));
                }
                if q.len() != m {
                    return Err(key_err(
                        "Q",
                        format!("expected {m} rows (one per row of R), found {}", q.len()),
                    ));
                }
                q
            }
        };
        let system = ConstraintSystem::with_dim(r, q, d)?;

        let anchors_raw = raw
            .anchors
            .ok_or_else(|| key_err("anchors", "missing (object: index -> new value)"))?;
        let mut anchors: Vec<(usize, Vec<Rat>)> = Vec::with_capacity(anchors_raw.len());
        for (k, v) in anchors_raw {
            let i = index_key(&k, "anchors", n)?;
            if v.len() != d {
                return Err(key_err(
                    format!("anchors.\"{k}\""),
                    format!("expected {d} values, found {}", v.len()),
                ));
            }
            anchors.push((i, v));
        }
        anchors.sort_by_key(|e| e.0);
        if let Some(w) = anchors.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(key_err("anchors", format!("parameter {} is given twice", w[0].0)));
        }
        let derived =
            raw.derived.ok_or_else(|| key_err("derived", "missing (array of indices)"))?;
        if let Some((k, &i)) = derived.iter().enumerate().find(|(_, &i)| i >= n) {
            return Err(key_err(
                format!("derived[{k}]"),
                format!("parameter {i} is out of range (there are {n})"),
            ));
        }
        // Position of each derived parameter (the first, if one is listed twice: the edit
        // check refuses that below).
        let mut pos = vec![usize::MAX; n];
        for (k, &s) in derived.iter().enumerate().rev() {
            pos[s] = k;
        }
        let pos_of = |i: usize, path: &str| match pos[i] {
            usize::MAX => Err(key_err(path, format!("parameter {i} is not derived"))),
            k => Ok(k),
        };
        let mut hints: Vec<Vec<Rat>> = derived.iter().map(|&s| p[s].clone()).collect();
        for (k, v) in raw.hints.unwrap_or_default() {
            let path = format!("hints.\"{k}\"");
            let i = index_key(&k, "hints", n)?;
            let at = pos_of(i, &path)?;
            if v.len() != d {
                return Err(key_err(path, format!("expected {d} values, found {}", v.len())));
            }
            hints[at] = v;
        }
        let mut weights = vec![Rat::from_integer(Int::from(1)); derived.len()];
        for (k, val) in raw.weights.unwrap_or_default() {
            let path = format!("weights.\"{k}\"");
            let i = index_key(&k, "weights", n)?;
            if !val.is_positive() {
                return Err(key_err(path, "weights must be positive"));
            }
            // Weights only say how much each derived value matters relative to the others;
            // huge exact numbers (1e10000) only make the exact solve crawl.
            if val.numer().bits() > MAX_WEIGHT_BITS || val.denom().bits() > MAX_WEIGHT_BITS {
                return Err(key_err(
                path,
                format!("weights must have a numerator and a denominator below 2^{MAX_WEIGHT_BITS} (about 1e38); rescale the weights (only their ratios matter)"),
            ));
            }
            weights[pos_of(i, &path)?] = val;
        }
        let method = match raw.method {
            None => Simplification::Turner,
            Some(s) => s.parse().map_err(|e: String| key_err("method", e))?,
        };
        let path = match raw.path.as_deref() {
            None | Some("auto") => SolvePath::Auto,
            Some("modular") => SolvePath::Modular,
            Some("fraction_free") => SolvePath::FractionFree,
            Some(s) => {
                return Err(key_err(
                    "path",
                    format!(
                        "expected {PATHS}, found {}",
                        serde_json::to_string(s).unwrap_or_default()
                    ),
                ))
            }
        };
        let (anchors, anchor_values) = anchors.into_iter().unzip();
        Ok(Problem {
            system,
            p,
            anchors,
            anchor_values,
            derived,
            hints,
            weights,
            strong: raw.strong.unwrap_or(false),
            method,
            path,
        })
    }
}

/// A key of an index object: a parameter index below `n`.
fn index_key(k: &str, name: &str, n: usize) -> Result<usize, ProblemError> {
    let i: usize = k.trim().parse().map_err(|_| {
        key_err(format!("{name}.\"{k}\""), "keys must be parameter indices (0, 1, 2, ...)")
    })?;
    if i >= n {
        return Err(key_err(
            format!("{name}.\"{k}\""),
            format!("parameter {i} is out of range (there are {n})"),
        ));
    }
    Ok(i)
}

impl Problem {
    /// Parses a problem from JSON text, in one streaming pass (module docs). Text that is not
    /// valid JSON (a syntax error, a key given twice) is a [`ProblemError::Json`] even when
    /// the pass met a wrong value first: on an error, the text is scanned once more for
    /// that.
    pub fn from_json(text: &str) -> Result<Problem, ProblemError> {
        read(serde_json::Deserializer::from_str(text)).and_then(Problem::from_raw).map_err(|e| {
            match e {
                ProblemError::Json(_) => e,
                _ => match crate::json::check_syntax(text) {
                    Err(j) => ProblemError::Json(j.to_string()),
                    Ok(()) => e,
                },
            }
        })
    }

    /// Parses a problem from a reader (a file, a pipe; buffered here), in one streaming pass
    /// without holding the text: the same problem as [`Problem::from_json`] on the text
    /// read. Errors are those met first in reading order (a wrong value before a later
    /// syntax error is reported as the wrong value).
    pub fn from_reader<R: std::io::Read>(r: R) -> Result<Problem, ProblemError> {
        let r = std::io::BufReader::with_capacity(1 << 16, r);
        read(serde_json::Deserializer::from_reader(r)).and_then(Problem::from_raw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    const PUMP: &str = r#"{"R": [[1,1,-1,0],[0,0,-1,1]], "Q": [[0],[5]], "P": [[1],[2],[3],[8]],
        "anchors": {"0": [4]}, "derived": [1, 2, 3]}"#;

    #[test]
    fn pump_round_trip() {
        let pr = Problem::from_json(PUMP).unwrap();
        let s = pr.solve().unwrap();
        assert_eq!(s.to_json()["P"], json!([["4"], ["0"], ["4"], ["9"]]));
        assert_eq!(s.to_json()["P_float"], json!([[4.0], [0.0], [4.0], [9.0]]));
        assert!(s.all_constraints_hold);
        assert_eq!(s.rank, 2);
    }

    /// The fast writer gives the same bytes as formatting the JSON value: fractions,
    /// negative and huge values, shared and distinct denominators, empty lists.
    #[test]
    fn json_text_equals_the_formatted_value() {
        let huge = format!("-{}/7", "9".repeat(60));
        let cases = [
            PUMP.to_string(),
            r#"{"R": [[1, -1, 0], [0, 1, -1], [1, 0, -1]], "P": [["1/3", 2], [0.1, "-5/6"], [7, 1e3]],
                "anchors": {"0": ["2/3", "1/9"]}, "derived": [1, 2], "weights": {"2": 3}}"#
                .to_string(),
            format!(r#"{{"R": [[2, 3]], "P": [["{huge}"], [0]], "anchors": {{"0": ["1/11"]}}, "derived": [1]}}"#),
        ];
        for text in cases {
            let s = Problem::from_json(&text).unwrap().solve().unwrap();
            assert_eq!(s.to_json_text(), crate::io::json_rows(&s.to_json()), "{text}");
        }
        let empty = Solution {
            p: Vec::new(),
            rank: 0,
            relevant: Vec::new(),
            fixed_relevant: Vec::new(),
            redundant: Vec::new(),
            all_constraints_hold: true,
            path: "modular",
        };
        assert_eq!(empty.to_json_text(), crate::io::json_rows(&empty.to_json()));
    }

    #[test]
    fn exact_decimals_and_fractions() {
        let t =
            r#"{"R": [[1, -1]], "P": [["1/3"], [0.1]], "anchors": {"0": ["2/3"]}, "derived": [1]}"#;
        let s = Problem::from_json(t).unwrap().solve().unwrap();
        assert_eq!(s.to_json()["P"], json!([["2/3"], ["2/3"]]));
    }

    #[test]
    fn weights_with_huge_exact_values_are_refused_before_solving() {
        // Found by the adversarial pass: weights of 1e+-10000 made `solve` run for minutes.
        let t = |w: &str| {
            format!(
                r#"{{"R": [[1, 1, 1]], "P": [[1], [2], [3]], "anchors": {{"0": [4]}}, "derived": [1, 2], "weights": {{"1": {w}, "2": 1}}}}"#
            )
        };
        for w in ["1e10000", "1e-10000", "\"1/1000000000000000000000000000000000000000000000\""] {
            let e = Problem::from_json(&t(w)).unwrap_err().to_string();
            assert!(e.contains("weights.\"1\"") && e.contains("2^128"), "{w}: {e}");
        }
        let ok = Problem::from_json(&t("1e30")).unwrap().solve().unwrap();
        assert_eq!(ok.to_json()["P"][0], json!(["4"]));
    }

    #[test]
    fn a_key_given_twice_is_refused() {
        let t =
            r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1], "0": [2]}, "derived": [1]}"#;
        let e = Problem::from_json(t).unwrap_err().to_string();
        assert!(e.contains("duplicate key \"0\""), "{e}");
    }

    #[test]
    fn errors_name_the_element() {
        let cases = [
            (
                r#"{"R": [[1, 2]], "P": [[1], [true]], "anchors": {"0": [1]}, "derived": []}"#,
                "P[1][0]",
            ),
            (r#"{"R": [[1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": []}"#, "R[0]"),
            (
                r#"{"R": [[1, 0.5]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": []}"#,
                "R[0][1]",
            ),
            (
                r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"x": [1]}, "derived": []}"#,
                "anchors.\"x\"",
            ),
            (
                r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1], "weights": {"1": -2}}"#,
                "weights.\"1\"",
            ),
            (
                r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1], "hints": {"0": [1]}}"#,
                "hints.\"0\"",
            ),
            (
                r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1], "method": "lu"}"#,
                "method",
            ),
            (r#"{"R": [[1, 1]], "P": [[1], [2]], "derived": [1]}"#, "anchors"),
            (
                r#"{"R": [[1, 1]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [5]}"#,
                "derived[0]",
            ),
            (
                r#"{"R": [[1, 1]], "Q": [[1], [2]], "P": [[1], [2]], "anchors": {"0": [1]}, "derived": [1]}"#,
                "Q",
            ),
        ];
        for (text, path) in cases {
            match Problem::from_json(text) {
                Err(ProblemError::Key { path: p, .. }) => assert_eq!(p, path, "{text}"),
                other => panic!("{text}: {other:?}"),
            }
        }
        assert!(matches!(Problem::from_json("{"), Err(ProblemError::Json(_))));
        assert!(matches!(Problem::from_json("[]"), Err(ProblemError::Key { .. })));
    }
}

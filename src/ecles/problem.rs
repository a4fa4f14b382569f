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
//! string `"p/q"`, `"p"` or a decimal. The output holds `"P"` (all `n` rows as exact strings
//! in lowest terms), `"P_float"`, `"rank"`, `"relevant"`, `"fixed_relevant"` and
//! `"redundant"` (constraint and parameter indices, 0-based), and `"path"`: the solver that
//! ran, `"fraction_free"` (the LDU of thesis ch. 6-9) or `"modular"` (the multi-modular
//! path of [`super::modular`], chosen by `"auto"` when `|E| x |D|` is at least
//! [`MODULAR_MIN_ENTRIES`]). Both give the same output apart from `"path"`: the same
//! `"P"` and `"rank"` (the minimizer is unique) and the same canonical `"redundant"` set
//! (each redundant constraint depends on the relevant ones before it; see
//! [`super::modular`]).

use super::{ConstraintSystem, EclesError, InitOptions};
use crate::exact::ldu::Simplification;
use crate::exact::matrix::{parse_rat, Rat, ScaledVec, SparseIntMatrix};
use crate::exact::Int;
use num_traits::Zero;
use rayon::prelude::*;
use serde_json::{Map, Value};

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

/// Errors reading a problem.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProblemError {
    /// Not valid JSON.
    #[error("not valid JSON: {0}")]
    Json(String),
    /// A key is missing or holds a value of the wrong kind.
    #[error("{path}: {message}")]
    Key {
        /// Where, e.g. `P[3][1]` or `anchors."7"`.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// The edit itself is malformed (indices, sizes, weights).
    #[error("{0}")]
    Edit(#[from] EclesError),
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

fn key_err(path: impl Into<String>, message: impl Into<String>) -> ProblemError {
    ProblemError::Key { path: path.into(), message: message.into() }
}

fn describe(v: &Value) -> String {
    let s = v.to_string();
    if s.len() > 40 {
        format!("{}...", &s[..40])
    } else {
        s
    }
}

fn num(v: &Value, path: &str) -> Result<Rat, ProblemError> {
    let text = match v {
        Value::Number(n) => n.to_string(),
        Value::String(s) => s.clone(),
        _ => {
            return Err(key_err(
                path,
                format!("expected a number or a \"p/q\" string, found {}", describe(v)),
            ))
        }
    };
    parse_rat(&text).map_err(|e| key_err(path, e.to_string()))
}

fn row(v: &Value, path: &str, len: Option<usize>) -> Result<Vec<Rat>, ProblemError> {
    let arr = v
        .as_array()
        .ok_or_else(|| key_err(path, format!("expected an array, found {}", describe(v))))?;
    if let Some(l) = len {
        if arr.len() != l {
            return Err(key_err(path, format!("expected {l} values, found {}", arr.len())));
        }
    }
    arr.iter().enumerate().map(|(j, x)| num(x, &format!("{path}[{j}]"))).collect()
}

fn rows(v: &Value, path: &str, len: Option<usize>) -> Result<Vec<Vec<Rat>>, ProblemError> {
    let arr = v.as_array().ok_or_else(|| {
        key_err(path, format!("expected an array of rows, found {}", describe(v)))
    })?;
    arr.iter().enumerate().map(|(i, r)| row(r, &format!("{path}[{i}]"), len)).collect()
}

fn index_key(k: &str, path: &str, n: usize) -> Result<usize, ProblemError> {
    let i: usize = k.trim().parse().map_err(|_| {
        key_err(format!("{path}.\"{k}\""), "keys must be parameter indices (0, 1, 2, ...)")
    })?;
    if i >= n {
        return Err(key_err(
            format!("{path}.\"{k}\""),
            format!("parameter {i} is out of range (there are {n})"),
        ));
    }
    Ok(i)
}

fn object<'a>(
    doc: &'a Map<String, Value>,
    key: &str,
) -> Result<Option<&'a Map<String, Value>>, ProblemError> {
    match doc.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Object(o)) => Ok(Some(o)),
        Some(v) => Err(key_err(
            key,
            format!("expected an object {{\"index\": ...}}, found {}", describe(v)),
        )),
    }
}

/// `R` as `m` dense rows of `n` integers.
fn dense_rows(r_val: &Value, n: usize) -> Result<Vec<Vec<(usize, Int)>>, ProblemError> {
    let r_rows = r_val
        .as_array()
        .ok_or_else(|| key_err("R", "expected an array of rows or {\"rows\": ...}"))?;
    let mut sparse = Vec::with_capacity(r_rows.len());
    for (i, rv) in r_rows.iter().enumerate() {
        let vals = row(rv, &format!("R[{i}]"), Some(n))?;
        let mut out = Vec::new();
        for (j, v) in vals.into_iter().enumerate() {
            if !v.is_integer() {
                return Err(key_err(format!("R[{i}][{j}]"), "coefficients must be integers"));
            }
            if !v.is_zero() {
                out.push((j, v.to_integer()));
            }
        }
        sparse.push(out);
    }
    Ok(sparse)
}

/// `R` in the sparse form `{"rows": [[[col, val], ...], ...]}`.
fn sparse_rows(o: &Map<String, Value>, n: usize) -> Result<Vec<Vec<(usize, Int)>>, ProblemError> {
    let rows_v = o.get("rows").ok_or_else(|| {
        key_err("R", "the sparse form needs \"rows\": [[[column, value], ...], ...]")
    })?;
    let rows_a = rows_v.as_array().ok_or_else(|| {
        key_err("R.rows", format!("expected an array, found {}", describe(rows_v)))
    })?;
    let mut out = Vec::with_capacity(rows_a.len());
    for (i, rv) in rows_a.iter().enumerate() {
        let path = format!("R.rows[{i}]");
        let pairs = rv.as_array().ok_or_else(|| {
            key_err(
                &path,
                format!("expected an array of [column, value] pairs, found {}", describe(rv)),
            )
        })?;
        let mut r: Vec<(usize, Int)> = Vec::with_capacity(pairs.len());
        for (k, pv) in pairs.iter().enumerate() {
            let pp = format!("{path}[{k}]");
            let pair = pv.as_array().filter(|a| a.len() == 2).ok_or_else(|| {
                key_err(&pp, format!("expected [column, value], found {}", describe(pv)))
            })?;
            let c = pair[0].as_u64().ok_or_else(|| {
                key_err(
                    format!("{pp}[0]"),
                    format!("expected a column index, found {}", describe(&pair[0])),
                )
            })? as usize;
            if c >= n {
                return Err(key_err(
                    format!("{pp}[0]"),
                    format!("column {c} is out of range (there are {n} parameters)"),
                ));
            }
            let v = num(&pair[1], &format!("{pp}[1]"))?;
            if !v.is_integer() {
                return Err(key_err(format!("{pp}[1]"), "coefficients must be integers"));
            }
            r.push((c, v.to_integer()));
        }
        r.sort_by_key(|e| e.0);
        if let Some(w) = r.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(key_err(&path, format!("column {} is given twice", w[0].0)));
        }
        r.retain(|e| !e.1.is_zero());
        out.push(r);
    }
    Ok(out)
}

/// Largest bit size of a weight's numerator and denominator (weights from about 1e-38 to
/// 1e38 pass; a weight of 1e10000 made a 3.5 KB problem take minutes).
pub const MAX_WEIGHT_BITS: u64 = 128;

impl Problem {
    /// Parses a problem from JSON text.
    pub fn from_json(text: &str) -> Result<Problem, ProblemError> {
        let doc: Value = crate::json::parse(text).map_err(|e| ProblemError::Json(e.to_string()))?;
        let doc =
            doc.as_object().ok_or_else(|| key_err("(top level)", "expected a JSON object"))?;
        let p = rows(
            doc.get("P").ok_or_else(|| key_err("P", "missing (n rows of current values)"))?,
            "P",
            None,
        )?;
        let n = p.len();
        let d = p.first().map_or(1, Vec::len);
        if d == 0 {
            return Err(key_err("P[0]", "rows must have at least one value"));
        }
        if let Some((i, _)) = p.iter().enumerate().find(|(_, r)| r.len() != d) {
            return Err(key_err(format!("P[{i}]"), format!("expected {d} values like P[0]")));
        }
        let r_val = doc.get("R").ok_or_else(|| key_err("R", "missing (m rows of n integers)"))?;
        let sparse = match r_val {
            Value::Object(o) => sparse_rows(o, n)?,
            _ => dense_rows(r_val, n)?,
        };
        let m = sparse.len();
        let r = SparseIntMatrix::from_rows(n, sparse).expect("columns checked");
        let q = match doc.get("Q") {
            None | Some(Value::Null) => vec![vec![Rat::zero(); d]; m],
            Some(v) => {
                let q = rows(v, "Q", Some(d))?;
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

        let anchors_obj = object(doc, "anchors")?
            .ok_or_else(|| key_err("anchors", "missing (object: index -> new value)"))?;
        let mut anchors: Vec<(usize, Vec<Rat>)> = Vec::new();
        for (k, v) in anchors_obj {
            let i = index_key(k, "anchors", n)?;
            anchors.push((i, row(v, &format!("anchors.\"{k}\""), Some(d))?));
        }
        anchors.sort_by_key(|e| e.0);
        if let Some(w) = anchors.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(key_err("anchors", format!("parameter {} is given twice", w[0].0)));
        }
        let derived_val =
            doc.get("derived").ok_or_else(|| key_err("derived", "missing (array of indices)"))?;
        let derived_arr = derived_val
            .as_array()
            .ok_or_else(|| key_err("derived", "expected an array of indices"))?;
        let mut derived = Vec::with_capacity(derived_arr.len());
        for (k, v) in derived_arr.iter().enumerate() {
            let i = v.as_u64().ok_or_else(|| {
                key_err(
                    format!("derived[{k}]"),
                    format!("expected a parameter index, found {}", describe(v)),
                )
            })? as usize;
            if i >= n {
                return Err(key_err(
                    format!("derived[{k}]"),
                    format!("parameter {i} is out of range (there are {n})"),
                ));
            }
            derived.push(i);
        }
        let pos_of = |i: usize, path: &str| {
            derived
                .iter()
                .position(|&s| s == i)
                .ok_or_else(|| key_err(path, format!("parameter {i} is not derived")))
        };
        let mut hints: Vec<Vec<Rat>> = derived.iter().map(|&s| p[s].clone()).collect();
        if let Some(h) = object(doc, "hints")? {
            for (k, v) in h {
                let path = format!("hints.\"{k}\"");
                let i = index_key(k, "hints", n)?;
                hints[pos_of(i, &path)?] = row(v, &path, Some(d))?;
            }
        }
        let mut weights = vec![Rat::from_integer(Int::from(1)); derived.len()];
        if let Some(w) = object(doc, "weights")? {
            for (k, v) in w {
                let path = format!("weights.\"{k}\"");
                let i = index_key(k, "weights", n)?;
                let val = num(v, &path)?;
                if val <= Rat::zero() {
                    return Err(key_err(path, "weights must be positive"));
                }
                // Weights only say how much each derived value matters relative to the
                // others; huge exact numbers (1e10000) only make the exact solve crawl.
                if val.numer().bits() > MAX_WEIGHT_BITS || val.denom().bits() > MAX_WEIGHT_BITS {
                    return Err(key_err(
                        path,
                        format!("weights must have a numerator and a denominator below 2^{MAX_WEIGHT_BITS} (about 1e38); rescale the weights (only their ratios matter)"),
                    ));
                }
                weights[pos_of(i, &path)?] = val;
            }
        }
        let strong = match doc.get("strong") {
            None | Some(Value::Null) => false,
            Some(Value::Bool(b)) => *b,
            Some(v) => {
                return Err(key_err(
                    "strong",
                    format!("expected true or false, found {}", describe(v)),
                ))
            }
        };
        let method = match doc.get("method") {
            None | Some(Value::Null) => Simplification::Turner,
            Some(Value::String(s)) => s.parse().map_err(|e: String| key_err("method", e))?,
            Some(v) => {
                return Err(key_err(
                    "method",
                    format!("expected \"none\", \"gcd\" or \"turner\", found {}", describe(v)),
                ))
            }
        };
        let path = match doc.get("path") {
            None | Some(Value::Null) => SolvePath::Auto,
            Some(Value::String(s)) if s == "auto" => SolvePath::Auto,
            Some(Value::String(s)) if s == "modular" => SolvePath::Modular,
            Some(Value::String(s)) if s == "fraction_free" => SolvePath::FractionFree,
            Some(v) => {
                return Err(key_err(
                    "path",
                    format!(
                        "expected \"auto\", \"modular\" or \"fraction_free\", found {}",
                        describe(v)
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
            strong,
            method,
            path,
        })
    }

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

//! The output of `trimorph solve` ([`Solution`]): the JSON object, and its text streamed
//! in blocks of rows formatted in parallel.

use super::problem::Solution;
use crate::exact::matrix::{rat_to_f64, rat_to_string, Rat};
use crate::exact::Int;
use num_traits::One;
use serde_json::{json, Value};

impl serde::Serialize for Solution {
    /// The output JSON object of `trimorph solve` ([`Solution::to_json`]'s).
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.to_json().serialize(s)
    }
}

impl Solution {
    /// The output JSON object of `trimorph solve`.
    pub(crate) fn to_json(&self) -> Value {
        json!({
            "P": self.p.iter().map(|r| r.iter().map(rat_to_string).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "P_float": self.p.iter().map(|r| r.iter().map(rat_to_f64).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "rank": self.rank,
            "relevant": self.relevant,
            "fixed_relevant": self.fixed_relevant,
            "redundant": self.redundant,
            "all_constraints_hold": self.all_constraints_hold,
            "path": self.path,
        })
    }
}

impl Solution {
    /// The text `trimorph solve` writes: the same bytes as
    /// [`crate::io::json_rows`]`(&self.to_json())` ([`Solution::write_json`] into a string).
    pub fn to_json_text(&self) -> String {
        let mut out = Vec::new();
        self.write_json(&mut out).expect("writing to memory");
        String::from_utf8(out).expect("JSON text is UTF-8")
    }

    /// Writes [`Solution::to_json_text`]'s bytes to `w`, formatting blocks of rows in
    /// parallel and writing each block as soon as it and the ones before it are done (while
    /// the next block is formatted), so the text is never held whole. The values of `p` are
    /// in lowest terms on both paths, so no gcd is taken here; the few distinct
    /// denominators of an exact solve are converted to decimal once.
    pub fn write_json<W: std::io::Write + Send>(&self, w: &mut W) -> std::io::Result<()> {
        use rayon::prelude::*;
        debug_assert!(self.p.iter().flatten().all(|r| r.denom().is_one() || {
            let g = num_integer::Integer::gcd(r.numer(), r.denom());
            g.is_one()
        }));
        let mut dens: Vec<&Int> =
            self.p.iter().flatten().map(|r| r.denom()).filter(|d| !d.is_one()).collect();
        dens.sort_unstable();
        dens.dedup();
        let den_text: std::collections::HashMap<&Int, String> =
            dens.par_iter().map(|&d| (d, d.to_string())).collect();
        let exact_row = |out: &mut String, r: &[Rat]| {
            out.push('[');
            for (k, v) in r.iter().enumerate() {
                if k > 0 {
                    out.push(',');
                }
                out.push('"');
                v.numer().push_decimal(out);
                if let Some(d) = den_text.get(v.denom()) {
                    out.push('/');
                    out.push_str(d);
                }
                out.push('"');
            }
            out.push(']');
        };
        let float_row = |out: &mut String, r: &[Rat]| {
            out.push_str(&Value::from(r.iter().map(rat_to_f64).collect::<Vec<_>>()).to_string());
        };
        w.write_all(b"{\n  \"P\": ")?;
        write_rows(w, &self.p, &exact_row)?;
        w.write_all(b",\n  \"P_float\": ")?;
        write_rows(w, &self.p, &float_row)?;
        let list = |v: &[usize]| Value::from(v.to_vec()).to_string();
        write!(
            w,
            ",\n  \"all_constraints_hold\": {},\n  \"fixed_relevant\": {},\n  \"path\": {},\n  \"rank\": {},\n  \"redundant\": {},\n  \"relevant\": {}\n}}\n",
            self.all_constraints_hold,
            list(&self.fixed_relevant),
            Value::from(self.path),
            self.rank,
            list(&self.redundant),
            list(&self.relevant),
        )
    }
}

/// Rows of [`Solution::write_json`] per block.
const JSON_BLOCK: usize = 64;

/// Writes `rows` as the JSON array layout of [`crate::io::json_rows`] (`[]`, or one row per
/// line indented by four spaces), each row's text from `row`. Blocks of rows are formatted
/// in parallel; block `k` is written while block `k + 1` is formatted.
fn write_rows<W, F>(w: &mut W, rows: &[Vec<Rat>], row: &F) -> std::io::Result<()>
where
    W: std::io::Write + Send,
    F: Fn(&mut String, &[Rat]) + Sync,
{
    use rayon::prelude::*;
    if rows.is_empty() {
        return w.write_all(b"[]");
    }
    let n = rows.len();
    let block = |b: usize| -> String {
        let lo = b * JSON_BLOCK;
        let hi = (lo + JSON_BLOCK).min(n);
        let parts: Vec<String> = rows[lo..hi]
            .par_iter()
            .enumerate()
            .map(|(k, r)| {
                let mut s = String::from("    ");
                row(&mut s, r);
                s.push_str(if lo + k + 1 < n { ",\n" } else { "\n" });
                s
            })
            .collect();
        parts.concat()
    };
    w.write_all(b"[\n")?;
    let blocks = n.div_ceil(JSON_BLOCK);
    let mut ready = block(0);
    for b in 1..=blocks {
        let (written, next) = rayon::join(
            || w.write_all(ready.as_bytes()),
            || if b < blocks { block(b) } else { String::new() },
        );
        written?;
        ready = next;
    }
    w.write_all(b"  ]")
}

/// The JSON error object for an ECLES error: `{"error": kind, "condition": ..., "message": ...}`
/// (what `trimorph solve` prints, with the problem file's `"file"` key added).
pub fn error_json(e: &super::EclesError) -> Value {
    use super::EclesError;
    match e {
        EclesError::NotWeaklySolvable { constraint, column } => json!({
            "error": "not_solvable", "condition": "weak_solvability",
            "constraint": constraint, "coordinate": column, "message": e.to_string(),
        }),
        EclesError::NotStronglySolvable { constraint, cause } => json!({
            "error": "not_solvable", "condition": "strong_solvability",
            "constraint": constraint, "cause": cause, "message": e.to_string(),
        }),
        other => json!({ "error": "invalid_edit", "message": other.to_string() }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Streaming in blocks (several blocks, one row past a block boundary) gives the
    /// formatted value's bytes, and a writer that fails part way reports its error.
    #[test]
    fn streamed_blocks_equal_the_formatted_value_and_write_errors_surface() {
        let big: Int = "123456789012345678901234567890123456789".parse().unwrap();
        let p: Vec<Vec<Rat>> = (0..(2 * JSON_BLOCK + 1) as i64)
            .map(|i| {
                vec![
                    Rat::new(&big * &Int::from(i - 60), Int::from(3 + i % 4)),
                    Rat::from_integer(Int::from(-i)),
                ]
            })
            .collect();
        let s = Solution {
            p,
            rank: 3,
            relevant: vec![0, 2],
            fixed_relevant: vec![1],
            redundant: Vec::new(),
            all_constraints_hold: true,
            path: "modular",
        };
        let text = s.to_json_text();
        assert_eq!(text, crate::io::json_rows(&s.to_json()));
        struct Fails(usize);
        impl std::io::Write for Fails {
            fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
                if self.0 < buf.len() {
                    return Err(std::io::Error::other("disk full"));
                }
                self.0 -= buf.len();
                Ok(buf.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let err = s.write_json(&mut Fails(text.len() / 2)).unwrap_err();
        assert_eq!(err.to_string(), "disk full");
    }
}

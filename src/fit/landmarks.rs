//! Landmark pairs: a source point in the reference domain and a target point in the image,
//! and their text formats.
//!
//! # Coordinates
//!
//! All points are pixel coordinates: pixel `(i, j)` (column `i`, row `j`) is centred at
//! `(x, y) = (i, j)`, `x` grows to the right and `y` grows downwards. The formats below store
//! these numbers unchanged (Fiji / BigWarp use the same convention for 2D images with unit
//! calibration: ImgLib2 puts pixel centres at integer coordinates).
//!
//! # Formats
//!
//! * [`LandmarkFormat::Csv`]: `name,src_x,src_y,dst_x,dst_y[,weight]`, one landmark a line,
//!   with an optional header line. The header is recognised when, on the first non-empty
//!   line, no field among columns 2..5 is a number (a first line with a typo in one number
//!   is data, and its error is reported). An empty name means no name; the
//!   weight defaults to 1. A field may be double-quoted (`""` inside is a quote). Values must
//!   be finite and weights `> 0`; errors give the 1-based line number. The writer emits the
//!   header `name,src_x,src_y,dst_x,dst_y,weight` and every number with Rust's `{}`
//!   formatting of `f64`, the shortest text that reads back to the same value.
//! * [`LandmarkFormat::BigWarp`]: the landmark table of Fiji's BigWarp: no header, every
//!   field quoted, `"Pt-0","true","x_moving","y_moving","x_fixed","y_fixed"` (2D). The
//!   second field is the active flag; inactive rows are skipped on import, and so are rows
//!   whose fixed or moving point is still unset (BigWarp writes `Infinity` there). By
//!   default the *moving* point becomes `src` and the *fixed* point `dst` (the deformation
//!   sends the moving image's landmarks onto the fixed image's); `swap = true` reverses
//!   this on import and export. Names come from the first field (`Pt-<index>` is written
//!   for unnamed landmarks); weights are not stored (1 on import). BigWarp's 3D table
//!   (its default export), `"Pt-0","true","x_moving","y_moving","z_moving","x_fixed",
//!   "y_fixed","z_fixed"`, is read when z is constant (every placed active row has the same
//!   moving z and the same fixed z): z is dropped and reported as a [`ConstantZ`] note
//!   ([`parse_bigwarp_with_notes`]). A table whose z varies is refused, naming the first line
//!   that differs: a 2D deformation cannot honour varying z. All rows of a table have the
//!   same number of fields; tables are written in the 2D form.
//! * [`LandmarkFormat::Json`]:
//!   `{"landmarks":[{"name":"a","src":[x,y],"dst":[x,y],"weight":1.0}, ...]}`, name and
//!   weight optional.
//!
//! Landmarks may also come as two point files, the sources in one and the targets in the
//! other, point `i` of each making landmark `i`: iBUG / menpo `.pts` (1-based), ITK / elastix
//! point sets and CSV `x,y` ([`point_files`], which converts each to the coordinates above).
//!
//! Everything here works on strings; reading and writing files is in `crate::io::landmarks`.

use crate::rng::SplitMix64;

mod bigwarp;
pub mod point_files;
pub use bigwarp::{
    parse_bigwarp, parse_bigwarp_flagged, parse_bigwarp_noted, parse_bigwarp_with_notes,
    to_bigwarp, to_bigwarp_flagged, ConstantZ,
};
pub use point_files::{parse_points, PointFormat};
use serde::{Deserialize, Serialize};

/// One matched pair: `src` in the reference domain (mesh coordinates), `dst` where the
/// deformation should send it (image pixels), with a weight and an optional name.
#[derive(Clone, Debug, PartialEq)]
pub struct Landmark {
    /// Name (unique names are kept through every format).
    pub name: Option<String>,
    /// Source point (reference domain).
    pub src: [f64; 2],
    /// Target point (image).
    pub dst: [f64; 2],
    /// Weight (finite, > 0; default 1).
    pub weight: f64,
}

/// Names of the coordinate fields, in landmark order.
pub const COORDS: [&str; 4] = ["src_x", "src_y", "dst_x", "dst_y"];

/// A landmark coordinate whose decimal text an `f64` cannot hold: the fit uses `used` (the
/// shortest decimal of the `f64` read from `text`), which differs from the text.
#[derive(Clone, Debug, PartialEq)]
pub struct Approximation {
    /// 0-based landmark index (in the parsed list).
    pub index: usize,
    /// The landmark's name.
    pub name: Option<String>,
    /// `src_x`, `src_y`, `dst_x` or `dst_y` (after BigWarp's moving/fixed mapping).
    pub field: &'static str,
    /// The text in the file.
    pub text: String,
    /// The value used, as the exact decimal `{}` writes for the `f64`.
    pub used: String,
    /// `|text - used|`, computed exactly then rounded; `None` when the text's exponent is
    /// beyond what [`crate::exact::parse_rat`] reads exactly.
    pub difference: Option<f64>,
}

impl std::fmt::Display for Approximation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = self.name.as_deref().unwrap_or("-");
        write!(
            f,
            "landmark {} ({name}): {} {} is approximated by {}",
            self.index, self.field, self.text, self.used
        )?;
        match self.difference {
            Some(d) => write!(f, " (difference {d:.1e})"),
            None => write!(f, " (difference not computable: exponent too large)"),
        }
    }
}

/// The approximation note of one coordinate read as `v` from `text`, if `v`'s shortest
/// decimal is not the text's exact value.
fn approximation(
    index: usize,
    name: &Option<String>,
    field: &'static str,
    text: &str,
    v: f64,
) -> Option<Approximation> {
    use crate::exact::{exact_decimal, parse_rat, rat_to_f64};
    let used = exact_decimal(v)?;
    let typed = parse_rat(text.trim());
    if typed.as_ref().is_ok_and(|t| *t == used) {
        return None;
    }
    Some(Approximation {
        index,
        name: name.clone(),
        field,
        text: text.trim().to_string(),
        used: format!("{v}"),
        difference: typed.ok().map(|t| rat_to_f64(&(t - used)).abs()),
    })
}

/// What reading a landmark text noticed besides the landmarks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReadNotes {
    /// Coordinates whose decimal text an `f64` cannot hold (see [`parse_noted`]).
    pub approximations: Vec<Approximation>,
    /// Set when a BigWarp 3D table's constant z was dropped.
    pub constant_z: Option<ConstantZ>,
}

/// Errors of the landmark text formats.
#[derive(Debug, thiserror::Error)]
pub enum LandmarkError {
    /// A line of a CSV or BigWarp table is malformed (`line` is 1-based).
    #[error("line {line}: {message}")]
    Line {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The JSON text does not have the expected shape.
    #[error("landmark JSON: {0} (expected {{\"landmarks\": [{{\"name\": \"a\", \"src\": [x, y], \"dst\": [x, y]}}, ...]}})")]
    Json(#[from] serde_json::Error),
    /// A landmark cannot be stored: a non-finite coordinate or a weight `<= 0`.
    #[error("landmark {index} ({name}): {message}")]
    Invalid {
        /// 0-based position in the list.
        index: usize,
        /// Its name, or `unnamed`.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A hold-out set as large as the whole list was asked for.
    #[error("cannot hold out {k} of {len} landmarks: at least one must remain for the fit")]
    Holdout {
        /// Requested hold-out size.
        k: usize,
        /// Number of landmarks.
        len: usize,
    },
    /// An unknown format name.
    #[error("unknown landmark format {0:?} (expected csv, bigwarp or json)")]
    UnknownFormat(String),
    /// A point file ([`point_files`]) is malformed as a whole (no points, a missing part);
    /// the message names the format and, where there is one, the line.
    #[error("{0}")]
    PointFile(String),
}

/// A landmark text format (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LandmarkFormat {
    /// `name,src_x,src_y,dst_x,dst_y[,weight]` with an optional header.
    Csv,
    /// Fiji BigWarp's landmark table (moving -> `src`, fixed -> `dst`).
    BigWarp,
    /// `{"landmarks": [...]}`.
    Json,
}

impl LandmarkFormat {
    /// The names its `from_str` accepts (in any case), in the order of the variants.
    pub const NAMES: [&'static str; 3] = ["csv", "bigwarp", "json"];

    /// The format of a file from its extension (without the dot, any case) and its text:
    /// `json` -> [`Json`](Self::Json); otherwise [`BigWarp`](Self::BigWarp) when the first
    /// non-empty line starts with a double quote and has 6 (2D) or 8 (3D) fields whose second
    /// is `true` or `false`; otherwise [`Csv`](Self::Csv). Without an extension, text starting with `{`
    /// is JSON.
    pub fn detect(extension: Option<&str>, text: &str) -> LandmarkFormat {
        let ext = extension.map(str::to_ascii_lowercase);
        if ext.as_deref() == Some("json") || (ext.is_none() && text.trim_start().starts_with('{')) {
            return LandmarkFormat::Json;
        }
        let first = text.lines().map(str::trim).find(|l| !l.is_empty());
        if let Some(line) = first {
            if line.starts_with('"') {
                if let Ok(f) = split_csv(line) {
                    if matches!(f.len(), 6 | 8) && matches!(f[1].trim(), "true" | "false") {
                        return LandmarkFormat::BigWarp;
                    }
                }
            }
        }
        LandmarkFormat::Csv
    }
}

impl std::str::FromStr for LandmarkFormat {
    type Err = LandmarkError;

    /// `csv`, `bigwarp` or `json` (any case).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "csv" => Ok(LandmarkFormat::Csv),
            "bigwarp" => Ok(LandmarkFormat::BigWarp),
            "json" => Ok(LandmarkFormat::Json),
            _ => Err(LandmarkError::UnknownFormat(s.to_string())),
        }
    }
}

/// Parses landmarks in `format` (BigWarp with moving -> `src`).
pub fn parse(text: &str, format: LandmarkFormat) -> Result<Vec<Landmark>, LandmarkError> {
    match format {
        LandmarkFormat::Csv => parse_csv(text),
        LandmarkFormat::BigWarp => parse_bigwarp(text, false),
        LandmarkFormat::Json => parse_json(text),
    }
}

/// [`parse`], also returning the coordinates whose decimal text an `f64` cannot hold
/// exactly (more significant digits than it keeps, or beyond its range), in landmark and
/// field order. Every other coordinate's text is recovered exactly from the `f64` by
/// [`crate::exact::exact_decimal`].
pub fn parse_noted(
    text: &str,
    format: LandmarkFormat,
) -> Result<(Vec<Landmark>, Vec<Approximation>), LandmarkError> {
    match format {
        LandmarkFormat::Csv => parse_csv_noted(text),
        LandmarkFormat::BigWarp => parse_bigwarp_noted(text, false),
        LandmarkFormat::Json => parse_json_noted(text),
    }
}

/// [`parse_noted`] with every note: the approximations and, for a BigWarp 3D table, the
/// dropped constant z ([`ConstantZ`]), which a reader should show as a warning.
pub fn parse_with_notes(
    text: &str,
    format: LandmarkFormat,
) -> Result<(Vec<Landmark>, ReadNotes), LandmarkError> {
    match format {
        LandmarkFormat::BigWarp => parse_bigwarp_with_notes(text, false),
        _ => parse_noted(text, format)
            .map(|(l, approximations)| (l, ReadNotes { approximations, constant_z: None })),
    }
}

/// Writes landmarks in `format` (BigWarp with `src` -> moving). Fails on a non-finite
/// coordinate or a weight `<= 0`.
pub fn to_string(lms: &[Landmark], format: LandmarkFormat) -> Result<String, LandmarkError> {
    match format {
        LandmarkFormat::Csv => to_csv(lms),
        LandmarkFormat::BigWarp => to_bigwarp(lms, false),
        LandmarkFormat::Json => to_json(lms),
    }
}

/// Splits one CSV line into fields; a field may be double-quoted with `""` for a quote.
fn split_csv(line: &str) -> Result<Vec<String>, String> {
    let mut fields = Vec::new();
    let mut chars = line.chars().peekable();
    loop {
        let mut field = String::new();
        while chars.peek().is_some_and(|c| *c == ' ' || *c == '\t') {
            chars.next();
        }
        if chars.peek() == Some(&'"') {
            chars.next();
            loop {
                match chars.next() {
                    Some('"') if chars.peek() == Some(&'"') => {
                        chars.next();
                        field.push('"');
                    }
                    Some('"') => break,
                    Some(c) => field.push(c),
                    None => return Err("unterminated quoted field".into()),
                }
            }
            while chars.peek().is_some_and(|c| *c == ' ' || *c == '\t') {
                chars.next();
            }
            match chars.next() {
                None => {
                    fields.push(field);
                    return Ok(fields);
                }
                Some(',') => fields.push(field),
                Some(c) => return Err(format!("unexpected {c:?} after a quoted field")),
            }
        } else {
            loop {
                match chars.next() {
                    None => {
                        fields.push(field.trim().to_string());
                        return Ok(fields);
                    }
                    Some(',') => break,
                    Some(c) => field.push(c),
                }
            }
            fields.push(field.trim().to_string());
        }
    }
}

/// A finite number, or an error message naming the column.
fn number(field: &str, column: &str) -> Result<f64, String> {
    let v: f64 =
        field.trim().parse().map_err(|_| format!("{column}: {field:?} is not a number"))?;
    if !v.is_finite() {
        return Err(format!("{column}: {field:?} is not finite"));
    }
    Ok(v)
}

const CSV_COLUMNS: [&str; 6] = ["name", "src_x", "src_y", "dst_x", "dst_y", "weight"];

/// Parses the CSV format (see the module documentation).
pub fn parse_csv(text: &str) -> Result<Vec<Landmark>, LandmarkError> {
    parse_csv_noted(text).map(|(l, _)| l)
}

/// [`parse_csv`] with the approximated coordinates (see [`parse_noted`]).
pub fn parse_csv_noted(text: &str) -> Result<(Vec<Landmark>, Vec<Approximation>), LandmarkError> {
    let mut out = Vec::new();
    let mut notes = Vec::new();
    let mut first = true;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let err = |message: String| LandmarkError::Line { line, message };
        if raw.trim().is_empty() {
            continue;
        }
        let f = split_csv(raw.trim()).map_err(err)?;
        let is_first = std::mem::replace(&mut first, false);
        // A header has no number among the coordinate columns; a first line with some
        // numbers is data (a typo there is reported, not silently dropped).
        if is_first && f.iter().skip(1).take(4).all(|x| x.trim().parse::<f64>().is_err()) {
            continue;
        }
        if f.len() != 5 && f.len() != 6 {
            return Err(err(format!(
                "expected 5 or 6 fields (name,src_x,src_y,dst_x,dst_y[,weight]), found {}",
                f.len()
            )));
        }
        let mut v = [0.0; 5];
        for c in 1..f.len() {
            v[c - 1] = number(&f[c], CSV_COLUMNS[c]).map_err(err)?;
        }
        let weight = if f.len() == 6 { v[4] } else { 1.0 };
        if weight <= 0.0 {
            return Err(err(format!("weight {weight} is not > 0")));
        }
        let name = if f[0].is_empty() { None } else { Some(f[0].clone()) };
        for c in 0..4 {
            notes.extend(approximation(out.len(), &name, COORDS[c], &f[c + 1], v[c]));
        }
        out.push(Landmark { name, src: [v[0], v[1]], dst: [v[2], v[3]], weight });
    }
    Ok((out, notes))
}

/// Checks that every landmark can be written: finite coordinates, weight finite and > 0.
fn validate(lms: &[Landmark]) -> Result<(), LandmarkError> {
    for (index, l) in lms.iter().enumerate() {
        let bad = |message: &str| LandmarkError::Invalid {
            index,
            name: l.name.clone().unwrap_or_else(|| "unnamed".into()),
            message: message.into(),
        };
        if !l.src.iter().chain(&l.dst).all(|v| v.is_finite()) {
            return Err(bad("non-finite coordinate"));
        }
        if !(l.weight.is_finite() && l.weight > 0.0) {
            return Err(bad("weight must be finite and > 0"));
        }
    }
    Ok(())
}

/// A CSV field, quoted when it holds a comma, a quote, leading/trailing space or a newline.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.trim() != s {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Writes the CSV format with a header; numbers in shortest round-trip form.
pub fn to_csv(lms: &[Landmark]) -> Result<String, LandmarkError> {
    validate(lms)?;
    let mut s = String::from("name,src_x,src_y,dst_x,dst_y,weight\n");
    for l in lms {
        let name = csv_field(l.name.as_deref().unwrap_or(""));
        s.push_str(&format!(
            "{name},{},{},{},{},{}\n",
            l.src[0], l.src[1], l.dst[0], l.dst[1], l.weight
        ));
    }
    Ok(s)
}

#[derive(Serialize, Deserialize)]
struct JsonLandmark {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    src: [f64; 2],
    dst: [f64; 2],
    #[serde(default = "unit_weight")]
    weight: f64,
}

fn unit_weight() -> f64 {
    1.0
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonLandmarks {
    landmarks: Vec<JsonLandmark>,
}

/// Parses the JSON format; weights must be `> 0`.
pub fn parse_json(text: &str) -> Result<Vec<Landmark>, LandmarkError> {
    let file: JsonLandmarks = crate::json::from_str(text)?;
    let lms: Vec<Landmark> = file
        .landmarks
        .into_iter()
        .map(|j| Landmark { name: j.name, src: j.src, dst: j.dst, weight: j.weight })
        .collect();
    validate(&lms)?;
    Ok(lms)
}

/// [`parse_json`] with the approximated coordinates (see [`parse_noted`]). The number
/// texts come from `serde_json`'s arbitrary-precision numbers, as written in the file.
pub fn parse_json_noted(text: &str) -> Result<(Vec<Landmark>, Vec<Approximation>), LandmarkError> {
    let lms = parse_json(text)?;
    let value: serde_json::Value = serde_json::from_str(text)?;
    let mut notes = Vec::new();
    let items = value.get("landmarks").and_then(|v| v.as_array());
    for (index, (l, item)) in lms.iter().zip(items.into_iter().flatten()).enumerate() {
        for (k, key) in ["src", "dst"].iter().enumerate() {
            for c in 0..2 {
                if let Some(serde_json::Value::Number(n)) = item.get(key).and_then(|p| p.get(c)) {
                    let v = if k == 0 { l.src[c] } else { l.dst[c] };
                    let field = COORDS[2 * k + c];
                    notes.extend(approximation(index, &l.name, field, &n.to_string(), v));
                }
            }
        }
    }
    Ok((lms, notes))
}

/// Writes the JSON format (pretty-printed, one key per line).
pub fn to_json(lms: &[Landmark]) -> Result<String, LandmarkError> {
    validate(lms)?;
    let file = JsonLandmarks {
        landmarks: lms
            .iter()
            .map(|l| JsonLandmark {
                name: l.name.clone(),
                src: l.src,
                dst: l.dst,
                weight: l.weight,
            })
            .collect(),
    };
    let mut s = serde_json::to_string_pretty(&file)?;
    s.push('\n');
    Ok(s)
}

/// Splits `lms` into a fit set and a held-out set of `k` landmarks, chosen uniformly at
/// random (a partial Fisher-Yates shuffle driven by SplitMix64 from `seed`, so the split is
/// the same on every platform). Both sets keep the input order. `k = 0` holds nothing out;
/// `k >= lms.len()` is an error ([`LandmarkError::Holdout`]), since nothing would be left
/// to fit.
pub fn holdout(
    lms: &[Landmark],
    k: usize,
    seed: u64,
) -> Result<(Vec<Landmark>, Vec<Landmark>), LandmarkError> {
    if k >= lms.len() && k > 0 {
        return Err(LandmarkError::Holdout { k, len: lms.len() });
    }
    let mut rng = SplitMix64::new(seed);
    let mut idx: Vec<usize> = (0..lms.len()).collect();
    for i in 0..k {
        let j = i + rng.below(lms.len() - i);
        idx.swap(i, j);
    }
    let mut held = vec![false; lms.len()];
    for &i in &idx[..k] {
        held[i] = true;
    }
    let (mut fit, mut out) = (Vec::new(), Vec::new());
    for (l, &h) in lms.iter().zip(&held) {
        if h {
            out.push(l.clone())
        } else {
            fit.push(l.clone())
        }
    }
    Ok((fit, out))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A landmark (shared with the BigWarp tests).
    pub(super) fn lm(name: Option<&str>, src: [f64; 2], dst: [f64; 2], weight: f64) -> Landmark {
        Landmark { name: name.map(String::from), src, dst, weight }
    }

    /// Landmarks with awkward names and values (shared with the BigWarp tests).
    pub(super) fn sample() -> Vec<Landmark> {
        vec![
            lm(Some("a"), [0.1, 2.0 / 3.0], [1e-300, -7.25], 1.0),
            lm(None, [512.0, 3.0], [0.30000000000000004, 1e21], 2.5),
            lm(Some("with, comma \"q\""), [-1.0, 0.0], [5.0, 6.0], 0.125),
        ]
    }

    #[test]
    fn csv_round_trip_is_exact() {
        let text = to_csv(&sample()).unwrap();
        assert!(text.starts_with("name,src_x,src_y,dst_x,dst_y,weight\n"));
        assert_eq!(parse_csv(&text).unwrap(), sample());
        assert_eq!(parse(&text, LandmarkFormat::Csv).unwrap(), sample());
    }

    #[test]
    fn csv_without_header_default_weight_and_empty_name() {
        let l = parse_csv("\n p1, 1, 2, 3, 4\n,5,6,7,8,0.5\n").unwrap();
        assert_eq!(l[0], lm(Some("p1"), [1.0, 2.0], [3.0, 4.0], 1.0));
        assert_eq!(l[1], lm(None, [5.0, 6.0], [7.0, 8.0], 0.5));
        // A numeric name in the first data line is not a header.
        let l = parse_csv("7,1,2,3,4\n").unwrap();
        assert_eq!(l[0].name.as_deref(), Some("7"));
    }

    /// Bug (reliability pass): a typo in the first data row made it a "header", silently
    /// dropped.
    #[test]
    fn a_typo_in_the_first_row_is_an_error_not_a_header() {
        let e = parse_csv("a,1,2x,3,4\nb,5,6,7,8\n").unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
        // A real header (no number in the coordinate columns) is still skipped.
        assert_eq!(parse_csv("name,sx,sy,dx,dy\nb,5,6,7,8\n").unwrap().len(), 1);
    }

    #[test]
    fn csv_errors_name_the_line() {
        let cases = [
            ("name,sx,sy,dx,dy\na,1,2,3\n", 2, "5 or 6 fields"),
            ("a,1,2,3,4\nb,1,NaN,3,4\n", 2, "not finite"),
            ("a,1,2,3,inf\n", 1, "not finite"),
            ("a,1,2,3,4,0\n", 1, "not > 0"),
            ("a,1,2,3,4,-2\n", 1, "not > 0"),
            ("a,1,2,3,4\nb,1,x,3,4\n", 2, "not a number"),
            ("a,1,2,3,4,1,9\n", 1, "5 or 6 fields"),
            ("\"a,1,2,3,4\n", 1, "unterminated"),
        ];
        for (text, line, msg) in cases {
            let e = parse_csv(text).unwrap_err();
            match &e {
                LandmarkError::Line { line: l, message } => {
                    assert_eq!(*l, line, "{text:?}: {e}");
                    assert!(message.contains(msg), "{text:?}: {e}");
                }
                other => panic!("{text:?}: unexpected {other}"),
            }
        }
    }

    #[test]
    fn writers_reject_invalid_landmarks() {
        let bad = [lm(None, [f64::NAN, 0.0], [0.0; 2], 1.0), lm(None, [0.0; 2], [0.0; 2], 0.0)];
        for l in bad {
            for f in [LandmarkFormat::Csv, LandmarkFormat::BigWarp, LandmarkFormat::Json] {
                assert!(matches!(
                    to_string(std::slice::from_ref(&l), f),
                    Err(LandmarkError::Invalid { .. })
                ));
            }
        }
    }

    #[test]
    fn json_round_trip_and_defaults() {
        let lms = sample();
        let text = to_json(&lms).unwrap();
        assert_eq!(parse_json(&text).unwrap(), lms);
        let l = parse_json(r#"{"landmarks":[{"src":[1,2],"dst":[3.5,4]}]}"#).unwrap();
        assert_eq!(l, vec![lm(None, [1.0, 2.0], [3.5, 4.0], 1.0)]);
        assert!(parse_json(r#"{"landmarks":[{"src":[1,2],"dst":[3,4],"weight":-1}]}"#).is_err());
        assert!(parse_json(r#"{"landmarks":[{"src":[1],"dst":[3,4]}]}"#).is_err());
        assert!(parse_json(r#"{"points":[]}"#).is_err());
    }

    #[test]
    fn format_detection_and_names() {
        let bw = "\n\"Pt-0\",\"false\",\"1\",\"2\",\"3\",\"4\"\n";
        assert_eq!(LandmarkFormat::detect(Some("csv"), bw), LandmarkFormat::BigWarp);
        assert_eq!(LandmarkFormat::detect(Some("CSV"), "a,1,2,3,4\n"), LandmarkFormat::Csv);
        // Quoted first field but not a BigWarp row (5 fields).
        let q = "\"a\",1,2,3,4\n";
        assert_eq!(LandmarkFormat::detect(Some("csv"), q), LandmarkFormat::Csv);
        assert_eq!(LandmarkFormat::detect(Some("json"), "x"), LandmarkFormat::Json);
        assert_eq!(LandmarkFormat::detect(None, " {\"landmarks\":[]}"), LandmarkFormat::Json);
        assert_eq!(LandmarkFormat::detect(Some("txt"), "{"), LandmarkFormat::Csv);
        for (s, f) in [
            ("csv", LandmarkFormat::Csv),
            ("BigWarp", LandmarkFormat::BigWarp),
            ("json", LandmarkFormat::Json),
        ] {
            assert_eq!(s.parse::<LandmarkFormat>().unwrap(), f);
        }
        assert!("xml".parse::<LandmarkFormat>().is_err());
        // Each writer's output is detected as its own format.
        for f in [LandmarkFormat::Csv, LandmarkFormat::BigWarp, LandmarkFormat::Json] {
            let ext = if f == LandmarkFormat::Json { "json" } else { "csv" };
            let text = to_string(&sample(), f).unwrap();
            assert_eq!(LandmarkFormat::detect(Some(ext), &text), f);
        }
    }

    #[test]
    fn approximated_coordinates_are_reported_in_every_format() {
        let long = "12.34567890123456789";
        let csv =
            format!("name,src_x,src_y,dst_x,dst_y\nk,1.5,2.0001,3,4\na,0.1,0.2,{long},4.25\n");
        let (l, notes) = parse_noted(&csv, LandmarkFormat::Csv).unwrap();
        assert_eq!(l.len(), 2);
        assert_eq!(notes.len(), 1, "{notes:?}");
        let n = &notes[0];
        assert_eq!((n.index, n.field, n.text.as_str()), (1, "dst_x", long));
        assert_eq!(n.used, "12.345678901234567");
        let d = n.difference.unwrap();
        assert!((d - 8.9e-16).abs() < 1e-17, "{d}");
        assert_eq!(
            n.to_string(),
            format!("landmark 1 (a): dst_x {long} is approximated by 12.345678901234567 (difference 8.9e-16)")
        );
        // BigWarp: fields 5-6 are the fixed point (dst unless swapped).
        let bw = format!("\"p\",\"true\",\"1\",\"2\",\"{long}\",\"4\"\n");
        let (_, notes) = parse_noted(&bw, LandmarkFormat::BigWarp).unwrap();
        assert_eq!(notes[0].field, "dst_x");
        let (_, notes) = parse_bigwarp_noted(&bw, true).unwrap();
        assert_eq!(notes[0].field, "src_x");
        let json = r#"{"landmarks":[{"src":[1,2]," dst":[0,0]}]}"#;
        assert!(parse_noted(json, LandmarkFormat::Json).is_err());
        let json = format!(
            r#"{{"landmarks":[{{"src":[1,2.5],"dst":[3,4]}},{{"src":[1e-400,2],"dst":[3,{long}]}}]}}"#
        );
        let (_, notes) = parse_noted(&json, LandmarkFormat::Json).unwrap();
        let got: Vec<_> = notes.iter().map(|n| (n.index, n.field)).collect();
        assert_eq!(got, vec![(1, "src_x"), (1, "dst_y")]);
        assert_eq!(notes[0].used, "0");
        // 15 significant digits are always exact.
        let csv = "a,123456.789012345,0.000123456789012345,1e5,-9.87654321098765\n";
        assert!(parse_noted(csv, LandmarkFormat::Csv).unwrap().1.is_empty());
    }

    #[test]
    fn holdout_is_deterministic_disjoint_and_ordered() {
        let lms: Vec<Landmark> =
            (0..20).map(|i| lm(Some(&format!("p{i}")), [i as f64, 0.0], [0.0; 2], 1.0)).collect();
        let (fit, held) = holdout(&lms, 5, 42).unwrap();
        assert_eq!((fit.len(), held.len()), (15, 5));
        assert_eq!(holdout(&lms, 5, 42).unwrap(), (fit.clone(), held.clone()));
        let key = |l: &Landmark| l.src[0];
        for set in [&fit, &held] {
            assert!(set.windows(2).all(|w| key(&w[0]) < key(&w[1])));
        }
        let mut all: Vec<f64> = fit.iter().chain(&held).map(key).collect();
        all.sort_by(f64::total_cmp);
        assert_eq!(all, (0..20).map(|i| i as f64).collect::<Vec<_>>());
        // Different seeds give different splits (for these seeds).
        assert_ne!(holdout(&lms, 5, 43).unwrap().1, held);
        assert_eq!(holdout(&lms, 0, 1).unwrap(), (lms.clone(), vec![]));
        assert!(matches!(holdout(&lms, 20, 1), Err(LandmarkError::Holdout { k: 20, len: 20 })));
    }
}

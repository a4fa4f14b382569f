//! Point files: one point set a file, as other tools write them; two such files, read side
//! by side, make landmark pairs (`trimorph fit --landmarks-src A --landmarks-dst B`; the
//! pairing and the files are in `crate::io::landmarks`).
//!
//! Every reader returns trimorph's coordinates: pixel `(i, j)` centred at `(i, j)` (0-based,
//! `x` right, `y` down).
//!
//! * [`PointFormat::Pts`]: the iBUG / menpo `.pts` file of face-landmark datasets (300-W,
//!   LFPW, HELEN, ...):
//!
//!   ```text
//!   version: 1
//!   n_points: 68
//!   {
//!   x y
//!   ...
//!   }
//!   ```
//!
//!   Header lines `key: value` before `{` (`n_points`, when given, must equal the number of
//!   points; other keys are ignored), then one point a line, two numbers separated by spaces.
//!   iBUG coordinates are **1-based** (the first pixel's centre is `(1, 1)`, as menpo reads
//!   them too): 1 is subtracted from both.
//! * [`PointFormat::Itk`]: ITK / elastix / transformix point-set text files:
//!
//!   ```text
//!   point
//!   3
//!   x y
//!   ...
//!   ```
//!
//!   `point` (physical coordinates) or `index` (pixel indices) on the first line, the number
//!   of points on the second, then one point a line. Both are read unchanged: with unit
//!   spacing and a zero origin (what ITK gives a PNG or a TIFF without calibration), ITK's
//!   pixel centres are at the pixel indices, trimorph's convention. Only 2D points are read.
//! * [`PointFormat::Csv`]: `x,y` a line (commas, semicolons, tabs or spaces between the two
//!   numbers), an optional header line without numbers; 0-based pixel centres, unchanged.
//!
//! All three skip blank lines (the CSV reader also `#` comments); a point needs two finite
//! numbers, exactly. Errors name the 1-based line and the 0-based point index.

use super::LandmarkError;

/// A point-file format (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PointFormat {
    /// iBUG / menpo `.pts` (1-based).
    Pts,
    /// ITK / elastix point set (`point` or `index`, the count, the points).
    Itk,
    /// `x,y` a line.
    Csv,
}

impl PointFormat {
    /// The format of a point file from its extension (without the dot, any case) and its
    /// text: `pts`, or a first non-empty line starting with `version:` or `n_points:`, is
    /// [`Pts`](Self::Pts); a first non-empty line `point` or `index` (any case) is
    /// [`Itk`](Self::Itk); anything else is [`Csv`](Self::Csv).
    pub fn detect(extension: Option<&str>, text: &str) -> PointFormat {
        if extension.is_some_and(|e| e.eq_ignore_ascii_case("pts")) {
            return PointFormat::Pts;
        }
        let first = text.lines().map(str::trim).find(|l| !l.is_empty()).unwrap_or("");
        let key = first.split(':').next().unwrap_or("").trim().to_ascii_lowercase();
        if first.contains(':') && matches!(key.as_str(), "version" | "n_points") {
            return PointFormat::Pts;
        }
        if first.eq_ignore_ascii_case("point") || first.eq_ignore_ascii_case("index") {
            return PointFormat::Itk;
        }
        PointFormat::Csv
    }

    /// What is added to the file's coordinates to get trimorph's (0-based pixel centres):
    /// `-1` for the 1-based `.pts`, `0` otherwise.
    pub fn offset(self) -> f64 {
        match self {
            PointFormat::Pts => -1.0,
            PointFormat::Itk | PointFormat::Csv => 0.0,
        }
    }

    /// A short name for messages: `iBUG .pts`, `ITK point set` or `CSV x,y`.
    pub fn name(self) -> &'static str {
        match self {
            PointFormat::Pts => "iBUG .pts",
            PointFormat::Itk => "ITK point set",
            PointFormat::Csv => "CSV x,y",
        }
    }
}

/// Parses a point file in `format`, returning trimorph's 0-based coordinates (the `.pts`
/// shift applied). At least one point.
pub fn parse_points(text: &str, format: PointFormat) -> Result<Vec<[f64; 2]>, LandmarkError> {
    let pts = match format {
        PointFormat::Pts => parse_pts(text)?,
        PointFormat::Itk => parse_itk(text)?,
        PointFormat::Csv => parse_xy(text)?,
    };
    if pts.is_empty() {
        return Err(LandmarkError::PointFile(format!("{}: no points", format.name())));
    }
    let d = format.offset();
    Ok(pts.into_iter().map(|[x, y]| [x + d, y + d]).collect())
}

/// Non-blank lines, trimmed, with their 1-based numbers.
fn lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty())
}

/// The point on one line, two finite numbers in `fields`; `index` is the point's 0-based
/// index, `how` says how the numbers are separated.
fn point(fields: &[&str], line: usize, index: usize, how: &str) -> Result<[f64; 2], LandmarkError> {
    let err = |message: String| LandmarkError::Line { line, message };
    if fields.len() != 2 {
        let what = if fields.len() == 3 {
            " (a 3D point? trimorph reads 2D points)".to_string()
        } else {
            String::new()
        };
        return Err(err(format!(
            "point {index}: expected two numbers `x{how}y`, found {} fields{what}",
            fields.len()
        )));
    }
    let mut v = [0.0; 2];
    for (c, (f, axis)) in fields.iter().zip(["x", "y"]).enumerate() {
        let n: f64 = f
            .trim()
            .parse()
            .map_err(|_| err(format!("point {index}: {axis} {f:?} is not a number")))?;
        if !n.is_finite() {
            return Err(err(format!("point {index}: {axis} {f:?} is not finite")));
        }
        v[c] = n;
    }
    Ok(v)
}

fn whitespace_fields(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

/// The iBUG `.pts` points as written (1-based).
fn parse_pts(text: &str) -> Result<Vec<[f64; 2]>, LandmarkError> {
    let mut declared: Option<(usize, usize)> = None;
    let mut out = Vec::new();
    // 0: header, 1: inside the braces, 2: after the closing brace.
    let mut part = 0;
    let mut last = 0;
    for (line, l) in lines(text) {
        let err = |message: String| LandmarkError::Line { line, message };
        last = line;
        match part {
            0 if l == "{" => part = 1,
            0 => {
                let (key, value) = l.split_once(':').ok_or_else(|| {
                    err(format!("expected a header line `key: value` or `{{`, found `{l}`"))
                })?;
                if key.trim().eq_ignore_ascii_case("n_points") {
                    let n = value.trim().parse::<usize>().map_err(|_| {
                        err(format!("n_points {:?} is not a whole number", value.trim()))
                    })?;
                    declared = Some((n, line));
                }
            }
            1 if l == "}" => {
                if let Some((n, at)) = declared {
                    if n != out.len() {
                        return Err(err(format!(
                            "the list ends after {} points, but line {at} declares n_points: {n}",
                            out.len()
                        )));
                    }
                }
                part = 2;
            }
            1 => out.push(point(&whitespace_fields(l), line, out.len(), " ")?),
            _ => return Err(err(format!("unexpected `{l}` after the closing `}}`"))),
        }
    }
    match part {
        0 => Err(LandmarkError::PointFile(
            "iBUG .pts: no `{` opens the list of points (expected `version: 1`, \
             `n_points: N`, `{`, one `x y` a line, `}`)"
                .into(),
        )),
        1 => Err(LandmarkError::PointFile(format!(
            "iBUG .pts: the file ends (line {last}) before the closing `}}` (truncated?)"
        ))),
        _ => Ok(out),
    }
}

/// The ITK / elastix points, unchanged.
fn parse_itk(text: &str) -> Result<Vec<[f64; 2]>, LandmarkError> {
    let mut rows = lines(text);
    let what = "ITK point set: expected `point` or `index`, the number of points, then one \
                `x y` a line";
    let Some((line, kind)) = rows.next() else {
        return Err(LandmarkError::PointFile(format!("{what}; the file is empty")));
    };
    if !(kind.eq_ignore_ascii_case("point") || kind.eq_ignore_ascii_case("index")) {
        return Err(LandmarkError::Line { line, message: format!("{what}; found `{kind}`") });
    }
    let Some((line, count)) = rows.next() else {
        return Err(LandmarkError::PointFile(format!(
            "ITK point set: the file ends after `{kind}` (line {line}); the number of points \
             comes next"
        )));
    };
    let n = count.parse::<usize>().map_err(|_| LandmarkError::Line {
        line,
        message: format!("the number of points {count:?} is not a whole number"),
    })?;
    let count_line = line;
    let mut out = Vec::with_capacity(n.min(1 << 20));
    for (line, l) in rows {
        if out.len() == n {
            return Err(LandmarkError::Line {
                line,
                message: format!(
                    "line {count_line} declares {n} points, but the file has more (`{l}`)"
                ),
            });
        }
        out.push(point(&whitespace_fields(l), line, out.len(), " ")?);
    }
    if out.len() < n {
        return Err(LandmarkError::PointFile(format!(
            "ITK point set: line {count_line} declares {n} points, but the file ends after {} \
             (truncated?)",
            out.len()
        )));
    }
    Ok(out)
}

/// `x,y` rows, unchanged.
fn parse_xy(text: &str) -> Result<Vec<[f64; 2]>, LandmarkError> {
    let mut out = Vec::new();
    let mut first = true;
    for (line, l) in lines(text) {
        if l.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = if l.contains([',', ';', '\t']) {
            l.split([',', ';', '\t']).map(str::trim).collect()
        } else {
            whitespace_fields(l)
        };
        if std::mem::replace(&mut first, false)
            && fields.iter().all(|f| f.trim().parse::<f64>().is_err())
        {
            continue;
        }
        out.push(point(&fields, line, out.len(), ",")?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PTS: &str = "version: 1\nn_points:  3\n{\n1 1\n221.5 30.25\n0.5 100\n}\n";

    #[test]
    fn pts_is_read_one_based() {
        let p = parse_points(PTS, PointFormat::Pts).unwrap();
        assert_eq!(p, vec![[0.0, 0.0], [220.5, 29.25], [-0.5, 99.0]]);
        // Windows line ends, no version, tabs, trailing blank lines.
        let t = "n_points: 1\r\n{\r\n 3\t4 \r\n}\r\n\r\n";
        assert_eq!(parse_points(t, PointFormat::Pts).unwrap(), vec![[2.0, 3.0]]);
        // Without n_points the list is read as it is.
        assert_eq!(parse_points("{\n2 2\n}\n", PointFormat::Pts).unwrap(), vec![[1.0, 1.0]]);
    }

    #[test]
    fn pts_errors_name_the_line_and_point() {
        let cases = [
            ("version: 1\nn_points: 2\n{\n1 2\n3\n}\n", "line 5: point 1: expected two numbers"),
            ("n_points: 2\n{\n1 2\n3 x\n}\n", "line 4: point 1: y \"x\" is not a number"),
            ("n_points: 2\n{\n1 2\n3 4 5\n}\n", "found 3 fields (a 3D point?"),
            ("n_points: 1\n{\n1 nan\n}\n", "line 3: point 0: y \"nan\" is not finite"),
            ("n_points: 3\n{\n1 2\n3 4\n}\n", "line 5: the list ends after 2 points, but line 1"),
            ("n_points: x\n{\n}\n", "line 1: n_points \"x\" is not a whole number"),
            ("version 1\n{\n1 2\n}\n", "line 1: expected a header line"),
            ("n_points: 1\n{\n1 2\n", "ends (line 3) before the closing `}`"),
            ("n_points: 1\n1 2\n", "line 2: expected a header line"),
            ("n_points: 0\n", "no `{` opens the list"),
            ("n_points: 1\n{\n1 2\n}\n3 4\n", "line 5: unexpected `3 4` after the closing"),
            ("n_points: 0\n{\n}\n", "no points"),
        ];
        for (text, want) in cases {
            let e = parse_points(text, PointFormat::Pts).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
    }

    #[test]
    fn itk_point_and_index_files_are_read_unchanged() {
        let t = "point\n3\n0 0\n221 10.5\n-1 160\n";
        assert_eq!(
            parse_points(t, PointFormat::Itk).unwrap(),
            vec![[0.0, 0.0], [221.0, 10.5], [-1.0, 160.0]]
        );
        let t = "INDEX\n\n2\n 4 5 \n6\t7\n\n";
        assert_eq!(parse_points(t, PointFormat::Itk).unwrap(), vec![[4.0, 5.0], [6.0, 7.0]]);
    }

    #[test]
    fn itk_errors_name_the_line_and_point() {
        let cases = [
            ("point\n2\n1 2\n", "declares 2 points, but the file ends after 1"),
            ("point\n1\n1 2\n3 4\n", "line 4: line 2 declares 1 points, but the file has more"),
            ("point\ntwo\n1 2\n", "line 2: the number of points \"two\" is not a whole number"),
            ("point\n2\n1 2\n1 2 3\n", "line 4: point 1: expected two numbers `x y`, found 3"),
            ("point\n", "the file ends after `point` (line 1)"),
            ("point\n0\n", "no points"),
        ];
        for (text, want) in cases {
            let e = parse_points(text, PointFormat::Itk).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
        // A file that is not a point set at all, read as ITK on purpose.
        let e = parse_points("x,y\n1,2\n", PointFormat::Itk).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("found `x,y`"), "{e}");
    }

    #[test]
    fn two_column_csv_with_or_without_header() {
        let want = vec![[1.0, 2.0], [3.5, -4.0]];
        for t in ["x,y\n1,2\n3.5,-4\n", "1,2\n\n# c\n3.5,-4\n", "1 2\n3.5 -4\n", "x;y\n1;2\n3.5;-4"]
        {
            assert_eq!(parse_points(t, PointFormat::Csv).unwrap(), want, "{t:?}");
        }
        let cases = [
            ("x,y\n1,2\n3\n", "line 3: point 1: expected two numbers `x,y`, found 1 fields"),
            ("1,2\nx,y\n", "line 2: point 1: x \"x\" is not a number"),
            ("1,2,3\n", "line 1: point 0: expected two numbers `x,y`, found 3 fields"),
            ("1,inf\n", "line 1: point 0: y \"inf\" is not finite"),
            ("x,y\n", "CSV x,y: no points"),
            // A landmark CSV given as a point file.
            ("name,src_x,src_y,dst_x,dst_y\na,1,2,3,4\n", "line 2: point 0: expected two"),
        ];
        for (text, want) in cases {
            let e = parse_points(text, PointFormat::Csv).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
    }

    #[test]
    fn formats_are_detected_from_the_extension_and_the_first_line() {
        assert_eq!(PointFormat::detect(Some("PTS"), "1,2\n"), PointFormat::Pts);
        assert_eq!(PointFormat::detect(Some("txt"), PTS), PointFormat::Pts);
        assert_eq!(PointFormat::detect(None, "\n n_points: 3\n"), PointFormat::Pts);
        assert_eq!(PointFormat::detect(Some("txt"), "point\n1\n1 2\n"), PointFormat::Itk);
        assert_eq!(PointFormat::detect(Some("txt"), "\nIndex\n1\n1 2\n"), PointFormat::Itk);
        assert_eq!(PointFormat::detect(Some("csv"), "x,y\n1,2\n"), PointFormat::Csv);
        assert_eq!(PointFormat::detect(Some("txt"), "points\n1 2\n"), PointFormat::Csv);
        assert_eq!(PointFormat::detect(None, ""), PointFormat::Csv);
    }
}

//! Points in CSV text: `x,y` rows in pixel coordinates (x to the right, y down).
//!
//! Two readers, for two uses:
//! * [`read_points`]: a point set (mesh vertices, an outline). Columns may be separated by
//!   commas, semicolons, tabs or spaces; extra columns are ignored; at least one point.
//! * [`read_optional_points`]: points to move through a map, where a row may be missing: an
//!   empty row `,` is `None`, as [`optional_points_csv`] writes a point that has no image,
//!   so a warped file can be warped back row for row.
//!
//! Both skip blank lines and `#` comments, and take a first line with no number in its
//! first two columns as a header. A row with a number in one column only is an error (a typo
//! must not shift the rows), and so is a number that is not finite. Errors name the source
//! and the 1-based line.

use std::fmt::Write as _;

/// A malformed points file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PointsError {
    /// A row that is not a point.
    #[error("{source_name}, line {line}: expected {expected}, found `{text}`")]
    Row {
        /// The file (as given to the reader).
        source_name: String,
        /// The 1-based line.
        line: usize,
        /// What was expected there.
        expected: &'static str,
        /// The line as found (trimmed).
        text: String,
    },
    /// No point at all.
    #[error("{source_name}: no points")]
    Empty {
        /// The file (as given to the reader).
        source_name: String,
    },
}

/// The rows of `text` that are neither blank nor comments, with their 1-based line numbers.
fn rows(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

fn finite(c: Option<&&str>) -> Option<f64> {
    c.and_then(|c| c.trim().parse::<f64>().ok()).filter(|v| v.is_finite())
}

/// Reads a point set: `x,y` rows (see the module documentation). `source` names the file in
/// errors.
///
/// ```
/// use trimorph::io::points::read_points;
/// let pts = read_points("x y\n1 2\n3;4;extra\n", "p.csv").unwrap();
/// assert_eq!(pts, vec![[1.0, 2.0], [3.0, 4.0]]);
/// assert!(read_points("1,2\n3\n", "p.csv").unwrap_err().to_string().contains("line 2"));
/// ```
pub fn read_points(text: &str, source: &str) -> Result<Vec<[f64; 2]>, PointsError> {
    let mut out = Vec::new();
    for (line, row) in rows(text) {
        let cols: Vec<&str> = row.split([',', ';', '\t', ' ']).filter(|c| !c.is_empty()).collect();
        let parse = |c: Option<&&str>| c.and_then(|c| c.trim().parse::<f64>().ok());
        match (parse(cols.first()), parse(cols.get(1))) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => out.push([x, y]),
            (None, None) if out.is_empty() && line == 1 => continue,
            _ => {
                return Err(PointsError::Row {
                    source_name: source.to_string(),
                    line,
                    expected: "two numbers `x,y`",
                    text: row.to_string(),
                })
            }
        }
    }
    if out.is_empty() {
        return Err(PointsError::Empty { source_name: source.to_string() });
    }
    Ok(out)
}

/// Reads points to be moved: comma-separated `x,y` rows where an empty row `,` is `None`
/// (see the module documentation). No row at all is an empty list, not an error.
///
/// ```
/// use trimorph::io::points::{optional_points_csv, read_optional_points};
/// let rows = read_optional_points("x,y\n1,2\n,\n3.5,4\n", "p.csv").unwrap();
/// assert_eq!(rows, vec![Some([1.0, 2.0]), None, Some([3.5, 4.0])]);
/// assert_eq!(read_optional_points(&optional_points_csv(&rows), "again").unwrap(), rows);
/// ```
pub fn read_optional_points(
    text: &str,
    source: &str,
) -> Result<Vec<Option<[f64; 2]>>, PointsError> {
    let mut out = Vec::new();
    for (line, row) in rows(text) {
        let cols: Vec<&str> = row.split(',').map(str::trim).collect();
        if cols.len() >= 2 && cols[0].is_empty() && cols[1].is_empty() {
            out.push(None);
            continue;
        }
        match (finite(cols.first()), finite(cols.get(1))) {
            (Some(x), Some(y)) => out.push(Some([x, y])),
            (None, None) if out.is_empty() && line == 1 => continue,
            _ => {
                return Err(PointsError::Row {
                    source_name: source.to_string(),
                    line,
                    expected: "`x,y` (finite numbers) or an empty row `,`",
                    text: row.to_string(),
                })
            }
        }
    }
    Ok(out)
}

/// CSV text of points with a header `x,y`; a `None` is an empty row `,`. Numbers are written
/// in the shortest form that reads back to the same `f64`.
pub fn optional_points_csv(points: &[Option<[f64; 2]>]) -> String {
    let mut csv = String::with_capacity(16 + 40 * points.len());
    csv.push_str("x,y\n");
    for p in points {
        match p {
            Some([x, y]) => {
                let _ = writeln!(csv, "{x},{y}");
            }
            None => csv.push_str(",\n"),
        }
    }
    csv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_header_is_only_a_first_line_without_numbers() {
        assert_eq!(read_points("x,y\n# c\n\n1,2\n", "f").unwrap(), vec![[1.0, 2.0]]);
        // The header is the file's first line only, comments and blank lines counted.
        let e = read_points("# c\n\nx,y\n1,2\n", "f").unwrap_err();
        assert_eq!(e.to_string(), "f, line 3: expected two numbers `x,y`, found `x,y`");
        let e = read_optional_points("1,2\nx,y\n", "f").unwrap_err();
        assert_eq!(
            e.to_string(),
            "f, line 2: expected `x,y` (finite numbers) or an empty row `,`, found `x,y`"
        );
    }

    #[test]
    fn non_finite_numbers_and_half_rows_are_refused() {
        for bad in ["1,nan\n", "inf,2\n", "1,\n", ",2\n"] {
            assert!(read_optional_points(bad, "f").is_err(), "{bad:?}");
            assert!(read_points(bad, "f").is_err(), "{bad:?}");
        }
        assert_eq!(
            read_points("", "f").unwrap_err(),
            PointsError::Empty { source_name: "f".into() }
        );
        assert_eq!(read_optional_points("x,y\n", "f").unwrap(), vec![]);
    }

    #[test]
    fn written_points_read_back_exactly() {
        let rows = vec![Some([0.1 + 0.2, -1e-300]), None, Some([f64::MAX, 12345.678901234567])];
        assert_eq!(read_optional_points(&optional_points_csv(&rows), "f").unwrap(), rows);
    }
}

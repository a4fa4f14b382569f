//! Fiji BigWarp's landmark tables, 2D (6 fields a row) and 3D with constant z (8 fields);
//! the format is described in the parent module ([`super`]).

use super::{
    approximation, split_csv, validate, Approximation, Landmark, LandmarkError, ReadNotes, COORDS,
};

/// BigWarp 3D landmarks whose z was dropped because it is the same on every row.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstantZ {
    /// The moving points' z.
    pub moving: f64,
    /// The fixed points' z.
    pub fixed: f64,
    /// Rows read (active and placed).
    pub rows: usize,
}

impl std::fmt::Display for ConstantZ {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "3D BigWarp landmarks: z dropped (constant on all {} rows: moving z = {}, fixed z = {}); fitted in 2D",
            self.rows, self.moving, self.fixed
        )
    }
}

/// Parses a BigWarp landmark table: moving -> `src`, fixed -> `dst`, or the reverse when
/// `swap`. Inactive rows and rows with an unset (infinite) point are skipped.
pub fn parse_bigwarp(text: &str, swap: bool) -> Result<Vec<Landmark>, LandmarkError> {
    parse_bigwarp_noted(text, swap).map(|(l, _)| l)
}

/// [`parse_bigwarp`] with the approximated coordinates (see [`super::parse_noted`]).
pub fn parse_bigwarp_noted(
    text: &str,
    swap: bool,
) -> Result<(Vec<Landmark>, Vec<Approximation>), LandmarkError> {
    parse_bigwarp_with_notes(text, swap).map(|(l, n)| (l, n.approximations))
}

/// [`parse_bigwarp`] with every note: the approximated coordinates and, for a 3D table
/// (8 fields a row), the constant z that was dropped. A 3D table whose moving or fixed z
/// differs between rows is an error at the first row that differs.
pub fn parse_bigwarp_with_notes(
    text: &str,
    swap: bool,
) -> Result<(Vec<Landmark>, ReadNotes), LandmarkError> {
    let (rows, notes) = parse_rows(text, swap, false)?;
    Ok((rows.into_iter().map(|(l, _)| l).collect(), notes))
}

/// A BigWarp table with every placed row and its active flag (`true`/`false`), for a
/// reader that keeps inactive rows (the editor's landmark table); rows whose point is
/// unset are still skipped. Moving -> `src` unless `swap`. A 3D table's z must be
/// constant over the active rows (inactive rows are not fitted).
pub fn parse_bigwarp_flagged(
    text: &str,
    swap: bool,
) -> Result<Vec<(Landmark, bool)>, LandmarkError> {
    parse_rows(text, swap, true).map(|(rows, _)| rows)
}

/// The rows of a table (inactive ones too with `keep_inactive`) and the notes (about the
/// active rows).
fn parse_rows(
    text: &str,
    swap: bool,
    keep_inactive: bool,
) -> Result<(Vec<(Landmark, bool)>, ReadNotes), LandmarkError> {
    let mut out: Vec<(Landmark, bool)> = Vec::new();
    let mut notes = Vec::new();
    // Fields per row (6 or 8, from the first row) and, for 3D, the first row's z and line.
    let mut width: Option<(usize, usize)> = None;
    let mut z0: Option<([f64; 2], usize)> = None;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let err = |message: String| LandmarkError::Line { line, message };
        if raw.trim().is_empty() {
            continue;
        }
        let f = split_csv(raw.trim()).map_err(err)?;
        if f.len() != 6 && f.len() != 8 {
            return Err(err(format!(
                "expected 6 fields (BigWarp 2D) or 8 (BigWarp 3D), found {}",
                f.len()
            )));
        }
        match width {
            None => width = Some((f.len(), line)),
            Some((n, first)) if n != f.len() => {
                let what = "a BigWarp table is either 2D (6 fields) or 3D (8)";
                return Err(err(format!("{} fields, but line {first} has {n}: {what}", f.len())));
            }
            Some(_) => {}
        }
        let active = match f[1].trim() {
            "true" => true,
            "false" if keep_inactive => false,
            "false" => continue,
            other => return Err(err(format!("active flag {other:?} is not true/false"))),
        };
        let dims = (f.len() - 2) / 2;
        let mut all = [0.0; 6];
        for c in 0..2 * dims {
            let t = f[c + 2].trim();
            all[c] = match t.parse::<f64>() {
                Ok(x) if x.is_nan() => return Err(err(format!("field {}: NaN", c + 3))),
                Ok(x) => x,
                Err(_) => return Err(err(format!("field {}: {t:?} is not a number", c + 3))),
            };
        }
        if all[..2 * dims].iter().any(|x| x.is_infinite()) {
            continue; // a point BigWarp has not placed yet
        }
        // Field indices (0-based, after name and flag) of moving x, y and fixed x, y.
        let xy: [usize; 4] = if dims == 3 { [0, 1, 3, 4] } else { [0, 1, 2, 3] };
        if dims == 3 && active {
            let z = [all[2], all[5]];
            match z0 {
                None => z0 = Some((z, line)),
                Some((z_first, first)) => {
                    for (i, which) in ["moving", "fixed"].iter().enumerate() {
                        if z[i] != z_first[i] {
                            return Err(err(format!(
                                "{which} z is {} here but {} on line {first}: z varies, and a 2D deformation cannot honour varying z (export the landmarks of one plane, or project them yourself)",
                                z[i], z_first[i]
                            )));
                        }
                    }
                }
            }
        }
        let v = xy.map(|i| all[i]);
        let (moving, fixed) = ([v[0], v[1]], [v[2], v[3]]);
        let (src, dst) = if swap { (fixed, moving) } else { (moving, fixed) };
        let name = if f[0].is_empty() { None } else { Some(f[0].clone()) };
        for c in 0..4 {
            // The moving point's x, y, then the fixed point's.
            let field = COORDS[if swap { (c + 2) % 4 } else { c }];
            notes.extend(approximation(out.len(), &name, field, f[xy[c] + 2].trim(), v[c]));
        }
        out.push((Landmark { name, src, dst, weight: 1.0 }, active));
    }
    notes.sort_by_key(|n| (n.index, COORDS.iter().position(|&c| c == n.field)));
    let rows = out.iter().filter(|(_, a)| *a).count();
    let constant_z = z0.map(|(z, _)| ConstantZ { moving: z[0], fixed: z[1], rows });
    Ok((out, ReadNotes { approximations: notes, constant_z }))
}

/// Writes a BigWarp landmark table (all rows active): `src` -> moving, `dst` -> fixed, or
/// the reverse when `swap`. Unnamed landmarks are called `Pt-<index>`; weights are lost.
pub fn to_bigwarp(lms: &[Landmark], swap: bool) -> Result<String, LandmarkError> {
    to_bigwarp_flagged(lms, &vec![true; lms.len()], swap)
}

/// [`to_bigwarp`] with each row's active flag (`active[i]` for `lms[i]`; a missing flag is
/// `true`), as BigWarp writes a table with rows switched off.
pub fn to_bigwarp_flagged(
    lms: &[Landmark],
    active: &[bool],
    swap: bool,
) -> Result<String, LandmarkError> {
    validate(lms)?;
    let q = |s: &str| format!("\"{}\"", s.replace('"', "\"\""));
    let mut s = String::new();
    for (i, l) in lms.iter().enumerate() {
        let name = l.name.clone().unwrap_or_else(|| format!("Pt-{i}"));
        let (m, f) = if swap { (l.dst, l.src) } else { (l.src, l.dst) };
        let nums: Vec<String> =
            [m[0], m[1], f[0], f[1]].iter().map(|v| q(&v.to_string())).collect();
        let flag = active.get(i).copied().unwrap_or(true);
        s.push_str(&format!("{},\"{flag}\",{}\n", q(&name), nums.join(",")));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{lm, sample};
    use super::super::{parse_with_notes, LandmarkFormat};
    use super::*;

    #[test]
    fn bigwarp_import_skips_inactive_and_unset_and_maps_moving_to_src() {
        let text = "\"Pt-0\",\"true\",\"10.5\",\"20.0\",\"11.0\",\"21.25\"\n\
                    \"Pt-1\",\"false\",\"1.0\",\"2.0\",\"3.0\",\"4.0\"\n\
                    \"Pt-2\",\"true\",\"5.0\",\"6.0\",\"Infinity\",\"Infinity\"\n\
                    \"nucleus\",\"true\",\"-1.0\",\"0.0\",\"7.0\",\"8.0\"\n";
        let l = parse_bigwarp(text, false).unwrap();
        assert_eq!(
            l,
            vec![
                lm(Some("Pt-0"), [10.5, 20.0], [11.0, 21.25], 1.0),
                lm(Some("nucleus"), [-1.0, 0.0], [7.0, 8.0], 1.0)
            ]
        );
        let s = parse_bigwarp(text, true).unwrap();
        assert_eq!(s[0].src, [11.0, 21.25]);
        assert_eq!(s[0].dst, [10.5, 20.0]);
        assert!(parse_bigwarp("\"a\",\"yes\",\"1\",\"2\",\"3\",\"4\"\n", false).is_err());
        assert!(parse_bigwarp("\"a\",\"true\",\"1\",\"2\",\"3\"\n", false).is_err());
        let e = parse_bigwarp("\"a\",\"true\",\"1\",\"2\",\"3\",\"4\",\"5\"\n", false);
        assert!(e.unwrap_err().to_string().contains("found 7"));
    }

    /// The editor's table keeps switched-off rows: the flagged reader returns them with
    /// their flag, and the flagged writer writes the flags back (a round trip).
    #[test]
    fn bigwarp_flags_round_trip_through_the_flagged_reader_and_writer() {
        let text = "\"Pt-0\",\"true\",\"10.5\",\"20.0\",\"11.0\",\"21.25\"\n\
                    \"Pt-1\",\"false\",\"1.0\",\"2.0\",\"3.0\",\"4.0\"\n\
                    \"Pt-2\",\"true\",\"5.0\",\"6.0\",\"Infinity\",\"Infinity\"\n";
        let rows = parse_bigwarp_flagged(text, false).unwrap();
        assert_eq!(
            rows,
            vec![
                (lm(Some("Pt-0"), [10.5, 20.0], [11.0, 21.25], 1.0), true),
                (lm(Some("Pt-1"), [1.0, 2.0], [3.0, 4.0], 1.0), false),
            ]
        );
        let (lms, flags): (Vec<Landmark>, Vec<bool>) = rows.iter().cloned().unzip();
        let out = to_bigwarp_flagged(&lms, &flags, false).unwrap();
        assert!(out.lines().nth(1).unwrap().starts_with("\"Pt-1\",\"false\",\"1\",\"2\""), "{out}");
        assert_eq!(parse_bigwarp_flagged(&out, false).unwrap(), rows);
        // The plain reader still skips the inactive row.
        assert_eq!(parse_bigwarp(&out, false).unwrap(), vec![lms[0].clone()]);
        // A 3D table's z only has to agree on the active rows.
        let z3 = "\"a\",\"true\",\"1\",\"2\",\"0\",\"3\",\"4\",\"0\"\n\
                  \"b\",\"false\",\"1\",\"2\",\"7\",\"3\",\"4\",\"7\"\n";
        assert_eq!(parse_bigwarp_flagged(z3, false).unwrap().len(), 2);
    }

    /// Issue 20: BigWarp exports 3D points by default; a constant z is dropped with a note.
    #[test]
    fn bigwarp_3d_with_constant_z_reads_as_2d_with_a_note() {
        let text = "\"Pt-0\",\"true\",\"10.5\",\"20.0\",\"0.0\",\"11.0\",\"21.25\",\"4.0\"\n\
                    \"Pt-1\",\"false\",\"1.0\",\"2.0\",\"9.0\",\"3.0\",\"4.0\",\"9.0\"\n\
                    \"Pt-2\",\"true\",\"5.0\",\"6.0\",\"Infinity\",\"Infinity\",\"Infinity\",\"Infinity\"\n\
                    \"nucleus\",\"true\",\"-1.0\",\"0.0\",\"0.0\",\"7.0\",\"8.0\",\"4.0\"\n";
        assert_eq!(LandmarkFormat::detect(Some("csv"), text), LandmarkFormat::BigWarp);
        let (l, notes) = parse_bigwarp_with_notes(text, false).unwrap();
        assert_eq!(
            l,
            vec![
                lm(Some("Pt-0"), [10.5, 20.0], [11.0, 21.25], 1.0),
                lm(Some("nucleus"), [-1.0, 0.0], [7.0, 8.0], 1.0)
            ]
        );
        let z = notes.constant_z.unwrap();
        assert_eq!((z.moving, z.fixed, z.rows), (0.0, 4.0, 2));
        assert!(z.to_string().contains("z dropped"), "{z}");
        let (s, _) = parse_bigwarp_with_notes(text, true).unwrap();
        assert_eq!((s[0].src, s[0].dst), ([11.0, 21.25], [10.5, 20.0]));
        // The same table in 2D has no z note.
        let (l2, n2) =
            parse_with_notes(&to_bigwarp(&l, false).unwrap(), LandmarkFormat::BigWarp).unwrap();
        assert_eq!((l2.len(), n2.constant_z), (2, None));
        // Approximations point at the x, y fields of a 3D row.
        let long = "12.3456789012345678901";
        let bw = format!("\"p\",\"true\",\"1\",\"2\",\"0\",\"{long}\",\"4\",\"0\"\n");
        let (_, n) = parse_bigwarp_with_notes(&bw, false).unwrap();
        assert_eq!(n.approximations.len(), 1);
        assert_eq!((n.approximations[0].field, n.approximations[0].text.as_str()), ("dst_x", long));
    }

    /// Issue 20: a 3D table whose z varies is refused at the row that differs.
    #[test]
    fn bigwarp_3d_with_varying_z_is_refused_naming_the_line() {
        let text = "\"a\",\"true\",\"1\",\"2\",\"3\",\"4\",\"5\",\"6\"\n\
                    \"b\",\"true\",\"1\",\"2\",\"3\",\"4\",\"5\",\"6\"\n\
                    \"c\",\"true\",\"1\",\"2\",\"3\",\"4\",\"5\",\"6.5\"\n";
        let e = parse_bigwarp(text, false).unwrap_err().to_string();
        assert!(
            e.starts_with("line 3:") && e.contains("fixed z is 6.5") && e.contains("line 1"),
            "{e}"
        );
        // A row of another width in the same table.
        let mixed = "\"a\",\"true\",\"1\",\"2\",\"3\",\"4\",\"5\",\"6\"\n\"b\",\"true\",\"1\",\"2\",\"3\",\"4\"\n";
        let e = parse_bigwarp(mixed, false).unwrap_err().to_string();
        assert!(e.starts_with("line 2:") && e.contains("either 2D"), "{e}");
    }

    #[test]
    fn bigwarp_round_trip_and_swap() {
        let lms = sample();
        let text = to_bigwarp(&lms, false).unwrap();
        assert!(text.lines().all(|l| l.starts_with('"') && l.contains(",\"true\",")));
        assert!(text.contains("\"Pt-1\""));
        let back = parse_bigwarp(&text, false).unwrap();
        for (a, b) in lms.iter().zip(&back) {
            assert_eq!((a.src, a.dst), (b.src, b.dst));
            assert_eq!(b.weight, 1.0);
        }
        assert_eq!(back[2].name, lms[2].name);
        assert_eq!(back[1].name.as_deref(), Some("Pt-1"));
        let swapped = parse_bigwarp(&to_bigwarp(&lms, true).unwrap(), false).unwrap();
        assert_eq!((swapped[0].src, swapped[0].dst), (lms[0].dst, lms[0].src));
    }
}

//! Landmark files: CSV, Fiji BigWarp tables and JSON (formats in
//! [`crate::fit::landmarks`]), or a pair of point files, sources in one and targets in the
//! other (iBUG `.pts`, ITK point sets, CSV `x,y`: [`crate::fit::landmarks::point_files`]).
//! Reading picks the format from the extension and the content; writing is atomic.

use super::{read_text, write_atomic, IoError};
use crate::fit::landmarks::{
    self, parse_points, Approximation, Landmark, LandmarkError, LandmarkFormat, PointFormat,
    ReadNotes,
};
use std::path::{Path, PathBuf};

/// Errors of landmark files, with the path.
#[derive(Debug, thiserror::Error)]
pub enum LandmarkIoError {
    /// File-system error.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The text is not valid in its format (or the landmarks cannot be written).
    #[error("{path}: {source}")]
    Format {
        /// The file.
        path: PathBuf,
        /// The cause (with the line number for CSV and BigWarp).
        source: LandmarkError,
    },
    /// Two landmarks share a name.
    #[error("{path}: landmarks {first} and {second} are both named `{name}`; give every landmark its own name")]
    Duplicate {
        /// The file.
        path: PathBuf,
        /// The shared name.
        name: String,
        /// Index of the first (0-based, in file order).
        first: usize,
        /// Index of the second.
        second: usize,
    },
    /// A point file (one point set) was given where a landmark file (pairs) is read.
    #[error("{path} is an {} file, one set of points; a landmark file pairs each source with its target (`fit` and `morph` pair two point files: --landmarks-src SRC --landmarks-dst DST)", .format.name())]
    PointFile {
        /// The file.
        path: PathBuf,
        /// Its point-file format.
        format: PointFormat,
    },
    /// The two point files of a pair hold different numbers of points.
    #[error("{src} has {src_count} points and {dst} has {dst_count}: the source and target files must list the same points in the same order")]
    Counts {
        /// The source points' file.
        src: PathBuf,
        /// Its number of points.
        src_count: usize,
        /// The target points' file.
        dst: PathBuf,
        /// Its number of points.
        dst_count: usize,
    },
}

/// Where a command's landmarks come from: one landmark file, or two point files.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LandmarkSource {
    /// A landmark file: CSV, BigWarp or JSON ([`read_landmarks_with_notes`]).
    File(PathBuf),
    /// Sources and targets in two point files ([`read_landmark_pair`]).
    Pair {
        /// The source points (the reference domain).
        src: PathBuf,
        /// The target points (the image).
        dst: PathBuf,
    },
}

impl From<PathBuf> for LandmarkSource {
    fn from(path: PathBuf) -> Self {
        LandmarkSource::File(path)
    }
}

impl std::fmt::Display for LandmarkSource {
    /// The file, or both files (`SRC and DST`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LandmarkSource::File(p) => write!(f, "{}", p.display()),
            LandmarkSource::Pair { src, dst } => {
                write!(f, "{} and {}", src.display(), dst.display())
            }
        }
    }
}

impl LandmarkSource {
    /// The landmarks ([`read_landmarks`] or [`read_landmark_pair`]).
    pub fn read(&self) -> Result<Vec<Landmark>, LandmarkIoError> {
        self.read_with_notes().map(|(l, _)| l)
    }

    /// The landmarks and the notes of reading them ([`read_landmarks_with_notes`]; a pair
    /// has none).
    pub fn read_with_notes(&self) -> Result<(Vec<Landmark>, ReadNotes), LandmarkIoError> {
        match self {
            LandmarkSource::File(p) => read_landmarks_with_notes(p),
            LandmarkSource::Pair { src, dst } => {
                read_landmark_pair(src, dst).map(|l| (l, ReadNotes::default()))
            }
        }
    }
}

/// The format of a point file from its extension and text (see [`PointFormat::detect`]).
pub fn detect_point_format(path: &Path, text: &str) -> PointFormat {
    PointFormat::detect(path.extension().and_then(|e| e.to_str()), text)
}

/// Reads one point file (`-` for standard input), detecting its format, in trimorph's
/// 0-based pixel coordinates (a `.pts` file's 1-based points shifted by -1).
pub fn read_point_file(path: &Path) -> Result<(Vec<[f64; 2]>, PointFormat), LandmarkIoError> {
    let text = read_text(path)?;
    let format = detect_point_format(path, &text);
    let points = parse_points(&text, format)
        .map_err(|source| LandmarkIoError::Format { path: path.to_path_buf(), source })?;
    Ok((points, format))
}

/// Landmarks from two point files: point `i` of `src` (the reference domain) and point `i`
/// of `dst` (the image) make landmark `i`, unnamed, weight 1. Each file is iBUG / menpo
/// `.pts`, an ITK point set or CSV `x,y`, detected on its own ([`read_point_file`]); errors
/// name the file and the line and point. Files with different numbers of points are
/// refused ([`LandmarkIoError::Counts`]).
pub fn read_landmark_pair(src: &Path, dst: &Path) -> Result<Vec<Landmark>, LandmarkIoError> {
    let (s, _) = read_point_file(src)?;
    let (d, _) = read_point_file(dst)?;
    if s.len() != d.len() {
        return Err(LandmarkIoError::Counts {
            src: src.to_path_buf(),
            src_count: s.len(),
            dst: dst.to_path_buf(),
            dst_count: d.len(),
        });
    }
    Ok(s.into_iter()
        .zip(d)
        .map(|(src, dst)| Landmark { name: None, src, dst, weight: 1.0 })
        .collect())
}

/// The format of a landmark file from its extension and text (see
/// [`LandmarkFormat::detect`]).
pub fn detect_format(path: &Path, text: &str) -> LandmarkFormat {
    LandmarkFormat::detect(path.extension().and_then(|e| e.to_str()), text)
}

/// Reads landmarks from `path` (`-` for standard input), detecting the format. Names must
/// be unique (unnamed landmarks are allowed).
pub fn read_landmarks(path: &Path) -> Result<Vec<Landmark>, LandmarkIoError> {
    read_landmarks_noted(path).map(|(l, _)| l)
}

/// [`read_landmarks`], also returning the coordinates whose decimal text an `f64` cannot
/// hold exactly ([`landmarks::parse_noted`]).
pub fn read_landmarks_noted(
    path: &Path,
) -> Result<(Vec<Landmark>, Vec<Approximation>), LandmarkIoError> {
    read_landmarks_with_notes(path).map(|(l, n)| (l, n.approximations))
}

/// [`read_landmarks`] with every note ([`landmarks::parse_with_notes`]): the approximated
/// coordinates and, for a BigWarp 3D table, the constant z that was dropped (a reader shows
/// it as a warning, as `trimorph fit` does).
pub fn read_landmarks_with_notes(
    path: &Path,
) -> Result<(Vec<Landmark>, ReadNotes), LandmarkIoError> {
    let text = read_text(path)?;
    let format = detect_format(path, &text);
    let points = detect_point_format(path, &text);
    if format == LandmarkFormat::Csv && points != PointFormat::Csv {
        return Err(LandmarkIoError::PointFile { path: path.to_path_buf(), format: points });
    }
    let (lms, notes) = landmarks::parse_with_notes(&text, format)
        .map_err(|source| LandmarkIoError::Format { path: path.to_path_buf(), source })?;
    unique_names(path, &lms)?;
    Ok((lms, notes))
}

/// Refuses two landmarks with the same name.
fn unique_names(path: &Path, lms: &[Landmark]) -> Result<(), LandmarkIoError> {
    let mut seen = std::collections::HashMap::new();
    for (i, l) in lms.iter().enumerate() {
        if let Some(name) = &l.name {
            if let Some(first) = seen.insert(name.as_str(), i) {
                return Err(LandmarkIoError::Duplicate {
                    path: path.to_path_buf(),
                    name: name.clone(),
                    first,
                    second: i,
                });
            }
        }
    }
    Ok(())
}

/// [`read_landmarks`] keeping a BigWarp table's inactive rows: every landmark with its
/// active flag ([`landmarks::parse_bigwarp_flagged`]); CSV and JSON landmarks are all
/// active.
pub fn read_landmarks_flagged(path: &Path) -> Result<Vec<(Landmark, bool)>, LandmarkIoError> {
    let text = read_text(path)?;
    if detect_format(path, &text) != LandmarkFormat::BigWarp {
        return Ok(read_landmarks(path)?.into_iter().map(|l| (l, true)).collect());
    }
    let rows = landmarks::parse_bigwarp_flagged(&text, false)
        .map_err(|source| LandmarkIoError::Format { path: path.to_path_buf(), source })?;
    let lms: Vec<Landmark> = rows.iter().map(|(l, _)| l.clone()).collect();
    unique_names(path, &lms)?;
    Ok(rows)
}

/// Writes landmarks with active flags (`active[i]` for `lms[i]`): a BigWarp table keeps
/// every row with its flag ([`landmarks::to_bigwarp_flagged`]); CSV and JSON, which have
/// no flag, get the active landmarks only (what a fit of that file uses). Atomic.
pub fn write_landmarks_flagged(
    path: &Path,
    lms: &[Landmark],
    active: &[bool],
    format: LandmarkFormat,
) -> Result<(), LandmarkIoError> {
    let fmt = |source| LandmarkIoError::Format { path: path.to_path_buf(), source };
    let text = match format {
        LandmarkFormat::BigWarp => {
            landmarks::to_bigwarp_flagged(lms, active, false).map_err(fmt)?
        }
        _ => {
            let on: Vec<Landmark> = lms
                .iter()
                .enumerate()
                .filter(|(i, _)| active.get(*i).copied().unwrap_or(true))
                .map(|(_, l)| l.clone())
                .collect();
            landmarks::to_string(&on, format).map_err(fmt)?
        }
    };
    write_atomic(path, text.as_bytes())?;
    Ok(())
}

/// Writes landmarks to `path` in `format`, atomically (nothing is written when a landmark
/// is invalid).
pub fn write_landmarks(
    path: &Path,
    lms: &[Landmark],
    format: LandmarkFormat,
) -> Result<(), LandmarkIoError> {
    let text = landmarks::to_string(lms, format)
        .map_err(|source| LandmarkIoError::Format { path: path.to_path_buf(), source })?;
    write_atomic(path, text.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<Landmark> {
        vec![
            Landmark { name: Some("a".into()), src: [1.5, 2.0], dst: [3.0, 4.25], weight: 2.0 },
            Landmark { name: None, src: [0.1, 0.2], dst: [0.3, 0.4], weight: 1.0 },
        ]
    }

    /// The editor's flags: BigWarp keeps an inactive row with its flag; CSV and JSON,
    /// without a flag column, get the active rows only.
    #[test]
    fn flagged_files_keep_flags_in_bigwarp_and_active_rows_elsewhere() {
        let dir = tempfile::tempdir().unwrap();
        let flags = [true, false];
        for (file, f) in [
            ("l.csv", LandmarkFormat::Csv),
            ("bw.csv", LandmarkFormat::BigWarp),
            ("l.json", LandmarkFormat::Json),
        ] {
            let p = dir.path().join(file);
            write_landmarks_flagged(&p, &sample(), &flags, f).unwrap();
            let back = read_landmarks_flagged(&p).unwrap();
            let want = if f == LandmarkFormat::BigWarp { 2 } else { 1 };
            assert_eq!(back.len(), want, "{file}");
            assert_eq!(
                (back[0].0.src, back[0].0.dst, back[0].1),
                (sample()[0].src, sample()[0].dst, true)
            );
            if f == LandmarkFormat::BigWarp {
                assert_eq!((back[1].0.src, back[1].1), (sample()[1].src, false), "{file}");
                assert_eq!(read_landmarks(&p).unwrap().len(), 1, "fit reads the active row only");
            }
        }
    }

    #[test]
    fn files_round_trip_in_every_format() {
        let dir = tempfile::tempdir().unwrap();
        for (file, f) in [
            ("l.csv", LandmarkFormat::Csv),
            ("bw.csv", LandmarkFormat::BigWarp),
            ("l.json", LandmarkFormat::Json),
        ] {
            let p = dir.path().join(file);
            write_landmarks(&p, &sample(), f).unwrap();
            let back = read_landmarks(&p).unwrap();
            assert_eq!(back.len(), 2);
            for (a, b) in sample().iter().zip(&back) {
                assert_eq!((a.src, a.dst), (b.src, b.dst), "{file}");
            }
            if f != LandmarkFormat::BigWarp {
                assert_eq!(back, sample(), "{file}");
            }
        }
    }

    #[test]
    fn point_files_pair_into_landmarks() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.pts");
        let b = dir.path().join("b.txt");
        let c = dir.path().join("c.csv");
        std::fs::write(&a, "version: 1\nn_points: 3\n{\n1 1\n11 21.5\n31 5\n}\n").unwrap();
        std::fs::write(&b, "point\n3\n2 3\n12 22\n33 6\n").unwrap();
        std::fs::write(&c, "x,y\n2,3\n12,22\n").unwrap();
        let l = read_landmark_pair(&a, &b).unwrap();
        let lm = |src, dst| Landmark { name: None, src, dst, weight: 1.0 };
        assert_eq!(
            l,
            vec![
                lm([0.0, 0.0], [2.0, 3.0]),
                lm([10.0, 20.5], [12.0, 22.0]),
                lm([30.0, 4.0], [33.0, 6.0])
            ]
        );
        let pair = LandmarkSource::Pair { src: a.clone(), dst: b.clone() };
        assert_eq!(pair.read().unwrap(), l);
        assert_eq!(pair.to_string(), format!("{} and {}", a.display(), b.display()));
        assert_eq!(read_point_file(&a).unwrap().1, PointFormat::Pts);
        assert_eq!(read_point_file(&b).unwrap().1, PointFormat::Itk);
        assert_eq!(read_point_file(&c).unwrap().1, PointFormat::Csv);
        // Different counts name both files and both counts.
        let e = read_landmark_pair(&a, &c).unwrap_err();
        assert!(matches!(e, LandmarkIoError::Counts { src_count: 3, dst_count: 2, .. }), "{e}");
        let e = e.to_string();
        assert!(e.contains("a.pts has 3 points and ") && e.contains("c.csv has 2"), "{e}");
        // A malformed file is named with its line and point.
        std::fs::write(&b, "point\n3\n2 3\n12\n33 6\n").unwrap();
        let e = read_landmark_pair(&a, &b).unwrap_err().to_string();
        assert!(e.contains("b.txt: line 4: point 1: expected two numbers"), "{e}");
        // A point file given as a landmark file says how to give it.
        for p in [&a, &b] {
            let e = read_landmarks(p).unwrap_err();
            assert!(matches!(e, LandmarkIoError::PointFile { .. }), "{e}");
            assert!(e.to_string().contains("--landmarks-src SRC --landmarks-dst DST"), "{e}");
        }
        let e = read_landmark_pair(&a, &dir.path().join("none.pts")).unwrap_err();
        assert!(matches!(e, LandmarkIoError::Io(IoError::Read { .. })), "{e}");
    }

    #[test]
    fn errors_carry_the_path_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.csv");
        std::fs::write(&p, "a,1,2,3,4\nb,1,2\n").unwrap();
        let e = read_landmarks(&p).unwrap_err().to_string();
        assert!(e.contains("bad.csv") && e.contains("line 2"), "{e}");
        assert!(matches!(
            read_landmarks(&dir.path().join("missing.csv")),
            Err(LandmarkIoError::Io(IoError::Read { .. }))
        ));
        let bad = [Landmark { name: None, src: [f64::NAN, 0.0], dst: [0.0; 2], weight: 1.0 }];
        let q = dir.path().join("out.csv");
        assert!(write_landmarks(&q, &bad, LandmarkFormat::Csv).is_err());
        assert!(!q.exists());
    }
}

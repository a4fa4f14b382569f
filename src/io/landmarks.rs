//! Landmark files: CSV, Fiji BigWarp tables and JSON (formats in
//! [`crate::fit::landmarks`]). Reading picks the format from the extension and the content;
//! writing is atomic.

use super::{read_text, write_atomic, IoError};
use crate::fit::landmarks::{
    self, Approximation, Landmark, LandmarkError, LandmarkFormat, ReadNotes,
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
    let (lms, notes) = landmarks::parse_with_notes(&text, format)
        .map_err(|source| LandmarkIoError::Format { path: path.to_path_buf(), source })?;
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
    Ok((lms, notes))
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

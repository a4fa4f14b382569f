//! The inputs of a morph read from files and the morph made from them (the first half of
//! `trimorph morph`; [`crate::jobs::morph::MorphJob`] then writes its files):
//!
//! * the two images (the first page of each, read in parallel);
//! * the maps' source ([`MorphSource`]): landmark pairs (a landmark file, or two point
//!   files), both maps fitted; or the given deformations `phi_ab` (with the similarity it
//!   stores, [`SIMILARITY_KEY`], when B is aligned) and optionally `phi_ba`;
//! * the options as plain values ([`MorphSettings`], the flags of `trimorph morph`, also
//!   behind Python's `trimorph.morph`), checked against the images
//!   ([`MorphSettings::check`]) and turned into [`MorphOptions`].
//!
//! What the fits found (their summaries, the landmarks they missed, crossing pairs, the
//! alignment) comes back as data ([`MorphNote`]), whose text is the line the command line
//! prints. Errors ([`MorphInputError`]) name the file and the image or key at fault.

use crate::fit::{Bend, FitOptions};
use crate::io::deformation::{self, DeformationError};
use crate::io::landmarks::{LandmarkIoError, LandmarkSource};
use crate::io::raster::{read_stack, RasterError};
use crate::io::{read_text, IoError};
use crate::morph::align::{AlignError, Similarity, SIMILARITY_KEY};
use crate::morph::fits::{MapSummary, MISS_TOLERANCE, PIN_PREFIX};
use crate::morph::{check_background, check_cells, Morph, MorphError, MorphOptions, Schedule};
use crate::spline::Spline;
use crate::timing::Phases;
use crate::warp::{EdgeMode, Interp};
use image::DynamicImage;
use std::path::{Path, PathBuf};

/// Where a morph's two maps come from.
#[derive(Clone, Debug)]
pub enum MorphSource {
    /// Landmark pairs (`src` in A, `dst` in B): both maps are fitted to them.
    Landmarks(LandmarkSource),
    /// Given deformations: `phi_ab` maps A's pixels to B's (e.g. a morph's `phi_ab.json`,
    /// whose stored similarity aligns B again); `phi_ba` maps B's pixels to A's (default:
    /// fitted to samples of `phi_ab` on a grid mesh of [`MorphSettings::cells`]).
    Deformations {
        /// The deformation A -> B.
        phi_ab: PathBuf,
        /// The deformation B -> A.
        phi_ba: Option<PathBuf>,
    },
}

/// The options of a morph as plain values: the flags of `trimorph morph` (`--shape --color
/// --interp --cells --no-align --background --pin-frame --mode --bend --hard`). The
/// defaults are [`MorphOptions::default`]'s.
#[derive(Clone, Debug, PartialEq)]
pub struct MorphSettings {
    /// `alpha_shape` ([`MorphOptions::shape`]).
    pub shape: Schedule,
    /// `alpha_color` ([`MorphOptions::color`]).
    pub color: Schedule,
    /// Resampling.
    pub interp: Interp,
    /// Cells per side of the grid mesh over B for a fitted `phi_ba` (1 to
    /// [`crate::morph::MAX_CELLS`]).
    pub cells: usize,
    /// Bring B into A's frame by a similarity.
    pub align: bool,
    /// Value of every channel where neither image has a preimage, in the working type's
    /// sample units.
    pub background: f64,
    /// Keep A's frame border still.
    pub pin_frame: bool,
    /// What shows where neither image has a preimage.
    pub mode: EdgeMode,
    /// The fits' bending weight (`None`: the morph's own, interpolating).
    pub bend: Option<Bend>,
    /// The landmarks are hard constraints of both fits.
    pub hard: bool,
}

impl Default for MorphSettings {
    fn default() -> MorphSettings {
        let d = MorphOptions::default();
        MorphSettings {
            shape: d.shape,
            color: d.color,
            interp: d.interp,
            cells: d.cells,
            align: d.align,
            background: d.background,
            pin_frame: d.pin_frame,
            mode: d.mode,
            bend: None,
            hard: d.fit.hard,
        }
    }
}

impl MorphSettings {
    /// The morph's options: [`MorphOptions::default`] with these values.
    pub fn options(&self) -> MorphOptions {
        let d = MorphOptions::default();
        let fit = FitOptions { bend: self.bend.unwrap_or(d.fit.bend), hard: self.hard, ..d.fit };
        MorphOptions {
            shape: self.shape,
            color: self.color,
            interp: self.interp,
            cells: self.cells,
            align: self.align,
            background: self.background,
            pin_frame: self.pin_frame,
            mode: self.mode,
            fit,
            ..d
        }
    }

    /// Checks the values against the two images before anything is fitted: the cell count
    /// ([`check_cells`]) and the background, a sample of the type the morph works in
    /// ([`check_background`]).
    pub fn check(&self, a: &DynamicImage, b: &DynamicImage) -> Result<(), MorphError> {
        check_cells(self.cells)?;
        check_background(self.background, a, b)
    }
}

/// Why a morph's inputs cannot be read or the morph cannot be made from them.
#[derive(Debug, thiserror::Error)]
pub enum MorphInputError {
    /// An image cannot be read.
    #[error("cannot read image {which} {}", path.display())]
    Image {
        /// `A` or `B`.
        which: char,
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: RasterError,
    },
    /// An image file holds no page.
    #[error("image {which} has no pages")]
    NoPages {
        /// `A` or `B`.
        which: char,
        /// The file.
        path: PathBuf,
    },
    /// The landmarks cannot be read.
    #[error("cannot read landmarks {landmarks}")]
    Landmarks {
        /// The landmark file(s) (boxed: the error stays small).
        landmarks: Box<LandmarkSource>,
        /// The cause.
        #[source]
        source: LandmarkIoError,
    },
    /// No morph through these landmarks (too few, outside an image, a fit that fails).
    #[error("landmarks {landmarks}")]
    Fit {
        /// The landmark file(s) (boxed: the error stays small).
        landmarks: Box<LandmarkSource>,
        /// The cause.
        #[source]
        source: MorphError,
    },
    /// A deformation file cannot be read (the error names it).
    #[error(transparent)]
    Read(IoError),
    /// A deformation file is not a deformation.
    #[error("cannot read deformation {}", path.display())]
    Deformation {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: DeformationError,
    },
    /// A deformation file is not JSON (read for its stored similarity).
    #[error("cannot read deformation {}", path.display())]
    DeformationJson {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: serde_json::Error,
    },
    /// The similarity stored in `phi_ab` ([`SIMILARITY_KEY`]) is malformed.
    #[error("{}: key {SIMILARITY_KEY}", path.display())]
    Similarity {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: AlignError,
    },
    /// The settings do not suit the images, or no morph through the given deformations.
    #[error(transparent)]
    Morph(#[from] MorphError),
}

/// Something the making of a morph found, as data; its text ([`std::fmt::Display`]) is the
/// line `trimorph morph` prints (without `--quiet`).
#[derive(Clone, Debug, PartialEq)]
pub enum MorphNote {
    /// A fit's summary (`dir` is `A->B` or `B->A`).
    Fit {
        /// The map.
        dir: &'static str,
        /// What the fit found.
        summary: MapSummary,
    },
    /// Landmarks missed by more than [`MISS_TOLERANCE`] px (name and residual, largest
    /// first; the border points of `pin_frame` left out) by a fit where no pair crosses.
    Missed {
        /// The map.
        dir: &'static str,
        /// The landmarks missed.
        misses: Vec<(String, f64)>,
    },
    /// Landmark pairs that cross: the fit stays fold-free and misses them.
    Crossing {
        /// The map.
        dir: &'static str,
        /// The crossing pairs.
        pairs: Vec<[String; 2]>,
        /// The fit's largest landmark residual, px.
        largest_residual: f64,
    },
    /// The similarity aligning B was read from the given `phi_ab`.
    SimilarityRead {
        /// The deformation file.
        file: PathBuf,
    },
    /// The given `phi_ab` covers only this share of A.
    Coverage {
        /// The deformation file.
        file: PathBuf,
        /// The share of A's pixels (sampled) in its domain, below 1.
        coverage: f64,
    },
    /// B is brought into A's frame by this similarity.
    Aligned {
        /// The similarity.
        similarity: Similarity,
    },
    /// B keeps its raw pixel coordinates.
    NotAligned,
}

impl MorphNote {
    /// Whether the note is a warning (its line starts with `warning:`).
    pub fn is_warning(&self) -> bool {
        matches!(self, MorphNote::Missed { .. } | MorphNote::Crossing { .. })
    }

    /// The notes of a fit: its summary, then the landmarks it missed (when no pair crosses)
    /// or the pairs that cross.
    fn of_fit(dir: &'static str, f: &MapSummary) -> Vec<MorphNote> {
        let mut out = vec![MorphNote::Fit { dir, summary: f.clone() }];
        let real: Vec<(String, f64)> =
            f.misses.iter().filter(|(n, _)| !n.starts_with(PIN_PREFIX)).cloned().collect();
        if !real.is_empty() && f.conflicts.is_empty() {
            out.push(MorphNote::Missed { dir, misses: real });
        }
        if !f.conflicts.is_empty() {
            out.push(MorphNote::Crossing {
                dir,
                pairs: f.conflicts.clone(),
                largest_residual: f.max_residual,
            });
        }
        out
    }
}

impl std::fmt::Display for MorphNote {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MorphNote::Fit { dir, summary: s } => write!(
                f,
                "fit {dir}: {} triangles, margin {} px, largest residual {:.3} px, certified \
                 fold-free (det J >= {}){}",
                s.triangles,
                s.margin,
                s.max_residual,
                crate::fit::report::det_text(s.det_j_lower_bound),
                if s.covers_frame { ", covers A's frame" } else { "" }
            ),
            MorphNote::Missed { dir, misses } => {
                let shown: Vec<String> =
                    misses.iter().take(5).map(|(n, r)| format!("{n} ({r:.2} px)")).collect();
                write!(
                    f,
                    "warning: fit {dir}: {} landmark(s) missed by more than {MISS_TOLERANCE} \
                     px: {}{}; the fits interpolate unless --bend smooths them or meeting them \
                     exactly would fold the map (the fold barrier keeps it fold-free); check \
                     them, or use --hard to force them (refused if the map then folds)",
                    misses.len(),
                    shown.join(", "),
                    if misses.len() > 5 { ", ..." } else { "" }
                )
            }
            MorphNote::Crossing { dir, pairs, largest_residual } => {
                let pairs: Vec<String> =
                    pairs.iter().map(|[x, y]| format!("{x} and {y}")).collect();
                write!(
                    f,
                    "warning: fit {dir}: these landmark pairs cross, so following them would \
                     fold the map; the morph stays fold-free and misses them (largest residual \
                     {largest_residual:.2} px): {}",
                    pairs.join(", ")
                )
            }
            MorphNote::SimilarityRead { file } => {
                write!(f, "similarity read from {} ({SIMILARITY_KEY})", file.display())
            }
            MorphNote::Coverage { file, coverage } => write!(
                f,
                "note: {} covers {:.1}% of A; the rest of A has no preimage in any frame",
                file.display(),
                100.0 * coverage
            ),
            MorphNote::Aligned { similarity } => {
                write!(f, "B aligned to A by the similarity: {similarity}")
            }
            MorphNote::NotAligned => write!(f, "B kept in its raw pixel coordinates (--no-align)"),
        }
    }
}

/// The images, the maps' source and the options of a morph.
#[derive(Clone, Debug)]
pub struct MorphInputs {
    /// Image A (the first frame; its first page).
    pub a: PathBuf,
    /// Image B (the last frame; its first page).
    pub b: PathBuf,
    /// Where the maps come from.
    pub source: MorphSource,
    /// The options.
    pub settings: MorphSettings,
}

/// A morph made from its inputs, with what making it found.
pub struct MadeMorph {
    /// The morph.
    pub morph: Morph,
    /// The fits' summaries and warnings, then how B is aligned, in the order printed.
    pub notes: Vec<MorphNote>,
    /// Whether the maps were fitted to landmarks.
    pub from_landmarks: bool,
    /// Wall time so far: `read` (the images), `fits` (the landmarks or deformations read and
    /// the maps made).
    pub phases: Phases,
}

/// The first page of the image `path` (`which`: `A` or `B`).
pub fn first_page(path: &Path, which: char) -> Result<DynamicImage, MorphInputError> {
    let stack = read_stack(path).map_err(|source| MorphInputError::Image {
        which,
        path: path.to_path_buf(),
        source,
    })?;
    stack
        .pages
        .into_iter()
        .next()
        .ok_or_else(|| MorphInputError::NoPages { which, path: path.to_path_buf() })
}

/// Reads the deformation file `path`: the spline and the file's text.
fn read_spline(path: &Path) -> Result<(Spline, String), MorphInputError> {
    let text = read_text(path).map_err(MorphInputError::Read)?;
    let (s, _) = deformation::from_str(&text)
        .map_err(|source| MorphInputError::Deformation { path: path.to_path_buf(), source })?;
    Ok((s, text))
}

/// The similarity stored in a deformation file's [`SIMILARITY_KEY`], if it has one (`text`
/// is the file's text).
pub fn stored_similarity(text: &str, path: &Path) -> Result<Option<Similarity>, MorphInputError> {
    let doc: serde_json::Value = serde_json::from_str(text)
        .map_err(|source| MorphInputError::DeformationJson { path: path.to_path_buf(), source })?;
    doc.get(SIMILARITY_KEY)
        .map(Similarity::from_json)
        .transpose()
        .map_err(|source| MorphInputError::Similarity { path: path.to_path_buf(), source })
}

impl MorphInputs {
    /// Reads the images (the first page of each), checks the settings against them, reads
    /// the landmarks or the deformations and makes the morph (module docs).
    pub fn make(&self) -> Result<MadeMorph, MorphInputError> {
        let mut phases = Phases::new();
        let (img_a, img_b) = rayon::join(|| first_page(&self.a, 'A'), || first_page(&self.b, 'B'));
        let (img_a, img_b) = (img_a?, img_b?);
        phases.mark("read");
        let s = &self.settings;
        s.check(&img_a, &img_b)?;
        let opts = s.options();
        let mut notes = Vec::new();
        let morph = match &self.source {
            MorphSource::Landmarks(l) => {
                let lms = l.read().map_err(|source| MorphInputError::Landmarks {
                    landmarks: Box::new(l.clone()),
                    source,
                })?;
                let m = Morph::new(&img_a, &img_b, &lms, &opts).map_err(|source| {
                    MorphInputError::Fit { landmarks: Box::new(l.clone()), source }
                })?;
                if let Some([ab, ba]) = m.fit_summaries() {
                    notes.extend(MorphNote::of_fit("A->B", ab));
                    notes.extend(MorphNote::of_fit("B->A", ba));
                }
                m
            }
            MorphSource::Deformations { phi_ab, phi_ba } => {
                let (ab, text) = read_spline(phi_ab)?;
                let stored = if s.align { stored_similarity(&text, phi_ab)? } else { None };
                drop(text);
                let ba = phi_ba.as_deref().map(|p| read_spline(p).map(|(s, _)| s)).transpose()?;
                let given = stored.is_some();
                let m = Morph::from_deformations_with(&img_a, &img_b, ab, ba, stored, &opts)?;
                if given {
                    notes.push(MorphNote::SimilarityRead { file: phi_ab.clone() });
                }
                let coverage = m.coverage();
                if coverage < 1.0 {
                    notes.push(MorphNote::Coverage { file: phi_ab.clone(), coverage });
                }
                m
            }
        };
        notes.push(if s.align {
            MorphNote::Aligned { similarity: morph.similarity().clone() }
        } else {
            MorphNote::NotAligned
        });
        phases.mark("fits");
        let from_landmarks = matches!(self.source, MorphSource::Landmarks(_));
        Ok(MadeMorph { morph, notes, from_landmarks, phases })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gray(w: u32, h: u32) -> DynamicImage {
        DynamicImage::ImageLuma8(image::GrayImage::from_fn(w, h, |x, y| {
            image::Luma([((x * 7 + y * 3) % 256) as u8])
        }))
    }

    fn inputs(dir: &Path, source: MorphSource) -> MorphInputs {
        MorphInputs {
            a: dir.join("a.png"),
            b: dir.join("b.png"),
            source,
            settings: MorphSettings::default(),
        }
    }

    fn landmarks(dir: &Path) -> MorphSource {
        MorphSource::Landmarks(LandmarkSource::File(dir.join("l.csv")))
    }

    fn write_images(dir: &Path) {
        gray(40, 30).save(dir.join("a.png")).unwrap();
        gray(36, 32).save(dir.join("b.png")).unwrap();
    }

    #[test]
    fn settings_default_to_the_morph_options_and_set_bend_and_hard() {
        assert_eq!(MorphSettings::default().options(), MorphOptions::default());
        let s = MorphSettings {
            bend: Some(Bend::Weight(0.5)),
            hard: true,
            cells: 3,
            ..Default::default()
        };
        let o = s.options();
        assert_eq!(o.fit.bend, Bend::Weight(0.5));
        assert!(o.fit.hard);
        assert_eq!(o.cells, 3);
        assert_eq!(
            FitOptions { bend: MorphOptions::default().fit.bend, hard: false, ..o.fit.clone() },
            MorphOptions::default().fit
        );
        let e = MorphSettings { cells: 0, ..Default::default() }.check(&gray(4, 4), &gray(4, 4));
        assert!(matches!(e, Err(MorphError::Cells(0))));
        let e = MorphSettings { background: 300.0, ..Default::default() }
            .check(&gray(4, 4), &gray(4, 4));
        assert!(matches!(e, Err(MorphError::Background(_))), "{e:?}");
    }

    #[test]
    fn input_errors_name_the_file_and_the_image_or_key() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // Image A missing: named A and by its path.
        let e = inputs(d, landmarks(d)).make().err().unwrap();
        let a = d.join("a.png");
        assert!(matches!(&e, MorphInputError::Image { which: 'A', path, .. } if *path == a));
        assert_eq!(e.to_string(), format!("cannot read image A {}", a.display()));
        // Image B not an image.
        gray(40, 30).save(&a).unwrap();
        std::fs::write(d.join("b.png"), "not a png").unwrap();
        let e = inputs(d, landmarks(d)).make().err().unwrap();
        assert!(matches!(&e, MorphInputError::Image { which: 'B', .. }), "{e:?}");
        write_images(d);
        // The landmark file missing.
        let e = inputs(d, landmarks(d)).make().err().unwrap();
        assert!(matches!(&e, MorphInputError::Landmarks { .. }), "{e:?}");
        assert_eq!(e.to_string(), format!("cannot read landmarks {}", d.join("l.csv").display()));
        // A landmark outside B: the morph's error, under the landmark file's name.
        std::fs::write(d.join("l.csv"), "p,1,1,2,2\nq,30,2,28,3\nr,5,20,6,90\n").unwrap();
        let e = inputs(d, landmarks(d)).make().err().unwrap();
        let MorphInputError::Fit { source, .. } = &e else { panic!("{e:?}") };
        assert!(matches!(source, MorphError::OutsideImage { index: 2, image: 'B', .. }));
        assert_eq!(e.to_string(), format!("landmarks {}", d.join("l.csv").display()));
        // A --phi-ab that is not a deformation, and one that is missing.
        let def = d.join("def.json");
        std::fs::write(&def, "[1, 2]").unwrap();
        let given =
            |phi_ba: Option<PathBuf>| MorphSource::Deformations { phi_ab: def.clone(), phi_ba };
        let e = inputs(d, given(None)).make().err().unwrap();
        assert!(matches!(&e, MorphInputError::Deformation { path, .. } if *path == def));
        assert_eq!(e.to_string(), format!("cannot read deformation {}", def.display()));
        std::fs::remove_file(&def).unwrap();
        let e = inputs(d, given(None)).make().err().unwrap();
        assert!(matches!(&e, MorphInputError::Read(IoError::Read { path, .. }) if *path == def));
        // Settings refused before anything is fitted.
        let mut i = inputs(d, landmarks(d));
        i.settings.background = 256.0;
        assert!(matches!(i.make(), Err(MorphInputError::Morph(MorphError::Background(_)))));
    }

    #[test]
    fn a_stored_similarity_is_read_back_or_its_key_named() {
        let p = Path::new("phi.json");
        assert!(stored_similarity("{}", p).unwrap().is_none());
        let sim = Similarity::identity();
        let text = serde_json::json!({ SIMILARITY_KEY: sim.to_json() }).to_string();
        assert_eq!(stored_similarity(&text, p).unwrap(), Some(sim));
        let e =
            stored_similarity(&format!(r#"{{"{SIMILARITY_KEY}": {{"a": 1}}}}"#), p).unwrap_err();
        assert!(matches!(e, MorphInputError::Similarity { .. }));
        assert_eq!(e.to_string(), format!("phi.json: key {SIMILARITY_KEY}"));
    }

    #[test]
    fn a_landmark_morph_notes_both_fits_then_the_alignment() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        write_images(d);
        std::fs::write(d.join("l.csv"), "p,5,5,6,5\nq,30,6,29,7\nr,8,22,8,24\ns,28,24,27,25\n")
            .unwrap();
        let made = inputs(d, landmarks(d)).make().unwrap();
        assert!(made.from_landmarks);
        let kinds: Vec<&MorphNote> = made.notes.iter().filter(|n| !n.is_warning()).collect();
        assert!(
            matches!(
                kinds[..],
                [
                    MorphNote::Fit { dir: "A->B", .. },
                    MorphNote::Fit { dir: "B->A", .. },
                    MorphNote::Aligned { .. }
                ]
            ),
            "{kinds:?}"
        );
        assert!(made.notes[0].to_string().starts_with("fit A->B: "));
        assert!(made.notes.last().unwrap().to_string().starts_with("B aligned to A by"));
        let phases: Vec<&str> = made.phases.rows().iter().map(|r| r.0).collect();
        assert_eq!(phases, ["read", "fits"]);
    }

    #[test]
    fn notes_print_the_command_lines_texts() {
        let missed = MorphNote::Missed {
            dir: "A->B",
            misses: (0..6).map(|k| (format!("m{k}"), 0.5)).collect(),
        };
        assert!(missed.is_warning());
        assert!(missed.to_string().starts_with(
            "warning: fit A->B: 6 landmark(s) missed by more than 0.1 px: m0 (0.50 px), m1 \
             (0.50 px), m2 (0.50 px), m3 (0.50 px), m4 (0.50 px), ...; the fits interpolate"
        ));
        let cross = MorphNote::Crossing {
            dir: "B->A",
            pairs: vec![["1 (a)".into(), "2 (b)".into()]],
            largest_residual: 1.234,
        };
        assert!(cross.to_string().ends_with("(largest residual 1.23 px): 1 (a) and 2 (b)"));
        let cov = MorphNote::Coverage { file: "d.json".into(), coverage: 0.5 };
        assert_eq!(
            cov.to_string(),
            "note: d.json covers 50.0% of A; the rest of A has no preimage in any frame"
        );
        assert_eq!(
            MorphNote::NotAligned.to_string(),
            "B kept in its raw pixel coordinates (--no-align)"
        );
    }
}

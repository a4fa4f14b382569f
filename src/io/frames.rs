//! The frames of a sequence fit ([`crate::fit::sequence`]) from files: a folder of images
//! (sorted by file name, each named by its stem) or a (multi-page) TIFF (pages named
//! `<stem>_000`, `<stem>_001`, ...). Sizes are checked before decoding
//! ([`crate::io::raster::read_stack`]). Also the other inputs of a sequence: the scene's
//! model and the landmarks of every frame ([`read_targets`]).

use super::landmarks::{read_landmarks, LandmarkIoError};
use super::model::{load_model_up, ModelIoError, UpAxis};
use super::raster::{read_stack, RasterError};
use super::{read_text, IoError};
use crate::fit::landmarks::Landmark;
use crate::fit::sequence::{Anchor, Frame, Targets};
use crate::fit::track::TrackOptions;
use crate::prism::Model;
use std::path::{Path, PathBuf};

/// Why the frames could not be read.
#[derive(Debug, thiserror::Error)]
pub enum FramesError {
    /// The folder cannot be listed.
    #[error("cannot list {}: {source}", path.display())]
    List {
        /// The folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The folder holds no image file.
    #[error("no image files (png, tif, jpg, pgm, ppm, pbm, pam, pnm) in {}", path.display())]
    Empty {
        /// The folder.
        path: PathBuf,
    },
    /// A frame file of a folder cannot be read.
    #[error("cannot read frame {}: {source}", path.display())]
    Frame {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: RasterError,
    },
    /// The stack cannot be read.
    #[error("cannot read frames {}: {source}", path.display())]
    Stack {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: RasterError,
    },
}

/// The frames of a folder or a stack, and whether each is float gray (held as RGB float,
/// to be written back as gray).
pub fn read_frames(path: &Path) -> Result<(Vec<Frame>, Vec<bool>), FramesError> {
    let mut frames = Vec::new();
    let mut gray_float = Vec::new();
    if path.is_dir() {
        let list_err = |source| FramesError::List { path: path.to_path_buf(), source };
        let mut files: Vec<PathBuf> = std::fs::read_dir(path)
            .map_err(list_err)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                matches!(
                    p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(),
                    Some(
                        "png"
                            | "tif"
                            | "tiff"
                            | "jpg"
                            | "jpeg"
                            | "pgm"
                            | "ppm"
                            | "pbm"
                            | "pam"
                            | "pnm"
                    )
                )
            })
            .collect();
        files.sort();
        if files.is_empty() {
            return Err(FramesError::Empty { path: path.to_path_buf() });
        }
        for f in &files {
            let mut stack =
                read_stack(f).map_err(|source| FramesError::Frame { path: f.clone(), source })?;
            let img = stack.pages.swap_remove(0);
            let stem = f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            frames.push(Frame::new(stem, f.display().to_string(), img));
            gray_float.push(stack.gray_float);
        }
    } else {
        let stack = read_stack(path)
            .map_err(|source| FramesError::Stack { path: path.to_path_buf(), source })?;
        let base = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        for (i, p) in stack.pages.into_iter().enumerate() {
            frames.push(Frame::new(
                format!("{base}_{i:03}"),
                format!("{}, page {i}", path.display()),
                p,
            ));
            gray_float.push(stack.gray_float);
        }
    }
    Ok((frames, gray_float))
}

/// Why a sequence's landmarks or model could not be read.
#[derive(Debug, thiserror::Error)]
pub enum InputsError {
    /// A folder of per-frame landmarks has no file for a frame.
    #[error("no landmarks for frame {frame} in {}", dir.display())]
    NoLandmarks {
        /// The frame's name.
        frame: String,
        /// The folder.
        dir: PathBuf,
    },
    /// A per-frame landmark file cannot be read.
    #[error("cannot read {}: {source}", path.display())]
    FrameLandmarks {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: LandmarkIoError,
    },
    /// The landmark file cannot be read.
    #[error("cannot read landmarks {}: {source}", path.display())]
    Landmarks {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: LandmarkIoError,
    },
    /// The scene cannot be read.
    #[error(transparent)]
    Scene(#[from] IoError),
    /// The scene is not JSON.
    #[error(transparent)]
    SceneJson(#[from] serde_json::Error),
    /// The scene's recorded up axis is not `x`, `y` or `z`.
    #[error("{}: {message}", path.display())]
    SceneUp {
        /// The scene.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The model cannot be read.
    #[error("cannot load model {}: {source}", path.display())]
    Model {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: ModelIoError,
    },
}

/// The model of a scene: `explicit`, else the scene file's `"model"` key (a path relative
/// to the scene's folder); `None` when there is neither. The model is loaded turned by the
/// up axis the scene records ([`UpAxis::of_scene`]), which is returned with it.
pub fn scene_model(
    scene: &Path,
    explicit: Option<&Path>,
) -> Result<Option<(PathBuf, Model, UpAxis)>, InputsError> {
    let v: serde_json::Value = crate::json::parse(&read_text(scene)?)?;
    let up = UpAxis::of_scene(&v)
        .map_err(|message| InputsError::SceneUp { path: scene.to_path_buf(), message })?;
    let path = match explicit {
        Some(p) => Some(p.to_path_buf()),
        None => v.get("model").and_then(|m| m.as_str()).map(|m| {
            let p = PathBuf::from(m);
            if p.is_absolute() {
                p
            } else {
                scene.parent().unwrap_or(Path::new(".")).join(p)
            }
        }),
    };
    match path {
        None => Ok(None),
        Some(p) => match load_model_up(&p, up) {
            Ok(m) => Ok(Some((p, m, up))),
            Err(source) => Err(InputsError::Model { path: p, source }),
        },
    }
}

/// Landmarks named like a model landmark take their source from that model vertex,
/// projected to xy.
pub fn name_sources(lms: &mut [Landmark], model: Option<&Model>) {
    let Some(m) = model else { return };
    for l in lms.iter_mut() {
        if let Some((_, v)) = l.name.as_ref().and_then(|n| m.landmarks.iter().find(|(k, _)| k == n))
        {
            let p = m.vertices[*v as usize];
            l.src = [p[0], p[1]];
        }
    }
}

/// Where each frame's targets come from: a folder `landmarks` holds one file per frame
/// (`<frame name>.csv` or `.json`); a file gives the first frame's targets, followed
/// through the frames when `track` says how, or the same in every frame otherwise. Sources
/// are named from `model` ([`name_sources`]).
pub fn read_targets(
    landmarks: &Path,
    frames: &[Frame],
    model: Option<&Model>,
    track: Option<(Anchor, TrackOptions)>,
) -> Result<Targets, InputsError> {
    if landmarks.is_dir() {
        let mut out = Vec::with_capacity(frames.len());
        for f in frames {
            let p = ["csv", "json"]
                .iter()
                .map(|e| landmarks.join(format!("{}.{e}", f.name)))
                .find(|p| p.exists())
                .ok_or_else(|| InputsError::NoLandmarks {
                    frame: f.name.clone(),
                    dir: landmarks.to_path_buf(),
                })?;
            let mut l = read_landmarks(&p)
                .map_err(|source| InputsError::FrameLandmarks { path: p.clone(), source })?;
            name_sources(&mut l, model);
            out.push(l);
        }
        return Ok(Targets::PerFrame(out));
    }
    let mut first = read_landmarks(landmarks)
        .map_err(|source| InputsError::Landmarks { path: landmarks.to_path_buf(), source })?;
    name_sources(&mut first, model);
    Ok(match track {
        Some((anchor, options)) => Targets::Tracked { first, anchor, options },
        None => Targets::Fixed(first),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_gives_sorted_frames_named_by_stem_and_skips_other_files() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["b.png", "a.png"] {
            image::GrayImage::from_pixel(3, 2, image::Luma([7]))
                .save(dir.path().join(name))
                .unwrap();
        }
        std::fs::write(dir.path().join("notes.txt"), "not a frame").unwrap();
        let (frames, float) = read_frames(dir.path()).unwrap();
        let names: Vec<&str> = frames.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["a", "b"]);
        assert_eq!(float, [false, false]);
        assert_eq!((frames[0].image.width(), frames[0].image.height()), (3, 2));
    }

    #[test]
    fn an_empty_folder_and_a_bad_frame_name_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_frames(dir.path()).unwrap_err();
        assert!(matches!(e, FramesError::Empty { .. }), "{e}");
        let bad = dir.path().join("x.png");
        std::fs::write(&bad, b"hello").unwrap();
        let e = read_frames(dir.path()).unwrap_err().to_string();
        assert!(e.starts_with(&format!("cannot read frame {}", bad.display())), "{e}");
    }

    #[test]
    fn per_frame_landmarks_come_from_a_folder_and_a_missing_one_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let img = || image::DynamicImage::ImageLuma8(image::GrayImage::new(4, 4));
        let frames = vec![Frame::new("f0", "f0.png", img()), Frame::new("f1", "f1.png", img())];
        let csv = "name,src_x,src_y,dst_x,dst_y\nm,1,1,2,2\n";
        std::fs::write(dir.path().join("f0.csv"), csv).unwrap();
        let e = read_targets(dir.path(), &frames, None, None).unwrap_err();
        assert_eq!(e.to_string(), format!("no landmarks for frame f1 in {}", dir.path().display()));
        std::fs::write(dir.path().join("f1.csv"), csv).unwrap();
        let t = read_targets(dir.path(), &frames, None, None).unwrap();
        assert!(matches!(&t, Targets::PerFrame(v) if v.len() == 2 && v[1][0].dst == [2.0, 2.0]));
        let file = dir.path().join("f0.csv");
        let t = read_targets(&file, &frames, None, Some((Anchor::First, TrackOptions::default())));
        assert!(matches!(t.unwrap(), Targets::Tracked { anchor: Anchor::First, .. }));
    }
}

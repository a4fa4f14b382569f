//! The document `trimorph editor` starts with ([`initial_doc`]): a deformation or scene file
//! (with the model, frame, fixed image and landmark pairs its keys name; a deformation
//! written by `trimorph fit` or `register` carries its landmarks), an identity over a frame
//! (2.5D when a model is given), or, with nothing given, the bundled worm scene. With a
//! fixed image (`--moving M --fixed F`) the page shows the two images side by side
//! ([`super::doc`]'s two-image session).

use super::doc::Doc;
use super::ServerError;
use crate::io::model::{load_model, UpAxis};
use crate::io::{deformation, read_text};
use crate::jobs::model::load_model as load_model_up;
use crate::jobs::{parse_deformation, JobError};
use crate::mesh::{Mesh, MeshOptions};
use crate::prism::identity_layers;
use crate::spline::Spline;
use std::path::{Path, PathBuf};

/// What to open (see `trimorph editor --help`).
#[derive(Clone, Debug, Default)]
pub struct StartOptions {
    /// A deformation or scene (format v1; a scene's `"model"`, `"image"` and `"landmarks"`
    /// keys are loaded too, paths relative to its folder).
    pub deformation: Option<PathBuf>,
    /// A 3D model (OBJ, OFF, PLY) bound to the prism layer.
    pub model: Option<PathBuf>,
    /// The background image (the microscope frame to match); the moving image of a
    /// two-image session.
    pub image: Option<PathBuf>,
    /// The fixed image of a two-image session (BigWarp's workflow).
    pub fixed: Option<PathBuf>,
}

/// Why the starting document could not be made.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// Reading a file.
    #[error(transparent)]
    Job(#[from] JobError),
    /// The document refused a part.
    #[error(transparent)]
    Server(#[from] ServerError),
    /// The bundled scene.
    #[error(transparent)]
    Bundled(#[from] crate::bundled::BundledError),
}

/// A path from a file's key, relative to that file's folder.
fn beside(file: &Path, rel: &str) -> PathBuf {
    let p = PathBuf::from(rel);
    if p.is_absolute() {
        p
    } else {
        file.parent().unwrap_or(Path::new(".")).join(p)
    }
}

fn read_image(p: &Path) -> Result<image::DynamicImage, JobError> {
    crate::io::raster::read_image(p)
        .map_err(|e| JobError::context(format!("cannot read image {}", p.display()), e))
}

/// The document the editor starts with, its files inside `root` (see the module docs).
/// Temporary files that a killed save left in `root` (`.NAME.PID-N.tmp` of a process that no
/// longer runs, untouched for [`crate::io::STALE_AFTER`]) are removed first.
pub fn initial_doc(a: &StartOptions, root: &Path) -> Result<Doc, StartError> {
    crate::io::remove_stale_temps(root, crate::io::STALE_AFTER);
    let mut model_path = a.model.clone();
    let mut image_path = a.image.clone();
    let mut fixed_path = a.fixed.clone();
    let mut pinned = Vec::new();
    let mut pairs = None;
    let mut up = UpAxis::Z;
    let spline = match &a.deformation {
        Some(d) => {
            let text = read_text(d).map_err(JobError::from)?;
            let (s, _) = parse_deformation(&text, d)?;
            pinned = deformation::pinned_from_str(&text).map_err(|e| {
                JobError::context(format!("cannot read deformation {}", d.display()), e)
            })?;
            let v: serde_json::Value = serde_json::from_str(&text).map_err(JobError::from)?;
            let key = |k: &str| v.get(k).and_then(|x| x.as_str()).map(|r| beside(d, r));
            if model_path.is_none() {
                model_path = key("model");
                up = UpAxis::of_scene(&v)
                    .map_err(|reason| JobError::SceneUp { scene: d.clone(), reason })?;
            }
            image_path = image_path.or_else(|| key("image"));
            fixed_path = fixed_path.or_else(|| key("fixed"));
            pairs = super::doc::pairs::pairs_from_scene(&v, &d.display().to_string())?;
            s
        }
        None if model_path.is_none() && image_path.is_none() && fixed_path.is_none() => {
            let (s, model, frame) = crate::bundled::scene()?;
            let mut doc = Doc::new(s, root);
            doc.set_model(PathBuf::from("bundled:worm.obj"), model)?;
            doc.set_frame(PathBuf::from("bundled:frame_00.png"), frame)?;
            doc.set_name(Some("bundled worm scene".into()));
            return Ok(doc);
        }
        None => {
            // An identity over the image (8 x 8 cells), 2.5D when a model is given.
            let (w, h) = match &image_path {
                Some(p) => {
                    let img = read_image(p)?;
                    (f64::from(img.width().max(2) - 1), f64::from(img.height().max(2) - 1))
                }
                None => (512.0, 512.0),
            };
            let mesh = Mesh::grid(8, 8, w, h, MeshOptions::default()).map_err(JobError::from)?;
            let mut s = Spline::identity(mesh, 5).map_err(JobError::from)?;
            if let Some(p) = &model_path {
                let m = load_model(p).map_err(|e| {
                    JobError::context(format!("cannot load model {}", p.display()), e)
                })?;
                let (lo, hi) = m.bbox();
                let b = (lo[2].abs().max(hi[2].abs()) * 1.25).ceil().max(1.0) as i64;
                let z = identity_layers(&s, crate::exact::rat_int(-b), crate::exact::rat_int(b))
                    .map_err(JobError::from)?;
                s.set_z_layers(Some(z));
            }
            s
        }
    };
    let mut doc = Doc::new(spline, root);
    doc.set_name(a.deformation.as_ref().map(|d| d.display().to_string()));
    doc.add_pinned(&pinned);
    if let Some(p) = pairs {
        doc.set_pairs(p)?;
    }
    if let Some(p) = model_path {
        let m = load_model_up(&p, up)?;
        doc.set_model_up(p, m, up)?;
    }
    if let Some(p) = image_path {
        let img = read_image(&p)?;
        doc.set_frame(p, img)?;
    }
    if let Some(p) = fixed_path {
        let img = read_image(&p)?;
        doc.set_fixed(p, img)?;
    }
    Ok(doc)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bug: temporary files left by a killed save stayed in the editor's folder forever.
    /// Starting the editor removes those of dead writers; a live writer's file stays.
    #[cfg(target_os = "linux")]
    #[test]
    fn starting_removes_the_temporary_files_of_a_killed_save() {
        let dir = tempfile::tempdir().unwrap();
        let dead = dir.path().join(".fit.json.4194400-3.tmp");
        let live = dir.path().join(format!(".fit.json.{}-1.tmp", std::process::id()));
        for p in [&dead, &live] {
            std::fs::write(p, "{").unwrap();
            let old = std::time::SystemTime::now() - std::time::Duration::from_secs(600);
            std::fs::File::options().write(true).open(p).unwrap().set_modified(old).unwrap();
        }
        initial_doc(&StartOptions::default(), dir.path()).unwrap();
        assert!(!dead.exists(), "the dead writer's file is removed");
        assert!(live.exists(), "this process's own file stays");
    }
}

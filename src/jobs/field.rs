//! Dense displacement fields of a deformation written to files (`trimorph field`): float
//! TIFF or `.npy` (forward `phi(p) - p`, or inverse `phi^-1(q) - q`), an ITK HDF5
//! displacement-field transform (`.h5`, [`crate::io::itk`]), or an OME-Zarr NGFF
//! `displacements` store (`.zarr`, [`crate::io::ngff`]; one direction or a `bijection`
//! holding both); and the Jacobian-determinant map as a PNG with its colour bar.

use super::OptionError;
use super::{ext_of, raster_fits, JobError, JobResult};
use crate::io::itk::{self, displacement_transform, write_h5, FieldDirection};
use crate::io::ngff;
use crate::io::write_atomic;
use crate::spline::{Physical, Spline};
use crate::warp::field as wf;
use crate::warp::inverse::InverseOptions;
use std::path::{Path, PathBuf};

/// What to write (see the module documentation).
#[derive(Clone, Debug, Default)]
pub struct FieldOptions {
    /// The field file: `.tif`/`.tiff`, `.npy`, `.h5` or `.zarr`.
    pub output: PathBuf,
    /// The other direction: `.npy`/`.tif` hold `phi^-1(q) - q` instead of `phi(p) - p`;
    /// `.h5` and `.zarr` hold `phi(p) - p` instead of `phi^-1(q) - q`.
    pub inverse: bool,
    /// `.zarr` only: both directions as an NGFF `bijection`.
    pub both: bool,
    /// Also write the Jacobian-determinant map here (a `.png`).
    pub jacobian: Option<PathBuf>,
    /// `.h5` and `.zarr` only: where the grid's pixels sit in physical space. Each part
    /// given replaces the one recorded with the deformation's frame
    /// ([`crate::spline::ImageFrame::physical`]); without either, pixels. `.npy` and `.tif`
    /// fields are always in pixels.
    pub placement: PlacementParts,
}

/// Parts of a physical placement given by a caller (`field --spacing --origin --unit`,
/// Python's `to_itk(spacing=, origin=)`), each replacing the recorded one ([`placement`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlacementParts {
    /// Distance between pixel centres along x and y.
    pub spacing: Option<[f64; 2]>,
    /// Physical position of pixel `(0, 0)`'s centre.
    pub origin: Option<[f64; 2]>,
    /// Unit of spacing and origin.
    pub unit: Option<String>,
}

impl FieldOptions {
    /// Checks the file types of the outputs (before anything is read).
    pub fn check_paths(&self) -> JobResult<()> {
        let (output, ext) = (&self.output, ext_of(&self.output));
        if !itk::is_h5_path(output) && !matches!(ext.as_str(), "npy" | "tif" | "tiff" | "zarr") {
            return Err(OptionError::OutputType {
                path: output.clone(),
                expected: "use a .npy or .tif output (or .h5 for an ITK transform, .zarr for an OME-Zarr store)",
            }
            .into());
        }
        if self.both && ext != "zarr" {
            return Err(OptionError::OutputType {
                path: output.clone(),
                expected:
                    "--both writes an NGFF bijection, which only an OME-Zarr (.zarr) store holds",
            }
            .into());
        }
        if let Some(jp) = self.jacobian.as_ref().filter(|jp| ext_of(jp) != "png") {
            return Err(OptionError::OutputType {
                path: jp.clone(),
                expected: "the Jacobian map is a PNG picture; name it .png",
            }
            .into());
        }
        Ok(())
    }
}

/// The grid of a field of `s` with no size given: the image frame recorded with it
/// ([`Spline::frame`], written by `fit --size`, `mesh --landmarks` and the morph), else the
/// mesh's extent from 0 (pixel centres `0 ..= floor(x_max)`).
pub fn default_size(s: &Spline) -> (u32, u32) {
    if let Some(f) = s.frame() {
        return f.grid();
    }
    let (_, hi) = s.mesh().bbox();
    (hi[0].max(0.0).floor() as u32 + 1, hi[1].max(0.0).floor() as u32 + 1)
}

/// Where a field of `s` is placed in physical space: each part `given`, else the one
/// recorded with its frame, else pixels (spacing 1, origin 0, no unit). Refused when the
/// result is out of range (a spacing not positive, an origin not finite, an empty unit).
pub fn placement(
    s: &Spline,
    given: &PlacementParts,
) -> Result<Physical, crate::spline::frame::FrameError> {
    let recorded = s.frame().map(|f| f.physical()).unwrap_or_default();
    let p = Physical {
        spacing: given.spacing.unwrap_or(recorded.spacing),
        origin: given.origin.unwrap_or(recorded.origin),
        unit: given.unit.clone().or(recorded.unit),
    };
    p.validate()?;
    Ok(p)
}

/// The words a report line adds for a placement: nothing for pixels.
fn placement_words(p: &Physical) -> String {
    if p.is_pixels() {
        return String::new();
    }
    format!(
        ", spacing {},{} origin {},{}{}",
        p.spacing[0],
        p.spacing[1],
        p.origin[0],
        p.origin[1],
        p.unit.as_deref().map(|u| format!(" {u}")).unwrap_or_default()
    )
}

/// Writes the fields of `s` (read from the file `deformation`, which errors name) over the
/// `w x h` pixel grid as `opts` says, after checking the size and the memory budget.
/// Returns the report lines, one per field written. The Jacobian map
/// ([`FieldOptions::jacobian`]) is [`write_jacobian_map`]'s.
pub fn write_field(
    s: &Spline,
    deformation: &Path,
    (w, h): (u32, u32),
    opts: &FieldOptions,
) -> JobResult<Vec<String>> {
    opts.check_paths()?;
    if !raster_fits(w, h) {
        return Err(OptionError::FieldSize {
            deformation: deformation.to_path_buf(),
            size: (w, h),
        }
        .into());
    }
    // Two f64 components per pixel, and their encoded copy.
    let field_bytes = crate::memory::bytes_of(w as u64 * h as u64, 2 * 8 * 2);
    crate::memory::check(field_bytes, || format!("a {w} x {h} displacement field"))
        .map_err(|e| JobError::context(deformation.display().to_string(), e))?;
    let output = &opts.output;
    let physical = placement(s, &opts.placement)
        .map_err(|e| JobError::context(deformation.display().to_string(), e))?;
    let lines = if itk::is_h5_path(output) {
        vec![field_h5(s, (w, h), output, opts.inverse, &physical)?]
    } else if ext_of(output) == "zarr" {
        field_zarr(s, (w, h), output, (opts.inverse, opts.both), &physical)?
    } else {
        vec![field_plain(s, (w, h), output, opts.inverse)?]
    };
    Ok(lines)
}

/// A float TIFF (RGB: dx, dy, valid) or `.npy` (float32 `(H, W, 2)`, NaN outside).
fn field_plain(s: &Spline, (w, h): (u32, u32), output: &Path, inverse: bool) -> JobResult<String> {
    let f = if inverse {
        wf::inverse_field(s, w, h, InverseOptions::default())
    } else {
        wf::forward_field(s, w, h)
    };
    let bytes = match ext_of(output).as_str() {
        "npy" => wf::to_npy(&f),
        // "tif" | "tiff", checked by `check_paths`.
        _ => {
            let mut c = std::io::Cursor::new(Vec::new());
            image::DynamicImage::ImageRgb32F(wf::to_rgb32f(&f))
                .write_to(&mut c, image::ImageFormat::Tiff)
                .map_err(|e| JobError::context("cannot encode the float TIFF", e))?;
            c.into_inner()
        }
    };
    write_atomic(output, &bytes)?;
    let undefined = f.data.iter().filter(|v| v[0].is_nan()).count();
    Ok(format!(
        "{} displacement field {w}x{h} -> {} ({undefined} pixels undefined)",
        if inverse { "inverse (phi^-1(q) - q)" } else { "forward (phi(p) - p)" },
        output.display()
    ))
}

/// The ITK transform of `s`: by default `phi^-1(q) - q` (ITK's resampling direction), with
/// `inverse` the forward `phi(p) - p`.
fn field_h5(
    s: &Spline,
    (w, h): (u32, u32),
    output: &Path,
    inverse: bool,
    physical: &Physical,
) -> JobResult<String> {
    let direction = if inverse { FieldDirection::Forward } else { FieldDirection::Resampling };
    let f = displacement_transform(s, w, h, direction, InverseOptions::default(), physical)?;
    write_h5(&f, output)?;
    let what = match direction {
        FieldDirection::Resampling => {
            "phi^-1(q) - q: TransformPoint(q) = phi^-1(q) as `warp --points --inverse`; Resample(moving, reference, T) = `warp --image`"
        }
        FieldDirection::Forward => {
            "phi(p) - p: TransformPoint(p) = phi(p) as `warp --points`; Resample with it warps the other way"
        }
    };
    Ok(format!(
        "ITK {} {w}x{h}{} -> {}: {what} ({} pixels undefined, NaN)",
        itk::TRANSFORM_TYPE,
        placement_words(physical),
        output.display(),
        f.undefined()
    ))
}

/// The NGFF displacement store (default `v(q) = phi^-1(q) - q`, `other_way`
/// `u(p) = phi(p) - p`, `both` a bijection holding both).
fn field_zarr(
    s: &Spline,
    (w, h): (u32, u32),
    output: &Path,
    (other_way, both): (bool, bool),
    physical: &Physical,
) -> JobResult<Vec<String>> {
    if both && other_way {
        return Err(OptionError::BothWithInverse.into());
    }
    let forward = (both || other_way).then(|| wf::forward_field_f64(s, w, h));
    let inverse =
        (both || !other_way).then(|| wf::inverse_field_f64(s, w, h, InverseOptions::default()));
    ngff::write_displacements(output, forward.as_ref(), inverse.as_ref(), physical)?;
    let mut lines = Vec::new();
    let at = placement_words(physical);
    if let Some(f) = &forward {
        lines.push(format!(
            "forward (phi(p) - p, original -> warped pixels) displacement field {w}x{h}{at} float64 -> {} ({} pixels undefined)",
            output.display(),
            f.undefined()
        ));
    }
    if let Some(f) = &inverse {
        lines.push(format!(
            "inverse (phi^-1(q) - q, warped -> original pixels) displacement field {w}x{h}{at} float64 -> {} ({} pixels undefined)",
            output.display(),
            f.undefined()
        ));
    }
    if both {
        lines.push("NGFF bijection `phi`: forward and inverse in one store".to_string());
    }
    Ok(lines)
}

/// Writes the colour map of `det J` of `s` over the `w x h` grid (field pixel `(x, y)` at
/// picture pixel `(x, y)`) with its colour bar below to the PNG `path`; returns its two
/// report lines (the map and the certificate).
pub fn write_jacobian_map(s: &Spline, (w, h): (u32, u32), path: &Path) -> JobResult<[String; 2]> {
    let (dets, rep) = wf::jacobian_det(s, w, h);
    let (pm, bar) = crate::render::colorbar::jacobian_picture(&dets, w, h)?;
    let png =
        pm.encode_png().map_err(|e| JobError::context("cannot encode the Jacobian map", e))?;
    write_atomic(path, &png)?;
    Ok([
        format!(
            "Jacobian determinant map {w}x{h} with its colour bar below ({}x{} in all) -> {} (min det J {:.4}; {} of {} samples fold{})",
            bar.width,
            bar.height,
            path.display(),
            rep.min_det,
            rep.folds,
            rep.samples,
            rep.fold_bbox
                .map(|b| format!(", in x {}..{}, y {}..{}", b[0], b[2], b[1], b[3]))
                .unwrap_or_default()
        ),
        crate::spline::check::det_j_line(&rep.certificate),
    ])
}

//! OME-Zarr inputs and outputs of `trimorph warp --image` and `trimorph field`: thin
//! wrappers over [`crate::io::ngff`] and [`crate::warp::field`].

use crate::io::ngff::{self, NgffImage, SampleType};
use crate::io::raster::Stack;
use crate::spline::Spline;
use crate::warp::field::{forward_field_f64, inverse_field_f64};
use crate::warp::inverse::InverseOptions;
use anyhow::{bail, Result};
use std::io::Write;
use std::path::Path;

/// Reads `--image`: an OME-Zarr image (kept as the template of an OME-Zarr output) or any
/// raster file.
pub fn read_input(path: &Path) -> Result<(Stack, Option<NgffImage>)> {
    if !ngff::is_zarr_path(path) {
        return Ok((crate::io::raster::read_stack(path)?, None));
    }
    let mut img = ngff::read_image(path)?;
    let pages = std::mem::take(&mut img.pages);
    Ok((Stack { pages, gray_float: img.dtype == SampleType::F32 }, Some(img)))
}

/// Writes the warped pages: an OME-Zarr image like the input's when `path` is `.zarr`,
/// else the raster writers.
pub fn write_output(path: &Path, stack: &Stack, like: Option<&NgffImage>) -> Result<()> {
    if !ngff::is_zarr_path(path) {
        crate::io::raster::write_stack(path, stack)?;
        return Ok(());
    }
    let Some(like) = like else {
        bail!(
            "{}: an OME-Zarr output copies the axes and metadata of an OME-Zarr input; give --image IN.zarr, or write .tif",
            path.display()
        );
    };
    ngff::write_image(path, like, &stack.pages)?;
    Ok(())
}

/// `trimorph field DEF -o F.zarr [--inverse | --both]`: the NGFF displacement store
/// (default `v(q) = phi^-1(q) - q`, `--inverse` `u(p) = phi(p) - p`, `--both` a bijection
/// holding both), over a `w x h` pixel grid.
pub fn field_zarr(
    s: &Spline,
    output: &Path,
    (w, h): (u32, u32),
    other_way: bool,
    both: bool,
    out: &mut impl Write,
) -> Result<()> {
    if both && other_way {
        bail!("--both writes both directions; leave out --inverse");
    }
    let forward = (both || other_way).then(|| forward_field_f64(s, w, h));
    let inverse =
        (both || !other_way).then(|| inverse_field_f64(s, w, h, InverseOptions::default()));
    ngff::write_displacements(output, forward.as_ref(), inverse.as_ref())?;
    if let Some(f) = &forward {
        writeln!(
            out,
            "forward (phi(p) - p, original -> warped pixels) displacement field {w}x{h} float64 -> {} ({} pixels undefined)",
            output.display(),
            f.undefined()
        )?;
    }
    if let Some(f) = &inverse {
        writeln!(
            out,
            "inverse (phi^-1(q) - q, warped -> original pixels) displacement field {w}x{h} float64 -> {} ({} pixels undefined)",
            output.display(),
            f.undefined()
        )?;
    }
    if both {
        writeln!(out, "NGFF bijection `phi`: forward and inverse in one store")?;
    }
    Ok(())
}

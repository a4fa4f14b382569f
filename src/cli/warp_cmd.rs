//! `trimorph warp DEF (--image IN | --points IN.csv | --mesh IN | --model IN) -o OUT`,
//! `trimorph colormesh` and `trimorph field`: the work is [`crate::jobs::warp`] and
//! [`crate::jobs::field`]; this layer checks the options, shows progress and prints.

use super::args::WarpCli;
use super::common::progress_bar;
use crate::jobs::field::{default_size, write_field, write_jacobian_map, FieldOptions};
use crate::jobs::read_deformation;
use crate::jobs::warp::{warp_points, ImageInput, MeshInput};
use crate::warp::inverse::InverseOptions;
use crate::warp::remap::RemapOptions;
use crate::warp::WarpOptions;
use anyhow::{bail, Result};
use std::io::Write;
use std::path::Path;

/// `trimorph colormesh IMAGE -o MESH.(ply|obj) [--step N] [--flat]`.
pub fn colormesh(image: &Path, output: &Path, step: u32, flat: bool) -> Result<()> {
    println!("{}", crate::jobs::warp::colormesh(image, output, step, flat)?);
    Ok(())
}

/// Runs `trimorph warp`.
pub fn run(a: &WarpCli) -> Result<()> {
    if let Some(m) = &a.model {
        if a.image.is_some() || a.points.is_some() || a.mesh.is_some() {
            bail!("give exactly one of --image, --points, --mesh or --model");
        }
        let up = a.up.resolve(m)?;
        return super::model_cmd::warp_model(&a.deformation, m, &a.output, up);
    }
    // An image warp reads its image while the deformation is parsed (two independent
    // files: about 4 ms of a 4096^2 warp off the serial start); the deformation's error,
    // if any, is reported first, as when they were read one after the other.
    let mut image = None;
    let s = match (&a.image, &a.points, &a.mesh, a.inverse) {
        (Some(img_path), None, None, false) => {
            let (s, input) =
                rayon::join(|| read_deformation(&a.deformation), || ImageInput::read(img_path));
            image = Some(input);
            s?.0
        }
        _ => read_deformation(&a.deformation)?.0,
    };
    if !(a.tolerance > 0.0 && a.tolerance.is_finite()) {
        bail!("--tolerance must be a positive number of pixels");
    }
    let opts = InverseOptions { tolerance: a.tolerance, ..Default::default() };
    let mut out = std::io::stdout().lock();
    let background = a.background.unwrap_or(0.0);
    let (def, output) = (&a.deformation, &a.output);
    match (&a.image, &a.points, &a.mesh) {
        (Some(img_path), None, None) => {
            if a.inverse {
                bail!("--inverse applies to --points; images are always warped as O(q) = I(phi^-1(q))");
            }
            let input = match image.take() {
                Some(input) => input?,
                None => ImageInput::read(img_path)?,
            };
            let wo = WarpOptions {
                interp: a.interp,
                background,
                remap: RemapOptions { inverse: opts, ..Default::default() },
                mode: a.mode,
            };
            let bar = progress_bar(input.rows(), input.is_large(), "warping");
            let rep = input.warp_to(&s, def, output, &wo, &|n| bar.inc(n));
            bar.finish_and_clear();
            let rep = rep?;
            writeln!(out, "{}", rep.summary_line())?;
            match rep.folds() {
                Ok(line) => writeln!(out, "{line}")?,
                Err(warning) => eprintln!("warning: {warning}"),
            }
            if a.verbose {
                for line in rep.timing_lines(&s, &wo) {
                    writeln!(out, "{line}")?;
                }
            }
            if let Some(w) = rep.tolerance_warning(opts.tolerance) {
                eprintln!("warning: {w}");
            }
        }
        (None, None, Some(m)) => {
            let mesh = MeshInput::deform(&s, m)?;
            if let Some(w) = mesh.dropped_warning(m) {
                eprintln!("warning: {w}");
            }
            let size = a.size.filter(|_| MeshInput::draws(output));
            writeln!(out, "{}", mesh.save(output, size, a.background)?)?;
        }
        (None, Some(p), None) => {
            let rep = warp_points(&s, p, output, a.inverse, opts)?;
            writeln!(out, "{}", rep.summary_line())?;
            if let Some(w) = rep.missing_warning() {
                eprintln!("warning: {w}");
            }
        }
        _ => bail!("give exactly one of --image, --points, --mesh or --model"),
    }
    Ok(())
}

/// `trimorph field DEF -o FIELD.(tif|npy|h5|zarr) [--inverse] [--both] [--jacobian JAC.png]
/// [--size W,H]`.
pub fn field(def: &Path, opts: &FieldOptions, size: Option<(u32, u32)>) -> Result<()> {
    opts.check_paths()?;
    let (s, _) = read_deformation(def)?;
    let size = size.unwrap_or_else(|| default_size(&s));
    let mut out = std::io::stdout().lock();
    for line in write_field(&s, def, size, opts)? {
        writeln!(out, "{line}")?;
    }
    if let Some(jp) = &opts.jacobian {
        for line in write_jacobian_map(&s, size, jp)? {
            writeln!(out, "{line}")?;
        }
    }
    Ok(())
}

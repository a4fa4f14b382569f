//! `trimorph field DEF -o F.h5 [--inverse]`: the ITK HDF5 displacement-field transform
//! ([`crate::io::itk`]).

use crate::io::itk::{displacement_transform, write_h5, FieldDirection};
use crate::spline::Spline;
use crate::warp::inverse::InverseOptions;
use anyhow::Result;
use std::io::Write;
use std::path::Path;

/// Writes the ITK transform of `s` on the `w x h` pixel grid to `output` and prints which map
/// it holds: by default `phi^-1(q) - q` (ITK's resampling direction), with `inverse` the
/// forward `phi(p) - p`.
pub fn field_h5(
    s: &Spline,
    w: u32,
    h: u32,
    output: &Path,
    inverse: bool,
    out: &mut impl Write,
) -> Result<()> {
    let direction = if inverse { FieldDirection::Forward } else { FieldDirection::Resampling };
    let f = displacement_transform(s, w, h, direction, InverseOptions::default())?;
    write_h5(&f, output)?;
    let what = match direction {
        FieldDirection::Resampling => {
            "phi^-1(q) - q: TransformPoint(q) = phi^-1(q) as `warp --points --inverse`; Resample(moving, reference, T) = `warp --image`"
        }
        FieldDirection::Forward => {
            "phi(p) - p: TransformPoint(p) = phi(p) as `warp --points`; Resample with it warps the other way"
        }
    };
    writeln!(
        out,
        "ITK {} {w}x{h} -> {}: {what} ({} pixels undefined, NaN)",
        crate::io::itk::TRANSFORM_TYPE,
        output.display(),
        f.undefined()
    )?;
    Ok(())
}

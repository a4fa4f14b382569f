//! `trimorph model bind | worm`, `trimorph warp DEF --model M -o OUT` and `trimorph render
//! DEF --model M` (2.5D): the work is [`crate::jobs::model`]; this layer prints.

use super::common::say;
use crate::io::model::UpAxis;
use crate::jobs::model::{self as job, outside_warning, BindOptions};
use crate::jobs::read_deformation;
use anyhow::{bail, Result};
use std::path::Path;

/// `--up x|y|z|auto` of the model commands.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct UpArgs {
    /// The model's up axis, the prisms' height: `x` or `y` turn the model (a cyclic
    /// permutation of its axes) so that axis becomes z, and back on output, so written
    /// models keep the file's axes. `auto`: the axis along which the model is thinnest (a
    /// specimen lies flat on the slide), when it is clearly thinnest. Default z; a note
    /// suggests --up when z is clearly not the thinnest.
    #[arg(long, value_parser = parse_up)]
    pub up: Option<UpChoice>,
}

/// An `--up` value: an axis or `auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpChoice {
    /// This axis.
    Axis(UpAxis),
    /// [`crate::io::model::auto_up`].
    Auto,
}

fn parse_up(s: &str) -> Result<UpChoice, String> {
    match s {
        "auto" => Ok(UpChoice::Auto),
        s => s.parse().map(UpChoice::Axis).map_err(|e| format!("{e} (or auto)")),
    }
}

impl UpArgs {
    /// The up axis for the model at `path`: the one given, the one `auto` picks (printed),
    /// or z by default (with a note when the model is clearly thinnest along another axis,
    /// as a y-up model lying on its side is).
    pub fn resolve(&self, path: &Path) -> Result<UpAxis> {
        use crate::io::model::auto_up;
        match self.up {
            Some(UpChoice::Axis(a)) => Ok(a),
            Some(UpChoice::Auto) => {
                let m = job::load_model(path, UpAxis::Z)?;
                let a = auto_up(&m.vertices)
                    .map_err(|e| anyhow::anyhow!("model {}: {e}", path.display()))?;
                eprintln!(
                    "--up auto: {} is up in {} (its thinnest axis)",
                    a.name(),
                    path.display()
                );
                Ok(a)
            }
            None => {
                let m = job::load_model(path, UpAxis::Z)?;
                if let Ok(a) = auto_up(&m.vertices) {
                    if a != UpAxis::Z {
                        let e = crate::io::model::extents(&m.vertices);
                        eprintln!(
                            "note: {} is thinnest along {} (extents x {:.4}, y {:.4}, z {:.4}), \
                             not z: if it lies on its side, give --up {} (or --up auto)",
                            path.display(),
                            a.name(),
                            e[0],
                            e[1],
                            e[2],
                            a.name()
                        );
                    }
                }
                Ok(UpAxis::Z)
            }
        }
    }
}

/// A warning when `def` is not certified fold-free: a model (or image) carried through a
/// folded map shows triangles flipped where it folds.
pub fn warn_folds(def: &Path) -> Result<()> {
    let (s, _) = read_deformation(def)?;
    let c = crate::spline::jacobian::certify(&s, &Default::default());
    if !c.fold_free {
        eprintln!(
            "warning: {} is not certified fold-free (sampled min det J {:.3}, certified lower \
             bound {:.3}): what it carries flips where it folds; see `trimorph check` and \
             `trimorph field --jacobian`",
            def.display(),
            c.sampled_min,
            c.lower_bound
        );
    }
    Ok(())
}

/// The options of `trimorph model bind` beside the original ones.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct BindExtra {
    #[command(flatten)]
    pub up: UpArgs,
    /// Vertex coordinates of the reference mesh (and the prism range) on multiples of 1/SNAP
    /// (default 16, as `mesh --snap`); a unit-size model wants a finer grid, e.g. 1024.
    #[arg(long)]
    pub snap: Option<i64>,
}

fn warn_outside(outside: &[usize]) {
    if let Some(w) = outside_warning(outside) {
        eprintln!("warning: {w}");
    }
}

/// `trimorph model bind`: an identity 2.5D deformation around a model.
pub fn bind_cmd(o: &BindOptions) -> Result<()> {
    let rep = job::bind_model(o)?;
    say(rep.summary())?;
    warn_outside(&rep.outside);
    Ok(())
}

/// `trimorph warp DEF --model M -o OUT.(obj|ply|xyz)`: the model through psi.
pub fn warp_model(def: &Path, model_path: &Path, output: &Path, up: UpAxis) -> Result<()> {
    let rep = job::warp_model(def, model_path, output, up)?;
    warn_folds(def)?;
    say(rep.summary_line())?;
    warn_outside(&rep.outside);
    Ok(())
}

/// `trimorph model worm -o DIR`: the bundled organism-like model, its landmarks and a
/// reference prism mesh.
pub fn worm_cmd(dir: &Path) -> Result<()> {
    println!("{}", job::write_worm(dir)?);
    Ok(())
}

/// `trimorph render DEF --model M --view top|oblique -o OUT.png [--background IMG]`.
pub fn render_model(
    def: &Path,
    model_path: &Path,
    output: &Path,
    background: Option<&Path>,
    view: crate::render::model::View,
    size: (u32, u32),
    up: UpAxis,
) -> Result<()> {
    let (s, _) = read_deformation(def)?;
    // Issue 54: this was "the deformation has no z layers", naming no file.
    if s.z_layers().is_none() {
        bail!(
            "{}: the deformation has no z layers (z_range, z0, z1), so it cannot move the 3D \
             model {}; make a 2.5D deformation for it with `trimorph model bind --model {} \
             --auto`, or render the deformation without --model",
            def.display(),
            model_path.display(),
            model_path.display()
        );
    }
    let model = job::load_model(model_path, up)?;
    let ((w, h), outside) = job::render_model(&s, &model, output, background, view, size)?;
    warn_folds(def)?;
    say(format_args!("{w}x{h} -> {}", output.display()))?;
    warn_outside(&outside);
    Ok(())
}

//! `trimorph model bind | worm`, `trimorph warp DEF --model M -o OUT` and `trimorph render
//! DEF --model M` (2.5D): the work is [`crate::jobs::model`]; this layer prints.

use super::common::say;
use crate::io::model::UpAxis;
use crate::jobs::model::{self as job, outside_warning, BindOptions};
use crate::jobs::read_deformation;
use anyhow::Result;
use std::path::Path;

/// `--up x|y|z` of the model commands.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct UpArgs {
    /// The model's up axis, the prisms' height: `x` or `y` turn the model (a cyclic
    /// permutation of its axes) so that axis becomes z, and back on output, so written
    /// models keep the file's axes.
    #[arg(long, default_value = "z", value_parser = parse_up)]
    pub up: UpAxis,
}

fn parse_up(s: &str) -> Result<UpAxis, String> {
    s.parse()
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
    let model = job::load_model(model_path, up)?;
    let ((w, h), outside) = job::render_model(&s, &model, output, background, view, size)?;
    say(format_args!("{w}x{h} -> {}", output.display()))?;
    warn_outside(&outside);
    Ok(())
}

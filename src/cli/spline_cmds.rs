//! `trimorph mesh`, `trimorph edit`, `trimorph check` and `trimorph render`: the work is
//! [`crate::jobs::spline`] and [`crate::spline::check`]; this layer parses the options and
//! prints.

use super::args::{MeshCli, RenderMarks};
use super::common::say;
use super::{Exit, EXIT_INPUT, EXIT_UNSOLVABLE};
use crate::io::deformation;
use crate::io::read_text;
use crate::jobs::read_deformation;
use crate::jobs::spline::{
    build_mesh, edit_file, render_file, write_identity, EditFileError, EditLog, MeshSource,
};
use crate::jobs::values::{check_extent, check_frame_size};
use crate::mesh::{AdaptOptions, MeshOptions};
use crate::render::deformation::{Layers, RenderOptions};
use anyhow::{anyhow, bail, Context, Result};
use std::io::Write;
use std::path::Path;

/// `trimorph mesh`: an identity deformation over a new reference mesh.
pub fn mesh(a: &MeshCli) -> Result<()> {
    if a.snap.is_some_and(|g| !(1..=crate::jobs::model::MAX_SNAP).contains(&g)) {
        bail!("--snap must be between 1 and 1048576 (grid steps per unit)");
    }
    let opts = MeshOptions { grid: a.snap.unwrap_or(16) };
    if a.landmarks.is_none() && (a.margin.is_some() || a.max_edge.is_some()) {
        bail!("--margin and --max-edge go with --landmarks");
    }
    let source = match (&a.points, a.grid, &a.obj, &a.landmarks) {
        (None, None, None, Some(l)) => {
            let size = a.size.ok_or_else(|| anyhow!("--landmarks needs --size W,H (the frame)"))?;
            let size = check_frame_size(size).map_err(|e| anyhow!("--size: {e}"))?;
            let adapt = AdaptOptions {
                margin: a.margin,
                max_edge: a.max_edge,
                min_angle: a.min_angle,
                grid: a.snap.unwrap_or(0),
                extra_points: Vec::new(),
                far_rings: a.far_rings,
            };
            MeshSource::Landmarks { path: l.clone(), size, adapt }
        }
        (Some(p), None, None, None) => {
            MeshSource::Points { points: p.clone(), outline: a.outline.clone() }
        }
        (None, Some((cols, rows)), None, None) => {
            let size = a.size.ok_or_else(|| anyhow!("--grid needs --size W,H"))?;
            let [width, height] = check_extent(size).map_err(|e| anyhow!("--size: {e}"))?;
            MeshSource::Grid { cols, rows, width, height }
        }
        (None, None, Some(o), None) => MeshSource::Obj(o.clone()),
        _ => bail!("give exactly one of --points, --grid, --obj or --landmarks"),
    };
    let mesh = build_mesh(&source, opts)?;
    say(write_identity(mesh, a.degree, a.z_range.clone(), source.frame(), &a.output)?)?;
    Ok(())
}

/// `trimorph edit DEF --script EDITS -o OUT`.
pub fn edit(def: &Path, script: &Path, output: &Path, bounded: Option<u32>) -> Result<()> {
    let mut out = std::io::stdout();
    let mut log = |l: EditLog| match l {
        EditLog::Note(n) => {
            eprintln!("note: {n}");
            Ok(())
        }
        EditLog::Op(line) => writeln!(out, "{line}"),
    };
    let rep = edit_file(def, script, output, bounded, &mut log).map_err(|e| match e {
        EditFileError::Script(e) => {
            let code = if e.error.is_unsolvable() { EXIT_UNSOLVABLE } else { EXIT_INPUT };
            Exit { code, message: e.to_string(), printed: false }.into()
        }
        EditFileError::Job(e) => anyhow::Error::from(e),
        EditFileError::Log(e) => anyhow::Error::from(e),
    })?;
    say(rep.summary())?;
    if let Some(w) = rep.fold_warning() {
        eprintln!("warning: {w}");
    }
    Ok(())
}

use crate::spline::check::{check_report_with, non_finite_point};

/// Report options of `trimorph check`.
#[derive(clap::Args, Clone, Copy, Debug, Default)]
pub struct CheckOptions {
    /// Also list every C1 condition's exact residual pair (`c1_residuals`, one `[x, y]` per
    /// condition) in the JSON report.
    #[arg(long)]
    pub residuals: bool,
}

/// `trimorph check DEF [--samples N] [--residuals]`: the JSON report on stdout, a one-line
/// summary on stderr; exit 0 when C1 holds exactly, 1 otherwise.
pub fn check(def: &Path, samples: usize, opts: CheckOptions) -> Result<()> {
    // The scan costs samples^2 evaluations per triangle: beyond this it never finishes.
    const MAX_SAMPLES: usize = 1000;
    if samples > MAX_SAMPLES {
        bail!("--samples {samples}: at most {MAX_SAMPLES} samples per triangle side");
    }
    let text = read_text(def)?;
    let (s, _) = deformation::from_str_unchecked(&text)
        .with_context(|| format!("cannot read deformation {}", def.display()))?;
    if let Some((p, a, v)) = non_finite_point(&s) {
        bail!(
            "{}: control point {p}: its {} coordinate {v} is not a finite double (the exact value is beyond the f64 range); correct that point",
            def.display(),
            ["x", "y"][a]
        );
    }
    let rep = check_report_with(&s, samples, opts.residuals);
    writeln!(std::io::stdout(), "{}", serde_json::to_string_pretty(&rep)?)?;
    eprintln!("{}: {}", def.display(), rep.summary_line());
    if !rep.c1_holds {
        return Err(Exit {
            code: EXIT_INPUT,
            message: format!("{}: C1 conditions do not hold", def.display()),
            printed: false,
        }
        .into());
    }
    Ok(())
}

/// `trimorph render DEF -o OUT.png [--background IMG] [--show LAYERS] [--size W,H]
/// [--landmarks L]`.
pub fn render(
    def: &Path,
    output: &Path,
    background: Option<&Path>,
    show: Layers,
    size: (u32, u32),
    marks: &RenderMarks,
) -> Result<()> {
    let (s, last) = read_deformation(def)?;
    let mut opts = RenderOptions::with_layers(show);
    if let Some(l) = &marks.landmarks {
        opts.landmarks = crate::io::landmarks::read_landmarks(l)
            .with_context(|| format!("cannot read landmarks {}", l.display()))?;
    }
    (opts.width, opts.height) = size;
    let (w, h) = render_file(&s, last.as_ref(), output, background, &opts)?;
    say(format_args!("{w}x{h} -> {}", output.display()))?;
    Ok(())
}

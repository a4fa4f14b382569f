//! `trimorph mesh`, `trimorph edit` and `trimorph check`.

use super::common::{pair, parse_canvas_size, parse_frame_size};
use super::{Exit, EXIT_INPUT, EXIT_UNSOLVABLE};
use crate::edit::script::{self, OpReport, Script, ScriptError};
use crate::edit::Editor;
use crate::exact::parse_rat;
use crate::io::deformation::{self, LastEdit};
use crate::io::points::read_points;
use crate::io::{read_text, write_atomic};
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::jacobian::{certify, CertifyOptions};
use crate::spline::{Spline, ZLayers};
use anyhow::{anyhow, bail, Context, Result};
use serde_json::json;
use std::io::Write;
use std::path::Path;

/// Options of `trimorph mesh`.
pub struct MeshArgs<'a> {
    pub points: Option<&'a Path>,
    pub outline: Option<&'a Path>,
    pub grid: Option<&'a str>,
    pub size: Option<&'a str>,
    pub obj: Option<&'a Path>,
    pub landmarks: Option<&'a Path>,
    pub margin: Option<f64>,
    pub max_edge: Option<f64>,
    pub min_angle: f64,
    pub degree: usize,
    pub snap: Option<i64>,
    pub z_range: Option<&'a str>,
    pub output: &'a Path,
}

/// `trimorph mesh`: an identity deformation over a new reference mesh.
pub fn mesh(a: MeshArgs) -> Result<()> {
    if a.snap.is_some_and(|g| !(1..=1 << 20).contains(&g)) {
        bail!("--snap must be between 1 and 1048576 (grid steps per unit)");
    }
    let opts = MeshOptions { grid: a.snap.unwrap_or(16) };
    if a.landmarks.is_none() && (a.margin.is_some() || a.max_edge.is_some()) {
        bail!("--margin and --max-edge go with --landmarks");
    }
    let mesh = match (a.points, a.grid, a.obj, a.landmarks) {
        (None, None, None, Some(l)) => {
            let size = a.size.ok_or_else(|| anyhow!("--landmarks needs --size W,H (the frame)"))?;
            let size = parse_frame_size(size)?;
            let lms = crate::io::landmarks::read_landmarks(l)
                .with_context(|| format!("cannot read landmarks {}", l.display()))?;
            let sources: Vec<[f64; 2]> = lms.iter().map(|x| x.src).collect();
            let grid = a.snap.unwrap_or_else(|| crate::fit::frame::source_grid(&lms));
            let ao = crate::mesh::AdaptOptions {
                margin: a.margin,
                max_edge: a.max_edge,
                min_angle: a.min_angle,
                grid,
                extra_points: Vec::new(),
            };
            Mesh::landmark_adapted(&sources, size, &ao)
                .with_context(|| format!("cannot build a landmark mesh from {}", l.display()))?
                .mesh
        }
        (Some(p), None, None, None) => {
            let mut pts = read_points(&read_text(p)?, &p.display().to_string())?;
            match a.outline {
                None => Mesh::delaunay(&pts, opts),
                Some(o) => {
                    let mut outline_pts = read_points(&read_text(o)?, &o.display().to_string())?;
                    // A closed polygon (last vertex repeating the first) is the same outline.
                    if outline_pts.len() > 3 && outline_pts.first() == outline_pts.last() {
                        outline_pts.pop();
                    }
                    let first = pts.len();
                    pts.extend(outline_pts.iter().copied());
                    let idx: Vec<usize> = (first..pts.len()).collect();
                    Mesh::constrained_delaunay(&pts, &idx, opts)
                }
            }
            .with_context(|| format!("cannot build a mesh from {}", p.display()))?
        }
        (None, Some(g), None, None) => {
            let (c, r) = pair(g, "--grid", 'x')?;
            if c < 1.0 || r < 1.0 || c.fract() != 0.0 || r.fract() != 0.0 || c * r > 1e6 {
                bail!("--grid: expected COLSxROWS with whole numbers of cells, e.g. 6x4");
            }
            let (w, h) =
                pair(a.size.ok_or_else(|| anyhow!("--grid needs --size W,H"))?, "--size", ',')?;
            if w <= 0.0 || h <= 0.0 {
                bail!("--size: width and height must be positive");
            }
            Mesh::grid(c as usize, r as usize, w, h, opts)?
        }
        (None, None, Some(o), None) => crate::io::obj::read_mesh(&read_text(o)?, opts)
            .with_context(|| format!("cannot read the reference mesh {}", o.display()))?,
        _ => bail!("give exactly one of --points, --grid, --obj or --landmarks"),
    };
    let mut spline = Spline::identity(mesh, a.degree)?;
    if let Some(z) = a.z_range {
        let (lo, hi) = z.split_once(',').ok_or_else(|| anyhow!("--z-range: expected A,B"))?;
        let (lo, hi) = (
            parse_rat(lo).map_err(|e| anyhow!("--z-range: {e}"))?,
            parse_rat(hi).map_err(|e| anyhow!("--z-range: {e}"))?,
        );
        if lo >= hi {
            bail!("--z-range: need A < B");
        }
        let n = spline.num_points();
        spline.set_z_layers(Some(ZLayers {
            z0: vec![lo.clone(); n],
            z1: vec![hi.clone(); n],
            range: [lo, hi],
        }));
    }
    write_atomic(a.output, deformation::to_string(&spline, None).as_bytes())?;
    let m = spline.mesh();
    let snap = m.snap_report();
    writeln!(
        std::io::stdout(),
        "identity deformation of degree {}: {} vertices, {} triangles, {} control points, {} C1 conditions\nsnapped to 1/{}: {} vertices moved, at most {:.3e}\n-> {}",
        spline.degree(),
        m.num_vertices(),
        m.num_triangles(),
        spline.num_points(),
        spline.quads().len(),
        snap.grid,
        snap.moved,
        snap.max_shift,
        a.output.display()
    )?;
    Ok(())
}

fn load(path: &Path) -> Result<(Spline, Option<LastEdit>)> {
    let text = read_text(path)?;
    deformation::from_str(&text)
        .with_context(|| format!("cannot read deformation {}", path.display()))
}

/// Applies an edit script (JSON text: an array of operations) to `ed` with
/// [`crate::edit::script`], writing one progress line per operation to `log`. Errors name
/// `source` (the script file) and the operation index; an unsolvable operation carries
/// [`EXIT_UNSOLVABLE`]. On an error `ed` is as it was. Returns the number of operations and
/// the anchors / derived points of the last move.
pub fn run_script(
    ed: &mut Editor,
    text: &str,
    source: &str,
    log: &mut dyn Write,
) -> Result<(usize, Option<LastEdit>)> {
    let fail = |e: ScriptError| -> anyhow::Error {
        let code = if e.is_unsolvable() { EXIT_UNSOLVABLE } else { EXIT_INPUT };
        let message = match e {
            ScriptError::Json { .. } => format!("{source}, {e}"),
            e => format!("{source}: {e}"),
        };
        Exit { code, message, printed: false }.into()
    };
    let script = Script::from_json_str(text).map_err(fail)?;
    let mut written = Ok(());
    let reports = script::run_script(ed, &script.ops, &mut |k, r| {
        if written.is_ok() {
            written = writeln!(log, "{}", progress_line(k, r));
        }
    })
    .map_err(fail)?;
    written?;
    Ok((reports.len(), script::last_edit(&reports)))
}

/// The progress line of operation `k`.
fn progress_line(k: usize, r: &OpReport) -> String {
    match r {
        OpReport::Constrained { in_force, .. } => {
            format!("operation {k}: {in_force} constraints in force")
        }
        OpReport::Moved { anchors, derived, relevant, rank, strong } => format!(
            "operation {k}: {} anchors, {} derived, {relevant} relevant conditions (rank {rank}), {}",
            anchors.len(),
            derived.len(),
            if *strong { "strongly solvable" } else { "weakly solvable" }
        ),
    }
}

/// `trimorph edit DEF --script EDITS -o OUT`.
pub fn edit(def: &Path, script: &Path, output: &Path, bounded: Option<u32>) -> Result<()> {
    if bounded.is_some_and(|b| !(8..=62).contains(&b)) {
        bail!("--bounded-bits must be between 8 and 62");
    }
    let (spline, _) = load(def)?;
    let extras = deformation::constraints_from_str(&read_text(def)?, &spline)
        .with_context(|| format!("cannot read the constraints of {}", def.display()))?;
    let text = read_text(script)?;
    let mut ed = Editor::new(spline);
    if let Err(e) = ed.set_bounded(bounded) {
        eprintln!("note: {e}; keeping exact values unbounded");
    }
    for e in extras {
        ed.add_constraint(e).context("a stored constraint does not hold")?;
    }
    let mut out = std::io::stdout();
    let (n_ops, last) = run_script(&mut ed, &text, &script.display().to_string(), &mut out)?;
    ed.spline().check_c1().context("internal error: the edit broke C1")?;
    // The editor's bound on coordinates (`trimorph editor` refuses the same with 422).
    if let Some(what) = crate::server::doc::absurd_point(ed.spline()) {
        return Err(Exit {
            code: super::EXIT_INPUT,
            message: format!(
                "{}: after the edits {what}, beyond {} pixels: refused (nothing written)",
                script.display(),
                crate::server::doc::MAX_COORD
            ),
            printed: false,
        }
        .into());
    }
    write_atomic(
        output,
        deformation::to_string_with(ed.spline(), last.as_ref(), ed.constraints()).as_bytes(),
    )?;
    writeln!(out, "{n_ops} operations applied; C1 holds exactly -> {}", output.display())?;
    let cert = certify(ed.spline(), &CertifyOptions::default());
    writeln!(out, "{}", det_j_line(&cert))?;
    if !cert.fold_free {
        eprintln!(
            "warning: {} is not certified fold-free (det J lower bound {}, sampled minimum {}): folding triangles {:?}, undecided triangles {:?}",
            output.display(),
            cert.lower_bound,
            cert.sampled_min,
            cert.folding,
            cert.undecided
        );
    }
    Ok(())
}

pub use crate::spline::check::{check_report_with, det_j_line, non_finite_point, summary_line};

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
    eprintln!("{}: {}", def.display(), summary_line(&rep));
    if rep["c1_holds"] != json!(true) {
        return Err(Exit {
            code: EXIT_INPUT,
            message: format!("{}: C1 conditions do not hold", def.display()),
            printed: false,
        }
        .into());
    }
    Ok(())
}

/// Landmark options of `trimorph render`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct RenderMarks {
    /// Landmarks to draw (CSV, BigWarp CSV or JSON, as `fit` reads them): each source as an
    /// orange cross, phi(source) as a green dot, the target as a magenta ring, and a line
    /// from phi(source) to the target (the residual).
    #[arg(long)]
    pub landmarks: Option<std::path::PathBuf>,
}

impl RenderMarks {
    /// `--landmarks` draws on the deformation's picture, not on a model's.
    pub fn refuse_with_model(&self) -> Result<()> {
        if let Some(l) = &self.landmarks {
            bail!("{}: --landmarks draws on a deformation's picture; omit --model", l.display());
        }
        Ok(())
    }
}

/// `trimorph render DEF -o OUT.png [--background IMG] [--show LAYERS] [--size W,H]
/// [--landmarks L]`.
pub fn render(
    def: &Path,
    output: &Path,
    background: Option<&Path>,
    show: &str,
    size: &str,
    marks: &RenderMarks,
) -> Result<()> {
    use crate::render::deformation as rd;
    let (s, last) = load(def)?;
    let mut opts = rd::RenderOptions::parse_show(show)?;
    if let Some(l) = &marks.landmarks {
        opts.landmarks = crate::io::landmarks::read_landmarks(l)
            .with_context(|| format!("cannot read landmarks {}", l.display()))?;
    }
    (opts.width, opts.height) = parse_canvas_size(size)?;
    let bg = background.map(rd::load_background).transpose()?;
    let pm = rd::render(&s, last.as_ref(), bg.as_ref(), &opts)?;
    rd::save_png(&pm, output)?;
    writeln!(std::io::stdout(), "{}x{} -> {}", pm.width(), pm.height(), output.display())?;
    Ok(())
}

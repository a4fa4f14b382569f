//! Spline deformations as files (`trimorph mesh`, `trimorph edit`, `trimorph render`):
//!
//! * [`build_mesh`] and [`write_identity`]: a reference mesh from points, a grid, an OBJ
//!   file or landmarks, and the identity deformation over it;
//! * [`edit_file`]: an edit script applied to a deformation file, the result checked (C1
//!   exactly, coordinates within [`MAX_COORD`], the det J certificate) and written;
//! * [`render_file`]: the picture of a deformation.

use super::OptionError;
use super::{read_deformation, JobError, JobResult};
use crate::edit::script::{self, OpReport, Script, ScriptError};
use crate::edit::Editor;
use crate::io::deformation::{self, LastEdit};
use crate::io::points::read_points;
use crate::io::{read_text, write_atomic};
use crate::mesh::{AdaptOptions, Mesh, MeshError, MeshOptions};
use crate::prism::ZRange;
use crate::spline::check::absurd_point;
use crate::spline::jacobian::{certify, CertifyOptions, DetJ};
use crate::spline::{ImageFrame, Spline};
use std::path::{Path, PathBuf};

/// Where a reference mesh comes from.
#[derive(Clone, Debug)]
pub enum MeshSource {
    /// The Delaunay triangulation of the points of a CSV file (`x,y`), or with `outline`
    /// (a CSV polygon, in order; a closing repeat of the first vertex is dropped) a
    /// constrained Delaunay triangulation.
    Points {
        /// The points.
        points: PathBuf,
        /// The outline polygon.
        outline: Option<PathBuf>,
    },
    /// A regular grid of `cols x rows` cells over `[0, width] x [0, height]`.
    Grid {
        /// Columns of cells.
        cols: usize,
        /// Rows of cells.
        rows: usize,
        /// Width covered.
        width: f64,
        /// Height covered.
        height: f64,
    },
    /// A 2D OBJ mesh (`v` and `f` lines).
    Obj(PathBuf),
    /// A mesh adapted to landmarks (their sources are vertices) over a frame, refined by
    /// Delaunay refinement ([`Mesh::landmark_adapted`]); `adapt.grid` 0 picks the
    /// finest snap grid on which every source is exact.
    Landmarks {
        /// The landmark file (CSV, BigWarp or JSON).
        path: PathBuf,
        /// The frame `[width, height]` in pixels.
        size: [f64; 2],
        /// Margin, longest edge, smallest angle and snap grid.
        adapt: AdaptOptions,
    },
}

impl MeshSource {
    /// The image frame the mesh is made for: a landmark mesh's `size`, and a grid's
    /// `width x height` when both are whole numbers (`mesh --grid 6x6 --size 550,660` is
    /// for a 550 x 660 image: the grid spans `[0, 550] x [0, 660]`, which holds every pixel
    /// centre, and fields default to 550 x 660 pixels, not to the 551 x 661 pixel centres
    /// of its extent). Other meshes have none.
    pub fn frame(&self) -> Option<ImageFrame> {
        match self {
            MeshSource::Landmarks { size, .. } => ImageFrame::new(*size).ok(),
            MeshSource::Grid { width, height, .. }
                if width.fract() == 0.0 && height.fract() == 0.0 =>
            {
                ImageFrame::new([*width, *height]).ok()
            }
            _ => None,
        }
    }
}

/// Builds the reference mesh of `source`, vertices snapped to `opts.grid` (landmark meshes
/// use `adapt.grid`, or with 0 the grid of their sources). Errors name the file.
pub fn build_mesh(source: &MeshSource, opts: MeshOptions) -> JobResult<Mesh> {
    match source {
        MeshSource::Landmarks { path, size, adapt } => {
            let lms = crate::io::landmarks::read_landmarks(path).map_err(|e| {
                JobError::context(format!("cannot read landmarks {}", path.display()), e)
            })?;
            let sources: Vec<[f64; 2]> = lms.iter().map(|x| x.src).collect();
            let mut ao = adapt.clone();
            if ao.grid == 0 {
                ao.grid = crate::fit::frame::source_grid(&lms);
            }
            Ok(Mesh::landmark_adapted(&sources, *size, &ao)
                .map_err(|e| {
                    JobError::context(
                        format!("cannot build a landmark mesh from {}", path.display()),
                        e,
                    )
                })?
                .mesh)
        }
        MeshSource::Points { points, outline } => {
            let mut pts = read_points(&read_text(points)?, &points.display().to_string())?;
            match outline {
                None => Mesh::delaunay(&pts, opts),
                Some(o) => {
                    let mut outline_pts = read_points(&read_text(o)?, &o.display().to_string())?;
                    // A closed polygon (last vertex repeating the first) is the same outline.
                    if outline_pts.len() > 3 && outline_pts.first() == outline_pts.last() {
                        outline_pts.pop();
                    }
                    // The outline alone first, so that its faults are reported with its
                    // own file and point numbers.
                    let own: Vec<usize> = (0..outline_pts.len()).collect();
                    Mesh::constrained_delaunay(&outline_pts, &own, opts)
                        .map_err(|e| JobError::context(format!("outline {}", o.display()), e))?;
                    let first = pts.len();
                    pts.extend(outline_pts.iter().copied());
                    let idx: Vec<usize> = (first..pts.len()).collect();
                    return Mesh::constrained_delaunay(&pts, &idx, opts)
                        .map_err(|e| outline_error(e, points, o, first));
                }
            }
            .map_err(|e| {
                JobError::context(format!("cannot build a mesh from {}", points.display()), e)
            })
        }
        MeshSource::Grid { cols, rows, width, height } => {
            Ok(Mesh::grid(*cols, *rows, *width, *height, opts)?)
        }
        MeshSource::Obj(path) => crate::io::obj::read_mesh(&read_text(path)?, opts).map_err(|e| {
            JobError::context(format!("cannot read the reference mesh {}", path.display()), e)
        }),
    }
}

/// A constrained mesh's error, naming the file each vertex comes from: vertices `0 ..
/// first` are the rows of `points`, the rest the rows of `outline` (issue 54: an outline's
/// faults were reported against the `--points` file, with vertex numbers that count both).
fn outline_error(e: MeshError, points: &Path, outline: &Path, first: usize) -> JobError {
    let vertex = |v: usize| {
        if v < first {
            format!("{} point {v}", points.display())
        } else {
            format!("{} point {}", outline.display(), v - first)
        }
    };
    let text = match &e {
        MeshError::NotFinite { vertex: v } => {
            format!("{} has a non-finite coordinate; give finite coordinates", vertex(*v))
        }
        MeshError::CoordinateOutOfRange { vertex: v, value } => format!(
            "{}: coordinate {value:e} is too large (|coordinate * grid| must be below 2^40); \
             rescale the input or use a smaller snapping grid",
            vertex(*v)
        ),
        MeshError::Duplicate { first: a, second: b, x, y } => format!(
            "{} and {} coincide at ({x}, {y}) after snapping; remove one of them or use a \
             finer snapping grid",
            vertex(*a),
            vertex(*b)
        ),
        MeshError::BadOutline(m) => format!(
            "{m} (points 0 to {} are those of {}, then come the outline's)",
            first.saturating_sub(1),
            points.display()
        ),
        _ => {
            let ctx = format!(
                "cannot build a mesh from {} with the outline {}",
                points.display(),
                outline.display()
            );
            return JobError::context(ctx, e);
        }
    };
    JobError::context(
        format!(
            "cannot build a mesh from {} with the outline {}",
            points.display(),
            outline.display()
        ),
        OutlineError(text),
    )
}

/// A constrained mesh's error with its vertices named by file ([`outline_error`]).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct OutlineError(String);

/// Writes the identity deformation of `degree` over `mesh` to `output` (2.5D with
/// constant layers `z0 = lo`, `z1 = hi` when `z_range = [lo, hi]` is given). Returns the report
/// lines (three).
///
/// `frame`: the image frame the mesh is for, recorded in the file (a landmark mesh's
/// `--size`; [`MeshSource::frame`]).
pub fn write_identity(
    mesh: Mesh,
    degree: usize,
    z_range: Option<ZRange>,
    frame: Option<ImageFrame>,
    output: &Path,
) -> JobResult<String> {
    let mut spline = Spline::identity(mesh, degree)?;
    spline.set_frame(frame);
    if let Some(r) = z_range {
        let z = r.layers(&spline);
        spline.set_z_layers(Some(z));
    }
    write_atomic(output, deformation::to_string(&spline, None).as_bytes())?;
    let m = spline.mesh();
    let snap = m.snap_report();
    Ok(format!(
        "identity deformation of degree {}: {} vertices, {} triangles, {} control points, {} C1 conditions\nsnapped to 1/{}: {} vertices moved, at most {:.3e}\n-> {}",
        spline.degree(),
        m.num_vertices(),
        m.num_triangles(),
        spline.num_points(),
        spline.quads().len(),
        snap.grid,
        snap.moved,
        snap.max_shift,
        output.display()
    ))
}

/// What [`edit_file`] tells as it goes.
#[derive(Clone, Debug)]
pub enum EditLog {
    /// A note (bounded exactness could not be set up: values stay exact).
    Note(String),
    /// One operation done: its progress line.
    Op(String),
}

/// An edit script that failed, with the script's name (the text is the command line's:
/// `SCRIPT: operation K: ...`, or `SCRIPT, line L: ...` for JSON).
#[derive(Debug, thiserror::Error)]
#[error("{}", match .error { ScriptError::Json { .. } => format!("{}, {}", .script, .error), e => format!("{}: {e}", .script) })]
pub struct ScriptFailed {
    /// The script file's name.
    pub script: String,
    /// What failed.
    pub error: ScriptError,
}

/// What [`edit_file`] did.
#[derive(Clone, Debug)]
pub struct EditReport {
    /// Operations applied.
    pub operations: usize,
    /// The det J certificate of the result.
    pub certificate: DetJ,
    /// The output file.
    pub output: PathBuf,
}

impl EditReport {
    /// `N operations applied; C1 holds exactly -> OUT` and the det J line.
    pub fn summary(&self) -> String {
        format!(
            "{} operations applied; C1 holds exactly -> {}\n{}",
            self.operations,
            self.output.display(),
            crate::spline::check::det_j_line(&self.certificate)
        )
    }

    /// The warning when the result is not certified fold-free.
    pub fn fold_warning(&self) -> Option<String> {
        let cert = &self.certificate;
        (!cert.fold_free).then(|| format!(
            "{} is not certified fold-free (det J lower bound {}, sampled minimum {}): folding triangles {:?}, undecided triangles {:?}",
            self.output.display(),
            cert.lower_bound,
            cert.sampled_min,
            cert.folding,
            cert.undecided
        ))
    }
}

/// Applies an edit script (JSON text: an array of operations, [`crate::edit::script`]) to
/// `ed`, calling `log` with one progress line per operation. Errors name `source` (the
/// script file) and the operation index. On an error `ed` is as it was. Returns the number
/// of operations and the anchors / derived points of the last move.
pub fn run_script_text(
    ed: &mut Editor,
    text: &str,
    source: &str,
    log: &mut dyn FnMut(String),
) -> Result<(usize, Option<LastEdit>), ScriptFailed> {
    let fail = |error: ScriptError| ScriptFailed { script: source.to_string(), error };
    let script = Script::from_json_str(text).map_err(fail)?;
    let reports =
        script::run_script(ed, &script.ops, &mut |k, r| log(progress_line(k, r))).map_err(fail)?;
    Ok((reports.len(), script::last_edit(&reports)))
}

/// The progress line of operation `k`.
fn progress_line(k: usize, r: &OpReport) -> String {
    match r {
        OpReport::Constrained { in_force, .. } => {
            format!("operation {k}: {in_force} constraints in force")
        }
        OpReport::Moved { anchors, derived, relevant, rank, strong, determining_set, modular } => {
            format!(
                "operation {k}: {} anchors, {} derived, {relevant} relevant conditions (rank {rank}), {}{}",
                anchors.len(),
                derived.len(),
                if *strong { "strongly solvable" } else { "weakly solvable" },
                match (determining_set, modular) {
                    (true, _) => " (solved in determining-set coordinates)",
                    (false, true) => " (solved on the modular path)",
                    (false, false) => "",
                }
            )
        }
    }
}

/// Why [`edit_file`] failed: the script (unsolvable operations among them, see
/// [`ScriptError::is_unsolvable`]) or anything else.
#[derive(Debug, thiserror::Error)]
pub enum EditFileError {
    /// The script failed.
    #[error(transparent)]
    Script(#[from] ScriptFailed),
    /// Reading, checking or writing.
    #[error(transparent)]
    Job(#[from] JobError),
    /// The log callback failed (the first of its errors; the edit stopped before writing).
    #[error(transparent)]
    Log(std::io::Error),
}

/// Applies the edit script `script` to the deformation `def` (its stored constraints kept)
/// and writes the result to `output`. `bounded`: round the free points to multiples of
/// 2^-bits after each operation (8 to 62), or keep exact values. The result must keep C1
/// exactly and every coordinate within [`MAX_COORD`]; nothing is written otherwise.
/// `log` hears the notes and progress lines; its first error stops the edit before
/// anything is written ([`EditFileError::Log`]).
pub fn edit_file(
    def: &Path,
    script: &Path,
    output: &Path,
    bounded: Option<u32>,
    log: &mut dyn FnMut(EditLog) -> std::io::Result<()>,
) -> Result<EditReport, EditFileError> {
    if bounded.is_some_and(|b| !(8..=62).contains(&b)) {
        let rule = "must be between 8 and 62";
        return Err(JobError::from(OptionError::OutOfRange { flag: "--bounded-bits", rule }).into());
    }
    let (spline, _) = read_deformation(def)?;
    let extras =
        deformation::constraints_from_str(&read_text(def).map_err(JobError::from)?, &spline)
            .map_err(|e| {
                JobError::context(format!("cannot read the constraints of {}", def.display()), e)
            })?;
    let text = read_text(script).map_err(JobError::from)?;
    let mut ed = Editor::new(spline);
    let mut logged = Ok(());
    let mut log = |l: EditLog| {
        if logged.is_ok() {
            logged = log(l);
        }
    };
    if let Err(e) = ed.set_bounded(bounded) {
        log(EditLog::Note(format!("{e}; keeping exact values unbounded")));
    }
    for e in extras {
        ed.add_constraint(e)
            .map_err(|e| JobError::context("a stored constraint does not hold", e))?;
    }
    let (operations, last) =
        run_script_text(&mut ed, &text, &script.display().to_string(), &mut |l| {
            log(EditLog::Op(l))
        })?;
    logged.map_err(EditFileError::Log)?;
    ed.spline()
        .check_c1()
        .map_err(|e| JobError::context("internal error: the edit broke C1", e))?;
    // The editor's bound on coordinates (`trimorph editor` refuses the same with 422).
    if let Some(what) = absurd_point(ed.spline()) {
        return Err(JobError::FarAfterEdits { script: script.to_path_buf(), point: what }.into());
    }
    write_atomic(
        output,
        deformation::to_string_with(ed.spline(), last.as_ref(), ed.constraints()).as_bytes(),
    )
    .map_err(JobError::from)?;
    let certificate = certify(ed.spline(), &CertifyOptions::default());
    Ok(EditReport { operations, certificate, output: output.to_path_buf() })
}

/// Draws the deformation `s` (with the last edit's anchors `last`; layers and size in
/// `opts`, over the picture `background` if given) and saves the PNG `output`. Returns the
/// picture's size.
pub fn render_file(
    s: &Spline,
    last: Option<&LastEdit>,
    output: &Path,
    background: Option<&Path>,
    opts: &crate::render::deformation::RenderOptions,
) -> JobResult<(u32, u32)> {
    use crate::render::deformation as rd;
    let bg = background.map(rd::load_background).transpose()?;
    let pm = rd::render(s, last, bg.as_ref(), opts)?;
    rd::save_png(&pm, output)?;
    Ok((pm.width(), pm.height()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bug: `mesh --grid 6x6 --size 550,660` for a 550 x 660 image recorded no frame, so its
    /// fields defaulted to the 551 x 661 pixel centres of the mesh's extent. A grid of whole
    /// pixels now records its frame; a fractional one (not an image) records none.
    #[test]
    fn a_grid_of_whole_pixels_records_its_image_frame() {
        let grid = MeshSource::Grid { cols: 6, rows: 6, width: 550.0, height: 660.0 };
        let frame = grid.frame().expect("a frame");
        assert_eq!(frame.grid(), (550, 660));
        let odd = MeshSource::Grid { cols: 2, rows: 2, width: 20.5, height: 10.0 };
        assert_eq!(odd.frame(), None);
        let obj = MeshSource::Obj(PathBuf::from("m.obj"));
        assert_eq!(obj.frame(), None);
        let mesh = build_mesh(&grid, MeshOptions { grid: 16 }).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("id.json");
        write_identity(mesh, 5, None, grid.frame(), &out).unwrap();
        let (s, _) = crate::jobs::read_deformation(&out).unwrap();
        assert_eq!(crate::jobs::field::default_size(&s), (550, 660));
    }
}

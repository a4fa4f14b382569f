//! 2.5D models in a layer of prisms, as files (`trimorph model bind | worm`,
//! `trimorph warp --model`, `trimorph render --model`):
//!
//! * [`bind_model`]: an identity 2.5D deformation around a model (a scene file naming the
//!   model), over a given 2D mesh or an automatic grid;
//! * [`warp_model`]: a model moved through a 2.5D deformation `psi`;
//! * [`render_model`]: the top or oblique view of a deformed model;
//! * [`write_worm`]: the bundled organism-like model, its landmarks and a reference mesh.

use super::OptionError;
use super::{read_deformation, JobError, JobResult};
use crate::exact::{rat_to_f64, Rat};
use crate::io::model::{load_model_up, save_landmarks, save_model, save_model_up, UpAxis};
use crate::io::{deformation, read_text, write_atomic};
use crate::mesh::MeshOptions;
use crate::prism::{
    auto_mesh, auto_mesh_on, bind, deform, identity_layers, organism, Model, ZRange,
};
use crate::render::model::View;
use crate::spline::Spline;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Largest vertex grid of a reference mesh: 2^20 steps per unit.
pub const MAX_SNAP: i64 = 1 << 20;

/// Most cells of the automatic grid of [`bind_model`] ([`AutoGrid`]): the model's
/// bounding box in at most this many prisms' footprints.
pub const MAX_AUTO_CELLS: usize = 10_000;

/// The cells `COLSxROWS` of the automatic reference mesh of [`bind_model`]: at least one
/// column and one row, at most [`MAX_AUTO_CELLS`] cells in all.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AutoGrid {
    cols: usize,
    rows: usize,
}

impl AutoGrid {
    /// `cols x rows` cells; `None` unless both are at least 1 and there are at most
    /// [`MAX_AUTO_CELLS`] cells.
    pub fn new(cols: usize, rows: usize) -> Option<AutoGrid> {
        let fits =
            cols >= 1 && rows >= 1 && cols.checked_mul(rows).is_some_and(|n| n <= MAX_AUTO_CELLS);
        fits.then_some(AutoGrid { cols, rows })
    }

    /// Columns (along x).
    pub fn cols(self) -> usize {
        self.cols
    }

    /// Rows (along y).
    pub fn rows(self) -> usize {
        self.rows
    }
}

impl Default for AutoGrid {
    /// 4 x 2 cells (`trimorph model bind`'s default).
    fn default() -> Self {
        AutoGrid { cols: 4, rows: 2 }
    }
}

impl std::str::FromStr for AutoGrid {
    type Err = AutoGridError;
    /// `COLSxROWS`, whole numbers (spaces around them ignored), e.g. `4x2`.
    fn from_str(text: &str) -> Result<AutoGrid, AutoGridError> {
        text.split_once('x')
            .and_then(|(c, r)| AutoGrid::new(c.trim().parse().ok()?, r.trim().parse().ok()?))
            .ok_or(AutoGridError)
    }
}

/// A text that is not an [`AutoGrid`] (not `COLSxROWS`, a side of 0, or more than
/// [`MAX_AUTO_CELLS`] cells).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("expected COLSxROWS, e.g. 4x2")]
pub struct AutoGridError;

/// How [`bind_model`] builds the reference mesh and the prism range.
#[derive(Clone, Debug)]
pub struct BindOptions {
    /// The 3D model (OBJ, OFF, PLY or XYZ).
    pub model: PathBuf,
    /// A 2D OBJ reference mesh whose vertices have z = b (prisms over [-b, b]).
    pub mesh: Option<PathBuf>,
    /// Instead of `mesh`: a grid around the model's bounding box.
    pub auto: bool,
    /// The automatic grid (default 4 x 2 cells).
    pub grid: AutoGrid,
    /// Margin of the automatic grid, a fraction of the model's largest side (0 to 10).
    pub margin: f64,
    /// The prism range; default from the mesh (`[-b, b]`) or the model.
    pub range: Option<ZRange>,
    /// Spline degree.
    pub degree: usize,
    /// The scene file written (a deformation with the model's path under `"model"`).
    pub output: PathBuf,
    /// The model's up axis.
    pub up: UpAxis,
    /// Vertex coordinates (and the range) on multiples of 1/`snap` (default 16).
    pub snap: Option<i64>,
}

/// What [`bind_model`] did.
#[derive(Clone, Debug)]
pub struct BindReport {
    /// Model vertices and triangles.
    pub vertices: usize,
    /// Model triangles.
    pub triangles: usize,
    /// Prisms (triangles of the reference mesh).
    pub prisms: usize,
    /// The prism range.
    pub range: [f64; 2],
    /// Binding time, ms.
    pub bind_ms: f64,
    /// Model vertices outside every prism (they stay in place).
    pub outside: Vec<usize>,
    /// The scene file.
    pub output: PathBuf,
}

impl BindReport {
    /// The report lines (two).
    pub fn summary(&self) -> String {
        format!(
            "{} vertices, {} triangles bound to {} prisms over [{}, {}] in {:.1} ms; {} outside\n-> {}",
            self.vertices,
            self.triangles,
            self.prisms,
            self.range[0],
            self.range[1],
            self.bind_ms,
            self.outside.len(),
            self.output.display()
        )
    }
}

/// The warning for model vertices outside the prisms (`None` when there are none).
pub fn outside_warning(outside: &[usize]) -> Option<String> {
    if outside.is_empty() {
        return None;
    }
    let first: Vec<String> = outside.iter().take(5).map(|i| i.to_string()).collect();
    Some(format!(
        "{} model vertices are outside the prisms and stay in place (first: {}); rebuild with `trimorph model bind --auto --margin ...`",
        outside.len(),
        first.join(", ")
    ))
}

/// A rational close to `v` on a 1/`grid` grid, rounded outwards (`up`) or inwards.
fn snap_to(v: f64, grid: i64, up: bool) -> Rat {
    let s = v * grid as f64;
    let k = if up { s.ceil() } else { s.floor() };
    Rat::new((k as i64).into(), grid.into())
}

/// Loads a model file with its up axis; errors name the file.
pub fn load_model(path: &Path, up: UpAxis) -> JobResult<Model> {
    load_model_up(path, up)
        .map_err(|e| JobError::context(format!("cannot load model {}", path.display()), e))
}

/// Writes an identity 2.5D deformation (format v1 with `z_range`, `z0`, `z1`) around a
/// model, with the model's path (relative to the scene's folder when it lies under it)
/// and its up axis, so that `fit --model SCENE` finds it.
pub fn bind_model(o: &BindOptions) -> JobResult<BindReport> {
    let grid = o.snap.unwrap_or(16);
    if !(1..=MAX_SNAP).contains(&grid) {
        return Err(OptionError::OutOfRange {
            flag: "--snap",
            rule: "must be between 1 and 1048576 (grid steps per unit)",
        }
        .into());
    }
    let model = load_model(&o.model, o.up)?;
    let (mesh, range) = match (&o.mesh, o.auto) {
        (Some(t), false) => {
            // A 2D OBJ whose vertices have z = b; the prisms span [-b, b] (thesis 18.2),
            // unless the range says otherwise.
            let text = read_text(t)?;
            let mesh = crate::io::obj::read_mesh(&text, MeshOptions { grid }).map_err(|e| {
                JobError::context(format!("cannot read the reference mesh {}", t.display()), e)
            })?;
            let b = text
                .lines()
                .filter_map(|l| l.strip_prefix("v "))
                .filter_map(|l| l.split_whitespace().nth(2).and_then(|z| z.parse::<f64>().ok()))
                .fold(f64::NEG_INFINITY, f64::max);
            let r = if b.is_finite() && b > 0.0 { Some([-b, b]) } else { None };
            (mesh, r)
        }
        (None, true) => {
            let (c, r) = (o.grid.cols(), o.grid.rows());
            if !(o.margin >= 0.0 && o.margin <= 10.0) {
                return Err(OptionError::OutOfRange {
                    flag: "--margin",
                    rule: "is a fraction of the model's size, between 0 and 10",
                }
                .into());
            }
            let (m, ab) = auto_mesh_on(&model, c, r, o.margin, MeshOptions { grid })
                .map_err(|e| JobError::context(o.model.display().to_string(), e))?;
            (m, Some(ab))
        }
        _ => return Err(OptionError::MeshOrAuto.into()),
    };
    let (lo, hi) = match (&o.range, range) {
        (Some(r), _) => (r.lo().clone(), r.hi().clone()),
        (None, Some([x, y])) => (snap_to(x, grid, false), snap_to(y, grid, true)),
        (None, None) => return Err(OptionError::NoRange.into()),
    };
    let mut s = Spline::identity(mesh, o.degree)?;
    let z = identity_layers(&s, lo, hi)?;
    s.set_z_layers(Some(z));
    let t = Instant::now();
    let b = bind(&model, &s)?;
    let bind_ms = t.elapsed().as_secs_f64() * 1e3;
    // The scene: the deformation plus the model's path (an extra key the format allows).
    let mut v = deformation::to_json(&s, None);
    v["model"] = serde_json::Value::from(scene_relative(&o.output, &o.model));
    o.up.record_in(&mut v);
    write_atomic(&o.output, crate::io::json_rows(&v).as_bytes())?;
    let z = s.z_layers().expect("set_z_layers(Some(..)) was called above");
    Ok(BindReport {
        vertices: model.vertices.len(),
        triangles: model.triangles.len(),
        prisms: s.mesh().num_triangles(),
        range: [rat_to_f64(&z.range[0]), rat_to_f64(&z.range[1])],
        bind_ms,
        outside: b.outside,
        output: o.output.clone(),
    })
}

/// `model` as seen from the folder of `scene`: relative when `model` lies under it,
/// absolute otherwise.
fn scene_relative(scene: &Path, model: &Path) -> String {
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let dir = abs(scene.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")));
    let m = abs(model);
    m.strip_prefix(&dir).unwrap_or(&m).to_string_lossy().into_owned()
}

/// What [`warp_model`] did.
#[derive(Clone, Debug)]
pub struct ModelWarpReport {
    /// Model vertices moved.
    pub vertices: usize,
    /// Binding time, ms.
    pub bind_ms: f64,
    /// Deformation time, ms.
    pub deform_ms: f64,
    /// Vertices outside the prisms (kept in place).
    pub outside: Vec<usize>,
    /// The output model.
    pub output: PathBuf,
}

impl ModelWarpReport {
    /// `N vertices through psi (bind .. ms, deform .. ms) -> OUT`.
    pub fn summary_line(&self) -> String {
        format!(
            "{} vertices through psi (bind {:.1} ms, deform {:.1} ms) -> {}",
            self.vertices,
            self.bind_ms,
            self.deform_ms,
            self.output.display()
        )
    }
}

/// Moves the model `model_path` (up axis `up`) through the 2.5D deformation `def` and
/// saves it to `output` (OBJ, PLY or XYZ, in the file's own axes).
pub fn warp_model(
    def: &Path,
    model_path: &Path,
    output: &Path,
    up: UpAxis,
) -> JobResult<ModelWarpReport> {
    let (s, _) = read_deformation(def)?;
    let model = load_model(model_path, up)?;
    let t = Instant::now();
    let b = bind(&model, &s)?;
    let bind_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let moved = deform(&model, &b, &s);
    let deform_ms = t.elapsed().as_secs_f64() * 1e3;
    save_model_up(&model, &moved, output, up)?;
    Ok(ModelWarpReport {
        vertices: model.vertices.len(),
        bind_ms,
        deform_ms,
        outside: b.outside,
        output: output.to_path_buf(),
    })
}

/// Writes the bundled organism-like model (`worm.obj` and its landmarks) and a reference
/// prism mesh at the scale of thesis Table 19.1 (`worm_prisms.obj`, a 4 x 2 grid: 16
/// triangles) into `dir`. Returns the report line.
pub fn write_worm(dir: &Path) -> JobResult<String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| JobError::context(format!("cannot create {}", dir.display()), e))?;
    let w = organism::worm(&organism::WormOptions::default());
    let obj = dir.join("worm.obj");
    save_model(&w, &w.vertices, &obj)?;
    save_landmarks(&w, &w.vertices, &obj)?;
    let (mesh, [_, b]) = auto_mesh(&w, 4, 2, 0.05)?;
    let b = rat_to_f64(&snap_to(b, 16, true));
    let mut t = String::from(
        "# reference prism mesh for worm.obj: vertices at z = b, prisms over [-b, b]\n",
    );
    for v in mesh.vertices() {
        t.push_str(&format!("v {} {} {}\n", v[0], v[1], b));
    }
    for tri in mesh.triangles() {
        t.push_str(&format!("f {} {} {}\n", tri[0] + 1, tri[1] + 1, tri[2] + 1));
    }
    let tpath = dir.join("worm_prisms.obj");
    write_atomic(&tpath, t.as_bytes())?;
    Ok(format!(
        "{} vertices, {} triangles, landmarks {} -> {}; reference prisms ({} triangles) -> {}",
        w.vertices.len(),
        w.triangles.len(),
        w.landmarks.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", "),
        obj.display(),
        mesh.num_triangles(),
        tpath.display()
    ))
}

/// Draws `model` deformed by the 2.5D deformation `s` (`view`: top or oblique) on a
/// `width x height` canvas, over the picture `background` if given, and saves the PNG.
/// Returns the picture's size and the model vertices outside the prisms.
pub fn render_model(
    s: &Spline,
    model: &Model,
    output: &Path,
    background: Option<&Path>,
    view: View,
    (width, height): (u32, u32),
) -> JobResult<((u32, u32), Vec<usize>)> {
    use crate::render::deformation as rd;
    use crate::render::model::{render_model as draw, ModelRenderOptions};
    let b = bind(model, s)?;
    let moved = deform(model, &b, s);
    let bg = background.map(rd::load_background).transpose()?;
    let opts = ModelRenderOptions { width, height, view, ..Default::default() };
    let pm = draw(s, model, &moved, bg.as_ref(), &opts)?;
    rd::save_png(&pm, output)?;
    Ok(((pm.width(), pm.height()), b.outside))
}

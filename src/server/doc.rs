//! The editor's document: the deformation being edited, the optional model and frame, the
//! undo history and the points corrected by hand.
//!
//! Every operation either succeeds or leaves the document exactly as it was: edits go
//! through [`Editor`] (which restores the spline on failure), loads are parsed completely
//! before anything is replaced, and saves write a temporary file and rename it.
//!
//! Coordinates: mesh coordinates are the reference image's pixel coordinates (x right,
//! y down, pixel centres at integers), as everywhere in trimorph; the frame is drawn in the
//! same coordinates, so `phi` maps the reference onto the frame.

mod fixed;
pub mod history;
pub mod pairs;
pub mod register;

pub use history::{Step, UNDO_LIMIT};

use super::answers::{Certificate, ImageInfo, Refitted, Selected, Stat, State, StateSelection};
use super::paths::confine;
use super::ServerError;
use crate::edit::script::{Motion, Translate};
use crate::edit::select::Neighborhood;
use crate::edit::{EditError, Editor, LastEdit, Mode};
use crate::fit::landmarks::Landmark;
use crate::fit::{fit, FitOptions};
use crate::io::landmarks::read_landmarks;
use crate::io::model::{load_model_up, save_model, UpAxis};
use crate::io::{deformation, read_text, write_atomic};
use crate::prism::{bind, deform, Binding, Model};
use crate::render::overlay::SilhouetteEdges;
use crate::spline::jacobian::{CertCache, CertifyOptions, DetJ};
use crate::spline::{ControlPoint, Spline};
use image::DynamicImage;
use serde_json::{json, Value};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use crate::spline::check::{absurd_point, MAX_COORD};

/// Range of an accepted scale factor.
pub const SCALE_RANGE: [f64; 2] = [1e-3, 1e3];

/// A model bound to the prism layer.
pub struct BoundModel {
    /// Its file, relative to the root when it was loaded from there.
    pub path: PathBuf,
    /// The model.
    pub model: Model,
    /// Where each vertex sits in the reference prisms.
    pub binding: Binding,
    /// The model's edges, grouped once for the silhouette of every answer.
    pub edges: SilhouetteEdges,
    /// The file's up axis: `model` holds the vertices turned z-up, files are written back in
    /// the file's axes, and a saved scene records it ([`crate::io::model::SCENE_UP_KEY`]).
    pub up: UpAxis,
}

impl BoundModel {
    /// Binds `model` (from `path`, z-up) with `binding`.
    pub fn new(path: PathBuf, model: Model, binding: Binding) -> BoundModel {
        let edges = SilhouetteEdges::new(&model.triangles);
        BoundModel { path, model, binding, edges, up: UpAxis::Z }
    }

    /// z-up vertices in the model file's axes.
    pub fn to_file_axes(&self, vertices: &[[f64; 3]]) -> Vec<[f64; 3]> {
        vertices.iter().map(|&v| self.up.from_z_up(v)).collect()
    }
}

/// The frame to match (the background).
pub struct Frame {
    /// Its file.
    pub path: PathBuf,
    /// The image.
    pub image: DynamicImage,
    /// The image as PNG, served to the page.
    pub png: Vec<u8>,
}

impl Frame {
    /// A frame from its file's image (encoded once as PNG for the page).
    pub fn new(path: PathBuf, image: DynamicImage) -> Result<Frame, ServerError> {
        let mut png = Vec::new();
        image
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(|e| ServerError::Unprocessable(format!("image {}: {e}", path.display())))?;
        Ok(Frame { path, image, png })
    }
}

/// A drag operation, relative to the positions at selection time: the edit-script
/// vocabulary ([`crate::edit::script::Motion`]) with finite `f64` numbers, each made exact
/// as it is (the page sends binary doubles).
pub type Op = Motion<f64>;

/// The editor's document; see the module docs.
pub struct Doc {
    editor: Editor,
    model: Option<BoundModel>,
    frame: Option<Frame>,
    undo: Vec<Step>,
    redo: Vec<Step>,
    pinned: BTreeSet<ControlPoint>,
    /// Landmark pairs placed, moved or imported in the page ([`pairs`]).
    landmarks: Vec<pairs::Pair>,
    /// The fixed image of a two-image session (`--moving M --fixed F`), if any: the frame
    /// is then the moving image, and the page shows the two side by side.
    fixed: Option<Frame>,
    /// Where the live warp's forward-map nodes lie in the reference mesh, per node grid
    /// ([`views::forward_grid`](super::views::forward_grid)); located once per grid.
    warp_nodes: std::cell::RefCell<Option<std::sync::Arc<super::views::WarpNodes>>>,
    before_drag: Option<Spline>,
    /// The last drag step of the selection that succeeded (re-applied to take back a
    /// step whose result is refused).
    last_op: Option<Op>,
    root: PathBuf,
    name: Option<String>,
    /// Per reference mesh edge, where its sample points lie: (triangle, barycentrics).
    edge_samples: Vec<Vec<(usize, [f64; 3])>>,
    /// The det J certificate per triangle, redone for the triangles a drag moves.
    cert: CertCache,
    /// Milliseconds of the last exact update.
    pub last_update_ms: f64,
}

/// A file a scene save writes beside the scene: its path relative to the root, and the
/// frame's PNG bytes (`None`: the model).
pub type SceneCopy = (String, Option<Vec<u8>>);

/// Segments per mesh edge in the page's `mesh` polylines.
pub const EDGE_SAMPLES: usize = 8;

/// Every unique edge of `mesh` (ordered by its vertex pair) as [`EDGE_SAMPLES`] + 1 points,
/// located once in the reference mesh (the mesh never changes within a document).
fn locate_edge_samples(mesh: &crate::mesh::Mesh) -> Vec<Vec<(usize, [f64; 3])>> {
    let mut edges: Vec<(usize, usize)> = Vec::with_capacity(3 * mesh.num_triangles());
    for t in 0..mesh.num_triangles() {
        let v = mesh.triangle(t);
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    edges.dedup();
    let mut hint = None;
    edges
        .iter()
        .map(|&(a, b)| {
            let (pa, pb) = (mesh.vertex(a), mesh.vertex(b));
            (0..=EDGE_SAMPLES)
                .filter_map(|k| {
                    let u = k as f64 / EDGE_SAMPLES as f64;
                    let p = [pa[0] + u * (pb[0] - pa[0]), pa[1] + u * (pb[1] - pa[1])];
                    let found = mesh.locate(p, hint);
                    hint = found.map(|f| f.0).or(hint);
                    found
                })
                .collect()
        })
        .collect()
}

fn edit_err(e: EditError) -> ServerError {
    ServerError::Unprocessable(e.to_string())
}

impl Doc {
    /// A document for `spline`, confined to `root` for file loads and saves.
    pub fn new(spline: Spline, root: &Path) -> Doc {
        let edge_samples = locate_edge_samples(spline.mesh());
        let cert = CertCache::new(&spline, CertifyOptions::default());
        Doc {
            edge_samples,
            cert,
            editor: Editor::new(spline),
            model: None,
            frame: None,
            undo: Vec::new(),
            redo: Vec::new(),
            pinned: BTreeSet::new(),
            landmarks: Vec::new(),
            fixed: None,
            warp_nodes: Default::default(),
            before_drag: None,
            last_op: None,
            root: root.to_path_buf(),
            name: None,
            last_update_ms: 0.0,
        }
    }

    /// Binds a z-up model (the deformation must have z layers).
    pub fn set_model(&mut self, path: PathBuf, model: Model) -> Result<(), ServerError> {
        self.set_model_up(path, model, UpAxis::Z)
    }

    /// Binds a model whose file's up axis is `up` (`model` already turned z-up, as
    /// [`crate::io::model::load_model_up`] gives it).
    pub fn set_model_up(
        &mut self,
        path: PathBuf,
        model: Model,
        up: UpAxis,
    ) -> Result<(), ServerError> {
        let binding = bind(&model, self.editor.spline())
            .map_err(|e| ServerError::Unprocessable(format!("model {}: {e}", path.display())))?;
        let mut bound = BoundModel::new(path, model, binding);
        bound.up = up;
        self.model = Some(bound);
        Ok(())
    }

    /// Sets the background frame (the moving image of a two-image session).
    pub fn set_frame(&mut self, path: PathBuf, image: DynamicImage) -> Result<(), ServerError> {
        self.frame = Some(Frame::new(path, image)?);
        Ok(())
    }

    /// Records the document's file name (shown in the page, default save name).
    pub fn set_name(&mut self, name: Option<String>) {
        self.name = name;
    }

    /// Marks control points as corrected by hand (e.g. read from a saved file).
    pub fn add_pinned(&mut self, pts: &[ControlPoint]) {
        let n = self.editor.spline().num_points();
        self.pinned.extend(pts.iter().copied().filter(|p| p.index() < n));
    }

    /// The spline.
    pub fn spline(&self) -> &Spline {
        self.editor.spline()
    }
    /// The editor (selection, index).
    pub fn editor(&self) -> &Editor {
        &self.editor
    }
    /// The bound model.
    pub fn model(&self) -> Option<&BoundModel> {
        self.model.as_ref()
    }
    /// The frame.
    pub fn frame(&self) -> Option<&Frame> {
        self.frame.as_ref()
    }
    /// Points corrected by hand so far.
    pub fn pinned(&self) -> &BTreeSet<ControlPoint> {
        &self.pinned
    }
    /// The folder file paths are confined to.
    pub fn root(&self) -> &Path {
        &self.root
    }
    /// The det J certificate of the current spline
    /// ([`crate::spline::jacobian`]; the numbers `trimorph check` prints for the saved file).
    pub fn det_j(&self) -> DetJ {
        self.cert.summary()
    }

    /// Summary for the page (`GET /api/state`).
    pub fn state(&self) -> State {
        let s = self.spline();
        let image = |f: &Frame| ImageInfo {
            path: f.path.display().to_string(),
            width: f.image.width(),
            height: f.image.height(),
        };
        let (undo_next, redo_next) = self.history_labels();
        State {
            name: self.name.clone(),
            degree: s.degree(),
            points: s.num_points(),
            triangles: s.mesh().num_triangles(),
            z_modes: s.z_layers().is_some(),
            model: self.model.as_ref().map(|m| m.path.display().to_string()),
            frame: self.frame.as_ref().map(image),
            fixed: self.fixed.as_ref().map(image),
            undo: self.undo.len(),
            redo: self.redo.len(),
            undo_next: undo_next.map(str::to_string),
            redo_next: redo_next.map(str::to_string),
            pinned: self.pinned.iter().copied().collect(),
            selection: self.editor.selection().map(|s| StateSelection {
                anchors: s.anchors.clone(),
                derived: s.derived.clone(),
                strong: s.strong,
                mode: mode_name(s.mode),
            }),
            last_update_ms: self.last_update_ms,
            det_j: Certificate::from(&self.det_j()),
        }
    }

    /// 2DSD.Select: anchors, a neighbourhood radius (`None`: all points) and the mode.
    pub fn select(
        &mut self,
        anchors: &[ControlPoint],
        radius: Option<usize>,
        mode: Mode,
    ) -> Result<Selected, ServerError> {
        let hood = match radius {
            Some(r) => Neighborhood::Radius(r),
            None => Neighborhood::All,
        };
        let before = self.editor.spline().clone();
        let sel = self.editor.select(anchors, &[], &hood, mode).map_err(edit_err)?;
        let out = Selected {
            anchors: sel.anchors.clone(),
            derived: sel.derived.clone(),
            theta: sel.theta.clone(),
            strong: sel.strong,
            relevant: sel.relevant(),
            rank: sel.rank(),
            solver: if sel.is_global() {
                "determining_set"
            } else if sel.is_modular() {
                "modular"
            } else {
                "sessions"
            },
        };
        self.before_drag = Some(before);
        self.last_op = None;
        Ok(out)
    }

    /// One drag step: the operation relative to the selection-time positions, exactly.
    /// The first successful step of a selection records an undo step.
    /// Arguments beyond [`MAX_COORD`] or [`SCALE_RANGE`], and steps that would move a
    /// point beyond [`MAX_COORD`], are refused (422) and change nothing.
    pub fn update(&mut self, op: &Op) -> Result<(), ServerError> {
        let t0 = Instant::now();
        check_op(op)?;
        self.apply(op)?;
        if let Err(e) = self.check_moved() {
            // Back to the previous step (or the selection-time positions), exactly.
            let back = self.last_op.clone().unwrap_or_else(|| {
                let dim =
                    if self.editor.selection().is_some_and(|s| s.mode == Mode::Xy) { 2 } else { 1 };
                Motion::Translate(Translate { by: vec![0.0; dim] })
            });
            self.apply(&back)?;
            return Err(e);
        }
        self.last_op = Some(op.clone());
        // Only the anchors and derived points moved (xy mode; z modes leave phi alone).
        if let Some(sel) = self.editor.selection().filter(|s| s.mode == Mode::Xy) {
            let s = self.editor.spline();
            self.cert.refresh_points(s, &ControlPoint::indices(&sel.anchors));
            self.cert.refresh_points(s, &ControlPoint::indices(&sel.derived));
        }
        self.last_update_ms = t0.elapsed().as_secs_f64() * 1e3;
        if let Some(before) = self.before_drag.take() {
            let what = self.drag_label(op);
            self.push_undo(before, what);
        }
        if let Some(sel) = self.editor.selection() {
            self.pinned.extend(sel.anchors.iter().copied());
        }
        Ok(())
    }

    /// The moved points (anchors and derived) are within [`MAX_COORD`].
    fn check_moved(&self) -> Result<(), ServerError> {
        let Some(sel) = self.editor.selection() else { return Ok(()) };
        let s = self.editor.spline();
        for i in sel.anchors.iter().chain(&sel.derived).map(|p| p.index()) {
            let v: Vec<f64> = match (sel.mode, s.z_layers()) {
                (Mode::Xy, _) | (_, None) => s.point_f64(i).to_vec(),
                (Mode::Z0, Some(z)) => vec![crate::exact::rat_to_f64(&z.z0[i])],
                (Mode::Z1, Some(z)) => vec![crate::exact::rat_to_f64(&z.z1[i])],
            };
            if v.iter().any(|&x| !within(x)) {
                return Err(ServerError::Unprocessable(format!(
                    "the edit would move control point {i} to {v:?}, beyond {MAX_COORD} pixels: refused"
                )));
            }
        }
        Ok(())
    }

    fn apply(&mut self, op: &Op) -> Result<(), ServerError> {
        op.to_exact().and_then(|m| m.apply(&mut self.editor)).map_err(edit_err)
    }

    /// Ends the selection.
    pub fn clear_selection(&mut self) {
        self.editor.clear_selection();
        self.before_drag = None;
        self.last_op = None;
    }

    /// The deformation file's JSON (format v1), with the corrected points (`"pinned"`),
    /// and for a scene saved as `rel` the model, frame and fixed image (`"model"`,
    /// `"image"`, `"fixed"`, paths relative to the scene file's folder) and the landmark
    /// pairs (`"landmarks"`, [`pairs`]).
    /// Also returns the copies a scene needs
    /// (relative path, the frame's PNG bytes or `None` for the model): a model or frame with no file inside that folder (bundled,
    /// or elsewhere) is written beside the scene as `STEM.model.obj` / `STEM.frame.png`.
    /// The text is the file [`Doc::save`] writes.
    pub fn to_json(&self, scene: Option<&str>) -> (String, Vec<SceneCopy>) {
        let (v, copies) = self.file_value(scene);
        (crate::io::json_rows(&v), copies)
    }

    /// [`Doc::to_json`] as the value `io::deformation` builds. A deformation file is
    /// `io`'s format, written from its untyped value (`io::deformation::to_json_with`)
    /// with the editor's keys added, so it stays a `Value` here.
    fn file_value(&self, scene: Option<&str>) -> (Value, Vec<SceneCopy>) {
        let last = self
            .editor
            .selection()
            .map(|s| LastEdit { anchors: s.anchors.clone(), derived: s.derived.clone() });
        let mut v =
            deformation::to_json_with(self.spline(), last.as_ref(), self.editor.constraints());
        v["pinned"] = json!(self.pinned.iter().collect::<Vec<_>>());
        let mut copies = Vec::new();
        let Some(rel) = scene else { return (v, copies) };
        v["landmarks"] = self.pairs_scene_value();
        let rel = Path::new(rel);
        let folder_rel = rel.parent().unwrap_or(Path::new(""));
        let stem = rel.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let folder = self.root.join(folder_rel).canonicalize().ok();
        // `p` relative to the scene's folder, if it is a file inside it.
        let inside = |p: &Path| -> Option<String> {
            if p.to_string_lossy().starts_with("bundled:") {
                return None;
            }
            let abs = if p.is_absolute() { p.to_path_buf() } else { self.root.join(p) };
            let abs = abs.canonicalize().ok()?;
            let r = abs.strip_prefix(folder.as_ref()?).ok()?;
            Some(r.to_string_lossy().into_owned())
        };
        if let Some(m) = &self.model {
            let key = inside(&m.path).unwrap_or_else(|| {
                let name = format!("{stem}.model.obj");
                copies.push((folder_rel.join(&name).to_string_lossy().into_owned(), None));
                name
            });
            v["model"] = json!(key);
            m.up.record_in(&mut v);
        }
        for (key, suffix, f) in [("image", "frame", &self.frame), ("fixed", "fixed", &self.fixed)] {
            if let Some(f) = f {
                let k = inside(&f.path).unwrap_or_else(|| {
                    let name = format!("{stem}.{suffix}.png");
                    let c = folder_rel.join(&name).to_string_lossy().into_owned();
                    copies.push((c, Some(f.png.clone())));
                    name
                });
                v[key] = json!(k);
            }
        }
        (v, copies)
    }

    /// Where a save or an export of `rel` writes: inside the root ([`confine`]), and never
    /// the image or the model this editor works on (an export named after the frame replaced
    /// the raw image). Overwriting anything else is the page's question to ask
    /// (`POST /api/stat` first).
    pub fn output_path(&self, rel: &str) -> Result<PathBuf, ServerError> {
        let path = confine(&self.root, rel, true)?;
        let same = |p: &std::path::Path| {
            let p = if p.is_absolute() { p.to_path_buf() } else { self.root.join(p) };
            p.canonicalize().is_ok_and(|c| c == path)
        };
        let input = match (&self.frame, &self.model, &self.fixed) {
            (Some(f), _, _) if same(&f.path) => Some("image"),
            (_, Some(m), _) if same(&m.path) => Some("model"),
            (_, _, Some(f)) if same(&f.path) => Some("fixed image"),
            _ => None,
        };
        match input {
            Some(what) => Err(ServerError::Forbidden(format!(
                "`{rel}` is the {what} this editor works on: writing it would replace an input; \
                 choose another name"
            ))),
            None => Ok(path),
        }
    }

    /// Saves the deformation (or the scene, with the copies [`Doc::to_json`] names) to
    /// `rel` inside the root; returns the file and the copies written.
    pub fn save(&self, rel: &str, scene: bool) -> Result<(PathBuf, Vec<String>), ServerError> {
        let path = self.output_path(rel)?;
        let (text, copies) = self.to_json(scene.then_some(rel));
        let io = |e: crate::io::IoError| ServerError::Io(e.to_string());
        let mut written = Vec::new();
        for (c, bytes) in &copies {
            let p = self.output_path(c)?;
            match (bytes, &self.model) {
                (Some(b), _) => write_atomic(&p, b).map_err(io)?,
                (None, Some(m)) => {
                    let e = |e: crate::io::model::ModelIoError| ServerError::Io(e.to_string());
                    let file = m.to_file_axes(&m.model.vertices);
                    save_model(&m.model, &file, &p).map_err(e)?;
                    if !m.model.landmarks.is_empty() {
                        crate::io::model::save_landmarks(&m.model, &file, &p).map_err(e)?;
                    }
                }
                (None, None) => {}
            }
            written.push(c.clone());
        }
        write_atomic(&path, text.as_bytes()).map_err(io)?;
        Ok((path, written))
    }

    /// What the page asks before a save or a load of `rel`: `exists`, `same_layout`
    /// (a deformation over the same mesh: loading it keeps the undo history; `null` when
    /// not readable as a deformation), and `scene_copies` (files a scene save would write
    /// besides, that exist already).
    pub fn stat(&self, rel: &str) -> Result<Stat, ServerError> {
        let path = confine(&self.root, rel, true)?;
        let exists = path.exists();
        let same = exists
            .then(|| read_text(&path).ok())
            .flatten()
            .and_then(|t| deformation::from_str(&t).ok())
            .map(|(s, _)| crate::edit::same_layout(self.spline(), &s));
        let copies: Vec<String> = self
            .file_value(Some(rel))
            .1
            .into_iter()
            .map(|(c, _)| c)
            .filter(|c| self.root.join(c).exists())
            .collect();
        Ok(Stat { exists, same_layout: same, scene_copies: copies })
    }

    /// Loads a deformation or scene from `rel` inside the root. Over the same mesh it
    /// replaces the spline as one undoable step; otherwise it starts a new document (and
    /// rebinds the model). A scene's `"model"`, `"image"` and `"fixed"` keys load those files too, and
    /// its `"landmarks"` replace the pairs (a file without that key keeps them).
    pub fn load(&mut self, rel: &str) -> Result<(), ServerError> {
        let path = confine(&self.root, rel, false)?;
        let bad = |e: String| ServerError::Unprocessable(format!("{rel}: {e}"));
        let text = read_text(&path).map_err(|e| bad(e.to_string()))?;
        let (s, _) = deformation::from_str(&text).map_err(|e| bad(e.to_string()))?;
        if let Some(what) = absurd_point(&s) {
            return Err(bad(format!(
                "{what}: not a finite value within {MAX_COORD} pixels; correct that point"
            )));
        }
        let pinned = deformation::pinned_from_str(&text).map_err(|e| bad(e.to_string()))?;
        // A scene is a deformation file (`io::deformation`'s format, any of its keys) with
        // the editor's keys: read as a free-form value, not a request body.
        let v: Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        // Keys are relative to the scene file's folder (as `trimorph editor SCENE` reads them).
        let folder = Path::new(rel).parent().unwrap_or(Path::new(""));
        let key = |k: &str| {
            v.get(k).and_then(Value::as_str).map(|p| folder.join(p).to_string_lossy().into_owned())
        };
        // Everything is read before anything changes.
        let lms = pairs::pairs_from_scene(&v, rel)?;
        let model = match key("model") {
            Some(m) => {
                let p = confine(&self.root, &m, false)?;
                let up = UpAxis::of_scene(&v).map_err(|e| bad(format!("{rel}: {e}")))?;
                let loaded = load_model_up(&p, up).map_err(|e| bad(e.to_string()))?;
                Some((PathBuf::from(m), loaded, up))
            }
            None => None,
        };
        let read = |k: &str| -> Result<Option<Frame>, ServerError> {
            let Some(i) = key(k) else { return Ok(None) };
            let p = confine(&self.root, &i, false)?;
            let img = crate::io::raster::read_image(&p).map_err(|e| bad(e.to_string()))?;
            Frame::new(PathBuf::from(i), img).map(Some)
        };
        let frame = read("image")?;
        let fixed = read("fixed")?;
        let same = crate::edit::same_layout(self.spline(), &s);
        let model =
            model.or_else(|| self.model.as_ref().map(|m| (m.path.clone(), m.model.clone(), m.up)));
        if same {
            let bound = match model {
                Some((p, m, up)) => {
                    let binding = bind(&m, &s).map_err(|e| bad(format!("model: {e}")))?;
                    let mut bound = BoundModel::new(p, m, binding);
                    bound.up = up;
                    Some(bound)
                }
                None => None,
            };
            let cur = self.editor.spline().clone();
            self.editor.replace_spline(s).map_err(edit_err)?;
            // A scene's pairs replace the current ones in the same step.
            let pairs = lms.as_ref().map(|_| self.landmarks.clone());
            self.push_step(Step { spline: Some(cur), pairs, what: format!("loading {rel}") });
            self.model = bound;
            self.cert.refresh_all(self.editor.spline());
        } else {
            let mut next = Doc::new(s, &self.root);
            if let Some((p, m, up)) = model {
                next.set_model_up(p, m, up)?;
            }
            next.frame = self.frame.take();
            next.fixed = self.fixed.take();
            next.landmarks = std::mem::take(&mut self.landmarks);
            *self = next;
        }
        if let Some(f) = frame {
            self.frame = Some(f);
        }
        if let Some(f) = fixed {
            self.fixed = Some(f);
        }
        self.add_pinned(&pinned);
        if let Some(l) = lms {
            self.landmarks = l;
        }
        self.name = Some(rel.to_string());
        self.before_drag = None;
        Ok(())
    }

    /// The sample points of the mesh edges in the reference mesh ([`EDGE_SAMPLES`]).
    pub fn edge_samples(&self) -> &[Vec<(usize, [f64; 3])>] {
        &self.edge_samples
    }

    /// The deformed model's vertices (`psi`), if a model is bound.
    pub fn deformed_model(&self) -> Option<Vec<[f64; 3]>> {
        self.model.as_ref().map(|m| deform(&m.model, &m.binding, self.spline()))
    }

    /// Exports the deformed model (OBJ or PLY by extension) to `rel` inside the root.
    pub fn export_model(&self, rel: &str) -> Result<PathBuf, ServerError> {
        let m =
            self.model.as_ref().ok_or(ServerError::Unprocessable("no model is loaded".into()))?;
        let path = self.output_path(rel)?;
        let v = m.to_file_axes(&deform(&m.model, &m.binding, self.spline()));
        save_model(&m.model, &v, &path).map_err(|e| ServerError::Io(e.to_string()))?;
        Ok(path)
    }

    /// Exports the frame warped by `phi` (`O(q) = I(phi^-1(q))`, as `trimorph warp`).
    pub fn export_warped(&self, rel: &str) -> Result<PathBuf, ServerError> {
        let f =
            self.frame.as_ref().ok_or(ServerError::Unprocessable("no image is loaded".into()))?;
        let path = self.output_path(rel)?;
        let (out, _) = crate::warp::warp_image(
            self.spline(),
            &f.image,
            crate::warp::Interp::Bilinear,
            0.0,
            Default::default(),
        )
        .map_err(|e| ServerError::Unprocessable(e.to_string()))?;
        let mut bytes = Vec::new();
        out.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
            .map_err(|e| ServerError::Io(e.to_string()))?;
        write_atomic(&path, &bytes).map_err(|e| ServerError::Io(e.to_string()))?;
        Ok(path)
    }

    /// Re-runs the fit from the current state with the landmarks in `rel`, holding every
    /// point corrected by hand exactly ([`FitOptions::pinned`]); `hard` makes the
    /// landmarks exact too. One undoable step.
    pub fn refit(&mut self, rel: &str, hard: bool) -> Result<Refitted, ServerError> {
        let path = confine(&self.root, rel, false)?;
        let lms =
            read_landmarks(&path).map_err(|e| ServerError::Unprocessable(format!("{rel}: {e}")))?;
        self.refit_with(&lms, hard, format!("re-fit to {rel}"))
    }

    /// Re-runs the fit from the current state to `lms` with the corrected points pinned
    /// (see [`Doc::refit`]); `what` names the step in the undo history.
    pub fn refit_with(
        &mut self,
        lms: &[Landmark],
        hard: bool,
        what: String,
    ) -> Result<Refitted, ServerError> {
        let opts = FitOptions {
            pinned: self.pinned.iter().copied().collect(),
            hard,
            ..Default::default()
        };
        let f = fit(self.spline(), lms, &opts)
            .map_err(|e| ServerError::Unprocessable(format!("fit: {e}")))?;
        let cur = self.editor.spline().clone();
        self.editor.replace_spline(f.spline).map_err(edit_err)?;
        self.push_undo(cur, what);
        self.before_drag = None;
        self.cert.refresh_all(self.editor.spline());
        Ok(Refitted {
            method: f.report.method,
            rms: f.report.fit.rms,
            max: f.report.fit.max,
            pinned: opts.pinned.len(),
            min_det_j: f.report.min_det_j,
            landmarks: None,
        })
    }
}

use crate::spline::check::within_coord as within;

/// Refuses arguments beyond [`MAX_COORD`] or outside [`SCALE_RANGE`] (422).
fn check_op(op: &Op) -> Result<(), ServerError> {
    let far = |what: &str, v: &[f64]| {
        if v.iter().all(|&x| within(x)) {
            Ok(())
        } else {
            Err(ServerError::Unprocessable(format!(
                "{what} {v:?} is beyond {MAX_COORD} pixels: refused"
            )))
        }
    };
    match op {
        Motion::Translate(t) => far("translation", &t.by),
        Motion::Rotate(r) => {
            far("rotation centre", &r.center)?;
            let angle = r.angle;
            if angle.abs() > 1e3 {
                return Err(ServerError::Unprocessable(format!("angle {angle} rad: refused")));
            }
            Ok(())
        }
        Motion::Scale(s) => {
            far("scale centre", &s.center)?;
            let factor = s.factor;
            if !(SCALE_RANGE[0]..=SCALE_RANGE[1]).contains(&factor.abs()) {
                return Err(ServerError::Unprocessable(format!(
                    "scale factor {factor} is outside {SCALE_RANGE:?}: refused"
                )));
            }
            Ok(())
        }
    }
}

/// The mode's name in the API.
pub fn mode_name(m: Mode) -> &'static str {
    m.name()
}

//! 3D models for 2.5D deformation: OBJ, PLY and XYZ point clouds, with
//! named landmarks in a JSON sidecar.
//!
//! * OBJ: `v x y z` and `f` lines, read by [`crate::io::obj`] (`a`, `a/t`, `a/t/n`, `a//n`;
//!   negative indices; polygons as fans). An OBJ without faces is a point cloud. A model
//!   keeps its file's vertex order (landmarks and correspondences across frames depend on it).
//! * OFF (Object File Format, <https://segeval.cs.princeton.edu/public/off_format.html>): an
//!   optional `OFF` header line (also `COFF`, `NOFF`, `CNOFF`: per-vertex colours and normals
//!   after `x y z` are ignored), then `nv nf ne`, `nv` lines `x y z` and `nf` lines
//!   `n i_1 .. i_n` with 0-based indices (extra values after a face, its colour, are
//!   ignored); `#` starts a comment. Polygons become fans, as in OBJ. Errors name the line.
//! * PLY: ascii or binary, `vertex` with `x y z`, optional `face` (a point cloud without it).
//! * XYZ: one point per line, `x y z` separated by spaces or commas; `#` starts a comment.
//! * Landmarks: `M.landmarks.json` beside `M.obj` (or `.ply`, `.xyz`), an object
//!   `{"name": [x, y, z], ...}`; each name is bound to the model vertex nearest that
//!   position (so the file survives re-indexing by other tools).
//!
//! Up axis: the prisms' height axis is `z`. A model whose up axis is `x` or `y`
//! ([`UpAxis`]) is turned on loading by the cyclic permutation that takes that axis to `z`
//! (a rotation, so faces keep their orientation), and turned back on saving, so written
//! models keep the file's axes.
//!
//! Writing: OBJ with `v`, recomputed unit normals `vn` and `f a//a b//b c//c`; OFF with
//! `OFF`, counts, vertices and triangles; binary
//! little-endian PLY with `x y z nx ny nz` and faces; XYZ for point clouds. Every file is
//! written atomically.

use super::obj::{Obj, ObjError};
use super::{write_atomic, IoError};
use crate::prism::{vertex_normals, Model};
use std::path::{Path, PathBuf};

/// Errors of model input and output.
#[derive(Debug, thiserror::Error)]
pub enum ModelIoError {
    /// File-system error.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The file is malformed.
    #[error("{path}{}: {message}", line.map(|l| format!(", line {l}")).unwrap_or_default())]
    Format {
        /// The file.
        path: PathBuf,
        /// 1-based line, when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A PLY error from the shared reader.
    #[error(transparent)]
    Ply(#[from] crate::io::colormesh::MeshFileError),
    /// Unknown extension.
    #[error("{0}: unknown model format (use .obj, .off, .ply or .xyz)")]
    Extension(PathBuf),
}

fn fmt_err(path: &Path, line: Option<usize>, message: impl Into<String>) -> ModelIoError {
    ModelIoError::Format { path: path.to_path_buf(), line, message: message.into() }
}

fn ext(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// The landmark sidecar of a model file: `M.landmarks.json` for `M.obj`.
pub fn landmarks_path(model: &Path) -> PathBuf {
    model.with_extension("landmarks.json")
}

/// Loads a model (and its landmark sidecar, when present).
pub fn load_model(path: &Path) -> Result<Model, ModelIoError> {
    let bytes =
        std::fs::read(path).map_err(|source| IoError::Read { path: path.to_path_buf(), source })?;
    let mut model = parse_model(&bytes, path)?;
    let side = landmarks_path(path);
    if side.exists() {
        model.landmarks = read_landmarks(&side, &model.vertices)?;
    }
    model.validate().map_err(|e| fmt_err(path, None, e.to_string()))?;
    Ok(model)
}

/// Parses the bytes of a model file; `path` picks the format by its extension and names the
/// file in errors (nothing is read from it, and no landmark sidecar is loaded). The model is
/// not yet validated (see [`Model::validate`]).
pub fn parse_model(bytes: &[u8], path: &Path) -> Result<Model, ModelIoError> {
    let model = match ext(path).as_deref() {
        Some("obj") => read_obj(bytes, path)?,
        Some("off") => read_off(bytes, path)?,
        Some("ply") => {
            let raw = crate::io::colormesh::read_ply_raw(bytes, path, false)?;
            Model { vertices: raw.vertices, triangles: raw.triangles, landmarks: Vec::new() }
        }
        Some("xyz" | "txt" | "csv") => read_xyz(bytes, path)?,
        _ => return Err(ModelIoError::Extension(path.to_path_buf())),
    };
    if model.vertices.is_empty() {
        return Err(fmt_err(path, None, "no vertices"));
    }
    Ok(model)
}

fn read_obj(bytes: &[u8], path: &Path) -> Result<Model, ModelIoError> {
    let obj = Obj::parse(bytes).map_err(|e| obj_error(path, e))?;
    obj.check_faces().map_err(|e| obj_error(path, e))?;
    let mut model = Model::default();
    for v in obj.vertices() {
        if v.values.len() < 3 || v.values[..3].iter().any(|c| !c.is_finite()) {
            return Err(fmt_err(path, Some(v.line), "expected `v x y z` with finite numbers"));
        }
        model.vertices.push([v.values[0], v.values[1], v.values[2]]);
    }
    // Indices are below the vertex count (checked), which fits u32 for any file we read.
    let index =
        |i: usize| u32::try_from(i).map_err(|_| fmt_err(path, None, "more than 2^32 vertices"));
    for t in obj.triangles() {
        model.triangles.push([index(t[0])?, index(t[1])?, index(t[2])?]);
    }
    Ok(model)
}

/// A model's wording of an OBJ statement error (the catalogue's rows `model_obj_*`).
fn obj_error(path: &Path, e: ObjError) -> ModelIoError {
    let message = match &e {
        ObjError::BadNumber { token, .. } => format!("`{token}` is not a number"),
        ObjError::RelativeOutOfRange { index, defined, .. } => {
            format!("vertex index {index} out of range ({defined} vertices)")
        }
        e => e.to_string(),
    };
    fmt_err(path, Some(e.line()), message)
}

fn read_off(bytes: &[u8], path: &Path) -> Result<Model, ModelIoError> {
    let text = std::str::from_utf8(bytes).map_err(|_| fmt_err(path, None, "not UTF-8 text"))?;
    // Content lines (1-based number, tokens) without comments and blank lines.
    let mut lines = text.lines().enumerate().filter_map(|(n, l)| {
        let t: Vec<&str> = l.split('#').next().unwrap_or("").split_whitespace().collect();
        (!t.is_empty()).then_some((n + 1, t))
    });
    let num = |line: usize, t: &str| -> Result<f64, ModelIoError> {
        t.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| fmt_err(path, Some(line), format!("`{t}` is not a finite number")))
    };
    let count = |line: usize, t: &str| -> Result<usize, ModelIoError> {
        t.parse::<usize>().map_err(|_| {
            fmt_err(path, Some(line), format!("`{t}` is not a count (a whole number >= 0)"))
        })
    };
    let (mut line, mut t) =
        lines.next().ok_or_else(|| fmt_err(path, None, "empty file (expected `OFF`)"))?;
    // The header keyword, alone or followed by the counts on the same line.
    if t[0].ends_with("OFF") {
        if t.len() == 1 {
            (line, t) = lines
                .next()
                .ok_or_else(|| fmt_err(path, Some(line), "expected the counts `nv nf ne`"))?;
        } else {
            t.remove(0);
        }
    }
    if t.len() < 2 {
        return Err(fmt_err(path, Some(line), "expected the counts `nv nf ne`"));
    }
    let (nv, nf) = (count(line, t[0])?, count(line, t[1])?);
    // Each vertex and face takes at least a few bytes: counts beyond the file are refused
    // before anything is reserved.
    if nv.saturating_add(nf) > bytes.len() {
        return Err(fmt_err(
            path,
            Some(line),
            format!("{nv} vertices and {nf} faces cannot fit in {} bytes", bytes.len()),
        ));
    }
    let mut model = Model::default();
    model.vertices.reserve(nv);
    let eof = |what: &str, k: usize| {
        fmt_err(path, None, format!("the file ends before {what} {k} (truncated?)"))
    };
    for k in 0..nv {
        let (line, t) = lines.next().ok_or_else(|| eof("vertex", k))?;
        if t.len() < 3 {
            return Err(fmt_err(path, Some(line), format!("vertex {k}: expected `x y z`")));
        }
        model.vertices.push([num(line, t[0])?, num(line, t[1])?, num(line, t[2])?]);
    }
    for k in 0..nf {
        let (line, t) = lines.next().ok_or_else(|| eof("face", k))?;
        let n = count(line, t[0])?;
        if n < 3 || t.len() < n + 1 {
            return Err(fmt_err(
                path,
                Some(line),
                format!("face {k}: expected `n i_1 .. i_n` with n >= 3 vertex indices"),
            ));
        }
        let idx: Vec<u32> = t[1..=n]
            .iter()
            .map(|s| {
                s.parse::<usize>().ok().filter(|&i| i < nv).map(|i| i as u32).ok_or_else(|| {
                    fmt_err(
                        path,
                        Some(line),
                        format!("face {k}: vertex index `{s}` out of range ({nv} vertices)"),
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        for j in 1..n - 1 {
            model.triangles.push([idx[0], idx[j], idx[j + 1]]);
        }
    }
    Ok(model)
}

/// The axis of a model that points up (the prisms' height axis `z` after loading).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UpAxis {
    /// `x` is up: `(x, y, z)` is read as `(y, z, x)`.
    X,
    /// `y` is up: `(x, y, z)` is read as `(z, x, y)`.
    Y,
    /// `z` is up (no change).
    #[default]
    Z,
}

impl std::str::FromStr for UpAxis {
    type Err = String;
    fn from_str(s: &str) -> Result<UpAxis, String> {
        match s.to_ascii_lowercase().as_str() {
            "x" => Ok(UpAxis::X),
            "y" => Ok(UpAxis::Y),
            "z" => Ok(UpAxis::Z),
            _ => Err(format!("`{s}`: the up axis is x, y or z")),
        }
    }
}

/// `--up auto`'s rule: the thinnest extent is the height. A specimen lies flat under the
/// microscope, so its height (the prisms' axis, `z` after loading) is the axis along which
/// its bounding box is thinnest. The rule decides only when that extent is at most
/// [`AUTO_UP_RATIO`] times the next thinnest; otherwise the model has no clear up axis and
/// `--up` must name it.
pub const AUTO_UP_RATIO: f64 = 0.8;

/// The extents of `vertices` along x, y and z (file axes).
pub fn extents(vertices: &[[f64; 3]]) -> [f64; 3] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for v in vertices {
        for a in 0..3 {
            lo[a] = lo[a].min(v[a]);
            hi[a] = hi[a].max(v[a]);
        }
    }
    [0, 1, 2].map(|a| (hi[a] - lo[a]).max(0.0))
}

/// The up axis by [`AUTO_UP_RATIO`]'s rule, or why there is none (the extents, and that
/// `--up` must be given).
///
/// ```
/// use trimorph::io::model::{auto_up, UpAxis};
/// // A worm 1000 long, 170 wide, 60 thick: z is up.
/// let v = [[0.0, 0.0, 0.0], [1000.0, 170.0, 60.0]];
/// assert_eq!(auto_up(&v), Ok(UpAxis::Z));
/// // Lying on its side (y thinnest): y is up.
/// assert_eq!(auto_up(&[[0.0; 3], [1000.0, 60.0, 170.0]]), Ok(UpAxis::Y));
/// // A cube has no up axis.
/// assert!(auto_up(&[[0.0; 3], [1.0, 1.0, 0.9]]).unwrap_err().contains("--up"));
/// ```
pub fn auto_up(vertices: &[[f64; 3]]) -> Result<UpAxis, String> {
    let e = extents(vertices);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| e[a].total_cmp(&e[b]));
    let text = format!("extents x {:.4}, y {:.4}, z {:.4}", e[0], e[1], e[2]);
    // NaN extents (no vertices) are no clear answer either.
    let clear = e[order[0]] <= AUTO_UP_RATIO * e[order[1]];
    if !clear {
        return Err(format!(
            "--up auto: no axis is clearly the model's thinnest ({text}; the rule needs one at \
             most {AUTO_UP_RATIO} times the next), so its up axis is not known: give --up x, y \
             or z"
        ));
    }
    Ok([UpAxis::X, UpAxis::Y, UpAxis::Z][order[0]])
}

/// The scene key that records the up axis of the scene's model when it is not `z`
/// (`"model_up": "x"` or `"y"`, written by `trimorph model bind --up`; an extra key, which the
/// deformation format allows). Readers of a scene's `"model"` load it with this axis.
pub const SCENE_UP_KEY: &str = "model_up";

impl UpAxis {
    /// `"x"`, `"y"` or `"z"`.
    pub fn name(self) -> &'static str {
        match self {
            UpAxis::X => "x",
            UpAxis::Y => "y",
            UpAxis::Z => "z",
        }
    }

    /// The up axis a scene records ([`SCENE_UP_KEY`]; `z` when the key is absent).
    pub fn of_scene(scene: &serde_json::Value) -> Result<UpAxis, String> {
        match scene.get(SCENE_UP_KEY) {
            None => Ok(UpAxis::Z),
            Some(serde_json::Value::String(s)) => {
                s.parse().map_err(|e| format!("key \"{SCENE_UP_KEY}\": {e}"))
            }
            Some(other) => Err(format!(
                "key \"{SCENE_UP_KEY}\": expected \"x\", \"y\" or \"z\", found {other}"
            )),
        }
    }

    /// Records the axis in a scene (nothing for `z`, so z-up scenes stay as they were).
    pub fn record_in(self, scene: &mut serde_json::Value) {
        if self != UpAxis::Z {
            scene[SCENE_UP_KEY] = serde_json::Value::from(self.name());
        }
    }

    /// A point of the file in the z-up frame (a cyclic permutation of the coordinates).
    pub fn to_z_up(self, [x, y, z]: [f64; 3]) -> [f64; 3] {
        match self {
            UpAxis::X => [y, z, x],
            UpAxis::Y => [z, x, y],
            UpAxis::Z => [x, y, z],
        }
    }

    /// The inverse of [`UpAxis::to_z_up`]: a z-up point in the file's axes.
    pub fn from_z_up(self, [a, b, c]: [f64; 3]) -> [f64; 3] {
        match self {
            UpAxis::X => [c, a, b],
            UpAxis::Y => [b, c, a],
            UpAxis::Z => [a, b, c],
        }
    }
}

/// [`load_model`], turned so that `up` becomes `z`.
pub fn load_model_up(path: &Path, up: UpAxis) -> Result<Model, ModelIoError> {
    let mut m = load_model(path)?;
    m.vertices.iter_mut().for_each(|v| *v = up.to_z_up(*v));
    Ok(m)
}

/// [`save_model`] (and the landmark sidecar when the model has landmarks) of z-up
/// `vertices`, turned back so that `z` becomes `up` in the file.
pub fn save_model_up(
    model: &Model,
    vertices: &[[f64; 3]],
    path: &Path,
    up: UpAxis,
) -> Result<(), ModelIoError> {
    let file: Vec<[f64; 3]> = vertices.iter().map(|&v| up.from_z_up(v)).collect();
    save_model(model, &file, path)?;
    if !model.landmarks.is_empty() {
        save_landmarks(model, &file, path)?;
    }
    Ok(())
}

fn read_xyz(bytes: &[u8], path: &Path) -> Result<Model, ModelIoError> {
    let text = std::str::from_utf8(bytes).map_err(|_| fmt_err(path, None, "not UTF-8 text"))?;
    let mut vertices = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let vals: Vec<f64> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| t.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| fmt_err(path, Some(n + 1), format!("expected `x y z`, found `{line}`")))?;
        if vals.len() < 3 || vals[..3].iter().any(|v| !v.is_finite()) {
            if vertices.is_empty() && n == 0 {
                continue; // a header line
            }
            return Err(fmt_err(path, Some(n + 1), format!("expected `x y z`, found `{line}`")));
        }
        vertices.push([vals[0], vals[1], vals[2]]);
    }
    Ok(Model { vertices, ..Default::default() })
}

fn read_landmarks(path: &Path, vertices: &[[f64; 3]]) -> Result<Vec<(String, u32)>, ModelIoError> {
    let text = super::read_text(path)?;
    let v: serde_json::Value =
        crate::json::parse(&text).map_err(|e| fmt_err(path, Some(e.line()), e.to_string()))?;
    let obj =
        v.as_object().ok_or_else(|| fmt_err(path, None, "expected {\"name\": [x, y, z], ...}"))?;
    let mut out = Vec::new();
    for (name, p) in obj {
        let p: Vec<f64> = p
            .as_array()
            .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
            .filter(|a: &Vec<f64>| a.len() == 3)
            .ok_or_else(|| fmt_err(path, None, format!("landmark `{name}`: expected [x, y, z]")))?;
        let (mut best, mut dist) = (0u32, f64::INFINITY);
        for (i, q) in vertices.iter().enumerate() {
            let d = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2);
            if d < dist {
                (best, dist) = (i as u32, d);
            }
        }
        out.push((name.clone(), best));
    }
    Ok(out)
}

/// Writes the landmark sidecar of `model` (positions of its landmark vertices) next to
/// `path`.
pub fn save_landmarks(
    model: &Model,
    vertices: &[[f64; 3]],
    path: &Path,
) -> Result<(), ModelIoError> {
    let mut m = serde_json::Map::new();
    for (name, i) in &model.landmarks {
        m.insert(name.clone(), serde_json::json!(vertices[*i as usize]));
    }
    let text = serde_json::to_string_pretty(&serde_json::Value::Object(m)).unwrap_or_default();
    write_atomic(&landmarks_path(path), text.as_bytes())?;
    Ok(())
}

/// Saves `model`'s topology with the given vertex positions (e.g. deformed), with
/// recomputed normals; the format follows the extension (`.obj`, `.off`, `.ply`, `.xyz`).
pub fn save_model(model: &Model, vertices: &[[f64; 3]], path: &Path) -> Result<(), ModelIoError> {
    use std::fmt::Write as _;
    let normals = vertex_normals(vertices, &model.triangles);
    let bytes = match ext(path).as_deref() {
        Some("obj") => {
            let mut s = String::with_capacity(vertices.len() * 80 + model.triangles.len() * 30);
            s.push_str("# written by trimorph\n");
            for v in vertices {
                let _ = writeln!(s, "v {} {} {}", v[0], v[1], v[2]);
            }
            if !model.triangles.is_empty() {
                for n in &normals {
                    let _ = writeln!(s, "vn {:.6} {:.6} {:.6}", n[0], n[1], n[2]);
                }
            }
            for t in &model.triangles {
                let [a, b, c] = t.map(|i| i + 1);
                let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
            }
            s.into_bytes()
        }
        Some("ply") => {
            let mut out = format!(
                "ply\nformat binary_little_endian 1.0\ncomment written by trimorph\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
                vertices.len(),
                model.triangles.len()
            )
            .into_bytes();
            for (v, n) in vertices.iter().zip(&normals) {
                for c in v {
                    out.extend_from_slice(&c.to_le_bytes());
                }
                for c in n {
                    out.extend_from_slice(&(*c as f32).to_le_bytes());
                }
            }
            for t in &model.triangles {
                out.push(3);
                for i in t {
                    out.extend_from_slice(&i.to_le_bytes());
                }
            }
            out
        }
        Some("off") => {
            let mut s = String::with_capacity(vertices.len() * 60 + model.triangles.len() * 20);
            s.push_str("OFF\n# written by trimorph\n");
            let _ = writeln!(s, "{} {} 0", vertices.len(), model.triangles.len());
            for v in vertices {
                let _ = writeln!(s, "{} {} {}", v[0], v[1], v[2]);
            }
            for [a, b, c] in &model.triangles {
                let _ = writeln!(s, "3 {a} {b} {c}");
            }
            s.into_bytes()
        }
        Some("xyz") => {
            let mut s = String::new();
            for v in vertices {
                let _ = writeln!(s, "{} {} {}", v[0], v[1], v[2]);
            }
            s.into_bytes()
        }
        _ => return Err(ModelIoError::Extension(path.to_path_buf())),
    };
    write_atomic(path, &bytes)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prism::organism::{worm, WormOptions};

    #[test]
    fn models_round_trip_through_obj_ply_and_xyz_with_landmarks() {
        let dir = tempfile::tempdir().unwrap();
        let w = worm(&WormOptions { rings: 12, around: 8, ..Default::default() });
        for name in ["w.obj", "w.ply"] {
            let p = dir.path().join(name);
            save_model(&w, &w.vertices, &p).unwrap();
            save_landmarks(&w, &w.vertices, &p).unwrap();
            let back = load_model(&p).unwrap();
            assert_eq!(back.triangles.len(), w.triangles.len(), "{name}");
            assert_eq!(back.vertices.len(), w.vertices.len(), "{name}");
            // Vertex order and positions are kept exactly (landmarks depend on them).
            assert_eq!(back.vertices, w.vertices, "{name}");
            assert_eq!(back.triangles, w.triangles, "{name}");
            // Same surface: every triangle's corners match some triangle of the original.
            let key = |m: &Model, t: &[u32; 3]| {
                let mut c: Vec<[i64; 3]> = t
                    .iter()
                    .map(|&i| m.vertices[i as usize].map(|x| (x * 1e6).round() as i64))
                    .collect();
                c.sort();
                c
            };
            let mut a: Vec<_> = w.triangles.iter().map(|t| key(&w, t)).collect();
            let mut b: Vec<_> = back.triangles.iter().map(|t| key(&back, t)).collect();
            a.sort();
            b.sort();
            assert_eq!(a, b, "{name}");
            let mut la = back.landmarks.clone();
            la.sort();
            for (n, i) in &la {
                let orig = w.landmarks.iter().find(|(m, _)| m == n).unwrap().1;
                assert_eq!(back.vertices[*i as usize], w.vertices[orig as usize], "{name} {n}");
            }
        }
        let p = dir.path().join("c.xyz");
        save_model(&Model { vertices: w.vertices.clone(), ..Default::default() }, &w.vertices, &p)
            .unwrap();
        assert_eq!(load_model(&p).unwrap().vertices, w.vertices);
    }

    #[test]
    fn off_models_read_like_obj_and_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let off = dir.path().join("q.off");
        // A unit square as one quad, with a comment, a colour after the face, counts on the
        // header line.
        std::fs::write(
            &off,
            "OFF 4 1 0\n# corners\n0 0 0\n1 0 0\n1 1 0.5\n0 1 0\n4 0 1 2 3 255 0 0\n",
        )
        .unwrap();
        let obj = dir.path().join("q.obj");
        std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        let (a, b) = (load_model(&off).unwrap(), load_model(&obj).unwrap());
        assert_eq!(a.vertices, b.vertices);
        assert_eq!(a.triangles, b.triangles);
        let w = worm(&WormOptions { rings: 6, around: 5, ..Default::default() });
        let p = dir.path().join("w.off");
        save_model(&w, &w.vertices, &p).unwrap();
        let back = load_model(&p).unwrap();
        assert_eq!((back.vertices, back.triangles), (w.vertices, w.triangles));
    }

    #[test]
    fn malformed_off_files_name_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        for (name, text, want) in [
            ("a.off", "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n", "a.off, line 4: `x`"),
            (
                "b.off",
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
                "line 6: face 0: vertex index `7`",
            ),
            ("c.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", "ends before vertex 2"),
            ("d.off", "OFF\n9999999 0 0\n", "cannot fit"),
            ("e.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "line 6: face 0: expected"),
            ("f.off", "", "empty file"),
        ] {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            let e = load_model(&p).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains(name), "{name}: {e}");
        }
    }

    #[test]
    fn up_axes_are_rotations_and_round_trip() {
        let p = [1.0, 2.0, 3.0];
        assert_eq!(UpAxis::X.to_z_up(p)[2], 1.0);
        assert_eq!(UpAxis::Y.to_z_up(p)[2], 2.0);
        assert_eq!(UpAxis::Z.to_z_up(p), p);
        for up in [UpAxis::X, UpAxis::Y, UpAxis::Z] {
            assert_eq!(up.from_z_up(up.to_z_up(p)), p);
            // Orientation kept: e_x x e_y = e_z still holds after the turn.
            let [ex, ey, ez] =
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(|v| up.to_z_up(v));
            let cross = [
                ex[1] * ey[2] - ex[2] * ey[1],
                ex[2] * ey[0] - ex[0] * ey[2],
                ex[0] * ey[1] - ex[1] * ey[0],
            ];
            assert_eq!(cross, ez);
        }
        assert_eq!("Y".parse::<UpAxis>(), Ok(UpAxis::Y));
        assert!("w".parse::<UpAxis>().is_err());
    }

    #[test]
    fn malformed_models_name_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        for (name, text, want) in [
            ("a.obj", "v 0 0 0\nv 1 x 0\n", "line 2"),
            ("b.obj", "v 0 0 nan\n", "finite"),
            ("c.xyz", "1 2 3\n4 5\n", "line 2"),
            ("d.obj", "", "no vertices"),
            ("e.stl", "solid", "unknown model format"),
        ] {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            let e = load_model(&p).unwrap_err().to_string();
            assert!(e.contains(want), "{name}: {e}");
        }
    }
}

//! The deformation file (JSON, version 1): `format`, `version`, `degree`, `vertices`,
//! `triangles`, `points`, `patches`, optional `z_range` / `z0` / `z1`, and the `exact` block
//! with every value as a `"p/q"` string in lowest terms. trimorph always writes the exact
//! block and reads it when present, so save -> load -> save is bit-exact. Extra keys written
//! by trimorph: `grid` (the vertex snapping denominator), `last_edit` (anchors and derived
//! points of the last edit, for rendering) and `frame` (the image frame the deformation was
//! made for, [`crate::spline::frame`]: `{"size": [w, h]}` in pixels, with `"spacing"`,
//! `"origin"` and `"unit"` when known). A deformation written by `trimorph fit` or
//! `trimorph register` also carries the landmarks it was fitted to, under
//! [`LANDMARKS_KEY`] (`"landmarks"`, the list of [`crate::fit::landmarks`]' JSON format:
//! `{"name", "src", "dst", "weight"}`), so that the editor's re-fit keeps them and adds
//! the corrections made there; files without the key read as before.
//!
//! Reading accepts files from other tools: the control-point numbering is taken from
//! `patches` (points at one nominal position must be one point), and without an exact block
//! the `f64` values are read exactly (every finite double is a rational). The control points
//! must satisfy the C1 conditions exactly.

use crate::exact::{parse_rat, rat_from_f64, rat_to_f64, rat_to_string, Int, Rat};
use crate::mesh::{Mesh, MeshError, MeshOptions};
use crate::spline::{ControlPoint, ImageFrame, Spline, SplineError, ZLayers};
use num_integer::Integer;
use num_traits::One;
use rayon::prelude::*;
use serde_json::{json, Map, Value};

/// Errors reading a deformation file.
#[derive(Debug, thiserror::Error)]
pub enum DeformationError {
    /// Not JSON.
    #[error("not valid JSON: {0} (is the file complete? deformations are written by `trimorph mesh`, `edit` or `fit`)")]
    Json(String),
    /// Missing or malformed key.
    #[error("{key}: {message}; correct that entry or write the file again with trimorph")]
    Key {
        /// The key (path).
        key: String,
        /// What is wrong.
        message: String,
    },
    /// Wrong format or version.
    #[error("not a trimorph deformation file version 1 ({0}); make one with `trimorph mesh`")]
    Format(String),
    /// The mesh is invalid.
    #[error("reference mesh: {0}")]
    Mesh(#[from] MeshError),
    /// The spline is invalid (for example not C1).
    #[error("spline: {0}")]
    Spline(#[from] SplineError),
    /// Reading the file would exceed the process's memory budget ([`crate::memory`]).
    #[error(transparent)]
    Memory(#[from] crate::memory::OverBudget),
}

/// Peak memory of reading a deformation, per byte of its text: the JSON tree (every exact
/// number kept as its text), the exact control points, the mesh and the spline's tables.
/// Measured on `trimorph mesh --grid 200x200 --size 2000,2000` (degree 5, a 57 MB file):
/// 3.5 GB peak resident for `warp --points` of one point, 61 bytes per file byte; 64 keeps
/// a margin. (Reading is memory-hungry; a streaming reader would lower this.)
pub const READ_BYTES_PER_FILE_BYTE: u64 = 64;

use crate::edit::extra::Extra;
pub use crate::edit::LastEdit;

fn key(k: &str, m: impl Into<String>) -> DeformationError {
    DeformationError::Key { key: k.to_string(), message: m.into() }
}

fn rstr(r: &Rat) -> Value {
    Value::String(rat_to_string(r))
}

/// The JSON document of a spline.
pub fn to_json(s: &Spline, last: Option<&LastEdit>) -> Value {
    to_json_with(s, last, &[])
}

/// The JSON document of a spline with extra constraints (key `"constraints"`).
pub fn to_json_with(s: &Spline, last: Option<&LastEdit>, extras: &[Extra]) -> Value {
    let m = s.mesh();
    let g = Int::from(m.grid_denominator());
    let vexact: Vec<[Rat; 2]> = (0..m.num_vertices())
        .map(|v| m.vertex_int(v).map(|c| Rat::new(Int::from(c), g.clone())))
        .collect();
    let mut doc = Map::new();
    doc.insert("format".into(), json!("trimorph.deformation"));
    doc.insert("version".into(), json!(1));
    doc.insert("degree".into(), json!(s.degree()));
    doc.insert("grid".into(), json!(m.grid_denominator()));
    doc.insert(
        "vertices".into(),
        json!(vexact.iter().map(|v| [rat_to_f64(&v[0]), rat_to_f64(&v[1])]).collect::<Vec<_>>()),
    );
    doc.insert("triangles".into(), json!(m.triangles()));
    doc.insert(
        "points".into(),
        json!((0..s.num_points()).map(|i| s.point_f64(i)).collect::<Vec<_>>()),
    );
    doc.insert("patches".into(), json!(s.layout().patches()));
    let mut exact = Map::new();
    exact.insert(
        "vertices".into(),
        Value::Array(vexact.iter().map(|v| json!([rstr(&v[0]), rstr(&v[1])])).collect()),
    );
    // In parallel: each value is reduced to lowest terms (a gcd) and converted to decimal,
    // which dominates the writing of large exact edits (a select-all rotation of 100
    // triangles writes 25 MB of digits).
    exact.insert(
        "points".into(),
        Value::Array(
            s.points().par_iter().map(|p| Value::Array(p.iter().map(rstr).collect())).collect(),
        ),
    );
    if let Some(z) = s.z_layers() {
        doc.insert("z_range".into(), json!([rat_to_f64(&z.range[0]), rat_to_f64(&z.range[1])]));
        doc.insert("z0".into(), json!(z.z0.iter().map(rat_to_f64).collect::<Vec<_>>()));
        doc.insert("z1".into(), json!(z.z1.iter().map(rat_to_f64).collect::<Vec<_>>()));
        exact.insert("z_range".into(), Value::Array(z.range.iter().map(rstr).collect()));
        exact.insert("z0".into(), Value::Array(z.z0.par_iter().map(rstr).collect()));
        exact.insert("z1".into(), Value::Array(z.z1.par_iter().map(rstr).collect()));
    }
    doc.insert("exact".into(), Value::Object(exact));
    if let Some(f) = s.frame() {
        doc.insert("frame".into(), serde_json::to_value(f).expect("a frame is plain data"));
    }
    if let Some(l) = last {
        doc.insert("last_edit".into(), json!({"anchors": l.anchors, "derived": l.derived}));
    }
    if !extras.is_empty() {
        doc.insert("constraints".into(), Value::Array(extras.iter().map(Extra::to_json).collect()));
    }
    Value::Object(doc)
}

/// The extra constraints stored in a deformation file (key `"constraints"`), checked
/// against the spline's control points.
pub fn constraints_from_str(text: &str, s: &Spline) -> Result<Vec<Extra>, DeformationError> {
    let doc: Value =
        serde_json::from_str(text).map_err(|e| DeformationError::Json(e.to_string()))?;
    match doc.get("constraints") {
        None | Some(Value::Null) => Ok(Vec::new()),
        Some(Value::Array(a)) => a
            .iter()
            .enumerate()
            .map(|(i, c)| {
                Extra::from_json(c, s.points())
                    .map_err(|e| key(&format!("constraints[{i}]"), e.to_string()))
            })
            .collect(),
        Some(_) => Err(key("constraints", "expected an array")),
    }
}

/// The control points recorded as corrected by hand (key `"pinned"`, written by
/// `trimorph editor`; an extra key that format v1 allows). Empty when absent.
pub fn pinned_from_str(text: &str) -> Result<Vec<ControlPoint>, DeformationError> {
    let doc: Value =
        serde_json::from_str(text).map_err(|e| DeformationError::Json(e.to_string()))?;
    match doc.get("pinned") {
        None | Some(Value::Null) => Ok(Vec::new()),
        Some(Value::Array(a)) => a
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v.as_u64().map(|x| ControlPoint(x as usize)).ok_or_else(|| {
                    key(&format!("pinned[{i}]"), "expected a control point index (integer >= 0)")
                })
            })
            .collect(),
        Some(_) => Err(key("pinned", "expected an array of control point indices")),
    }
}

/// The key under which a deformation carries the landmarks it was fitted to.
pub const LANDMARKS_KEY: &str = "landmarks";

/// Landmarks as the JSON landmark format's list (`[]` when they cannot be written: a
/// non-finite value, which fitted landmarks never have).
pub fn landmarks_value(lms: &[crate::fit::landmarks::Landmark]) -> Value {
    let text = crate::fit::landmarks::to_json(lms).unwrap_or_else(|_| "{}".into());
    serde_json::from_str::<Value>(&text)
        .ok()
        .and_then(|v| v.get("landmarks").cloned())
        .unwrap_or_else(|| json!([]))
}

/// [`to_string`] with the landmarks the spline was fitted to under [`LANDMARKS_KEY`]
/// (none: no key, the plain file).
pub fn to_string_with_landmarks(s: &Spline, lms: &[crate::fit::landmarks::Landmark]) -> String {
    let mut v = to_json_with(s, None, &[]);
    if !lms.is_empty() {
        v[LANDMARKS_KEY] = landmarks_value(lms);
    }
    super::json_rows(&v)
}

/// The file text of a spline: one key per line, one row per line for arrays of rows.
pub fn to_string(s: &Spline, last: Option<&LastEdit>) -> String {
    to_string_with(s, last, &[])
}

/// [`to_string`] with extra constraints.
pub fn to_string_with(s: &Spline, last: Option<&LastEdit>, extras: &[Extra]) -> String {
    super::json_rows(&to_json_with(s, last, extras))
}

/// The exact value of `v`; `path` names it in errors (built only then: a file holds
/// thousands of values).
fn num(v: &Value, path: impl Fn() -> String) -> Result<Rat, DeformationError> {
    match v {
        Value::String(s) => parse_rat(s).map_err(|e| key(&path(), e.to_string())),
        Value::Number(n) => {
            let f = n.as_f64().ok_or_else(|| key(&path(), "not a number"))?;
            rat_from_f64(f).ok_or_else(|| key(&path(), "not a finite number"))
        }
        other => Err(key(&path(), format!("expected a number, found {other}"))),
    }
}

/// Rows this long or longer are parsed on the thread pool (a far-field fit's points need a
/// `BigInt` gcd each); an error is then looked up again in order, so the message names the
/// first bad element as the sequential read does.
const PARALLEL_ROWS: usize = 512;

fn rows(v: Option<&Value>, path: &str, width: usize) -> Result<Vec<Vec<Rat>>, DeformationError> {
    let arr = v.and_then(Value::as_array).ok_or_else(|| key(path, "missing or not an array"))?;
    if arr.len() >= PARALLEL_ROWS {
        let row = |r: &Value| -> Option<Vec<Rat>> {
            let r = r.as_array().filter(|r| r.len() == width)?;
            r.iter().map(|x| num(x, String::new).ok()).collect()
        };
        if let Some(all) = arr.par_iter().map(row).collect::<Option<Vec<_>>>() {
            return Ok(all);
        }
    }
    arr.iter()
        .enumerate()
        .map(|(i, r)| {
            let p = || format!("{path}[{i}]");
            let r = r.as_array().ok_or_else(|| key(&p(), "expected an array"))?;
            // Exactly `width`: a third coordinate would be dropped without a word (issue 54).
            if r.len() != width {
                return Err(key(
                    &p(),
                    format!("expected {width} values (x, y), found {}", r.len()),
                ));
            }
            r.iter().enumerate().map(|(j, x)| num(x, || format!("{}[{j}]", p()))).collect()
        })
        .collect()
}

fn scalars(v: Option<&Value>, path: &str) -> Result<Vec<Rat>, DeformationError> {
    let arr = v.and_then(Value::as_array).ok_or_else(|| key(path, "missing or not an array"))?;
    arr.iter().enumerate().map(|(i, x)| num(x, || format!("{path}[{i}]"))).collect()
}

fn indices(v: Option<&Value>, path: &str) -> Result<Vec<Vec<usize>>, DeformationError> {
    let arr = v.and_then(Value::as_array).ok_or_else(|| key(path, "missing or not an array"))?;
    arr.iter()
        .enumerate()
        .map(|(i, r)| {
            let p = || format!("{path}[{i}]");
            r.as_array()
                .ok_or_else(|| key(&p(), "expected an array of indices"))?
                .iter()
                .map(|x| {
                    x.as_u64()
                        .map(|u| u as usize)
                        .ok_or_else(|| key(&p(), "expected non-negative integers"))
                })
                .collect()
        })
        .collect()
}

/// Reads a deformation file; returns the spline and the last edit, if recorded. The control
/// points must satisfy every C1 condition exactly.
pub fn from_str(text: &str) -> Result<(Spline, Option<LastEdit>), DeformationError> {
    read(text, true)
}

/// Reads a deformation file without requiring C1 (for `trimorph check`).
pub fn from_str_unchecked(text: &str) -> Result<(Spline, Option<LastEdit>), DeformationError> {
    read(text, false)
}

fn read(text: &str, require_c1: bool) -> Result<(Spline, Option<LastEdit>), DeformationError> {
    let need = crate::memory::bytes_of(text.len() as u64, READ_BYTES_PER_FILE_BYTE);
    crate::memory::check(need, || {
        format!("reading a deformation file of {}", crate::memory::format_size(text.len() as u64))
    })?;
    let doc: Value = crate::json::parse(text).map_err(|e| DeformationError::Json(e.to_string()))?;
    let doc =
        doc.as_object().ok_or_else(|| DeformationError::Format("not a JSON object".into()))?;
    if doc.get("format").and_then(Value::as_str) != Some("trimorph.deformation") {
        return Err(DeformationError::Format("\"format\" must be \"trimorph.deformation\"".into()));
    }
    match doc.get("version").and_then(Value::as_u64) {
        Some(1) => {}
        _ => {
            let found = doc.get("version").map_or("none".to_string(), Value::to_string);
            return Err(DeformationError::Format(format!(
                "\"version\" is {found}, this trimorph reads version 1 (a newer trimorph may read it)"
            )));
        }
    }
    let degree = match doc.get("degree") {
        None => return Err(key("degree", "missing")),
        Some(d) => d
            .as_u64()
            .and_then(|d| usize::try_from(d).ok())
            .ok_or_else(|| key("degree", format!("expected a whole number, found {d}")))?,
    };
    let ex = doc.get("exact").and_then(Value::as_object);
    let pick = |k: &str| ex.and_then(|e| e.get(k)).or_else(|| doc.get(k));
    let pick_path = |k: &str| {
        if ex.is_some_and(|e| e.contains_key(k)) {
            format!("exact.{k}")
        } else {
            k.to_string()
        }
    };
    let verts = rows(pick("vertices"), &pick_path("vertices"), 2)?;
    // The grid: least common denominator of the vertex coordinates.
    let mut grid = Int::one();
    for v in verts.iter().flatten() {
        grid = grid.lcm(v.denom());
    }
    // The file's own `grid` (the snapping denominator it was made with) joins by the least
    // common multiple: a vertex at 1/3 on a file grid of 16 needs 48, not 16 (which would
    // snap it silently).
    let file_grid = match doc.get("grid") {
        None => 1,
        Some(v) => v.as_i64().filter(|g| (1..=1 << 20).contains(g)).ok_or_else(|| {
            key("grid", format!("expected a whole number from 1 to 2^20, found {v}"))
        })?,
    };
    let grid = match grid.as_i64() {
        Some(g) if num_integer::Integer::lcm(&g, &file_grid) <= 1 << 20 => {
            num_integer::Integer::lcm(&g, &file_grid)
        }
        _ => {
            return Err(key(
                "vertices",
                "vertex coordinates are not on a grid of at most 2^20 steps per unit",
            ))
        }
    };
    let vf: Vec<[f64; 2]> = verts.iter().map(|v| [rat_to_f64(&v[0]), rat_to_f64(&v[1])]).collect();
    let tris: Vec<[usize; 3]> = indices(doc.get("triangles"), "triangles")?
        .into_iter()
        .enumerate()
        .map(|(i, t)| {
            <[usize; 3]>::try_from(t)
                .map_err(|_| key(&format!("triangles[{i}]"), "expected 3 indices"))
        })
        .collect::<Result<_, _>>()?;
    let mesh = Mesh::from_triangles(&vf, &tris, MeshOptions { grid })?;
    let template = Spline::identity(mesh.clone(), degree)?;
    let file_points = rows(pick("points"), &pick_path("points"), 2)?;
    let patches = indices(doc.get("patches"), "patches")?;
    let lay = template.layout();
    if patches.len() != lay.patches().len() {
        return Err(key(
            "patches",
            format!("{} patches for {} triangles", patches.len(), lay.patches().len()),
        ));
    }
    // Our point -> the file's point, consistent across patches.
    let mut map: Vec<Option<usize>> = vec![None; template.num_points()];
    for (t, (ours, theirs)) in lay.patches().iter().zip(&patches).enumerate() {
        if theirs.len() != ours.len() {
            return Err(key(&format!("patches[{t}]"), format!("expected {} points", ours.len())));
        }
        for (&o, &f) in ours.iter().zip(theirs) {
            if f >= file_points.len() {
                return Err(key(&format!("patches[{t}]"), format!("point {f} does not exist")));
            }
            match map[o] {
                None => map[o] = Some(f),
                Some(g) if g == f => {}
                Some(g) => {
                    return Err(key(
                        &format!("patches[{t}]"),
                        format!(
                            "points {g} and {f} share a nominal position but differ (C0 broken)"
                        ),
                    ))
                }
            }
        }
    }
    let points: Vec<Vec<Rat>> =
        map.iter().map(|f| file_points[f.expect("every point is in a patch")].clone()).collect();
    let remap_scalar = |k: &str| -> Result<Vec<Rat>, DeformationError> {
        let v = scalars(pick(k), &pick_path(k))?;
        map.iter()
            .map(|f| v.get(f.expect("mapped")).cloned().ok_or_else(|| key(k, "too few values")))
            .collect()
    };
    let z = if doc.contains_key("z_range") {
        let range = scalars(pick("z_range"), &pick_path("z_range"))?;
        if range.len() != 2 || range[0] >= range[1] {
            return Err(key("z_range", "expected [a, b] with a < b"));
        }
        Some(ZLayers {
            range: [range[0].clone(), range[1].clone()],
            z0: remap_scalar("z0")?,
            z1: remap_scalar("z1")?,
        })
    } else {
        None
    };
    let last = match doc.get("last_edit") {
        Some(Value::Object(o)) => {
            let list = |k: &str| -> Vec<ControlPoint> {
                o.get(k)
                    .and_then(Value::as_array)
                    .map(|a| {
                        a.iter()
                            .filter_map(Value::as_u64)
                            .map(|u| ControlPoint(u as usize))
                            .collect()
                    })
                    .unwrap_or_default()
            };
            Some(LastEdit { anchors: list("anchors"), derived: list("derived") })
        }
        _ => None,
    };
    let frame = doc.get("frame").map(read_frame).transpose()?;
    let mut spline = if require_c1 {
        Spline::from_points(mesh, degree, points, z)?
    } else {
        Spline::from_points_unchecked(mesh, degree, points, z)?
    };
    spline.set_frame(frame);
    Ok((spline, last))
}

/// The `"frame"` object: `size` (required), `spacing`, `origin` (pairs of numbers) and
/// `unit` (a string), each checked ([`ImageFrame::validate`]).
fn read_frame(v: &Value) -> Result<ImageFrame, DeformationError> {
    let o =
        v.as_object().ok_or_else(|| key("frame", "expected an object with \"size\": [w, h]"))?;
    let pair = |k: &str| -> Result<Option<[f64; 2]>, DeformationError> {
        match o.get(k) {
            None | Some(Value::Null) => Ok(None),
            Some(Value::Array(a)) if a.len() == 2 => {
                let mut out = [0.0; 2];
                for (i, x) in a.iter().enumerate() {
                    out[i] = x.as_f64().filter(|f| f.is_finite()).ok_or_else(|| {
                        key(
                            &format!("frame.{k}[{i}]"),
                            format!("expected a finite number, found {x}"),
                        )
                    })?;
                }
                Ok(Some(out))
            }
            Some(x) => Err(key(&format!("frame.{k}"), format!("expected [x, y], found {x}"))),
        }
    };
    let size = pair("size")?.ok_or_else(|| key("frame.size", "missing"))?;
    let unit = match o.get("unit") {
        None | Some(Value::Null) => None,
        Some(Value::String(u)) => Some(u.clone()),
        Some(x) => return Err(key("frame.unit", format!("expected a string, found {x}"))),
    };
    let f = ImageFrame { size, spacing: pair("spacing")?, origin: pair("origin")?, unit };
    f.validate().map_err(|e| key("frame", e.to_string()))?;
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::rat_int;

    #[test]
    fn round_trip_is_bit_exact() {
        let pts = [[0.0, 0.0], [10.0, 0.5], [3.3, 7.1], [8.0, 9.0], [-2.0, 5.0]];
        let mesh = Mesh::delaunay(&pts, MeshOptions::default()).unwrap();
        let mut s = Spline::identity(mesh, 5).unwrap();
        let n = s.num_points();
        s.set_z_layers(Some(ZLayers {
            range: [rat_int(-1), rat_int(1)],
            z0: vec![rat_int(-1); n],
            z1: vec![Rat::new(3.into(), 7.into()); n],
        }));
        let last = LastEdit {
            anchors: vec![ControlPoint(1)],
            derived: ControlPoint::from_indices(&[2, 3]),
        };
        let text = to_string(&s, Some(&last));
        let (back, l2) = from_str(&text).unwrap();
        assert_eq!(l2, Some(last.clone()));
        assert_eq!(back.points(), s.points());
        assert_eq!(back.z_layers(), s.z_layers());
        assert_eq!(to_string(&back, Some(&last)), text);
    }

    #[test]
    fn the_frame_survives_a_round_trip_and_bad_frames_are_named() {
        let pts = [[0.0, 0.0], [10.0, 0.5], [3.3, 7.1], [8.0, 9.0]];
        let mesh = Mesh::delaunay(&pts, MeshOptions::default()).unwrap();
        let mut s = Spline::identity(mesh, 5).unwrap();
        let mut f = ImageFrame::new([11.0, 10.0]).unwrap();
        f.spacing = Some([0.5, 0.25]);
        f.unit = Some("micrometer".into());
        s.set_frame(Some(f.clone()));
        let text = to_string(&s, None);
        let (back, _) = from_str(&text).unwrap();
        assert_eq!(back.frame(), Some(&f));
        assert_eq!(to_string(&back, None), text);
        // A copy with other points keeps it.
        let copy = back.with_points_c1_by_construction(back.points().to_vec()).unwrap();
        assert_eq!(copy.frame(), Some(&f));
        let with = |k: &str, v: Value| {
            let mut doc: Value = serde_json::from_str(&text).unwrap();
            doc["frame"][k] = v;
            from_str(&doc.to_string()).unwrap_err().to_string()
        };
        let e = with("size", json!([11.0, -1.0]));
        assert!(e.contains("frame") && e.contains("positive"), "{e}");
        let e = with("unit", json!(3));
        assert!(e.contains("frame.unit"), "{e}");
    }

    /// Long point lists are parsed on the thread pool; a bad element is still the first one
    /// in the file's order, named by its path, and a good file reads back exactly.
    #[test]
    fn long_point_lists_read_in_parallel_name_the_first_bad_element() {
        let pts: Vec<[f64; 2]> =
            (0..64).map(|k| [(k % 8) as f64 * 10.0, (k / 8) as f64 * 10.0 + 0.25]).collect();
        let s = Spline::identity(Mesh::delaunay(&pts, MeshOptions::default()).unwrap(), 5).unwrap();
        assert!(s.num_points() >= PARALLEL_ROWS);
        let text = to_string(&s, None);
        assert_eq!(from_str(&text).unwrap().0.points(), s.points());
        let doc = to_json(&s, None);
        for (bad, why) in [(json!("1/x"), "1/x"), (json!([1]), "expected 2 values")] {
            let mut d = doc.clone();
            d["exact"]["points"][700] = json!(["1/y", "0"]);
            d["exact"]["points"][600][1] = bad.clone();
            if bad.is_array() {
                d["exact"]["points"][600] = bad;
            }
            let e = from_str(&d.to_string()).unwrap_err().to_string();
            assert!(e.contains("exact.points[600]") && e.contains(why), "{e}");
        }
    }

    #[test]
    fn bad_files_are_reported() {
        assert!(matches!(from_str("{"), Err(DeformationError::Json(_))));
        assert!(matches!(from_str("{\"format\": \"x\"}"), Err(DeformationError::Format(_))));
        assert!(matches!(
            from_str("{\"format\": \"trimorph.deformation\", \"version\": 2}"),
            Err(DeformationError::Format(_))
        ));
        let pts = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        let s = Spline::identity(Mesh::delaunay(&pts, MeshOptions::default()).unwrap(), 5).unwrap();
        let mut doc = to_json(&s, None);
        // Break C1: move one medial point in the exact block.
        let q = s.quads()[0];
        doc["exact"]["points"][q.l][0] = json!("1/3");
        assert!(matches!(
            from_str(&doc.to_string()),
            Err(DeformationError::Spline(SplineError::NotC1 { .. }))
        ));
        let mut doc = to_json(&s, None);
        doc["patches"][0][0] = json!(999);
        assert!(matches!(from_str(&doc.to_string()), Err(DeformationError::Key { .. })));
    }
}

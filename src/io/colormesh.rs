//! Colored meshes in files: Wavefront OBJ with vertex colors, and PLY.
//!
//! Coordinates are written as they are (pixel coordinates, y down, see
//! [`crate::warp::colormesh`]) with `z = 0`; a `z` read back must be finite and is ignored.
//!
//! # OBJ
//!
//! * Written as `v x y 0 r g b` (six decimals, colors as `0..1` floats) and `f a b c`
//!   (1-based). OBJ has no alpha: it is dropped on writing and read as 255. A flat mesh is
//!   written with three vertices per triangle, all of the triangle's color, so reading it back
//!   gives a [`Colors::PerVertex`] mesh that looks the same.
//! * Read by [`crate::io::obj`] (faces triangulated as fans, negative indices allowed, several
//!   objects concatenated). Every `v` line must carry a color (`v x y z r g b`). Colors are
//!   `0..1` floats; if any component in the file exceeds 1, all are read as `0..255` instead.
//!   Vertices come out **in the order each object's faces first use them** (as `tobj`'s single
//!   index did before), unused vertices are dropped and a vertex shared by two objects is
//!   repeated; the triangles keep their order and corners.
//!
//! # PLY
//!
//! * Read: `ascii`, `binary_little_endian` and `binary_big_endian`. Element `vertex` with
//!   `x`, `y` (any numeric type), optional `z`, and `red`, `green`, `blue`, optional `alpha`
//!   (also `diffuse_red`, ...) as `uchar` or as `float` / `double` in `0..1`; element `face`
//!   with a `vertex_indices` (or `vertex_index`) list of integers, polygons fan-triangulated,
//!   optional face colors like the vertex ones. Face colors, when present, win: the mesh is
//!   flat ([`Colors::PerTriangle`], one color per fan triangle); otherwise vertex colors are
//!   used. Other elements and properties are skipped. The header's counts are checked against
//!   the file size before anything is allocated.
//! * Written as `binary_little_endian` by default ([`PlyFormat`]): `double x, y, z`, then
//!   `uchar red, green, blue, alpha` on the vertices (per-vertex colors) or on the faces (flat);
//!   ascii coordinates use the shortest text that reads back to the same `f64`.
//!
//! Errors name the file and the line (text) or element (binary) at fault.

use std::collections::HashMap;
use std::fmt;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::obj::{Obj, ObjError};
use crate::warp::colormesh::{ColorMesh, ColorMeshError, Colors};

/// Where in a file a problem is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// The file as a whole.
    File,
    /// The header (PLY).
    Header,
    /// A line of a text file (1-based).
    Line(usize),
    /// An element of a binary file, e.g. `vertex 12` (0-based index).
    Element {
        /// Element name (`vertex`, `face`, ...).
        name: String,
        /// Index of the element.
        index: u64,
    },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::File => write!(f, "file"),
            Location::Header => write!(f, "header"),
            Location::Line(n) => write!(f, "line {n}"),
            Location::Element { name, index } => write!(f, "{name} {index}"),
        }
    }
}

/// Errors of colored mesh files: reading, parsing and writing them. A mesh that is itself
/// invalid (a bad index, a non-finite vertex, a color count that does not match) is
/// [`MeshFileError::Mesh`] when it is about to be written; when it is read from a file it is
/// a [`MeshFileError::Format`] naming the file.
#[derive(Debug, thiserror::Error)]
pub enum MeshFileError {
    /// A file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::IoError),
    /// A file's content is malformed.
    #[error("{}: {location}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// Where in the file.
        location: Location,
        /// What is wrong.
        message: String,
    },
    /// The file name has no known mesh extension.
    #[error("{}: unknown colored mesh format (use .obj or .ply)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The mesh to be written is invalid.
    #[error(transparent)]
    Mesh(#[from] ColorMeshError),
}

/// Encoding of a written PLY file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlyFormat {
    /// `binary_little_endian 1.0`.
    #[default]
    BinaryLittleEndian,
    /// `binary_big_endian 1.0`.
    BinaryBigEndian,
    /// `ascii 1.0`.
    Ascii,
}

fn fail(path: &Path, location: Location, message: impl Into<String>) -> MeshFileError {
    MeshFileError::Format { path: path.to_path_buf(), location, message: message.into() }
}

fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// Reads a colored mesh from a `.obj` or `.ply` file (extension case-insensitive).
pub fn load(path: &Path) -> Result<ColorMesh, MeshFileError> {
    let ext = extension(path);
    if !matches!(ext.as_deref(), Some("obj" | "ply")) {
        return Err(MeshFileError::UnknownFormat { path: path.to_path_buf() });
    }
    let bytes = std::fs::read(path)
        .map_err(|source| MeshFileError::Read { path: path.to_path_buf(), source })?;
    let mesh = if ext.as_deref() == Some("obj") {
        read_obj(&bytes, path)?
    } else {
        read_ply(&bytes, path)?
    };
    mesh.validate().map_err(|e| fail(path, Location::File, e.to_string()))?;
    Ok(mesh)
}

/// Writes a (valid) colored mesh to a `.obj` or `.ply` (binary little endian) file,
/// atomically.
pub fn save(mesh: &ColorMesh, path: &Path) -> Result<(), MeshFileError> {
    match extension(path).as_deref() {
        Some("obj") => {
            mesh.validate()?;
            Ok(crate::io::write_atomic(path, write_obj(mesh).as_bytes())?)
        }
        Some("ply") => save_ply(mesh, path, PlyFormat::default()),
        _ => Err(MeshFileError::UnknownFormat { path: path.to_path_buf() }),
    }
}

/// Writes a (valid) colored mesh to a PLY file in the given encoding, atomically.
pub fn save_ply(mesh: &ColorMesh, path: &Path, format: PlyFormat) -> Result<(), MeshFileError> {
    mesh.validate()?;
    Ok(crate::io::write_atomic(path, &write_ply(mesh, format))?)
}

/// OBJ text of a mesh (see the module docs; a flat mesh gets three vertices per triangle).
pub fn write_obj(mesh: &ColorMesh) -> String {
    let mut s = format!(
        "# trimorph colored mesh: {} vertices, {} triangles, pixel coordinates (y down)\n",
        mesh.vertices.len(),
        mesh.triangles.len()
    );
    let mut vertex = |p: Option<&[f64; 2]>, c: Option<&[u8; 4]>| {
        let ([x, y], [r, g, b, _]) =
            (p.copied().unwrap_or_default(), c.copied().unwrap_or_default());
        let f = |v: u8| f64::from(v) / 255.0;
        let _ = writeln!(s, "v {x:.6} {y:.6} 0 {:.6} {:.6} {:.6}", f(r), f(g), f(b));
    };
    match &mesh.colors {
        Colors::PerVertex(c) => {
            for (k, p) in mesh.vertices.iter().enumerate() {
                vertex(Some(p), c.get(k));
            }
        }
        Colors::PerTriangle(c) => {
            for (k, t) in mesh.triangles.iter().enumerate() {
                for &i in t {
                    vertex(mesh.vertices.get(i as usize), c.get(k));
                }
            }
        }
    }
    let flat = matches!(mesh.colors, Colors::PerTriangle(_));
    for (k, t) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = if flat { [0, 1, 2].map(|j| 3 * k as u64 + j) } else { t.map(u64::from) };
        let _ = writeln!(s, "f {} {} {}", a + 1, b + 1, c + 1);
    }
    s
}

/// Reads OBJ text (`path` only names the file in errors; see the module docs).
pub fn read_obj(bytes: &[u8], path: &Path) -> Result<ColorMesh, MeshFileError> {
    let obj = Obj::parse(bytes).map_err(|e| obj_error(path, e))?;
    let (mut points, mut rgb, mut over_1) = (Vec::new(), Vec::new(), false);
    for v in obj.vertices() {
        let (at, vals) = (Location::Line(v.line), v.values);
        if vals.len() != 6 {
            let msg = match vals.len() {
                3 | 4 => "vertex without a color; colored OBJ needs `v x y z r g b` (or use PLY)",
                _ => "expected `v x y z r g b`",
            };
            return Err(fail(path, at, format!("{msg}; found {} values", vals.len())));
        }
        if let Some(v) = vals[..3].iter().find(|v| !v.is_finite()) {
            return Err(fail(path, at, format!("vertex coordinate {v} is not finite")));
        }
        if let Some(c) = vals[3..].iter().find(|c| !(0.0..=255.0).contains(*c)) {
            return Err(fail(path, at, format!("color component {c} is outside 0..1 (or 0..255)")));
        }
        over_1 |= vals[3..].iter().any(|&c| c > 1.0);
        points.push([vals[0], vals[1]]);
        rgb.push([vals[3], vals[4], vals[5]]);
    }
    obj.check_faces().map_err(|e| obj_error(path, e))?;
    let scale = if over_1 { 1.0 } else { 255.0 };
    let u = |v: f64| (v * scale).round().clamp(0.0, 255.0) as u8;
    // Vertices are numbered in the order each object's faces first use them (a vertex used
    // by two objects is repeated, an unused one dropped); triangles keep their order.
    let (mut vertices, mut colors, mut triangles) = (Vec::new(), Vec::new(), Vec::new());
    let mut renumber: HashMap<usize, u32> = HashMap::new();
    let mut object = None;
    for face in obj.faces() {
        if object != Some(face.object) {
            (object, renumber) = (Some(face.object), HashMap::new());
        }
        for t in face.fan() {
            let mut tri = [0u32; 3];
            for (slot, &i) in tri.iter_mut().zip(&t) {
                *slot = match renumber.get(&i) {
                    Some(&k) => k,
                    None => {
                        let k = u32::try_from(vertices.len())
                            .map_err(|_| fail(path, Location::File, "more than 2^32 vertices"))?;
                        vertices.push(points[i]);
                        let [r, g, b] = rgb[i].map(u);
                        colors.push([r, g, b, 255]);
                        renumber.insert(i, k);
                        k
                    }
                };
            }
            triangles.push(tri);
        }
    }
    if triangles.is_empty() {
        return Err(fail(path, Location::File, "no triangles (faces)"));
    }
    Ok(ColorMesh { vertices, triangles, colors: Colors::PerVertex(colors) })
}

/// A colored mesh's wording of an OBJ statement error.
fn obj_error(path: &Path, e: ObjError) -> MeshFileError {
    let at = Location::Line(e.line());
    match &e {
        ObjError::BadNumber { token, .. } => fail(path, at, format!("`{token}` is not a number")),
        ObjError::ZeroIndex { .. }
        | ObjError::RelativeOutOfRange { .. }
        | ObjError::OutOfRange { .. } => {
            fail(path, at, format!("face vertex index out of bounds: {e}"))
        }
        _ => fail(path, at, e.to_string()),
    }
}

/// PLY bytes of a mesh (see the module docs).
pub fn write_ply(mesh: &ColorMesh, format: PlyFormat) -> Vec<u8> {
    let (enc, name) = match format {
        PlyFormat::BinaryLittleEndian => (Enc::Le, "binary_little_endian"),
        PlyFormat::BinaryBigEndian => (Enc::Be, "binary_big_endian"),
        PlyFormat::Ascii => (Enc::Ascii, "ascii"),
    };
    let (vc, fc) = match &mesh.colors {
        Colors::PerVertex(c) => (Some(c), None),
        Colors::PerTriangle(c) => (None, Some(c)),
    };
    let rgba =
        "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n";
    let big = mesh.vertices.len() > i32::MAX as usize;
    let mut out = format!(
        "ply\nformat {name} 1.0\ncomment trimorph colored mesh, pixel coordinates (y down)\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n{}\
         element face {}\nproperty list uchar {} vertex_indices\n{}end_header\n",
        mesh.vertices.len(),
        if vc.is_some() { rgba } else { "" },
        mesh.triangles.len(),
        if big { "uint" } else { "int" },
        if fc.is_some() { rgba } else { "" },
    )
    .into_bytes();
    let color = |c: Option<&Vec<[u8; 4]>>, k: usize| c.and_then(|c| c.get(k).copied());
    for (k, &[x, y]) in mesh.vertices.iter().enumerate() {
        record(&mut out, enc, &[x, y, 0.0], &[], color(vc, k));
    }
    for (k, t) in mesh.triangles.iter().enumerate() {
        record(&mut out, enc, &[], t, color(fc, k));
    }
    out
}

/// Appends one PLY element: `doubles`, then the list `ints` (if any), then the color.
fn record(out: &mut Vec<u8>, enc: Enc, doubles: &[f64], ints: &[u32], c: Option<[u8; 4]>) {
    let ordered = |b: Vec<u8>| if enc == Enc::Be { b.into_iter().rev().collect() } else { b };
    if enc == Enc::Ascii {
        let mut words: Vec<String> = doubles.iter().map(f64::to_string).collect();
        if !ints.is_empty() {
            words.push(ints.len().to_string());
        }
        words.extend(ints.iter().map(u32::to_string));
        words.extend(c.iter().flatten().map(u8::to_string));
        out.extend_from_slice(words.join(" ").as_bytes());
        out.push(b'\n');
        return;
    }
    doubles.iter().for_each(|v| out.extend(ordered(v.to_le_bytes().to_vec())));
    out.extend((!ints.is_empty()).then_some(ints.len() as u8));
    ints.iter().for_each(|i| out.extend(ordered(i.to_le_bytes().to_vec())));
    out.extend(c.iter().flatten());
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Enc {
    Ascii,
    Le,
    Be,
}

/// A PLY scalar type: size in bytes, and whether it is a float or a signed integer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Ty {
    size: usize,
    float: bool,
    signed: bool,
}

const fn ty(size: usize, float: bool, signed: bool) -> Ty {
    Ty { size, float, signed }
}
const U8: Ty = ty(1, false, false);
/// PLY type names (old and new style) and their types.
const TYPES: [(&str, &str, Ty); 8] = [
    ("char", "int8", ty(1, false, true)),
    ("uchar", "uint8", U8),
    ("short", "int16", ty(2, false, true)),
    ("ushort", "uint16", ty(2, false, false)),
    ("int", "int32", ty(4, false, true)),
    ("uint", "uint32", ty(4, false, false)),
    ("float", "float32", ty(4, true, true)),
    ("double", "float64", ty(8, true, true)),
];

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        TYPES.iter().find(|t| t.0 == s || t.1 == s).map(|t| t.2)
    }
    fn is_int(self) -> bool {
        !self.float
    }
    /// Range of an integer type.
    fn range(self) -> (f64, f64) {
        let bits = 8 * self.size as i32;
        if self.signed {
            (-(2f64.powi(bits - 1)), 2f64.powi(bits - 1) - 1.0)
        } else {
            (0.0, 2f64.powi(bits) - 1.0)
        }
    }
}

/// A property: a scalar, or a list (count type, item type).
#[derive(Clone, Debug)]
struct Prop {
    name: String,
    ty: Ty,
    list: Option<Ty>,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Prop>,
}

/// Parses the header: encoding, elements, offset of the body and its first line number.
fn header(bytes: &[u8], path: &Path) -> Result<(Enc, Vec<Element>, usize, usize), MeshFileError> {
    let (mut pos, mut enc, mut elems, mut n) = (0usize, None, Vec::<Element>::new(), 0);
    loop {
        n += 1;
        let at = Location::Line(n);
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(fail(path, at, "the header has no `end_header` line"));
        };
        let line = std::str::from_utf8(&bytes[pos..pos + len])
            .map_err(|_| fail(path, at.clone(), "header line is not text"))?
            .trim_end_matches('\r');
        pos += len + 1;
        let w: Vec<&str> = line.split_whitespace().collect();
        if n == 1 {
            if w != ["ply"] {
                return Err(fail(path, at, "not a PLY file (no `ply` magic line)"));
            }
            continue;
        }
        match w.as_slice() {
            ["format", f, "1.0"] => {
                enc = Some(match *f {
                    "ascii" => Enc::Ascii,
                    "binary_little_endian" => Enc::Le,
                    "binary_big_endian" => Enc::Be,
                    _ => return Err(fail(path, at, format!("unknown PLY format `{f}`"))),
                })
            }
            ["comment" | "obj_info", ..] | [] => {}
            ["element", name, count] => {
                let count =
                    count.parse().map_err(|_| fail(path, at, format!("bad count `{count}`")))?;
                elems.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            ["property", rest @ ..] => {
                let ty = |s: &str| {
                    Ty::parse(s)
                        .ok_or_else(|| fail(path, at.clone(), format!("unknown type `{s}`")))
                };
                let prop = match rest {
                    ["list", ct, it, name] if ty(ct)?.is_int() => {
                        Prop { name: name.to_string(), ty: ty(it)?, list: Some(ty(ct)?) }
                    }
                    [t, name] => Prop { name: name.to_string(), ty: ty(t)?, list: None },
                    _ => return Err(fail(path, at, format!("malformed property line `{line}`"))),
                };
                let Some(e) = elems.last_mut() else {
                    return Err(fail(path, at, "property before any element"));
                };
                e.props.push(prop);
            }
            ["end_header"] => {
                let enc = enc.ok_or_else(|| fail(path, at, "no `format` line"))?;
                return Ok((enc, elems, pos, n + 1));
            }
            _ => return Err(fail(path, at, format!("unexpected header line `{line}`"))),
        }
    }
}

/// The body of a PLY file, read value by value.
struct Body<'a> {
    enc: Enc,
    data: &'a [u8],
    pos: usize,
    line: usize,
    toks: std::str::SplitAsciiWhitespace<'a>,
}

impl<'a> Body<'a> {
    /// Starts an element: in ascii, moves to its (next non-empty) line.
    fn begin(&mut self) -> Result<(), String> {
        if self.enc != Enc::Ascii {
            return Ok(());
        }
        loop {
            if self.pos >= self.data.len() {
                return Err("unexpected end of file".into());
            }
            let rest = &self.data[self.pos..];
            let len = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            self.pos += len + 1;
            self.line += 1;
            let text = std::str::from_utf8(&rest[..len]).map_err(|_| "not text".to_string())?;
            if !text.trim().is_empty() {
                self.toks = text.split_ascii_whitespace();
                return Ok(());
            }
        }
    }
    /// Ends an element: in ascii, no value may be left on its line.
    fn end(&mut self) -> Result<(), String> {
        match self.toks.next() {
            Some(t) => Err(format!("unexpected extra value `{t}`")),
            None => Ok(()),
        }
    }
    fn value(&mut self, ty: Ty) -> Result<f64, String> {
        let v = match self.enc {
            Enc::Ascii => {
                let t = self.toks.next().ok_or("missing value")?;
                let v = t.parse::<f64>().map_err(|_| format!("`{t}` is not a number"))?;
                let (lo, hi) = ty.range();
                if ty.is_int() && (v.fract() != 0.0 || !(lo..=hi).contains(&v)) {
                    return Err(format!("`{t}` is not a value of its integer type"));
                }
                v
            }
            Enc::Le | Enc::Be => {
                let n = ty.size;
                let b = self.data.get(self.pos..self.pos + n).ok_or("unexpected end of file")?;
                self.pos += n;
                let mut a = [0u8; 8];
                a[..n].copy_from_slice(b);
                if self.enc == Enc::Be {
                    a[..n].reverse();
                }
                let [b0, b1, b2, b3, ..] = a;
                match (ty.float, n) {
                    (true, 4) => f64::from(f32::from_le_bytes([b0, b1, b2, b3])),
                    (true, _) => f64::from_le_bytes(a),
                    (false, _) if ty.signed => {
                        // Sign-extend from the top bit of the last byte.
                        let fill = if a[n - 1] & 0x80 != 0 { 0xff } else { 0 };
                        a[n..].fill(fill);
                        i64::from_le_bytes(a) as f64
                    }
                    (false, _) => u64::from_le_bytes(a) as f64,
                }
            }
        };
        Ok(v)
    }
    /// Reads one property; a list's items go to `items` (cleared first).
    fn prop(&mut self, p: &Prop, items: &mut Vec<f64>) -> Result<f64, String> {
        let Some(ct) = p.list else { return self.value(p.ty) };
        let n = self.value(ct)?;
        if n < 0.0 {
            return Err(format!("negative list length {n}"));
        }
        items.clear();
        for _ in 0..n as u64 {
            items.push(self.value(p.ty)?);
        }
        Ok(n)
    }
}

/// Positions of the color properties (`red`, `green`, `blue`, optional `alpha`) of `e`.
fn color_props(e: &Element, path: &Path) -> Result<Option<[Option<usize>; 4]>, MeshFileError> {
    let find = |c: &str| {
        e.props.iter().position(|p| p.name == c || p.name.strip_prefix("diffuse_") == Some(c))
    };
    let idx = ["red", "green", "blue", "alpha"].map(find);
    for i in idx.iter().flatten() {
        let p = &e.props[*i];
        if p.list.is_some() || !(p.ty == U8 || p.ty.float) {
            let msg = format!("{} property `{}` must be uchar, float or double", e.name, p.name);
            return Err(fail(path, Location::Header, msg));
        }
    }
    Ok(idx[..3].iter().all(Option::is_some).then_some(idx))
}

/// An RGBA8 color from the values of an element (see [`color_props`]).
fn color(e: &Element, idx: &[Option<usize>; 4], vals: &[f64]) -> Result<[u8; 4], String> {
    let mut c = [255u8; 4];
    for (k, i) in idx.iter().enumerate() {
        let Some(i) = *i else { continue };
        let v = vals[i];
        c[k] = if e.props[i].ty == U8 {
            v as u8
        } else if (0.0..=1.0).contains(&v) {
            (v * 255.0).round() as u8
        } else {
            return Err(format!("color {} = {v} is outside 0..1", e.props[i].name));
        };
    }
    Ok(c)
}

/// Reads PLY bytes (`path` only names the file in errors; see the module docs).
pub fn read_ply(bytes: &[u8], path: &Path) -> Result<ColorMesh, MeshFileError> {
    let raw = read_ply_raw(bytes, path, true)?;
    let vertices = raw.vertices.iter().map(|v| [v[0], v[1]]).collect();
    let colors = match (raw.face_colors, raw.vertex_colors) {
        (Some(f), _) => Colors::PerTriangle(f),
        (None, Some(v)) => Colors::PerVertex(v),
        (None, None) => unreachable!("colors are required"),
    };
    Ok(ColorMesh { vertices, triangles: raw.triangles, colors })
}

/// A PLY file's geometry: 3D vertices, triangles (polygons fan-triangulated) and colours.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawPly {
    /// Vertex positions (`z = 0` when the file has no `z`).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Vertex colours, if the file has them.
    pub vertex_colors: Option<Vec<[u8; 4]>>,
    /// Face colours (one per triangle), if the file has them.
    pub face_colors: Option<Vec<[u8; 4]>>,
}

/// Reads a PLY file (ascii, binary little or big endian). With `need_colors`, a file
/// without vertex or face colours is an error; without it, the `face` element is optional
/// (a point cloud).
pub fn read_ply_raw(bytes: &[u8], path: &Path, need_colors: bool) -> Result<RawPly, MeshFileError> {
    let (enc, elems, start, line) = header(bytes, path)?;
    let body_len = (bytes.len() - start) as u128;
    let mut need = 0u128;
    for e in &elems {
        // Least bytes per element: a value and a separator per property in ascii.
        let min: usize = if enc == Enc::Ascii {
            2 * e.props.len()
        } else {
            e.props.iter().map(|p| p.list.unwrap_or(p.ty).size).sum()
        };
        // (An element without properties needs at least a line or a byte: count it as 1.)
        need += u128::from(e.count) * min.max(1) as u128;
        if need > body_len {
            let msg = format!(
                "the header declares {} `{}` elements, more than the {body_len} bytes of data hold",
                e.count, e.name
            );
            return Err(fail(path, Location::Header, msg));
        }
    }
    let find = |name: &str| elems.iter().find(|e| e.name == name);
    let no_face = Element { name: "face".into(), count: 0, props: Vec::new() };
    let (ve, fe) = match (find("vertex"), find("face")) {
        (Some(v), Some(f)) => (v, f),
        (Some(v), None) if !need_colors => (v, &no_face),
        _ => return Err(fail(path, Location::Header, "needs a `vertex` and a `face` element")),
    };
    let hfail = |m: &str| fail(path, Location::Header, m);
    let prop = |e: &Element, n: &str| e.props.iter().position(|p| p.name == n && p.list.is_none());
    let (Some(px), Some(py)) = (prop(ve, "x"), prop(ve, "y")) else {
        return Err(hfail("vertex needs scalar `x` and `y` properties"));
    };
    let pz = prop(ve, "z");
    let pi = fe.props.iter().position(|p| {
        matches!(p.name.as_str(), "vertex_indices" | "vertex_index")
            && p.list.is_some()
            && p.ty.is_int()
    });
    let pi = match pi {
        Some(pi) => pi,
        None if fe.count == 0 && !need_colors => usize::MAX,
        None => return Err(hfail("face needs an integer list `vertex_indices`")),
    };
    let (vcol, fcol) = (color_props(ve, path)?, color_props(fe, path)?);
    if need_colors && vcol.is_none() && fcol.is_none() {
        return Err(hfail("no colors: vertex or face needs `red`, `green` and `blue` properties"));
    }
    let nv = usize::try_from(ve.count)
        .ok()
        .filter(|&n| n <= u32::MAX as usize)
        .ok_or_else(|| hfail("more than 2^32 vertices"))?;
    let mut body = Body {
        enc,
        data: &bytes[start..],
        pos: 0,
        line: line - 1,
        toks: "".split_ascii_whitespace(),
    };
    let (mut vertices, mut vcolors) = (Vec::with_capacity(nv), Vec::new());
    let (mut triangles, mut fcolors) = (Vec::with_capacity(fe.count as usize), Vec::new());
    let (mut vals, mut items) = (Vec::new(), Vec::new());
    for e in &elems {
        let is = |x: &Element| std::ptr::eq(e, x);
        for index in 0..e.count {
            let at = |b: &Body| match enc {
                Enc::Ascii => Location::Line(b.line),
                _ => Location::Element { name: e.name.clone(), index },
            };
            let mut item = || -> Result<(), String> {
                body.begin()?;
                vals.clear();
                let mut face = Vec::new();
                for (k, p) in e.props.iter().enumerate() {
                    vals.push(body.prop(p, &mut items)?);
                    if is(fe) && k == pi {
                        face.clone_from(&items);
                    }
                }
                body.end()?;
                if is(ve) {
                    let (x, y) = (vals[px], vals[py]);
                    let z = pz.map_or(0.0, |z| vals[z]);
                    if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                        return Err(format!(
                            "vertex {index}: coordinates ({x}, {y}, {z}) are not finite"
                        ));
                    }
                    vertices.push([x, y, z]);
                    if let Some(c) = &vcol {
                        vcolors.push(color(e, c, &vals)?);
                    }
                } else if is(fe) {
                    if face.len() < 3 {
                        return Err(format!(
                            "face {index} has {} vertices (at least 3 needed)",
                            face.len()
                        ));
                    }
                    if let Some(&i) = face.iter().find(|&&i| i < 0.0 || i >= nv as f64) {
                        return Err(format!(
                            "face {index}: vertex index {i} out of range ({nv} vertices)"
                        ));
                    }
                    let fc = fcol.as_ref().map(|c| color(e, c, &vals)).transpose()?;
                    for j in 1..face.len() - 1 {
                        triangles.push([face[0], face[j], face[j + 1]].map(|i| i as u32));
                        fcolors.extend(fc);
                    }
                }
                Ok(())
            };
            item().map_err(|m| {
                let loc = at(&body);
                // A binary file's location already names the element ("face 3"): the
                // message does not say it again.
                let m = match &loc {
                    Location::Element { name, index } => {
                        let tag = format!("{name} {index}");
                        match m.strip_prefix(&tag) {
                            Some(rest) => rest.trim_start_matches(':').trim_start().to_string(),
                            None => m,
                        }
                    }
                    _ => m,
                };
                fail(path, loc, m)
            })?;
        }
    }
    Ok(RawPly {
        vertices,
        triangles,
        vertex_colors: vcol.is_some().then_some(vcolors),
        face_colors: fcol.is_some().then_some(fcolors),
    })
}

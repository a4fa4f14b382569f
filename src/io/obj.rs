//! Wavefront OBJ: the one reader behind 2D meshes ([`read_mesh`]), 3D models
//! ([`crate::io::model`]) and colored meshes ([`crate::io::colormesh`]), and the 2D mesh
//! writer ([`write_mesh`]).
//!
//! What is read (<https://paulbourke.net/dataformats/obj/>):
//! * `v a b c ...`: a vertex with all its numbers (`x y` for meshes, `x y z` for models,
//!   `x y z r g b` for colored meshes: each caller checks the count it needs). Vertices keep
//!   the file's order (landmarks and correspondences across frames depend on it; this is why
//!   the reader is not `tobj`, which renumbers vertices in order of first use).
//! * `f a b c ...`: a face. Each entry is `a`, `a/t`, `a/t/n` or `a//n`; only the position
//!   index `a` is used. Indices are 1-based; a negative index counts back from the last vertex
//!   defined so far (`-1` is the previous `v` line). Positive indices are range-checked when
//!   the faces are used ([`Obj::check_faces`]), since a 2D mesh reports them per triangle.
//!   Polygons become fans `(a_0, a_i, a_{i+1})`.
//! * `o` and `g` start a new object when the current one has faces ([`ObjFace::object`]).
//! * Everything after `#` is a comment; other statements (`vn`, `vt`, `l`, `p`, `s`,
//!   `usemtl`, `mtllib`, ...) are ignored.
//!
//! Errors are typed ([`ObjError`]) with the 1-based line, so that each caller words them in
//! its own error type.

use std::fmt::Write as _;

use crate::mesh::{Mesh, MeshError, MeshOptions};

/// A malformed OBJ statement (every variant names its 1-based line).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ObjError {
    /// The bytes are not UTF-8; `line` is where the first bad byte is.
    #[error("not UTF-8 text")]
    NotUtf8 {
        /// 1-based line.
        line: usize,
    },
    /// A `v` value that is not a number.
    #[error("bad coordinate {token:?}")]
    BadNumber {
        /// 1-based line.
        line: usize,
        /// The token as written.
        token: String,
    },
    /// A face entry whose position index is not an integer.
    #[error("bad vertex reference {token:?}")]
    BadIndex {
        /// 1-based line.
        line: usize,
        /// The entry as written.
        token: String,
    },
    /// A face entry with index 0.
    #[error("vertex index 0 (indices are 1-based)")]
    ZeroIndex {
        /// 1-based line.
        line: usize,
    },
    /// A negative index reaching before the first vertex.
    #[error("relative index {index}, but only {defined} vertices are defined so far")]
    RelativeOutOfRange {
        /// 1-based line.
        line: usize,
        /// The index as written (negative).
        index: i64,
        /// Vertices defined before the face.
        defined: usize,
    },
    /// A face with fewer than 3 entries.
    #[error("face needs at least 3 vertices, got {count}")]
    ShortFace {
        /// 1-based line.
        line: usize,
        /// Entries found.
        count: usize,
    },
    /// A positive index beyond the last vertex of the file (from [`Obj::check_faces`]).
    #[error("vertex index {index} out of range ({vertices} vertices)")]
    OutOfRange {
        /// 1-based line.
        line: usize,
        /// The index as written (1-based).
        index: u64,
        /// Vertices in the file.
        vertices: usize,
    },
}

impl ObjError {
    /// The 1-based line at fault.
    pub fn line(&self) -> usize {
        match *self {
            ObjError::NotUtf8 { line }
            | ObjError::BadNumber { line, .. }
            | ObjError::BadIndex { line, .. }
            | ObjError::ZeroIndex { line }
            | ObjError::RelativeOutOfRange { line, .. }
            | ObjError::ShortFace { line, .. }
            | ObjError::OutOfRange { line, .. } => line,
        }
    }
}

/// One `v` line: where its numbers are in [`Obj`]'s value list.
#[derive(Clone, Copy, Debug)]
struct VertexRecord {
    start: usize,
    len: usize,
    line: usize,
}

#[derive(Clone, Copy, Debug)]
struct FaceRecord {
    start: usize,
    len: usize,
    line: usize,
    object: usize,
}

/// A parsed OBJ file: vertices with their numbers, faces with 0-based position indices.
#[derive(Clone, Debug, Default)]
pub struct Obj {
    values: Vec<f64>,
    vertices: Vec<VertexRecord>,
    indices: Vec<usize>,
    faces: Vec<FaceRecord>,
}

/// A vertex of an [`Obj`]: its `v` line and the numbers written on it.
#[derive(Clone, Copy, Debug)]
pub struct ObjVertex<'a> {
    /// 1-based line.
    pub line: usize,
    /// Every number of the `v` line, in order.
    pub values: &'a [f64],
}

/// A face of an [`Obj`].
#[derive(Clone, Copy, Debug)]
pub struct ObjFace<'a> {
    /// 1-based line.
    pub line: usize,
    /// 0-based object number (`o`/`g` statements after faces start a new one).
    pub object: usize,
    /// 0-based position indices, in the file's order. Negative indices are resolved and
    /// checked; positive ones are checked only by [`Obj::check_faces`].
    pub indices: &'a [usize],
}

impl ObjFace<'_> {
    /// The face as a fan of triangles `(a_0, a_i, a_{i+1})`.
    pub fn fan(&self) -> impl Iterator<Item = [usize; 3]> + '_ {
        let a = self.indices;
        (1..a.len() - 1).map(move |k| [a[0], a[k], a[k + 1]])
    }
}

impl Obj {
    /// Parses OBJ bytes (see the module docs).
    pub fn parse(bytes: &[u8]) -> Result<Obj, ObjError> {
        let text = std::str::from_utf8(bytes).map_err(|e| ObjError::NotUtf8 {
            line: bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1,
        })?;
        let mut obj = Obj::default();
        let mut object = 0;
        let mut object_has_faces = false;
        for (n, raw) in text.lines().enumerate() {
            let line = n + 1;
            let content = raw.split('#').next().unwrap_or("");
            let mut tokens = content.split_whitespace();
            match tokens.next() {
                Some("v") => {
                    let start = obj.values.len();
                    for token in tokens {
                        let v = token
                            .parse::<f64>()
                            .map_err(|_| ObjError::BadNumber { line, token: token.to_string() })?;
                        obj.values.push(v);
                    }
                    obj.vertices.push(VertexRecord { start, len: obj.values.len() - start, line });
                }
                Some("f") => {
                    let start = obj.indices.len();
                    let defined = obj.vertices.len();
                    for token in tokens {
                        let first = token.split('/').next().unwrap_or("");
                        let i: i64 = first
                            .parse()
                            .map_err(|_| ObjError::BadIndex { line, token: token.to_string() })?;
                        let index = match i {
                            0 => return Err(ObjError::ZeroIndex { line }),
                            i if i > 0 => (i - 1) as usize,
                            i => {
                                let back = i.unsigned_abs();
                                if back > defined as u64 {
                                    return Err(ObjError::RelativeOutOfRange {
                                        line,
                                        index: i,
                                        defined,
                                    });
                                }
                                defined - back as usize
                            }
                        };
                        obj.indices.push(index);
                    }
                    let len = obj.indices.len() - start;
                    if len < 3 {
                        return Err(ObjError::ShortFace { line, count: len });
                    }
                    obj.faces.push(FaceRecord { start, len, line, object });
                    object_has_faces = true;
                }
                Some("o" | "g") if object_has_faces => {
                    object += 1;
                    object_has_faces = false;
                }
                _ => {}
            }
        }
        Ok(obj)
    }

    /// Number of `v` lines.
    pub fn num_vertices(&self) -> usize {
        self.vertices.len()
    }

    /// Number of `f` lines.
    pub fn num_faces(&self) -> usize {
        self.faces.len()
    }

    /// The vertices in file order.
    pub fn vertices(&self) -> impl ExactSizeIterator<Item = ObjVertex<'_>> + '_ {
        self.vertices
            .iter()
            .map(|r| ObjVertex { line: r.line, values: &self.values[r.start..r.start + r.len] })
    }

    /// The faces in file order.
    pub fn faces(&self) -> impl ExactSizeIterator<Item = ObjFace<'_>> + '_ {
        self.faces.iter().map(|r| ObjFace {
            line: r.line,
            object: r.object,
            indices: &self.indices[r.start..r.start + r.len],
        })
    }

    /// Checks that every face index names a vertex of the file: the first that does not is
    /// an [`ObjError::OutOfRange`].
    pub fn check_faces(&self) -> Result<(), ObjError> {
        let n = self.vertices.len();
        for f in self.faces() {
            if let Some(&i) = f.indices.iter().find(|&&i| i >= n) {
                return Err(ObjError::OutOfRange {
                    line: f.line,
                    index: i as u64 + 1,
                    vertices: n,
                });
            }
        }
        Ok(())
    }

    /// All faces as fan triangles (indices unchecked; see [`Obj::check_faces`]).
    pub fn triangles(&self) -> Vec<[usize; 3]> {
        let count = self.faces.iter().map(|f| f.len - 2).sum();
        let mut out = Vec::with_capacity(count);
        for f in self.faces() {
            out.extend(f.fan());
        }
        out
    }
}

/// Reads a 2D mesh from OBJ text.
///
/// Reads `v x y [z ...]` lines (only `x` and `y` are used) and `f` lines (see the module
/// docs). Faces must be counter-clockwise; the mesh is then validated like
/// [`Mesh::from_triangles`] (triangle numbers in errors count the triangles after fan
/// splitting; an index beyond the last vertex is reported per triangle). Statement errors
/// are [`MeshError::Obj`] with the line.
pub fn read_mesh(text: &str, opts: MeshOptions) -> Result<Mesh, MeshError> {
    let obj = Obj::parse(text.as_bytes())
        .map_err(|e| MeshError::Obj { line: e.line(), message: e.to_string() })?;
    let mut points = Vec::with_capacity(obj.num_vertices());
    for v in obj.vertices() {
        if v.values.len() < 2 {
            return Err(MeshError::Obj {
                line: v.line,
                message: format!("vertex needs x and y coordinates, found {}", v.values.len()),
            });
        }
        points.push([v.values[0], v.values[1]]);
    }
    Mesh::from_triangles(&points, &obj.triangles(), opts)
}

/// Writes a 2D mesh as Wavefront OBJ: a comment line, `v x y 0` per vertex (snapped
/// coordinates, printed exactly) and `f a b c` per triangle (1-based, counter-clockwise).
/// [`read_mesh`] with the same grid reads it back unchanged.
pub fn write_mesh(mesh: &Mesh) -> String {
    let mut s = String::with_capacity(24 * (mesh.num_vertices() + mesh.num_triangles()) + 80);
    let _ = writeln!(
        s,
        "# trimorph mesh: {} vertices, {} triangles, coordinates are multiples of 1/{}",
        mesh.num_vertices(),
        mesh.num_triangles(),
        mesh.grid_denominator()
    );
    for p in mesh.vertices() {
        let _ = writeln!(s, "v {} {} 0", p[0], p[1]);
    }
    for t in mesh.triangles() {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_resolve_relative_indices_against_the_vertices_so_far() {
        let obj =
            Obj::parse(b"v 0 0\nv 1 0\nv 0 1\nf -3 -2 -1\nv 2 2\nf 1/1 2//3 -1/4/5\n").unwrap();
        let faces: Vec<Vec<usize>> = obj.faces().map(|f| f.indices.to_vec()).collect();
        assert_eq!(faces, vec![vec![0, 1, 2], vec![0, 1, 3]]);
        assert_eq!(obj.vertices().nth(3).unwrap().line, 5);
        obj.check_faces().unwrap();
    }

    #[test]
    fn objects_start_at_o_or_g_after_faces_and_polygons_are_fans() {
        let obj =
            Obj::parse(b"o a\ng b\nv 0 0\nv 1 0\nv 1 1\nv 0 1\nf 1 2 3 4\ng c\nf 1 2 3\n").unwrap();
        let objects: Vec<usize> = obj.faces().map(|f| f.object).collect();
        assert_eq!(objects, vec![0, 1]);
        assert_eq!(obj.triangles(), vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
    }

    #[test]
    fn statement_errors_name_their_line() {
        let cases: [(&[u8], ObjError); 6] = [
            (b"v 0 zero\n", ObjError::BadNumber { line: 1, token: "zero".into() }),
            (b"v 0 0\n\nf 1 x 1\n", ObjError::BadIndex { line: 3, token: "x".into() }),
            (b"v 0 0\nf 0 1 1\n", ObjError::ZeroIndex { line: 2 }),
            (b"v 0 0\nf -2 1 1\n", ObjError::RelativeOutOfRange { line: 2, index: -2, defined: 1 }),
            (b"v 0 0\nf 1 1\n", ObjError::ShortFace { line: 2, count: 1 + 1 }),
            (b"v 0 0\n\xff\n", ObjError::NotUtf8 { line: 2 }),
        ];
        for (bytes, want) in cases {
            assert_eq!(Obj::parse(bytes).unwrap_err(), want);
        }
        let obj = Obj::parse(b"v 0 0\nv 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(
            obj.check_faces().unwrap_err(),
            ObjError::OutOfRange { line: 3, index: 3, vertices: 2 }
        );
    }

    #[test]
    fn comments_and_other_statements_are_ignored() {
        let obj = Obj::parse(b"# c\nv 1 2 3 # tail\nvn 0 0 1\nvt 0 0\nusemtl m\ns off\n").unwrap();
        assert_eq!(obj.vertices().next().unwrap().values, &[1.0, 2.0, 3.0]);
        assert_eq!(obj.num_faces(), 0);
    }
}

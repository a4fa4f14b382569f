//! Wavefront OBJ input and output (2D: `z` is ignored on input and written as 0).

use std::fmt::Write;

use super::validate::{assemble, check_grid, snap_points};
use super::{Mesh, MeshError, MeshOptions};

impl Mesh {
    /// Parses a mesh from Wavefront OBJ text.
    ///
    /// Reads `v x y [z ...]` lines (z ignored) and `f a b c ...` lines. Face entries are 1-based
    /// vertex indices, possibly written `a/b`, `a/b/c` or `a//c` (only `a` is used); negative
    /// indices count back from the last vertex defined so far (`-1` is the last one). Faces
    /// with more than 3 vertices are split into a fan `(a0, a_i, a_i+1)`. Everything after `#`
    /// is a comment; other lines (`vn`, `vt`, `o`, `g`, `s`, `usemtl`, `mtllib`, ...) are
    /// ignored. Faces must be counter-clockwise; the mesh is then validated like
    /// [`Mesh::from_triangles`] (triangle numbers in errors count the triangles after fan
    /// splitting).
    pub fn from_obj(text: &str, opts: MeshOptions) -> Result<Mesh, MeshError> {
        let grid = check_grid(opts)?;
        let mut verts: Vec<[f64; 2]> = Vec::new();
        let mut tris: Vec<[usize; 3]> = Vec::new();
        for (n, raw) in text.lines().enumerate() {
            let line = n + 1;
            let err = |message: String| MeshError::Obj { line, message };
            let content = raw.split('#').next().unwrap_or("");
            let mut tokens = content.split_whitespace();
            match tokens.next() {
                Some("v") => {
                    let mut xy = [0.0; 2];
                    for (k, c) in xy.iter_mut().enumerate() {
                        let tok = tokens.next().ok_or_else(|| {
                            err(format!("vertex needs x and y coordinates, found {k}"))
                        })?;
                        *c = tok.parse().map_err(|_| err(format!("bad coordinate {tok:?}")))?;
                    }
                    verts.push(xy);
                }
                Some("f") => {
                    let mut face = Vec::new();
                    for tok in tokens {
                        let first = tok.split('/').next().unwrap_or("");
                        let i: i64 = first
                            .parse()
                            .map_err(|_| err(format!("bad vertex reference {tok:?}")))?;
                        let index = match i {
                            0 => return Err(err("vertex index 0 (indices are 1-based)".into())),
                            i if i > 0 => (i - 1) as usize,
                            i => {
                                let back = i.unsigned_abs() as usize;
                                if back > verts.len() {
                                    return Err(err(format!(
                                        "relative index {i}, but only {} vertices are defined so far",
                                        verts.len()
                                    )));
                                }
                                verts.len() - back
                            }
                        };
                        face.push(index);
                    }
                    if face.len() < 3 {
                        return Err(err(format!(
                            "face needs at least 3 vertices, got {}",
                            face.len()
                        )));
                    }
                    for k in 1..face.len() - 1 {
                        tris.push([face[0], face[k], face[k + 1]]);
                    }
                }
                _ => {}
            }
        }
        if tris.is_empty() {
            return Err(MeshError::Empty);
        }
        assemble(snap_points(&verts, grid)?, tris)
    }

    /// Writes the mesh as Wavefront OBJ: a comment line, `v x y 0` per vertex (snapped
    /// coordinates, printed exactly) and `f a b c` per triangle (1-based, counter-clockwise).
    /// [`Mesh::from_obj`] with the same grid reads it back unchanged.
    pub fn to_obj(&self) -> String {
        let mut s = String::with_capacity(24 * (self.num_vertices() + self.num_triangles()) + 80);
        let _ = writeln!(
            s,
            "# trimorph mesh: {} vertices, {} triangles, coordinates are multiples of 1/{}",
            self.num_vertices(),
            self.num_triangles(),
            self.grid
        );
        for p in self.vertices() {
            let _ = writeln!(s, "v {} {} 0", p[0], p[1]);
        }
        for t in self.triangles() {
            let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
        }
        s
    }
}

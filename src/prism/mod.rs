//! 2.5D deformations of 3D models with a layer of vertical prisms (PrisMystic; thesis
//! Part III, ch. 17-19; MSc dissertation ch. 5).
//!
//! The reference prism mesh is `P = T x [a, b]`: the 2D reference mesh `T` of a spline
//! deformation times an interval. A 2.5D deformation is
//!
//! ```text
//!   psi(x, y, z) = (phi(x, y), alpha0 sigma0(x, y) + alpha1 sigma1(x, y)),
//!   alpha0 = (b - z) / (b - a),  alpha1 = (z - a) / (b - a)          (eq. 17.1, 17.2.1)
//! ```
//!
//! where `phi` is the 2DSD spline and `sigma0`, `sigma1` are scalar degree-`d` splines on the
//! same layout ([`ZLayers`]): the deformed bottom and top of every prism. The identity has
//! `sigma0 = a`, `sigma1 = b`. All three are edited through the same API
//! ([`crate::edit::Mode`]): xy edits change `phi` only (x and y of every point move, z never),
//! z0 / z1 edits change one layer only (z moves, x and y never).
//!
//! A model vertex is *bound* once: its triangle of `T`, barycentric coordinates `beta` of its
//! `(x, y)`, and `alpha`. Deforming is then two patch evaluations per vertex. Coordinates
//! are model units, the same as the reference mesh's.

pub mod organism;

use crate::exact::{parse_rat, rat_to_f64, ParseRatError, Rat};
use crate::mesh::{Mesh, MeshError, MeshOptions};
use crate::spline::{Spline, ZLayers};
use rayon::prelude::*;

/// Errors of 2.5D deformation.
#[derive(Debug, thiserror::Error)]
pub enum PrismError {
    /// The deformation has no z layers.
    #[error(
        "the deformation has no z layers (z_range, z0, z1): make one with `trimorph model bind`"
    )]
    NotPrism,
    /// A model vertex is not finite.
    #[error("model vertex {index} is not finite: {value:?}")]
    NonFinite {
        /// Vertex index (0-based).
        index: usize,
        /// Its coordinates.
        value: [f64; 3],
    },
    /// A triangle refers to a missing vertex.
    #[error("model triangle {index} refers to vertex {vertex}, but there are {count} vertices")]
    Index {
        /// Triangle index (0-based).
        index: usize,
        /// The bad vertex index.
        vertex: u32,
        /// Number of vertices.
        count: usize,
    },
    /// The model is empty.
    #[error("the model has no vertices")]
    Empty,
    /// Bad prism range.
    #[error("prism range [{a}, {b}] is empty: need a < b")]
    Range {
        /// Bottom.
        a: f64,
        /// Top.
        b: f64,
    },
    /// The model spans too little across its up axis for the automatic grid (issue 54: a
    /// model whose vertices all coincide was refused as coinciding grid vertices).
    #[error("the model spans {width:.3e} x {height:.3e} across its up axis (with the margin), too little for a grid of {cols} x {rows} cells on steps of 1/{grid}: its vertices coincide, or lie on a line seen along the up axis; check the model and --up, or give a reference mesh with --mesh")]
    Flat {
        /// Width of the grid's box.
        width: f64,
        /// Height of the grid's box.
        height: f64,
        /// Cells across.
        cols: usize,
        /// Cells down.
        rows: usize,
        /// The snapping grid's steps per unit.
        grid: i64,
    },
    /// The reference mesh could not be built.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// A triangle mesh (or, without triangles, a point cloud) in 3D, with named landmark
/// vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Model {
    /// Vertex positions.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles (vertex indices, counter-clockwise seen from outside).
    pub triangles: Vec<[u32; 3]>,
    /// Named landmark vertices (name, vertex index).
    pub landmarks: Vec<(String, u32)>,
}

impl Model {
    /// Checks indices and finiteness.
    pub fn validate(&self) -> Result<(), PrismError> {
        if self.vertices.is_empty() {
            return Err(PrismError::Empty);
        }
        if let Some((index, v)) =
            self.vertices.iter().enumerate().find(|(_, v)| v.iter().any(|c| !c.is_finite()))
        {
            return Err(PrismError::NonFinite { index, value: *v });
        }
        let count = self.vertices.len();
        for (index, t) in self.triangles.iter().enumerate() {
            if let Some(&vertex) = t.iter().find(|&&v| v as usize >= count) {
                return Err(PrismError::Index { index, vertex, count });
            }
        }
        for (_, v) in &self.landmarks {
            if *v as usize >= count {
                return Err(PrismError::Index { index: usize::MAX, vertex: *v, count });
            }
        }
        Ok(())
    }

    /// Axis-aligned bounding box `(lo, hi)`.
    pub fn bbox(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for v in &self.vertices {
            for a in 0..3 {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
            }
        }
        (lo, hi)
    }

    /// Per-vertex unit normals: the area-weighted sum of the adjacent triangles' normals
    /// (zero for vertices in no triangle).
    pub fn vertex_normals(&self) -> Vec<[f64; 3]> {
        vertex_normals(&self.vertices, &self.triangles)
    }
}

/// Per-vertex unit normals of a triangle mesh (area-weighted face normals).
pub fn vertex_normals(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f64; 3]> {
    let mut n = vec![[0.0f64; 3]; vertices.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let (u, v) =
            ([b[0] - a[0], b[1] - a[1], b[2] - a[2]], [c[0] - a[0], c[1] - a[1], c[2] - a[2]]);
        let f = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
        for &i in t {
            for k in 0..3 {
                n[i as usize][k] += f[k];
            }
        }
    }
    for v in &mut n {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.0 {
            *v = v.map(|c| c / l);
        }
    }
    n
}

/// The identity layers of a prism mesh `T x [a, b]`: every coefficient of `sigma0` is `a`
/// and of `sigma1` is `b` (constants are splines, C1 trivially).
pub fn identity_layers(s: &Spline, a: Rat, b: Rat) -> Result<ZLayers, PrismError> {
    if a >= b {
        return Err(PrismError::Range { a: rat_to_f64(&a), b: rat_to_f64(&b) });
    }
    Ok(ZRange { lo: a, hi: b }.layers(s))
}

/// An exact prism range `[lo, hi]` with `lo < hi`: the z extent of a 2.5D deformation's
/// identity layers (`trimorph mesh --z-range`, `trimorph model bind --range`). Its text form
/// is `A,B`, each an exact decimal or fraction ([`parse_rat`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ZRange {
    lo: Rat,
    hi: Rat,
}

impl ZRange {
    /// The range `[lo, hi]`, refused unless `lo < hi`.
    pub fn new(lo: Rat, hi: Rat) -> Result<ZRange, ZRangeError> {
        // Beyond the mesh's coordinate range the prisms' z values would overflow `f64`
        // downstream (a model warped to NaN coordinates).
        let limit = crate::exact::rat_int(1i64 << 40);
        for v in [&lo, &hi] {
            if *v >= limit || -v.clone() >= limit {
                let f = crate::exact::rat_to_f64(v);
                let shown = if f.is_finite() {
                    format!("{f:e}")
                } else {
                    let digits = v.numer().to_string().trim_start_matches('-').len();
                    format!(
                        "{}number of about {digits} digits",
                        if f < 0.0 { "a negative " } else { "a " }
                    )
                };
                return Err(ZRangeError::TooLarge(shown));
            }
        }
        if lo >= hi {
            return Err(ZRangeError::Empty { lo: Box::new(lo), hi: Box::new(hi) });
        }
        Ok(ZRange { lo, hi })
    }

    /// The bottom `a`.
    pub fn lo(&self) -> &Rat {
        &self.lo
    }

    /// The top `b`.
    pub fn hi(&self) -> &Rat {
        &self.hi
    }

    /// The identity layers of `s` over this range ([`identity_layers`]).
    pub fn layers(&self, s: &Spline) -> ZLayers {
        let n = s.num_points();
        ZLayers {
            range: [self.lo.clone(), self.hi.clone()],
            z0: vec![self.lo.clone(); n],
            z1: vec![self.hi.clone(); n],
        }
    }
}

impl std::str::FromStr for ZRange {
    type Err = ZRangeError;
    /// `A,B` with `A < B`, each an exact number ([`parse_rat`]; spaces around them ignored).
    fn from_str(text: &str) -> Result<ZRange, ZRangeError> {
        let (a, b) = text.split_once(',').ok_or(ZRangeError::Malformed)?;
        ZRange::new(parse_rat(a)?, parse_rat(b)?)
    }
}

/// Why a prism range is refused; the texts leave the option's name to the caller (the
/// command line prints `--z-range: need A < B`).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ZRangeError {
    /// Not two values separated by a comma.
    #[error("expected A,B")]
    Malformed,
    /// A value that is not an exact number.
    #[error(transparent)]
    Value(#[from] ParseRatError),
    /// A value beyond the coordinates a mesh holds (`|v| < 2^40`).
    #[error("{0} is too large: z values must be below 2^40 in magnitude")]
    TooLarge(String),
    /// `lo >= hi`.
    #[error("need A < B")]
    Empty {
        /// The bottom given.
        lo: Box<Rat>,
        /// The top given.
        hi: Box<Rat>,
    },
}

/// A reference mesh around a model: a `cols x rows` grid over the model's xy bounding box
/// grown by `margin` (a fraction of its larger side) on every side, and the z range grown
/// the same way. Returns the mesh and `[a, b]`.
pub fn auto_mesh(
    model: &Model,
    cols: usize,
    rows: usize,
    margin: f64,
) -> Result<(Mesh, [f64; 2]), PrismError> {
    auto_mesh_on(model, cols, rows, margin, MeshOptions::default())
}

/// [`auto_mesh`] with the mesh's vertices snapped to the grid of `opts` (1/`opts.grid`)
/// instead of the default 1/16: a model a few units across wants a finer grid, or its cells
/// come out uneven.
pub fn auto_mesh_on(
    model: &Model,
    cols: usize,
    rows: usize,
    margin: f64,
    opts: MeshOptions,
) -> Result<(Mesh, [f64; 2]), PrismError> {
    model.validate()?;
    let (lo, hi) = model.bbox();
    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(hi[2] - lo[2]).max(1e-9);
    let m = margin.max(0.0) * size;
    let (x0, y0) = (lo[0] - m, lo[1] - m);
    let (w, h) = (hi[0] - lo[0] + 2.0 * m, hi[1] - lo[1] + 2.0 * m);
    let (cols, rows) = (cols.max(1), rows.max(1));
    // Each cell at least two snapping steps wide, so that no two grid vertices snap together.
    let step = 2.0 / opts.grid.max(1) as f64;
    if !(w >= cols as f64 * step && h >= rows as f64 * step) {
        return Err(PrismError::Flat { width: w, height: h, cols, rows, grid: opts.grid });
    }
    let mesh = Mesh::grid(cols, rows, w, h, opts)?;
    // Translate the grid to the box (grid vertices start at the origin).
    let verts: Vec<[f64; 2]> = mesh.vertices().iter().map(|v| [v[0] + x0, v[1] + y0]).collect();
    let mesh = Mesh::from_triangles(&verts, mesh.triangles(), opts)?;
    let zm = m.max(1e-6 * size);
    Ok((mesh, [lo[2] - zm, hi[2] + zm]))
}

/// A bound vertex: its triangle of `T`, the barycentric coordinates of its `(x, y)`, and
/// `(alpha0, alpha1)`.
pub type BoundVertex = (u32, [f64; 3], [f64; 2]);

/// Where each model vertex sits in the reference prism mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Binding {
    /// Per vertex, where it is bound; `None` for vertices outside `P`.
    pub at: Vec<Option<BoundVertex>>,
    /// Indices of the vertices outside `P` (xy outside `T`, or z outside `[a, b]`).
    pub outside: Vec<usize>,
}

/// Binds every vertex of `model` to the prisms of `s` (which must have z layers).
/// Consecutive vertices are located from the previous one's triangle (models are usually
/// stored coherently), in parallel chunks.
pub fn bind(model: &Model, s: &Spline) -> Result<Binding, PrismError> {
    model.validate()?;
    let z = s.z_layers().ok_or(PrismError::NotPrism)?;
    let (a, b) = (rat_to_f64(&z.range[0]), rat_to_f64(&z.range[1]));
    let tol = 1e-12 * (b - a).abs().max(1.0);
    let at: Vec<Option<BoundVertex>> = model
        .vertices
        .par_chunks(4096)
        .flat_map_iter(|chunk| {
            let mut hint = None;
            chunk.iter().map(move |v| {
                if v[2] < a - tol || v[2] > b + tol {
                    return None;
                }
                let (t, beta) = s.mesh().locate([v[0], v[1]], hint)?;
                hint = Some(t);
                let a1 = ((v[2] - a) / (b - a)).clamp(0.0, 1.0);
                Some((t as u32, beta, [1.0 - a1, a1]))
            })
        })
        .collect();
    let outside = at.iter().enumerate().filter(|(_, b)| b.is_none()).map(|(i, _)| i).collect();
    Ok(Binding { at, outside })
}

/// `psi` of every bound vertex (vertices outside `P` keep their position), in parallel.
pub fn deform(model: &Model, binding: &Binding, s: &Spline) -> Vec<[f64; 3]> {
    let cache = s.eval_cache();
    model
        .vertices
        .par_iter()
        .zip(binding.at.par_iter())
        .with_min_len(1024)
        .map(|(v, at)| match at {
            Some((t, beta, alpha)) => {
                let p = cache.value(*t as usize, *beta);
                let z = s
                    .eval_z(*t as usize, *beta)
                    .map_or(v[2], |[z0, z1]| alpha[0] * z0 + alpha[1] * z1);
                [p[0], p[1], z]
            }
            None => *v,
        })
        .collect()
}

#[cfg(test)]
mod tests;

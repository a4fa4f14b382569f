//! Reference triangle meshes: building, validation, coordinate snapping, adjacency and fast
//! point location.
//!
//! A deformation in trimorph is a C1 spline made of triangular Bezier patches over a 2D
//! reference mesh T. This module is that mesh. Source: 2017 thesis (*Mathematical and
//! computational methods for modeling and editing deformations*), ch. 13 (data structure) and
//! section 18.2 (reference mesh input).
//!
//! # Indices
//!
//! Vertices are named by their index in [`Mesh::vertices`], triangles by their index in
//! [`Mesh::triangles`] and edges by their index in the edge list ([`Mesh::triangle_edges`]).
//! None of them is a spline control point index
//! ([`ControlPoint`](crate::spline::ControlPoint)), which numbers the Bezier control points of
//! a spline over this mesh.
//!
//! # Units
//!
//! Mesh coordinates are in the same units as the input (for images: pixels). Nothing is
//! rescaled or translated; only snapping (below) changes coordinates.
//!
//! # Snapping rule
//!
//! Every vertex coordinate `x` is replaced by `round(x * grid) / grid`, where `grid` is
//! [`MeshOptions::grid`] (default 16, so coordinates become multiples of 1/16). The exact integer
//! numerators are kept ([`Mesh::vertex_int`]), so barycentric coordinates of vertices with
//! respect to triangles are exact rationals and the C1 constraints become integer equations
//! ([`Mesh::twice_area_int`], [`Mesh::barycentric_int`]). `|x * grid|` must be below 2^40.
//! Snapping is applied before any other check: two vertices that become equal are an error
//! ([`MeshError::Duplicate`]), as is a triangle that becomes flat ([`MeshError::Degenerate`]).
//! The Delaunay builders snap the points first and then triangulate the snapped points, so they
//! never produce flat triangles. [`Mesh::snap_report`] tells how far vertices moved.
//!
//! # Orientation convention
//!
//! Every triangle `[a, b, c]` is counter-clockwise in the mathematical sense (x to the right,
//! y up): its signed area `(b - a) x (c - a)` is positive. With image coordinates (y pointing
//! down) such triangles look clockwise on screen. Builders never flip triangles silently:
//! [`Mesh::from_triangles`] (and so `io::obj::read_mesh`) reject clockwise input
//! ([`MeshError::Clockwise`]).
//!
//! # Local numbering
//!
//! In triangle `t` with vertices `triangle(t) = [v0, v1, v2]`, local edge `k` is the edge
//! *opposite* local vertex `k`: it joins `triangle(t)[(k + 1) % 3]` and `triangle(t)[(k + 2) % 3]`,
//! and it is traversed in that direction counter-clockwise. [`Mesh::triangle_edges`] and
//! [`Mesh::neighbor`] use this numbering.
//!
//! Global edges ([`Edge`]) store their vertices with `v[0] < v[1]`; `tris[0]` is the triangle on
//! the left of the directed edge `v[0] -> v[1]` and `tris[1]` the one on its right. A border
//! edge has exactly one of them `None` (which one depends on the side the mesh is on).
//!
//! # Validity
//!
//! All builders go through one validator. A valid mesh has finite, distinct (after snapping)
//! vertices, each used by some triangle; counter-clockwise triangles of positive area; every
//! edge shared by at most two triangles, in opposite directions; around every vertex the
//! triangles form a single fan whose angles add up to exactly 2 pi (interior vertex) or less
//! (border vertex); no vertex inside or on a triangle that does not use it; and no two border
//! edges touching except at a common vertex. Meshes may have holes and several components.

mod adapt;
mod build;
mod check;
mod locate;
mod refine;
#[cfg(test)]
mod tests;
mod validate;

pub use adapt::{
    check_frame, default_margin, in_landmark_frame, AdaptOptions, AdaptedMesh, DEFAULT_MIN_ANGLE,
    FRAME_SLACK,
};
use locate::Locator;
pub use refine::Refinement;

/// Options shared by all mesh builders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshOptions {
    /// Snapping denominator: every coordinate becomes `round(x * grid) / grid`. Must be >= 1.
    /// Default 16.
    pub grid: i64,
}

impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions { grid: 16 }
    }
}

/// An undirected mesh edge with its (up to two) adjacent triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    /// The two end vertices, with `v[0] < v[1]`.
    pub v: [usize; 2],
    /// `tris[0]`: the triangle on the left of `v[0] -> v[1]` (the one in which `v[0] -> v[1]`
    /// is traversed counter-clockwise); `tris[1]`: the triangle on the right. On a border edge
    /// exactly one of them is `None`.
    pub tris: [Option<usize>; 2],
}

/// How much snapping to the rational grid moved the input vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct SnapReport {
    /// The snapping denominator used (coordinates are multiples of `1 / grid`).
    pub grid: i64,
    /// Number of vertices whose coordinates changed.
    pub moved: usize,
    /// Largest Euclidean distance a vertex moved, in input units (at most `sqrt(2) / (2 grid)`).
    pub max_shift: f64,
}

/// Why a mesh could not be built. Vertex and triangle numbers are 0-based positions in the
/// input (for OBJ files read by `io::obj::read_mesh`: 0-based order of the `v` lines and of the triangles after
/// fan triangulation).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// The snapping denominator is not positive.
    #[error("snapping grid denominator must be at least 1, got {grid}; use e.g. MeshOptions::default() (grid 16)")]
    InvalidGrid {
        /// The rejected denominator.
        grid: i64,
    },
    /// A refinement's marks do not match the mesh ([`Mesh::refine`]).
    #[error("refinement marks {marks} triangles, the mesh has {triangles}")]
    MarkCount {
        /// Marks given.
        marks: usize,
        /// Triangles of the mesh.
        triangles: usize,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error(
        "vertex {vertex} has a non-finite coordinate (NaN or infinity); give finite coordinates"
    )]
    NotFinite {
        /// The offending vertex.
        vertex: usize,
    },
    /// A coordinate is too large for exact integer arithmetic once scaled by the grid.
    #[error("vertex {vertex}: coordinate {value:e} is too large (|coordinate * grid| must be below 2^40); rescale the input or use a smaller snapping grid")]
    CoordinateOutOfRange {
        /// The offending vertex.
        vertex: usize,
        /// The offending coordinate.
        value: f64,
    },
    /// Fewer than 3 points were given to a Delaunay builder.
    #[error("need at least 3 points to triangulate, got {count}")]
    TooFewPoints {
        /// Number of points given.
        count: usize,
    },
    /// Two vertices coincide after snapping.
    #[error("vertices {first} and {second} coincide at ({x}, {y}) after snapping; remove one of them or use a finer snapping grid")]
    Duplicate {
        /// The lower vertex number.
        first: usize,
        /// The higher vertex number.
        second: usize,
        /// Snapped x coordinate.
        x: f64,
        /// Snapped y coordinate.
        y: f64,
    },
    /// All points lie on one line (after snapping).
    #[error("all points are collinear (after snapping), so they span no triangle; add a point off that line")]
    AllCollinear,
    /// A triangle has zero area after snapping (repeated or collinear vertices).
    #[error("triangle {triangle} has zero area after snapping (repeated or collinear vertices); remove it or move its vertices apart")]
    Degenerate {
        /// The offending triangle.
        triangle: usize,
    },
    /// A triangle is listed clockwise.
    #[error("triangle {triangle} is clockwise; list its vertices counter-clockwise (x right, y up; with y pointing down, clockwise on screen)")]
    Clockwise {
        /// The offending triangle.
        triangle: usize,
    },
    /// More than two triangles share an edge.
    #[error("edge {a}-{b} is shared by more than two triangles; an edge may border at most two triangles")]
    NonManifoldEdge {
        /// Lower end vertex.
        a: usize,
        /// Higher end vertex.
        b: usize,
    },
    /// Two triangles traverse their common edge in the same direction.
    #[error("two triangles both traverse edge {a}->{b} counter-clockwise, so they lie on the same side of it and overlap; triangles sharing an edge must use it in opposite directions")]
    InconsistentOrientation {
        /// Start of the doubly used direction.
        a: usize,
        /// End of the doubly used direction.
        b: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but there are only {count} vertices (indices are 0-based)")]
    VertexIndex {
        /// The offending triangle.
        triangle: usize,
        /// The out-of-range vertex index.
        index: usize,
        /// Number of vertices.
        count: usize,
    },
    /// A vertex is not used by any triangle.
    #[error("vertex {vertex} is not used by any triangle; remove it or add a triangle using it")]
    UnusedVertex {
        /// The unused vertex.
        vertex: usize,
    },
    /// The triangles around a vertex do not form a single fan.
    #[error("the triangles around vertex {vertex} do not form a single fan (the mesh is pinched there); give each fan its own vertex or fill the gap")]
    NonManifoldVertex {
        /// The offending vertex.
        vertex: usize,
    },
    /// The triangles around a vertex overlap (their angles add up to more than a full turn).
    #[error("the triangles around vertex {vertex} overlap (their angles at it add up to more than a full turn); fix the positions or the connectivity there")]
    FoldedVertex {
        /// The offending vertex.
        vertex: usize,
    },
    /// A vertex lies inside or on a triangle that does not use it.
    #[error("vertex {vertex} lies inside or on the border of triangle {triangle}, which does not use it (overlapping triangles or a T-junction)")]
    Overlap {
        /// The vertex.
        vertex: usize,
        /// The triangle containing it.
        triangle: usize,
    },
    /// Two border edges cross or touch away from a common vertex.
    #[error("border edges {}-{} and {}-{} cross or touch; the mesh overlaps itself there", first[0], first[1], second[0], second[1])]
    BorderIntersection {
        /// End vertices of the first border edge.
        first: [usize; 2],
        /// End vertices of the second border edge.
        second: [usize; 2],
    },
    /// The outline given to [`Mesh::constrained_delaunay`] is unusable.
    #[error("invalid outline: {0}")]
    BadOutline(String),
    /// An OBJ file could not be parsed.
    #[error("OBJ line {line}: {message}")]
    Obj {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A landmark source outside the frame of a landmark-adapted mesh.
    #[error("landmark {index}: source point ({x}, {y}) lies outside the {w} x {h} frame (pixel centres run from 0 to width - 1 and height - 1; a landmark may lie up to one pixel beyond them, x from -1 to width, y from -1 to height); check --size and the landmark file's columns")]
    OutsideFrame {
        /// Index of the source.
        index: usize,
        /// Source x.
        x: f64,
        /// Source y.
        y: f64,
        /// Frame width.
        w: f64,
        /// Frame height.
        h: f64,
    },
    /// Invalid options of [`Mesh::landmark_adapted`].
    #[error("landmark mesh: {0}")]
    BadAdapt(String),
    /// The mesh would have no triangles.
    #[error("the mesh has no triangles; give at least one triangle (or grid cell)")]
    Empty,
    /// A regular grid with more than [`MAX_GRID_CELLS`] cells.
    #[error("a grid of {cols} x {rows} cells is too large (at most {max} cells); use fewer cells", max = MAX_GRID_CELLS)]
    GridTooLarge {
        /// Requested columns.
        cols: usize,
        /// Requested rows.
        rows: usize,
    },
}

/// The most cells [`Mesh::grid`] builds (`cols * rows`): larger grids would need tens of
/// gigabytes once a spline is built over them.
pub const MAX_GRID_CELLS: usize = 1_000_000;

/// A validated 2D reference triangle mesh with snapped coordinates, adjacency and a point
/// location index. See the [module documentation](self) for the conventions.
#[derive(Clone, Debug)]
pub struct Mesh {
    grid: i64,
    snap: SnapReport,
    verts_int: Vec<[i64; 2]>,
    verts: Vec<[f64; 2]>,
    tris: Vec<[usize; 3]>,
    /// Sorted by `(v[0], v[1])`.
    edges: Vec<Edge>,
    /// Edges with `v[0] == a` are `edges[edge_start[a]..edge_start[a + 1]]`.
    edge_start: Vec<usize>,
    tri_edges: Vec<[usize; 3]>,
    tri_nbrs: Vec<[Option<usize>; 3]>,
    /// Triangles around vertex `v` (counter-clockwise) are `vt_list[vt_start[v]..vt_start[v + 1]]`.
    vt_start: Vec<usize>,
    vt_list: Vec<usize>,
    border_vertex: Vec<bool>,
    n_interior_edges: usize,
    bbox: ([f64; 2], [f64; 2]),
    locator: Locator,
}

impl Mesh {
    /// The snapping denominator: coordinates are multiples of `1 / grid_denominator()`.
    pub fn grid_denominator(&self) -> i64 {
        self.grid
    }

    /// How far snapping moved the input vertices.
    pub fn snap_report(&self) -> &SnapReport {
        &self.snap
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.verts.len()
    }

    /// Number of triangles.
    pub fn num_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Number of (undirected) edges.
    pub fn num_edges(&self) -> usize {
        self.edges.len()
    }

    /// Number of edges shared by two triangles.
    pub fn num_interior_edges(&self) -> usize {
        self.n_interior_edges
    }

    /// Number of vertices not on the border.
    pub fn num_interior_vertices(&self) -> usize {
        self.border_vertex.iter().filter(|&&b| !b).count()
    }

    /// Snapped coordinates of vertex `i` (equal to `vertex_int(i) / grid_denominator()`).
    pub fn vertex(&self, i: usize) -> [f64; 2] {
        self.verts[i]
    }

    /// Exact snapped coordinates of vertex `i` in units of `1 / grid_denominator()`.
    pub fn vertex_int(&self, i: usize) -> [i64; 2] {
        self.verts_int[i]
    }

    /// All snapped vertex coordinates.
    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.verts
    }

    /// Vertices of triangle `t`, counter-clockwise.
    pub fn triangle(&self, t: usize) -> [usize; 3] {
        self.tris[t]
    }

    /// All triangles (each counter-clockwise).
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.tris
    }

    /// All edges, sorted by `(v[0], v[1])`.
    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// Global edge numbers of the local edges of triangle `t`: entry `k` is the edge opposite
    /// local vertex `k`, between `triangle(t)[(k + 1) % 3]` and `triangle(t)[(k + 2) % 3]`.
    pub fn triangle_edges(&self, t: usize) -> [usize; 3] {
        self.tri_edges[t]
    }

    /// The edge joining vertices `a` and `b` (in either order), if any.
    pub fn edge_between(&self, a: usize, b: usize) -> Option<usize> {
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        if hi >= self.verts.len() {
            return None;
        }
        let (s, e) = (self.edge_start[lo], self.edge_start[lo + 1]);
        self.edges[s..e].binary_search_by_key(&hi, |ed| ed.v[1]).ok().map(|i| s + i)
    }

    /// The triangle across local edge `k` of triangle `t` (`None` on the border).
    pub fn neighbor(&self, t: usize, k: usize) -> Option<usize> {
        self.tri_nbrs[t][k]
    }

    /// Triangles incident to vertex `v`, in counter-clockwise order around `v`. For a border
    /// vertex the list starts with the triangle whose clockwise side at `v` is a border edge.
    pub fn vertex_triangles(&self, v: usize) -> &[usize] {
        &self.vt_list[self.vt_start[v]..self.vt_start[v + 1]]
    }

    /// Number of edges incident to vertex `v`.
    pub fn vertex_degree(&self, v: usize) -> usize {
        self.vertex_triangles(v).len() + usize::from(self.border_vertex[v])
    }

    /// Whether edge `e` has a triangle on one side only.
    pub fn is_border_edge(&self, e: usize) -> bool {
        self.edges[e].tris[0].is_none() || self.edges[e].tris[1].is_none()
    }

    /// Whether vertex `v` lies on the border (is an end of a border edge).
    pub fn is_border_vertex(&self, v: usize) -> bool {
        self.border_vertex[v]
    }

    /// Exact twice the area of triangle `t`, in units of `(1 / grid)^2`; always positive.
    pub fn twice_area_int(&self, t: usize) -> i128 {
        let [a, b, c] = self.tris[t];
        validate::orient(self.verts_int[a], self.verts_int[b], self.verts_int[c])
    }

    /// Exact barycentric numerators of the grid point `p` (in units of `1 / grid`) with respect
    /// to triangle `t`: entry `k` is twice the signed area of the triangle obtained by replacing
    /// vertex `k` by `p`. They sum to [`twice_area_int`](Self::twice_area_int)`(t)`, and dividing
    /// by it gives the barycentric coordinates. `p`'s coordinates must be below 2^60 in absolute
    /// value.
    pub fn barycentric_int(&self, t: usize, p: [i64; 2]) -> [i128; 3] {
        debug_assert!(p[0].unsigned_abs() < 1 << 60 && p[1].unsigned_abs() < 1 << 60);
        let [a, b, c] = self.tris[t].map(|v| self.verts_int[v]);
        [validate::orient(p, b, c), validate::orient(a, p, c), validate::orient(a, b, p)]
    }

    /// Barycentric coordinates of `p` with respect to triangle `t` (they sum to 1 up to
    /// rounding; negative entries mean `p` is outside).
    pub fn barycentric(&self, t: usize, p: [f64; 2]) -> [f64; 3] {
        self.locator.barycentric(t, p)
    }

    /// Bounding box `(min, max)` of the (snapped) vertices.
    pub fn bbox(&self) -> ([f64; 2], [f64; 2]) {
        self.bbox
    }

    /// The triangle containing `p` and the barycentric coordinates of `p` in it, or `None` if
    /// `p` is outside the mesh. A point on an edge or a vertex (within a tolerance of 1e-12
    /// times the triangle size) belongs to one of the incident triangles; its barycentric
    /// coordinates may then be negative by that tolerance. `hint` (for example the previous
    /// answer, for coherent queries) and its neighbors are tried first; otherwise a uniform
    /// bucket grid (about 2 triangles per bucket) is searched.
    pub fn locate(&self, p: [f64; 2], hint: Option<usize>) -> Option<(usize, [f64; 3])> {
        self.locator.locate(&self.tri_nbrs, p, hint)
    }
}

/// Test helper: a Delaunay mesh of `n` pseudo-random points (xorshift from `state`), with
/// coordinates `(x % modulus) / divisor`.
#[cfg(test)]
pub(crate) fn xorshift_mesh(mut state: u64, n: usize, modulus: u64, divisor: f64) -> Mesh {
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % modulus) as f64 / divisor
    };
    let pts: Vec<[f64; 2]> = (0..n).map(|_| [next(), next()]).collect();
    Mesh::delaunay(&pts, MeshOptions::default()).unwrap()
}

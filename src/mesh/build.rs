//! Mesh builders: explicit triangles, regular grids, Delaunay and constrained Delaunay
//! triangulations (the latter two through `spade`).

use std::collections::HashMap;

use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, DelaunayTriangulation, Point2, Triangulation};

use super::validate::{
    assemble, check_grid, check_not_collinear, on_segment, orient, segments_intersect, snap_points,
};
use super::{Mesh, MeshError, MeshOptions};

impl Mesh {
    /// Builds a mesh from vertices and counter-clockwise triangles (0-based vertex indices).
    /// Coordinates are snapped (see the module docs) and the result is fully validated;
    /// clockwise triangles are rejected, not flipped.
    pub fn from_triangles(
        vertices: &[[f64; 2]],
        triangles: &[[usize; 3]],
        opts: MeshOptions,
    ) -> Result<Mesh, MeshError> {
        let grid = check_grid(opts)?;
        if triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        assemble(snap_points(vertices, grid)?, triangles.to_vec())
    }

    /// Delaunay triangulation of `points` (spade's `DelaunayTriangulation`). The points are
    /// snapped first and the snapped points are triangulated, so the result is always valid.
    /// Vertex `i` is point `i`; the mesh covers the convex hull of the points.
    pub fn delaunay(points: &[[f64; 2]], opts: MeshOptions) -> Result<Mesh, MeshError> {
        let grid = check_grid(opts)?;
        if points.len() < 3 {
            return Err(MeshError::TooFewPoints { count: points.len() });
        }
        let s = snap_points(points, grid)?;
        check_not_collinear(&s.ints)?;
        let dt = DelaunayTriangulation::<Point2<f64>>::bulk_load_stable(spade_points(&s.ints))
            .expect("snapped coordinates are small integers, which spade accepts");
        let map = vertex_map(&s.ints, dt.vertices().map(|v| v.position()));
        let tris = dt.inner_faces().map(|f| f.vertices().map(|v| map[v.fix().index()])).collect();
        assemble(s, tris)
    }

    /// Constrained Delaunay triangulation of `points` inside `outline` (spade's
    /// `ConstrainedDelaunayTriangulation`). `outline` lists indices into `points` forming a
    /// simple closed polygon, in either orientation (it is closed implicitly; repeating the
    /// first index at the end is allowed). Only triangles inside the outline are kept. Every
    /// point must lie inside the outline or on it. Vertex `i` is point `i`.
    pub fn constrained_delaunay(
        points: &[[f64; 2]],
        outline: &[usize],
        opts: MeshOptions,
    ) -> Result<Mesh, MeshError> {
        let grid = check_grid(opts)?;
        if points.len() < 3 {
            return Err(MeshError::TooFewPoints { count: points.len() });
        }
        let s = snap_points(points, grid)?;
        check_not_collinear(&s.ints)?;
        let outline = match outline {
            [first, rest @ .., last] if first == last && !rest.is_empty() => {
                &outline[..outline.len() - 1]
            }
            _ => outline,
        };
        let poly = check_outline(&s.ints, outline)?;
        for (i, &p) in s.ints.iter().enumerate() {
            if point_in_polygon(&poly, p) < 0 {
                return Err(MeshError::BadOutline(format!(
                    "point {i} ({}, {}) lies outside the outline; every point must be inside or on it",
                    points[i][0], points[i][1]
                )));
            }
        }
        let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::bulk_load_cdt(
            spade_points(&s.ints),
            Vec::new(),
        )
        .expect("snapped coordinates are small integers, which spade accepts");
        let map = vertex_map(&s.ints, cdt.vertices().map(|v| v.position()));
        let mut handle = vec![FixedVertexHandle::from_index(0); map.len()];
        for (h, &i) in map.iter().enumerate() {
            handle[i] = FixedVertexHandle::from_index(h);
        }
        for k in 0..outline.len() {
            let (a, b) = (outline[k], outline[(k + 1) % outline.len()]);
            if cdt.try_add_constraint(handle[a], handle[b]).is_empty() {
                return Err(MeshError::BadOutline(format!(
                    "outline edge {a}-{b} could not be inserted (it crosses another outline edge)"
                )));
            }
        }
        // Every outline edge is (a union of) triangulation edges, so each triangle is entirely
        // inside or outside: test its centroid exactly (coordinates scaled by 3).
        let poly3: Vec<[i64; 2]> = poly.iter().map(|p| [3 * p[0], 3 * p[1]]).collect();
        let tris = cdt
            .inner_faces()
            .map(|f| f.vertices().map(|v| map[v.fix().index()]))
            .filter(|tri| {
                let c = [0, 1].map(|k| tri.iter().map(|&v| s.ints[v][k]).sum::<i64>());
                point_in_polygon(&poly3, c) > 0
            })
            .collect();
        assemble(s, tris)
    }

    /// A regular grid of `cols x rows` cells covering `[0, width] x [0, height]`:
    /// `(cols + 1) (rows + 1)` vertices numbered row by row from `(0, 0)` (vertex
    /// `r (cols + 1) + c` is at `(c width / cols, r height / rows)`), each cell split along its
    /// diagonal from the lower-left `(c, r)` to the upper-right `(c + 1, r + 1)` corner into
    /// `2 cols rows` triangles (cell `(c, r)` gives triangles `2 (r cols + c)` and the next).
    /// At most [`MAX_GRID_CELLS`](super::MAX_GRID_CELLS) cells ([`MeshError::GridTooLarge`]).
    pub fn grid(
        cols: usize,
        rows: usize,
        width: f64,
        height: f64,
        opts: MeshOptions,
    ) -> Result<Mesh, MeshError> {
        Mesh::grid_from([0.0, 0.0], cols, rows, width, height, opts)
    }

    /// [`Mesh::grid`] with its lower-left corner at `origin` instead of `(0, 0)` (e.g. an
    /// image frame `[-1/2, w - 1/2] x [-1/2, h - 1/2]`).
    pub fn grid_from(
        origin: [f64; 2],
        cols: usize,
        rows: usize,
        width: f64,
        height: f64,
        opts: MeshOptions,
    ) -> Result<Mesh, MeshError> {
        let grid = check_grid(opts)?;
        if cols == 0 || rows == 0 {
            return Err(MeshError::Empty);
        }
        if cols.checked_mul(rows).is_none_or(|n| n > super::MAX_GRID_CELLS) {
            return Err(MeshError::GridTooLarge { cols, rows });
        }
        let mut verts = Vec::with_capacity((cols + 1) * (rows + 1));
        for r in 0..=rows {
            for c in 0..=cols {
                verts.push([
                    origin[0] + c as f64 * width / cols as f64,
                    origin[1] + r as f64 * height / rows as f64,
                ]);
            }
        }
        let mut tris = Vec::with_capacity(2 * cols * rows);
        for r in 0..rows {
            for c in 0..cols {
                let v00 = r * (cols + 1) + c;
                let (v10, v01, v11) = (v00 + 1, v00 + cols + 1, v00 + cols + 2);
                tris.push([v00, v10, v11]);
                tris.push([v00, v11, v01]);
            }
        }
        assemble(snap_points(&verts, grid)?, tris)
    }
}

/// Snapped integer points as spade points (exact: |k| < 2^40).
fn spade_points(ints: &[[i64; 2]]) -> Vec<Point2<f64>> {
    ints.iter().map(|p| Point2::new(p[0] as f64, p[1] as f64)).collect()
}

/// Maps spade's vertex order back to input indices (by exact position).
fn vertex_map(ints: &[[i64; 2]], positions: impl Iterator<Item = Point2<f64>>) -> Vec<usize> {
    let index: HashMap<[i64; 2], usize> = ints.iter().enumerate().map(|(i, &p)| (p, i)).collect();
    let map: Vec<usize> = positions.map(|p| index[&[p.x as i64, p.y as i64]]).collect();
    assert_eq!(map.len(), ints.len(), "spade kept every (distinct) point");
    map
}

/// Checks that `outline` is a simple polygon over `ints`; returns its vertex coordinates.
fn check_outline(ints: &[[i64; 2]], outline: &[usize]) -> Result<Vec<[i64; 2]>, MeshError> {
    let bad = |m: String| Err(MeshError::BadOutline(m));
    let m = outline.len();
    if m < 3 {
        return bad(format!("it needs at least 3 points, got {m}"));
    }
    let mut pos: HashMap<usize, usize> = HashMap::with_capacity(m);
    for (j, &i) in outline.iter().enumerate() {
        if i >= ints.len() {
            return bad(format!("entry {j} is {i}, but there are only {} points", ints.len()));
        }
        if let Some(k) = pos.insert(i, j) {
            return bad(format!("point {i} appears twice (entries {k} and {j}); the outline must be a simple polygon"));
        }
    }
    let poly: Vec<[i64; 2]> = outline.iter().map(|&i| ints[i]).collect();
    let seg = |k: usize| (poly[k], poly[(k + 1) % m]);
    for k in 0..m {
        let (a, b) = seg(k);
        let c = poly[(k + 2) % m];
        // Consecutive edges a-b, b-c must not fold back onto each other.
        if orient(a, b, c) == 0 && (on_segment(a, b, c) || on_segment(b, c, a)) {
            return bad(format!(
                "edges {}-{} and {}-{} overlap",
                outline[k],
                outline[(k + 1) % m],
                outline[(k + 1) % m],
                outline[(k + 2) % m]
            ));
        }
        for l in k + 2..m {
            if k == 0 && l == m - 1 {
                continue;
            }
            let (p, q) = seg(l);
            if segments_intersect(a, b, p, q) {
                return bad(format!(
                    "edges {}-{} and {}-{} cross or touch; the outline must be a simple polygon",
                    outline[k],
                    outline[(k + 1) % m],
                    outline[l],
                    outline[(l + 1) % m]
                ));
            }
        }
    }
    Ok(poly)
}

/// 1 if `p` is strictly inside the simple polygon, 0 on its border, -1 outside (exact).
fn point_in_polygon(poly: &[[i64; 2]], p: [i64; 2]) -> i32 {
    let mut inside = false;
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        let o = orient(a, b, p);
        if o == 0 && on_segment(a, b, p) {
            return 0;
        }
        if (a[1] > p[1]) != (b[1] > p[1]) && ((b[1] > a[1]) == (o > 0)) {
            inside = !inside;
        }
    }
    if inside {
        1
    } else {
        -1
    }
}

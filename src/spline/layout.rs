//! Numbering of the Bezier control points of a degree-`d` spline over a mesh (thesis ch. 12-13).
//!
//! A triangle `t = (v0, v1, v2)` has `(d+1)(d+2)/2` control points `q^t_ijk`, `i+j+k = d`,
//! with nominal positions `(i v0 + j v1 + k v2) / d`. Points at the same nominal position
//! are shared between triangles (C0 by construction), so there is one control point per
//! mesh vertex, `d-1` per edge and `(d-1)(d-2)/2` per triangle interior:
//! `V + (d-1)E + (d-1)(d-2)/2 F` in all. Numbering: vertices first (same index as the mesh
//! vertex), then edges in mesh order (point `s = 1..d-1` of edge `e` sits at
//! `((d-s) v[0] + s v[1]) / d`), then triangle interiors in mesh order and file order.
//!
//! The file order of a patch (`../spec/deformation-format.md`): `i` from `d` down to 0, then
//! `j` from `d-i` down to 0, `k = d-i-j`.

use crate::mesh::Mesh;

/// Where a control point lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Owner {
    /// At mesh vertex `v`.
    Vertex(usize),
    /// Point `s` (1..d-1) of edge `e`, counted from `edge.v[0]`.
    Edge(usize, usize),
    /// Interior point of triangle `t` with barycentric multi-index `(i, j, k)`.
    Face(usize, [usize; 3]),
}

/// The six control-point types of thesis fig. 14.5 (used by ExpandDerived).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PointType {
    /// At a mesh vertex.
    Corner,
    /// On an edge, next to a vertex.
    EdgeCorner,
    /// On an edge, farther from the vertices.
    Edge,
    /// Inside a triangle, diagonally next to a vertex (two indices equal 1).
    InnerCorner,
    /// Inside a triangle, next to an edge (one index equals 1).
    InnerEdge,
    /// Inside a triangle, all indices at least 2: in no C1 condition.
    Interior,
}

/// Classifies a multi-index of degree `d` (thesis fig. 14.5).
pub fn classify(m: [usize; 3], d: usize) -> PointType {
    let [i, j, k] = m;
    if i == d || j == d || k == d {
        PointType::Corner
    } else if (i == 0 && (j == 1 || k == 1))
        || (j == 0 && (i == 1 || k == 1))
        || (k == 0 && (i == 1 || j == 1))
    {
        PointType::EdgeCorner
    } else if i == 0 || j == 0 || k == 0 {
        PointType::Edge
    } else if [i, j, k].iter().filter(|&&x| x == 1).count() >= 2 {
        PointType::InnerCorner
    } else if i == 1 || j == 1 || k == 1 {
        PointType::InnerEdge
    } else {
        PointType::Interior
    }
}

/// Multi-indices of degree `d` in file order.
pub fn multi_indices(d: usize) -> Vec<[usize; 3]> {
    let mut out = Vec::with_capacity((d + 1) * (d + 2) / 2);
    for i in (0..=d).rev() {
        for j in (0..=d - i).rev() {
            out.push([i, j, d - i - j]);
        }
    }
    out
}

/// Position of multi-index `(i, j, k)` in the file order of degree `d`.
pub fn local_index(d: usize, i: usize, j: usize) -> usize {
    // Rows i = d, d-1, ..., i+1 hold 1, 2, ..., d-i points; then j counts down from d-i.
    let before = (d - i) * (d - i + 1) / 2;
    before + (d - i - j)
}

/// Control-point numbering of a degree-`d` spline over a mesh.
#[derive(Clone, Debug)]
pub struct Layout {
    degree: usize,
    /// Per triangle, the global point index of each local point in file order.
    patches: Vec<Vec<usize>>,
    owners: Vec<Owner>,
}

impl Layout {
    /// Numbers the control points of a degree-`d` spline over `mesh` (`d >= 1`).
    ///
    /// # Panics
    /// Panics when `d` is 0.
    pub fn new(mesh: &Mesh, d: usize) -> Layout {
        assert!(d >= 1, "degree must be at least 1");
        let (nv, ne, nf) = (mesh.num_vertices(), mesh.num_edges(), mesh.num_triangles());
        let per_face = if d >= 3 { (d - 1) * (d - 2) / 2 } else { 0 };
        let mut owners: Vec<Owner> = (0..nv).map(Owner::Vertex).collect();
        for e in 0..ne {
            for s in 1..d {
                owners.push(Owner::Edge(e, s));
            }
        }
        let mi = multi_indices(d);
        let mut patches = Vec::with_capacity(nf);
        for t in 0..nf {
            let tri = mesh.triangle(t);
            let te = mesh.triangle_edges(t);
            let face_base = nv + (d - 1) * ne + per_face * t;
            let mut face_count = 0;
            let mut patch = Vec::with_capacity(mi.len());
            for &[i, j, k] in &mi {
                let w = [i, j, k];
                let idx = if let Some(c) = (0..3).find(|&c| w[c] == d) {
                    tri[c]
                } else if let Some(z) = (0..3).find(|&z| w[z] == 0) {
                    // On the edge opposite local vertex z, between a = tri[z+1], b = tri[z+2].
                    let (ca, cb) = ((z + 1) % 3, (z + 2) % 3);
                    let e = te[z];
                    let edge = mesh.edges()[e];
                    let s = if edge.v[0] == tri[ca] { w[cb] } else { w[ca] };
                    nv + (d - 1) * e + (s - 1)
                } else {
                    owners.push(Owner::Face(t, w));
                    face_count += 1;
                    face_base + face_count - 1
                };
                patch.push(idx);
            }
            debug_assert_eq!(face_count, per_face);
            patches.push(patch);
        }
        Layout { degree: d, patches, owners }
    }

    /// The degree `d`.
    pub fn degree(&self) -> usize {
        self.degree
    }
    /// Number of control points.
    pub fn len(&self) -> usize {
        self.owners.len()
    }
    /// True when there are no control points.
    pub fn is_empty(&self) -> bool {
        self.owners.is_empty()
    }
    /// Per-triangle point indices in file order.
    pub fn patches(&self) -> &[Vec<usize>] {
        &self.patches
    }
    /// Point index of `q^t_ijk`.
    pub fn point(&self, t: usize, m: [usize; 3]) -> usize {
        self.patches[t][local_index(self.degree, m[0], m[1])]
    }
    /// Where point `p` lives.
    pub fn owner(&self, p: usize) -> Owner {
        self.owners[p]
    }

    /// Type of point `p` (fig. 14.5). Edge points are classified from their position on the
    /// edge; vertices are corners.
    pub fn point_type(&self, p: usize) -> PointType {
        let d = self.degree;
        match self.owners[p] {
            Owner::Vertex(_) => PointType::Corner,
            Owner::Edge(_, s) => classify([0, s, d - s], d),
            Owner::Face(_, m) => classify(m, d),
        }
    }

    /// Nominal position of every control point, exactly, as integer numerators over the
    /// common denominator `d * grid` (mesh integer coordinates are in units of `1/grid`).
    pub fn nominal_int(&self, mesh: &Mesh) -> Vec<[i128; 2]> {
        let d = self.degree as i128;
        let mut out = vec![[0i128; 2]; self.len()];
        for (p, o) in self.owners.iter().enumerate() {
            out[p] = match *o {
                Owner::Vertex(v) => {
                    let q = mesh.vertex_int(v);
                    [q[0] as i128 * d, q[1] as i128 * d]
                }
                Owner::Edge(e, s) => {
                    let ed = mesh.edges()[e];
                    let (a, b) = (mesh.vertex_int(ed.v[0]), mesh.vertex_int(ed.v[1]));
                    let s = s as i128;
                    [
                        (d - s) * a[0] as i128 + s * b[0] as i128,
                        (d - s) * a[1] as i128 + s * b[1] as i128,
                    ]
                }
                Owner::Face(t, m) => {
                    let tri = mesh.triangle(t);
                    let mut acc = [0i128; 2];
                    for c in 0..3 {
                        let q = mesh.vertex_int(tri[c]);
                        acc[0] += m[c] as i128 * q[0] as i128;
                        acc[1] += m[c] as i128 * q[1] as i128;
                    }
                    acc
                }
            };
        }
        out
    }

    /// The global Bezier control net (thesis 12.1) as adjacency lists: two points are joined
    /// when their multi-indices in some triangle differ by moving one unit between two
    /// coordinates.
    pub fn control_net(&self) -> Vec<Vec<usize>> {
        let d = self.degree;
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); self.len()];
        for t in 0..self.patches.len() {
            for m in multi_indices(d) {
                let p = self.point(t, m);
                for from in 0..3 {
                    if m[from] == 0 {
                        continue;
                    }
                    for to in 0..3 {
                        if to != from {
                            let mut n = m;
                            n[from] -= 1;
                            n[to] += 1;
                            adj[p].push(self.point(t, n));
                        }
                    }
                }
            }
        }
        for a in adj.iter_mut() {
            a.sort_unstable();
            a.dedup();
        }
        adj
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_order_matches_the_spec() {
        let m = multi_indices(5);
        assert_eq!(&m[..6], &[[5, 0, 0], [4, 1, 0], [4, 0, 1], [3, 2, 0], [3, 1, 1], [3, 0, 2]]);
        assert_eq!(m.last(), Some(&[0, 0, 5]));
        for d in 1..9 {
            for (n, &[i, j, _]) in multi_indices(d).iter().enumerate() {
                assert_eq!(local_index(d, i, j), n);
            }
        }
    }

    #[test]
    fn classification_of_degree_6_matches_fig_14_5() {
        let d = 6;
        assert_eq!(classify([6, 0, 0], d), PointType::Corner);
        assert_eq!(classify([5, 1, 0], d), PointType::EdgeCorner);
        assert_eq!(classify([0, 1, 5], d), PointType::EdgeCorner);
        assert_eq!(classify([4, 2, 0], d), PointType::Edge);
        assert_eq!(classify([4, 1, 1], d), PointType::InnerCorner);
        assert_eq!(classify([3, 2, 1], d), PointType::InnerEdge);
        assert_eq!(classify([2, 2, 2], d), PointType::Interior);
        let count = |t| multi_indices(d).into_iter().filter(|&m| classify(m, d) == t).count();
        assert_eq!(count(PointType::Corner), 3);
        assert_eq!(count(PointType::EdgeCorner), 6);
        assert_eq!(count(PointType::Edge), 9);
        assert_eq!(count(PointType::InnerCorner), 3);
        assert_eq!(count(PointType::InnerEdge), 6);
        assert_eq!(count(PointType::Interior), 1);
    }
}

//! Nested refinement: red-green splitting of marked triangles.
//!
//! A *red* triangle `(a, b, c)` is split at its edge midpoints `m_ab, m_bc, m_ca` into four
//! triangles similar to it: `(a, m_ab, m_ca)`, `(m_ab, b, m_bc)`, `(m_ca, m_bc, c)` and the
//! middle one `(m_ab, m_bc, m_ca)`. A triangle next to a red one then has a vertex in the
//! middle of one of its edges (a *hanging node*); the closure removes them:
//! - a triangle with two or three split edges becomes red too (repeated until nothing
//!   changes: red only spreads, so this ends);
//! - a triangle with one split edge `(a, b)` is split *green*, from the midpoint `m` to the
//!   opposite vertex: `(a, m, c)` and `(m, b, c)`.
//!
//! The result is a conforming mesh (every edge is an edge of both its triangles) whose every
//! triangle lies inside one triangle of the coarse mesh, its *parent*. So every piecewise
//! polynomial over the coarse mesh is one over the fine mesh, with the same smoothness: the
//! C1 spline space of the fine mesh contains the coarse one, and a coarse spline is carried
//! to the fine mesh exactly ([`crate::spline::Spline::prolong`]). This is the mesh pyramid of
//! a coarse-to-fine registration: the usual red-green scheme of adaptive finite elements
//! (Bank, Sherman and Weiser 1983), without the removal of green triangles before the next
//! refinement, which would break the nesting. A green triangle split again is halved once
//! more, so its smallest angle can shrink with each refinement that reaches it; a registration
//! refines two or three times.
//!
//! Midpoints are exact: when some midpoint is not on the coarse mesh's snapping grid `1/g`,
//! the fine mesh's grid is `1/(2g)`, on which every coarse vertex and every midpoint lies.

use std::collections::HashMap;

use super::validate::{assemble, Snapped};
use super::{Mesh, MeshError, SnapReport};

/// A refined mesh and, for each of its triangles, the coarse triangle it lies in.
#[derive(Clone, Debug)]
pub struct Refinement {
    /// The fine mesh. Its first vertices are the coarse mesh's, in the same order; the edge
    /// midpoints follow.
    pub mesh: Mesh,
    /// `parent[t]`: the coarse triangle containing fine triangle `t`.
    pub parent: Vec<usize>,
    /// How many coarse triangles were split red (marked ones and those the closure added).
    pub red: usize,
    /// How many coarse triangles were split green.
    pub green: usize,
}

impl Mesh {
    /// Splits the `marked` triangles red and closes the result green ([module docs](self)).
    /// `marked` has one entry per triangle; with nothing marked the mesh comes back unchanged
    /// (each triangle its own parent).
    ///
    /// ```
    /// use trimorph::mesh::{Mesh, MeshOptions};
    /// let coarse = Mesh::grid(2, 1, 20.0, 10.0, MeshOptions::default()).unwrap();
    /// let r = coarse.refine(&[true, false, false, false]).unwrap();
    /// // Triangle 0 in four, each neighbour across one of its edges in two.
    /// let neighbours = (0..3).filter(|&k| coarse.neighbor(0, k).is_some()).count();
    /// assert_eq!((r.red, r.green), (1, neighbours));
    /// assert_eq!(r.mesh.num_triangles(), 4 + 3 + neighbours);
    /// assert_eq!(r.parent.iter().filter(|&&p| p == 0).count(), 4);
    /// ```
    pub fn refine(&self, marked: &[bool]) -> Result<Refinement, MeshError> {
        let nt = self.num_triangles();
        if marked.len() != nt {
            return Err(MeshError::MarkCount { marks: marked.len(), triangles: nt });
        }
        // Red closure: an edge is split when a red triangle touches it.
        let mut red = marked.to_vec();
        let mut split = vec![false; self.num_edges()];
        let mut queue: Vec<usize> = (0..nt).filter(|&t| red[t]).collect();
        while let Some(t) = queue.pop() {
            for e in self.triangle_edges(t) {
                if split[e] {
                    continue;
                }
                split[e] = true;
                for u in self.edges()[e].tris.into_iter().flatten() {
                    if !red[u] && self.triangle_edges(u).iter().filter(|&&f| split[f]).count() >= 2
                    {
                        red[u] = true;
                        queue.push(u);
                    }
                }
            }
        }
        // Midpoints: numerators on the grid 2g are a + b; the grid stays g when all are even.
        let split_edges: Vec<usize> = (0..self.num_edges()).filter(|&e| split[e]).collect();
        let twice = |e: usize| {
            let [a, b] = self.edges()[e].v.map(|v| self.verts_int[v]);
            [a[0] + b[0], a[1] + b[1]]
        };
        let stays = split_edges.iter().all(|&e| twice(e).iter().all(|c| c % 2 == 0));
        let (grid, scale) = if stays { (self.grid, 1) } else { (2 * self.grid, 2) };
        let mut ints: Vec<[i64; 2]> = self.verts_int.iter().map(|p| p.map(|c| c * scale)).collect();
        let mut mid: HashMap<usize, usize> = HashMap::with_capacity(split_edges.len());
        for &e in &split_edges {
            let m = twice(e);
            mid.insert(e, ints.len());
            ints.push(if stays { m.map(|c| c / 2) } else { m });
        }
        let mut tris = Vec::with_capacity(nt + 3 * split_edges.len());
        let mut parent = Vec::with_capacity(tris.capacity());
        let mut green = 0;
        for t in 0..nt {
            let v = self.triangle(t);
            let te = self.triangle_edges(t);
            // Midpoint of the edge opposite local vertex k, if split.
            let m = |k: usize| split[te[k]].then(|| mid[&te[k]]);
            let children: Vec<[usize; 3]> = if red[t] {
                let (m0, m1, m2) = (m(0).unwrap(), m(1).unwrap(), m(2).unwrap());
                // m2 is on v0-v1, m0 on v1-v2, m1 on v2-v0.
                vec![[v[0], m2, m1], [m2, v[1], m0], [m1, m0, v[2]], [m2, m0, m1]]
            } else if let Some(k) = (0..3).find(|&k| split[te[k]]) {
                green += 1;
                let (a, b, c) = (v[(k + 1) % 3], v[(k + 2) % 3], v[k]);
                let mk = m(k).unwrap();
                vec![[a, mk, c], [mk, b, c]]
            } else {
                vec![v]
            };
            parent.extend(std::iter::repeat_n(t, children.len()));
            tris.extend(children);
        }
        let report = SnapReport { grid, ..self.snap.clone() };
        let mesh = assemble(Snapped { grid, ints, report }, tris)?;
        Ok(Refinement { mesh, parent, red: red.iter().filter(|&&r| r).count(), green })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshOptions;

    /// Every fine triangle lies in its parent (exact barycentric numerators >= 0), and the
    /// fine triangles of each parent cover its area exactly.
    fn check_nested(coarse: &Mesh, r: &Refinement) {
        r.mesh.sanity_check().unwrap();
        let g = r.mesh.grid_denominator() / coarse.grid_denominator();
        assert!(g == 1 || g == 2);
        for v in 0..coarse.num_vertices() {
            assert_eq!(r.mesh.vertex_int(v), coarse.vertex_int(v).map(|c| c * g));
        }
        let mut area = vec![0i128; coarse.num_triangles()];
        for (t, &p) in r.parent.iter().enumerate() {
            for v in r.mesh.triangle(t) {
                let q = r.mesh.vertex_int(v);
                let b = barycentric_scaled(coarse, p, q, g);
                assert!(b.iter().all(|&x| x >= 0), "fine triangle {t} leaves parent {p}");
            }
            area[p] += r.mesh.twice_area_int(t);
        }
        for (p, a) in area.iter().enumerate() {
            assert_eq!(*a, coarse.twice_area_int(p) * (g * g) as i128, "parent {p}");
        }
    }

    fn barycentric_scaled(coarse: &Mesh, t: usize, q: [i64; 2], g: i64) -> [i128; 3] {
        let [a, b, c] = coarse.triangle(t).map(|v| coarse.vertex_int(v).map(|x| x * g));
        let o = |p: [i64; 2], q: [i64; 2], r: [i64; 2]| {
            (q[0] - p[0]) as i128 * (r[1] - p[1]) as i128
                - (q[1] - p[1]) as i128 * (r[0] - p[0]) as i128
        };
        [o(q, b, c), o(a, q, c), o(a, b, q)]
    }

    #[test]
    fn all_marked_is_the_grid_of_half_the_spacing() {
        let coarse = Mesh::grid(3, 2, 30.0, 20.0, MeshOptions { grid: 1 }).unwrap();
        let r = coarse.refine(&vec![true; coarse.num_triangles()]).unwrap();
        check_nested(&coarse, &r);
        assert_eq!((r.red, r.green), (12, 0));
        assert_eq!(r.mesh.num_triangles(), 48);
        assert_eq!(r.mesh.num_vertices(), 7 * 5);
        // Midpoints of a grid of 10 px are integers: the grid denominator stays 1.
        assert_eq!(r.mesh.grid_denominator(), 1);
        let fine = Mesh::grid(6, 4, 30.0, 20.0, MeshOptions { grid: 1 }).unwrap();
        let mut a: Vec<[[i64; 2]; 3]> = (0..48).map(|t| tri_ints(&r.mesh, t)).collect();
        let mut b: Vec<[[i64; 2]; 3]> = (0..48).map(|t| tri_ints(&fine, t)).collect();
        a.sort();
        b.sort();
        assert_eq!(a, b);
    }

    /// A triangle's vertex coordinates, rotated so that the smallest comes first.
    fn tri_ints(m: &Mesh, t: usize) -> [[i64; 2]; 3] {
        let v = m.triangle(t).map(|v| m.vertex_int(v));
        let k = (0..3).min_by_key(|&k| v[k]).unwrap();
        [v[k], v[(k + 1) % 3], v[(k + 2) % 3]]
    }

    #[test]
    fn odd_midpoints_double_the_grid() {
        let coarse = Mesh::grid(1, 1, 3.0, 3.0, MeshOptions { grid: 1 }).unwrap();
        let r = coarse.refine(&[true, false]).unwrap();
        assert_eq!(r.mesh.grid_denominator(), 2);
        check_nested(&coarse, &r);
        assert_eq!(r.mesh.vertex(4), [1.5, 0.0]);
    }

    #[test]
    fn one_red_triangle_is_closed_green_and_red_spreads_where_two_edges_are_split() {
        let coarse = Mesh::grid(4, 4, 40.0, 40.0, MeshOptions::default()).unwrap();
        let nt = coarse.num_triangles();
        let mut marked = vec![false; nt];
        marked[10] = true;
        let r = coarse.refine(&marked).unwrap();
        check_nested(&coarse, &r);
        assert_eq!(r.red, 1);
        // Its three neighbours each have one split edge.
        assert_eq!(r.green, 3);
        assert_eq!(r.mesh.num_triangles(), nt + 3 + 3);
        // Two triangles of one cell marked: the cells' other neighbours are green.
        let mut marked = vec![false; nt];
        marked[10] = true;
        marked[13] = true;
        let r = coarse.refine(&marked).unwrap();
        check_nested(&coarse, &r);
        assert!(r.red >= 2);
        // Refining again, the mesh still nests (green children split red or green).
        let r2 =
            r.mesh.refine(&(0..r.mesh.num_triangles()).map(|t| t % 3 == 0).collect::<Vec<_>>());
        check_nested(&r.mesh, &r2.unwrap());
    }

    #[test]
    fn nothing_marked_is_the_same_mesh_and_wrong_lengths_are_refused() {
        let coarse = Mesh::grid(2, 2, 8.0, 8.0, MeshOptions::default()).unwrap();
        let r = coarse.refine(&[false; 8]).unwrap();
        assert_eq!(r.mesh.triangles(), coarse.triangles());
        assert_eq!(r.parent, (0..8).collect::<Vec<_>>());
        assert!(coarse.refine(&[true]).is_err());
    }
}

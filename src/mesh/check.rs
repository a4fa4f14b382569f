//! Independent invariant checker, for tests and debugging.

use super::validate::orient;
use super::Mesh;

macro_rules! ensure {
    ($cond:expr, $($msg:tt)+) => {
        if !$cond {
            return Err(format!($($msg)+));
        }
    };
}

impl Mesh {
    /// Checks the internal invariants of the mesh, returning the first violation found:
    /// snapped coordinates consistent with their integer numerators, counter-clockwise
    /// triangles of positive area, the edge table sorted and consistent with the triangles
    /// (left/right sides included), local edge numbering, symmetric neighbors,
    /// counter-clockwise vertex fans (starting at the border), border flags and degrees, the
    /// bounding box and the point location index. A mesh built by this module always passes;
    /// this is meant for tests.
    pub fn sanity_check(&self) -> Result<(), String> {
        let (nv, nt) = (self.num_vertices(), self.num_triangles());
        let g = self.grid as f64;
        ensure!(
            self.verts_int.len() == nv,
            "{} integer vertices for {nv} vertices",
            self.verts_int.len()
        );
        for (v, (p, q)) in self.verts.iter().zip(&self.verts_int).enumerate() {
            ensure!(
                p[0] == q[0] as f64 / g && p[1] == q[1] as f64 / g,
                "vertex {v}: {p:?} is not {q:?} / {}",
                self.grid
            );
        }
        for (t, tri) in self.tris.iter().enumerate() {
            ensure!(tri.iter().all(|&v| v < nv), "triangle {t} {tri:?} has a bad vertex index");
            let [a, b, c] = tri.map(|v| self.verts_int[v]);
            ensure!(orient(a, b, c) > 0, "triangle {t} {tri:?} is not counter-clockwise");
            ensure!(self.twice_area_int(t) == orient(a, b, c), "twice_area_int({t}) is wrong");
        }

        // Edges.
        ensure!(self.edge_start.len() == nv + 1, "edge_start has the wrong length");
        let mut interior = 0;
        for (e, edge) in self.edges.iter().enumerate() {
            let [a, b] = edge.v;
            ensure!(a < b && b < nv, "edge {e} has vertices {:?}", edge.v);
            if e > 0 {
                ensure!(self.edges[e - 1].v < edge.v, "edges {} and {e} are not sorted", e - 1);
            }
            ensure!(self.edge_between(a, b) == Some(e), "edge_between({a}, {b}) is not {e}");
            ensure!(self.edge_between(b, a) == Some(e), "edge_between({b}, {a}) is not {e}");
            ensure!(edge.tris.iter().any(Option::is_some), "edge {e} has no triangle");
            for (side, from, to) in [(0, a, b), (1, b, a)] {
                if let Some(t) = edge.tris[side] {
                    ensure!(t < nt, "edge {e} refers to triangle {t}");
                    let tri = self.tris[t];
                    let k = (0..3).find(|&k| tri[(k + 1) % 3] == from && tri[(k + 2) % 3] == to);
                    ensure!(k.is_some(), "edge {e}: triangle {t} {tri:?} lacks {from}->{to}");
                    let k = k.unwrap_or(0);
                    ensure!(self.tri_edges[t][k] == e, "triangle_edges({t})[{k}] is not {e}");
                    ensure!(
                        self.tri_nbrs[t][k] == edge.tris[1 - side],
                        "neighbor({t}, {k}) disagrees with edge {e}"
                    );
                }
            }
            let is_border = edge.tris.iter().any(Option::is_none);
            ensure!(self.is_border_edge(e) == is_border, "is_border_edge({e}) is wrong");
            if is_border {
                ensure!(
                    self.border_vertex[a] && self.border_vertex[b],
                    "border edge {e} has a non-border end"
                );
            } else {
                interior += 1;
            }
        }
        ensure!(interior == self.num_interior_edges(), "wrong number of interior edges");
        for t in 0..nt {
            let tri = self.tris[t];
            for k in 0..3 {
                let e = self.tri_edges[t][k];
                ensure!(e < self.edges.len(), "triangle_edges({t})[{k}] = {e} out of range");
                let (a, b) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
                ensure!(self.edges[e].v == [a.min(b), a.max(b)], "triangle {t} local edge {k}");
                if let Some(n) = self.tri_nbrs[t][k] {
                    let back = (0..3).filter(|&j| self.tri_nbrs[n][j] == Some(t)).count();
                    ensure!(back == 1, "neighbor({t}, {k}) = {n} is not symmetric");
                }
            }
        }
        ensure!(self.edges.len() + interior == 3 * nt, "edge sides do not add up to 3 x triangles");

        // Vertex fans.
        ensure!(self.vt_start.len() == nv + 1, "vt_start has the wrong length");
        let mut count = vec![0usize; nv];
        for tri in &self.tris {
            for &v in tri {
                count[v] += 1;
            }
        }
        let mut degree = vec![0usize; nv];
        for e in &self.edges {
            degree[e.v[0]] += 1;
            degree[e.v[1]] += 1;
        }
        for v in 0..nv {
            let fan = self.vertex_triangles(v);
            ensure!(fan.len() == count[v] && !fan.is_empty(), "vertex {v}: fan size is wrong");
            let border = self.border_vertex[v];
            ensure!(self.vertex_degree(v) == degree[v], "vertex_degree({v}) is wrong");
            ensure!(
                degree[v] == fan.len() + usize::from(border),
                "vertex {v}: {} edges for {} triangles",
                degree[v],
                fan.len()
            );
            for (j, &t) in fan.iter().enumerate() {
                let tri = self.tris[t];
                let i = tri.iter().position(|&w| w == v);
                ensure!(i.is_some(), "vertex_triangles({v}) lists triangle {t} {tri:?}");
                let i = i.unwrap_or(0);
                let next = self.tri_nbrs[t][(i + 1) % 3];
                let prev = self.tri_nbrs[t][(i + 2) % 3];
                if j == 0 {
                    ensure!(
                        border == prev.is_none(),
                        "vertex {v}: fan does not start at the border"
                    );
                }
                let expect = match fan.get(j + 1) {
                    Some(&n) => Some(n),
                    None if border => None,
                    None => Some(fan[0]),
                };
                ensure!(next == expect, "vertex {v}: fan is not counter-clockwise at triangle {t}");
            }
        }

        // Point location: each triangle is found at its centroid (from itself or from scratch).
        for t in 0..nt {
            let c = self.tris[t].map(|v| self.verts[v]);
            let p = [(c[0][0] + c[1][0] + c[2][0]) / 3.0, (c[0][1] + c[1][1] + c[2][1]) / 3.0];
            ensure!(self.locator.bucket_triangles(p).any(|s| s == t), "triangle {t} not bucketed");
            ensure!(self.locate(p, Some(t)).map(|r| r.0) == Some(t), "centroid of {t} not in it");
            ensure!(self.locate(p, None).is_some(), "centroid of triangle {t} not located");
        }
        let (lo, hi) = self.bbox;
        ensure!(
            self.verts.iter().all(|p| (0..2).all(|k| lo[k] <= p[k] && p[k] <= hi[k])),
            "bounding box does not contain all vertices"
        );
        Ok(())
    }
}

//! The C1 ("quadrilateral") conditions as integer rows (thesis eqs. 12.6-12.7, ch. 13).
//!
//! For an interior edge `e` with endpoints `a = e.v[0]`, `b = e.v[1]`, let `u = (w, a, b)`
//! be the triangle on its left and `v = (w', a, b)` the one on its right, written with the
//! opposite vertex first. For `j + k = d - 1` (`i = j`, the condition's number along the
//! edge, counted from `a`):
//!
//! ```text
//!   q^v_(1,j,k) = b_w q^u_(1,j,k) + b_a q^u_(0,j+1,k) + b_b q^u_(0,j,k+1)       (12.7)
//! ```
//!
//! where `(b_w, b_a, b_b)` are the barycentric coordinates of `w'` relative to `(w, a, b)`.
//! With vertex coordinates on the grid `1/g`, `b = (B_w, B_a, B_b) / A` with integer
//! numerators and `A = B_w + B_a + B_b` = twice the area of `u` in grid units. So each
//! condition is the integer row
//!
//! ```text
//!   A q_l - B_w q_r - B_a q_p - B_b q_n = 0
//! ```
//!
//! (divided by the gcd of its coefficients). Its coefficients sum to zero, so every affine
//! map of the plane keeps it. `l` and `r` are the medial members, `p` and `n` the extreme
//! ones (the two points on the edge), in the labels of thesis fig. 13.2.

use super::layout::Layout;
use crate::exact::{Int, SparseIntMatrix};
use crate::mesh::Mesh;

/// One quadrilateral condition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quad {
    /// The interior edge.
    pub edge: usize,
    /// Number along the edge, `0..d`, counted from `edge.v[0]`.
    pub index: usize,
    /// Medial member in the right triangle (`q^v_(1,j,k)`).
    pub l: usize,
    /// Medial member in the left triangle (`q^u_(1,j,k)`).
    pub r: usize,
    /// Extreme member nearer `edge.v[0]`.
    pub p: usize,
    /// Extreme member nearer `edge.v[1]`.
    pub n: usize,
    /// Integer coefficients of `(l, r, p, n)`, summing to zero.
    pub coef: [i64; 4],
}

impl Quad {
    /// The four members `[l, r, p, n]`.
    pub fn members(&self) -> [usize; 4] {
        [self.l, self.r, self.p, self.n]
    }
}

fn gcd(a: i128, b: i128) -> i128 {
    let (mut a, mut b) = (a.abs(), b.abs());
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// All quadrilateral conditions of the spline, `d` per interior edge, in edge order.
///
/// # Panics
/// Panics if a reduced coefficient exceeds `i64` (impossible for the coordinate range the
/// mesh accepts).
pub fn quads(mesh: &Mesh, layout: &Layout) -> Vec<Quad> {
    let d = layout.degree();
    let mut out = Vec::new();
    for (e, edge) in mesh.edges().iter().enumerate() {
        let (Some(u), Some(v)) = (edge.tris[0], edge.tris[1]) else { continue };
        let (a, b) = (edge.v[0], edge.v[1]);
        let tu = mesh.triangle(u);
        let tv = mesh.triangle(v);
        let w = tu.iter().copied().find(|&x| x != a && x != b).expect("triangle has 3 vertices");
        let w2 = tv.iter().copied().find(|&x| x != a && x != b).expect("triangle has 3 vertices");
        // Barycentric numerators of w2 relative to u, reordered to (w, a, b).
        let bu = mesh.barycentric_int(u, mesh.vertex_int(w2));
        let pos = |x: usize| tu.iter().position(|&y| y == x).expect("vertex of u");
        let (bw, ba, bb) = (bu[pos(w)], bu[pos(a)], bu[pos(b)]);
        let area = bw + ba + bb;
        let g = gcd(gcd(area, bw), gcd(ba, bb));
        let coef = [area / g, -bw / g, -ba / g, -bb / g]
            .map(|c| i64::try_from(c).expect("coefficient fits in i64"));
        // Point of triangle `t` with weights `x` on its opposite vertex `o`, `y` on a, `z` on b.
        let idx = |t: usize, o: usize, x: usize, y: usize, z: usize| {
            let tri = mesh.triangle(t);
            let mut m = [0; 3];
            for (vert, wgt) in [(o, x), (a, y), (b, z)] {
                m[tri.iter().position(|&q| q == vert).expect("vertex of triangle")] = wgt;
            }
            layout.point(t, m)
        };
        let idx_u = |x, y, z| idx(u, w, x, y, z);
        let idx_v = |x, y, z| idx(v, w2, x, y, z);
        for j in 0..d {
            // Weight on a: counted so that index 0 is nearest a.
            let ja = d - 1 - j;
            let kb = j;
            out.push(Quad {
                edge: e,
                index: j,
                l: idx_v(1, ja, kb),
                r: idx_u(1, ja, kb),
                p: idx_u(0, ja + 1, kb),
                n: idx_u(0, ja, kb + 1),
                coef,
            });
        }
    }
    out
}

/// The quadrilateral conditions as the rows of an integer matrix over all control points.
pub fn matrix(quads: &[Quad], num_points: usize) -> SparseIntMatrix {
    let rows = quads
        .iter()
        .map(|q| q.members().iter().zip(q.coef).map(|(&m, c)| (m, Int::from(c))).collect())
        .collect();
    SparseIntMatrix::from_rows(num_points, rows).expect("indices in range")
}

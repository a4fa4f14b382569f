//! Exact prolongation of a spline to a finer, nested mesh.
//!
//! When every triangle `t` of a fine mesh lies inside a triangle `P(t)` of the coarse mesh
//! (as after [`crate::mesh::Mesh::refine`]), a spline over the coarse mesh is a piecewise
//! polynomial over the fine one: on `t` it is the polynomial of `P(t)`'s patch, and it keeps
//! its smoothness across every fine edge (across a fine edge inside `P(t)` the two pieces are
//! one polynomial; a fine edge on a coarse edge is part of it). So the fine spline space
//! contains the coarse one, and the coarse spline has exact fine control points.
//!
//! They come from the *blossom* (polar form) of the coarse patch (thesis Part II ch. 10 for
//! the Bernstein-Bezier form; de Boor, "B-form basics", 1987, for the blossom): for a patch
//! `p(u) = sum_{|m| = d} c_m B_m(u)` in the barycentric coordinates `u` of `P(t)`, the
//! Bezier point of `p` restricted to `t = (v0, v1, v2)` with multi-index `(i, j, k)` is the
//! blossom `b(v0^i, v1^j, v2^k)`: de Casteljau's algorithm with the `d` arguments `v0`
//! (`i` times), `v1` (`j` times) and `v2` (`k` times) in turn, each step
//! `c'_m = sum_l u_l c_{m + e_l}` lowering the degree by one.
//!
//! Arithmetic is exact and integer: the fine vertices' barycentric coordinates in `P(t)` are
//! `beta / A` with integer numerators `beta` ([`Mesh::barycentric_int`]) and `A` twice the
//! area, the coarse patch's points `N / D` on one common denominator `D`; de Casteljau then
//! runs on integers and each result is `N' / (D A^d)`, reduced once.

use super::layout::{local_index, multi_indices};
use super::{Spline, SplineError, ZLayers};
use crate::exact::{Int, Rat};
use crate::mesh::Mesh;
use num_integer::Integer;
use num_traits::{One, Zero};
use rayon::prelude::*;

impl Spline {
    /// The same map over `fine`, where fine triangle `t` lies in this spline's triangle
    /// `parent[t]` ([module docs](self)): the result is equal to `self` everywhere, exactly,
    /// and C1 by construction (checked in the tests, not here). The degree, the image frame
    /// and the 2.5D layers are carried over.
    ///
    /// ```
    /// use trimorph::exact::Rat;
    /// use trimorph::mesh::{Mesh, MeshOptions};
    /// use trimorph::spline::Spline;
    /// let coarse = Mesh::grid(2, 2, 8.0, 8.0, MeshOptions::default()).unwrap();
    /// let r = |n: i64, d: i64| Rat::new(n.into(), d.into());
    /// let a = [[r(1, 2), r(1, 3), r(1, 1)], [r(0, 1), r(2, 1), r(-1, 7)]];
    /// let s = Spline::affine(coarse.clone(), 5, &a).unwrap();
    /// let fine = coarse.refine(&vec![true; coarse.num_triangles()]).unwrap();
    /// let f = s.prolong(fine.mesh.clone(), &fine.parent).unwrap();
    /// f.check_c1().unwrap();
    /// // The same affine map, exactly: the control points of its spline over the fine mesh.
    /// assert_eq!(f.points(), Spline::affine(fine.mesh, 5, &a).unwrap().points());
    /// ```
    pub fn prolong(&self, fine: Mesh, parent: &[usize]) -> Result<Spline, SplineError> {
        let coarse = self.mesh();
        let d = self.degree();
        if parent.len() != fine.num_triangles() {
            return Err(SplineError::NotNested(format!(
                "{} parents for {} fine triangles",
                parent.len(),
                fine.num_triangles()
            )));
        }
        let (gc, gf) = (coarse.grid_denominator(), fine.grid_denominator());
        if gf % gc != 0 {
            return Err(SplineError::NotNested(format!(
                "the fine grid 1/{gf} does not contain the coarse grid 1/{gc}"
            )));
        }
        let scale = gf / gc;
        let layout = Self::layout_for(&fine, d)?;
        // Per fine triangle: its vertices' barycentric numerators in the parent (coarse
        // coordinates scaled to the fine grid) and twice the parent's area on that grid.
        let mut args = Vec::with_capacity(fine.num_triangles());
        for (t, &p) in parent.iter().enumerate() {
            if p >= coarse.num_triangles() {
                return Err(SplineError::NotNested(format!(
                    "fine triangle {t} names parent {p}; the coarse mesh has {} triangles",
                    coarse.num_triangles()
                )));
            }
            let corners = coarse.triangle(p).map(|v| coarse.vertex_int(v).map(|c| c * scale));
            let beta = fine.triangle(t).map(|v| barycentric(corners, fine.vertex_int(v)));
            if beta.iter().flatten().any(|&b| b < 0) {
                return Err(SplineError::NotNested(format!(
                    "fine triangle {t} is not inside coarse triangle {p}"
                )));
            }
            args.push(beta);
        }
        // Channels per point: x, y and, for 2.5D, z0 and z1.
        let channels = |q: usize| -> Vec<&Rat> {
            let mut v: Vec<&Rat> = self.points()[q].iter().collect();
            if let Some(z) = self.z_layers() {
                v.push(&z.z0[q]);
                v.push(&z.z1[q]);
            }
            v
        };
        // Which fine patch computes each fine point (the first that holds it).
        let mut first = vec![usize::MAX; layout.len()];
        for (t, patch) in layout.patches().iter().enumerate() {
            for (k, &q) in patch.iter().enumerate() {
                if first[q] == usize::MAX {
                    first[q] = t * patch.len() + k;
                }
            }
        }
        let mi = multi_indices(d);
        let per_patch = mi.len();
        let computed: Vec<Vec<(usize, Vec<Rat>)>> = (0..fine.num_triangles())
            .into_par_iter()
            .map(|t| {
                let p = parent[t];
                let coarse_patch = &self.layout().patches()[p];
                let (nums, den) = common_denominator(coarse_patch.iter().map(|&q| channels(q)));
                let a = Int::from_i128(coarse.twice_area_int(p) * (scale as i128 * scale as i128));
                let den = den * num_traits::pow(a, d);
                let beta = args[t].map(|b| b.map(Int::from_i128));
                let mut out = Vec::new();
                for (k, m) in mi.iter().enumerate() {
                    let q = layout.patches()[t][k];
                    if first[q] != t * per_patch + k {
                        continue;
                    }
                    let mut u = Vec::with_capacity(d);
                    for (v, &times) in m.iter().enumerate() {
                        u.extend(std::iter::repeat_n(&beta[v], times));
                    }
                    let value = blossom(d, &nums, &u);
                    out.push((q, value.into_iter().map(|n| Rat::new(n, den.clone())).collect()));
                }
                out
            })
            .collect();
        let nc = channels(0).len();
        let mut values: Vec<Vec<Rat>> = vec![Vec::new(); layout.len()];
        for (q, v) in computed.into_iter().flatten() {
            values[q] = v;
        }
        debug_assert!(values.iter().all(|v| v.len() == nc));
        let z = self.z_layers().map(|z| ZLayers {
            range: z.range.clone(),
            z0: values.iter().map(|v| v[2].clone()).collect(),
            z1: values.iter().map(|v| v[3].clone()).collect(),
        });
        let points = values.into_iter().map(|mut v| {
            v.truncate(2);
            v
        });
        let mut s = Self::assemble(fine, layout, points.collect(), z);
        s.set_frame(self.frame().cloned());
        Ok(s)
    }
}

/// Twice the signed areas of `(q, b, c)`, `(a, q, c)`, `(a, b, q)`.
fn barycentric([a, b, c]: [[i64; 2]; 3], q: [i64; 2]) -> [i128; 3] {
    let o = |p: [i64; 2], q: [i64; 2], r: [i64; 2]| {
        (q[0] - p[0]) as i128 * (r[1] - p[1]) as i128
            - (q[1] - p[1]) as i128 * (r[0] - p[0]) as i128
    };
    [o(q, b, c), o(a, q, c), o(a, b, q)]
}

/// The values as integer numerators over their least common denominator.
fn common_denominator<'a>(rows: impl Iterator<Item = Vec<&'a Rat>>) -> (Vec<Vec<Int>>, Int) {
    let rows: Vec<Vec<&Rat>> = rows.collect();
    let den = rows.iter().flatten().fold(Int::one(), |l, r| l.lcm(r.denom()));
    let nums = rows
        .iter()
        .map(|row| row.iter().map(|r| r.numer() * &den.div_exact(r.denom())).collect())
        .collect();
    (nums, den)
}

/// de Casteljau with the arguments `u` (one per degree, integer barycentric numerators) on
/// the degree-`d` coefficients `c` (file order, any number of channels).
fn blossom(d: usize, c: &[Vec<Int>], u: &[&[Int; 3]]) -> Vec<Int> {
    debug_assert_eq!(u.len(), d);
    let mut cur: Vec<Vec<Int>> = c.to_vec();
    for (step, w) in u.iter().enumerate() {
        let r = d - step - 1;
        let mut next = Vec::with_capacity((r + 1) * (r + 2) / 2);
        for m in multi_indices(r) {
            let up = |l: usize| {
                let mut e = m;
                e[l] += 1;
                &cur[local_index(r + 1, e[0], e[1])]
            };
            let v = (0..cur[0].len())
                .map(|ch| {
                    (0..3).fold(Int::zero(), |acc, l| {
                        if w[l].is_zero() {
                            acc
                        } else {
                            acc + &w[l] * &up(l)[ch]
                        }
                    })
                })
                .collect();
            next.push(v);
        }
        cur = next;
    }
    cur.pop().unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshOptions;
    use crate::spline::mds::Mds;

    fn r(n: i64, d: i64) -> Rat {
        Rat::new(Int::from(n), Int::from(d))
    }

    /// A spline that is not polynomial: the identity with some free points moved, the
    /// dependents recomputed exactly (C1).
    fn wavy(mesh: Mesh, d: usize) -> Spline {
        let id = Spline::identity(mesh, d).unwrap();
        let mds = Mds::new(&id).unwrap();
        let mut pts = id.points().to_vec();
        for (i, p) in pts.iter_mut().enumerate() {
            p[0] = &p[0] + r((i as i64 * 7) % 5 - 2, 16);
            p[1] = &p[1] + r((i as i64 * 3) % 7 - 3, 32);
        }
        id.with_determined_points(&mds, pts).unwrap()
    }

    /// Exact value of `s` at the rational point `x / den` inside triangle `t`.
    fn value_at(s: &Spline, t: usize, q: [i64; 2], den: i64) -> Vec<Rat> {
        let m = s.mesh();
        let scale = den / m.grid_denominator();
        let corners = m.triangle(t).map(|v| m.vertex_int(v).map(|c| c * scale));
        let b = barycentric(corners, q);
        assert!(b.iter().all(|&x| x >= 0));
        let area = b.iter().sum::<i128>();
        let d = s.degree();
        let (nums, cden) = common_denominator(
            s.layout().patches()[t].iter().map(|&p| s.points()[p].iter().collect()),
        );
        let beta = b.map(Int::from_i128);
        let u = vec![&beta; d];
        let v = blossom(d, &nums, &u);
        let den = cden * num_traits::pow(Int::from_i128(area), d);
        v.into_iter().map(|n| Rat::new(n, den.clone())).collect()
    }

    #[test]
    fn the_prolonged_spline_is_c1_and_equal_to_the_coarse_one_at_rational_points() {
        let coarse = Mesh::grid(3, 2, 30.0, 21.0, MeshOptions { grid: 2 }).unwrap();
        let s = wavy(coarse.clone(), 5);
        s.check_c1().unwrap();
        let mut marked = vec![false; coarse.num_triangles()];
        marked[2] = true;
        marked[7] = true;
        let r1 = coarse.refine(&marked).unwrap();
        let f = s.prolong(r1.mesh.clone(), &r1.parent).unwrap();
        f.check_c1().unwrap();
        // Twice: green children refined again.
        let r2 = r1.mesh.refine(&vec![true; r1.mesh.num_triangles()]).unwrap();
        let f2 = f.prolong(r2.mesh.clone(), &r2.parent).unwrap();
        f2.check_c1().unwrap();
        // Exact equality at the centroids of the finest triangles (on the grid 3 g).
        let g = f2.mesh().grid_denominator() * 3;
        for t in 0..f2.mesh().num_triangles() {
            let c = [0, 1].map(|k| {
                f2.mesh().triangle(t).iter().map(|&v| f2.mesh().vertex_int(v)[k]).sum::<i64>()
            });
            let t1 = r2.parent[t];
            let t0 = r1.parent[t1];
            assert_eq!(value_at(&f2, t, c, g), value_at(&s, t0, c, g), "triangle {t}");
        }
    }

    #[test]
    fn a_triangle_outside_its_parent_is_refused() {
        let coarse = Mesh::grid(2, 1, 8.0, 4.0, MeshOptions::default()).unwrap();
        let s = Spline::identity(coarse.clone(), 3).unwrap();
        let parent: Vec<usize> = vec![1, 0, 2, 3];
        assert!(matches!(s.prolong(coarse.clone(), &parent), Err(SplineError::NotNested(_))));
        assert!(matches!(s.prolong(coarse.clone(), &[0]), Err(SplineError::NotNested(_))));
    }
}

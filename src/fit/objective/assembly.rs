//! Assembly of the bending energy over the variables.
//!
//! Per coordinate, `E(x) = x^T K x + 2 b^T x + const` with
//!
//! ```text
//!   K = sum_T S_T^T K_T S_T,      b = sum_T S_T^T K_T q0_T,
//! ```
//!
//! `K_T` the triangle's thin-plate bending matrix over its patch ([`super::super::basis`]),
//! `S_T` the patch points' rows over the variables ([`Param::rows`](super::Param::rows)) and
//! `q0_T` the patch points at `x = 0` (the fixed points' share). Every triangle's block is
//! independent, so blocks are computed in parallel and summed in triangle order
//! (deterministic).
//!
//! The structure of `K` (which variables each triangle touches, [`Objective::bending_locals`])
//! is known before any value, so a caller can run the symbolic analysis of `K`
//! ([`lower_entries`]) beside the numeric assembly ([`Objective::bending_values`]), which is
//! what [`super::super::smooth::Smoother`] does.

use super::{Objective, TriTerm, TriangleBlock};
use rayon::prelude::*;

/// The bending system of [`Objective::bending_system`].
#[derive(Clone, Debug, PartialEq)]
pub struct BendingSystem {
    /// `K`'s lower-triangle entries `(row, column)`, `row >= column`, duplicates to be
    /// summed ([`lower_entries`] of the triangles' variables).
    pub entries: Vec<(usize, usize)>,
    /// The numbers: one value per entry, `b`, and `K`'s diagonal.
    pub values: BendingValues,
}

/// The numbers of the bending system, in the order of [`lower_entries`].
#[derive(Clone, Debug, PartialEq)]
pub struct BendingValues {
    /// One value per entry of [`lower_entries`].
    pub values: Vec<f64>,
    /// `b` per coordinate (`nv` entries each).
    pub b: [Vec<f64>; 2],
    /// The sum of `K`'s diagonal entries, and how many diagonal entries were summed.
    pub diag: (f64, usize),
}

/// `K`'s lower-triangle entries, triangle after triangle: for each triangle's variables
/// `local`, the pairs `(local[z1], local[z2])` with `local[z1] >= local[z2]`, `z1` then
/// `z2` ascending. [`Objective::bending_values`] gives the values in this order.
pub fn lower_entries(locals: &[Vec<usize>]) -> Vec<(usize, usize)> {
    let count: usize = locals.iter().map(|l| l.len() * (l.len() + 1) / 2).sum();
    let mut entries = Vec::with_capacity(count);
    for local in locals {
        for &a in local {
            for &b in local {
                if a >= b {
                    entries.push((a, b));
                }
            }
        }
    }
    entries
}

impl Objective {
    /// The bending energy over the variables (see the module docs): `K`'s lower-triangle
    /// entries with their values, `b` per coordinate, and `K`'s diagonal sum.
    pub fn bending_system(&self) -> BendingSystem {
        let locals = self.bending_locals();
        let (entries, values) =
            rayon::join(|| lower_entries(&locals), || self.bending_values(&locals));
        BendingSystem { entries, values }
    }

    /// Per triangle, the variables its patch depends on, ascending.
    pub fn bending_locals(&self) -> Vec<Vec<usize>> {
        let nv = self.param.nv();
        let rows = self.param.rows();
        self.tris
            .par_iter()
            .map_init(
                || vec![false; nv],
                |seen, tri| {
                    let mut local = Vec::new();
                    for &j in &tri.patch {
                        for &(k, _) in &rows[j] {
                            if !seen[k] {
                                seen[k] = true;
                                local.push(k);
                            }
                        }
                    }
                    for &k in &local {
                        seen[k] = false;
                    }
                    // Ascending, so that the lower-triangle pairs are z2 <= z1
                    // (`sparse::Pattern::from_cliques`).
                    local.sort_unstable();
                    local
                },
            )
            .collect()
    }

    /// The values of `K` in the order of [`lower_entries`]`(locals)`, `b`, and the diagonal
    /// sum, for `locals` = [`bending_locals`](Self::bending_locals).
    pub fn bending_values(&self, locals: &[Vec<usize>]) -> BendingValues {
        let nv = self.param.nv();
        let rows = self.param.rows();
        let mut p0 = vec![[0.0f64; 2]; self.param.var_of.len()];
        self.param.points_into(&vec![0.0; 2 * nv], &mut p0);
        let p0 = &p0;
        // Per triangle: its lower-triangle values, S_T^T K_T q0_T over its variables, and its
        // diagonal sum and count.
        type Part = (Vec<f64>, Vec<[f64; 2]>, f64, usize);
        let parts: Vec<Part> = self
            .tris
            .par_iter()
            .zip(locals)
            .map_init(
                || vec![usize::MAX; nv],
                |pos, (tri, local)| {
                    let blk = block(tri, rows, pos, local.clone());
                    let u = local.len();
                    let mut vals = Vec::with_capacity(u * (u + 1) / 2);
                    let (mut diag, mut count) = (0.0, 0);
                    // `local` is ascending: local[z1] >= local[z2] iff z2 <= z1.
                    for z1 in 0..u {
                        vals.extend_from_slice(&blk.bend[z1 * u..z1 * u + z1 + 1]);
                        diag += blk.bend[z1 * u + z1];
                        count += 1;
                    }
                    // K_T q0 over the patch, then S_T^T (K_T q0).
                    let m = tri.patch.len();
                    let mut bl = vec![[0.0f64; 2]; u];
                    for r in 0..m {
                        let mut kq = [0.0; 2];
                        for c in 0..m {
                            let kv = tri.k[r * m + c];
                            kq[0] += kv * p0[tri.patch[c]][0];
                            kq[1] += kv * p0[tri.patch[c]][1];
                        }
                        for z in 0..u {
                            let sv = blk.st[r * u + z];
                            bl[z][0] += sv * kq[0];
                            bl[z][1] += sv * kq[1];
                        }
                    }
                    (vals, bl, diag, count)
                },
            )
            .collect();
        let mut values = Vec::with_capacity(parts.iter().map(|p| p.0.len()).sum());
        let mut b = [vec![0.0; nv], vec![0.0; nv]];
        let mut diag = (0.0, 0);
        for ((vals, bl, d, c), local) in parts.into_iter().zip(locals) {
            values.extend_from_slice(&vals);
            for (&k, v) in local.iter().zip(&bl) {
                b[0][k] += v[0];
                b[1][k] += v[1];
            }
            diag.0 += d;
            diag.1 += c;
        }
        BendingValues { values, b, diag }
    }

    /// The diagonal of the bending matrix over the variables (`nv` entries, the same for
    /// both coordinates; without `lambda`).
    pub fn bending_diagonal(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.param.nv()];
        self.bending_entries(|a, b, v| {
            if a == b {
                d[a] += v;
            }
        });
        d
    }

    /// Calls `emit(a, b, v)` for every contribution `v` to `K[a][b]` of the bending matrix
    /// over the variables (`K = sum_T S_T^T K_T S_T`, both triangles, without `lambda`).
    pub(super) fn bending_entries(&self, mut emit: impl FnMut(usize, usize, f64)) {
        for blk in self.triangle_blocks() {
            let u = blk.local.len();
            for z1 in 0..u {
                for z2 in 0..u {
                    let v = blk.bend[z1 * u + z2];
                    if v != 0.0 {
                        emit(blk.local[z1], blk.local[z2], v);
                    }
                }
            }
        }
    }

    /// Per triangle, the variables its patch depends on, `S_T` (patch points x those
    /// variables) and `S_T^T K_T S_T`.
    pub(in crate::fit) fn triangle_blocks(&self) -> Vec<TriangleBlock> {
        let nv = self.param.nv();
        let rows = self.param.rows();
        let locals = self.bending_locals();
        // Independent per triangle: in parallel, in order, one position map per worker.
        self.tris
            .par_iter()
            .zip(locals)
            .map_init(|| vec![usize::MAX; nv], |pos, (tri, local)| block(tri, rows, pos, local))
            .collect()
    }
}

/// One triangle's block over its variables `local`: `S_T` and `S_T^T K_T S_T`. `pos` is a
/// scratch position map over all variables (`usize::MAX` everywhere, and left so).
fn block(
    tri: &TriTerm,
    rows: &[Vec<(usize, f64)>],
    pos: &mut [usize],
    local: Vec<usize>,
) -> TriangleBlock {
    for (z, &k) in local.iter().enumerate() {
        pos[k] = z;
    }
    let (m, u) = (tri.patch.len(), local.len());
    // S_T (m x u), then K S_T (m x u), then S_T^T (K S_T) (u x u).
    let mut st = vec![0.0; m * u];
    for (a, &j) in tri.patch.iter().enumerate() {
        for &(k, v) in &rows[j] {
            st[a * u + pos[k]] += v;
        }
    }
    let mut ks = vec![0.0; m * u];
    for r in 0..m {
        for c in 0..m {
            let kv = tri.k[r * m + c];
            if kv != 0.0 {
                for z in 0..u {
                    ks[r * u + z] += kv * st[c * u + z];
                }
            }
        }
    }
    let mut bend = vec![0.0; u * u];
    for a in 0..m {
        for z1 in 0..u {
            let sv = st[a * u + z1];
            if sv != 0.0 {
                for z2 in 0..u {
                    bend[z1 * u + z2] += sv * ks[a * u + z2];
                }
            }
        }
    }
    for &k in &local {
        pos[k] = usize::MAX;
    }
    TriangleBlock { local, st, bend }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::landmarks::Landmark;
    use crate::fit::{solve::objective, FitOptions};
    use crate::mesh::{Mesh, MeshOptions};
    use crate::spline::Spline;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    /// `E(x) - E(0) = sum_c x_c^T K x_c + 2 b_c^T x_c` with `K` summed from the entries
    /// (lower triangle, mirrored), against the objective's own bending term, which sums
    /// `q^T K_T q` over the triangles' patches directly. The border is pinned, so fixed
    /// points give `b` a share.
    #[test]
    fn assembled_energy_equals_the_patch_sums() {
        let mesh = Mesh::grid(6, 4, 300.0, 200.0, MeshOptions::default()).unwrap();
        let s = Spline::identity(mesh, 5).unwrap();
        let mut rng = SmallRng::seed_from_u64(4);
        let lms: Vec<Landmark> = (0..15)
            .map(|_| {
                let p = [rng.gen_range(10.0..290.0), rng.gen_range(10.0..190.0)];
                Landmark { name: None, src: p, dst: [p[0] + 2.0, p[1] - 1.0], weight: 1.0 }
            })
            .collect();
        for pin_border in [false, true] {
            let opts = FitOptions { pin_border, barrier: None, ..FitOptions::default() };
            let mut obj = objective(&s, &lms, &opts).unwrap();
            // eval sums the bending term only where it is weighted.
            obj.bend = 1.0;
            let nv = obj.param.nv();
            let sys = obj.bending_system();
            let locals = obj.bending_locals();
            assert_eq!(sys.entries, lower_entries(&locals));
            assert_eq!(sys.entries.len(), sys.values.values.len());
            assert!(sys.entries.iter().all(|&(r, c)| r >= c && r < nv));
            assert_eq!(sys.values.diag.1, locals.iter().map(Vec::len).sum::<usize>());
            assert_eq!(pin_border, sys.values.b.iter().flatten().any(|&v| v != 0.0));
            let x: Vec<f64> = (0..2 * nv).map(|_| rng.gen_range(-3.0..3.0)).collect();
            let mut quad = 0.0;
            for c in 0..2 {
                let xc = &x[c * nv..(c + 1) * nv];
                for (&(r, col), &v) in sys.entries.iter().zip(&sys.values.values) {
                    let both = if r == col { 1.0 } else { 2.0 };
                    quad += both * v * xc[r] * xc[col];
                }
                quad += 2.0 * sys.values.b[c].iter().zip(xc).map(|(b, x)| b * x).sum::<f64>();
            }
            let e0 = obj.eval(&vec![0.0; 2 * nv], None).bend;
            let e = obj.eval(&x, None).bend;
            assert!(
                ((e - e0) - quad).abs() <= 1e-9 * e.abs().max(1.0),
                "pin_border {pin_border}: E(x) - E(0) = {} but the assembly gives {quad}",
                e - e0
            );
            // The blocks Newton uses describe the same matrix.
            let mut dense = vec![0.0; nv * nv];
            obj.bending_entries(|a, b, v| dense[a * nv + b] += v);
            let mut sparse = vec![0.0; nv * nv];
            for (&(r, c), &v) in sys.entries.iter().zip(&sys.values.values) {
                sparse[r * nv + c] += v;
                if r != c {
                    sparse[c * nv + r] += v;
                }
            }
            let scale = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, b) in dense.iter().zip(&sparse) {
                assert!((a - b).abs() <= 1e-12 * scale, "{a} vs {b}");
            }
        }
    }
}

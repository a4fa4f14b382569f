//! A local minimal determining set (MDS) for C1 splines of degree `d >= 5` (after Lai &
//! Schumaker, *Spline Functions on Triangulations*, ch. 5 and 9), used to keep exact control
//! points bounded over long editing sessions.
//!
//! The C1 conditions split into local groups, because for `d >= 5` the disks of radius 2
//! around different vertices are disjoint:
//!
//! * **ring 1 of a vertex `v`** (the vertex and its edge corners): the `Q_0` conditions say the
//!   edge corners come from one linear map (the derivative at `v`). Free: `v` and the two
//!   edge corners of one triangle `T_v`; every other edge corner on edge `(v, w)` is
//!   `(1 - a - b) q_v + a q_1 + b q_2` with `w - v = a (w1 - v) + b (w2 - v)`;
//! * **ring 2 of `v`** (the points at distance 2 on edges, and the inner corners): the `Q_1`
//!   conditions around `v`, given ring 1, form a small system; an exact elimination (pivots
//!   preferring inner corners) makes its pivot points dependent and the rest free;
//! * **edge middles**: each condition `Q_i`, `2 <= i <= d-3`, has its own pair of medial
//!   points; the one in the left triangle is free, the other follows from (12.7).
//!
//! Every other control point is free. The dependents are fixed rational combinations of
//! points evaluated before them (ring 1, then ring 2, then middles), with coefficients that
//! depend only on the mesh. So a spline whose free points lie on a grid has control points
//! of bounded size, whatever its edit history, and any choice of free values gives an exactly
//! C1 spline. Construction fails (and bounded mode is unavailable) only at vertices whose
//! ring-2 system constrains ring 1, such as interior vertices where four edges lie on two
//! lines (the `sigma` vertices of the dimension formula).

use super::c1::Quad;
use super::intform::IntPlan;
use super::layout::Layout;
use super::rref::{pivot_formulas, rref, rref_big, rref_fixed, rref_int, Formula};
use super::Spline;
use crate::exact::{Int, Rat};
use crate::mesh::Mesh;
use bnum::cast::As;
use bnum::types::I256;
use num_traits::{One, Signed, Zero};
use rayon::prelude::*;

/// How a control point is obtained.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Role {
    /// In the determining set.
    Free,
    /// `sum c_j x_j` over earlier points.
    Dependent(Vec<(usize, Rat)>),
}

/// A determining set with its evaluation order.
#[derive(Clone, Debug)]
pub struct Mds {
    roles: Vec<Role>,
    /// Dependents in evaluation order.
    order: Vec<usize>,
    /// For each point, the dependents whose formula uses it.
    used_by: Vec<Vec<usize>>,
    /// The formulas on common denominators ([`IntPlan`]), built on first use.
    plan: std::sync::OnceLock<IntPlan>,
    /// [`Mds::amplification`], computed on first use.
    amplification: std::sync::OnceLock<f64>,
    /// The spline's C1 conditions (its quads, in order), checked by
    /// [`recompute_verified`](Self::recompute_verified). Shared with the spline (no copy).
    quads: std::sync::Arc<Vec<Quad>>,
}

/// Why no MDS could be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MdsError {
    /// Degree below 5.
    #[error("bounded exactness needs degree 5 or more (this spline has degree {0})")]
    Degree(usize),
    /// A vertex whose ring-2 conditions constrain its ring 1.
    #[error(
        "vertex {0} is singular (its C1 conditions couple rings 1 and 2); no local determining set"
    )]
    Singular(usize),
}

fn point_on_edge(mesh: &Mesh, lay: &Layout, e: usize, from: usize, dist: usize) -> usize {
    let d = lay.degree();
    let ed = mesh.edges()[e];
    let s = if ed.v[0] == from { dist } else { d - dist };
    if s == 0 {
        ed.v[0]
    } else if s == d {
        ed.v[1]
    } else {
        mesh.num_vertices() + (d - 1) * e + (s - 1)
    }
}

fn inner_corner(mesh: &Mesh, lay: &Layout, t: usize, v: usize) -> usize {
    let d = lay.degree();
    let tri = mesh.triangle(t);
    let mut m = [1usize; 3];
    m[tri.iter().position(|&x| x == v).expect("v in t")] = d - 2;
    lay.point(t, m)
}

/// The quadrilateral conditions `quads` as rows of fractions over the points `all`.
fn irows_to_rat(quads: &[usize], s: &Spline, all: &[usize]) -> Vec<Vec<Rat>> {
    quads
        .iter()
        .map(|&qi| {
            let q = s.quads()[qi];
            let mut row = vec![Rat::zero(); all.len()];
            for (m, c) in q.members().into_iter().zip(q.coef) {
                let j = all.iter().position(|&x| x == m).expect("member listed");
                row[j] += Rat::from_integer(Int::from(c));
            }
            row
        })
        .collect()
}

impl Mds {
    /// Builds the determining set of a spline's layout.
    pub fn new(s: &Spline) -> Result<Mds, MdsError> {
        let (mesh, lay) = (s.mesh(), s.layout());
        let d = lay.degree();
        if d < 5 {
            return Err(MdsError::Degree(d));
        }
        let n = s.num_points();
        let mut roles = vec![Role::Free; n];
        let mut order = Vec::new();
        let mut quad_at = std::collections::HashMap::new();
        for (qi, q) in s.quads().iter().enumerate() {
            quad_at.insert((q.edge, q.index), qi);
        }
        let vint = |v: usize| mesh.vertex_int(v).map(|c| c as i128);
        let mut edges_at: Vec<Vec<usize>> = vec![Vec::new(); mesh.num_vertices()];
        for (e, ed) in mesh.edges().iter().enumerate() {
            edges_at[ed.v[0]].push(e);
            edges_at[ed.v[1]].push(e);
        }
        // Ring 1.
        for v in 0..mesh.num_vertices() {
            let t = mesh.vertex_triangles(v)[0];
            let tri = mesh.triangle(t);
            let k = tri.iter().position(|&x| x == v).expect("v in t");
            let (w1, w2) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let (pv, p1, p2) = (vint(v), vint(w1), vint(w2));
            let (a1, a2) = ([p1[0] - pv[0], p1[1] - pv[1]], [p2[0] - pv[0], p2[1] - pv[1]]);
            let cross = |a: [i128; 2], b: [i128; 2]| a[0] * b[1] - a[1] * b[0];
            let det = cross(a1, a2);
            let e1 = mesh.edge_between(v, w1).expect("edge");
            let e2 = mesh.edge_between(v, w2).expect("edge");
            let (c1, c2) = (point_on_edge(mesh, lay, e1, v, 1), point_on_edge(mesh, lay, e2, v, 1));
            for &e in &edges_at[v] {
                if e == e1 || e == e2 {
                    continue;
                }
                let ed = mesh.edges()[e];
                let w = if ed.v[0] == v { ed.v[1] } else { ed.v[0] };
                let pw = vint(w);
                let dw = [pw[0] - pv[0], pw[1] - pv[1]];
                let a = Rat::new(Int::from_i128(cross(dw, a2)), Int::from_i128(det));
                let b = Rat::new(Int::from_i128(cross(a1, dw)), Int::from_i128(det));
                let c = point_on_edge(mesh, lay, e, v, 1);
                let f = vec![(v, Rat::one() - &a - &b), (c1, a), (c2, b)];
                roles[c] = Role::Dependent(f.into_iter().filter(|(_, x)| !x.is_zero()).collect());
                order.push(c);
            }
        }
        // Ring 2: one small exact elimination per vertex, independent of the others, so
        // they run in parallel; results are merged in vertex order (deterministic).
        let ring2 = |v: usize| -> Result<Vec<(usize, Formula)>, MdsError> {
            let mut cols: Vec<usize> =
                mesh.vertex_triangles(v).iter().map(|&t| inner_corner(mesh, lay, t, v)).collect();
            let ncorners = cols.len();
            cols.extend(edges_at[v].iter().map(|&e| point_on_edge(mesh, lay, e, v, 2)));
            let ncand = cols.len();
            let mut quads = Vec::new();
            for &e in &edges_at[v] {
                let idx = if mesh.edges()[e].v[0] == v { 1 } else { d - 2 };
                if let Some(&qi) = quad_at.get(&(e, idx)) {
                    quads.push(qi);
                }
            }
            if quads.is_empty() {
                return Ok(Vec::new());
            }
            let _ = ncorners;
            // Parameter columns: ring-1 members.
            let mut params: Vec<usize> = Vec::new();
            let col_of = |p: usize, cols: &Vec<usize>| cols.iter().position(|&c| c == p);
            for &qi in &quads {
                let q = s.quads()[qi];
                for m in q.members() {
                    if col_of(m, &cols).is_none() && !params.contains(&m) {
                        params.push(m);
                    }
                }
            }
            let all: Vec<usize> = cols.iter().chain(&params).copied().collect();
            let mut irows: Vec<Vec<i128>> = Vec::with_capacity(quads.len());
            for &qi in &quads {
                let q = s.quads()[qi];
                let mut row = vec![0i128; all.len()];
                for (m, c) in q.members().into_iter().zip(q.coef) {
                    let j = all.iter().position(|&x| x == m).expect("member listed");
                    row[j] += i128::from(c);
                }
                irows.push(row);
            }
            // The reduced rows in the narrowest exact type that holds them: i128, then 256
            // bits, then exact integers, then fractions. Only the pivot rows' entries become
            // fractions (the formulas).
            let formulas = if let Some(pivots) = rref_int(&mut irows, ncand) {
                pivot_formulas(&irows, &pivots, &cols, &all)
            } else {
                let mut wrows: Vec<Vec<I256>> =
                    irows.iter().map(|r| r.iter().map(|&x| x.as_()).collect()).collect();
                if let Some(pivots) = rref_fixed(&mut wrows, ncand) {
                    pivot_formulas(&wrows, &pivots, &cols, &all)
                } else {
                    let mut brows: Vec<Vec<Int>> = irows
                        .iter()
                        .map(|r| r.iter().map(|&x| Int::from_i128(x)).collect())
                        .collect();
                    if let Some(pivots) = rref_big(&mut brows, ncand) {
                        pivot_formulas(&brows, &pivots, &cols, &all)
                    } else {
                        let mut rows = irows_to_rat(&quads, s, &all);
                        let pivots = rref(&mut rows, ncand);
                        pivot_formulas(&rows, &pivots, &cols, &all)
                    }
                }
            };
            formulas.ok_or(MdsError::Singular(v))
        };
        let per_vertex: Vec<_> = (0..mesh.num_vertices()).into_par_iter().map(ring2).collect();
        for r in per_vertex {
            for (p, f) in r? {
                roles[p] = Role::Dependent(f);
                order.push(p);
            }
        }
        // Edge middles.
        for q in s.quads() {
            if q.index >= 2 && q.index + 3 <= d {
                let c = |x: i64| Rat::from_integer(Int::from(x));
                let inv = c(q.coef[0]).recip();
                let f = vec![
                    (q.r, -c(q.coef[1]) * &inv),
                    (q.p, -c(q.coef[2]) * &inv),
                    (q.n, -c(q.coef[3]) * &inv),
                ];
                roles[q.l] = Role::Dependent(f.into_iter().filter(|(_, x)| !x.is_zero()).collect());
                order.push(q.l);
            }
        }
        let mut used_by = vec![Vec::new(); n];
        for &p in &order {
            if let Role::Dependent(f) = &roles[p] {
                for (j, _) in f {
                    used_by[*j].push(p);
                }
            }
        }
        Ok(Mds {
            roles,
            order,
            used_by,
            plan: std::sync::OnceLock::new(),
            amplification: std::sync::OnceLock::new(),
            quads: s.shared_quads(),
        })
    }

    /// Builds the integer form of the formulas ([`IntPlan`], used by
    /// [`recompute`](Self::recompute)) now rather than on first use: a caller with an idle
    /// thread (the fit, while it solves in floating point) runs it there.
    pub fn prepare(&self) {
        self.plan();
    }

    /// The integer form of the formulas, built on first use (sequential: each dependent's
    /// denominator is built from those of the points before it).
    fn plan(&self) -> &IntPlan {
        self.plan.get_or_init(|| {
            let conditions: Vec<([usize; 4], [i64; 4])> =
                self.quads.iter().map(|q| (q.members(), q.coef)).collect();
            IntPlan::new(
                self.roles.len(),
                &self.order,
                |p| match &self.roles[p] {
                    Role::Dependent(f) => f.as_slice(),
                    Role::Free => &[],
                },
                &conditions,
            )
        })
    }

    /// The role of point `p`.
    pub fn role(&self, p: usize) -> &Role {
        &self.roles[p]
    }
    /// The dependent points in evaluation order (each uses only free points and dependents
    /// earlier in this order).
    pub fn order(&self) -> &[usize] {
        &self.order
    }
    /// Number of free points (the dimension of the C1 spline space when construction
    /// succeeds).
    pub fn num_free(&self) -> usize {
        self.roles.iter().filter(|r| matches!(r, Role::Free)).count()
    }
    /// Largest bit size of a formula coefficient (numerator or denominator).
    pub fn max_coef_bits(&self) -> u64 {
        self.order
            .iter()
            .filter_map(|&p| match &self.roles[p] {
                Role::Dependent(f) => {
                    f.iter().map(|(_, c)| c.numer().bits().max(c.denom().bits())).max()
                }
                Role::Free => None,
            })
            .max()
            .unwrap_or(0)
    }

    /// How much a change of the free points can grow in each control point: a free point
    /// has `a_p = 1`, a dependent `p = sum c_j x_j` has `a_p = sum |c_j| a_j` (in
    /// evaluation order). Moving every free point by at most `e` moves point `p` by at most
    /// `e * a_p`.
    pub fn amplifications(&self) -> Vec<f64> {
        let mut a = vec![1.0f64; self.roles.len()];
        for &p in &self.order {
            if let Role::Dependent(f) = &self.roles[p] {
                a[p] = f.iter().map(|(j, c)| crate::exact::rat_to_f64(c).abs() * a[*j]).sum();
            }
        }
        a
    }

    /// The largest of [`Mds::amplifications`] (computed once).
    ///
    /// It is small (at most a few thousand) on well-shaped meshes and grows without bound
    /// near the singular vertices of the module docs (edges at a vertex close to lying on
    /// two lines): there a rounding of the free points that is harmless elsewhere moves the
    /// dependents by pixels. Exact fits therefore round on a finer grid
    /// ([`rounding_bits`]), and the landmark-adapted fit breaks up such a vertex
    /// ([`Mds::first_amplified`], [`crate::fit::frame`]).
    pub fn amplification(&self) -> f64 {
        *self.amplification.get_or_init(|| self.amplifications().into_iter().fold(1.0, f64::max))
    }

    /// The first dependent in evaluation order whose amplification exceeds `limit`: where
    /// a blow-up starts (its own formula has the large coefficients).
    pub fn first_amplified(&self, limit: f64) -> Option<usize> {
        let a = self.amplifications();
        self.order.iter().copied().find(|&p| a[p] > limit)
    }

    /// Adds to `set` every dependent whose formula uses a point of `set`, transitively.
    pub fn close(&self, set: &mut [bool]) {
        let mut stack: Vec<usize> = (0..set.len()).filter(|&p| set[p]).collect();
        while let Some(p) = stack.pop() {
            for &q in &self.used_by[p] {
                if !set[q] {
                    set[q] = true;
                    stack.push(q);
                }
            }
        }
    }

    /// Recomputes, in evaluation order, the dependents marked in `which` from the current
    /// values (`values[p]` has one entry per coordinate). When every dependent is marked,
    /// the integer form of the formulas runs ([`IntPlan`]: one common denominator, one gcd
    /// per value); it gives the same exact values as
    /// [`recompute_rational`](Self::recompute_rational), which serves partial updates.
    pub fn recompute(&self, values: &mut [Vec<Rat>], which: &[bool]) {
        if self.order.iter().all(|&p| which[p]) {
            self.plan().recompute(values, |p| matches!(self.roles[p], Role::Free));
        } else {
            self.recompute_rational(values, which);
        }
    }

    /// Recomputes every dependent from the free points' values, as
    /// [`recompute`](Self::recompute) with every point marked, and then checks every C1
    /// condition of the spline this set was built for, exactly: on the integer numerators
    /// over the common denominator, before the reduction to lowest terms (`sum_k c_k (L /
    /// E_(m_k)) N_(m_k) = 0`, see [`IntPlan`]), so without a gcd. `Err(quad)` names the first
    /// condition that fails (a determining set that does not determine), and `values` is
    /// then unchanged.
    pub fn recompute_verified(&self, values: &mut [Vec<Rat>]) -> Result<(), usize> {
        self.plan().recompute_verified(values, |p| matches!(self.roles[p], Role::Free))
    }

    /// Whether this set was built for a spline with these C1 conditions.
    pub fn is_for(&self, quads: &[Quad]) -> bool {
        // The spline that built this set shares its quads: equal by address, no comparison.
        std::ptr::eq(self.quads.as_slice(), quads) || self.quads.as_slice() == quads
    }

    /// [`recompute`](Self::recompute) in reduced-fraction arithmetic only (the reference).
    pub fn recompute_rational(&self, values: &mut [Vec<Rat>], which: &[bool]) {
        for &p in &self.order {
            if !which[p] {
                continue;
            }
            let Role::Dependent(f) = &self.roles[p] else { continue };
            let dim = values[p].len();
            let mut acc = vec![Rat::zero(); dim];
            for (j, c) in f {
                for (a, x) in acc.iter_mut().zip(&values[*j]) {
                    *a += c * x;
                }
            }
            values[p] = acc;
        }
    }
}

/// The finest grid exponent that exact fits round their free points to.
pub const MAX_ROUNDING_BITS: u32 = 60;

/// The grid `2^-bits` on which free points are rounded so that no control point moves by
/// more than `2^-tol_bits` from its floating-point value: rounding moves a free point by at
/// most `2^-(bits + 1)`, a dependent by at most `amplification` times that
/// ([`Mds::amplification`]), so `bits = tol_bits - 1 + ceil(log2 amplification)`, at least
/// `tol_bits` and at most [`MAX_ROUNDING_BITS`].
///
/// ```
/// use trimorph::spline::mds::rounding_bits;
/// assert_eq!(rounding_bits(1.0, 20), 20);
/// assert_eq!(rounding_bits(2.0e5, 20), 37); // 2e5 < 2^18
/// assert_eq!(rounding_bits(1.0e30, 20), 60);
/// ```
pub fn rounding_bits(amplification: f64, tol_bits: u32) -> u32 {
    let grow = if amplification.is_finite() && amplification > 1.0 {
        amplification.log2().ceil() as u32
    } else if amplification.is_finite() {
        0
    } else {
        MAX_ROUNDING_BITS
    };
    (tol_bits + grow).saturating_sub(1).max(tol_bits).min(MAX_ROUNDING_BITS.max(tol_bits))
}

/// Rounds `x` to the nearest multiple of `2^-bits` (ties away from zero).
pub fn round_to_grid(x: &Rat, bits: u32) -> Rat {
    let scale = Rat::from_integer(Int::from_i128(1i128 << bits));
    let y = x * &scale;
    let r = if y.is_negative() {
        -((-y) + Rat::new(1.into(), 2.into())).floor()
    } else {
        (y + Rat::new(1.into(), 2.into())).floor()
    };
    r / scale
}

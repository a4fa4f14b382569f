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
use super::Spline;
use crate::exact::{Int, Rat};
use crate::mesh::Mesh;
use bnum::cast::As;
use bnum::types::{I256, I512};
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

/// A dependent's formula: `sum c_j x_j` as `(j, c_j)`.
type Formula = Vec<(usize, Rat)>;

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
    /// The spline's C1 conditions (its quads, in order), checked by
    /// [`recompute_verified`](Self::recompute_verified).
    quads: Vec<Quad>,
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

/// Reduced row echelon form over the rationals, pivots searched in column order among the
/// first `ncand` columns.
fn rref(rows: &mut [Vec<Rat>], ncand: usize) -> Vec<(usize, usize)> {
    let mut pivots = Vec::new();
    let mut r = 0;
    for c in 0..ncand {
        let Some(p) = (r..rows.len()).find(|&i| !rows[i][c].is_zero()) else { continue };
        rows.swap(r, p);
        let inv = rows[r][c].recip();
        // The rows are sparse (a quadrilateral condition has four members): only the pivot
        // row's nonzero entries take part, which leaves every value as the dense loops would.
        let mut nz: Vec<usize> = Vec::new();
        for (j, x) in rows[r].iter_mut().enumerate() {
            if !x.is_zero() {
                *x *= &inv;
                nz.push(j);
            }
        }
        let pivot_row = rows[r].clone();
        for (i, row) in rows.iter_mut().enumerate() {
            if i != r && !row[c].is_zero() {
                let f = row[c].clone();
                for &j in &nz {
                    row[j] -= &f * &pivot_row[j];
                }
            }
        }
        pivots.push((r, c));
        r += 1;
    }
    pivots
}

/// A fixed-width integer for [`rref_fixed`]: the fraction-free step `(p x - a y) / prev`,
/// exact (Bareiss: `prev` divides it), with the products formed in a type twice as wide.
/// The minors of an elimination fit in a width far more often than the products before
/// each division (two minors' product) do.
trait Word: Copy + PartialEq + Send + Sync {
    /// Zero.
    fn zero() -> Self;
    /// One.
    fn one() -> Self;
    /// `(p x - a y) / prev`, or `None` when the division is not exact or the quotient does
    /// not fit.
    fn step(p: Self, x: Self, a: Self, y: Self, prev: Self) -> Option<Self>;
}

impl Word for i128 {
    fn zero() -> Self {
        0
    }
    fn one() -> Self {
        1
    }
    #[inline]
    fn step(p: i128, x: i128, a: i128, y: i128, prev: i128) -> Option<i128> {
        let narrow =
            p.checked_mul(x).and_then(|px| a.checked_mul(y).and_then(|ay| px.checked_sub(ay)));
        if let Some(t) = narrow {
            return if prev == 1 {
                Some(t)
            } else if t % prev != 0 {
                None
            } else {
                Some(t / prev)
            };
        }
        // |p x|, |a y| <= 2^254: neither the products nor their difference overflow.
        let w = |v: i128| -> I256 { v.as_() };
        let t = w(p) * w(x) - w(a) * w(y);
        let q = t.checked_div(w(prev))?;
        if q * w(prev) != t {
            return None;
        }
        i128::try_from(q).ok()
    }
}

impl Word for I256 {
    fn zero() -> Self {
        0i128.as_()
    }
    fn one() -> Self {
        1i128.as_()
    }
    #[inline]
    fn step(p: I256, x: I256, a: I256, y: I256, prev: I256) -> Option<I256> {
        let narrow =
            p.checked_mul(x).and_then(|px| a.checked_mul(y).and_then(|ay| px.checked_sub(ay)));
        if let Some(t) = narrow {
            return if prev == I256::one() {
                Some(t)
            } else {
                let q = t.checked_div(prev)?;
                (q * prev == t).then_some(q)
            };
        }
        // |p x|, |a y| <= 2^510: neither the products nor their difference overflow.
        let w = |v: I256| -> I512 { v.as_() };
        let t = w(p) * w(x) - w(a) * w(y);
        let q = t.checked_div(w(prev))?;
        if q * w(prev) != t {
            return None;
        }
        let narrow: I256 = q.as_();
        (w(narrow) == q).then_some(narrow)
    }
}

/// [`rref`] of an integer matrix by fraction-free Gauss-Jordan elimination: each step
/// replaces every other row by `(p row_i - a_i row_r) / p_prev` (`p` the pivot, `a_i` the
/// row's entry in the pivot column, `p_prev` the previous pivot), an exact division, since
/// every entry is then a minor of the matrix (Bareiss 1968). Pivots are chosen as [`rref`]
/// chooses them (first nonzero row, columns in order among the first `ncand`), and the
/// reduced row echelon form is unique, so dividing each pivot row by its pivot gives
/// exactly [`rref`]'s rows, with integer operations instead of a gcd per operation.
/// Returns the pivots, or `None` when a number does not fit in `W` or a division is not
/// exact (the caller then tries a wider type, then [`rref_big`]); the rows are left as they
/// are then.
fn rref_fixed<W: Word>(rows: &mut [Vec<W>], ncand: usize) -> Option<Vec<(usize, usize)>> {
    let mut pivots = Vec::new();
    let (zero, one) = (W::zero(), W::one());
    let mut prev = one;
    let mut r = 0;
    let mut work: Vec<Vec<W>> = rows.to_vec();
    for c in 0..ncand {
        let Some(p) = (r..work.len()).find(|&i| work[i][c] != zero) else { continue };
        work.swap(r, p);
        let piv = work[r][c];
        let (before, rest) = work.split_at_mut(r);
        let (pivot_row, after) = rest.split_first_mut().expect("row r exists");
        for row in before.iter_mut().chain(after.iter_mut()) {
            let a = row[c];
            for (x, &y) in row.iter_mut().zip(pivot_row.iter()) {
                // The rows are sparse: an entry with x = 0 and a y = 0 stays 0 (t = 0), and
                // the first step divides by 1; both skip the division.
                if *x == zero && (a == zero || y == zero) {
                    continue;
                }
                *x = W::step(piv, *x, a, y, prev)?;
            }
        }
        prev = piv;
        pivots.push((r, c));
        r += 1;
    }
    rows.clone_from_slice(&work);
    Some(pivots)
}

/// [`rref_fixed`] on `i128` entries.
fn rref_int(rows: &mut [Vec<i128>], ncand: usize) -> Option<Vec<(usize, usize)>> {
    rref_fixed(rows, ncand)
}

/// An exact integer from a 256-bit one.
fn int_of_i256(x: I256) -> Int {
    match i128::try_from(x) {
        Ok(v) => Int::from_i128(v),
        Err(_) => Int::from_big(num_bigint::BigInt::from_signed_bytes_le(&x.to_le_bytes())),
    }
}

/// [`rref_int`] in exact integers of any size (the same steps, each division checked):
/// for eliminations whose minors do not fit in `i128`. Returns the pivots, or `None` when a
/// division is not exact (the caller then runs [`rref`]); the rows are then unspecified.
fn rref_big(rows: &mut [Vec<Int>], ncand: usize) -> Option<Vec<(usize, usize)>> {
    let mut pivots = Vec::new();
    let mut prev = Int::from(1);
    let mut r = 0;
    for c in 0..ncand {
        let Some(p) = (r..rows.len()).find(|&i| !rows[i][c].is_zero_int()) else { continue };
        rows.swap(r, p);
        let piv = rows[r][c].clone();
        let (before, rest) = rows.split_at_mut(r);
        let (pivot_row, after) = rest.split_first_mut().expect("row r exists");
        let first = pivots.is_empty();
        for row in before.iter_mut().chain(after.iter_mut()) {
            let a = row[c].clone();
            for (x, y) in row.iter_mut().zip(pivot_row.iter()) {
                if x.is_zero_int() && (a.is_zero_int() || y.is_zero_int()) {
                    continue;
                }
                let t = &(&piv * &*x) - &(&a * y);
                if first {
                    *x = t;
                } else if !(&t % &prev).is_zero_int() {
                    return None;
                } else {
                    *x = t.div_exact(&prev);
                }
            }
        }
        prev = piv;
        pivots.push((r, c));
        r += 1;
    }
    Some(pivots)
}

/// `x / den` in lowest terms (`den != 0`), reduced on the machine words: the same value
/// as `Rat::new`, without a `BigInt` gcd for values above `i64`.
fn rat_i128(x: i128, den: i128) -> Rat {
    let g = super::intform::gcd_u128(x.unsigned_abs(), den.unsigned_abs());
    let (n, d) = (x.unsigned_abs() / g, den.unsigned_abs() / g);
    // Both are below 2^127 unless g = 1 and a value is i128::MIN: then fall back.
    match (i128::try_from(n), i128::try_from(d)) {
        (Ok(n), Ok(d)) => {
            let n = if (x < 0) != (den < 0) { -n } else { n };
            Rat::new_raw(Int::from_i128(n), Int::from_i128(d))
        }
        _ => Rat::new(Int::from_i128(x), Int::from_i128(den)),
    }
}

/// An entry of a reduced row: an exact integer of some width, or a fraction.
trait Entry {
    /// Whether it is zero.
    fn is_zero_entry(&self) -> bool;
    /// `self / den` in lowest terms (`den` nonzero).
    fn ratio(&self, den: &Self) -> Rat;
}

impl Entry for i128 {
    fn is_zero_entry(&self) -> bool {
        *self == 0
    }
    fn ratio(&self, den: &i128) -> Rat {
        rat_i128(*self, *den)
    }
}

impl Entry for I256 {
    fn is_zero_entry(&self) -> bool {
        *self == I256::zero()
    }
    fn ratio(&self, den: &I256) -> Rat {
        match (i128::try_from(*self), i128::try_from(*den)) {
            (Ok(x), Ok(d)) => rat_i128(x, d),
            _ => Rat::new(int_of_i256(*self), int_of_i256(*den)),
        }
    }
}

impl Entry for Int {
    fn is_zero_entry(&self) -> bool {
        self.is_zero_int()
    }
    fn ratio(&self, den: &Int) -> Rat {
        Rat::new(self.clone(), den.clone())
    }
}

impl Entry for Rat {
    fn is_zero_entry(&self) -> bool {
        self.is_zero()
    }
    fn ratio(&self, den: &Rat) -> Rat {
        self / den
    }
}

/// The dependents of a reduced system (rows after [`rref_fixed`], [`rref_big`] or
/// [`rref`]): each pivot `(r, c)` makes `cols[c] = -sum_(j != c) (row_r[j] / row_r[c])
/// all[j]`. `None` when a row without a pivot is not zero (the conditions constrain the
/// parameters: a singular vertex).
fn pivot_formulas<E: Entry>(
    rows: &[Vec<E>],
    pivots: &[(usize, usize)],
    cols: &[usize],
    all: &[usize],
) -> Option<Vec<(usize, Formula)>> {
    for (i, row) in rows.iter().enumerate() {
        if !pivots.iter().any(|&(r, _)| r == i) && row.iter().any(|x| !x.is_zero_entry()) {
            return None;
        }
    }
    Some(
        pivots
            .iter()
            .map(|&(r, c)| {
                let den = &rows[r][c];
                let f: Formula = (0..all.len())
                    .filter(|&j| j != c && !rows[r][j].is_zero_entry())
                    .map(|j| (all[j], -rows[r][j].ratio(den)))
                    .collect();
                (cols[c], f)
            })
            .collect(),
    )
}

/// The fractions of reduced rows: pivot rows divided by their pivot, other rows as they
/// are (the rows [`rref`] gives, for comparing the integer eliminations with it).
#[cfg(test)]
fn rows_to_rat<E: Entry>(rows: &[Vec<E>], pivots: &[(usize, usize)], one: &E) -> Vec<Vec<Rat>> {
    rows.iter()
        .enumerate()
        .map(|(i, row)| {
            let den = pivots.iter().find(|&&(r, _)| r == i).map_or(one, |&(r, c)| &rows[r][c]);
            row.iter().map(|x| if x.is_zero_entry() { Rat::zero() } else { x.ratio(den) }).collect()
        })
        .collect()
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
            quads: s.quads().to_vec(),
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
        self.quads == quads
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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn to_rat(rows: &[Vec<i128>]) -> Vec<Vec<Rat>> {
        rows.iter()
            .map(|r| r.iter().map(|&x| Rat::from_integer(Int::from_i128(x))).collect())
            .collect()
    }

    #[test]
    fn fraction_free_rref_of_a_rank_deficient_matrix_matches_fractions() {
        // Row 3 = row 1 + row 2, and column 1 = 2 * column 0: pivots skip column 1.
        let m = vec![
            vec![2, 4, 1, 0, 3],
            vec![1, 2, 0, 5, -1],
            vec![3, 6, 1, 5, 2],
            vec![0, 0, 7, 1, 1],
        ];
        let mut ints = m.clone();
        let pivots = rref_int(&mut ints, 4).expect("small numbers fit");
        let mut rats = to_rat(&m);
        assert_eq!(pivots, rref(&mut rats, 4));
        assert_eq!(pivots, vec![(0, 0), (1, 2), (2, 3)]);
        assert_eq!(rows_to_rat(&ints, &pivots, &1), rats);
    }

    #[test]
    fn fraction_free_rref_reports_overflow() {
        let big = i128::MAX / 3;
        let mut m = vec![vec![big, 1, 2], vec![3, big, 5]];
        let before = m.clone();
        assert_eq!(rref_int(&mut m, 2), None);
        assert_eq!(m, before, "rows untouched on overflow");
    }

    /// The pivot rows of an exact elimination equal the rational one's (`rats`), and each
    /// other row is zero in both or in neither.
    fn same_reduced_rows(
        got: &[Vec<Rat>],
        rats: &[Vec<Rat>],
        pivots: &[(usize, usize)],
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        for &(r, _) in pivots {
            prop_assert_eq!(&got[r], &rats[r]);
        }
        for i in 0..rats.len() {
            if !pivots.iter().any(|&(r, _)| r == i) {
                let zero_int = got[i].iter().all(|x| x.is_zero());
                let zero_rat = rats[i].iter().all(|x| x.is_zero());
                prop_assert_eq!(zero_int, zero_rat);
            }
        }
        Ok(())
    }

    proptest! {
        /// Random small integer matrices, often rank deficient (rows repeated with a
        /// multiple): the fraction-free elimination gives the same pivots and the same reduced
        /// rows as the elimination in fractions.
        #[test]
        fn fraction_free_rref_equals_rational_rref(
            base in proptest::collection::vec(proptest::collection::vec(-9i64..10, 7), 1..6),
            dup in proptest::option::of((0usize..6, -3i64..4)),
            ncand in 1usize..8,
        ) {
            let mut m: Vec<Vec<i128>> =
                base.iter().map(|r| r.iter().map(|&x| i128::from(x)).collect()).collect();
            if let Some((i, k)) = dup {
                let r: Vec<i128> = m[i % m.len()].iter().map(|&x| x * i128::from(k)).collect();
                m.push(r);
            }
            let mut ints = m.clone();
            let pivots = rref_int(&mut ints, ncand.min(7)).expect("small numbers fit");
            let mut rats = to_rat(&m);
            prop_assert_eq!(&pivots, &rref(&mut rats, ncand.min(7)));
            same_reduced_rows(&rows_to_rat(&ints, &pivots, &1), &rats, &pivots)?;
        }

        /// Matrices whose minors overflow `i128` (entries up to 2^45, as C1 conditions on a
        /// fine snapping grid have): the elimination in exact integers gives the same pivots
        /// and reduced rows as the one in fractions, while the `i128` one gives up.
        #[test]
        fn big_fraction_free_rref_equals_rational_rref(
            base in proptest::collection::vec(proptest::collection::vec(-9i64..10, 7), 2..7),
            scale in proptest::collection::vec(1i64..(1 << 45), 7),
            dup in proptest::option::of((0usize..7, -3i64..4)),
            ncand in 1usize..8,
        ) {
            let mut m: Vec<Vec<i128>> = base
                .iter()
                .map(|r| r.iter().zip(&scale).map(|(&x, &s)| i128::from(x) * i128::from(s) + i128::from(x.signum())).collect())
                .collect();
            if let Some((i, k)) = dup {
                let r: Vec<i128> = m[i % m.len()].iter().map(|&x| x * i128::from(k)).collect();
                m.push(r);
            }
            let ncand = ncand.min(7);
            let mut big: Vec<Vec<Int>> =
                m.iter().map(|r| r.iter().map(|&x| Int::from_i128(x)).collect()).collect();
            let pivots = rref_big(&mut big, ncand).expect("fraction-free divisions are exact");
            let mut rats = to_rat(&m);
            prop_assert_eq!(&pivots, &rref(&mut rats, ncand));
            same_reduced_rows(&rows_to_rat(&big, &pivots, &Int::from(1)), &rats, &pivots)?;
        }
    }

    #[test]
    fn fraction_free_rref_forms_products_beyond_i128_in_256_bits() {
        // Entries near 2^30: the 4 x 4 minors (about 2^122) fit in i128, but the products
        // before each exact division (two minors, about 2^215) do not. The old i128-only step
        // gave up here and sent most ring-2 systems of a fit to big integers.
        let e = 1i128 << 30;
        let m: Vec<Vec<i128>> = (0..4)
            .map(|i| (0..6).map(|j| e + ((i * 7 + j * 13) % 11) * 1_000_003 - 5 * i).collect())
            .collect();
        let mut ints = m.clone();
        let pivots = rref_int(&mut ints, 6).expect("the minors fit in i128");
        let mut rats = to_rat(&m);
        assert_eq!(pivots, rref(&mut rats, 6));
        assert_eq!(rows_to_rat(&ints, &pivots, &1), rats);
        // The last step multiplies the leading 3 x 3 minor by another 3 x 3 minor: beyond
        // i128, so the 256-bit branch was taken.
        let det3 = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        assert!(det3 != 0 && det3.checked_mul(det3).is_none(), "the test must reach 256 bits");
    }

    #[test]
    fn a_step_whose_quotient_exceeds_i128_gives_up() {
        let step = <i128 as Word>::step;
        let big = i128::MAX / 2;
        assert_eq!(step(big, big, 0, 0, 1), None);
        assert_eq!(step(big, big, 0, 0, 3), None, "quotient about 2^250");
        assert_eq!(step(big, 4, 1, 1, 2), None, "not exact: 4 big - 1 is odd");
        assert_eq!(step(big, 4, 2, 2, 2), Some(2 * big - 2));
    }

    #[test]
    fn a_256_bit_step_forms_its_products_in_512_bits() {
        let w = |v: i128| -> I256 { v.as_() };
        let step = <I256 as Word>::step;
        let big = w(i128::MAX) * w(1 << 100); // about 2^227
        assert_eq!(step(big, big, w(0), w(0), w(1)), None, "quotient about 2^454");
        assert_eq!(step(big, w(4), w(2), w(2), w(2)), Some(big * w(2) - w(2)));
        assert_eq!(step(big, big, w(1), big, big), Some(big - w(1)), "products near 2^454");
        assert_eq!(step(big, w(4), w(1), w(1), w(2)), None, "not exact");
    }

    fn w256(v: i128) -> I256 {
        v.as_()
    }

    /// A matrix whose 3 x 3 minors (of 2^44-sized entries, about 2^132) overflow i128 but
    /// fit 256 bits.
    fn minors_beyond_i128() -> Vec<Vec<i128>> {
        let e = 1i128 << 44;
        let m = vec![vec![e + 1, e - 3, 7, 1], vec![e - 5, e + 9, e, 2], vec![3, e + 1, e - 1, 3]];
        assert_eq!(rref_int(&mut m.clone(), 3), None);
        m
    }

    #[test]
    fn minors_beyond_i128_are_eliminated_in_256_bits() {
        let m = minors_beyond_i128();
        let mut wide: Vec<Vec<I256>> =
            m.iter().map(|r| r.iter().map(|&x| x.as_()).collect()).collect();
        let pivots = rref_fixed(&mut wide, 3).expect("the minors fit in 256 bits");
        let mut rats = to_rat(&m);
        assert_eq!(pivots, rref(&mut rats, 3));
        assert_eq!(rows_to_rat(&wide, &pivots, &w256(1)), rats);
        // Values beyond i128 convert exactly, with their sign.
        let x = w256(i128::MIN) * w256(1 << 90) + w256(3);
        let want = num_bigint::BigInt::from(i128::MIN) * (num_bigint::BigInt::from(1) << 90) + 3;
        assert_eq!(int_of_i256(x), Int::from_big(want));
        assert_eq!(int_of_i256(w256(-5)), Int::from(-5));
    }

    proptest! {
        /// Lowest terms on machine words equal `Rat::new`, signs and extremes included.
        #[test]
        fn fractions_reduced_on_words_equal_rat_new(
            x in prop_oneof![any::<i128>(), -1000i128..1000, Just(i128::MIN)],
            den in prop_oneof![any::<i128>(), -1000i128..1000, Just(i128::MIN)],
        ) {
            prop_assume!(x != 0 && den != 0);
            prop_assert_eq!(
                rat_i128(x, den),
                Rat::new(Int::from_i128(x), Int::from_i128(den))
            );
        }
    }

    #[test]
    fn fraction_free_rref_in_big_integers_takes_over_from_i128() {
        let m = minors_beyond_i128();
        let mut big: Vec<Vec<Int>> =
            m.iter().map(|r| r.iter().map(|&x| Int::from_i128(x)).collect()).collect();
        let pivots = rref_big(&mut big, 3).unwrap();
        let mut rats = to_rat(&m);
        assert_eq!(pivots, rref(&mut rats, 3));
        assert_eq!(rows_to_rat(&big, &pivots, &Int::from(1)), rats);
    }
}

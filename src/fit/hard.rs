//! Exact interpolation: landmarks as hard constraints `phi(s_i) = t_i`, solved in the
//! coordinates of a minimal determining set.
//!
//! This is the direct manipulation of the FFD-by-pseudoinverse paper (its sections on point
//! constraints: move points of the deformed object, solve for the control points by a
//! minimum-norm correction), generalized with C1 and made exact. Each landmark gives one
//! affine constraint on the control points of the triangle `T` that holds `s_i`,
//!
//! ```text
//!   sum_{|m|=d} B^d_m(b_i) q_m = t_i,                                        (1)
//! ```
//!
//! with `b_i` the exact rational barycentric coordinates of `s_i` in `T` (mesh vertices are
//! exact, `vertex_int / grid_denominator`). The numbers are the ones written in the landmark
//! file: every coordinate is read back exactly from its `f64` as the shortest round-trip
//! decimal ([`crate::exact::exact_decimal`]); nothing is rounded to a grid. Coordinates with
//! more digits than an `f64` holds are reported by the readers
//! ([`super::landmarks::parse_noted`]).
//!
//! **MDS coordinates.** Every control point is a fixed rational combination of the free
//! points `x` of the spline's minimal determining set ([`crate::spline::mds`], Lai &
//! Schumaker ch. 5; the `Role::Dependent` formulas applied in evaluation order), and *any*
//! values of `x` give an exactly C1 spline. Substituting these combinations into (1) gives a
//! row `a_i . x = t_i` over free points only (no C1 rows are needed: C1 holds by
//! construction). This replaces the earlier ECLES formulation (thesis ch. 2, `R p = q`, the
//! landmark rows stacked onto every C1 condition), whose exact eliminations over a growing
//! neighbourhood made 100 landmarks take half a minute and grew huge rationals.
//! **Pinned points** ([`FitOptions::pinned`]) add rows too: a pinned dependent is the row
//! of its own combination equal to its input value; a pinned free point is simply fixed.
//! Without `hard` only the pinned rows are used.
//!
//! **The solve** ([`super::hard_solve`]) starts from the soft fit ([`super::solve`]), whose
//! free points lie on the `2^-grid_bits` grid. Let `A` be the rows over the variable free
//! points (free points in the rows' support, not pinned; every other point keeps its soft
//! value) and `r = b - A h` the residual at the soft values `h`:
//!
//! 1. the minimum-norm correction `dx = A^T (A A^T)^-1 r` (the weighted least-squares
//!    solution nearest `h` with unit weights) is computed in `f64` and `h + dx` rounded to
//!    the grid; this is within one grid step of the nearest exact solution;
//! 2. the rounded values miss (1) by about `2^-grid_bits`; one pivot free point per row
//!    (chosen among the row's largest coefficients, preferring points few other rows use)
//!    absorbs that residual exactly: the rows split into small groups coupled through their
//!    pivots, each solved by exact Gaussian elimination. A group whose pivots are dependent
//!    is re-solved by an exact row reduction over all the free points only its rows use,
//!    growing to neighbouring groups if needed.
//!
//! So only one free point per constraint carries a non-grid value, denominators stay those
//! of the landmark's decimals times the Bernstein weights, and the output file keeps the
//! soft fit's size order. The result is checked exactly against (1) and against the pins in
//! control-point space, and [`Spline::from_points`] checks every C1 condition exactly.
//!
//! **Diagnostics.** One source with two targets is refused naming both landmarks
//! ([`FitError::Conflicting`]). A triangle holding more landmarks than a degree-`d`
//! polynomial has coefficients (`(d+1)(d+2)/2`), or rows that stay dependent after the
//! grown reduction, give [`FitError::TooManyConstraints`], naming the landmarks involved.

use super::error::FitError;
use super::hard_solve::{solve_rows, Row, Unmet, MAX_GROUP};
use super::landmarks::Landmark;
use super::options::{Bend, FitOptions};
use super::report::{ExactStep, Fit, FitMethod};
use super::solve::fit_soft;
use crate::exact::{exact_decimal, rat_to_f64, Int, Rat};
use crate::spline::layout::{local_index, multi_indices};
use crate::spline::mds::{Mds, Role};
use crate::spline::Spline;
use num_integer::Integer;
use num_traits::{One, Signed, Zero};
use std::collections::HashMap;
use std::time::Instant;

/// Exact weights over control points.
type WeightRow = Vec<(usize, Rat)>;

/// An integer constraint row over control points and its integer-scaled target.
pub type ExactRow = (Vec<(usize, Int)>, [Rat; 2]);

/// The exact source and target of a landmark, as written in its file (see the module docs).
pub fn exact_landmark(l: &Landmark) -> ([Rat; 2], [Rat; 2]) {
    let e = |v: f64| exact_decimal(v).expect("validated finite");
    ([e(l.src[0]), e(l.src[1])], [e(l.dst[0]), e(l.dst[1])])
}

/// Exact barycentric coordinates of `p` in triangle `t`.
pub fn barycentric_exact(s: &Spline, t: usize, p: &[Rat; 2]) -> [Rat; 3] {
    let mesh = s.mesh();
    let den = Rat::from_integer(Int::from(mesh.grid_denominator()));
    let v: Vec<[Rat; 2]> = mesh
        .triangle(t)
        .iter()
        .map(|&i| {
            let c = mesh.vertex_int(i);
            [Rat::from_integer(Int::from(c[0])) / &den, Rat::from_integer(Int::from(c[1])) / &den]
        })
        .collect();
    let cross = |a: &[Rat; 2], b: &[Rat; 2], c: &[Rat; 2]| {
        (&b[0] - &a[0]) * (&c[1] - &a[1]) - (&c[0] - &a[0]) * (&b[1] - &a[1])
    };
    let area = cross(&v[0], &v[1], &v[2]);
    [cross(p, &v[1], &v[2]) / &area, cross(&v[0], p, &v[2]) / &area, cross(&v[0], &v[1], p) / &area]
}

/// The triangle holding the exact point `p` and its exact barycentric coordinates there (all
/// `>= 0`), or `None` outside the mesh. `locate`'s floating tolerance may answer a
/// neighbour for a point on an edge; the triangles around that answer are then tried.
pub fn locate_exact(s: &Spline, p: &[Rat; 2]) -> Option<(usize, [Rat; 3])> {
    let (t, _) = s.mesh().locate([rat_to_f64(&p[0]), rat_to_f64(&p[1])], None)?;
    let inside = |t: usize| {
        let b = barycentric_exact(s, t, p);
        (!b.iter().any(Signed::is_negative)).then_some((t, b))
    };
    inside(t).or_else(|| {
        s.mesh()
            .triangle(t)
            .iter()
            .flat_map(|&v| s.mesh().vertex_triangles(v).iter().copied())
            .find_map(inside)
    })
}

/// The exact Bernstein weights `B^d_m(b)` of triangle `t` at barycentric `b`, as
/// `(control point, weight)` pairs with non-zero weight.
pub fn bernstein_row(s: &Spline, t: usize, b: &[Rat; 3]) -> Vec<(usize, Rat)> {
    let d = s.degree();
    let patch = &s.layout().patches()[t];
    let fact = |n: usize| (1..=n).fold(Int::one(), |a, k| a * Int::from(k as i64));
    let pows: Vec<Vec<Rat>> = b
        .iter()
        .map(|x| {
            let mut p = vec![Rat::one()];
            for k in 0..d {
                let next = &p[k] * x;
                p.push(next);
            }
            p
        })
        .collect();
    let mut out = Vec::new();
    for m in multi_indices(d) {
        let w = Rat::new(fact(d), fact(m[0]) * fact(m[1]) * fact(m[2]))
            * &pows[0][m[0]]
            * &pows[1][m[1]]
            * &pows[2][m[2]];
        if !w.is_zero() {
            out.push((patch[local_index(d, m[0], m[1])], w));
        }
    }
    out
}

/// The exact constraint row of one landmark: integer coefficients over control points and
/// the integer-scaled target (the row (1) times the common denominator of its weights).
/// `None` when the source lies outside the mesh.
pub fn landmark_row(s: &Spline, l: &Landmark) -> Option<ExactRow> {
    let (src, dst) = exact_landmark(l);
    let (t, b) = locate_exact(s, &src)?;
    let coefs = bernstein_row(s, t, &b);
    let lcm = coefs.iter().fold(Int::one(), |a, (_, w)| a.lcm(w.denom()));
    let scale = Rat::from_integer(lcm);
    let row = coefs.iter().map(|(p, w)| (*p, (w * &scale).to_integer())).collect();
    let [x, y] = dst;
    Some((row, [x * &scale, y * &scale]))
}

/// Control points written over the free points of a determining set (memoized).
pub struct FreeExpansion<'a> {
    mds: &'a Mds,
    memo: HashMap<usize, Vec<(usize, Rat)>>,
}

impl<'a> FreeExpansion<'a> {
    /// An empty expansion cache for `mds`.
    pub fn new(mds: &'a Mds) -> Self {
        FreeExpansion { mds, memo: HashMap::new() }
    }

    /// Control point `p` as `sum c_j x_j` over free points `x_j` (sorted by point).
    pub fn of(&mut self, p: usize) -> Vec<(usize, Rat)> {
        if let Some(v) = self.memo.get(&p) {
            return v.clone();
        }
        let v = match self.mds.role(p) {
            Role::Free => vec![(p, Rat::one())],
            Role::Dependent(f) => {
                let terms: Vec<(usize, Rat)> = f
                    .iter()
                    .flat_map(|(j, c)| {
                        self.of(*j).into_iter().map(move |(k, a)| (k, a * c)).collect::<Vec<_>>()
                    })
                    .collect();
                combine(terms)
            }
        };
        self.memo.insert(p, v.clone());
        v
    }

    /// `sum w_p P_p` over control points as a combination of free points.
    pub fn combination(&mut self, row: &[(usize, Rat)]) -> Vec<(usize, Rat)> {
        let terms: Vec<(usize, Rat)> = row
            .iter()
            .flat_map(|(p, w)| self.of(*p).into_iter().map(|(k, a)| (k, a * w)).collect::<Vec<_>>())
            .collect();
        combine(terms)
    }
}

/// Sums the coefficients of equal points, drops zeros, sorts by point.
fn combine(mut terms: Vec<(usize, Rat)>) -> Vec<(usize, Rat)> {
    terms.sort_by_key(|t| t.0);
    let mut out: Vec<(usize, Rat)> = Vec::with_capacity(terms.len());
    for (k, a) in terms {
        match out.last_mut() {
            Some((j, b)) if *j == k => *b += a,
            _ => out.push((k, a)),
        }
    }
    out.retain(|(_, a)| !a.is_zero());
    out
}

fn label(l: &Landmark) -> String {
    l.name.clone().unwrap_or_else(|| "-".into())
}

/// `landmark i (name)` for messages.
fn landmark_text(lms: &[Landmark], i: usize) -> String {
    format!("landmark {i} ({})", label(&lms[i]))
}

/// The error for constraints that cannot hold together (see the module docs).
fn too_many(s: &Spline, detail: String) -> FitError {
    let d = s.degree();
    FitError::TooManyConstraints { detail, degree: d, per_triangle: (d + 1) * (d + 2) / 2 }
}

/// What a constraint row stands for.
#[derive(Clone, Copy, Debug)]
enum Source {
    Landmark(usize),
    Pinned(usize),
}

/// The hard fit; see the module docs.
pub(super) fn fit_hard(
    s: &Spline,
    mds: &Mds,
    lms: &[Landmark],
    opts: &FitOptions,
    start: Instant,
) -> Result<Fit, FitError> {
    // The exact step corrects the soft fit landmark by landmark, so the soft fit should aim
    // at the targets: with hard landmarks, `Bend::Auto` (which may smooth far away from them)
    // means the interpolating weight. (The earlier `DEFAULT_BEND` left up to 1.8 px for the
    // exact step, which folded tiny triangles between close landmarks.)
    let soft_opts = match opts.bend {
        Bend::Auto if opts.hard => {
            FitOptions { bend: Bend::Weight(super::smooth::INTERPOLATING_BEND), ..opts.clone() }
        }
        _ => opts.clone(),
    };
    let soft = fit_soft(s, mds, lms, &soft_opts, start)?;
    let spline = exact_constraints(s, mds, &soft.spline, lms, opts)?;
    let exact = if opts.hard { ExactStep::Hard } else { ExactStep::Pinned };
    let mut rep = super::report::build(
        &spline,
        lms,
        opts,
        FitMethod { exact: Some(exact), ..soft.report.method },
        soft.report.variables / 2,
        soft.report.iterations,
        soft.report.cost_initial,
        soft.report.cost_final,
        start,
    )?;
    rep.bend = soft.report.bend;
    rep.bend_auto = soft.report.bend_auto;
    rep.gcv_rms = soft.report.gcv_rms;
    rep.loo_rms = soft.report.loo_rms;
    rep.bend_criterion = soft.report.bend_criterion;
    rep.termination = soft.report.termination;
    rep.conflicts = soft.report.conflicts.clone();
    rep.time_ms = start.elapsed().as_secs_f64() * 1e3;
    Ok(Fit { spline, report: rep })
}

/// The exact step of the hard fit (module docs) on its own: from `soft` (a spline over
/// `s`'s mesh whose free points lie on the `2^-opts.grid_bits` grid), the spline with every
/// landmark met exactly (when `opts.hard`) and every pinned control point
/// ([`FitOptions::pinned`]) at its value in `s`, changing as few free points as the rows
/// need. Checked exactly; C1 exactly by [`Spline::with_points`]. Also used by image
/// registration ([`crate::register`]) after its own soft solve.
pub fn exact_constraints(
    s: &Spline,
    mds: &Mds,
    soft: &Spline,
    lms: &[Landmark],
    opts: &FitOptions,
) -> Result<Spline, FitError> {
    let n = s.num_points();
    let mut values: Vec<Vec<Rat>> = soft.points().to_vec();
    for p in opts.pinned.iter().map(|p| p.index()) {
        values[p] = s.points()[p].clone();
    }
    // Exact landmark rows over control points (in control-point space, for the final check).
    let mut checks: Vec<(WeightRow, [Rat; 2])> = Vec::new();
    let mut sources: Vec<Source> = Vec::new();
    if opts.hard {
        let mut seen: HashMap<[Rat; 2], (usize, [Rat; 2])> = HashMap::new();
        let mut per_triangle: HashMap<usize, Vec<usize>> = HashMap::new();
        for (index, l) in lms.iter().enumerate() {
            let (src, dst) = exact_landmark(l);
            if let Some((first, t0)) = seen.get(&src) {
                if *t0 != dst {
                    return Err(FitError::Conflicting {
                        first: landmark_text(lms, *first),
                        second: landmark_text(lms, index),
                        x: l.src[0],
                        y: l.src[1],
                    });
                }
                continue; // the same constraint twice
            }
            seen.insert(src.clone(), (index, dst.clone()));
            let (t, b) = locate_exact(s, &src).ok_or(FitError::OutsideMesh {
                index,
                name: label(l),
                x: l.src[0],
                y: l.src[1],
            })?;
            per_triangle.entry(t).or_default().push(index);
            checks.push((bernstein_row(s, t, &b), dst));
            sources.push(Source::Landmark(index));
        }
        let d = s.degree();
        let cap = (d + 1) * (d + 2) / 2;
        let mut crowded: Vec<(usize, Vec<usize>)> =
            per_triangle.into_iter().filter(|(_, v)| v.len() > cap).collect();
        crowded.sort();
        if let Some((t, members)) = crowded.first() {
            let names: Vec<String> =
                members.iter().take(4).map(|&i| landmark_text(lms, i)).collect();
            return Err(too_many(
                s,
                format!(
                    "triangle {t} holds {} landmarks ({}{}){}",
                    members.len(),
                    names.join(", "),
                    if members.len() > 4 { ", ..." } else { "" },
                    if crowded.len() > 1 {
                        format!(" and {} more triangles hold more than {cap}", crowded.len() - 1)
                    } else {
                        String::new()
                    }
                ),
            ));
        }
    }
    let mut expand = FreeExpansion::new(mds);
    let mut rows: Vec<Row> = Vec::new();
    for (row, dst) in &checks {
        rows.push(Row { coefs: expand.combination(row), rhs: dst.clone() });
    }
    let mut is_pinned = vec![false; n];
    let mut pinned: Vec<usize> = opts.pinned.iter().map(|p| p.index()).collect();
    for &p in &pinned {
        is_pinned[p] = true;
    }
    pinned.sort_unstable();
    pinned.dedup();
    for &p in &pinned {
        if matches!(mds.role(p), Role::Dependent(_)) {
            let v = &s.points()[p];
            rows.push(Row { coefs: expand.of(p), rhs: [v[0].clone(), v[1].clone()] });
            sources.push(Source::Pinned(p));
        }
    }
    let is_var: Vec<bool> =
        (0..n).map(|p| !is_pinned[p] && matches!(mds.role(p), Role::Free)).collect();
    // A landmark that no variable point moves is met already or never (not a matter of
    // too many constraints: its control points are all pinned).
    for (k, row) in rows.iter().enumerate().take(checks.len()) {
        if row.coefs.iter().any(|(p, _)| is_var[*p]) {
            continue;
        }
        let at: Vec<Rat> = (0..2)
            .map(|c| row.coefs.iter().fold(Rat::zero(), |a, (p, w)| a + w * &values[*p][c]))
            .collect();
        if at[..] != row.rhs[..] {
            let Source::Landmark(i) = sources[k] else { unreachable!("landmarks first") };
            return Err(FitError::PinnedAway {
                landmark: landmark_text(lms, i),
                x: lms[i].dst[0],
                y: lms[i].dst[1],
                at_x: rat_to_f64(&at[0]),
                at_y: rat_to_f64(&at[1]),
            });
        }
    }
    solve_rows(&rows, &mut values, &is_var, opts.grid_bits).map_err(|unmet| {
        let (bad, coupled) = match unmet {
            Unmet::Dependent(b) => (b, false),
            Unmet::Coupled(b) => (b, true),
        };
        let mut lm: Vec<String> = Vec::new();
        let mut pins: Vec<usize> = Vec::new();
        for &r in &bad {
            match sources[r] {
                Source::Landmark(i) => lm.push(landmark_text(lms, i)),
                Source::Pinned(p) => pins.push(p),
            }
        }
        let shown = lm.len().min(6);
        let what = if coupled {
            format!(
                "are coupled through shared control points into one group of {} (more than {MAX_GROUP} at once; the landmarks are too dense for this mesh)",
                bad.len()
            )
        } else {
            "cannot hold together".to_string()
        };
        let mut detail = format!(
            "the constraints of {}{} {what}",
            lm[..shown].join(", "),
            if lm.len() > shown {
                format!(" and {} more landmarks", lm.len() - shown)
            } else {
                String::new()
            }
        );
        if !pins.is_empty() {
            let p: Vec<String> = pins.iter().map(|p| p.to_string()).collect();
            detail += &format!(" with pinned control points {}", p.join(", "));
        }
        too_many(s, detail)
    })?;
    let all = vec![true; n];
    mds.recompute(&mut values, &all);
    // Exact checks in control-point space: phi(s_i) = t_i and the pins.
    for (k, (row, dst)) in checks.iter().enumerate() {
        for (c, target) in dst.iter().enumerate() {
            let got = row.iter().fold(Rat::zero(), |a, (p, w)| a + w * &values[*p][c]);
            if got != *target {
                let Source::Landmark(i) = sources[k] else { unreachable!("landmarks first") };
                return Err(FitError::Internal(format!(
                    "{} is not met exactly after the exact solve",
                    landmark_text(lms, i)
                )));
            }
        }
    }
    if let Some(p) = opts.pinned.iter().find(|p| values[p.index()] != s.points()[p.index()]) {
        return Err(FitError::Internal(format!("pinned control point {p} moved in the solve")));
    }
    // `with_points` checks every C1 condition exactly, as `from_points` did, and keeps the
    // spline's z layers and recorded frame (a hard fit over `--size` lost its frame).
    Ok(s.with_points(values)?)
}

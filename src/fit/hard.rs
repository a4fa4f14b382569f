//! Exact interpolation: landmarks as hard constraints `phi(s_i) = t_i` through ECLES.
//!
//! This is the direct manipulation of the FFD-by-pseudoinverse paper (its sections on point
//! constraints: move points of the deformed object, solve for the control points by a
//! minimum-norm correction), generalized with C1 and made exact. Each landmark gives one
//! affine constraint on the control points of the triangle that holds `s_i`,
//!
//! ```text
//!   sum_{|m|=d} B^d_m(b_i) q_m = t_i,
//! ```
//!
//! with `b_i` the exact rational barycentric coordinates of `s_i` (sources are first rounded
//! to multiples of 2^-8 px and targets to 2^-20 px, so the numbers stay small). Scaled to
//! integers, these rows join the C1 conditions in one ECLES system (thesis ch. 2: `R p = q`
//! with a non-zero `q` this time).
//!
//! The soft fit ([`super::solve`]) gives hints for every control point. ECLES then keeps
//! every point outside a neighbourhood of the landmarks' triangles fixed, anchors one corner
//! point far from the landmarks at its value (ECLES edits need an anchor), and moves the
//! derived points in the neighbourhood to the exact solution nearest the hints (Alg. 4-5,
//! weighted least squares). If the edit is not solvable the neighbourhood grows (radius 3,
//! 6, then everything); if it is still not solvable the landmarks contradict each other
//! (e.g. one source sent to two targets) and the fit fails with ECLES's reason.
//!
//! **Pinned points** ([`FitOptions::pinned`], e.g. control points corrected by hand in the
//! editor) replace that single anchor: they are the ECLES anchors, held at their values in
//! the input spline, and the neighbourhood grows from them as well as from the landmarks.
//! Without `hard` the landmark rows are left out and only the pins are exact.

use super::landmarks::Landmark;
use super::solve::{fit_soft, report, Fit, FitError, FitOptions};
use crate::ecles::{ConstraintSystem, EclesError, InitOptions};
use crate::edit::select::{neighborhood, Neighborhood, SelectIndex};
use crate::exact::{Int, Rat};
use crate::spline::layout::{local_index, multi_indices};
use crate::spline::mds::round_to_grid;
use crate::spline::Spline;
use num_integer::Integer;
use num_traits::{One, Zero};
use std::time::Instant;

/// Bits of the source grid (sources are rounded to multiples of `2^-SRC_BITS`).
pub const SRC_BITS: u32 = 8;
/// Bits of the target grid.
pub const DST_BITS: u32 = 20;

fn exact(v: f64, bits: u32) -> Rat {
    round_to_grid(&crate::exact::rat_from_f64(v).expect("validated finite"), bits)
}

/// An integer constraint row over control points and its integer-scaled target.
pub type ExactRow = (Vec<(usize, Int)>, [Rat; 2]);

/// The exact constraint row of one landmark: integer coefficients over control points and
/// the integer-scaled target. `None` when the source lies outside the mesh.
pub fn landmark_row(s: &Spline, l: &Landmark) -> Option<ExactRow> {
    let src = [exact(l.src[0], SRC_BITS), exact(l.src[1], SRC_BITS)];
    let (t, _) = s
        .mesh()
        .locate([crate::exact::rat_to_f64(&src[0]), crate::exact::rat_to_f64(&src[1])], None)?;
    let den = Rat::from_integer(Int::from(s.mesh().grid_denominator()));
    let v: Vec<[Rat; 2]> = s
        .mesh()
        .triangle(t)
        .iter()
        .map(|&i| {
            let c = s.mesh().vertex_int(i);
            [Rat::from_integer(Int::from(c[0])) / &den, Rat::from_integer(Int::from(c[1])) / &den]
        })
        .collect();
    let cross = |a: &[Rat; 2], b: &[Rat; 2], c: &[Rat; 2]| {
        (&b[0] - &a[0]) * (&c[1] - &a[1]) - (&c[0] - &a[0]) * (&b[1] - &a[1])
    };
    let area = cross(&v[0], &v[1], &v[2]);
    let b = [
        cross(&src, &v[1], &v[2]) / &area,
        cross(&v[0], &src, &v[2]) / &area,
        cross(&v[0], &v[1], &src) / &area,
    ];
    if b.iter().any(|x| x < &Rat::zero()) {
        // locate's floating tolerance put the snapped source just outside; refuse rather
        // than extrapolate.
        return None;
    }
    let d = s.degree();
    let patch = &s.layout().patches()[t];
    let fact = |n: usize| (1..=n).fold(Int::one(), |a, k| a * Int::from(k as i64));
    let mut coefs: Vec<(usize, Rat)> = Vec::new();
    for m in multi_indices(d) {
        let multi = Rat::new(fact(d), fact(m[0]) * fact(m[1]) * fact(m[2]));
        let mut w = multi;
        for c in 0..3 {
            for _ in 0..m[c] {
                w *= &b[c];
            }
        }
        if !w.is_zero() {
            coefs.push((patch[local_index(d, m[0], m[1])], w));
        }
    }
    let lcm = coefs.iter().fold(Int::one(), |a, (_, w)| a.lcm(w.denom()));
    let scale = Rat::from_integer(lcm.clone());
    let row = coefs.iter().map(|(p, w)| (*p, (w * &scale).to_integer())).collect();
    let tgt = [exact(l.dst[0], DST_BITS) * &scale, exact(l.dst[1], DST_BITS) * &scale];
    Some((row, tgt))
}

/// The hard fit; see the module docs.
pub(super) fn fit_hard(
    s: &Spline,
    lms: &[Landmark],
    opts: &FitOptions,
    start: Instant,
) -> Result<Fit, FitError> {
    let soft = fit_soft(s, lms, opts, start)?;
    let hint = &soft.spline;
    let n = s.num_points();
    let mut is_pinned = vec![false; n];
    for &p in &opts.pinned {
        is_pinned[p] = true;
    }
    let c1 = s.c1_matrix();
    let mut rows: Vec<Vec<(usize, Int)>> = (0..c1.rows()).map(|i| c1.row(i).to_vec()).collect();
    let mut q: Vec<Vec<Rat>> = vec![vec![Rat::zero(); 2]; c1.rows()];
    let mut seeds: Vec<usize> = Vec::new();
    for (index, l) in lms.iter().enumerate() {
        let (row, tgt) = landmark_row(s, l).ok_or(FitError::OutsideMesh {
            index,
            name: l.name.clone().unwrap_or_else(|| "-".into()),
            x: l.src[0],
            y: l.src[1],
        })?;
        seeds.extend(row.iter().map(|(p, _)| *p));
        if opts.hard {
            rows.push(row);
            q.push(tgt.to_vec());
        }
    }
    seeds.extend(&opts.pinned);
    seeds.sort_unstable();
    seeds.dedup();
    let r = crate::exact::SparseIntMatrix::from_rows(n, rows)
        .map_err(|e| FitError::Unsolvable(e.to_string()))?;
    let sys = ConstraintSystem::new(r, q).map_err(|e| FitError::Unsolvable(e.to_string()))?;
    // The anchor: the vertex corner point farthest from every landmark source.
    let anchor = (0..s.mesh().num_vertices())
        .max_by(|&a, &b| {
            let dist = |v: usize| {
                let p = s.mesh().vertex(v);
                lms.iter()
                    .map(|l| (p[0] - l.src[0]).hypot(p[1] - l.src[1]))
                    .fold(f64::INFINITY, f64::min)
            };
            dist(a).total_cmp(&dist(b))
        })
        .expect("a mesh has vertices");
    // Vertex v's corner point has index v (corner points come first in the layout).
    // Pinned points, if any, are the anchors instead, at their input values.
    let anchors: Vec<usize> =
        if opts.pinned.is_empty() { vec![anchor] } else { opts.pinned.clone() };
    let idx = SelectIndex::new(s);
    let mut values = hint.points().to_vec();
    for &p in &opts.pinned {
        values[p] = s.points()[p].clone();
    }
    let mut last_err = None;
    for hood in [Neighborhood::Radius(3), Neighborhood::Radius(6), Neighborhood::All] {
        let mut in_d = vec![false; n];
        for p in seeds.iter().copied().chain(neighborhood(&idx, &seeds, &hood)) {
            in_d[p] = true;
        }
        let derived: Vec<usize> =
            (0..n).filter(|&p| in_d[p] && !is_pinned[p] && p != anchors[0]).collect();
        let mut session = match sys.initialize(&values, &anchors, &derived, InitOptions::default())
        {
            Ok(x) => x,
            Err(e) => {
                last_err = Some(e);
                continue;
            }
        };
        let hints: Vec<Vec<Rat>> = derived.iter().map(|&p| values[p].clone()).collect();
        let anchor_values: Vec<Vec<Rat>> = anchors.iter().map(|&p| values[p].clone()).collect();
        match session.update(&anchor_values, Some(&hints), None) {
            Ok(()) => {
                let mut pts = values.clone();
                session.write_into(&mut pts);
                if !sys.is_satisfied(&pts) {
                    return Err(FitError::Unsolvable("exact check failed".into()));
                }
                let spline =
                    Spline::from_points(s.mesh().clone(), s.degree(), pts, s.z_layers().cloned())?;
                let mut rep = report(
                    &spline,
                    lms,
                    opts,
                    format!("{}+{}", soft.report.method, if opts.hard { "hard" } else { "pinned" }),
                    soft.report.variables / 2,
                    soft.report.iterations,
                    soft.report.cost_initial,
                    soft.report.cost_final,
                    start,
                )?;
                rep.time_ms = start.elapsed().as_secs_f64() * 1e3;
                return Ok(Fit { spline, report: rep });
            }
            Err(e) => last_err = Some(e),
        }
    }
    Err(FitError::Unsolvable(match last_err {
        Some(EclesError::NotWeaklySolvable { constraint, .. }) if constraint >= c1.rows() => {
            let i = constraint - c1.rows();
            format!(
                "landmark {i} ({}) conflicts with the others or with C1",
                lms[i].name.clone().unwrap_or_else(|| "-".into())
            )
        }
        Some(e) => e.to_string(),
        None => "no neighbourhood was solvable".into(),
    }))
}

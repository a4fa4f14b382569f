//! Large selections on ECLES's modular path (issue 24, point 4).
//!
//! A selection whose relevant conditions times derived points `|E| x |D|` reach
//! [`Editor::set_modular_path`]'s threshold (by default
//! [`crate::ecles::problem::MODULAR_MIN_ENTRIES`], the same as `trimorph solve`'s `"auto"`)
//! is initialized by [`ConstraintSystem::plan_modular`] instead of the fraction-free LDU of
//! [`ConstraintSystem::initialize`] (thesis Alg. 1): a basis of the rows of `R_ED` certified
//! with exact dependency certificates gives the rank, the redundant conditions and the strong
//! solvability test (eqs. 8.15-8.16), so the growth of `D` in 2DSD.Select runs as before.
//! Each operation (translate, rotate, scale) is then one [`ModularPlan::update`] (Alg. 4 and
//! 15): weak solvability by the certificates, the weighted least-squares solution by Dixon
//! lifting with rational reconstruction, verified exactly. The minimizer is unique, so the
//! values are the sessions' values exactly (tests: `edit::modular_tests`).
//!
//! The fraction-free LDU costs about the cube of the selection and keeps its factors for
//! cheap repeated updates; the modular plan costs far less to build and a certified solve per
//! operation. That suits the large selections (`"neighborhood": "all"` in the editor, `trimorph
//! edit --unbounded`), where the LDU took minutes. When no prime certifies a plan or an
//! operation, the selection falls back to sessions, so an answer is never reported exact
//! without proof.

use super::{axis_system_params, EditError, Editor, Mode};
use crate::ecles::modular::{ModularEdit, ModularPlan};
use crate::ecles::{ConstraintSystem, EclesError, InitOptions, Session};
use crate::exact::matrix::{Rat, ScaledVec};
use num_traits::One;
use rayon::prelude::*;
use std::sync::Arc;

/// One solver per system (one system, or the x and y systems under extra constraints).
pub(super) enum Solvers {
    /// Fraction-free ECLES sessions.
    Ldu(Vec<Session>),
    /// Modular plans.
    Modular(Vec<Arc<ModularPlan>>),
}

/// The exact values (unreduced) and their `f64` of the derived points, one row per point.
type Values = (Vec<Vec<Rat>>, Vec<Vec<f64>>);

/// A translation preview `(p0, gx, gy)`: `p(v) = p0 + v_x gx + v_y gy`, coordinates
/// interleaved (x, y per derived point).
type PreviewBasis = (Vec<f64>, Vec<f64>, Vec<f64>);

impl Editor {
    /// Whether a selection of `derived` points with these anchors runs on the modular path.
    fn modular_applies(
        &self,
        sys: &ConstraintSystem,
        anchors: &[usize],
        derived: &[usize],
    ) -> bool {
        self.modular_min.is_some_and(|min| {
            let (e, _) = sys.extract_relevant(anchors, derived);
            e.len() * derived.len() >= min
        })
    }

    /// ECLES Initialize on every system, with or without the strong solvability check;
    /// on failure, the index of the system that failed and its error.
    pub(super) fn start(
        &self,
        systems: &[(&ConstraintSystem, &[Vec<Rat>])],
        anchors: &[usize],
        derived: &[usize],
        strong: bool,
    ) -> Result<Solvers, (usize, EclesError)> {
        let mut uncertified = false;
        if self.modular_applies(systems[0].0, anchors, derived) {
            let mut plans = Vec::with_capacity(systems.len());
            for (k, (sys, p)) in systems.iter().enumerate() {
                match sys.plan_modular(p, anchors, derived, strong) {
                    Ok(Some(plan)) => plans.push(Arc::new(plan)),
                    Ok(None) => break, // not certified: sessions below
                    Err(e) => return Err((k, e)),
                }
            }
            if plans.len() == systems.len() {
                return Ok(Solvers::Modular(plans));
            }
            uncertified = true;
        }
        let opts = InitOptions { strong, ..Default::default() };
        let mut sessions = Vec::with_capacity(systems.len());
        for (k, (sys, p)) in systems.iter().enumerate() {
            match sys.initialize(p, anchors, derived, opts) {
                Ok(s) => sessions.push(s),
                Err(EclesError::NotStronglySolvable { constraint, cause }) => {
                    // The LDU names a failing condition in its pivot order; with the modular
                    // path on, the growth of D takes the canonical one, as the modular path
                    // names it, so that both paths grow D alike (the same selection). Not
                    // when no prime certified the basis just above.
                    let own = EclesError::NotStronglySolvable { constraint, cause };
                    if self.modular_min.is_none() || uncertified {
                        return Err((k, own));
                    }
                    let canonical = match sys.plan_modular(p, anchors, derived, true) {
                        Err(e @ EclesError::NotStronglySolvable { .. }) => e,
                        _ => own,
                    };
                    return Err((k, canonical));
                }
                Err(e) => return Err((k, e)),
            }
        }
        Ok(Solvers::Ldu(sessions))
    }

    /// Replaces the selection's modular plans by fraction-free sessions of the same edit
    /// (when an operation could not be certified). Initialization only reads the fixed
    /// points, which no operation of the selection moves.
    pub(super) fn fall_back_to_sessions(&mut self) -> Result<(), EditError> {
        let sel = self.selection.as_ref().ok_or(EditError::NoSelection)?;
        let anchors: Vec<usize> = sel.anchors.iter().map(|p| p.index()).collect();
        let derived: Vec<usize> = sel.derived.iter().map(|p| p.index()).collect();
        let opts = InitOptions { strong: sel.strong, ..Default::default() };
        let params = match sel.mode {
            Mode::Xy => self.spline.points().to_vec(),
            mode => self.z_params(mode)?,
        };
        let sessions = if sel.plans.len() == 2 {
            let [x, y] = self.axis_sys.as_ref().expect("built when the selection split");
            let cols = axis_system_params(&params);
            vec![
                x.initialize(&cols[0], &anchors, &derived, opts)?,
                y.initialize(&cols[1], &anchors, &derived, opts)?,
            ]
        } else {
            let sys = if sel.mode == Mode::Xy { self.spline.system() } else { &self.zsys };
            vec![sys.initialize(&params, &anchors, &derived, opts)?]
        };
        let sel = self.selection.as_mut().expect("checked above");
        sel.sessions = sessions;
        sel.plans.clear();
        Ok(())
    }
}

/// One operation on the modular plans: the derived values for these anchor values and
/// hints (unit weights, as the sessions' updates), or `None` when a solve could not be
/// certified. Nothing is kept, so a failed operation changes nothing.
pub(super) fn values(
    plans: &[Arc<ModularPlan>],
    anchors: &[Vec<Rat>],
    hints: &[Vec<Rat>],
) -> Result<Option<Values>, EditError> {
    let ones = vec![Rat::one(); hints.len()];
    let edits: Vec<ModularEdit> = if plans.len() == 1 {
        match plans[0].update(anchors, hints, &ones)? {
            Some(e) => vec![e],
            None => return Ok(None),
        }
    } else {
        // x and y separately, one coordinate each.
        let mut edits = Vec::with_capacity(plans.len());
        for (a, plan) in plans.iter().enumerate() {
            let av: Vec<Vec<Rat>> = anchors.iter().map(|r| vec![r[a].clone()]).collect();
            let hv: Vec<Vec<Rat>> = hints.iter().map(|r| vec![r[a].clone()]).collect();
            match plan.update(&av, &hv, &ones)? {
                Some(e) => edits.push(e),
                None => return Ok(None),
            }
        }
        edits
    };
    let cols: Vec<&ScaledVec> = edits.iter().flat_map(|e| &e.derived_values).collect();
    let exact: Vec<Vec<Rat>> = cols.par_iter().map(|c| c.to_rats_raw()).collect();
    let approx: Vec<Vec<f64>> = cols.par_iter().map(|c| c.to_f64()).collect();
    Ok(Some((rows(&exact, hints.len()), rows(&approx, hints.len()))))
}

/// Columns (one per coordinate) to rows (one per point).
fn rows<T: Clone>(cols: &[Vec<T>], n: usize) -> Vec<Vec<T>> {
    (0..n).map(|s| cols.iter().map(|c| c[s].clone()).collect()).collect()
}

/// The translation preview of a modular selection (xy mode, one plan): positions of the
/// derived points are affine in the translation `v` (hints `base + theta v`, here with
/// `theta` exactly as its `f64`), so three exact operations (`v = 0`, `(1, 0)`, `(0, 1)`)
/// give `p0`, `gx` and `gy` with `p(v) = p0 + v_x gx + v_y gy`, as the sessions' affine map
/// does.
/// `None` when an operation could not be certified.
pub(super) fn preview_basis(
    plan: &Arc<ModularPlan>,
    base_anchors: &[Vec<Rat>],
    base_derived: &[Vec<Rat>],
    theta: &[f64],
) -> Result<Option<PreviewBasis>, EditError> {
    let run = |v: [i64; 2]| -> Result<Option<Vec<f64>>, EditError> {
        let anchors: Vec<Vec<Rat>> = base_anchors
            .iter()
            .map(|a| (0..2).map(|j| &a[j] + Rat::from_integer(v[j].into())).collect())
            .collect();
        let hints: Vec<Vec<Rat>> = base_derived
            .iter()
            .zip(theta)
            .map(|(p, &th)| {
                (0..2)
                    .map(|j| Ok(&p[j] + super::exact(th * v[j] as f64)?))
                    .collect::<Result<Vec<Rat>, EditError>>()
            })
            .collect::<Result<_, _>>()?;
        let found = values(std::slice::from_ref(plan), &anchors, &hints)?;
        Ok(found.map(|(_, f)| f.into_iter().flatten().collect()))
    };
    let (Some(p0), Some(px), Some(py)) = (run([0, 0])?, run([1, 0])?, run([0, 1])?) else {
        return Ok(None);
    };
    let diff = |a: Vec<f64>| -> Vec<f64> { a.iter().zip(&p0).map(|(a, b)| a - b).collect() };
    let (gx, gy) = (diff(px), diff(py));
    Ok(Some((p0, gx, gy)))
}

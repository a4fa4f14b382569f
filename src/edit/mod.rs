//! The 2DSD editing algorithm (thesis ch. 14; MSc dissertation ch. 7) on top of ECLES.
//!
//! An editing action has two steps:
//!
//! 1. [`Editor::select`] (2DSD.Select, Alg. 16): anchors `A` and an initial derived set `S`
//!    (explicit, or a neighbourhood radius `delta_max` on the control net, or all points);
//!    ExpandDerived grows `S` into `D` so that the edit is solvable ([`select`]); RelMagnitude
//!    gives each derived point a weight `theta_s` in `[0, 1]`; ECLES initialize factors the
//!    relevant C1 conditions once.
//! 2. Any number of operations, each relative to the positions at selection time (so a drag
//!    can call them repeatedly with the total motion so far):
//!    * [`Editor::translate`] by `v` (Alg. 17): anchors to `p + v`, hints `p + theta_s v`;
//!    * [`Editor::rotate`] about `c` by `alpha`: anchors by an **exact rational rotation**
//!      `(cos, sin) = ((1 - t^2)/(1 + t^2), 2t/(1 + t^2))`, `t` a rational close to
//!      `tan(alpha/2)`, so the motion of the anchors is exactly affine and keeps every
//!      condition among them (thesis ch. 20 lists this as open); hints rotated by
//!      `theta_s alpha`;
//!    * [`Editor::scale`] about `c` by a rational `gamma`: anchors `c + gamma (p - c)`,
//!      hints `c + gamma^theta_s (p - c)`.
//!
//!    ECLES update then moves `D` to the exact solution nearest the hints. A failed operation
//!    leaves the spline exactly as it was.
//!
//! Modes: `xy` edits `phi` (parameters in `R^2`); `z0` and `z1` edit the scalar splines of a
//! 2.5D deformation (parameters in `R^1`) through the same code.
//!
//! Hints are computed in `f64` and rounded to multiples of `2^-20` (they need not be exact;
//! the constraints are). Anchor positions are exact.
//!
//! [`script`] holds the operations as typed values (edit scripts, the editor server's drag
//! steps) and runs a script all or nothing.

pub mod extra;
pub mod global;
pub mod script;
pub mod select;

use crate::ecles::modular::ModularPlan;
use crate::ecles::problem::MODULAR_MIN_ENTRIES;
use crate::ecles::{ConstraintSystem, EclesError, Session};
use crate::exact::{rat_from_f64, rat_to_f64, Int, Rat};
use crate::spline::{ControlPoint, Spline};
use extra::{axis_system, Extra};
use global::GlobalSolve;
use modular::Solvers;
use num_traits::Zero;
use select::{expand, neighborhood, rel_magnitude, Neighborhood, SelectIndex};
use std::sync::Arc;

/// Which spline an edit changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Mode {
    /// The plane deformation phi (2D control points).
    #[default]
    Xy,
    /// The bottom surface sigma0 of a 2.5D deformation.
    Z0,
    /// The top surface sigma1 of a 2.5D deformation.
    Z1,
}

impl Mode {
    /// The mode's name in files and requests (`xy`, `z0`, `z1`).
    pub fn name(self) -> &'static str {
        match self {
            Mode::Xy => "xy",
            Mode::Z0 => "z0",
            Mode::Z1 => "z1",
        }
    }
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Mode, String> {
        match s {
            "xy" => Ok(Mode::Xy),
            "z0" => Ok(Mode::Z0),
            "z1" => Ok(Mode::Z1),
            _ => Err(format!("unknown mode `{s}` (use xy, z0 or z1)")),
        }
    }
}

/// Errors of editing operations. After any error the spline is unchanged.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EditError {
    /// The constraint layer refused (unsolvable edits carry the failed condition).
    #[error(transparent)]
    Ecles(#[from] EclesError),
    /// A control point index is out of range.
    #[error("control point {index} does not exist (the spline has {count})")]
    PointIndex {
        /// The index.
        index: usize,
        /// Number of control points.
        count: usize,
    },
    /// No anchors.
    #[error("the edit has no anchors: choose at least one control point to move")]
    NoAnchors,
    /// An operation came before any selection.
    #[error("no selection: call select before translate, rotate or scale")]
    NoSelection,
    /// A z mode on a deformation without 2.5D layers, or a 2D operation in a z mode.
    #[error("{0}")]
    Mode(String),
    /// A non-finite or otherwise invalid argument.
    #[error("invalid argument: {0}")]
    Argument(String),
}

/// The anchors and derived points of an edit (saved in deformation files for rendering).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LastEdit {
    /// Anchor control points.
    pub anchors: Vec<ControlPoint>,
    /// Derived control points.
    pub derived: Vec<ControlPoint>,
}

/// The current selection: anchors, derived points, their weights and the ECLES session.
#[derive(Clone, Debug)]
pub struct Selection {
    /// The anchors.
    pub anchors: Vec<ControlPoint>,
    /// The derived points (after ExpandDerived).
    pub derived: Vec<ControlPoint>,
    /// RelMagnitude of each derived point.
    pub theta: Vec<f64>,
    /// Whether strong solvability holds (otherwise only exactly affine motions are safe).
    pub strong: bool,
    /// The mode.
    pub mode: Mode,
    base_anchors: Vec<Vec<Rat>>,
    base_derived: Vec<Vec<Rat>>,
    /// One session (parameters in R^2 or R^1), or two one-coordinate sessions (x, y) when
    /// extra constraints bind the coordinates differently; none on the select-all path.
    sessions: Vec<Session>,
    /// The select-all path ([`global`]), instead of sessions.
    global: Option<Arc<GlobalSolve>>,
    /// The modular path of ECLES (one plan per system, like `sessions`), instead of
    /// sessions, for large derived sets ([`Editor::set_modular_path`]).
    plans: Vec<Arc<ModularPlan>>,
    /// Relevant conditions and their rank (reported by scripts and the editor).
    relevant: usize,
    rank: usize,
    /// `f64` preview of translations: derived = p0 + v_x gx + v_y gy (built on demand).
    preview: Option<(Vec<f64>, Vec<f64>, Vec<f64>)>,
}

impl Selection {
    /// The (first) ECLES session of this selection (relevant constraints, rank, ...);
    /// `None` on the select-all path ([`Selection::is_global`]).
    pub fn session(&self) -> Option<&Session> {
        self.sessions.first()
    }
    /// All ECLES sessions of this selection (two, x and y, with extra constraints; none on
    /// the select-all path).
    pub fn sessions(&self) -> &[Session] {
        &self.sessions
    }
    /// Whether this select-all edit is solved in determining-set coordinates ([`global`])
    /// rather than by ECLES sessions.
    pub fn is_global(&self) -> bool {
        self.global.is_some()
    }
    /// Whether this selection is solved on ECLES's modular path
    /// ([`crate::ecles::modular`]: a certified basis once, a certified exact solve per
    /// operation) rather than by fraction-free sessions; see [`Editor::set_modular_path`].
    pub fn is_modular(&self) -> bool {
        !self.plans.is_empty()
    }
    /// Number of C1 conditions that involve an anchor or a derived point.
    pub fn relevant(&self) -> usize {
        self.relevant
    }
    /// Rank of those conditions (on the select-all path: control points minus the size of
    /// the minimal determining set, the rank of the whole C1 system).
    pub fn rank(&self) -> usize {
        self.rank
    }
    /// The relevant conditions without redundant ones, as ECLES found them (which of the
    /// dependent conditions are left out follows the LDU's pivot order on sessions, and is
    /// the canonical set on the modular path; their number is the same); on the select-all
    /// path every condition of the spline (redundancy is not computed there).
    pub fn independent_constraints(&self, spline: &Spline) -> Vec<usize> {
        let (relevant, redundant) = match (self.sessions.first(), self.plans.first()) {
            (Some(session), _) => (session.relevant(), session.redundant()),
            (None, Some(plan)) => (plan.relevant(), plan.redundant().to_vec()),
            (None, None) => return (0..spline.c1_matrix().rows()).collect(),
        };
        let redundant: std::collections::BTreeSet<usize> = redundant.into_iter().collect();
        relevant.iter().copied().filter(|c| !redundant.contains(c)).collect()
    }
}

/// Edits a spline with 2DSD; see the module docs.
#[derive(Clone, Debug)]
pub struct Editor {
    spline: Spline,
    index: SelectIndex,
    zsys: ConstraintSystem,
    extras: Vec<Extra>,
    axis_sys: Option<[ConstraintSystem; 2]>,
    bounded: Option<(crate::spline::mds::Mds, u32)>,
    /// Fewest control points for the select-all path (`None`: never).
    global_min: Option<usize>,
    /// Smallest `|E| x |D|` for the modular path (`None`: never).
    modular_min: Option<usize>,
    selection: Option<Selection>,
}

/// Rounds an `f64` to a multiple of `2^-20` as an exact rational (hints only).
fn hint_rat(v: f64) -> Rat {
    let scale = (1u64 << 20) as f64;
    Rat::new(Int::from((v * scale).round() as i64), Int::from(1i64 << 20))
}

impl Editor {
    /// An editor for `spline`.
    pub fn new(spline: Spline) -> Editor {
        let index = SelectIndex::new(&spline);
        let zsys = ConstraintSystem::homogeneous(spline.c1_matrix().clone(), 1);
        Editor {
            spline,
            index,
            zsys,
            extras: Vec::new(),
            axis_sys: None,
            bounded: None,
            global_min: Some(global::GLOBAL_MIN_POINTS),
            modular_min: Some(MODULAR_MIN_ENTRIES),
            selection: None,
        }
    }

    /// Selections whose relevant conditions times derived points (`|E| x |D|`) reach
    /// `min_entries` are solved on ECLES's modular path ([`crate::ecles::modular`]): the
    /// rank, the redundant conditions and strong solvability from a certified basis at
    /// selection, then each operation one exactly verified solve, the same exact answer as
    /// the fraction-free sessions (which stay for smaller selections, and whenever no prime
    /// certifies). The default is [`MODULAR_MIN_ENTRIES`], as for `trimorph solve`.
    ///
    /// With a threshold set, the growth of the derived set in 2DSD.Select (when strong
    /// solvability fails) takes the canonical failing condition on both paths (the first
    /// that depends on the conditions before it), so the selection does not depend on
    /// which path ran. `None` always uses sessions, and grows by the condition the LDU
    /// names in its pivot order (the rule before the modular path existed). Ends the
    /// selection.
    pub fn set_modular_path(&mut self, min_entries: Option<usize>) {
        self.modular_min = min_entries;
        self.selection = None;
    }

    /// Select-all edits in bounded xy mode without extra constraints, on splines with at
    /// least `min_points` control points, are solved in the coordinates of the minimal
    /// determining set ([`global`]); `None` always uses ECLES sessions. The default is
    /// [`global::GLOBAL_MIN_POINTS`]. Ends the selection.
    pub fn set_global_path(&mut self, min_points: Option<usize>) {
        self.global_min = min_points;
        self.selection = None;
    }

    /// Bounded exactness (xy mode without extra constraints): after every operation the free
    /// points of a minimal determining set among the edited points are rounded to multiples
    /// of `2^-bits` and the dependent points recomputed exactly (see
    /// [`crate::spline::mds`]). C1 still holds exactly and nothing outside the edit changes;
    /// control-point sizes no longer grow with the edit history; anchors land within a
    /// small tolerance instead of exactly. `None` turns it off.
    pub fn set_bounded(&mut self, bits: Option<u32>) -> Result<(), crate::spline::mds::MdsError> {
        self.bounded = match bits {
            None => None,
            Some(b) => Some((crate::spline::mds::Mds::new(&self.spline)?, b.min(62))),
        };
        self.selection = None;
        Ok(())
    }

    /// The extra affine constraints in force.
    pub fn constraints(&self) -> &[Extra] {
        &self.extras
    }

    /// Adds an extra constraint (it must hold for the current points; see [`Extra`]). Ends
    /// the current selection.
    pub fn add_constraint(&mut self, e: Extra) -> Result<(), EditError> {
        let n = self.spline.num_points();
        if let Some(&index) = e.points().iter().find(|&&p| p >= n) {
            return Err(EditError::PointIndex { index, count: n });
        }
        let holds = {
            let sys = axis_system(self.spline.c1_matrix(), std::slice::from_ref(&e), 0);
            let sys_y = axis_system(self.spline.c1_matrix(), std::slice::from_ref(&e), 1);
            let col = |a: usize| -> Vec<Vec<Rat>> {
                self.spline.points().iter().map(|p| vec![p[a].clone()]).collect()
            };
            sys.is_satisfied(&col(0)) && sys_y.is_satisfied(&col(1))
        };
        if !holds {
            return Err(EditError::Argument(format!(
                "constraint {} does not hold for the current points",
                e.to_json()
            )));
        }
        self.extras.push(e);
        self.axis_sys = None;
        self.selection = None;
        Ok(())
    }

    /// Replaces the spline by another with the same mesh and degree (undo and redo, or a
    /// fit result loaded over the current one), keeping the selection index. Ends the
    /// selection. Refused, with nothing changed, if the layouts differ or an extra
    /// constraint does not hold for the new points.
    pub fn replace_spline(&mut self, s: Spline) -> Result<(), EditError> {
        if !same_layout(&self.spline, &s) {
            return Err(EditError::Argument(
                "the new deformation has another mesh or degree than the one being edited".into(),
            ));
        }
        for e in &self.extras {
            let col = |k: usize| -> Vec<Vec<Rat>> {
                s.points().iter().map(|p| vec![p[k].clone()]).collect()
            };
            let holds = (0..2).all(|k| {
                axis_system(s.c1_matrix(), std::slice::from_ref(e), k).is_satisfied(&col(k))
            });
            if !holds {
                return Err(EditError::Argument(format!(
                    "constraint {} does not hold for the new points",
                    e.to_json()
                )));
            }
        }
        // The bounded mode's minimal determining set depends on the mesh only: kept.
        self.spline = s;
        self.selection = None;
        Ok(())
    }

    /// The spline being edited.
    pub fn spline(&self) -> &Spline {
        &self.spline
    }
    /// Consumes the editor, returning the spline.
    pub fn into_spline(self) -> Spline {
        self.spline
    }
    /// The current selection, if any.
    pub fn selection(&self) -> Option<&Selection> {
        self.selection.as_ref()
    }
    /// The selection index (control net, conditions per point, vertex disks).
    pub fn index(&self) -> &SelectIndex {
        &self.index
    }

    /// The parameters of a z mode as rows of one value (xy uses the spline's points directly).
    fn z_params(&self, mode: Mode) -> Result<Vec<Vec<Rat>>, EditError> {
        match mode {
            Mode::Xy => unreachable!("xy parameters are borrowed from the spline"),
            Mode::Z0 | Mode::Z1 => {
                let z = self.spline.z_layers().ok_or_else(|| {
                    EditError::Mode("z0/z1 modes need a 2.5D deformation (with z_range)".into())
                })?;
                let v = if mode == Mode::Z0 { &z.z0 } else { &z.z1 };
                Ok(v.iter().map(|x| vec![x.clone()]).collect())
            }
        }
    }

    /// The control points nearest to the given positions in the *deformed* plane (the
    /// current control points), one per position.
    pub fn nearest_points(&self, pos: &[[f64; 2]]) -> Vec<ControlPoint> {
        pos.iter()
            .map(|p| {
                (0..self.spline.num_points())
                    .min_by(|&a, &b| {
                        let (qa, qb) = (self.spline.point_f64(a), self.spline.point_f64(b));
                        let da = (qa[0] - p[0]).powi(2) + (qa[1] - p[1]).powi(2);
                        let db = (qb[0] - p[0]).powi(2) + (qb[1] - p[1]).powi(2);
                        da.total_cmp(&db)
                    })
                    .map(ControlPoint)
                    .expect("a spline has control points")
            })
            .collect()
    }

    /// 2DSD.Select: anchors, initial derived set (`extra` plus the neighbourhood), mode.
    pub fn select(
        &mut self,
        anchors: &[ControlPoint],
        extra: &[ControlPoint],
        hood: &Neighborhood,
        mode: Mode,
    ) -> Result<&Selection, EditError> {
        let (anchor_idx, extra) = (ControlPoint::indices(anchors), ControlPoint::indices(extra));
        let anchors = &anchor_idx[..];
        let n = self.spline.num_points();
        if anchors.is_empty() {
            return Err(EditError::NoAnchors);
        }
        if let Some(&index) = anchors.iter().chain(&extra).find(|&&p| p >= n) {
            return Err(EditError::PointIndex { index, count: n });
        }
        let mut is_anchor = vec![false; n];
        for &a in anchors {
            if std::mem::replace(&mut is_anchor[a], true) {
                return Err(EclesError::Duplicate { what: "anchors", index: a }.into());
            }
        }
        if let Some(&index) = extra.iter().find(|&&p| is_anchor[p]) {
            return Err(EclesError::AnchorAlsoDerived { index }.into());
        }
        let zparams = if mode == Mode::Xy { None } else { Some(self.z_params(mode)?) };
        let params: &[Vec<Rat>] = match &zparams {
            Some(z) => z,
            None => self.spline.points(),
        };
        if let Some(sel) = self.select_global(anchors, hood, mode) {
            self.selection = Some(sel);
            return Ok(self.selection.as_ref().expect("the selection is stored just above"));
        }
        let mut in_d = vec![false; n];
        let mut seeds: Vec<usize> = anchors.to_vec();
        for p in extra.iter().copied().chain(neighborhood(&self.index, anchors, hood)) {
            if !in_d[p] && !is_anchor[p] {
                in_d[p] = true;
                seeds.push(p);
            }
        }
        expand(&self.spline, &self.index, &is_anchor, &mut in_d, &seeds);
        let split = mode == Mode::Xy && !self.extras.is_empty();
        let bounded = mode == Mode::Xy && !split && self.bounded.is_some();
        let close = |in_d: &mut Vec<bool>, bd: &Option<(crate::spline::mds::Mds, u32)>| {
            if let (true, Some((mds, _))) = (bounded, bd) {
                let mut set: Vec<bool> =
                    in_d.iter().zip(&is_anchor).map(|(a, b)| *a || *b).collect();
                mds.close(&mut set);
                for (p, x) in set.into_iter().enumerate() {
                    if x && !is_anchor[p] {
                        in_d[p] = true;
                    }
                }
            }
        };
        close(&mut in_d, &self.bounded);
        if split && self.axis_sys.is_none() {
            let c1 = self.spline.c1_matrix();
            self.axis_sys =
                Some([axis_system(c1, &self.extras, 0), axis_system(c1, &self.extras, 1)]);
        }
        let cols = if split { axis_system_params(params) } else { Vec::new() };
        let systems: Vec<(&ConstraintSystem, &[Vec<Rat>])> = if split {
            let [x, y] = self.axis_sys.as_ref().expect("built above");
            vec![(x, &cols[0]), (y, &cols[1])]
        } else if mode == Mode::Xy {
            vec![(self.spline.system(), params)]
        } else {
            vec![(&self.zsys, params)]
        };
        let (solvers, strong, derived) = loop {
            let derived: Vec<usize> = (0..n).filter(|&p| in_d[p]).collect();
            let (k, constraint) = match self.start(&systems, anchors, &derived, true) {
                Ok(s) => break (s, true, derived),
                Err((k, EclesError::NotStronglySolvable { constraint, .. })) => (k, constraint),
                Err((_, e)) => return Err(e.into()),
            };
            let sys = systems[k].0;
            // Grow D by the free members of the failing condition; if it has none, by the
            // fixed points that the relevant conditions involve (F'), which are what blocks.
            let mut grow: Vec<usize> = sys
                .matrix()
                .row(constraint)
                .iter()
                .map(|(p, _)| *p)
                .filter(|&p| !is_anchor[p] && !in_d[p])
                .collect();
            if grow.is_empty() {
                grow = sys.extract_relevant(anchors, &derived).1;
            }
            if grow.is_empty() {
                let weak = self.start(&systems, anchors, &derived, false).map_err(|(_, e)| e)?;
                break (weak, false, derived);
            }
            for &p in &grow {
                in_d[p] = true;
            }
            expand(&self.spline, &self.index, &is_anchor, &mut in_d, &grow);
            close(&mut in_d, &self.bounded);
        };
        let theta = rel_magnitude(&self.index, anchors, &derived);
        let (sessions, plans) = match solvers {
            Solvers::Ldu(s) => (s, Vec::new()),
            Solvers::Modular(p) => (Vec::new(), p),
        };
        let (relevant, rank) = match (sessions.first(), plans.first()) {
            (Some(s), _) => (s.relevant().len(), s.rank()),
            (None, Some(p)) => (p.relevant().len(), p.rank()),
            (None, None) => unreachable!("one solver per system, and there is one system"),
        };
        self.selection = Some(Selection {
            anchors: ControlPoint::from_indices(anchors),
            base_anchors: anchors.iter().map(|&a| params[a].clone()).collect(),
            base_derived: derived.iter().map(|&p| params[p].clone()).collect(),
            derived: ControlPoint::from_indices(&derived),
            theta,
            strong,
            mode,
            sessions,
            global: None,
            plans,
            relevant,
            rank,
            preview: None,
        });
        Ok(self.selection.as_ref().expect("the selection is stored just above"))
    }

    /// Runs ECLES update with these anchor values and hints, then writes the result.
    fn apply(&mut self, anchors: Vec<Vec<Rat>>, hints: Vec<Vec<Rat>>) -> Result<(), EditError> {
        let global = self.selection.as_ref().and_then(|s| s.global.clone());
        if let Some(solve) = global {
            return self.apply_global(&solve, &anchors, &hints);
        }
        let plans = self.selection.as_ref().map(|s| s.plans.clone()).unwrap_or_default();
        let modular = match plans.is_empty() {
            true => None,
            false => modular::values(&plans, &anchors, &hints)?,
        };
        if !plans.is_empty() && modular.is_none() {
            // No prime certified this operation: the selection goes on with sessions (and
            // keeps its plans if the operation fails on them too).
            self.fall_back_to_sessions()?;
            let result = self.apply(anchors, hints);
            if result.is_err() {
                let sel = self.selection.as_mut().expect("the selection is kept");
                sel.sessions.clear();
                sel.plans = plans;
            }
            return result;
        }
        let sel = self.selection.as_mut().ok_or(EditError::NoSelection)?;
        let (derived, df): (Vec<Vec<Rat>>, Vec<Vec<f64>>) = if let Some(v) = modular {
            v
        } else if sel.sessions.len() == 1 {
            sel.sessions[0].update(&anchors, Some(&hints), None)?;
            // Exact values unreduced (no gcd per value during a drag); f64 straight from
            // the common-denominator form.
            (sel.sessions[0].derived_values_raw(), sel.sessions[0].derived_f64())
        } else {
            // x and y separately; on failure restore both sessions.
            let saved = sel.sessions.clone();
            for (a, s) in sel.sessions.iter_mut().enumerate() {
                let av: Vec<Vec<Rat>> = anchors.iter().map(|r| vec![r[a].clone()]).collect();
                let hv: Vec<Vec<Rat>> = hints.iter().map(|r| vec![r[a].clone()]).collect();
                if let Err(e) = s.update(&av, Some(&hv), None) {
                    sel.sessions = saved;
                    return Err(e.into());
                }
            }
            let (x, y) =
                (sel.sessions[0].derived_values_raw(), sel.sessions[1].derived_values_raw());
            let (xf, yf) = (sel.sessions[0].derived_f64(), sel.sessions[1].derived_f64());
            (
                x.into_iter().zip(y).map(|(a, b)| vec![a[0].clone(), b[0].clone()]).collect(),
                xf.into_iter().zip(yf).map(|(a, b)| vec![a[0], b[0]]).collect(),
            )
        };
        let idx: Vec<usize> = sel.anchors.iter().chain(&sel.derived).map(|p| p.index()).collect();
        let mut approx: Vec<[f64; 2]> =
            anchors.iter().map(|a| [rat_to_f64(&a[0]), a.get(1).map_or(0.0, rat_to_f64)]).collect();
        approx.extend(df.iter().map(|r| [r[0], r.get(1).copied().unwrap_or(0.0)]));
        let mut vals = anchors;
        vals.extend(derived);
        match sel.mode {
            Mode::Xy => {
                self.spline.write_points(&idx, vals, &approx);
                let systems = sel.sessions.len() + sel.plans.len();
                if let (Some((mds, bits)), 1) = (&self.bounded, systems) {
                    let mut region = vec![false; self.spline.num_points()];
                    for &p in &idx {
                        region[p] = true;
                    }
                    self.spline.bound_region(mds, &region, *bits);
                }
            }
            mode => {
                let mut z = self.spline.z_layers().cloned().expect("checked at select");
                let layer = if mode == Mode::Z0 { &mut z.z0 } else { &mut z.z1 };
                for (&i, v) in idx.iter().zip(vals) {
                    layer[i] = v.into_iter().next().expect("one coordinate");
                }
                self.spline.set_z_layers(Some(z));
            }
        }
        Ok(())
    }

    fn selection_or_err(&self) -> Result<&Selection, EditError> {
        self.selection.as_ref().ok_or(EditError::NoSelection)
    }

    /// Soft translation by `v` (2 values in xy mode, 1 in z modes) from the positions at
    /// selection time.
    pub fn translate(&mut self, v: &[Rat]) -> Result<(), EditError> {
        let sel = self.selection_or_err()?;
        let dim = if sel.mode == Mode::Xy { 2 } else { 1 };
        if v.len() != dim {
            return Err(EditError::Argument(format!(
                "translation needs {dim} values, got {}",
                v.len()
            )));
        }
        let anchors = sel
            .base_anchors
            .iter()
            .map(|p| p.iter().zip(v).map(|(a, b)| a + b).collect())
            .collect();
        let hints = sel
            .base_derived
            .iter()
            .zip(&sel.theta)
            .map(|(p, &th)| {
                p.iter().zip(v).map(|(a, b)| a + hint_rat(th * rat_to_f64(b))).collect()
            })
            .collect();
        self.apply(anchors, hints)
    }

    /// Soft rotation about `center` by `angle` radians (xy mode), exact for the anchors.
    pub fn rotate(&mut self, center: [Rat; 2], angle: f64) -> Result<(), EditError> {
        if !angle.is_finite() {
            return Err(EditError::Argument(format!("rotation angle {angle} is not finite")));
        }
        let sel = self.selection_or_err()?;
        if sel.mode != Mode::Xy {
            return Err(EditError::Mode("rotate works in xy mode only".into()));
        }
        let (c, s) = rational_rotation(angle);
        let anchors = sel
            .base_anchors
            .iter()
            .map(|p| {
                let (dx, dy) = (&p[0] - &center[0], &p[1] - &center[1]);
                vec![&center[0] + &c * &dx - &s * &dy, &center[1] + &s * &dx + &c * &dy]
            })
            .collect();
        let cf = [rat_to_f64(&center[0]), rat_to_f64(&center[1])];
        let hints = sel
            .base_derived
            .iter()
            .zip(&sel.theta)
            .map(|(p, &th)| {
                let (dx, dy) = (rat_to_f64(&p[0]) - cf[0], rat_to_f64(&p[1]) - cf[1]);
                let (sa, ca) = (th * angle).sin_cos();
                vec![hint_rat(cf[0] + ca * dx - sa * dy), hint_rat(cf[1] + sa * dx + ca * dy)]
            })
            .collect();
        self.apply(anchors, hints)
    }

    /// Soft scaling about `center` (2 values in xy mode, 1 in z modes) by `factor` > 0.
    pub fn scale(&mut self, center: &[Rat], factor: &Rat) -> Result<(), EditError> {
        let sel = self.selection_or_err()?;
        let dim = if sel.mode == Mode::Xy { 2 } else { 1 };
        if center.len() != dim {
            return Err(EditError::Argument(format!("scaling centre needs {dim} values")));
        }
        if *factor <= Rat::zero() {
            return Err(EditError::Argument(format!("scale factor {factor} must be positive")));
        }
        let anchors = sel
            .base_anchors
            .iter()
            .map(|p| p.iter().zip(center).map(|(x, c)| c + factor * (x - c)).collect())
            .collect();
        let fl = rat_to_f64(factor);
        let hints = sel
            .base_derived
            .iter()
            .zip(&sel.theta)
            .map(|(p, &th)| {
                let g = fl.powf(th);
                p.iter()
                    .zip(center)
                    .map(|(x, c)| hint_rat(rat_to_f64(c) + g * (rat_to_f64(x) - rat_to_f64(c))))
                    .collect()
            })
            .collect();
        self.apply(anchors, hints)
    }

    /// Ends the selection (the spline keeps its current state).
    pub fn clear_selection(&mut self) {
        self.selection = None;
    }
}

/// The x and y columns of the parameters, for the per-axis systems (one coordinate each).
fn axis_system_params(params: &[Vec<Rat>]) -> Vec<Vec<Vec<Rat>>> {
    (0..2).map(|a| params.iter().map(|p| vec![p[a].clone()]).collect()).collect()
}

/// Whether two splines have the same mesh (exact vertex coordinates and triangles) and
/// degree, so that control points correspond one to one.
pub fn same_layout(a: &Spline, b: &Spline) -> bool {
    let (ma, mb) = (a.mesh(), b.mesh());
    a.degree() == b.degree()
        && a.num_points() == b.num_points()
        && ma.grid_denominator() == mb.grid_denominator()
        && ma.num_vertices() == mb.num_vertices()
        && ma.num_triangles() == mb.num_triangles()
        && (0..ma.num_triangles()).all(|t| ma.triangle(t) == mb.triangle(t))
        && (0..ma.num_vertices()).all(|v| ma.vertex_int(v) == mb.vertex_int(v))
}

/// Exact rational from a finite `f64` (convenience for callers).
pub fn exact(v: f64) -> Result<Rat, EditError> {
    rat_from_f64(v).ok_or_else(|| EditError::Argument(format!("{v} is not a finite number")))
}

mod modular;
mod preview;
mod rational;
pub use rational::{rational_approx, rational_rotation};

#[cfg(test)]
mod tests;

#[cfg(test)]
mod global_tests;

#[cfg(test)]
mod modular_tests;

//! ECLES sessions: `Initialize` once per choice of anchors and derived parameters (Alg. 1-3),
//! then `Update` for every new set of anchor values (Alg. 4-5).

use super::{ConstraintSystem, EclesError};
use crate::exact::ldu::{Ldu, LduOptions, Pivoting, Simplification};
use crate::exact::lsq::{LsqError, WeightedLsq};
use crate::exact::matrix::{Rat, ScaledVec, SparseIntMatrix};
use num_traits::{One, Signed, Zero};

/// Options of [`ConstraintSystem::initialize`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct InitOptions {
    /// Require strong solvability (any anchor values can be honoured) at initialization.
    pub strong: bool,
    /// Common-factor simplification of the factoring.
    pub method: Simplification,
    /// Pivot choice of the factoring.
    pub pivoting: Pivoting,
}

/// An edit in progress: the factored relevant system plus the current values of the anchors
/// and derived parameters. See the [module docs](super).
#[derive(Clone, Debug)]
pub struct Session {
    pub(super) anchors: Vec<usize>,
    pub(super) derived: Vec<usize>,
    pub(super) relevant: Vec<usize>,
    pub(super) fixed_relevant: Vec<usize>,
    /// Factoring of `R_ED` (rows: relevant constraints in `relevant` order).
    pub(super) ldu: Ldu,
    /// `R_EA` (`|E| x |A|`).
    pub(super) r_ea: SparseIntMatrix,
    /// `R_ED` restricted to the independent rows (`rank x |D|`).
    pub(super) r_hat: SparseIntMatrix,
    /// `C = Q_E - R_EF' P_F'` (`|E| x d`): constant while the session lives.
    pub(super) c: Vec<Vec<Rat>>,
    pub(super) d: usize,
    pub(super) method: Simplification,
    anchor_values: Vec<Vec<Rat>>,
    /// Derived values per coordinate (`d` vectors of length `|D|`).
    values: Vec<ScaledVec>,
    lsq: Option<(Vec<Rat>, WeightedLsq)>,
    /// Strong solvability was verified: every update is solvable, no weak check needed.
    strong_ok: bool,
}

pub(super) fn check_indices(what: &'static str, idx: &[usize], n: usize) -> Result<(), EclesError> {
    let mut seen = vec![false; n];
    for &s in idx {
        if s >= n {
            return Err(EclesError::IndexOutOfRange { what, index: s, n });
        }
        if std::mem::replace(&mut seen[s], true) {
            return Err(EclesError::Duplicate { what, index: s });
        }
    }
    Ok(())
}

/// The checks every edit starts with: `p` is `n x d`, at least one anchor, anchors and
/// derived points are in range, each listed once, and no point is both.
pub(super) fn check_edit(
    p: &[Vec<Rat>],
    anchors: &[usize],
    derived: &[usize],
    n: usize,
    d: usize,
) -> Result<(), EclesError> {
    check_rows("P (current values)", p, n, d)?;
    if anchors.is_empty() {
        return Err(EclesError::NoAnchors);
    }
    check_indices("anchors", anchors, n)?;
    check_indices("derived", derived, n)?;
    let mut is_anchor = vec![false; n];
    for &a in anchors {
        is_anchor[a] = true;
    }
    if let Some(&index) = derived.iter().find(|&&s| is_anchor[s]) {
        return Err(EclesError::AnchorAlsoDerived { index });
    }
    Ok(())
}

/// One positive weight per derived parameter (`derived` names them in errors).
pub(super) fn check_weights(weights: &[Rat], derived: &[usize]) -> Result<(), EclesError> {
    if weights.len() != derived.len() {
        return Err(EclesError::Dimension {
            what: "weights (one per derived parameter)".into(),
            expected: derived.len(),
            found: weights.len(),
        });
    }
    if let Some((k, v)) = weights.iter().enumerate().find(|(_, v)| !v.is_positive()) {
        return Err(EclesError::NonPositiveWeight { index: derived[k], value: v.to_string() });
    }
    Ok(())
}

pub(super) fn check_rows(
    what: &str,
    m: &[Vec<Rat>],
    rows: usize,
    d: usize,
) -> Result<(), EclesError> {
    if m.len() != rows {
        return Err(EclesError::Dimension {
            what: format!("rows of {what}"),
            expected: rows,
            found: m.len(),
        });
    }
    if let Some(r) = m.iter().find(|r| r.len() != d) {
        return Err(EclesError::Dimension {
            what: format!("values per row of {what}"),
            expected: d,
            found: r.len(),
        });
    }
    Ok(())
}

impl ConstraintSystem {
    /// ECLES.Initialize (Alg. 1): relevant sets, one factoring of `R_ED`, optional strong
    /// solvability check. `p` holds the current values of all `n` parameters.
    pub fn initialize(
        &self,
        p: &[Vec<Rat>],
        anchors: &[usize],
        derived: &[usize],
        opts: InitOptions,
    ) -> Result<Session, EclesError> {
        let n = self.params();
        check_edit(p, anchors, derived, n, self.d)?;
        let (relevant, fixed_relevant) = self.extract_relevant(anchors, derived);
        // Column maps as hash maps: the edit touches few of the n parameters.
        let map_cols = |cols: &[usize]| -> std::collections::HashMap<usize, usize> {
            cols.iter().enumerate().map(|(k, &s)| (s, k)).collect()
        };
        let (md, ma, mf) = (map_cols(derived), map_cols(anchors), map_cols(&fixed_relevant));
        let r_ed = self.r.select_with(&relevant, |c| md.get(&c).copied(), derived.len());
        let r_ea = self.r.select_with(&relevant, |c| ma.get(&c).copied(), anchors.len());
        let r_ef = self.r.select_with(&relevant, |c| mf.get(&c).copied(), fixed_relevant.len());
        let ldu =
            Ldu::factor(&r_ed, LduOptions { simplification: opts.method, pivoting: opts.pivoting });
        let p_f: Vec<Vec<Rat>> = fixed_relevant.iter().map(|&s| p[s].clone()).collect();
        let rf = r_ef.mul_rat(&p_f);
        let c: Vec<Vec<Rat>> = relevant
            .iter()
            .enumerate()
            .map(|(k, &i)| {
                (0..self.d)
                    .map(|j| match rf[k].get(j) {
                        Some(v) => &self.q[i][j] - v,
                        None => self.q[i][j].clone(),
                    })
                    .collect()
            })
            .collect();
        let r_hat = r_ed.select(
            ldu.independent_rows(),
            &(0..derived.len()).map(Some).collect::<Vec<_>>(),
            derived.len(),
        );
        let session = Session {
            anchors: anchors.to_vec(),
            derived: derived.to_vec(),
            relevant,
            fixed_relevant,
            ldu,
            r_ea,
            r_hat,
            c,
            d: self.d,
            method: opts.method,
            anchor_values: anchors.iter().map(|&s| p[s].clone()).collect(),
            values: (0..self.d)
                .map(|j| {
                    ScaledVec::from_rats(
                        &derived.iter().map(|&s| p[s][j].clone()).collect::<Vec<_>>(),
                    )
                })
                .collect(),
            lsq: None,
            strong_ok: false,
        };
        let mut session = session;
        if opts.strong {
            session.check_strong()?;
            session.strong_ok = true;
        }
        Ok(session)
    }
}

impl Session {
    /// Anchor parameter indices, in the order of the anchor values.
    pub fn anchors(&self) -> &[usize] {
        &self.anchors
    }
    /// Derived parameter indices, in the order of the derived values.
    pub fn derived(&self) -> &[usize] {
        &self.derived
    }
    /// Relevant constraints `E` (sorted original indices).
    pub fn relevant(&self) -> &[usize] {
        &self.relevant
    }
    /// Fixed relevant parameters `F'` (sorted).
    pub fn fixed_relevant(&self) -> &[usize] {
        &self.fixed_relevant
    }
    /// Rank of `R_ED`.
    pub fn rank(&self) -> usize {
        self.ldu.rank()
    }
    /// Relevant constraints that are redundant given the others (sorted original indices).
    pub fn redundant(&self) -> Vec<usize> {
        let mut v: Vec<usize> =
            self.ldu.redundant_rows().iter().map(|&k| self.relevant[k]).collect();
        v.sort_unstable();
        v
    }
    /// Relevant constraints kept as independent (sorted original indices).
    pub fn independent(&self) -> Vec<usize> {
        let mut v: Vec<usize> =
            self.ldu.independent_rows().iter().map(|&k| self.relevant[k]).collect();
        v.sort_unstable();
        v
    }
    /// The factoring of `R_ED`.
    pub fn factoring(&self) -> &Ldu {
        &self.ldu
    }
    /// Current anchor values (`|A|` rows of `d`).
    pub fn anchor_values(&self) -> &[Vec<Rat>] {
        &self.anchor_values
    }
    /// Current derived values (`|D|` rows of `d`), each in lowest terms.
    pub fn derived_values(&self) -> Vec<Vec<Rat>> {
        let cols: Vec<Vec<Rat>> = self.values.iter().map(ScaledVec::to_rats).collect();
        (0..self.derived.len()).map(|s| cols.iter().map(|c| c[s].clone()).collect()).collect()
    }

    /// Current derived values (`|D|` rows of `d`), exact but not reduced to lowest terms
    /// (cheap; see [`ScaledVec::to_rats_raw`]).
    pub fn derived_values_raw(&self) -> Vec<Vec<Rat>> {
        let cols: Vec<Vec<Rat>> = self.values.iter().map(ScaledVec::to_rats_raw).collect();
        (0..self.derived.len()).map(|s| cols.iter().map(|c| c[s].clone()).collect()).collect()
    }

    /// Current derived values per coordinate, as integers over a common denominator (no
    /// reduction; the cheap form).
    pub fn derived_scaled(&self) -> &[ScaledVec] {
        &self.values
    }

    /// Current derived values as `f64` (`|D|` rows of `d`).
    pub fn derived_f64(&self) -> Vec<Vec<f64>> {
        let cols: Vec<Vec<f64>> = self.values.iter().map(ScaledVec::to_f64).collect();
        (0..self.derived.len()).map(|s| cols.iter().map(|c| c[s]).collect()).collect()
    }
    /// Writes the current anchor and derived values into a full parameter matrix.
    pub fn write_into(&self, p: &mut [Vec<Rat>]) {
        for (&s, v) in self.anchors.iter().zip(&self.anchor_values) {
            p[s] = v.clone();
        }
        for (&s, v) in self.derived.iter().zip(self.derived_values()) {
            p[s] = v;
        }
    }

    /// Strong solvability (Alg. 3, eqs. 8.15-8.16): every column of `R_EA` and of
    /// `C = Q_E - R_EF' P_F'` lies in the column space of `R_ED`.
    pub fn check_strong(&self) -> Result<(), EclesError> {
        let m = self.relevant.len();
        for a in 0..self.anchors.len() {
            let mut col = vec![Rat::zero(); m];
            for (i, v) in col.iter_mut().enumerate() {
                *v = Rat::from_integer(self.r_ea.get(i, a));
            }
            if let Some(row) = self.ldu.forward(&col).1 {
                return Err(EclesError::NotStronglySolvable {
                    constraint: self.relevant[row],
                    cause: format!("anchor {}", self.anchors[a]),
                });
            }
        }
        for j in 0..self.d {
            let col: Vec<Rat> = self.c.iter().map(|r| r[j].clone()).collect();
            if let Some(row) = self.ldu.forward(&col).1 {
                return Err(EclesError::NotStronglySolvable {
                    constraint: self.relevant[row],
                    cause: "the fixed parameters".into(),
                });
            }
        }
        Ok(())
    }

    /// `B = C - R_EA P'_A`, the right-hand side of eq. 2.3 for these anchor values.
    pub(super) fn rhs(&self, anchor_values: &[Vec<Rat>]) -> Vec<Vec<Rat>> {
        let ka = self.r_ea.mul_rat(anchor_values);
        self.c
            .iter()
            .zip(ka)
            .map(|(c, k)| {
                (0..self.d)
                    .map(|j| match k.get(j) {
                        Some(v) => &c[j] - v,
                        None => c[j].clone(),
                    })
                    .collect()
            })
            .collect()
    }

    /// The factored least-squares problem for these weights (cached across updates).
    pub(super) fn lsq_for(&mut self, weights: &[Rat]) -> Result<&WeightedLsq, EclesError> {
        let stale = match &self.lsq {
            Some((w, _)) => w != weights,
            None => true,
        };
        if stale {
            let lsq =
                WeightedLsq::new(self.r_hat.clone(), weights, self.method).map_err(
                    |e| match e {
                        LsqError::NonPositiveWeight { index, value } => {
                            EclesError::NonPositiveWeight { index: self.derived[index], value }
                        }
                        other => unreachable!("independent rows and checked weights: {other}"),
                    },
                )?;
            self.lsq = Some((weights.to_vec(), lsq));
        }
        Ok(&self.lsq.as_ref().expect("self.lsq is filled just above when stale").1)
    }

    /// Validated weights for the derived parameters (default 1).
    pub(super) fn weights_or_default(
        &self,
        weights: Option<&[Rat]>,
    ) -> Result<Vec<Rat>, EclesError> {
        match weights {
            None => Ok(vec![Rat::one(); self.derived.len()]),
            Some(w) => {
                check_weights(w, &self.derived)?;
                Ok(w.to_vec())
            }
        }
    }

    /// ECLES.Update (Alg. 4): sets the anchors to `anchor_values` (`|A|` rows of `d`) and
    /// moves the derived parameters to the values nearest `hints` (default: their current
    /// values) with per-derived `weights` (default 1) that keep every constraint exactly.
    /// Read the result with [`Session::derived_values`] (or the cheaper
    /// [`Session::derived_scaled`] / [`Session::derived_f64`]).
    ///
    /// On error (weak solvability fails, bad sizes or weights) the session is unchanged.
    pub fn update(
        &mut self,
        anchor_values: &[Vec<Rat>],
        hints: Option<&[Vec<Rat>]>,
        weights: Option<&[Rat]>,
    ) -> Result<(), EclesError> {
        check_rows("anchor values", anchor_values, self.anchors.len(), self.d)?;
        if let Some(h) = hints {
            check_rows("hints", h, self.derived.len(), self.d)?;
        }
        let weights = self.weights_or_default(weights)?;
        let b = self.rhs(anchor_values);
        // Weak solvability (Alg. 5) per coordinate; with full column rank the same pass gives
        // the unique solution (Alg. 14).
        let unique = self.ldu.rank() == self.derived.len();
        let mut new_values: Vec<ScaledVec> = Vec::with_capacity(self.d);
        let mut b_cols: Vec<Vec<Rat>> = Vec::with_capacity(self.d);
        for j in 0..self.d {
            let col: Vec<Rat> = b.iter().map(|r| r[j].clone()).collect();
            let fail = |row: usize| EclesError::NotWeaklySolvable {
                constraint: self.relevant[row],
                column: j,
            };
            if unique {
                let (x, den) = self.ldu.solve_scaled(&col).map_err(|e| fail(e.row))?;
                new_values.push(ScaledVec::new(x, den));
            } else if !self.strong_ok {
                if let Some(row) = self.ldu.first_inconsistent(&col) {
                    return Err(fail(row));
                }
            }
            b_cols.push(col);
        }
        if !unique {
            let rows = self.ldu.independent_rows().to_vec();
            let hint_cols: Vec<ScaledVec> = match hints {
                Some(h) => (0..self.d)
                    .map(|j| {
                        ScaledVec::from_rats(&h.iter().map(|r| r[j].clone()).collect::<Vec<_>>())
                    })
                    .collect(),
                None => {
                    // Reusing the results as hints: divide out common content first so that
                    // repeated updates do not compound denominators.
                    for v in self.values.iter_mut() {
                        v.reduce_content();
                    }
                    self.values.clone()
                }
            };
            let lsq = self.lsq_for(&weights)?;
            for (j, col) in b_cols.iter().enumerate() {
                let b_hat =
                    ScaledVec::from_rats(&rows.iter().map(|&k| col[k].clone()).collect::<Vec<_>>());
                new_values.push(lsq.solve_scaled(&b_hat, &hint_cols[j]));
            }
        }
        self.anchor_values = anchor_values.to_vec();
        self.values = new_values;
        Ok(())
    }
}

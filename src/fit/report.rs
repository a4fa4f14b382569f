//! The text of a fit's report ([`FitReport`]): the one-line summary every fit prints, and
//! the warnings for a result that is not certified fold-free or whose landmarks cross.

use super::solve::FitReport;

/// A `det J` bound as text: three decimals, or two significant digits for a positive bound
/// below 0.001 (which three decimals would print as `0.000`, as if it were not positive).
///
/// ```
/// use trimorph::fit::report::det_text;
/// assert_eq!(det_text(0.5), "0.500");
/// assert_eq!(det_text(0.00042), "4.2e-4");
/// assert_eq!(det_text(-2.125), "-2.125");
/// ```
pub fn det_text(v: f64) -> String {
    if v > 0.0 && v < 1e-3 {
        format!("{v:.1e}")
    } else {
        format!("{v:.3}")
    }
}

impl FitReport {
    /// One line per fit: landmark residuals, held-out TRE, the bending weight (when chosen
    /// by cross-validation), `det J` (sampled and certified), the solver and its termination, and
    /// whether C1 holds exactly.
    pub fn summary_line(&self) -> String {
        let r = self;
        let mut s =
            format!("{} landmarks: rms {:.3} px, max {:.3} px", r.fit.count, r.fit.rms, r.fit.max);
        if let Some(h) = &r.holdout {
            s += &format!(
                "; held-out TRE rms {:.3} px, max {:.3} px ({})",
                h.tre.rms, h.tre.max, h.tre.count
            );
        }
        if r.bend_auto {
            s += &format!("; bend {:.2e} (auto", r.bend);
            if let Some(l) = r.loo_rms {
                s += &format!(", leave-one-out {l:.3} px");
            } else if let (Some(g), Some(c)) = (r.gcv_rms, r.bend_criterion) {
                s += &format!(", {} {g:.3} px", c.name());
            }
            s += ")";
        }
        s += &format!(
            "; min det J {:.3}{}, certified >= {}{}; {} ({} iterations, {}, {} variables) in \
             {:.1} ms; C1 exact: {}",
            r.min_det_j,
            if r.folds { " (FOLDS)" } else { "" },
            det_text(r.det_j_lower_bound),
            if r.fold_free { " (fold-free)" } else { "" },
            r.method,
            r.iterations,
            r.termination,
            r.variables,
            r.time_ms,
            if r.exact_c1 { "yes" } else { "NO" }
        );
        s
    }

    /// The warnings of a fit: landmark pairs that cross (a fold or a strong twist), and a result
    /// that folds or is not certified fold-free, with what to do (`barrier`: whether the
    /// fold barrier was on).
    pub fn warnings(&self, barrier: bool) -> Vec<String> {
        let mut out = Vec::new();
        if !self.conflicts.is_empty() {
            let pairs: Vec<String> =
                self.conflicts.iter().map(|[a, b]| format!("{a} and {b}")).collect();
            out.push(format!(
                "these landmark pairs cross (the targets reverse their order against the \
                 landmarks' affine map), which a fold-free map follows only by twisting \
                 strongly between them: {}; check or remove one of each pair",
                pairs.join(", ")
            ));
        }
        if self.fold_free {
            return out;
        }
        let what = if self.folds { "folds" } else { "is not certified fold-free" };
        let hint = if !barrier {
            "turn the fold barrier on (drop --no-barrier) or raise --bend"
        } else {
            "the landmarks demand a fold (crossing pairs?) or a very strong bend: check the \
             landmarks with the largest residuals, or raise --bend"
        };
        out.push(format!(
            "the fit {what} (sampled min det J {:.3}, certified lower bound {:.3}); {hint}",
            self.min_det_j, self.det_j_lower_bound
        ));
        out
    }
}

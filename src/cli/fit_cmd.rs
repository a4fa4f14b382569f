//! `trimorph fit DEF.json --landmarks L -o OUT.json`: one deformation fitted to landmarks.

use super::{Exit, EXIT_UNSOLVABLE};
use crate::fit::landmarks::{holdout, Landmark};
use crate::fit::objective::{Barrier, Loss};
use crate::fit::solve::{fit, with_holdout, FitError, FitOptions, FitReport};
use crate::io::landmarks::read_landmarks_noted;
use crate::io::{deformation, read_text, write_atomic};
use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::Path;

/// Solver options shared by the single and batch fits.
pub struct SolverArgs<'a> {
    pub loss: &'a str,
    pub loss_scale: f64,
    pub bend: f64,
    pub hard: bool,
    pub radius: Option<usize>,
    pub min_det: f64,
    pub no_barrier: bool,
    pub max_iters: u64,
}

impl SolverArgs<'_> {
    /// The library options.
    pub fn options(&self) -> Result<FitOptions> {
        let loss = match self.loss {
            "squares" | "l2" => Loss::Squares,
            "huber" => Loss::Huber(self.loss_scale),
            "cauchy" => Loss::Cauchy(self.loss_scale),
            other => bail!("--loss: unknown loss `{other}` (use squares, huber or cauchy)"),
        };
        if !(self.min_det.is_finite() && self.min_det < 1.0) {
            bail!("--min-det must be a number below 1");
        }
        let barrier = (!self.no_barrier).then_some(Barrier {
            floor: self.min_det,
            tau: self.min_det + 0.2,
            mu: 1.0,
        });
        Ok(FitOptions {
            loss,
            bend: self.bend,
            barrier,
            radius: self.radius,
            max_iters: self.max_iters,
            hard: self.hard,
            ..FitOptions::default()
        })
    }
}

/// Maps a fit error to the CLI's exit codes: unsolvable hard constraints exit 2.
pub fn fit_error(e: FitError) -> anyhow::Error {
    match e {
        FitError::Unsolvable(_)
        | FitError::Conflicting { .. }
        | FitError::TooManyConstraints { .. } => anyhow::Error::new(Exit {
            code: EXIT_UNSOLVABLE,
            message: e.to_string(),
            printed: false,
        }),
        other => anyhow::Error::new(other),
    }
}

/// Prefixes a fit error with the landmark file it is about (keeping the exit code).
fn in_landmarks(e: anyhow::Error, landmarks: &Path) -> anyhow::Error {
    let file = landmarks.display();
    match e.downcast::<Exit>() {
        Ok(x) => Exit { message: format!("{file}: {}", x.message), ..x }.into(),
        Err(e) => anyhow::anyhow!("{file}: {}", super::error_text(&e)),
    }
}

/// One line per fit.
pub fn summary(r: &FitReport) -> String {
    let mut s =
        format!("{} landmarks: rms {:.3} px, max {:.3} px", r.fit.count, r.fit.rms, r.fit.max);
    if let Some(h) = &r.holdout {
        s += &format!(
            "; held-out TRE rms {:.3} px, max {:.3} px ({})",
            h.tre.rms, h.tre.max, h.tre.count
        );
    }
    s += &format!(
        "; min det J {:.3}{}; {} ({} iterations, {} variables) in {:.1} ms; C1 exact: {}",
        r.min_det_j,
        if r.folds { " (FOLDS)" } else { "" },
        r.method,
        r.iterations,
        r.variables,
        r.time_ms,
        if r.exact_c1 { "yes" } else { "NO" }
    );
    s
}

/// `trimorph fit DEF --landmarks L -o OUT [--report R] [--holdout k]`.
#[allow(clippy::too_many_arguments)]
pub fn run_single(
    def: &Path,
    landmarks: &Path,
    output: &Path,
    report: Option<&Path>,
    holdout_k: usize,
    seed: u64,
    pin: Option<&str>,
    solver: &SolverArgs,
) -> Result<()> {
    let mut opts = solver.options()?;
    let text = read_text(def)?;
    let (s, _) = deformation::from_str(&text)
        .with_context(|| format!("cannot read deformation {}", def.display()))?;
    if let Some(list) = pin {
        opts.pinned = if list.trim() == "edited" {
            let p = deformation::pinned_from_str(&text)
                .with_context(|| format!("--pin edited: {}", def.display()))?;
            if p.is_empty() {
                bail!(
                    "--pin edited: {} records no corrected points (save it from the editor after an edit)",
                    def.display()
                );
            }
            p
        } else {
            list.split(',')
                .map(|t| {
                    t.trim().parse::<usize>().map_err(|_| {
                        anyhow::anyhow!("--pin: `{}` is not a control point index", t.trim())
                    })
                })
                .collect::<Result<_>>()?
        };
    }
    let (lms, notes) = read_landmarks_noted(landmarks)
        .with_context(|| format!("cannot read landmarks {}", landmarks.display()))?;
    if opts.hard {
        // Hard constraints hold for the decimals as written; say which ones an f64 changed.
        for n in &notes {
            eprintln!("warning: {}: {n}", landmarks.display());
        }
    }
    let (fitted, held): (Vec<Landmark>, Vec<Landmark>) = if holdout_k > 0 {
        if holdout_k >= lms.len() {
            bail!(
                "--holdout {holdout_k}: only {} landmarks, at least one must be fitted",
                lms.len()
            );
        }
        holdout(&lms, holdout_k, seed)?
    } else {
        (lms, Vec::new())
    };
    // A fit too large for the solver is the deformation's doing (its mesh and degree);
    // every other fit error is about the landmarks.
    let in_file = |e: FitError| match e {
        FitError::TooLarge { .. } => anyhow::anyhow!("{}: {e}", def.display()),
        e => in_landmarks(fit_error(e), landmarks),
    };
    let f = fit(&s, &fitted, &opts).map_err(in_file)?;
    let rep = with_holdout(f.report, &f.spline, &held).map_err(in_file)?;
    write_atomic(output, deformation::to_string(&f.spline, None).as_bytes())?;
    if let Some(r) = report {
        let text = serde_json::to_string_pretty(&rep)?;
        write_atomic(r, text.as_bytes())?;
    }
    writeln!(std::io::stdout(), "{}\n-> {}", summary(&rep), output.display())?;
    if rep.folds {
        eprintln!(
            "warning: the fit folds (min det J {:.3}); raise --bend or keep the barrier on",
            rep.min_det_j
        );
    }
    Ok(())
}

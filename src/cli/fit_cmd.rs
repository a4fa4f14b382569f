//! `trimorph fit DEF.json --landmarks L -o OUT.json`: one deformation fitted to landmarks.

use super::{Exit, EXIT_UNSOLVABLE};
use crate::fit::frame::{fit_frame, FrameFitOptions};
use crate::fit::landmarks::{holdout, Landmark};
use crate::fit::objective::{Barrier, Loss};
use crate::fit::solve::{fit, with_holdout, Bend, FitError, FitOptions, FitReport};
use crate::io::landmarks::read_landmarks_with_notes;
use crate::io::{deformation, read_text, write_atomic};
use crate::mesh::AdaptOptions;
use anyhow::{anyhow, bail, Context, Result};
use std::io::Write;
use std::path::Path;

/// Solver options shared by the single and batch fits.
pub struct SolverArgs<'a> {
    pub loss: &'a str,
    pub loss_scale: f64,
    pub bend: &'a str,
    pub hard: bool,
    pub radius: Option<usize>,
    pub min_det: f64,
    pub no_barrier: bool,
    pub max_iters: u64,
}

impl SolverArgs<'_> {
    /// The library options.
    pub fn options(&self) -> Result<FitOptions> {
        // The library's parsers, so the CLI and the library accept the same values.
        let loss =
            Loss::from_name(self.loss, self.loss_scale).map_err(|e| anyhow!("--loss: {e}"))?;
        let barrier = if self.no_barrier {
            None
        } else {
            Some(Barrier::with_floor(self.min_det).map_err(|e| anyhow!("--min-det: {e}"))?)
        };
        let bend: Bend = self.bend.parse().map_err(|e| anyhow!("--bend: {e}"))?;
        Ok(FitOptions {
            loss,
            bend,
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
        FitError::Conflicting { .. } | FitError::TooManyConstraints { .. } => {
            anyhow::Error::new(Exit {
                code: EXIT_UNSOLVABLE,
                message: e.to_string(),
                printed: false,
            })
        }
        other => anyhow::Error::new(other),
    }
}

/// Prefixes a fit error with the landmark file it is about (keeping the exit code).
fn in_landmarks(e: anyhow::Error, landmarks: &Path) -> anyhow::Error {
    let file = landmarks.display();
    match e.downcast::<Exit>() {
        Ok(x) => Exit { message: format!("{file}: {}", x.message), ..x }.into(),
        Err(e) => anyhow::anyhow!("{file}: {}", super::common::error_text(&e)),
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
    if r.bend_auto {
        s += &format!("; bend {:.2e} (auto", r.bend);
        if let Some(l) = r.loo_rms {
            s += &format!(", leave-one-out {l:.3} px");
        }
        s += ")";
    }
    s += &format!(
        "; min det J {:.3}{}, certified >= {:.3}{}; {} ({} iterations, {}, {} variables) in \
         {:.1} ms; C1 exact: {}",
        r.min_det_j,
        if r.folds { " (FOLDS)" } else { "" },
        r.det_j_lower_bound,
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

/// The frame of a fit with no deformation given.
pub struct FrameArgs<'a> {
    pub size: &'a str,
    pub margin: Option<f64>,
    pub max_edge: Option<f64>,
    pub min_angle: f64,
}

/// Where a single fit starts.
pub enum Start<'a> {
    /// A deformation file (its mesh is used).
    Deformation(&'a Path),
    /// A frame: the landmark-adapted mesh.
    Frame(&'a FrameArgs<'a>),
}

/// `trimorph fit (DEF | --size W,H) --landmarks L -o OUT [--report R] [--holdout k]`.
#[allow(clippy::too_many_arguments)]
pub fn run_single(
    start: Start,
    landmarks: &Path,
    output: &Path,
    report: Option<&Path>,
    holdout_k: usize,
    seed: u64,
    pin: Option<&str>,
    solver: &SolverArgs,
) -> Result<()> {
    let mut opts = solver.options()?;
    let def = match start {
        Start::Deformation(d) => d,
        Start::Frame(f) => {
            if pin.is_some() {
                bail!("--pin needs a deformation (DEF) whose control points it names");
            }
            return run_frame(f, landmarks, output, report, holdout_k, seed, opts);
        }
    };
    let text = read_text(def)?;
    let (s, _) = deformation::from_str(&text)
        .with_context(|| format!("cannot read deformation {}", def.display()))?;
    // Far points (a file translated by 1e160, say) lose every digit of their position in
    // f64, so the fit's system is singular; that is the file's doing, not the landmarks'.
    if let Some(what) = crate::server::doc::absurd_point(&s) {
        bail!(
            "{}: {what}, beyond {} pixels: the fit works in pixel coordinates; correct that point",
            def.display(),
            crate::server::doc::MAX_COORD
        );
    }
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
    let (fitted, held) = read_split(landmarks, holdout_k, seed, opts.hard)?;
    // A fit too large for the solver is the deformation's doing (its mesh and degree);
    // every other fit error is about the landmarks.
    let in_file = |e: FitError| match e {
        FitError::TooLarge { .. } => anyhow::anyhow!("{}: {e}", def.display()),
        // Options come from the command line, not from the landmark file: `--pin` names
        // the deformation's control points.
        FitError::Options(_) if pin.is_some() && e.to_string().contains("pinned") => {
            anyhow::anyhow!("--pin: {}: {e}", def.display())
        }
        FitError::Options(_) => anyhow::anyhow!("{e}"),
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
    warn_folds(&rep, &opts);
    Ok(())
}

/// The landmarks of a file, split into fitted and held-out ones.
/// With `hard`, the coordinates an `f64` cannot hold as written are reported on stderr (hard
/// constraints hold for the values used).
fn read_split(
    landmarks: &Path,
    k: usize,
    seed: u64,
    hard: bool,
) -> Result<(Vec<Landmark>, Vec<Landmark>)> {
    let (lms, notes) = read_landmarks_with_notes(landmarks)
        .with_context(|| format!("cannot read landmarks {}", landmarks.display()))?;
    if let Some(z) = &notes.constant_z {
        eprintln!("warning: {}: {z}", landmarks.display());
    }
    if hard {
        for n in &notes.approximations {
            eprintln!("warning: {}: {n}", landmarks.display());
        }
    }
    if k == 0 {
        return Ok((lms, Vec::new()));
    }
    if k >= lms.len() {
        bail!("--holdout {k}: only {} landmarks, at least one must be fitted", lms.len());
    }
    Ok(holdout(&lms, k, seed)?)
}

/// Warns on stderr when a fit is not certified fold-free, with what to do, and names the
/// landmark pairs that cross.
fn warn_folds(rep: &FitReport, opts: &FitOptions) {
    if !rep.conflicts.is_empty() {
        let pairs: Vec<String> =
            rep.conflicts.iter().map(|[a, b]| format!("{a} and {b}")).collect();
        eprintln!(
            "warning: these landmark pairs cross (the targets reverse their order), which \
             demands a fold between them: {}; check or remove one of each pair",
            pairs.join(", ")
        );
    }
    if rep.fold_free {
        return;
    }
    let what = if rep.folds { "folds" } else { "is not certified fold-free" };
    let hint = if opts.barrier.is_none() {
        "turn the fold barrier on (drop --no-barrier) or raise --bend"
    } else {
        "the landmarks demand a fold (crossing pairs?) or a very strong bend: check the \
         landmarks with the largest residuals, or raise --bend"
    };
    eprintln!(
        "warning: the fit {what} (sampled min det J {:.3}, certified lower bound {:.3}); {hint}",
        rep.min_det_j, rep.det_j_lower_bound
    );
}

/// `trimorph fit --size W,H --landmarks L -o OUT`: a fit over the landmark-adapted mesh.
#[allow(clippy::too_many_arguments)]
fn run_frame(
    f: &FrameArgs,
    landmarks: &Path,
    output: &Path,
    report: Option<&Path>,
    holdout_k: usize,
    seed: u64,
    opts: FitOptions,
) -> Result<()> {
    let size = super::common::parse_frame_size(f.size)?;
    let (fitted, held) = read_split(landmarks, holdout_k, seed, opts.hard)?;
    let fopts = FrameFitOptions {
        mesh: AdaptOptions {
            margin: f.margin,
            max_edge: f.max_edge,
            min_angle: f.min_angle,
            grid: 0,
            extra_points: Vec::new(),
        },
        degree: 5,
        fit: opts.clone(),
    };
    let r = fit_frame(&fitted, size, &fopts).map_err(|e| in_landmarks(fit_error(e), landmarks))?;
    let rep = with_holdout(r.fit.report, &r.fit.spline, &held)
        .map_err(|e| in_landmarks(fit_error(e), landmarks))?;
    write_atomic(output, deformation::to_string(&r.fit.spline, None).as_bytes())?;
    if let Some(path) = report {
        let mut v = serde_json::to_value(&rep)?;
        v["frame"] = serde_json::to_value(&r.frame)?;
        write_atomic(path, serde_json::to_string_pretty(&v)?.as_bytes())?;
    }
    writeln!(
        std::io::stdout(),
        "adapted mesh: {} vertices, {} triangles ({} added by refinement), margin {} px, grid \
         1/{}; covers the frame: {}\n{}\n-> {}",
        r.frame.vertices,
        r.frame.triangles,
        r.frame.steiner,
        r.frame.margin,
        r.frame.grid,
        if r.frame.covers_frame { "yes (certified)" } else { "not certified" },
        summary(&rep),
        output.display()
    )?;
    warn_folds(&rep, &opts);
    Ok(())
}

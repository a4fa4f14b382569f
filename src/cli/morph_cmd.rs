//! `trimorph morph A B --landmarks L.csv --frames N -o DIR`: frames, animations, contact sheet,
//! and the fitted deformations `phi_ab.json` (A's pixels -> B's pixels) and `phi_ba.json`
//! (B's pixels -> A's pixels), readable by `--phi-ab` / `--phi-ba`.

use super::args::MorphCli;
use super::common::progress_bar;
use crate::fit::FitOptions;
use crate::io::landmarks::LandmarkSource;
use crate::io::raster::read_stack;
use crate::io::{deformation, read_text};
use crate::jobs::morph::{check_frames, write_morph, MorphFileOptions};
use crate::morph::align::{Similarity, SIMILARITY_KEY};
use crate::morph::fits::{MISS_TOLERANCE, PIN_PREFIX};
use crate::morph::{Morph, MorphOptions};
use crate::spline::Spline;
use crate::timing::Phases;
use anyhow::{anyhow, bail, Context, Result};
use image::DynamicImage;
use std::path::Path;

fn first_page(path: &Path, which: &str) -> Result<DynamicImage> {
    let stack = read_stack(path)
        .with_context(|| format!("cannot read image {which} {}", path.display()))?;
    stack.pages.into_iter().next().ok_or_else(|| anyhow!("image {which} has no pages"))
}

/// Runs the command.
pub fn run(a: &MorphCli) -> Result<()> {
    let mut ph = Phases::new();
    check_frames(a.frames)?;
    let (shape, color, interp) = (a.shape, a.color, a.interp);
    let align = !a.no_align;
    let (img_a, img_b) = rayon::join(|| first_page(&a.a, "A"), || first_page(&a.b, "B"));
    let (img_a, img_b) = (img_a?, img_b?);
    ph.mark("read");
    crate::morph::check_cells(a.cells)?;
    crate::morph::check_background(a.background, &img_a, &img_b)?;
    let opts = MorphOptions {
        shape,
        color,
        interp,
        cells: a.cells,
        align,
        background: a.background,
        pin_frame: a.pin_frame,
        mode: a.mode,
        ..MorphOptions::default()
    };
    let opts = MorphOptions {
        fit: FitOptions { bend: a.bend.unwrap_or(opts.fit.bend), hard: a.hard, ..opts.fit.clone() },
        ..opts
    };
    let load = |p: &Path| -> Result<Spline> {
        let (s, _) = deformation::from_str(&read_text(p)?)
            .with_context(|| format!("cannot read deformation {}", p.display()))?;
        Ok(s)
    };
    let source = match (&a.landmarks, &a.landmarks_src, &a.landmarks_dst) {
        (Some(l), _, _) => Some(LandmarkSource::File(l.clone())),
        (None, Some(src), Some(dst)) => {
            Some(LandmarkSource::Pair { src: src.clone(), dst: dst.clone() })
        }
        _ => None,
    };
    let morph = match (&source, &a.phi_ab) {
        (Some(l), _) => {
            let lms = l.read().with_context(|| format!("cannot read landmarks {l}"))?;
            let m = Morph::new(&img_a, &img_b, &lms, &opts)
                .with_context(|| format!("landmarks {l}"))?;
            if let (Some([ab, ba]), false) = (m.fit_summaries(), a.quiet) {
                for (dir, f) in [("A->B", ab), ("B->A", ba)] {
                    eprintln!(
                        "fit {dir}: {} triangles, margin {} px, largest residual {:.3} px, \
                         certified fold-free (det J >= {}){}",
                        f.triangles,
                        f.margin,
                        f.max_residual,
                        crate::fit::report::det_text(f.det_j_lower_bound),
                        if f.covers_frame { ", covers A's frame" } else { "" }
                    );
                    let real: Vec<&(String, f64)> =
                        f.misses.iter().filter(|(n, _)| !n.starts_with(PIN_PREFIX)).collect();
                    if !real.is_empty() && f.conflicts.is_empty() {
                        let shown: Vec<String> = real
                            .iter()
                            .take(5)
                            .map(|(n, r)| format!("{n} ({r:.2} px)"))
                            .collect();
                        eprintln!(
                            "warning: fit {dir}: {} landmark(s) missed by more than \
                             {MISS_TOLERANCE} px: {}{}; the fits interpolate unless --bend \
                             smooths them or meeting them exactly would fold the map (the fold \
                             barrier keeps it fold-free); check them, or use --hard to force \
                             them (refused if the map then folds)",
                            real.len(),
                            shown.join(", "),
                            if real.len() > 5 { ", ..." } else { "" }
                        );
                    }
                    if !f.conflicts.is_empty() {
                        let pairs: Vec<String> =
                            f.conflicts.iter().map(|[x, y]| format!("{x} and {y}")).collect();
                        eprintln!(
                            "warning: fit {dir}: these landmark pairs cross, so following them \
                             would fold the map; the morph stays fold-free and misses them \
                             (largest residual {:.2} px): {}",
                            f.max_residual,
                            pairs.join(", ")
                        );
                    }
                }
            }
            m
        }
        (None, Some(p)) => {
            let text = read_text(p)?;
            let (phi_ab, _) = deformation::from_str(&text)
                .with_context(|| format!("cannot read deformation {}", p.display()))?;
            let stored = if align { stored_similarity(&text, p)? } else { None };
            let phi_ba = a.phi_ba.as_deref().map(load).transpose()?;
            let given = stored.is_some();
            let m = Morph::from_deformations_with(&img_a, &img_b, phi_ab, phi_ba, stored, &opts)?;
            if given && !a.quiet {
                eprintln!("similarity read from {} ({SIMILARITY_KEY})", p.display());
            }
            let cov = m.coverage();
            if cov < 1.0 && !a.quiet {
                eprintln!(
                    "note: {} covers {:.1}% of A; the rest of A has no preimage in any frame",
                    p.display(),
                    100.0 * cov
                );
            }
            m
        }
        (None, None) => bail!(
            "give --landmarks L.csv, --landmarks-src A.pts --landmarks-dst B.pts, or --phi-ab DEF.json"
        ),
    };
    if !a.quiet {
        if align {
            eprintln!("B aligned to A by the similarity: {}", morph.similarity());
        } else {
            eprintln!("B kept in its raw pixel coordinates (--no-align)");
        }
    }
    ph.mark("fits");
    let files = MorphFileOptions {
        output: a.output.clone(),
        gif: a.gif.clone(),
        apng: a.apng.clone(),
        frames: a.frames,
        range: a.range,
        preview: a.preview,
        background: a.background,
        delay_ms: a.delay,
    };
    let bar = progress_bar(a.frames as u64, !a.quiet, "morph");
    let rep = write_morph(&morph, &files, &|| bar.inc(1))?;
    bar.finish_and_clear();
    for &(name, ms) in &rep.phases {
        ph.add(name, ms);
    }
    if !a.quiet {
        if rep.uncovered > 0 {
            eprintln!(
                "note: {} pixels over all frames have a preimage in neither image \
                 (they show --background)",
                rep.uncovered
            );
        }
        if !rep.uncertified.is_empty() {
            let ts: Vec<String> = rep.uncertified.iter().map(|t| format!("{t:.3}")).collect();
            eprintln!(
                "warning: the blended maps are not certified fold-free at t = {}",
                ts.join(", ")
            );
        }
    }
    if a.timings {
        eprintln!(
            "inverse maps: {} pixels solved by per-pixel Newton over all frames",
            rep.newton_solves
        );
    }
    if a.timings {
        eprintln!("timings (ms): {}", ph.line());
    }
    if !a.quiet {
        let residual = if source.is_some() {
            format!("; largest landmark fit residual {:.3} px", rep.largest_residual)
        } else {
            String::new()
        };
        eprintln!(
            "{} frames ({} x {}) in {}; {}, {}, {}{}",
            a.frames,
            morph.image_a().width(),
            morph.image_a().height(),
            a.output.display(),
            rep.gif.display(),
            rep.apng.display(),
            rep.sheet.display(),
            residual
        );
    }
    Ok(())
}

/// The similarity stored in a deformation file's [`SIMILARITY_KEY`], if it has one.
fn stored_similarity(text: &str, path: &Path) -> Result<Option<Similarity>> {
    let doc: serde_json::Value = serde_json::from_str(text)
        .with_context(|| format!("cannot read deformation {}", path.display()))?;
    doc.get(SIMILARITY_KEY)
        .map(Similarity::from_json)
        .transpose()
        .with_context(|| format!("{}: key {SIMILARITY_KEY}", path.display()))
}

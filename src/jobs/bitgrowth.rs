//! The bit-size study of the fraction-free LDU factors (thesis ch. 7, figs. 7.1-7.10) as
//! files (`trimorph bench bitgrowth`): `bitgrowth.csv` and one line plot `<id>.png` per
//! experiment ([`crate::exact::bitgrowth`], [`crate::render::plot`]).

use super::OptionError;
use super::{JobError, JobResult};
use crate::exact::bitgrowth::{experiments, run, to_csv, Point};
use crate::exact::Simplification;
use crate::io::write_atomic;
use crate::render::plot::{LinePlot, Series};
use std::path::Path;

/// What [`write_bitgrowth`] tells as it goes.
#[derive(Clone, Debug)]
pub enum StudyLog {
    /// An experiment's run time (`ID: N points in S s`).
    Timing(String),
    /// A result line: per experiment and method the mean bits at each x, then the files.
    Line(String),
}

fn color(m: Simplification) -> [u8; 3] {
    match m {
        Simplification::None => [214, 39, 40],
        Simplification::Gcd => [31, 119, 180],
        Simplification::Turner => [44, 160, 44],
    }
}

/// The most random matrices per point `--trials` takes.
pub const MAX_TRIALS: usize = 10_000;

/// Runs the experiments whose id contains `only` (all without it; fewer x values with
/// `quick`), `trials` random matrices per point from `seed`, and writes `bitgrowth.csv` and
/// one `<id>.png` per experiment into `dir`. `log` hears the timings and result lines; its
/// first error stops the study ([`JobError::Output`]).
pub fn write_bitgrowth(
    dir: &Path,
    trials: usize,
    quick: bool,
    seed: u64,
    only: Option<&str>,
    log: &mut dyn FnMut(StudyLog) -> std::io::Result<()>,
) -> JobResult<()> {
    if trials == 0 {
        return Err(OptionError::OutOfRange { flag: "--trials", rule: "must be at least 1" }.into());
    }
    // Each trial's factors are kept per point (4,294,967,295 trials asked for 103 GB).
    if trials > MAX_TRIALS {
        return Err(OptionError::OutOfRange {
            flag: "--trials",
            rule:
                "must be at most 10000 (the thesis's figures use 20; the mean settles long before)",
        }
        .into());
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| JobError::context(format!("cannot create {}", dir.display()), e))?;
    let exps: Vec<_> =
        experiments(quick).into_iter().filter(|e| only.is_none_or(|o| e.id.contains(o))).collect();
    if exps.is_empty() {
        return Err(OptionError::NoExperiment(only.unwrap_or_default().to_string()).into());
    }
    let mut log = |l: StudyLog| log(l).map_err(JobError::Output);
    let mut all: Vec<Point> = Vec::new();
    for exp in &exps {
        let t0 = std::time::Instant::now();
        let pts = run(exp, trials, seed);
        log(StudyLog::Timing(format!(
            "{}: {} points in {:.1} s",
            exp.id,
            pts.len(),
            t0.elapsed().as_secs_f64()
        )))?;
        let mut plot = LinePlot::new(exp.title, exp.x_label, "largest bit size of L, D, U");
        plot.log_y = exp.methods.contains(&Simplification::None);
        for &m in &exp.methods {
            let points =
                pts.iter().filter(|p| p.method == m).map(|p| (p.x as f64, p.mean_bits)).collect();
            plot.series.push(Series {
                label: format!("{m} (mean of {trials})"),
                points,
                color: color(m),
            });
        }
        let png = dir.join(format!("{}.png", exp.id));
        plot.save_png(&png)
            .map_err(|e| JobError::context(format!("cannot write {}", png.display()), e))?;
        for m in &exp.methods {
            let line: Vec<String> = pts
                .iter()
                .filter(|p| p.method == *m)
                .map(|p| format!("{}:{:.0}", p.x, p.mean_bits))
                .collect();
            log(StudyLog::Line(format!(
                "{} {:>6}  x:bits  {}",
                exp.id,
                m.to_string(),
                line.join(" ")
            )))?;
        }
        all.extend(pts);
    }
    let csv = dir.join("bitgrowth.csv");
    write_atomic(&csv, to_csv(&all).as_bytes())?;
    log(StudyLog::Line(format!(
        "wrote {} and {} plots in {}",
        csv.display(),
        exps.len(),
        dir.display()
    )))
}

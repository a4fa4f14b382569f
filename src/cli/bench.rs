//! `trimorph bench bitgrowth`: the ch. 7 bit-size study, written as CSV and PNG plots.

use crate::exact::bitgrowth::{experiments, run, to_csv, Point};
use crate::exact::Simplification;
use crate::io::write_atomic;
use crate::render::plot::{LinePlot, Series};
use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::Path;

fn color(m: Simplification) -> [u8; 3] {
    match m {
        Simplification::None => [214, 39, 40],
        Simplification::Gcd => [31, 119, 180],
        Simplification::Turner => [44, 160, 44],
    }
}

/// Runs the experiments and writes `bitgrowth.csv` and one `<id>.png` per experiment.
pub fn bitgrowth(
    dir: &Path,
    trials: usize,
    quick: bool,
    seed: u64,
    only: Option<&str>,
) -> Result<()> {
    if trials == 0 {
        bail!("--trials must be at least 1");
    }
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let exps: Vec<_> =
        experiments(quick).into_iter().filter(|e| only.is_none_or(|o| e.id.contains(o))).collect();
    if exps.is_empty() {
        bail!("no experiment id contains {:?}", only.unwrap_or_default());
    }
    let mut all: Vec<Point> = Vec::new();
    for exp in &exps {
        let t0 = std::time::Instant::now();
        let pts = run(exp, trials, seed);
        eprintln!("{}: {} points in {:.1} s", exp.id, pts.len(), t0.elapsed().as_secs_f64());
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
        plot.save_png(&png).with_context(|| format!("cannot write {}", png.display()))?;
        for m in &exp.methods {
            let line: Vec<String> = pts
                .iter()
                .filter(|p| p.method == *m)
                .map(|p| format!("{}:{:.0}", p.x, p.mean_bits))
                .collect();
            writeln!(
                std::io::stdout(),
                "{} {:>6}  x:bits  {}",
                exp.id,
                m.to_string(),
                line.join(" ")
            )?;
        }
        all.extend(pts);
    }
    let csv = dir.join("bitgrowth.csv");
    write_atomic(&csv, to_csv(&all).as_bytes())?;
    writeln!(
        std::io::stdout(),
        "wrote {} and {} plots in {}",
        csv.display(),
        exps.len(),
        dir.display()
    )?;
    Ok(())
}

//! `trimorph bench bitgrowth`: the ch. 7 bit-size study ([`crate::jobs::bitgrowth`]).

use crate::jobs::bitgrowth::{write_bitgrowth, StudyLog};
use crate::jobs::JobError;
use anyhow::Result;
use std::io::Write;
use std::path::Path;

/// Runs the experiments and writes `bitgrowth.csv` and one `<id>.png` per experiment.
pub fn bitgrowth(
    dir: &Path,
    trials: usize,
    quick: bool,
    seed: u64,
    only: Option<&str>,
) -> Result<()> {
    let mut log = |l: StudyLog| match l {
        StudyLog::Timing(t) => writeln!(std::io::stderr(), "{t}"),
        StudyLog::Line(l) => writeln!(std::io::stdout(), "{l}"),
    };
    write_bitgrowth(dir, trials, quick, seed, only, &mut log).map_err(|e| match e {
        // A closed pipe is reported as the I/O error it is (`exit_code` maps it to 0).
        JobError::Output(e) => anyhow::Error::from(e),
        e => anyhow::Error::from(e),
    })
}

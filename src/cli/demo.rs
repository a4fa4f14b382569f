//! `trimorph demo`: the main job on bundled data ([`crate::jobs::demo`], which writes the
//! folder and the report lines; this layer hands it the process's streams).

use crate::jobs::JobError;
use anyhow::Result;
use std::path::Path;

/// Runs the demo, writing into `dir`.
pub fn run(dir: &Path) -> Result<()> {
    let (mut out, mut err) = (std::io::stdout(), std::io::stderr());
    crate::jobs::demo::run_demo(dir, &mut out, &mut err).map_err(|e| match e {
        // A closed pipe is reported as the I/O error it is (`exit_code` maps it to 0).
        JobError::Output(e) => anyhow::Error::from(e),
        e => anyhow::Error::from(e),
    })
}

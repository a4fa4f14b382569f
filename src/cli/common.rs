//! What every subcommand shares: the exit codes and the [`Exit`] error, the mapping of a
//! command's result to the process exit code, the progress bar, and the value parsers of
//! options that several subcommands take (sizes `W,H`, shards `i/n`, memory sizes).

use anyhow::{anyhow, bail, Result};

/// Exit code for bad input and I/O errors.
pub const EXIT_INPUT: i32 = 1;
/// Exit code for an edit that is not solvable.
pub const EXIT_UNSOLVABLE: i32 = 2;

/// An error that maps to a specific exit code.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct Exit {
    /// Process exit code.
    pub code: i32,
    /// Human-readable text (already printed when `printed`).
    pub message: String,
    /// Whether the message was already written to stderr.
    pub printed: bool,
}

/// The error and its causes joined by ": ", skipping a cause whose text the message already
/// holds (many errors print their source themselves).
pub(super) fn error_text(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for c in e.chain().skip(1) {
        let t = c.to_string();
        if !msg.contains(&t) {
            msg += ": ";
            msg += &t;
        }
    }
    msg
}

/// Prints a command-line parse failure (or `--help` / `--version`) and returns its exit code:
/// 0 for `--help` and `--version`, [`EXIT_INPUT`] for a malformed or missing command line. clap's own default
/// (2) would be mistaken for [`EXIT_UNSOLVABLE`] by scripts.
pub(super) fn usage_exit(e: &clap::Error) -> i32 {
    // Printing can fail only on a closed stream; the exit code is what matters then.
    let _ = e.print();
    // clap prints help and version to stdout and errors (including bare `trimorph`) to stderr.
    if e.use_stderr() {
        EXIT_INPUT
    } else {
        0
    }
}

/// Maps a command's result to the process exit code, printing the error.
pub(super) fn exit_code(result: anyhow::Result<()>) -> i32 {
    match result {
        Ok(()) => 0,
        Err(e) => match e.downcast_ref::<Exit>() {
            Some(x) => {
                if !x.printed {
                    eprintln!("error: {}", x.message);
                }
                x.code
            }
            None => {
                // A closed pipe (`trimorph ... | head`) is not an error of ours.
                if let Some(io) = e.downcast_ref::<std::io::Error>() {
                    if io.kind() == std::io::ErrorKind::BrokenPipe {
                        return 0;
                    }
                }
                eprintln!("error: {}", error_text(&e));
                EXIT_INPUT
            }
        },
    }
}

/// `--max-memory SIZE` (e.g. 4G, 512M), through [`crate::memory::parse_size`].
pub(super) fn parse_memory(s: &str) -> Result<u64, String> {
    crate::memory::parse_size(s).map_err(|e| e.to_string())
}

/// Writes `text` and a newline to stdout; unlike `println!` a closed pipe is an error
/// (mapped to exit 0 by [`exit_code`]), not a panic.
pub fn say(text: impl std::fmt::Display) -> std::io::Result<()> {
    use std::io::Write;
    writeln!(std::io::stdout(), "{text}")
}

/// A progress bar on stderr for `len` units of work, drawn only when `show` and stderr is a
/// terminal (indicatif hides it otherwise).
pub fn progress_bar(len: u64, show: bool, what: &str) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {percent}% ({eta} left)")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}

/// Two finite numbers `A<sep>B` (e.g. `640,480` or `6x4`); errors name the option `what`.
pub fn pair(text: &str, what: &str, sep: char) -> Result<(f64, f64)> {
    let (a, b) = text
        .split_once(sep)
        .ok_or_else(|| anyhow!("{what}: expected two numbers as A{sep}B, found `{text}`"))?;
    let (a, b): (f64, f64) = (
        a.trim().parse().map_err(|_| anyhow!("{what}: `{a}` is not a number"))?,
        b.trim().parse().map_err(|_| anyhow!("{what}: `{b}` is not a number"))?,
    );
    if !a.is_finite() || !b.is_finite() {
        bail!("{what}: values must be finite");
    }
    Ok((a, b))
}

/// A frame size `W,H` in whole pixels (1 to 1,000,000 each): `mesh --landmarks`, `fit --size`.
pub fn parse_frame_size(text: &str) -> Result<[f64; 2]> {
    let (w, h) = pair(text, "--size", ',')?;
    if w < 1.0 || h < 1.0 || w > 1e6 || h > 1e6 || w.fract() != 0.0 || h.fract() != 0.0 {
        bail!("--size: width and height must be whole numbers of pixels from 1 to 1000000");
    }
    Ok([w, h])
}

/// The width and height of a drawn canvas `W,H`, whole numbers from 16 to 16384 (`render`).
pub fn parse_canvas_size(text: &str) -> Result<(u32, u32)> {
    let (w, h) = pair(text, "--size", ',')?;
    if w < 16.0 || h < 16.0 || w > 16384.0 || h > 16384.0 || w.fract() != 0.0 || h.fract() != 0.0 {
        bail!("--size: width and height must be whole numbers from 16 to 16384");
    }
    Ok((w as u32, h as u32))
}

/// A raster size `W,H` in whole pixels (`field --size`, `warp --mesh --size`); the limits are
/// checked by the job with [`crate::jobs::raster_fits`], whose message names the file.
pub fn parse_raster_size(text: &str) -> Result<(u32, u32)> {
    let (a, b) = text.split_once(',').ok_or_else(|| anyhow!("--size: expected W,H"))?;
    Ok((
        a.trim().parse().map_err(|_| anyhow!("--size: `{a}` is not a whole number"))?,
        b.trim().parse().map_err(|_| anyhow!("--size: `{b}` is not a whole number"))?,
    ))
}

/// `i/n` -> `(i, n)` with `0 <= i < n` (`fit --shard`).
pub fn parse_shard(spec: &str) -> Result<(usize, usize)> {
    spec.split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse::<usize>().ok()?, n.trim().parse::<usize>().ok()?)))
        .filter(|&(i, n)| n >= 1 && i < n)
        .ok_or_else(|| anyhow!("--shard: expected i/n with 0 <= i < n, e.g. 0/4"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::sequence::shard_range;

    #[test]
    fn shards_cover_every_frame_once() {
        for n in 1..7 {
            let mut next = 0;
            for i in 0..n {
                let (i, n) = parse_shard(&format!("{i}/{n}")).unwrap();
                let (lo, hi) = shard_range(i, n, 10);
                assert_eq!(lo, next);
                next = hi;
            }
            assert_eq!(next, 10);
        }
        assert!(parse_shard("3/3").is_err());
        assert!(parse_shard("x").is_err());
    }

    #[test]
    fn sizes_keep_their_limits() {
        assert_eq!(parse_frame_size("640,480").unwrap(), [640.0, 480.0]);
        assert!(parse_frame_size("0,480").is_err());
        assert!(parse_frame_size("1.5,2").is_err());
        assert_eq!(parse_canvas_size("800,600").unwrap(), (800, 600));
        assert!(parse_canvas_size("15,600").is_err());
        assert_eq!(parse_raster_size("0,0").unwrap(), (0, 0));
        use crate::jobs::raster_fits;
        assert!(!raster_fits(0, 0) && raster_fits(10_000, 10_000) && !raster_fits(10_001, 10_000));
        assert!(parse_raster_size("12").is_err() && parse_raster_size("a,2").is_err());
    }
}

/// A command-line choice mirroring a library enum: clap lists and checks the values
/// (`[possible values: ...]` in the help, an error naming the option otherwise).
macro_rules! choice {
    ($(#[$doc:meta])* $name:ident => $lib:ty { $($v:ident = $lv:expr),+ $(,)? }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
        pub enum $name {
            $(
                #[allow(missing_docs)]
                $v,
            )+
        }
        impl From<$name> for $lib {
            fn from(c: $name) -> $lib {
                match c {
                    $($name::$v => $lv,)+
                }
            }
        }
    };
}

choice!(
    /// `--interp`: image resampling.
    InterpArg => crate::warp::Interp {
        Nearest = crate::warp::Interp::Nearest,
        Bilinear = crate::warp::Interp::Bilinear,
        Bicubic = crate::warp::Interp::Bicubic,
    }
);
choice!(
    /// `--shape` / `--color`: a morph schedule.
    ScheduleArg => crate::morph::Schedule {
        Linear = crate::morph::Schedule::Linear,
        Smooth = crate::morph::Schedule::Smooth,
    }
);
choice!(
    /// `--view`: the picture of a model.
    ViewArg => crate::render::model::View {
        Top = crate::render::model::View::Top,
        Oblique = crate::render::model::View::Oblique,
    }
);

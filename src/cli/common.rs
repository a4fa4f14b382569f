//! What every subcommand shares: the exit codes and the [`Exit`] error, the mapping of a
//! command's result to the process exit code, the progress bar, and the value parsers of
//! options whose values are not a plain number or path (sizes `W,H` and their limits,
//! grids, shards `i/n`, time ranges, memory sizes), with [`TextParser`], which hands clap a
//! library type's parser (e.g. [`crate::prism::ZRange`] for `--z-range`,
//! [`crate::jobs::model::AutoGrid`] for `model bind --grid`) and words a refused value
//! `--flag: reason`.

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
/// (2) would be mistaken for [`EXIT_UNSOLVABLE`] by scripts. A value refused by a
/// [`TextParser`] is printed as `error: --flag: reason`.
pub(super) fn usage_exit(e: &clap::Error) -> i32 {
    use std::error::Error as _;
    if e.kind() == clap::error::ErrorKind::ValueValidation {
        if let Some(bad) = e.source().and_then(|s| s.downcast_ref::<BadValue>()) {
            eprintln!("error: {bad}");
            return EXIT_INPUT;
        }
    }
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

/// A boxed error: why a [`TextParser`] refused a value.
pub(super) type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// An option value refused by its parser: printed `--flag: reason` (see [`usage_exit`]), the
/// way the command line words every bad option.
#[derive(Debug, thiserror::Error)]
#[error("{flag}: {reason}")]
pub(super) struct BadValue {
    /// The option, e.g. `--size`.
    flag: String,
    /// Why its value was refused.
    #[source]
    reason: BoxError,
}

/// What a [`TextParser`] calls.
type ParseFn<T> = dyn Fn(&str) -> Result<T, BoxError> + Send + Sync;

/// A clap value parser from a function of the text (usually a library type's `FromStr`):
/// the typed value reaches the command, and a refused value is a [`BadValue`] naming the
/// option. Choices list their names in `--help` (`[possible values: ...]`).
#[derive(Clone)]
pub(super) struct TextParser<T> {
    parse: std::sync::Arc<ParseFn<T>>,
    names: &'static [&'static str],
}

/// A [`TextParser`] through `parse`.
pub(super) fn text<T: 'static, E>(parse: fn(&str) -> Result<T, E>) -> TextParser<T>
where
    E: Into<BoxError> + 'static,
{
    TextParser { parse: std::sync::Arc::new(move |t| parse(t).map_err(Into::into)), names: &[] }
}

/// A [`TextParser`] of a closed choice through `T`'s `FromStr`, listing `names` in the help.
pub(super) fn choice<T>(names: &'static [&'static str]) -> TextParser<T>
where
    T: std::str::FromStr + 'static,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    TextParser { parse: std::sync::Arc::new(|t| t.parse::<T>().map_err(Into::into)), names }
}

impl<T: Clone + Send + Sync + 'static> clap::builder::TypedValueParser for TextParser<T> {
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<T, clap::Error> {
        let flag = arg.and_then(|a| a.get_long()).map(|l| format!("--{l}")).unwrap_or_default();
        let parse = self.parse.clone();
        clap::builder::StringValueParser::new()
            .try_map(move |t| parse(&t).map_err(|reason| BadValue { flag: flag.clone(), reason }))
            .parse_ref(cmd, arg, value)
    }

    fn possible_values(
        &self,
    ) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        if self.names.is_empty() {
            return None;
        }
        Some(Box::new(self.names.iter().map(|&n| clap::builder::PossibleValue::new(n))))
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

/// Two finite numbers `A<sep>B` (e.g. `640,480` or `6x4`); the error says what is wrong with
/// the text (a [`TextParser`] names the option).
fn pair(text: &str, sep: char) -> Result<(f64, f64), String> {
    let (a, b) = text
        .split_once(sep)
        .ok_or_else(|| format!("expected two numbers as A{sep}B, found `{text}`"))?;
    let (a, b): (f64, f64) = (
        a.trim().parse().map_err(|_| format!("`{a}` is not a number"))?,
        b.trim().parse().map_err(|_| format!("`{b}` is not a number"))?,
    );
    if !a.is_finite() || !b.is_finite() {
        return Err("values must be finite".into());
    }
    Ok((a, b))
}

/// Smallest side of a frame ([`parse_frame_size`]): one whole pixel.
pub const MIN_FRAME_SIDE: f64 = 1.0;
/// Largest side of a frame ([`parse_frame_size`]): 10^6 pixels, beyond any camera or
/// microscope frame, so that a typo (an extra digit or two) is refused before the
/// landmark-adapted mesh is built over it.
pub const MAX_FRAME_SIDE: f64 = 1e6;
/// Largest number of cells of `mesh --grid` ([`parse_grid`]): the mesh has two triangles
/// per cell, and a spline of degree 5 over 2 * 10^6 triangles is already beyond memory.
pub const MAX_GRID_CELLS: f64 = 1e6;

/// A frame size `W,H` in whole pixels, [`MIN_FRAME_SIDE`] to [`MAX_FRAME_SIDE`] each:
/// `fit --size`, and `mesh --size` with `--landmarks` (through [`check_frame_size`]).
pub fn parse_frame_size(text: &str) -> Result<[f64; 2], String> {
    let (w, h) = pair(text, ',')?;
    check_frame_size([w, h])
}

/// `size` if it is a frame size ([`parse_frame_size`]'s limits).
pub fn check_frame_size([w, h]: [f64; 2]) -> Result<[f64; 2], String> {
    let side = |v: f64| (MIN_FRAME_SIDE..=MAX_FRAME_SIDE).contains(&v) && v.fract() == 0.0;
    if !side(w) || !side(h) {
        return Err("width and height must be whole numbers of pixels from 1 to 1000000".into());
    }
    Ok([w, h])
}

/// The size `W,H` that a reference mesh covers (`mesh --size`): two finite numbers. Its
/// limits depend on the mesh: with `--grid` [`check_extent`], with `--landmarks`
/// [`check_frame_size`].
pub fn parse_extent(text: &str) -> Result<[f64; 2], String> {
    let (w, h) = pair(text, ',')?;
    Ok([w, h])
}

/// `size` if both sides are above 0 (`mesh --grid`: no upper limit, the mesh is a grid of
/// `--grid` cells whatever their size).
pub fn check_extent([w, h]: [f64; 2]) -> Result<[f64; 2], String> {
    if w <= 0.0 || h <= 0.0 {
        return Err("width and height must be positive".into());
    }
    Ok([w, h])
}

/// The cells `COLSxROWS` of `mesh --grid`: whole numbers from 1, at most [`MAX_GRID_CELLS`]
/// cells in all.
pub fn parse_grid(text: &str) -> Result<(usize, usize), String> {
    let (c, r) = pair(text, 'x')?;
    if c < 1.0 || r < 1.0 || c.fract() != 0.0 || r.fract() != 0.0 || c * r > MAX_GRID_CELLS {
        return Err("expected COLSxROWS with whole numbers of cells, e.g. 6x4".into());
    }
    Ok((c as usize, r as usize))
}

/// The width and height of a drawn canvas `W,H`, whole numbers from
/// [`MIN_SIZE`](crate::render::deformation::MIN_SIZE) to
/// [`MAX_SIZE`](crate::render::deformation::MAX_SIZE) (16 to 16384, the limits of the
/// renderer): `render --size`, with or without `--model`.
pub fn parse_canvas_size(text: &str) -> Result<(u32, u32), String> {
    use crate::render::deformation::{MAX_SIZE, MIN_SIZE};
    let (w, h) = pair(text, ',')?;
    let side = |v: f64| (MIN_SIZE as f64..=MAX_SIZE as f64).contains(&v) && v.fract() == 0.0;
    if !side(w) || !side(h) {
        return Err(format!(
            "width and height must be whole numbers from {MIN_SIZE} to {MAX_SIZE}"
        ));
    }
    Ok((w as u32, h as u32))
}

/// A raster size `W,H` in whole pixels: `field --size` and `warp --mesh --size`. Only the
/// form is checked here; the limits (not empty, at most
/// [`MAX_RASTER_PIXELS`](crate::jobs::MAX_RASTER_PIXELS)) are the job's, checked with
/// [`crate::jobs::raster_fits`], whose message names the file (the library refuses the same
/// sizes whoever calls it).
pub fn parse_raster_size(text: &str) -> Result<(u32, u32), String> {
    let (a, b) = text.split_once(',').ok_or("expected W,H")?;
    Ok((
        a.trim().parse().map_err(|_| format!("`{a}` is not a whole number"))?,
        b.trim().parse().map_err(|_| format!("`{b}` is not a whole number"))?,
    ))
}

/// The times `T0,T1` of the first and last frame of `morph --range`: two finite numbers,
/// each within [`MAX_TIME`](crate::render::morph_files::MAX_TIME) of 0 (the limit is the
/// library's, [`check_range`](crate::render::morph_files::check_range)).
pub fn parse_time_range(text: &str) -> Result<(f64, f64), String> {
    use crate::render::morph_files::{check_range, MAX_TIME};
    let range =
        pair(text, ',').map_err(|_| format!("expected T0,T1 (two numbers), got `{text}`"))?;
    // Far outside 0..1 the blended control points overflow f64 and the warp never ends.
    check_range(range)
        .map_err(|_| format!("times must lie within -{MAX_TIME}..{MAX_TIME}, got `{text}`"))?;
    Ok(range)
}

/// `i/n` -> `(i, n)` with `0 <= i < n` (`fit --shard`).
pub fn parse_shard(spec: &str) -> Result<(usize, usize), String> {
    spec.split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse::<usize>().ok()?, n.trim().parse::<usize>().ok()?)))
        .filter(|&(i, n)| n >= 1 && i < n)
        .ok_or_else(|| "expected i/n with 0 <= i < n, e.g. 0/4".into())
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
        assert_eq!(parse_time_range(" -0.25, 1.25").unwrap(), (-0.25, 1.25));
        assert_eq!(parse_time_range("0").unwrap_err(), "expected T0,T1 (two numbers), got `0`");
        assert_eq!(
            parse_time_range("0,101").unwrap_err(),
            "times must lie within -100..100, got `0,101`"
        );
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

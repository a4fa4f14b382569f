//! The text forms of option values that are not a plain number or path, with their limits in
//! one place: frame sizes `W,H`, mesh extents, grids `COLSxROWS`, canvas and raster sizes,
//! time ranges `T0,T1` and shards `i/n`. The command line hands these parsers to clap (a
//! refused value prints as `--flag: reason`); a library user can call them on any text.
//!
//! Every parser refuses non-finite numbers. The limits are the library's own: a frame side
//! is [`MIN_FRAME_SIDE`]..=[`MAX_FRAME_SIDE`] whole pixels, a grid has at most
//! [`crate::mesh::MAX_GRID_CELLS`] cells, a canvas side is
//! [`MIN_SIZE`](crate::render::deformation::MIN_SIZE)..=[`MAX_SIZE`](crate::render::deformation::MAX_SIZE),
//! times lie within [`MAX_TIME`](crate::jobs::morph::MAX_TIME) of 0, and a raster's
//! area is checked by the job ([`super::raster_fits`]).
//!
//! ```
//! use trimorph::jobs::values::{parse_frame_size, parse_grid, parse_shard};
//! assert_eq!(parse_frame_size("640,480").unwrap(), [640.0, 480.0]);
//! assert_eq!(parse_grid("6x4").unwrap(), (6, 4));
//! assert_eq!(parse_shard("1/4").unwrap(), (1, 4));
//! assert!(parse_frame_size("0,480").is_err());
//! ```

use crate::jobs::morph::{check_range, MAX_TIME};
use crate::render::deformation::{MAX_SIZE, MIN_SIZE};

/// Smallest side of a frame ([`parse_frame_size`]): one whole pixel.
pub const MIN_FRAME_SIDE: f64 = 1.0;
/// Largest side of a frame ([`parse_frame_size`]): 10^6 pixels, beyond any camera or
/// microscope frame, so that a typo (an extra digit or two) is refused before the
/// landmark-adapted mesh is built over it.
pub const MAX_FRAME_SIDE: f64 = 1e6;

/// Why an option's text was refused. The text says what is wrong with the value; the
/// command line puts the option's flag in front.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ValueError {
    /// Not two items `A<sep>B`.
    #[error("expected two numbers as A{sep}B, found `{text}`")]
    NotAPair {
        /// The separator expected, `,` or `x`.
        sep: char,
        /// The text given.
        text: String,
    },
    /// An item that is not a number.
    #[error("`{0}` is not a number")]
    NotANumber(String),
    /// An item that is not a whole number (raster sizes).
    #[error("`{0}` is not a whole number")]
    NotAWholeNumber(String),
    /// A raster size without its comma.
    #[error("expected W,H")]
    NotASize,
    /// An infinite or NaN number.
    #[error("values must be finite")]
    NotFinite,
    /// A frame side outside [`MIN_FRAME_SIDE`]..=[`MAX_FRAME_SIDE`] or not whole.
    #[error("width and height must be whole numbers of pixels from 1 to 1000000")]
    FrameSide,
    /// A mesh extent that is not positive.
    #[error("width and height must be positive")]
    Extent,
    /// A grid that is not whole numbers of cells from 1.
    #[error("expected COLSxROWS with whole numbers of cells, e.g. 6x4")]
    Grid,
    /// A grid of whole numbers with too many cells (issue 54: it was refused as a format
    /// error).
    #[error(
        "a grid of {cols} x {rows} cells is too large (at most {max} cells in all, e.g. 1000x1000); use fewer cells",
        max = crate::mesh::MAX_GRID_CELLS
    )]
    GridTooLarge {
        /// Columns asked for.
        cols: f64,
        /// Rows asked for.
        rows: f64,
    },
    /// A canvas side outside the renderer's limits.
    #[error("width and height must be whole numbers from {MIN_SIZE} to {MAX_SIZE}")]
    CanvasSide,
    /// A time range that is not two numbers.
    #[error("expected T0,T1 (two numbers), got `{0}`")]
    NotATimeRange(String),
    /// Times too far from 0.
    #[error("times must lie within -{MAX_TIME}..{MAX_TIME}, got `{0}`")]
    TimesOutOfRange(String),
    /// A spacing that is not positive.
    #[error("a spacing is two positive numbers SX,SY (the distance between pixel centres)")]
    Spacing,
    /// Not a shard `i/n` with `0 <= i < n`.
    #[error("expected i/n with 0 <= i < n, e.g. 0/4")]
    Shard,
}

/// Two finite numbers `A<sep>B` (e.g. `640,480` or `6x4`).
pub fn parse_pair(text: &str, sep: char) -> Result<(f64, f64), ValueError> {
    let (a, b) =
        text.split_once(sep).ok_or_else(|| ValueError::NotAPair { sep, text: text.into() })?;
    let number = |s: &str| s.trim().parse::<f64>().map_err(|_| ValueError::NotANumber(s.into()));
    let (a, b) = (number(a)?, number(b)?);
    if !a.is_finite() || !b.is_finite() {
        return Err(ValueError::NotFinite);
    }
    Ok((a, b))
}

/// A sample value (`--background` of `warp`, `morph` and `fit --frames`): a finite number.
/// Whether the image's type holds it is [`crate::warp::check_background`]'s rule, checked
/// once the type is known.
///
/// ```
/// use trimorph::jobs::values::parse_sample;
/// assert_eq!(parse_sample("12.5").unwrap(), 12.5);
/// assert!(parse_sample("nan").is_err() && parse_sample("1e400").is_err());
/// ```
pub fn parse_sample(text: &str) -> Result<f64, ValueError> {
    let v = text.trim().parse::<f64>().map_err(|_| ValueError::NotANumber(text.into()))?;
    if !v.is_finite() {
        return Err(ValueError::NotFinite);
    }
    Ok(v)
}

/// A pixel spacing `SX,SY`: two positive finite numbers (`field --spacing`).
pub fn parse_spacing(text: &str) -> Result<[f64; 2], ValueError> {
    let (x, y) = parse_pair(text, ',')?;
    if x <= 0.0 || y <= 0.0 {
        return Err(ValueError::Spacing);
    }
    Ok([x, y])
}

/// A physical origin `OX,OY`: two finite numbers (`field --origin`).
pub fn parse_origin(text: &str) -> Result<[f64; 2], ValueError> {
    let (x, y) = parse_pair(text, ',')?;
    Ok([x, y])
}

/// A frame size `W,H` in whole pixels, [`MIN_FRAME_SIDE`] to [`MAX_FRAME_SIDE`] each:
/// `fit --size`, and `mesh --size` with `--landmarks` (through [`check_frame_size`]).
pub fn parse_frame_size(text: &str) -> Result<[f64; 2], ValueError> {
    let (w, h) = parse_pair(text, ',')?;
    check_frame_size([w, h])
}

/// `size` if it is a frame size ([`parse_frame_size`]'s limits).
pub fn check_frame_size([w, h]: [f64; 2]) -> Result<[f64; 2], ValueError> {
    let side = |v: f64| (MIN_FRAME_SIDE..=MAX_FRAME_SIDE).contains(&v) && v.fract() == 0.0;
    if !side(w) || !side(h) {
        return Err(ValueError::FrameSide);
    }
    Ok([w, h])
}

/// The size `W,H` that a reference mesh covers (`mesh --size`): two finite numbers. Its
/// limits depend on the mesh: with `--grid` [`check_extent`], with `--landmarks`
/// [`check_frame_size`].
pub fn parse_extent(text: &str) -> Result<[f64; 2], ValueError> {
    let (w, h) = parse_pair(text, ',')?;
    Ok([w, h])
}

/// `size` if both sides are above 0 (`mesh --grid`: no upper limit, the mesh is a grid of
/// `--grid` cells whatever their size).
pub fn check_extent([w, h]: [f64; 2]) -> Result<[f64; 2], ValueError> {
    if w <= 0.0 || h <= 0.0 {
        return Err(ValueError::Extent);
    }
    Ok([w, h])
}

/// The cells `COLSxROWS` of `mesh --grid`: whole numbers from 1, at most
/// [`crate::mesh::MAX_GRID_CELLS`] cells in all (the limit of the grid builder).
pub fn parse_grid(text: &str) -> Result<(usize, usize), ValueError> {
    let (c, r) = parse_pair(text, 'x')?;
    let max = crate::mesh::MAX_GRID_CELLS as f64;
    if c < 1.0 || r < 1.0 || c.fract() != 0.0 || r.fract() != 0.0 {
        return Err(ValueError::Grid);
    }
    if c * r > max {
        return Err(ValueError::GridTooLarge { cols: c, rows: r });
    }
    Ok((c as usize, r as usize))
}

/// The width and height of a drawn canvas `W,H`, whole numbers from [`MIN_SIZE`] to
/// [`MAX_SIZE`] (16 to 16384, the limits of the renderer): `render --size`, with or without
/// `--model`.
pub fn parse_canvas_size(text: &str) -> Result<(u32, u32), ValueError> {
    let (w, h) = parse_pair(text, ',')?;
    let side = |v: f64| (MIN_SIZE as f64..=MAX_SIZE as f64).contains(&v) && v.fract() == 0.0;
    if !side(w) || !side(h) {
        return Err(ValueError::CanvasSide);
    }
    Ok((w as u32, h as u32))
}

/// A raster size `W,H` in whole pixels: `field --size` and `warp --mesh --size`. Only the
/// form is checked here; the limits (not empty, at most [`super::MAX_RASTER_PIXELS`]) are
/// the job's, checked with [`super::raster_fits`], whose message names the file (the
/// library refuses the same sizes whoever calls it).
pub fn parse_raster_size(text: &str) -> Result<(u32, u32), ValueError> {
    let (a, b) = text.split_once(',').ok_or(ValueError::NotASize)?;
    let whole = |s: &str| s.trim().parse().map_err(|_| ValueError::NotAWholeNumber(s.into()));
    Ok((whole(a)?, whole(b)?))
}

/// The times `T0,T1` of the first and last frame of `morph --range`: two finite numbers,
/// each within [`MAX_TIME`] of 0 (the limit is the library's, [`check_range`]).
pub fn parse_time_range(text: &str) -> Result<(f64, f64), ValueError> {
    let range = parse_pair(text, ',').map_err(|_| ValueError::NotATimeRange(text.into()))?;
    // Far outside 0..1 the blended control points overflow f64 and the warp never ends.
    check_range(range).map_err(|_| ValueError::TimesOutOfRange(text.into()))?;
    Ok(range)
}

/// `i/n` -> `(i, n)` with `0 <= i < n` (`fit --shard`; the frames of a shard are
/// [`crate::fit::sequence::shard_range`]).
pub fn parse_shard(spec: &str) -> Result<(usize, usize), ValueError> {
    spec.split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse::<usize>().ok()?, n.trim().parse::<usize>().ok()?)))
        .filter(|&(i, n)| n >= 1 && i < n)
        .ok_or(ValueError::Shard)
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
        assert_eq!(
            parse_time_range("0").unwrap_err().to_string(),
            "expected T0,T1 (two numbers), got `0`"
        );
        assert_eq!(
            parse_time_range("0,101").unwrap_err().to_string(),
            "times must lie within -100..100, got `0,101`"
        );
    }

    #[test]
    fn grids_share_the_builder_s_cell_limit() {
        assert_eq!(parse_grid("1000x1000").unwrap(), (1000, 1000));
        assert_eq!(
            parse_grid("1001x1000"),
            Err(ValueError::GridTooLarge { cols: 1001.0, rows: 1000.0 })
        );
        assert_eq!(parse_grid("0x3"), Err(ValueError::Grid));
        assert_eq!(parse_grid("2.5x3"), Err(ValueError::Grid));
        assert_eq!(
            parse_grid("6,4").unwrap_err().to_string(),
            "expected two numbers as AxB, found `6,4`"
        );
        assert_eq!(parse_extent("3,inf"), Err(ValueError::NotFinite));
        assert_eq!(parse_extent("3,q").unwrap_err().to_string(), "`q` is not a number");
        assert_eq!(check_extent([0.0, 1.0]), Err(ValueError::Extent));
    }
}

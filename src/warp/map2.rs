//! Any map of the plane, resampled like a spline: the [`Map2`] trait.
//!
//! A [`Map2`] is a map `m: R^2 -> R^2` in pixels (x to the right, y down, pixel `(i, j)`
//! centred at `(i, j)`, as everywhere in [`crate::warp`]): its value `m(p)` (`None` outside
//! its domain), its Jacobian `Dm(p) = [[dm_x/dx, dm_x/dy], [dm_y/dx, dm_y/dy]]`, and, where
//! the map can say, its inverse `m^-1(q)`. Points are [`Point`]s, the translation of an
//! affine map a [`Vector`] (inner loops keep `[f64; 2]` arrays; the types convert for free). The spline deformation ([`Spline`]), an affine
//! map ([`AffineMap`]) and the baselines of the tests (a thin-plate spline) implement it, so
//! they are resampled by the same code:
//!
//! * [`pull_back_map`]: `R(p) = F(m(p))` on a `w x h` grid (only `m` is evaluated; the
//!   registration direction of [`super::pullback`], and of OpenCV's `remap` and ITK's
//!   resampler, whose transforms also map output to input points);
//! * [`warp_map`]: `O(q) = I(m^-1(q))`, the direction of [`super::warp_image`] (a feature at
//!   `p` appears at `m(p)`), for maps with an inverse.
//!
//! Background rules, types and resampling kernels are those of [`super::pullback`] and
//! [`super::sample`]. The spline-specific paths ([`super::warp_image`], [`super::pull_back`])
//! stay the fast way for splines (band-wise certified interpolation of the inverse, located
//! rows); these generic paths evaluate the map once per pixel, in parallel rows.

use super::pullback::in_frame;
use super::sample::Texel;
use super::{fill, rebuild, source, Buf, EdgeMode, Interp, Src, WarpError};
use crate::geom::{Mat2, Point, Vector};
use crate::spline::Spline;
use image::DynamicImage;
use rayon::prelude::*;

/// A map of the plane in pixels (see the module docs).
pub trait Map2: Sync {
    /// `m(p)`, or `None` where `p` is outside the map's domain.
    fn value(&self, p: Point) -> Option<Point>;

    /// The Jacobian `[[dm_x/dx, dm_x/dy], [dm_y/dx, dm_y/dy]]` at `p` (`None` outside).
    fn jacobian(&self, p: Point) -> Option<Mat2>;

    /// `m^-1(q)` when the map provides it and `q` has a preimage; `None` otherwise (the
    /// default: no inverse).
    fn inverse(&self, q: Point) -> Option<Point> {
        let _ = q;
        None
    }

    /// Whether [`Map2::inverse`] is provided at all ([`warp_map`] refuses maps without it).
    fn has_inverse(&self) -> bool {
        false
    }
}

/// The spline deformation `phi` on its mesh. The inverse is not provided here: build a
/// [`super::inverse::InverseMap`] once (it implements [`Map2`] with the inverse) instead of
/// one per point.
impl Map2 for Spline {
    fn value(&self, p: Point) -> Option<Point> {
        let (t, b) = self.mesh().locate(p.to_array(), None)?;
        Some(self.eval_cache().value(t, b).into())
    }

    fn jacobian(&self, p: Point) -> Option<Mat2> {
        let (t, b) = self.mesh().locate(p.to_array(), None)?;
        Some(self.eval_cache().jacobian(t, b))
    }
}

/// `phi` with its inverse: Newton's method from the map's buckets, polished to machine
/// precision ([`super::inverse::InverseMap::polish`]), as [`super::inverse()`] does.
impl Map2 for super::inverse::InverseMap<'_> {
    fn value(&self, p: Point) -> Option<Point> {
        self.spline().value(p)
    }

    fn jacobian(&self, p: Point) -> Option<Mat2> {
        self.spline().jacobian(p)
    }

    fn inverse(&self, q: Point) -> Option<Point> {
        let q = q.to_array();
        self.invert(q, None).map(|r| self.polish(q, r).p.into())
    }

    fn has_inverse(&self) -> bool {
        true
    }
}

/// An affine map `p -> a p + b` of the whole plane (`a` row-major).
///
/// ```
/// use trimorph::geom::{Point, Vector};
/// use trimorph::warp::{AffineMap, Map2};
/// let m = AffineMap { a: [[0.0, -1.0], [1.0, 0.0]], b: Vector::new(10.0, 0.0) };
/// let q = m.apply(Point::new(1.0, 2.0));
/// assert_eq!(q, Point::new(8.0, 1.0));
/// assert_eq!(m.inverse(q), Some(Point::new(1.0, 2.0)));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AffineMap {
    /// The linear part: `a[r][c]`.
    pub a: Mat2,
    /// The translation.
    pub b: Vector,
}

impl AffineMap {
    /// `a p + b`.
    pub fn apply(&self, p: Point) -> Point {
        Point::ORIGIN + crate::geom::mat_vec(&self.a, p.to_vector()) + self.b
    }

    /// The inverse map, `None` when `det a` is 0 or not finite.
    pub fn inverted(&self) -> Option<AffineMap> {
        let a = &self.a;
        let det = crate::geom::det(a);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = [[a[1][1] / det, -a[0][1] / det], [-a[1][0] / det, a[0][0] / det]];
        let b = -crate::geom::mat_vec(&inv, self.b);
        Some(AffineMap { a: inv, b })
    }
}

impl Map2 for AffineMap {
    fn value(&self, p: Point) -> Option<Point> {
        Some(self.apply(p))
    }

    fn jacobian(&self, _p: Point) -> Option<Mat2> {
        Some(self.a)
    }

    fn inverse(&self, q: Point) -> Option<Point> {
        self.inverted().map(|m| m.apply(q))
    }

    fn has_inverse(&self) -> bool {
        self.inverted().is_some()
    }
}

/// Resamples `src` at `pos(x, y)` for every pixel of a `w x h` output, row by row in
/// parallel; `NaN` positions get the background.
fn resample<T: Texel + Default>(
    src: &super::sample::Source<'_, T>,
    (w, h): (usize, usize),
    interp: Interp,
    background: f64,
    pos: &(dyn Fn(f64, f64) -> Option<[f64; 2]> + Sync),
) -> Vec<T> {
    let nc = src.nc;
    let mut out = vec![T::default(); w * h * nc];
    // One position buffer per worker, reused for every row it fills.
    out.par_chunks_mut((w * nc).max(1)).enumerate().for_each_init(
        || Vec::with_capacity(w),
        |at: &mut Vec<[f64; 2]>, (y, row)| {
            at.clear();
            at.extend((0..w).map(|x| in_frame(pos(x as f64, y as f64), src.w, src.h)));
            // Positions are limited to the frame's pixel squares (`in_frame`): beyond, the
            // background; within the outer half pixel, the edge pixels.
            fill(src, at, row, interp, background, EdgeMode::Edge);
        },
    );
    out
}

fn resample_image(
    img: &DynamicImage,
    w: u32,
    h: u32,
    interp: Interp,
    background: f64,
    pos: &(dyn Fn(f64, f64) -> Option<[f64; 2]> + Sync),
) -> Result<DynamicImage, WarpError> {
    let size = (w as usize, h as usize);
    let bytes = u64::from(img.color().bytes_per_pixel()) * u64::from(w) * u64::from(h);
    crate::memory::check(bytes, || format!("resampling into {w} x {h} {:?}", img.color()))?;
    let buf = match source(img)? {
        Src::U8(src) => Buf::U8(resample(&src, size, interp, background, pos)),
        Src::U16(src) => Buf::U16(resample(&src, size, interp, background, pos)),
        Src::F32(src) => Buf::F32(resample(&src, size, interp, background, pos)),
    };
    Ok(rebuild(img, w, h, buf))
}

/// `R(p) = F(m(p))` on a `w x h` grid, with the frame's type and channels; `background`
/// (in the frame's sample units) where `m(p)` is undefined or leaves the frame (outside the
/// union of its pixel squares, as in [`super::pullback`]).
pub fn pull_back_map<M: Map2 + ?Sized>(
    map: &M,
    frame: &DynamicImage,
    w: u32,
    h: u32,
    interp: Interp,
    background: f64,
) -> Result<DynamicImage, WarpError> {
    resample_image(frame, w, h, interp, background, &|x, y| {
        map.value(Point::new(x, y)).map(Point::to_array)
    })
}

/// `O(q) = I(m^-1(q))`, the size and type of `img` ([`super::warp_image`]'s direction);
/// `background` where `q` has no preimage or the preimage leaves the image. Maps without an
/// inverse ([`Map2::has_inverse`]) are refused with [`WarpError::NoInverse`].
pub fn warp_map<M: Map2 + ?Sized>(
    map: &M,
    img: &DynamicImage,
    interp: Interp,
    background: f64,
) -> Result<DynamicImage, WarpError> {
    if !map.has_inverse() {
        return Err(WarpError::NoInverse);
    }
    resample_image(img, img.width(), img.height(), interp, background, &|x, y| {
        map.inverse(Point::new(x, y)).map(Point::to_array)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Mesh, MeshOptions};

    fn ramp(w: u32, h: u32) -> DynamicImage {
        DynamicImage::ImageLuma16(image::ImageBuffer::from_fn(w, h, |x, y| {
            image::Luma([(x * 300 + y * 7) as u16])
        }))
    }

    /// A shift by whole pixels, warped through the generic path, moves the pixels exactly.
    #[test]
    fn an_affine_shift_moves_pixels_exactly_both_ways() {
        let img = ramp(20, 12);
        let shift = AffineMap { a: [[1.0, 0.0], [0.0, 1.0]], b: Vector::new(3.0, -2.0) };
        let out = warp_map(&shift, &img, Interp::Bilinear, 0.0).unwrap().into_luma16();
        let back = pull_back_map(&shift, &img, 20, 12, Interp::Bilinear, 0.0).unwrap();
        let (src, back) = (img.to_luma16(), back.into_luma16());
        for y in 0..12u32 {
            for x in 0..20u32 {
                // O(q) = I(q - b); R(p) = I(p + b).
                let o = src.get_pixel_checked(x.wrapping_sub(3), y + 2).map_or(0, |p| p[0]);
                assert_eq!(out.get_pixel(x, y)[0], o, "warp at ({x}, {y})");
                let r = src.get_pixel_checked(x + 3, y.wrapping_sub(2)).map_or(0, |p| p[0]);
                assert_eq!(back.get_pixel(x, y)[0], r, "pull back at ({x}, {y})");
            }
        }
    }

    /// The affine map's inverse and Jacobian are its own; a singular one has no inverse.
    #[test]
    fn affine_inverse_and_jacobian() {
        let m = AffineMap { a: [[2.0, 1.0], [-0.5, 1.5]], b: Vector::new(4.0, -1.0) };
        let p = Point::new(3.25, -7.5);
        let q = m.value(p).unwrap();
        let back = m.inverse(q).unwrap();
        assert!(back.distance(p) < 1e-12);
        assert_eq!(m.jacobian(p), Some(m.a));
        let flat = AffineMap { a: [[1.0, 2.0], [2.0, 4.0]], b: Vector::ZERO };
        assert!(!flat.has_inverse());
        let img = ramp(4, 4);
        assert!(matches!(warp_map(&flat, &img, Interp::Nearest, 0.0), Err(WarpError::NoInverse)));
    }

    /// The spline through the generic paths agrees with its own fast paths: pull back within
    /// one 16-bit level (point location without row hints may pick the other triangle of an
    /// edge, which changes the last bits of the position), warp within the inverse's 0.01 px
    /// tolerance times the ramp's slope (300 levels per pixel) plus one level.
    #[test]
    fn the_spline_through_the_generic_path_matches_its_own_paths() {
        let mesh = Mesh::grid(4, 3, 19.0, 11.0, MeshOptions::default()).unwrap();
        let s = super::super::tests::dragged(mesh, 1, 1);
        let img = ramp(20, 12);
        let fast =
            super::super::pullback::pull_back(&s, &img, 20, 12, Interp::Bilinear, 0.0).unwrap();
        let generic = pull_back_map(&s, &img, 20, 12, Interp::Bilinear, 0.0).unwrap();
        let (a, b) = (fast.into_luma16(), generic.into_luma16());
        assert!(a.pixels().zip(b.pixels()).all(|(x, y)| x[0].abs_diff(y[0]) <= 1));
        let opts = super::super::inverse::InverseOptions::default();
        let (fast, _) = super::super::warp_image(&s, &img, Interp::Bilinear, 0.0, opts).unwrap();
        let inv = super::super::inverse::InverseMap::new(&s, opts);
        let generic = warp_map(&inv, &img, Interp::Bilinear, 0.0).unwrap();
        let (a, b) = (fast.into_luma16(), generic.into_luma16());
        assert!(a.pixels().zip(b.pixels()).all(|(x, y)| x[0].abs_diff(y[0]) <= 4));
        assert!(s.jacobian(Point::new(9.5, 5.5)).is_some());
        assert!(s.value(Point::new(-5.0, 0.0)).is_none());
    }
}

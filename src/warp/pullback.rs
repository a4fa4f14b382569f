//! Registering a frame back to the reference: `R(p) = F(phi(p))`.
//!
//! A deformation fitted to a frame maps reference points `p` (mesh coordinates = reference
//! pixels) to frame pixels `phi(p)`. Sampling the frame there pulls it back onto the
//! reference, so frames fitted to one reference all line up with it (and with each other).
//! Only `phi` itself is evaluated (no inverse). Pixel `(i, j)` is centred at `(i, j)`, as
//! everywhere in [`crate::warp`].
//!
//! **Background.** A reference pixel `p` gets the background value (every colour channel;
//! alpha 0) when `p` is outside the mesh, or when `phi(p)` leaves the frame, i.e. lies
//! outside the union of the frame's pixel squares, `[-1/2, fw - 1/2] x [-1/2, fh - 1/2]`.
//! Inside that rectangle the resampling kernels of [`super::sample`] are used unchanged
//! (within half a pixel of the border they read the border pixel, which is that pixel's own
//! square); beyond it nothing of the frame is known, so edge pixels are not smeared out.
//!
//! **Types.** [`pull_back`] keeps the frame's type and channels: 8- and 16-bit gray,
//! gray+alpha, RGB, RGBA and 32-bit float RGB(A), like [`super::warp_pages`].

#[cfg(test)]
use super::sample::fill_pixels;
use super::sample::{Source, Texel};
use super::{fill, rebuild, source, Buf, EdgeMode, Interp, Src, WarpError};
use crate::spline::Spline;
use image::DynamicImage;
use rayon::prelude::*;

/// `phi` at the reference pixels of row `y` (`w` of them); `NaN` where the pixel is outside
/// the mesh or its image lies outside the `fw x fh` frame (see the module docs).
fn mapped_row(s: &Spline, y: usize, w: usize, fw: usize, fh: usize) -> Vec<[f64; 2]> {
    let mut hint = None;
    (0..w)
        .map(|x| {
            let q = s.mesh().locate([x as f64, y as f64], hint).map(|(t, b)| {
                hint = Some(t);
                s.eval_cache().value(t, b)
            });
            in_frame(q, fw, fh)
        })
        .collect()
}

/// `q` when it lies in the union of the `fw x fh` frame's pixel squares,
/// `[-1/2, fw - 1/2] x [-1/2, fh - 1/2]`; `NaN` (the background) when it does not or is
/// `None` (see the module docs).
pub(super) fn in_frame(q: Option<[f64; 2]>, fw: usize, fh: usize) -> [f64; 2] {
    let (xmax, ymax) = (fw as f64 - 0.5, fh as f64 - 0.5);
    match q {
        Some(q) if q[0] >= -0.5 && q[0] <= xmax && q[1] >= -0.5 && q[1] <= ymax => q,
        _ => [f64::NAN, f64::NAN],
    }
}

fn pull<T: Texel + Default>(
    s: &Spline,
    src: &Source<'_, T>,
    w: usize,
    h: usize,
    interp: Interp,
    background: f64,
) -> Vec<T> {
    let nc = src.nc;
    let mut out = vec![T::default(); w * h * nc];
    out.par_chunks_mut((w * nc).max(1)).enumerate().for_each(|(y, row)| {
        let pos = mapped_row(s, y, w, src.w, src.h);
        // Positions are limited to the frame's pixel squares (`in_frame`): beyond, the
        // background; within the outer half pixel, the edge pixels.
        fill(src, &pos, row, interp, background, EdgeMode::Edge);
    });
    out
}

/// The frame pulled back onto a `w x h` reference grid through `phi`, with the frame's type
/// and channels; `background` (in the frame's sample units) outside the mesh and where
/// `phi` leaves the frame (see the module docs).
pub fn pull_back(
    s: &Spline,
    frame: &DynamicImage,
    w: u32,
    h: u32,
    interp: Interp,
    background: f64,
) -> Result<DynamicImage, WarpError> {
    let (wu, hu) = (w as usize, h as usize);
    let buf = match source(frame)? {
        Src::U8(src) => Buf::U8(pull(s, &src, wu, hu, interp, background)),
        Src::U16(src) => Buf::U16(pull(s, &src, wu, hu, interp, background)),
        Src::F32(src) => Buf::F32(pull(s, &src, wu, hu, interp, background)),
    };
    Ok(rebuild(frame, w, h, buf))
}

/// The 8-bit gray frame `frame` (`fw x fh`, row-major) pulled back onto a `w x h` reference
/// grid through `phi`, with bilinear sampling and `background` outside (as [`pull_back`]).
#[cfg(test)]
pub fn pull_back_gray8(
    s: &Spline,
    frame: &[u8],
    fw: usize,
    fh: usize,
    w: usize,
    h: usize,
    background: u8,
) -> Vec<u8> {
    assert_eq!(frame.len(), fw * fh, "frame size");
    let src = Source { data: frame, w: fw, h: fh, nc: 1 };
    let mut out = vec![0u8; w * h];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        let pos = mapped_row(s, y, w, fw, fh);
        fill_pixels::<u8, 1>(&src, &pos, row, Interp::Bilinear, background as f64);
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Mesh, MeshOptions};
    use image::{ImageBuffer, Luma, Rgb};

    #[test]
    fn identity_pull_back_reproduces_the_frame_inside_the_mesh() {
        let mesh = Mesh::grid(2, 2, 20.0, 10.0, MeshOptions::default()).unwrap();
        let s = Spline::identity(mesh, 5).unwrap();
        let frame: Vec<u8> = (0..30 * 16).map(|i| (i * 7 % 251) as u8).collect();
        let out = pull_back_gray8(&s, &frame, 30, 16, 30, 16, 9);
        for y in 0..16 {
            for x in 0..30 {
                let want = if x <= 20 && y <= 10 { frame[y * 30 + x] } else { 9 };
                assert_eq!(out[y * 30 + x], want, "({x}, {y})");
            }
        }
    }

    /// Bug (issue 16): where `phi` left the frame, the pull-back clamped to the frame's
    /// edge pixels and smeared them over the reference instead of showing the background.
    #[test]
    fn where_phi_leaves_the_frame_the_background_is_shown_not_the_edge() {
        // The mesh covers 40 x 20; the frame is only 30 x 20, so reference pixels with
        // x > 29.5 map (identity) beyond its right edge.
        let mesh = Mesh::grid(2, 2, 40.0, 20.0, MeshOptions::default()).unwrap();
        let s = Spline::identity(mesh, 5).unwrap();
        let frame = ImageBuffer::from_fn(30, 20, |x, y| Luma([1000u16 + (x * 20 + y) as u16]));
        let frame = DynamicImage::ImageLuma16(frame);
        let out = pull_back(&s, &frame, 41, 21, Interp::Bilinear, 7.0).unwrap();
        let DynamicImage::ImageLuma16(g) = &out else { panic!("16-bit gray in, {out:?} out") };
        assert_eq!(g.dimensions(), (41, 21));
        for y in 0..21 {
            for x in 0..41 {
                let want = if x < 30 && y < 20 { 1000 + (x * 20 + y) as u16 } else { 7 };
                assert_eq!(g.get_pixel(x, y)[0], want, "({x}, {y})");
            }
        }
        // The 8-bit path agrees.
        let f8: Vec<u8> = (0..30 * 20).map(|i| (i % 200) as u8).collect();
        let o8 = pull_back_gray8(&s, &f8, 30, 20, 41, 21, 3);
        assert_eq!(o8[10 * 41 + 35], 3);
        assert_eq!(o8[10 * 41 + 29], f8[10 * 30 + 29]);
    }

    #[test]
    fn every_type_keeps_its_type_and_channels() {
        let mesh = Mesh::grid(2, 2, 10.0, 10.0, MeshOptions::default()).unwrap();
        let s = Spline::identity(mesh, 5).unwrap();
        let rgb = ImageBuffer::from_fn(11, 11, |x, y| Rgb([x as u8 * 10, y as u8 * 10, 200]));
        let frames = [
            DynamicImage::ImageRgb8(rgb.clone()),
            DynamicImage::ImageRgba8(DynamicImage::ImageRgb8(rgb.clone()).to_rgba8()),
            DynamicImage::ImageLumaA8(DynamicImage::ImageRgb8(rgb.clone()).to_luma_alpha8()),
            DynamicImage::ImageRgb16(DynamicImage::ImageRgb8(rgb.clone()).to_rgb16()),
            DynamicImage::ImageRgb32F(DynamicImage::ImageRgb8(rgb).to_rgb32f()),
        ];
        for f in &frames {
            let out = pull_back(&s, f, 11, 11, Interp::Nearest, 0.0).unwrap();
            assert_eq!(out.color(), f.color());
            assert_eq!(out.as_bytes(), f.as_bytes(), "{:?}", f.color());
            // One pixel beyond: background, alpha 0.
            let out = pull_back(&s, f, 12, 11, Interp::Nearest, 0.0).unwrap();
            let px = out.to_rgba32f().get_pixel(11, 5).0;
            assert_eq!(px[..3], [0.0; 3], "{:?}", f.color());
            let alpha = if f.color().has_alpha() { 0.0 } else { 1.0 };
            assert_eq!(px[3], alpha, "{:?}", f.color());
        }
    }
}

//! Registering a frame back to the reference: `R(p) = F(phi(p))`.
//!
//! A deformation fitted to a frame maps reference points `p` (mesh coordinates = reference
//! pixels) to frame pixels `phi(p)`. Sampling the frame there pulls it back onto the
//! reference, so frames fitted to one reference all line up with it (and with each other).
//! Only `phi` itself is evaluated (no inverse); reference pixels outside the mesh get the
//! background. Pixel `(i, j)` is centred at `(i, j)`, as everywhere in [`crate::warp`].

use super::sample::{fill_pixels, Source};
use super::Interp;
use crate::spline::Spline;
use rayon::prelude::*;

/// The 8-bit gray frame `frame` (`fw x fh`, row-major) pulled back onto a `w x h` reference
/// grid through `phi`, with bilinear sampling.
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
        let pts: Vec<[f64; 2]> = (0..w).map(|x| [x as f64, y as f64]).collect();
        let mut mapped = vec![None; w];
        let mut hint = None;
        for (m, p) in mapped.iter_mut().zip(&pts) {
            *m = s.mesh().locate(*p, hint).map(|(t, b)| {
                hint = Some(t);
                s.eval_cache().value(t, b)
            });
        }
        let pos: Vec<[f64; 2]> = mapped.iter().map(|m| m.unwrap_or([f64::NAN, f64::NAN])).collect();
        fill_pixels::<u8, 1>(&src, &pos, row, Interp::Bilinear, background as f64);
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Mesh, MeshOptions};

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
}

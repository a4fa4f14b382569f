//! Dense maps of a deformation over a pixel grid: displacement fields and the Jacobian
//! determinant.
//!
//! * forward field at pixel `p`: `u(p) = phi(p) - p` (reference domain);
//! * inverse field at pixel `q`: `v(q) = phi^-1(q) - q` (deformed plane);
//! * Jacobian determinant `det J(p)` of phi at `p`: below 1 compression, above 1 expansion,
//!   at most 0 a fold (phi is not injective there).
//!
//! [`Field`] holds `f32` (the `.npy` / TIFF files); [`Field64`] the same values in `f64`
//! ([`forward_field_f64`], [`inverse_field_f64`]) for the OME-Zarr stores of
//! [`crate::io::ngff`].
//!
//! Pixels where the map is undefined (outside the mesh, or no preimage) are NaN. Files:
//! `.npy` (float32, shape `(H, W, 2)` for fields, C order) or float TIFF (RGB float32:
//! `dx`, `dy` and a validity channel 1/0). [`forward_field_f64`] and [`inverse_field_f64`]
//! give the same fields in `f64` (the `f32` ones are these rounded to nearest), for the ITK
//! transform files of [`crate::io::itk`].

use super::inverse::InverseOptions;
use super::remap::{preimage_grid_watched, RemapOptions};
use crate::spline::jacobian::{certify, CertifyOptions, DetJ};
use crate::spline::Spline;
use rayon::prelude::*;

/// A dense 2-component field, row-major, `NaN` where undefined.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `(dx, dy)` per pixel.
    pub data: Vec<[f32; 2]>,
}

/// Where phi folds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FoldReport {
    /// Pixels sampled inside the mesh.
    pub samples: usize,
    /// Samples with `det J <= 0`.
    pub folds: usize,
    /// Smallest determinant seen.
    pub min_det: f64,
    /// Bounding box `[x0, y0, x1, y1]` of the folded samples, if any.
    pub fold_bbox: Option<[f64; 4]>,
    /// The certificate over whole triangles ([`crate::spline::jacobian::certify`]): the
    /// certified lower bound, `fold_free`, and the sampled minimum every command reports.
    pub certificate: DetJ,
}

/// The forward displacement field `phi(p) - p` on a `w x h` pixel grid.
pub fn forward_field(s: &Spline, w: u32, h: u32) -> Field {
    Field { width: w, height: h, data: to_f32(forward_field_f64(s, w, h).data) }
}

/// The inverse displacement field `phi^-1(q) - q` on a `w x h` pixel grid, from the same
/// certified preimages as the image warp ([`super::remap`]).
pub fn inverse_field(s: &Spline, w: u32, h: u32, opts: InverseOptions) -> Field {
    Field { width: w, height: h, data: to_f32(inverse_field_f64(s, w, h, opts).data) }
}

/// Each component rounded to the nearest `f32` (the storage type of [`Field`]).
fn to_f32(v: Vec<[f64; 2]>) -> Vec<[f32; 2]> {
    v.into_iter().map(|d| [d[0] as f32, d[1] as f32]).collect()
}

/// A dense 2-component field in full precision (`f64`), row-major (x fastest), `[NaN, NaN]`
/// where undefined. Same layout and meaning as [`Field`] (which rounds it to `f32`); used
/// by the file formats that store float64 (ITK HDF5, [`crate::io::itk`]; OME-Zarr,
/// [`crate::io::ngff`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Field64 {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `(dx, dy)` per pixel, in pixels.
    pub data: Vec<[f64; 2]>,
}

impl Field64 {
    /// Number of pixels where the field is undefined (NaN).
    pub fn undefined(&self) -> usize {
        self.data.iter().filter(|v| v[0].is_nan()).count()
    }
}

/// [`forward_field`] in `f64`: `u(p) = phi(p) - p` at every pixel centre `p = (x, y)` of a
/// `w x h` grid (reference domain), from the same evaluation as [`super::forward`].
pub fn forward_field_f64(s: &Spline, w: u32, h: u32) -> Field64 {
    let pts: Vec<[f64; 2]> =
        (0..h).flat_map(|y| (0..w).map(move |x| [x as f64, y as f64])).collect();
    let mut out = vec![None; pts.len()];
    s.eval_many(&pts, &mut out);
    let data = pts
        .iter()
        .zip(&out)
        .map(|(p, q)| match q {
            Some(q) => [q[0] - p[0], q[1] - p[1]],
            None => [f64::NAN; 2],
        })
        .collect();
    Field64 { width: w, height: h, data }
}

/// [`inverse_field`] in `f64`: `v(q) = phi^-1(q) - q` at every pixel centre `q` of a
/// `w x h` grid (deformed plane), from the same certified preimages as the image warp
/// ([`super::remap::preimage_grid`], error bound within `opts.tolerance`).
pub fn inverse_field_f64(s: &Spline, w: u32, h: u32, opts: InverseOptions) -> Field64 {
    let never = crate::cancel::Cancel::never();
    inverse_field_watched(s, w, h, opts, &|_| {}, &never).expect("never cancelled")
}

/// [`inverse_field_f64`] reporting the rows finished to `progress` and stopping with
/// [`crate::cancel::Cancelled`] once `cancel` is set (between bands of rows).
pub fn inverse_field_watched(
    s: &Spline,
    w: u32,
    h: u32,
    opts: InverseOptions,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &crate::cancel::Cancel,
) -> Result<Field64, crate::cancel::Cancelled> {
    let ro = RemapOptions { inverse: opts, ..Default::default() };
    let (pre, _) = preimage_grid_watched(s, w, h, ro, progress, cancel)?;
    let data = pre
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let q = [(i % w as usize) as f64, (i / w as usize) as f64];
            if p[0].is_nan() {
                [f64::NAN; 2]
            } else {
                [p[0] - q[0], p[1] - q[1]]
            }
        })
        .collect();
    Ok(Field64 { width: w, height: h, data })
}

/// `det J` of phi at every pixel of a `w x h` grid (`NaN` outside the mesh) and the fold
/// report (per-pixel counts and the certificate of the whole spline).
pub fn jacobian_det(s: &Spline, w: u32, h: u32) -> (Vec<f64>, FoldReport) {
    let m = s.mesh();
    let cache = s.eval_cache();
    let dets: Vec<f64> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut hint = None;
            (0..w).map(move |x| match m.locate([x as f64, y as f64], hint) {
                Some((t, b)) => {
                    hint = Some(t);
                    let j = cache.jacobian(t, b);
                    j[0][0] * j[1][1] - j[0][1] * j[1][0]
                }
                None => f64::NAN,
            })
        })
        .collect();
    let mut rep = FoldReport {
        min_det: f64::INFINITY,
        certificate: certify(s, &CertifyOptions::default()),
        ..Default::default()
    };
    for (i, &d) in dets.iter().enumerate() {
        if d.is_nan() {
            continue;
        }
        rep.samples += 1;
        rep.min_det = rep.min_det.min(d);
        if d <= 0.0 {
            rep.folds += 1;
            let (x, y) = ((i % w as usize) as f64, (i / w as usize) as f64);
            let b = rep.fold_bbox.get_or_insert([x, y, x, y]);
            *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
    }
    (dets, rep)
}

/// A colour for a Jacobian determinant: white at 1, blue for compression, orange for
/// expansion (log scale, saturating at 1/4 and 4), red for folds, transparent outside.
pub fn det_color(d: f64) -> [u8; 4] {
    if d.is_nan() {
        return [0, 0, 0, 0];
    }
    if d <= 0.0 {
        return [220, 0, 0, 255];
    }
    let t = (d.log2() / 2.0).clamp(-1.0, 1.0);
    let mix = |a: f64, b: f64, s: f64| (a + (b - a) * s).round() as u8;
    if t < 0.0 {
        let s = -t;
        [mix(255.0, 40.0, s), mix(255.0, 90.0, s), mix(255.0, 200.0, s), 255]
    } else {
        [mix(255.0, 230.0, t), mix(255.0, 120.0, t), mix(255.0, 20.0, t), 255]
    }
}

/// The `.npy` bytes (format 1.0, little-endian float32, shape `(H, W, 2)`).
pub fn to_npy(f: &Field) -> Vec<u8> {
    let header = format!(
        "{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, {}, 2), }}",
        f.height, f.width
    );
    // Pad so that magic (6) + version (2) + length (2) + header + '\n' is a multiple of 64.
    let unpadded = 10 + header.len() + 1;
    let pad = (64 - unpadded % 64) % 64;
    let mut h = header.into_bytes();
    h.extend(std::iter::repeat_n(b' ', pad));
    h.push(b'\n');
    let mut out = Vec::with_capacity(10 + h.len() + f.data.len() * 8);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(&h);
    for v in &f.data {
        out.extend_from_slice(&v[0].to_le_bytes());
        out.extend_from_slice(&v[1].to_le_bytes());
    }
    out
}

/// The field as an RGB float32 image: `dx`, `dy`, validity (1 inside, 0 outside; `dx`, `dy`
/// are 0 there).
pub fn to_rgb32f(f: &Field) -> image::Rgb32FImage {
    image::Rgb32FImage::from_fn(f.width, f.height, |x, y| {
        let v = f.data[(y * f.width + x) as usize];
        if v[0].is_nan() {
            image::Rgb([0.0, 0.0, 0.0])
        } else {
            image::Rgb([v[0], v[1], 1.0])
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::{rat_int, Rat};
    use crate::mesh::{Mesh, MeshOptions};

    fn shifted() -> Spline {
        let mesh = Mesh::grid(3, 2, 29.0, 19.0, MeshOptions::default()).unwrap();
        let id = Spline::identity(mesh.clone(), 5).unwrap();
        let pts: Vec<Vec<Rat>> =
            id.points().iter().map(|p| vec![&p[0] + rat_int(2), &p[1] - rat_int(1)]).collect();
        Spline::from_points(mesh, 5, pts, None).unwrap()
    }

    #[test]
    fn fields_of_a_shift() {
        let s = shifted();
        let f = forward_field(&s, 32, 22);
        assert_eq!(f.data[5 * 32 + 5], [2.0, -1.0]);
        assert!(f.data[21 * 32 + 31][0].is_nan(), "outside the mesh");
        let g = inverse_field(&s, 32, 22, InverseOptions::default());
        let v = g.data[5 * 32 + 5];
        assert!((v[0] + 2.0).abs() < 1e-6 && (v[1] - 1.0).abs() < 1e-6);
        assert!(g.data[0][0].is_nan(), "q = (0, 0) has no preimage after the shift");
        let (d, rep) = jacobian_det(&s, 32, 22);
        assert!((d[5 * 32 + 5] - 1.0).abs() < 1e-9);
        assert_eq!(rep.folds, 0);
        assert_eq!(rep.samples, 30 * 20);
        assert!(rep.certificate.fold_free && rep.certificate.lower_bound <= 1.0);
    }

    /// The `f64` fields (ITK export) are the `f32` ones before rounding.
    #[test]
    fn f64_fields_agree_with_the_f32_ones() {
        let s = shifted();
        let (f, f64f) = (forward_field(&s, 32, 22), forward_field_f64(&s, 32, 22));
        let (g, g64) = (
            inverse_field(&s, 32, 22, InverseOptions::default()),
            inverse_field_f64(&s, 32, 22, InverseOptions::default()),
        );
        for (a, b) in f.data.iter().zip(&f64f.data).chain(g.data.iter().zip(&g64.data)) {
            assert_eq!(a[0].is_nan(), b[0].is_nan());
            if !a[0].is_nan() {
                assert_eq!(*a, [b[0] as f32, b[1] as f32]);
            }
        }
        assert_eq!(f64f.undefined(), f.data.iter().filter(|v| v[0].is_nan()).count());
        assert_eq!(g64.undefined(), g.data.iter().filter(|v| v[0].is_nan()).count());
        // The shift (2, -1), up to the f64 rounding of evaluating the spline.
        const EVAL_EPS: f64 = 1e-12;
        let v = f64f.data[5 * 32 + 5];
        assert!((v[0] - 2.0).abs() < EVAL_EPS && (v[1] + 1.0).abs() < EVAL_EPS, "{v:?}");
    }

    #[test]
    fn a_fold_is_reported() {
        // Mirror every control point's x about 15: phi(p) = (30 - x, y), det J = -1.
        let mesh = Mesh::grid(3, 2, 30.0, 20.0, MeshOptions::default()).unwrap();
        let id = Spline::identity(mesh.clone(), 5).unwrap();
        let pts: Vec<Vec<Rat>> =
            id.points().iter().map(|p| vec![rat_int(30) - &p[0], p[1].clone()]).collect();
        let s = Spline::from_points(mesh, 5, pts, None).unwrap();
        let (_, rep) = jacobian_det(&s, 31, 21);
        assert_eq!(rep.folds, rep.samples);
        assert_eq!(rep.fold_bbox, Some([0.0, 0.0, 30.0, 20.0]));
        assert_eq!(rep.certificate.folding.len(), s.mesh().num_triangles());
        assert_eq!(det_color(-1.0), [220, 0, 0, 255]);
        assert_eq!(det_color(1.0), [255, 255, 255, 255]);
    }

    #[test]
    fn npy_header_is_valid() {
        let f = Field { width: 3, height: 2, data: vec![[1.0, 2.0]; 6] };
        let b = to_npy(&f);
        assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
        let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hl) % 64, 0);
        let header = std::str::from_utf8(&b[10..10 + hl]).unwrap();
        assert!(header.contains("'shape': (2, 3, 2)"));
        assert_eq!(b.len(), 10 + hl + 6 * 8);
        assert_eq!(f32::from_le_bytes([b[10 + hl], b[11 + hl], b[12 + hl], b[13 + hl]]), 1.0);
    }
}

//! Warping tests: identity, exact shifts, round trips and bit depths.

use super::*;
use crate::edit::select::Neighborhood;
use crate::edit::{Editor, Mode};
use crate::exact::{rat_int, Rat};
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::ControlPoint;
use image::{GrayImage, ImageBuffer, Luma, Rgba};

fn grid(w: f64, h: f64) -> Mesh {
    Mesh::grid(4, 3, w, h, MeshOptions::default()).unwrap()
}

/// A spline whose control points are all shifted by (dx, dy): phi(p) = p + (dx, dy), C1.
fn shifted(mesh: Mesh, dx: i64, dy: i64) -> Spline {
    let id = Spline::identity(mesh.clone(), 5).unwrap();
    let pts: Vec<Vec<Rat>> =
        id.points().iter().map(|p| vec![&p[0] + rat_int(dx), &p[1] + rat_int(dy)]).collect();
    Spline::from_points(mesh, 5, pts, None).unwrap()
}

fn test_image(w: u32, h: u32) -> GrayImage {
    GrayImage::from_fn(w, h, |x, y| Luma([((x * 7 + y * 13) % 251) as u8]))
}

#[test]
fn identity_reproduces_the_image() {
    let s = Spline::identity(grid(39.0, 29.0), 5).unwrap();
    let img = DynamicImage::ImageLuma8(test_image(40, 30));
    for interp in [Interp::Nearest, Interp::Bilinear, Interp::Bicubic] {
        let (out, rep) = warp_image(&s, &img, interp, 0.0, InverseOptions::default()).unwrap();
        assert_eq!(rep.outside, 0);
        assert!(rep.max_error_bound <= 0.01);
        assert_eq!(out.to_luma8(), img.to_luma8(), "{interp:?}");
    }
}

#[test]
fn a_cancel_token_stops_the_warp_between_bands() {
    let s = shifted(grid(399.0, 599.0), 3, 2);
    let img = test_image(400, 600);
    let layout = Layout { width: 400, height: 600, channels: 1 };
    let pages = [Samples::U8(img.as_raw())];
    let mut out = vec![0u8; 400 * 600];
    let opts = WarpOptions::default();
    // Set before the call: nothing is warped.
    let token = crate::cancel::Cancel::new();
    token.cancel();
    let mut outs = [SamplesMut::U8(&mut out)];
    let r =
        warp_samples_cancellable(&s, layout, &pages, (400, 600), &mut outs, &opts, &|_| {}, &token);
    assert!(matches!(r, Err(WarpError::Cancelled)), "{r:?}");
    assert!(out.iter().all(|&v| v == 0));
    // Set by the first band finished: the bands not yet started are never warped.
    let token = crate::cancel::Cancel::new();
    let rows = std::sync::atomic::AtomicU64::new(0);
    let progress = |n: u64| {
        rows.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        token.cancel();
    };
    let mut outs = [SamplesMut::U8(&mut out)];
    let r = warp_samples_cancellable(
        &s,
        layout,
        &pages,
        (400, 600),
        &mut outs,
        &opts,
        &progress,
        &token,
    );
    assert!(matches!(r, Err(WarpError::Cancelled)), "{r:?}");
    let done = rows.into_inner();
    assert!(done > 0 && done < 600, "{done} of 600 rows warped");
    // Never set: the same warp completes and equals the plain call.
    let mut whole = vec![0u8; 400 * 600];
    let never = crate::cancel::Cancel::never();
    let mut outs = [SamplesMut::U8(&mut whole)];
    warp_samples_cancellable(&s, layout, &pages, (400, 600), &mut outs, &opts, &|_| {}, &never)
        .unwrap();
    let mut plain = vec![0u8; 400 * 600];
    warp_samples_into(&s, layout, &pages, &mut [SamplesMut::U8(&mut plain)], &opts, &|_| {})
        .unwrap();
    assert_eq!(whole, plain);
}

#[test]
fn a_shift_moves_features_by_the_shift() {
    let s = shifted(grid(39.0, 29.0), 3, 2);
    let src = test_image(40, 30);
    let (out, rep) = warp_image(
        &s,
        &DynamicImage::ImageLuma8(src.clone()),
        Interp::Nearest,
        7.0,
        InverseOptions::default(),
    )
    .unwrap();
    let out = out.to_luma8();
    // O(q) = I(q - (3, 2)) where q - (3, 2) is inside; background elsewhere.
    for y in 0..30 {
        for x in 0..40 {
            let expect = if x >= 3 && y >= 2 { src.get_pixel(x - 3, y - 2)[0] } else { 7 };
            assert_eq!(out.get_pixel(x, y)[0], expect, "({x}, {y})");
        }
    }
    assert_eq!(rep.outside, 40 * 30 - 37 * 28);
}

#[test]
fn bit_depth_and_alpha_are_kept() {
    let s = shifted(grid(19.0, 19.0), 2, 0);
    let g16: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_fn(20, 20, |x, _| Luma([x as u16 * 3000]));
    let (out, _) = warp_image(
        &s,
        &DynamicImage::ImageLuma16(g16),
        Interp::Bilinear,
        0.0,
        InverseOptions::default(),
    )
    .unwrap();
    let DynamicImage::ImageLuma16(o) = out else { panic!("type changed") };
    assert_eq!(o.get_pixel(10, 5)[0], 8 * 3000);
    let rgba: ImageBuffer<Rgba<u8>, Vec<u8>> =
        ImageBuffer::from_pixel(20, 20, Rgba([10, 20, 30, 255]));
    let (out, _) = warp_image(
        &s,
        &DynamicImage::ImageRgba8(rgba),
        Interp::Bicubic,
        0.0,
        InverseOptions::default(),
    )
    .unwrap();
    let o = out.to_rgba8();
    assert_eq!(o.get_pixel(0, 0).0, [0, 0, 0, 0], "outside is transparent");
    assert_eq!(o.get_pixel(10, 10).0, [10, 20, 30, 255]);
}

#[test]
fn inverse_undoes_forward_after_edits() {
    let mesh = grid(100.0, 80.0);
    let mut ed = Editor::new(Spline::identity(mesh.clone(), 5).unwrap());
    let v = (0..mesh.num_vertices()).find(|&v| !mesh.is_border_vertex(v)).unwrap();
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(3), Mode::Xy).unwrap();
    ed.translate(&[rat_int(6), rat_int(-4)]).unwrap();
    let s = ed.into_spline();
    let pts: Vec<[f64; 2]> =
        (0..400).map(|k| [(k % 20) as f64 * 5.0 + 0.3, (k / 20) as f64 * 4.0 + 0.2]).collect();
    let fwd = forward(&s, &pts);
    let qs: Vec<[f64; 2]> = fwd.iter().map(|q| q.unwrap()).collect();
    let back = inverse(&s, &qs, InverseOptions::default());
    for (p, b) in pts.iter().zip(&back) {
        let b = b.expect("preimage found");
        assert!(b.error_bound <= 0.01);
        assert!(
            (b.p[0] - p[0]).abs() <= 0.01 && (b.p[1] - p[1]).abs() <= 0.01,
            "{p:?} -> {:?}",
            b.p
        );
    }
    // Outside the mesh: forward is None; a far-away point has no preimage.
    assert_eq!(forward(&s, &[[-5.0, -5.0]])[0], None);
    assert!(inverse(&s, &[[500.0, 500.0]], InverseOptions::default())[0].is_none());
}

/// An edited spline on `mesh`: one interior vertex dragged by `(dx, dy)`.
pub(super) fn dragged(mesh: Mesh, dx: i64, dy: i64) -> Spline {
    let mut ed = Editor::new(Spline::identity(mesh.clone(), 5).unwrap());
    let (lo, hi) = mesh.bbox();
    let c = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let v = (0..mesh.num_vertices())
        .filter(|&v| !mesh.is_border_vertex(v))
        .min_by(|&a, &b| {
            let d = |v: usize| {
                let p = mesh.vertex(v);
                (p[0] - c[0]).hypot(p[1] - c[1])
            };
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
    ed.translate(&[rat_int(dx), rat_int(dy)]).unwrap();
    ed.into_spline()
}

/// The fast preimages agree with per-pixel Newton within the tolerance, everywhere; and
/// pixels are outside exactly where Newton finds no preimage (up to pixels within the
/// tolerance of the deformed border).
fn check_remap_against_newton(s: &Spline, w: u32, h: u32) -> remap::RemapStats {
    let tol = 0.01;
    let opts = remap::RemapOptions::default();
    let (fast, stats) = remap::preimage_grid(s, w, h, opts);
    let slow = preimages(s, w, h, InverseOptions::default());
    let mut disagree_outside = 0;
    for (k, (f, n)) in fast.iter().zip(&slow).enumerate() {
        let (x, y) = (k as u32 % w, k as u32 / w);
        match n {
            Some(n) if !f[0].is_nan() => {
                let e = (f[0] - n.p[0]).hypot(f[1] - n.p[1]);
                assert!(e <= tol + n.error_bound, "({x}, {y}): {f:?} vs {:?} ({e})", n.p);
            }
            _ => {
                if f[0].is_nan() != n.is_none() {
                    // Only allowed for pixels whose centre is within the tolerance of phi(border).
                    let q = [x as f64, y as f64];
                    let near = (0..=8).any(|i| {
                        (0..=8).any(|j| {
                            let p = [
                                q[0] + (i as f64 - 4.0) * tol / 4.0,
                                q[1] + (j as f64 - 4.0) * tol / 4.0,
                            ];
                            inverse(s, &[p], InverseOptions::default())[0].is_some() != n.is_some()
                        })
                    });
                    assert!(near, "({x}, {y}) fast {f:?} vs newton {n:?}");
                    disagree_outside += 1;
                }
            }
        }
    }
    assert!(stats.max_error_bound <= tol, "{stats:?}");
    assert!(disagree_outside <= (w + h) as usize, "{disagree_outside}");
    stats
}

#[test]
fn fast_preimages_match_newton_on_a_grid_mesh() {
    let s = dragged(Mesh::grid(4, 3, 119.0, 89.0, MeshOptions::default()).unwrap(), 9, -6);
    let st = check_remap_against_newton(&s, 120, 90);
    assert!(st.interpolated > 0);
}

#[test]
fn fast_preimages_match_newton_on_a_delaunay_mesh_inside_a_larger_image() {
    let m = crate::mesh::xorshift_mesh(11, 40, 1000, 10.0);
    let (lo, hi) = m.bbox();
    let s = dragged(m, 4, 3);
    let st = check_remap_against_newton(&s, (hi[0] + 12.0) as u32, (hi[1] + 9.0) as u32);
    assert!(st.outside > 0 && lo[0] >= 0.0);
}

#[test]
fn fast_preimages_match_newton_on_a_non_convex_mesh() {
    // An L shape: the square [0, 60]^2 without [30, 60] x [30, 60], on a 15 px lattice.
    let v: Vec<[f64; 2]> =
        (0..25).map(|k| [(k % 5) as f64 * 15.0, (k / 5) as f64 * 15.0]).collect();
    let mut t = Vec::new();
    for j in 0..4 {
        for i in 0..4 {
            if i >= 2 && j >= 2 {
                continue;
            }
            let a = j * 5 + i;
            t.push([a, a + 1, a + 6]);
            t.push([a, a + 6, a + 5]);
        }
    }
    let used: Vec<usize> = (0..25).filter(|k| t.iter().any(|tr| tr.contains(k))).collect();
    let v: Vec<[f64; 2]> = used.iter().map(|&k| v[k]).collect();
    let t: Vec<[usize; 3]> =
        t.iter().map(|tr| tr.map(|k| used.iter().position(|&u| u == k).unwrap())).collect();
    let m = Mesh::from_triangles(&v, &t, MeshOptions::default()).unwrap();
    let s = dragged(m, 3, 2);
    let st = check_remap_against_newton(&s, 64, 64);
    assert!(st.outside > 900, "{st:?}");
}

#[test]
fn warp_at_phi_p_equals_the_input_at_p() {
    // For points p in the mesh, O(phi(p)) = I(p) within the bilinear interpolation error of
    // a smooth image (which is tiny for this slowly varying image).
    let s = dragged(Mesh::grid(4, 3, 119.0, 89.0, MeshOptions::default()).unwrap(), 7, 5);
    let f = |x: f64, y: f64| 20000.0 + 8000.0 * (x / 17.0).sin() + 6000.0 * (y / 13.0).cos();
    let img: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_fn(120, 90, |x, y| Luma([f(x as f64, y as f64).round() as u16]));
    let (out, rep) = warp_image(
        &s,
        &DynamicImage::ImageLuma16(img),
        Interp::Bilinear,
        0.0,
        InverseOptions::default(),
    )
    .unwrap();
    assert!(rep.max_error_bound <= 0.01);
    let out = out.to_luma16();
    let mut checked = 0;
    for k in 0..400 {
        let p = [5.0 + (k % 20) as f64 * 5.3, 4.0 + (k / 20) as f64 * 4.1];
        let Some(q) = forward(&s, &[p])[0] else { continue };
        // Sample the output at q bilinearly (q is not a pixel centre).
        let (x0, y0) = (q[0].floor(), q[1].floor());
        if x0 < 0.0 || y0 < 0.0 || x0 >= 119.0 || y0 >= 89.0 {
            continue;
        }
        let (fx, fy) = (q[0] - x0, q[1] - y0);
        let at = |x: f64, y: f64| out.get_pixel(x as u32, y as u32)[0] as f64;
        let v = (at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx) * (1.0 - fy)
            + (at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx) * fy;
        // Two bilinear interpolations of a function with |f''| <= 8000/17^2 ~ 28 per px^2,
        // plus 0.01 px of preimage error times |grad f| <= 8000/17 + 6000/13 ~ 933: <= 30.
        assert!((v - f(p[0], p[1])).abs() <= 30.0, "{p:?}: {v} vs {}", f(p[0], p[1]));
        checked += 1;
    }
    assert!(checked > 300);
}

#[test]
fn inverse_of_forward_is_within_a_micro_pixel() {
    let s = dragged(Mesh::grid(4, 3, 119.0, 89.0, MeshOptions::default()).unwrap(), 9, -6);
    let pts: Vec<[f64; 2]> =
        (0..300).map(|k| [1.0 + (k % 20) as f64 * 5.9, 1.0 + (k / 20) as f64 * 5.7]).collect();
    let qs: Vec<[f64; 2]> = forward(&s, &pts).into_iter().map(|q| q.unwrap()).collect();
    let opts = InverseOptions { tolerance: 1e-6, ..Default::default() };
    for (p, b) in pts.iter().zip(inverse(&s, &qs, opts)) {
        let b = b.expect("preimage");
        assert!((b.p[0] - p[0]).hypot(b.p[1] - p[1]) <= 1e-6, "{p:?} vs {:?}", b.p);
    }
}

/// Newton stopped at the acceptance test leaves `|phi(p) - q|` around 1e-6 px; polished
/// (`InverseMap::polish`, used by `inverse`) it is at the rounding level of evaluating phi.
#[test]
fn polished_inverse_reaches_machine_precision() {
    use crate::warp::inverse::InverseMap;
    let s = dragged(Mesh::grid(4, 3, 119.0, 89.0, MeshOptions::default()).unwrap(), 9, -6);
    let qs: Vec<[f64; 2]> =
        (0..300).map(|k| [2.3 + (k % 20) as f64 * 5.7, 1.9 + (k / 20) as f64 * 5.6]).collect();
    let map = InverseMap::new(&s, InverseOptions::default());
    let resid = |q: [f64; 2], p: [f64; 2]| {
        let f = forward(&s, &[p])[0].expect("p in the mesh");
        (f[0] - q[0]).hypot(f[1] - q[1])
    };
    let (mut raw, mut polished, mut n) = (0.0f64, 0.0f64, 0);
    for (q, b) in qs.iter().zip(inverse(&s, &qs, InverseOptions::default())) {
        let Some(b) = b else { continue };
        let r = map.invert(*q, None).expect("a preimage without polishing too");
        raw = raw.max(resid(*q, r.p));
        polished = polished.max(resid(*q, b.p));
        assert!(b.error_bound <= r.error_bound.max(1e-12), "{b:?} vs {r:?}");
        n += 1;
    }
    assert!(n > 250, "{n}");
    assert!(polished <= 1e-9, "polished {polished:e}");
    assert!(polished < raw, "polished {polished:e}, raw {raw:e}");
}

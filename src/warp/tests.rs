//! Warping tests: identity, exact shifts, round trips and bit depths.

use super::*;
use crate::edit::select::Neighborhood;
use crate::edit::{Editor, Mode};
use crate::exact::{rat_int, Rat};
use crate::mesh::{Mesh, MeshOptions};
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
    ed.select(&[v], &[], &Neighborhood::Radius(3), Mode::Xy).unwrap();
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

//! Golden-image regression tests: warped images and a rasterized colored mesh compared with
//! stored PNGs, pixel by pixel, with an explicit tolerance.
//!
//! Inputs (committed): `tests/golden/deformation.json` (two drags on a 4 x 3 grid over
//! 200 x 160 px) and `tests/golden/input.png` (a 200 x 160 crop of the bundled
//! `data/microscopy/cell.png`). To regenerate the expected outputs after an intended change,
//! run `TRIMORPH_REGENERATE_GOLDEN=1 cargo test --test golden` and review the new PNGs.
//!
//! Tolerance: every channel of every pixel within `common::GOLDEN_MAX_DIFF` (2) levels of the stored value
//! (the outputs are deterministic, but float rounding may differ across CPUs and compilers),
//! and at most `common::GOLDEN_MAX_OFF` (64) pixels differing at all.

use crate::common;

use image::DynamicImage;
use std::path::{Path, PathBuf};
use trimorph::warp::inverse::InverseOptions;
use trimorph::warp::{warp_image, Interp};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn regenerate() -> bool {
    std::env::var_os("TRIMORPH_REGENERATE_GOLDEN").is_some()
}

fn input() -> DynamicImage {
    let p = dir().join("input.png");
    if regenerate() && !p.exists() {
        let cell =
            image::open(Path::new(env!("CARGO_MANIFEST_DIR")).join("data/microscopy/cell.png"))
                .unwrap();
        cell.crop_imm(300, 330, 200, 160).save(&p).unwrap();
    }
    image::open(&p).expect("tests/golden/input.png")
}

fn spline() -> trimorph::spline::Spline {
    let text = std::fs::read_to_string(dir().join("deformation.json")).unwrap();
    trimorph::io::deformation::from_str(&text).unwrap().0
}

fn compare(name: &str, got: &DynamicImage) {
    common::compare_golden(name, got);
}

#[test]
fn golden_warps() {
    let (s, img) = (spline(), input());
    for (interp, name) in [
        (Interp::Nearest, "warp_nearest.png"),
        (Interp::Bilinear, "warp_bilinear.png"),
        (Interp::Bicubic, "warp_bicubic.png"),
    ] {
        let (out, rep) = warp_image(&s, &img, interp, 0.0, InverseOptions::default()).unwrap();
        assert!(rep.max_error_bound <= 0.01);
        compare(name, &out);
    }
}

#[test]
fn golden_colored_mesh() {
    use trimorph::warp::colormesh::{ColorMesh, ColorMode};
    let (s, img) = (spline(), input());
    for (mode, name) in
        [(ColorMode::PerVertex, "colormesh_vertex.png"), (ColorMode::Flat, "colormesh_flat.png")]
    {
        let mesh = ColorMesh::from_image(&img, 2, mode).unwrap();
        let (moved, dropped) = mesh.deform(&s);
        assert_eq!(dropped, 0);
        let pix =
            trimorph::render::colormesh::rasterize(&moved, 200, 160, Some([0, 0, 0, 255])).unwrap();
        let rgba = image::RgbaImage::from_raw(200, 160, pix.data().to_vec()).unwrap();
        compare(name, &DynamicImage::ImageRgba8(rgba));
    }
}

#[test]
fn golden_jacobian_map() {
    let s = spline();
    let (det, rep) = trimorph::warp::field::jacobian_det(&s, 200, 160);
    assert_eq!(rep.folds, 0);
    let img = image::RgbaImage::from_fn(200, 160, |x, y| {
        image::Rgba(trimorph::warp::field::det_color(det[(y * 200 + x) as usize]))
    });
    compare("jacobian.png", &DynamicImage::ImageRgba8(img));
}

//! Rendering deformations to PNG: sizes, lines, backgrounds, anchors, saving, and a
//! golden-image style check with an explicit per-pixel tolerance.

// Cell loops index the downsampled image by (row, column), as in the crate.
#![allow(clippy::needless_range_loop)]

use std::path::Path;

use tiny_skia::Pixmap;
use trimorph::edit::select::Neighborhood;
use trimorph::edit::{Editor, Mode};
use trimorph::exact::rat_int;
use trimorph::io::deformation::LastEdit;
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::render::deformation::{
    load_background, render, save_png, RenderError, RenderOptions,
};
use trimorph::spline::{ControlPoint, Spline};

/// The identity spline of degree 5 over the 3x2 grid on `[0, 300] x [0, 200]`.
fn grid() -> Spline {
    let mesh = Mesh::grid(3, 2, 300.0, 200.0, MeshOptions::default()).unwrap();
    Spline::identity(mesh, 5).unwrap()
}

/// Without a background the 300x200 grid fits into 800x600 at scale 2.4, offset (40, 60).
fn to_px(p: [f64; 2]) -> (f64, f64) {
    (40.0 + 2.4 * p[0], 60.0 + 2.4 * p[1])
}

/// Un-premultiplied RGB of pixel (x, y).
fn rgb(pm: &Pixmap, x: u32, y: u32) -> [u8; 3] {
    let c = pm.pixel(x, y).unwrap().demultiply();
    [c.red(), c.green(), c.blue()]
}

fn luma(c: [u8; 3]) -> f64 {
    (f64::from(c[0]) + f64::from(c[1]) + f64::from(c[2])) / 3.0
}

/// Darkest luma in the (2r+1)^2 window around (x, y).
fn darkest(pm: &Pixmap, (x, y): (f64, f64), r: i64) -> f64 {
    let (cx, cy) = (x.round() as i64, y.round() as i64);
    let mut best = 255.0f64;
    for py in cy - r..=cy + r {
        for px in cx - r..=cx + r {
            if px >= 0 && py >= 0 && (px as u32) < pm.width() && (py as u32) < pm.height() {
                best = best.min(luma(rgb(pm, px as u32, py as u32)));
            }
        }
    }
    best
}

/// Count of clearly red pixels within `r` of (x, y).
fn red_near(pm: &Pixmap, (x, y): (f64, f64), r: i64) -> usize {
    let (cx, cy) = (x.round() as i64, y.round() as i64);
    let mut n = 0;
    for py in (cy - r).max(0)..=(cy + r).min(i64::from(pm.height()) - 1) {
        for px in (cx - r).max(0)..=(cx + r).min(i64::from(pm.width()) - 1) {
            let [r, g, b] = rgb(pm, px as u32, py as u32);
            n += usize::from(r > 170 && g < 100 && b < 100);
        }
    }
    n
}

#[test]
fn size_and_lines() {
    let pm = render(&grid(), None, None, &RenderOptions::default()).unwrap();
    assert_eq!((pm.width(), pm.height()), (800, 600));
    let small = RenderOptions { width: 320, height: 100, ..RenderOptions::default() };
    let pm2 = render(&grid(), None, None, &small).unwrap();
    assert_eq!((pm2.width(), pm2.height()), (320, 100));
    // Along edges: the vertical line x = 100, the horizontal y = 100, the diagonal of cell
    // (1, 0) and the outer border.
    for p in [[100.0, 50.0], [150.0, 100.0], [150.0, 50.0], [0.0, 130.0], [230.0, 200.0]] {
        let d = darkest(&pm, to_px(p), 1);
        assert!(d < 160.0, "edge point {p:?} is not dark: {d}");
    }
    // Inside triangles, away from edges and control points: white.
    for p in [[70.0, 30.0], [30.0, 70.0], [230.0, 170.0]] {
        let (x, y) = to_px(p);
        assert_eq!(rgb(&pm, x as u32, y as u32), [255; 3], "{p:?}");
    }
    // Far outside the mesh, where no legend fits: white.
    assert_eq!(rgb(&pm, 400, 20), [255; 3]);
    assert_eq!(rgb(&pm, 400, 585), [255; 3]);
}

#[test]
fn every_layer_renders_and_sizes_are_checked() {
    let all = RenderOptions::parse_show("all").unwrap();
    let last = LastEdit {
        anchors: ControlPoint::from_indices(&[5, 10_000]),
        derived: ControlPoint::from_indices(&[6, 9]),
    };
    let pm = render(&grid(), Some(&last), None, &all).unwrap();
    assert_eq!((pm.width(), pm.height()), (800, 600));
    // The constraint quads tint the area around interior edges (orange, translucent).
    let c = rgb(&pm, to_px([100.0, 150.0]).0 as u32 + 6, to_px([100.0, 150.0]).1 as u32 + 3);
    assert!(c[0] > c[2] + 20, "no constraint tint: {c:?}");
    for (w, h) in [(0, 600), (800, 3), (20_000, 600)] {
        let o = RenderOptions { width: w, height: h, ..RenderOptions::default() };
        let err = render(&grid(), None, None, &o).unwrap_err();
        assert!(matches!(err, RenderError::Size { .. }), "{err}");
    }
}

#[test]
fn parse_show_accepts_and_rejects() {
    let o = RenderOptions::parse_show("mesh,net,constraints").unwrap();
    assert!(o.show_mesh && o.show_net && o.show_constraints);
    assert!(!o.show_points && !o.show_reference);
    let o = RenderOptions::parse_show(" reference , POINTS ").unwrap();
    assert!(o.show_reference && o.show_points && !o.show_mesh);
    let err = RenderOptions::parse_show("mesh,wireframe").unwrap_err();
    assert!(matches!(&err, RenderError::UnknownLayer(w) if w == "wireframe"));
    assert!(err.to_string().contains("wireframe"), "{err}");
    assert!(RenderOptions::parse_show("").is_err());
}

#[test]
fn background_shows_through() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame.png");
    let img = image::RgbImage::from_fn(320, 240, |x, _| image::Rgb([10, 200, (x % 256) as u8]));
    img.save(&path).unwrap();
    let bg = load_background(&path).unwrap();
    assert_eq!((bg.width(), bg.height()), (320, 240));
    let opts = RenderOptions::default(); // 800x600 is ignored with a background
    let pm = render(&grid(), None, Some(&bg), &opts).unwrap();
    assert_eq!((pm.width(), pm.height()), (320, 240));
    // Away from lines the image shows through unchanged; scale 1, no offset.
    for (x, y) in [(230, 170), (70, 30), (310, 120)] {
        assert_eq!(rgb(&pm, x, y), [10, 200, x as u8], "({x}, {y})");
    }
    // Mesh coordinate (100, 50) is on a vertical edge, drawn at pixel (100, 50).
    assert!(darkest(&pm, (100.0, 50.0), 0) < 100.0);
    assert!(luma(rgb(&pm, 103, 50)) > 60.0);
}

#[test]
fn background_formats_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    // 16-bit gray TIFF: scaled to 8 bits.
    let tif = dir.path().join("gray16.tif");
    image::ImageBuffer::<image::Luma<u16>, _>::from_pixel(40, 30, image::Luma([65535u16 / 2]))
        .save(&tif)
        .unwrap();
    let pm = load_background(&tif).unwrap();
    let c = rgb(&pm, 5, 5);
    assert!(c.iter().all(|&v| (126..=128).contains(&v)) && pm.pixel(5, 5).unwrap().alpha() == 255);
    // RGBA PNG with transparency, saved under a misleading extension.
    let png = dir.path().join("rgba.jpg");
    let rgba = image::RgbaImage::from_pixel(8, 8, image::Rgba([200, 100, 0, 128]));
    image::DynamicImage::ImageRgba8(rgba).save_with_format(&png, image::ImageFormat::Png).unwrap();
    let px = load_background(&png).unwrap().pixel(1, 1).unwrap().demultiply();
    assert_eq!(px.alpha(), 128);
    assert!(px.red().abs_diff(200) <= 1 && px.green().abs_diff(100) <= 1);
    // Unreadable files give a clear message naming the file.
    let text = dir.path().join("notes.png");
    std::fs::write(&text, "not an image").unwrap();
    for bad in [text, dir.path().join("missing.png")] {
        let err = load_background(&bad).unwrap_err();
        assert!(matches!(err, RenderError::Image { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains(bad.file_name().unwrap().to_str().unwrap()), "{msg}");
    }
}

#[test]
fn anchors_are_red_after_an_edit() {
    let mut ed = Editor::new(grid());
    let anchor = 5; // mesh vertex 5 at (100, 100)
    let sel = ed.select(&[ControlPoint(anchor)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
    let last = LastEdit { anchors: sel.anchors.clone(), derived: sel.derived.clone() };
    ed.translate(&[rat_int(20), rat_int(-10)]).unwrap();
    let s = ed.into_spline();
    assert_eq!(s.point_f64(anchor), [120.0, 90.0]);
    let opts = RenderOptions::default();
    let with = render(&s, Some(&last), None, &opts).unwrap();
    let without = render(&s, None, None, &opts).unwrap();
    // The fit changes nothing here (the bounding box is the same), so positions agree.
    let at = to_px([120.0, 90.0]);
    assert!(red_near(&with, at, 8) >= 10, "no red circle around the anchor");
    assert_eq!(red_near(&without, at, 8), 0);
    let derived = to_px(s.point_f64(last.derived[0].index()));
    let c = rgb(&with, derived.0.round() as u32, derived.1.round() as u32);
    assert!(c[2] > 150 && c[0] < 120, "derived point not blue: {c:?}");
    // With a background the anchor is at its mesh coordinates.
    let bg = Pixmap::new(300, 220).unwrap();
    let on_bg = render(&s, Some(&last), Some(&bg), &opts).unwrap();
    assert!(red_near(&on_bg, (120.0, 90.0), 8) >= 10);
}

#[test]
fn save_png_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("phi.png");
    let pm = render(&grid(), None, None, &RenderOptions::default()).unwrap();
    save_png(&pm, &path).unwrap();
    save_png(&pm, &path).unwrap(); // overwriting works too
    let back = Pixmap::load_png(&path).unwrap();
    assert_eq!((back.width(), back.height()), (800, 600));
    assert_eq!(back.data(), pm.data());
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap()).collect();
    assert_eq!(names.len(), 1, "temporary file left behind");
    let missing = dir.path().join("no-such-dir").join("phi.png");
    assert!(matches!(save_png(&pm, &missing), Err(RenderError::Io { .. })));
    assert!(matches!(save_png(&pm, Path::new("/")), Err(RenderError::Io { .. })));
}

/// Block-averaged luma, `BLOCK x BLOCK` pixels per cell.
fn downsample(pm: &Pixmap) -> Vec<Vec<f64>> {
    let (w, h) = (pm.width() / BLOCK, pm.height() / BLOCK);
    (0..h)
        .map(|by| {
            (0..w)
                .map(|bx| {
                    let mut sum = 0.0;
                    for y in by * BLOCK..(by + 1) * BLOCK {
                        for x in bx * BLOCK..(bx + 1) * BLOCK {
                            sum += luma(rgb(pm, x, y));
                        }
                    }
                    sum / f64::from(BLOCK * BLOCK)
                })
                .collect()
        })
        .collect()
}

const BLOCK: u32 = 20;
/// Per-cell tolerance (luma, 0..255) of the golden comparison.
const TOL: f64 = 0.5;
/// A cell counts as inked when its average luma is below this.
const INKED: f64 = 250.0;

#[test]
fn golden_downsampled_grid() {
    let opts = RenderOptions { show_points: false, ..RenderOptions::default() };
    let a = downsample(&render(&grid(), None, None, &opts).unwrap());
    let b = downsample(&render(&grid(), None, None, &opts).unwrap());
    assert_eq!((a.len(), a[0].len()), (30, 40));
    for (y, (ra, rb)) in a.iter().zip(&b).enumerate() {
        for (x, (va, vb)) in ra.iter().zip(rb).enumerate() {
            assert!((va - vb).abs() <= TOL, "not deterministic at cell ({x}, {y})");
        }
    }
    // Hand-computed expectation. The mesh maps to pixels [40, 760] x [60, 540]; its grid
    // lines are at x = 40, 280, 520, 760 and y = 60, 300, 540 (2 px wide on the border), and
    // each 240x240 cell has a diagonal from its top-left to bottom-right corner. The legend
    // sits in one corner: cells within 12 x 4 cells of a corner are not checked.
    let legend = |x: usize, y: usize| !(12..28).contains(&x) && !(4..26).contains(&y);
    // Border pixels of the mesh area: columns 40 and 760 are cells 2 and 38, rows 60 and 540
    // are cells 3 and 27.
    for y in 3..=27 {
        for x in [2, 38] {
            assert!(legend(x, y) || a[y][x] < INKED, "left/right border cell ({x}, {y})");
        }
    }
    for x in 2..=38 {
        for y in [3, 27] {
            assert!(legend(x, y) || a[y][x] < INKED, "top/bottom border cell ({x}, {y})");
        }
    }
    // Cells at least 3 px from every line are white within the tolerance.
    let near_line = |x: usize, y: usize| {
        let (x0, y0) = (x as f64 * 20.0 - 3.0, y as f64 * 20.0 - 3.0);
        let (x1, y1) = (x0 + 26.0, y0 + 26.0);
        let in_x = (40.0..=760.0).contains(&x1) || (40.0..=760.0).contains(&x0);
        let in_y = (60.0..=540.0).contains(&y1) || (60.0..=540.0).contains(&y0);
        let vert = [40.0, 280.0, 520.0, 760.0].iter().any(|&l| x0 <= l && l <= x1) && in_y;
        let horiz = [60.0, 300.0, 540.0].iter().any(|&l| y0 <= l && l <= y1) && in_x;
        // Diagonals: x - y = 40 - 60 + 240 k for the cells of column c and row r, k = c - r.
        let diag = [-260.0, -20.0, 220.0, 460.0, 700.0].iter().any(|&k| {
            let (lo, hi) = (x0 - y1, x1 - y0);
            lo <= k && k <= hi && in_x && in_y
        });
        vert || horiz || diag
    };
    let mut white = 0;
    for y in 0..30 {
        for x in 0..40 {
            if !legend(x, y) && !near_line(x, y) {
                assert!((a[y][x] - 255.0).abs() <= TOL, "cell ({x}, {y}) = {}", a[y][x]);
                white += 1;
            }
        }
    }
    assert!(white > 500, "only {white} white cells checked");
}

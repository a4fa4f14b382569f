//! Feature points of a test image, shared by the fitting tests.

/// Feature points of an image: pixels of largest gradient, at least `sep` px apart and 20 px
/// inside the border.
pub fn feature_points(img: &image::GrayImage, n: usize, sep: f64) -> Vec<[f64; 2]> {
    let (w, h) = img.dimensions();
    let g = |x: u32, y: u32| img.get_pixel(x, y)[0] as f64;
    let mut cand: Vec<(f64, [f64; 2])> = Vec::new();
    for y in 20..h - 20 {
        for x in 20..w - 20 {
            let gx = g(x + 1, y) - g(x - 1, y);
            let gy = g(x, y + 1) - g(x, y - 1);
            cand.push((gx * gx + gy * gy, [x as f64, y as f64]));
        }
    }
    cand.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut out: Vec<[f64; 2]> = Vec::new();
    for (_, p) in cand {
        if out.iter().all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) >= sep) {
            out.push(p);
            if out.len() == n {
                break;
            }
        }
    }
    out
}

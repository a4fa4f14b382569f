//! Makes the bundled morph pair `data/morph/` from the bundled nucleus time-lapse (see
//! `data/SOURCES.md`): two images of different size and type with matched landmarks.
//!
//! * `nuclei_a.png`: frame 0 (511 x 511, 8-bit grey) reduced to 184 x 184 (about 34,000 px,
//!   triangle filter) and coloured with a fixed green-cyan fluorescence LUT: 8-bit RGB.
//! * `nuclei_b.png`: frame 9 under `T(p) = c_B + 0.6 R(12 deg) (p - c_F)` (`c_F` the frame's
//!   centre, `c_B` B's centre; bilinear, area-filtered first), 250 x 230 px, 16-bit grey
//!   (`v * 257`), inside the rotated frame everywhere.
//! * `nuclei_landmarks.csv`: the 14 tracked nuclei of `landmarks_00_09.csv`, sources
//!   scaled to A (`(x + 0.5) 184 / 511 - 0.5`), targets mapped by `T`; pairs outside either
//!   image are dropped.
//!
//! `cargo run --release --example make_morph_pair` (writes into `data/morph/`).

use image::{imageops, GrayImage, ImageBuffer, Luma, Rgb, RgbImage};
use std::path::Path;

const A_SIZE: u32 = 184;
const B_SIZE: (u32, u32) = (250, 230);
const SCALE: f64 = 0.6;
const ANGLE_DEG: f64 = 12.0;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("data/microscopy/timelapse");
    let out = root.join("data/morph");
    std::fs::create_dir_all(&out).unwrap();
    let f0 = image::open(src.join("frame_00.png")).unwrap().to_luma8();
    let f9 = image::open(src.join("frame_09.png")).unwrap().to_luma8();
    let n = f0.width() as f64;

    // A: reduced and coloured.
    let small = imageops::resize(&f0, A_SIZE, A_SIZE, imageops::FilterType::Triangle);
    let a: RgbImage = ImageBuffer::from_fn(A_SIZE, A_SIZE, |x, y| {
        let v = f64::from(small.get_pixel(x, y)[0]) / 255.0;
        let c = |g: f64| (255.0 * g.clamp(0.0, 1.0)).round() as u8;
        Rgb([c(0.15 * v + 0.6 * v * v), c(v.powf(0.8)), c(0.55 * v + 0.1)])
    });
    a.save(out.join("nuclei_a.png")).unwrap();

    // B: frame 9 pre-filtered to the target scale, then rotated and scaled by T.
    let pre = imageops::blur(&f9, (0.5 / SCALE) as f32);
    let (th, ca) = (ANGLE_DEG.to_radians(), [(n - 1.0) / 2.0; 2]);
    let cb = [(f64::from(B_SIZE.0) - 1.0) / 2.0, (f64::from(B_SIZE.1) - 1.0) / 2.0];
    let t = |p: [f64; 2]| {
        let (u, v) = (p[0] - ca[0], p[1] - ca[1]);
        [
            cb[0] + SCALE * (th.cos() * u - th.sin() * v),
            cb[1] + SCALE * (th.sin() * u + th.cos() * v),
        ]
    };
    let t_inv = |q: [f64; 2]| {
        let (u, v) = ((q[0] - cb[0]) / SCALE, (q[1] - cb[1]) / SCALE);
        [ca[0] + th.cos() * u + th.sin() * v, ca[1] - th.sin() * u + th.cos() * v]
    };
    let bilinear = |g: &GrayImage, p: [f64; 2]| -> f64 {
        let (w, h) = (g.width() as i64, g.height() as i64);
        assert!(p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= (w - 1) as f64 && p[1] <= (h - 1) as f64);
        let (x0, y0) = (p[0].floor() as i64, p[1].floor() as i64);
        let (fx, fy) = (p[0] - x0 as f64, p[1] - y0 as f64);
        let at =
            |x: i64, y: i64| f64::from(g.get_pixel(x.min(w - 1) as u32, y.min(h - 1) as u32)[0]);
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
        let bot = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
        top * (1.0 - fy) + bot * fy
    };
    let b: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_fn(B_SIZE.0, B_SIZE.1, |x, y| {
        let v = bilinear(&pre, t_inv([f64::from(x), f64::from(y)]));
        Luma([(v * 257.0).round().clamp(0.0, 65535.0) as u16])
    });
    b.save(out.join("nuclei_b.png")).unwrap();

    // Landmarks.
    let text = std::fs::read_to_string(src.join("landmarks_00_09.csv")).unwrap();
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    let k = f64::from(A_SIZE) / n;
    let inside = |p: [f64; 2], w: u32, h: u32| {
        p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= f64::from(w - 1) && p[1] <= f64::from(h - 1)
    };
    let mut kept = 0;
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let v: Vec<f64> = f[1..5].iter().map(|s| s.trim().parse().unwrap()).collect();
        let s = [(v[0] + 0.5) * k - 0.5, (v[1] + 0.5) * k - 0.5];
        let d = t([v[2], v[3]]);
        if inside(s, A_SIZE, A_SIZE) && inside(d, B_SIZE.0, B_SIZE.1) {
            csv += &format!("{},{:.4},{:.4},{:.4},{:.4}\n", f[0], s[0], s[1], d[0], d[1]);
            kept += 1;
        }
    }
    std::fs::write(out.join("nuclei_landmarks.csv"), csv).unwrap();
    println!("{kept} landmark pairs");
}

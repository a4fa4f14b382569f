//! Writes the two hard maps of the warping tests and benches (issue 18) into `tests/data/`:
//!
//! * `warp_folded_150x225.json`: a 150 x 225 image's 3 x 4 grid (24 triangles, degree 5)
//!   fitted with the fold barrier off to four landmarks whose targets cross over (two
//!   landmarks 20 px apart swap places), so `phi` folds in the middle of the image;
//! * `warp_bent_2048.json`: a 2048 x 2048 image's 8 x 8 grid (128 triangles, degree 5)
//!   fitted (barrier on, bending `1e-3`) to 60 landmarks on a jittered grid that reaches
//!   the border, displaced by up to 40 px (the larger displacements near the border).
//!
//! Run with `cargo run --release --example warp_maps`; the files are deterministic.

use trimorph::fit::landmarks::Landmark;
use trimorph::fit::{fit, Bend, FitOptions};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::Spline;

/// A small deterministic generator (64-bit LCG, Knuth's constants), values in `[0, 1)`.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn lm(src: [f64; 2], dst: [f64; 2]) -> Landmark {
    Landmark { name: None, src, dst, weight: 1.0 }
}

fn main() {
    // Folded: landmarks a and b, 20 px apart on a row, swap places; two anchors hold the
    // rest of the image (and make the fit well posed).
    let mesh = Mesh::grid(3, 4, 149.0, 224.0, MeshOptions::default()).unwrap();
    let id = Spline::identity(mesh, 5).unwrap();
    let lms = vec![
        lm([65.0, 110.0], [85.0, 112.0]),
        lm([85.0, 112.0], [65.0, 110.0]),
        lm([20.0, 20.0], [20.0, 20.0]),
        lm([130.0, 200.0], [130.0, 200.0]),
        lm([130.0, 20.0], [130.0, 20.0]),
        lm([20.0, 200.0], [20.0, 200.0]),
    ];
    let opts = FitOptions { barrier: None, bend: Bend::Weight(1e-5), ..Default::default() };
    let f = fit(&id, &lms, &opts).expect("folded fit");
    let min = trimorph::warp::field::jacobian_det(&f.spline, 150, 225).1.min_det;
    assert!(min < 0.0, "the folded map must fold (min det J {min})");
    let text = trimorph::io::deformation::to_string(&f.spline, None);
    std::fs::write("tests/data/warp_folded_150x225.json", text).unwrap();
    println!("folded: min det J {min:.3}");

    // Bent: 60 landmarks on a jittered 10 x 6 grid over the whole image (border included).
    let n = 2048.0;
    let mesh = Mesh::grid(8, 8, n - 1.0, n - 1.0, MeshOptions::default()).unwrap();
    let id = Spline::identity(mesh, 5).unwrap();
    let mut rng = Lcg(18);
    let mut lms = Vec::new();
    for j in 0..6 {
        for i in 0..10 {
            let s = [
                (i as f64 + 0.2 + 0.6 * rng.next()) * (n - 1.0) / 10.0,
                (j as f64 + 0.2 + 0.6 * rng.next()) * (n - 1.0) / 6.0,
            ];
            // Larger near the border: 40 px at the edge, 15 px in the centre.
            let edge = (s[0].min(n - 1.0 - s[0]).min(s[1]).min(n - 1.0 - s[1])) / (n / 2.0);
            let len = 40.0 - 25.0 * edge.clamp(0.0, 1.0);
            let a = std::f64::consts::TAU * rng.next();
            lms.push(lm(s, [s[0] + len * a.cos(), s[1] + len * a.sin()]));
        }
    }
    let opts = FitOptions { bend: Bend::Weight(1e-3), ..Default::default() };
    let f = fit(&id, &lms, &opts).expect("bent fit");
    let min = trimorph::warp::field::jacobian_det(&f.spline, 2048, 2048).1.min_det;
    let text = trimorph::io::deformation::to_string(&f.spline, None);
    std::fs::write("tests/data/warp_bent_2048.json", text).unwrap();
    println!("bent: {} landmarks, min det J {min:.3}", lms.len());
}

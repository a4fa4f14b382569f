//! Times `fit_frame` (the landmark-adapted mesh, leave-one-out smoothing, the fit, the fold
//! certificate and the coverage check) on the `fit_frame` bench's landmarks: `N` random
//! landmarks over a 511 x 511 frame, displaced by a smooth field. With `TRIMORPH_TRACE=1`
//! each phase prints its wall time on stderr.
//!
//! ```sh
//! TRIMORPH_TRACE=1 cargo run --release --example fit_profile -- 500 3
//! ```
//!
//! A third argument sets the number of far-field rings (default: the frame fit's 2).

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use trimorph::fit::frame::{fit_frame, FrameFitOptions};
use trimorph::fit::landmarks::Landmark;

/// The bench's landmarks (`benches/fit.rs`, seed 5).
fn landmarks(n: usize, seed: u64) -> Vec<Landmark> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let p: [f64; 2] = [rng.gen_range(5.0..505.0), rng.gen_range(5.0..505.0)];
            let q = [p[0] + 6.0 * (p[1] / 70.0).sin() + 2.0, p[1] + 5.0 * (p[0] / 90.0).cos()];
            Landmark { name: Some(format!("l{i}")), src: p, dst: q, weight: 1.0 }
        })
        .collect()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(500);
    let reps: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(3);
    let lms = landmarks(n, 5);
    let mut opts = FrameFitOptions::default();
    if let Some(rings) = args.next().and_then(|a| a.parse().ok()) {
        opts.mesh.far_rings = rings;
    }
    for _ in 0..reps {
        let t = std::time::Instant::now();
        let f = fit_frame(&lms, [511.0, 511.0], &opts).expect("the bench's landmarks fit");
        println!(
            "{n} landmarks: {} triangles, {} variables, fold-free {}, covers {}: {:.1} ms",
            f.frame.triangles,
            f.fit.report.variables,
            f.fit.report.fold_free,
            f.frame.covers_frame,
            t.elapsed().as_secs_f64() * 1e3
        );
    }
}

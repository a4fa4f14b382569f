//! How big do the exact control points get over a long editing session?
//!
//! Random edits (translate / rotate / scale; random anchor, random neighbourhood radius)
//! on a 50-triangle Delaunay mesh and a 50-triangle grid mesh. At checkpoints it prints the
//! largest numerator and denominator bit size among the stored control points (in lowest
//! terms) and the mean time per edit since the previous checkpoint, as CSV.
//!
//! `cargo run --release --example exact_growth -- [MAX_EDITS] [SECONDS_LIMIT] [BOUNDED_BITS]`
//!
//! With `BOUNDED_BITS` the editor runs in bounded mode (free points of the determining set
//! rounded to multiples of `2^-BITS` after each edit).

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::time::Instant;
use trimorph::edit::select::Neighborhood;
use trimorph::edit::{Editor, Mode};
use trimorph::exact::{Int, Rat};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::{ControlPoint, Spline};

fn sizes(s: &Spline) -> (u64, u64) {
    let (mut n, mut d) = (0, 0);
    for p in s.points().iter().flatten() {
        let r = p.reduced();
        n = n.max(r.numer().bits());
        d = d.max(r.denom().bits());
    }
    (n, d)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let max_edits: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(10_000);
    let limit: f64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(600.0);
    let bounded: Option<u32> = args.get(3).and_then(|a| a.parse().ok());
    let mut rng = SmallRng::seed_from_u64(1);
    let pts: Vec<[f64; 2]> =
        (0..30).map(|_| [rng.gen_range(0.0..200.0), rng.gen_range(0.0..200.0)]).collect();
    let delaunay = Mesh::delaunay(&pts, MeshOptions::default()).unwrap();
    let grid = Mesh::grid(5, 5, 200.0, 200.0, MeshOptions::default()).unwrap();
    println!("mode,mesh,triangles,edits,max_numerator_bits,max_denominator_bits,mean_ms_per_edit");
    let mode = match bounded {
        Some(b) => format!("bounded{b}"),
        None => "unbounded".to_string(),
    };
    for (name, mesh) in [("delaunay", delaunay), ("grid", grid)] {
        let mut ed = Editor::new(Spline::identity(mesh.clone(), 5).unwrap());
        ed.set_bounded(bounded).unwrap();
        let n = ed.spline().num_points();
        let start = Instant::now();
        let mut last = Instant::now();
        let mut done = 0usize;
        let checkpoints = [10usize, 100, 1000, 10_000, 100_000];
        for &cp in checkpoints.iter().filter(|&&c| c <= max_edits) {
            while done < cp {
                let a = rng.gen_range(0..n);
                let hood = Neighborhood::Radius(rng.gen_range(0..4));
                if ed.select(&[ControlPoint(a)], &[], &hood, Mode::Xy).is_err() {
                    continue;
                }
                let q = ed.spline().points()[a].clone();
                let r = match rng.gen_range(0..3) {
                    0 => ed.translate(&[
                        Rat::new(Int::from(rng.gen_range(-16..=16)), Int::from(8)),
                        Rat::new(Int::from(rng.gen_range(-16..=16)), Int::from(8)),
                    ]),
                    1 => ed.rotate([q[0].clone(), q[1].clone()], rng.gen_range(-0.3..0.3)),
                    _ => ed.scale(&q, &Rat::new(Int::from(rng.gen_range(58..=70)), Int::from(64))),
                };
                if r.is_ok() {
                    done += 1;
                }
                if start.elapsed().as_secs_f64() > limit {
                    break;
                }
            }
            let (nb, db) = sizes(ed.spline());
            let ms = last.elapsed().as_secs_f64() * 1e3
                / (cp as f64
                    - (checkpoints.iter().rev().find(|&&c| c < cp).copied().unwrap_or(0)) as f64);
            println!("{mode},{name},{},{done},{nb},{db},{ms:.3}", mesh.num_triangles());
            assert!(ed.spline().check_c1().is_ok());
            last = Instant::now();
            if start.elapsed().as_secs_f64() > limit {
                eprintln!("{name}: time limit reached after {done} edits");
                break;
            }
        }
    }
}

//! Dragging with ECLES: a polyline of 2D points whose second differences must vanish
//! (`p[i-1] - 2 p[i] + p[i+1] = 0`: the points stay evenly spaced on a straight line) is
//! dragged by one end while the other end stays fixed.
//!
//! Shows the two speeds of the API: the `f64` affine fast path for every mouse move, and one
//! exact update to certify the final position.
//!
//! Run with `cargo run --release --example ecles_drag`.

use std::time::Instant;
use trimorph::ecles::{ConstraintSystem, InitOptions};
use trimorph::exact::{rat_from_f64, rat_int, Int, Rat, SparseIntMatrix};

fn main() {
    let n = 40;
    // Constraints: p[i-1] - 2 p[i] + p[i+1] = 0 for i = 1..n-1.
    let rows = (1..n - 1)
        .map(|i| vec![(i - 1, Int::from(1)), (i, Int::from(-2)), (i + 1, Int::from(1))])
        .collect();
    let r = SparseIntMatrix::from_rows(n, rows).expect("valid");
    let sys = ConstraintSystem::homogeneous(r, 2);
    let p: Vec<Vec<Rat>> = (0..n).map(|i| vec![rat_int(i as i64), rat_int(0)]).collect();
    assert!(sys.is_satisfied(&p));

    // Anchor: the last point. Derived: all others but the first (which stays fixed).
    let anchors = [n - 1];
    let derived: Vec<usize> = (1..n - 1).collect();
    let t = Instant::now();
    let mut session = sys.initialize(&p, &anchors, &derived, InitOptions::default()).unwrap();
    println!(
        "initialize: {} relevant constraints, rank {}, {:?}",
        session.relevant().len(),
        session.rank(),
        t.elapsed()
    );

    // The fast path: derived = J * anchor + c (the hints are the fixed current values).
    let map = session.affine_map(None).unwrap().to_f64();
    let hints: Vec<f64> = session.derived_f64().into_iter().flatten().collect();
    let fast = map.with_fixed_hints(&hints);
    let mut out = vec![0.0; derived.len() * 2];
    let t = Instant::now();
    let moves = 10_000;
    for k in 0..moves {
        let angle = (k + 1) as f64 / moves as f64;
        let end = [39.0 * angle.cos(), 39.0 * angle.sin()];
        fast.eval_into(&end, &[], &mut out);
    }
    println!("{moves} f64 drag steps in {:?}", t.elapsed());

    // Certify the final position exactly.
    let end: Vec<Rat> = [39.0 * 1f64.cos(), 39.0 * 1f64.sin()]
        .iter()
        .map(|v| rat_from_f64(*v).expect("finite"))
        .collect();
    let t = Instant::now();
    session.update(&[end], None, None).unwrap();
    let mut full = p.clone();
    session.write_into(&mut full);
    println!(
        "exact update in {:?}; every constraint holds exactly: {}",
        t.elapsed(),
        sys.is_satisfied(&full)
    );
    let mid = session.derived_f64()[18].clone();
    println!(
        "point 19 is now at ({:.6}, {:.6}); fast path said ({:.6}, {:.6})",
        mid[0], mid[1], out[36], out[37]
    );
}

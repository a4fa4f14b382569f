//! Writes a `trimorph solve` problem: the "select all" edit of a degree-5 C1 spline over a
//! random Delaunay mesh (thesis ch. 13): one control point (the one nearest the centre) moves
//! by (1/2, 1/3); every other control point is derived; `R` is the C1 matrix.
//!
//! `cargo run --release --example c1_select_all -- TRIANGLES SEED OUT.json [dense|sparse|spline]`
//!
//! The mesh has the smallest number of random points (uniform in a 200 x 200 square, snapped
//! to 1/16) whose Delaunay triangulation has at least `TRIANGLES` triangles. `dense` writes
//! `R` as rows of `n` integers, `sparse` (the default) as `{"rows": [[[col, val], ...], ...]}`.
//! `spline` writes instead the identity deformation over that mesh (`trimorph edit`'s input;
//! the scaling series of bounded select-all edits in `benches/exact_scaling.sh`).
//!
//! `cargo run --release --example c1_select_all -- banded OUT.json` writes instead the sparse
//! 400 x 800 benchmark of `benches/exact.rs` (`solve_process/sparse_400x800`): 4 nonzeros per
//! row near the diagonal, entries in [-20, 20], anchor 0 moved by (1/2, 1/3), all other
//! parameters derived, `Q = R P`.

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::io::Write;
use trimorph::exact::rat_to_string;
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::Spline;

fn mesh_with(triangles: usize, seed: u64) -> Mesh {
    let mut k = 3 + triangles / 2;
    loop {
        let mut rng = SmallRng::seed_from_u64(seed);
        let pts: Vec<[f64; 2]> =
            (0..k).map(|_| [rng.gen_range(0.0..200.0), rng.gen_range(0.0..200.0)]).collect();
        let m = Mesh::delaunay(&pts, MeshOptions::default()).expect("random points triangulate");
        if m.num_triangles() >= triangles {
            return m;
        }
        k += 1;
    }
}

/// The banded 400 x 800 problem (the same generator as `benches/exact.rs`).
fn banded(out: &str) {
    let (m, n): (usize, usize) = (400, 800);
    let mut rng = SmallRng::seed_from_u64(42);
    let rows: Vec<Vec<(usize, i64)>> = (0..m)
        .map(|i| {
            let c = i * n / m;
            let (lo, hi) = (c.saturating_sub(8), (c + 8).min(n - 1));
            let mut cols: Vec<usize> = Vec::new();
            while cols.len() < 4 {
                let j = rng.gen_range(lo..=hi);
                if !cols.contains(&j) {
                    cols.push(j);
                }
            }
            cols.into_iter()
                .map(|j| (j, [-1, 1][rng.gen_range(0..2)] * rng.gen_range(1..=20)))
                .collect()
        })
        .collect();
    let p: Vec<[i64; 2]> = (0..n).map(|j| [(j % 7) as i64, (j % 5) as i64]).collect();
    let q: Vec<String> = rows
        .iter()
        .map(|r| {
            let (a, b) =
                r.iter().fold((0i64, 0i64), |(a, b), &(j, v)| (a + v * p[j][0], b + v * p[j][1]));
            format!("[{a},{b}]")
        })
        .collect();
    let mut mrows = rows.clone();
    for r in &mut mrows {
        r.sort_unstable();
    }
    let r_json: Vec<String> = mrows
        .iter()
        .map(|r| {
            let e: Vec<String> = r.iter().map(|(j, v)| format!("[{j},{v}]")).collect();
            format!("[{}]", e.join(","))
        })
        .collect();
    let p_json: Vec<String> = p.iter().map(|q| format!("[\"{}\",\"{}\"]", q[0], q[1])).collect();
    let derived: Vec<String> = (1..n).map(|i| i.to_string()).collect();
    let text = format!(
        "{{\"Q\": [{}], \"R\": {{\"rows\": [{}]}}, \"P\": [{}], \"anchors\": {{\"0\": [\"1/2\", \"1/3\"]}}, \"derived\": [{}]}}\n",
        q.join(","),
        r_json.join(","),
        p_json.join(","),
        derived.join(",")
    );
    std::fs::write(out, text).expect("write");
    eprintln!("{out}: banded, R {m} x {n}, anchor 0");
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).is_some_and(|a| a == "banded") {
        banded(args.get(2).map_or("banded.json", String::as_str));
        return;
    }
    let tris: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(102);
    let seed: u64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(7);
    let out = args.get(3).cloned().unwrap_or_else(|| "select_all.json".into());
    let dense = args.get(4).is_some_and(|a| a == "dense");
    let mesh = mesh_with(tris, seed);
    let ntri = mesh.num_triangles();
    let s = Spline::identity(mesh, 5).expect("degree 5");
    if args.get(4).is_some_and(|a| a == "spline") {
        std::fs::write(&out, trimorph::io::deformation::to_string(&s, None)).expect("write");
        eprintln!("{out}: {ntri} triangles, {} control points", s.points().len());
        return;
    }
    let r = s.c1_matrix();
    let (m, n) = (r.rows(), r.cols());
    let pts = s.points();
    let anchor = (0..n)
        .min_by(|&a, &b| {
            let d = |i: usize| {
                let p = s.point_f64(i);
                (p[0] - 100.0).powi(2) + (p[1] - 100.0).powi(2)
            };
            d(a).total_cmp(&d(b))
        })
        .expect("points");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&out).expect("create output"));
    let mut w = |s: &str| f.write_all(s.as_bytes()).expect("write");
    w("{\"R\": ");
    if dense {
        w("[\n");
        for i in 0..m {
            let mut row = vec!["0".to_string(); n];
            for (j, v) in r.row(i) {
                row[*j] = v.to_string();
            }
            w(&format!("[{}]{}\n", row.join(","), if i + 1 < m { "," } else { "" }));
        }
        w("]");
    } else {
        w("{\"rows\": [\n");
        for i in 0..m {
            let e: Vec<String> = r.row(i).iter().map(|(j, v)| format!("[{j},{v}]")).collect();
            w(&format!("[{}]{}\n", e.join(","), if i + 1 < m { "," } else { "" }));
        }
        w("]}");
    }
    w(",\n\"P\": [\n");
    for (i, p) in pts.iter().enumerate() {
        let sep = if i + 1 < n { "," } else { "" };
        w(&format!("[\"{}\",\"{}\"]{sep}\n", rat_to_string(&p[0]), rat_to_string(&p[1])));
    }
    let a = &pts[anchor];
    let half = trimorph::exact::Rat::new(1.into(), 2.into());
    let third = trimorph::exact::Rat::new(1.into(), 3.into());
    w(&format!(
        "],\n\"anchors\": {{\"{anchor}\": [\"{}\", \"{}\"]}},\n\"derived\": [",
        rat_to_string(&(&a[0] + half)),
        rat_to_string(&(&a[1] + third))
    ));
    let derived: Vec<String> = (0..n).filter(|&i| i != anchor).map(|i| i.to_string()).collect();
    w(&derived.join(","));
    w("]}\n");
    f.flush().expect("flush");
    eprintln!("{out}: {ntri} triangles, R {m} x {n}, anchor {anchor}");
}

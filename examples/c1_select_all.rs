//! Writes a `trimorph solve` problem: the "select all" edit of a degree-5 C1 spline over a
//! random Delaunay mesh (thesis ch. 13): one control point (the one nearest the centre) moves
//! by (1/2, 1/3); every other control point is derived; `R` is the C1 matrix.
//!
//! `cargo run --release --example c1_select_all -- TRIANGLES SEED OUT.json [dense|sparse]`
//!
//! The mesh has the smallest number of random points (uniform in a 200 x 200 square, snapped
//! to 1/16) whose Delaunay triangulation has at least `TRIANGLES` triangles. `dense` writes
//! `R` as rows of `n` integers, `sparse` (the default) as `{"rows": [[[col, val], ...], ...]}`.

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

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let tris: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(102);
    let seed: u64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(7);
    let out = args.get(3).cloned().unwrap_or_else(|| "select_all.json".into());
    let dense = args.get(4).is_some_and(|a| a == "dense");
    let mesh = mesh_with(tris, seed);
    let ntri = mesh.num_triangles();
    let s = Spline::identity(mesh, 5).expect("degree 5");
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

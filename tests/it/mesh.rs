//! Integration tests of `trimorph::mesh` through its public API.

use proptest::prelude::*;
use trimorph::io::obj::{read_mesh, write_mesh};
use trimorph::mesh::{Mesh, MeshError, MeshOptions};

fn opts() -> MeshOptions {
    MeshOptions::default()
}

/// Unwraps a build result and runs the invariant checker.
fn built(m: Result<Mesh, MeshError>) -> Mesh {
    let m = m.unwrap_or_else(|e| panic!("expected a valid mesh, got: {e}"));
    m.sanity_check().unwrap_or_else(|e| panic!("sanity check failed: {e}"));
    m
}

/// Unwraps a build error and checks that its message contains every word of `words`.
fn failed(m: Result<Mesh, MeshError>, words: &[&str]) -> MeshError {
    let e = m.expect_err("expected an error");
    let msg = e.to_string();
    for w in words {
        assert!(msg.contains(w), "message {msg:?} lacks {w:?}");
    }
    e
}

/// Six triangles in a strip over 8 vertices: bottom row 0..4 at y = 0, top row 4..8 at y = 1.
fn strip() -> Mesh {
    let v: Vec<[f64; 2]> = (0..8).map(|i| [(i % 4) as f64, (i / 4) as f64]).collect();
    let t: Vec<[usize; 3]> = (0..3).flat_map(|i| [[i, i + 1, i + 5], [i, i + 5, i + 4]]).collect();
    built(Mesh::from_triangles(&v, &t, opts()))
}

/// L-shaped outline (notch at [1, 2] x [1, 2]) with a few inner points.
fn l_shape(reverse: bool) -> Mesh {
    let mut pts = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]];
    pts.extend([[0.5, 0.5], [1.5, 0.5], [0.5, 1.5], [1.0, 0.0], [0.25, 1.0]]);
    let mut outline: Vec<usize> = (0..6).collect();
    outline.insert(1, 9); // (1, 0) lies on the outline
    if reverse {
        outline.reverse();
    }
    built(Mesh::constrained_delaunay(&pts, &outline, opts()))
}

fn euler(m: &Mesh) -> i64 {
    m.num_vertices() as i64 - m.num_edges() as i64 + m.num_triangles() as i64
}

fn centroid(m: &Mesh, t: usize) -> [f64; 2] {
    let [a, b, c] = m.triangle(t).map(|v| m.vertex(v));
    [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0]
}

#[test]
fn grid_counts() {
    let m = built(Mesh::grid(2, 2, 2.0, 2.0, opts()));
    assert_eq!(m.num_vertices(), 9);
    assert_eq!(m.num_triangles(), 8);
    assert_eq!(m.num_edges(), 16);
    assert_eq!(m.num_interior_edges(), 8);
    assert_eq!(m.num_interior_vertices(), 1);
    assert_eq!(euler(&m), 1);
    assert_eq!(m.vertex(5), [2.0, 1.0]);
    assert_eq!(m.vertex_int(5), [32, 16]);
    assert_eq!(m.bbox(), ([0.0, 0.0], [2.0, 2.0]));
    assert_eq!(m.grid_denominator(), 16);
    assert_eq!(m.snap_report().moved, 0);
    let big = built(Mesh::grid(7, 5, 640.0, 480.0, opts()));
    assert_eq!((big.num_vertices(), big.num_triangles()), (48, 70));
    assert_eq!(euler(&big), 1);
}

#[test]
fn strip_counts() {
    let m = strip();
    assert_eq!((m.num_vertices(), m.num_triangles(), m.num_edges()), (8, 6, 13));
    assert_eq!(m.num_interior_edges(), 5);
    assert_eq!(m.num_interior_vertices(), 0);
    assert_eq!(euler(&m), 1);
    let interior: Vec<usize> = (0..m.num_edges()).filter(|&e| !m.is_border_edge(e)).collect();
    assert_eq!(interior.len(), 5);
    assert!((0..8).all(|v| m.is_border_vertex(v)));
    assert_eq!(m.vertex_degree(1), 4);
    assert_eq!(m.vertex_degree(0), 3);
}

#[test]
fn adjacency_is_consistent() {
    let m = strip();
    for t in 0..m.num_triangles() {
        let tri = m.triangle(t);
        for k in 0..3 {
            let (a, b) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let e = m.triangle_edges(t)[k];
            assert_eq!(m.edge_between(a, b), Some(e));
            assert_eq!(m.edge_between(b, a), Some(e));
            let edge = m.edges()[e];
            assert_eq!(edge.v, [a.min(b), a.max(b)]);
            // t is on the left of a -> b, so on the left of v[0] -> v[1] iff a < b.
            assert_eq!(edge.tris[usize::from(a > b)], Some(t));
            assert_eq!(edge.tris[usize::from(a < b)], m.neighbor(t, k));
        }
    }
    assert_eq!(m.edge_between(0, 7), None);
    assert_eq!(m.edge_between(0, 100), None);
}

#[test]
fn snapping_is_reported() {
    let m = built(Mesh::grid(3, 1, 1.0, 1.0, opts()));
    assert_eq!(m.vertex(1), [5.0 / 16.0, 0.0]);
    assert_eq!(m.vertex(2), [11.0 / 16.0, 0.0]);
    let r = m.snap_report();
    assert_eq!((r.grid, r.moved), (16, 4));
    assert!((r.max_shift - 1.0 / 48.0).abs() < 1e-15);
    let fine = built(Mesh::grid(3, 1, 1.0, 1.0, MeshOptions { grid: 3 }));
    assert_eq!(fine.snap_report().moved, 0);
    assert_eq!(fine.vertex_int(2), [2, 0]);
}

#[test]
fn euler_for_disks() {
    let pts: Vec<[f64; 2]> = (0..50)
        .map(|i| [((i * 7919) % 113) as f64 * 0.37, ((i * 104729) % 127) as f64 * 0.29])
        .collect();
    assert_eq!(euler(&built(Mesh::delaunay(&pts, opts()))), 1);
    assert_eq!(euler(&l_shape(false)), 1);
    assert_eq!(euler(&strip()), 1);
}

#[test]
fn errors_name_the_problem() {
    let tri = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    let o = opts();
    failed(Mesh::grid(1, 1, 1.0, 1.0, MeshOptions { grid: 0 }), &["grid", "at least 1", "0"]);
    failed(
        Mesh::from_triangles(&[[0.0, 0.0], [f64::NAN, 0.0], [0.0, 1.0]], &[[0, 1, 2]], o),
        &["vertex 1", "non-finite"],
    );
    failed(
        Mesh::from_triangles(&[[0.0, 0.0], [1e12, 0.0], [0.0, 1.0]], &[[0, 1, 2]], o),
        &["vertex 1", "too large", "2^40"],
    );
    failed(Mesh::delaunay(&tri[..2], o), &["at least 3 points", "got 2"]);
    let dup = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.01, 0.0]];
    let e = failed(Mesh::delaunay(&dup, o), &["vertices 1 and 3", "(1, 0)", "snapping"]);
    assert!(matches!(e, MeshError::Duplicate { first: 1, second: 3, .. }));
    failed(Mesh::delaunay(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.01]], o), &["collinear"]);
    let e = failed(
        Mesh::from_triangles(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.01]], &[[0, 1, 2]], o),
        &["triangle 0", "zero area"],
    );
    assert!(matches!(e, MeshError::Degenerate { triangle: 0 }));
    failed(Mesh::from_triangles(&tri, &[[0, 1, 1]], o), &["triangle 0", "zero area"]);
    failed(
        Mesh::from_triangles(&tri, &[[0, 2, 1]], o),
        &["triangle 0", "clockwise", "list its vertices counter-clockwise"],
    );
    let fan = [[0.0, 0.0], [1.0, 0.0], [0.5, 1.0], [0.5, -1.0], [0.5, 2.0]];
    failed(
        Mesh::from_triangles(&fan, &[[0, 1, 2], [1, 0, 3], [0, 1, 4]], o),
        &["edge 0-1", "more than two triangles"],
    );
    let e = failed(Mesh::from_triangles(&fan, &[[0, 1, 2], [0, 1, 4]], o), &["0->1", "same side"]);
    assert!(matches!(e, MeshError::InconsistentOrientation { a: 0, b: 1 }));
    failed(Mesh::from_triangles(&tri, &[[0, 1, 5]], o), &["triangle 0", "vertex 5", "only 3"]);
    failed(
        Mesh::from_triangles(&[tri[0], tri[1], tri[2], [5.0, 5.0]], &[[0, 1, 2]], o),
        &["vertex 3", "not used"],
    );
    let bowtie = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [-1.0, 0.0], [-1.0, -1.0]];
    let e = failed(
        Mesh::from_triangles(&bowtie, &[[0, 1, 2], [0, 3, 4]], o),
        &["vertex 0", "single fan"],
    );
    assert!(matches!(e, MeshError::NonManifoldVertex { vertex: 0 }));
    let nested = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [1.0, 1.0], [2.0, 1.0], [1.0, 2.0]];
    let e = failed(
        Mesh::from_triangles(&nested, &[[0, 1, 2], [3, 4, 5]], o),
        &["vertex 3", "triangle 0"],
    );
    assert!(matches!(e, MeshError::Overlap { vertex: 3, triangle: 0 }));
    // Star of David: no vertex inside the other triangle, but the borders cross.
    let star = [[0.0, 2.0], [-2.0, -1.0], [2.0, -1.0], [0.0, -2.0], [2.0, 1.0], [-2.0, 1.0]];
    let e =
        failed(Mesh::from_triangles(&star, &[[0, 1, 2], [3, 4, 5]], o), &["border edges", "cross"]);
    assert!(matches!(e, MeshError::BorderIntersection { .. }));
    failed(Mesh::from_triangles(&tri, &[], o), &["no triangles"]);
    failed(Mesh::grid(0, 3, 1.0, 1.0, o), &["no triangles"]);
    failed(read_mesh("v 0 0\nv 1 0\nv 0\n", o), &["line 3", "x and y"]);
    failed(read_mesh("# nothing\n", o), &["no triangles"]);
}

#[test]
fn folded_fan_is_rejected() {
    // A border vertex whose four wedges turn through 390 degrees.
    let mut v = vec![[0.0, 0.0]];
    for (deg, r) in [(0.0f64, 4.0), (120.0, 4.0), (240.0, 4.0), (30.0, 2.0)] {
        v.push([r * deg.to_radians().cos(), r * deg.to_radians().sin()]);
    }
    let m = Mesh::from_triangles(&v, &[[0, 1, 2], [0, 2, 3], [0, 3, 4]], opts());
    failed(m, &["vertex 0", "overlap", "full turn"]);
}

#[test]
fn outline_errors() {
    let pts = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [1.0, 1.0], [3.0, 1.0]];
    let o = opts();
    failed(Mesh::constrained_delaunay(&pts[..5], &[0, 1], o), &["outline", "at least 3"]);
    failed(Mesh::constrained_delaunay(&pts[..5], &[0, 1, 9], o), &["outline", "entry 2 is 9"]);
    failed(Mesh::constrained_delaunay(&pts[..5], &[0, 1, 2, 1], o), &["point 1 appears twice"]);
    failed(Mesh::constrained_delaunay(&pts[..5], &[0, 2, 1, 3], o), &["cross or touch"]);
    failed(Mesh::constrained_delaunay(&pts, &[0, 1, 2, 3], o), &["point 5", "outside the outline"]);
    failed(Mesh::constrained_delaunay(&pts[..5], &[0, 4, 2], o), &["overlap"]);
    failed(Mesh::constrained_delaunay(&pts[..2], &[0, 1], o), &["at least 3 points"]);
    // A closing repetition of the first index is accepted.
    let m = built(Mesh::constrained_delaunay(&pts[..5], &[0, 1, 2, 3, 0], o));
    assert_eq!(m.num_triangles(), 4);
}

#[test]
fn obj_round_trip() {
    for m in [strip(), l_shape(false), built(Mesh::grid(4, 3, 100.0, 75.3, opts()))] {
        let text = write_mesh(&m);
        assert!(text.starts_with("# trimorph mesh"));
        assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), m.num_vertices());
        assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), m.num_triangles());
        let back = built(read_mesh(&text, opts()));
        assert_eq!(back.triangles(), m.triangles());
        assert_eq!(back.vertices(), m.vertices());
        assert_eq!(back.edges(), m.edges());
        assert_eq!(back.snap_report().moved, 0);
    }
}

#[test]
fn obj_dialect() {
    let text = "# a quad and a triangle\nmtllib x.mtl\no quad\nv 0 0 5\nv 1 0 5\nvt 0 0\n\
                vn 0 0 1\nv 1 1 5\nv 0 1 5 # trailing comment\ng part\ns off\nusemtl m\n\
                f 1/1/1 2/1/1 3//1 4\nv 2 0\nf 2 -1 -3\n";
    let m = built(read_mesh(text, opts()));
    assert_eq!(m.num_vertices(), 5);
    assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3], [1, 4, 2]]);
    assert_eq!(m.vertex(4), [2.0, 0.0]);
    let o = opts();
    failed(read_mesh("v 0 0\nv 1 0\nv 0 1\nf 1 2\n", o), &["line 4", "at least 3"]);
    failed(read_mesh("v 0 0\nv 1 0\nv 0 1\nf 0 1 2\n", o), &["line 4", "1-based"]);
    failed(read_mesh("v 0 0\nv 1 0\nv 0 1\nf -4 -2 -1\n", o), &["line 4", "relative"]);
    failed(read_mesh("v 0 0\nv 1 x\n", o), &["line 2", "bad coordinate"]);
    failed(read_mesh("v 0 0\nv 1 0\nv 0 1\nf 1 2 a\n", o), &["line 4", "bad vertex"]);
    failed(read_mesh("v 0 0\nv 1 0\nv 0 1\nf 1 2 4\n", o), &["triangle 0", "vertex 3"]);
    failed(read_mesh("v 0 0\nv 1 0\nv 0 1\nf 1 3 2\n", o), &["clockwise"]);
}

/// Exact in-circle test: > 0 when `d` is strictly inside the circle through ccw `a, b, c`.
fn incircle(a: [i64; 2], b: [i64; 2], c: [i64; 2], d: [i64; 2]) -> i128 {
    let r = |p: [i64; 2]| {
        let (x, y) = ((p[0] - d[0]) as i128, (p[1] - d[1]) as i128);
        [x, y, x * x + y * y]
    };
    let (a, b, c) = (r(a), r(b), r(c));
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn delaunay_of_random_points(
        raw in prop::collection::vec((-100.0f64..100.0, -100.0f64..100.0), 3..60),
        grid in prop::sample::select(vec![1i64, 4, 16]),
    ) {
        let pts: Vec<[f64; 2]> = raw.iter().map(|&(x, y)| [x, y]).collect();
        let o = MeshOptions { grid };
        let m = match Mesh::delaunay(&pts, o) {
            Err(MeshError::Duplicate { .. }) | Err(MeshError::AllCollinear) => return Ok(()),
            r => built(r),
        };
        prop_assert_eq!(m.num_vertices(), pts.len());
        prop_assert_eq!(euler(&m), 1);
        for (i, p) in pts.iter().enumerate() {
            let q = m.vertex(i);
            prop_assert_eq!(q, [(p[0] * grid as f64).round() / grid as f64, (p[1] * grid as f64).round() / grid as f64]);
            prop_assert!(m.snap_report().max_shift <= 0.5f64.sqrt() / grid as f64 + 1e-12);
        }
        for t in 0..m.num_triangles() {
            prop_assert!(m.twice_area_int(t) > 0);
            let [a, b, c] = m.triangle(t).map(|v| m.vertex_int(v));
            for d in 0..m.num_vertices() {
                prop_assert!(incircle(a, b, c, m.vertex_int(d)) <= 0, "vertex {} in circle of {}", d, t);
            }
            let c = centroid(&m, t);
            prop_assert_eq!(m.locate(c, None).map(|r| r.0), Some(t));
        }
    }
}

#[test]
fn constrained_delaunay_keeps_inside() {
    for reverse in [false, true] {
        let m = l_shape(reverse);
        assert_eq!(m.num_vertices(), 11);
        let area: i128 = (0..m.num_triangles()).map(|t| m.twice_area_int(t)).sum();
        assert_eq!(area, 2 * 3 * 256, "L has area 3");
        for t in 0..m.num_triangles() {
            let c = centroid(&m, t);
            assert!(!(c[0] > 1.0 && c[1] > 1.0), "triangle {t} in the notch");
        }
        assert!(m.edge_between(0, 9).is_some() && m.edge_between(9, 1).is_some());
        assert!(m.edge_between(2, 4).is_none(), "no edge across the notch");
    }
}

#[test]
fn locate_finds_points() {
    let pts: Vec<[f64; 2]> =
        (0..80).map(|i| [((i * 37) % 83) as f64 * 1.3, ((i * 61) % 79) as f64 * 0.7]).collect();
    for m in [l_shape(false), strip(), built(Mesh::delaunay(&pts, opts()))] {
        for t in 0..m.num_triangles() {
            let (s, l) = m.locate(centroid(&m, t), None).unwrap();
            assert_eq!(s, t);
            assert!(l.iter().all(|&x| (x - 1.0 / 3.0).abs() < 1e-9), "{l:?}");
        }
        for v in 0..m.num_vertices() {
            let (t, l) = m.locate(m.vertex(v), None).unwrap();
            let k = m.triangle(t).iter().position(|&w| w == v).expect("vertex's triangle");
            assert!((l[k] - 1.0).abs() < 1e-9);
        }
        for e in m.edges() {
            let [a, b] = e.v.map(|v| m.vertex(v));
            let mid = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
            let (t, _) = m.locate(mid, None).unwrap();
            assert!(e.tris.contains(&Some(t)), "midpoint of {e:?} found in {t}");
        }
        let (lo, hi) = m.bbox();
        assert!(m.locate([lo[0] - 1.0, lo[1]], None).is_none());
        assert!(m.locate([hi[0], hi[1] + 1e-3], Some(0)).is_none());
        assert!(m.locate([f64::NAN, 0.0], Some(0)).is_none());
    }
    let l = l_shape(false);
    for p in [[1.5, 1.5], [1.01, 1.99], [1.99, 1.01], [1.0 + 1e-9, 1.5]] {
        assert!(l.locate(p, None).is_none(), "{p:?} is in the notch");
        assert!(l.locate(p, Some(3)).is_none());
    }
    assert!(l.locate([1.0, 1.5], None).is_some(), "on the notch border");
}

#[test]
fn coherent_locate_agrees_and_is_fast() {
    let m = built(Mesh::grid(25, 20, 500.0, 400.0, opts()));
    assert_eq!(m.num_triangles(), 1000);
    let (nx, ny) = (1000, 800);
    let mut hint = None;
    let mut found = 0usize;
    let start = std::time::Instant::now();
    for j in 0..ny {
        for i in 0..nx {
            let p = [(i as f64 + 0.5) * 0.5, (j as f64 + 0.5) * 0.5];
            if let Some((t, _)) = m.locate(p, hint) {
                hint = Some(t);
                found += 1;
            }
        }
    }
    let ns = start.elapsed().as_nanos() as f64 / (nx * ny) as f64;
    assert_eq!(found, nx * ny);
    eprintln!("coherent locate: {ns:.1} ns per query");
    // Loose bound: test builds are not fully optimized; release builds take well under 100 ns.
    assert!(ns < 2000.0, "{ns} ns per query");
    for j in 0..40 {
        let p = [j as f64 * 12.3 + 0.1, j as f64 * 9.7 + 0.2];
        let a = m.locate(p, Some(0)).unwrap();
        let b = m.locate(p, None).unwrap();
        assert_eq!(a.0, b.0);
    }
}

#[test]
fn vertex_fans_turn_counter_clockwise() {
    for m in [built(Mesh::grid(3, 3, 3.0, 3.0, opts())), l_shape(false), strip()] {
        for v in 0..m.num_vertices() {
            let fan = m.vertex_triangles(v);
            let pv = m.vertex(v);
            let mut total = 0.0;
            for (j, &t) in fan.iter().enumerate() {
                let tri = m.triangle(t);
                let i = tri.iter().position(|&w| w == v).unwrap();
                let (a, b) = (m.vertex(tri[(i + 1) % 3]), m.vertex(tri[(i + 2) % 3]));
                let ang = |p: [f64; 2]| (p[1] - pv[1]).atan2(p[0] - pv[0]);
                let mut d = ang(b) - ang(a);
                if d < 0.0 {
                    d += std::f64::consts::TAU;
                }
                total += d;
                if let Some(&next) = fan.get(j + 1) {
                    assert!(m.triangle(next).contains(&tri[(i + 2) % 3]), "fan of {v} at {t}");
                }
            }
            if m.is_border_vertex(v) {
                assert!(total < std::f64::consts::TAU);
                let first = m.triangle(fan[0]);
                let i = first.iter().position(|&w| w == v).unwrap();
                assert_eq!(m.neighbor(fan[0], (i + 2) % 3), None);
            } else {
                assert!((total - std::f64::consts::TAU).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn barycentric_int_sums_to_twice_area() {
    let m = l_shape(false);
    for t in 0..m.num_triangles() {
        let area = m.twice_area_int(t);
        assert!(area > 0);
        for p in [[0, 0], [7, -3], [40, 17], [1 << 40, -(1 << 39)]] {
            assert_eq!(m.barycentric_int(t, p).iter().sum::<i128>(), area);
        }
        for (k, &v) in m.triangle(t).iter().enumerate() {
            let mut expect = [0; 3];
            expect[k] = area;
            assert_eq!(m.barycentric_int(t, m.vertex_int(v)), expect);
            let l = m.barycentric(t, m.vertex(v));
            assert!((l[k] - 1.0).abs() < 1e-12 && l.iter().sum::<f64>() - 1.0 < 1e-12);
        }
        // A grid point's exact coordinates agree with the floating-point ones.
        let p = [13, 9];
        let bi = m.barycentric_int(t, p);
        let bf = m.barycentric(t, [13.0 / 16.0, 9.0 / 16.0]);
        for k in 0..3 {
            assert!((bi[k] as f64 / area as f64 - bf[k]).abs() < 1e-12);
        }
    }
}

#[test]
fn delaunay_of_a_lattice_and_large_coordinates() {
    // Many cocircular quadruples.
    let pts: Vec<[f64; 2]> = (0..100).map(|i| [(i % 10) as f64, (i / 10) as f64]).collect();
    let m = built(Mesh::delaunay(&pts, opts()));
    assert_eq!((m.num_triangles(), euler(&m)), (162, 1));
    // Coordinates close to the 2^40 / grid limit stay exact.
    let s = 6.8e10;
    let m = built(Mesh::grid(2, 2, s, s, opts()));
    let area: i128 = (0..m.num_triangles()).map(|t| m.twice_area_int(t)).sum();
    assert_eq!(area, 2 * (s as i128 * 16).pow(2));
    let pts = [[-s, -s], [s, -s], [s, s], [-s, s], [1.0, 2.0]];
    let m = built(Mesh::delaunay(&pts, opts()));
    assert_eq!(m.num_triangles(), 4);
    assert_eq!(m.locate([0.5, 0.5], None).map(|r| m.triangle(r.0).contains(&4)), Some(true));
}

/// Twice the signed area of a polygon over integer points.
fn shoelace(p: &[[i64; 2]]) -> i128 {
    (0..p.len())
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            a[0] as i128 * b[1] as i128 - a[1] as i128 * b[0] as i128
        })
        .sum()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn constrained_delaunay_of_star_polygons(
        ring in prop::collection::vec((0.0f64..1.0, 2.0f64..10.0), 8..30),
        inner in prop::collection::vec((0.0f64..std::f64::consts::TAU, 0.0f64..1.0), 0..30),
        clockwise in any::<bool>(),
    ) {
        let n = ring.len();
        let step = std::f64::consts::TAU / n as f64;
        let mut pts: Vec<[f64; 2]> = ring
            .iter()
            .enumerate()
            .map(|(i, &(jit, r))| {
                let a = (i as f64 + 0.9 * jit) * step;
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        pts.extend(inner.iter().map(|&(a, r)| [r * a.cos(), r * a.sin()]));
        let mut outline: Vec<usize> = (0..n).collect();
        if clockwise {
            outline.reverse();
        }
        let m = match Mesh::constrained_delaunay(&pts, &outline, opts()) {
            Err(MeshError::Duplicate { .. }) | Err(MeshError::BadOutline(_)) => return Ok(()),
            r => built(r),
        };
        prop_assert_eq!(m.num_vertices(), pts.len());
        prop_assert_eq!(euler(&m), 1);
        let poly: Vec<[i64; 2]> = (0..n).map(|i| m.vertex_int(i)).collect();
        let area: i128 = (0..m.num_triangles()).map(|t| m.twice_area_int(t)).sum();
        prop_assert_eq!(area, shoelace(&poly));
        for i in 0..n {
            prop_assert!(m.edge_between(i, (i + 1) % n).is_some(), "outline edge {} kept", i);
        }
    }
}

//! Unit tests of the mesh module internals (the public API is tested in `tests/it/mesh.rs`).

use super::validate::{on_segment, orient, segments_intersect, snap_points};
use super::*;

fn opts() -> MeshOptions {
    MeshOptions::default()
}

fn built(m: Result<Mesh, MeshError>) -> Mesh {
    let m = m.expect("valid mesh");
    m.sanity_check().expect("sanity");
    m
}

#[test]
fn orientation_and_segments() {
    assert!(orient([0, 0], [1, 0], [0, 1]) > 0);
    assert!(orient([0, 0], [0, 1], [1, 0]) < 0);
    assert_eq!(orient([0, 0], [1, 1], [3, 3]), 0);
    assert!(on_segment([0, 0], [4, 4], [2, 2]));
    assert!(!on_segment([0, 0], [4, 4], [5, 5]));
    // Proper crossing, touching at an end, collinear overlap, collinear apart, parallel.
    assert!(segments_intersect([0, 0], [2, 2], [0, 2], [2, 0]));
    assert!(segments_intersect([0, 0], [2, 0], [1, 0], [1, 5]));
    assert!(segments_intersect([0, 0], [2, 0], [1, 0], [3, 0]));
    assert!(!segments_intersect([0, 0], [1, 0], [2, 0], [3, 0]));
    assert!(!segments_intersect([0, 0], [2, 0], [0, 1], [2, 1]));
    // Large coordinates stay exact.
    let big = (1i64 << 40) - 1;
    assert!(orient([-big, -big], [big, -big], [big, big]) > 0);
}

#[test]
fn snapping_rounds_and_reports() {
    let s = snap_points(&[[0.0, 0.0], [1.0 / 3.0, 0.5], [-0.03, 2.0]], 16).unwrap();
    assert_eq!(s.ints, vec![[0, 0], [5, 8], [0, 32]]);
    assert_eq!(s.report.moved, 2);
    assert!((s.report.max_shift - 0.03).abs() < 1e-15);
    let e = snap_points(&[[0.0, 0.0], [0.01, 0.0]], 16).err().unwrap();
    assert!(matches!(e, MeshError::Duplicate { first: 0, second: 1, .. }));
    let e = snap_points(&[[0.0, 0.0], [1e12, 0.0]], 16).err().unwrap();
    assert!(matches!(e, MeshError::CoordinateOutOfRange { vertex: 1, .. }));
    assert!(snap_points(&[[0.0, 0.0], [1e11, 0.0]], 1).is_ok());
}

#[test]
fn edge_sides_follow_orientation() {
    // One triangle listed with a decreasing pair: 0 -> 2 -> 1 is counter-clockwise.
    let m =
        built(Mesh::from_triangles(&[[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]], &[[0, 2, 1]], opts()));
    for e in m.edges() {
        let forward =
            (0..3).any(|k| m.triangle(0)[k] == e.v[0] && m.triangle(0)[(k + 1) % 3] == e.v[1]);
        let expect = if forward { [Some(0), None] } else { [None, Some(0)] };
        assert_eq!(e.tris, expect, "{e:?}");
    }
    assert_eq!(m.edges()[m.edge_between(1, 0).unwrap()].tris, [None, Some(0)]);
}

#[test]
fn fans_are_ordered() {
    let m = built(Mesh::grid(2, 2, 2.0, 2.0, opts()));
    // Center vertex 4: six triangles, closed loop.
    assert_eq!(m.vertex_triangles(4).len(), 6);
    assert!(!m.is_border_vertex(4));
    assert_eq!(m.vertex_degree(4), 6);
    // Corner 0 has one triangle (lower-left cell split along 0-4 gives two).
    assert_eq!(m.vertex_triangles(0), &[0, 1]);
    assert_eq!(m.vertex_degree(0), 3);
    // Border vertex 1 starts with the triangle whose clockwise side (1-2) is on the border and
    // turns through 1-5 and 1-4 to the border edge 1-0.
    assert_eq!(m.vertex_triangles(1), &[2, 3, 0]);
}

#[test]
fn locator_buckets_are_small() {
    let m = built(Mesh::grid(30, 20, 300.0, 200.0, opts()));
    let (buckets, items) = m.locator.stats();
    assert!(buckets * 3 >= m.num_triangles() && buckets <= m.num_triangles());
    let per = items as f64 / buckets as f64;
    assert!(per < 8.0, "{per} triangles per bucket");
}

#[test]
fn folded_interior_vertex() {
    // Vertex 0 is wrapped twice by six 120-degree wedges.
    let mut v = vec![[0.0, 0.0]];
    for (i, deg) in [0.0f64, 120.0, 240.0, 30.0, 150.0, 270.0].iter().enumerate() {
        let r = if i < 3 { 4.0 } else { 2.0 };
        v.push([r * deg.to_radians().cos(), r * deg.to_radians().sin()]);
    }
    let t: Vec<[usize; 3]> = (0..6).map(|i| [0, 1 + i, 1 + (i + 1) % 6]).collect();
    let e = Mesh::from_triangles(&v, &t, opts()).err().unwrap();
    assert!(matches!(e, MeshError::FoldedVertex { vertex: 0 }), "{e}");
}

#[test]
fn folded_border_vertex() {
    let mut v = vec![[0.0, 0.0]];
    for (deg, r) in [(0.0f64, 4.0), (120.0, 4.0), (240.0, 4.0), (30.0, 2.0)] {
        v.push([r * deg.to_radians().cos(), r * deg.to_radians().sin()]);
    }
    let e = Mesh::from_triangles(&v, &[[0, 1, 2], [0, 2, 3], [0, 3, 4]], opts()).err().unwrap();
    assert!(matches!(e, MeshError::FoldedVertex { vertex: 0 }), "{e}");
}

#[test]
fn bucket_lookup_matches_brute_force() {
    let pts: Vec<[f64; 2]> =
        (0..200).map(|i| [((i * 37) % 101) as f64 * 1.7, ((i * 53) % 97) as f64 * 0.9]).collect();
    let m = built(Mesh::delaunay(&pts, opts()));
    for i in 0..2000 {
        let p = [(i % 50) as f64 * 3.43 - 3.0, (i / 50) as f64 * 2.21 - 2.0];
        let brute = (0..m.num_triangles()).find(|&t| m.barycentric(t, p).iter().all(|&l| l >= 0.0));
        let found = m.locate(p, None);
        assert_eq!(brute.is_some(), found.is_some(), "{p:?}");
        if let Some((t, l)) = found {
            assert!(l.iter().all(|&x| x >= -1e-9), "{t} {l:?}");
        }
    }
}

#[test]
fn grid_too_large_is_an_error_not_an_overflow() {
    // (cols + 1) * (rows + 1) overflowed usize (a panic), and 100000 x 100000 asked for 160 GB.
    let o = MeshOptions::default();
    assert!(matches!(Mesh::grid(usize::MAX, 2, 1.0, 1.0, o), Err(MeshError::GridTooLarge { .. })));
    assert!(matches!(
        Mesh::grid(100_000, 100_000, 10.0, 10.0, o),
        Err(MeshError::GridTooLarge { cols: 100_000, rows: 100_000 })
    ));
    assert!(Mesh::grid(1000, 1, 1000.0, 10.0, o).is_ok());
}

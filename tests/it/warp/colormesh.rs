//! Colored triangle meshes through the public API: image -> mesh -> files -> mesh, deformed
//! by splines, rasterized; malformed files.

use image::{DynamicImage, Rgba, RgbaImage};
use std::path::Path;
use tiny_skia::Pixmap;
use trimorph::exact::{rat_int, Rat};
use trimorph::io::colormesh::{
    load, read_obj, read_ply, save, save_ply, write_ply, Location, MeshFileError, PlyFormat,
};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::render::colormesh::rasterize;
use trimorph::spline::Spline;
use trimorph::warp::colormesh::{ColorMesh, ColorMeshError, ColorMode, Colors};

fn noisy(w: u32, h: u32) -> RgbaImage {
    RgbaImage::from_fn(w, h, |x, y| {
        let v = (x * 7919 + y * 104_729) ^ (x * y * 31);
        Rgba([v as u8, (v >> 8) as u8, (v >> 3) as u8 ^ 0x5a, 255])
    })
}

fn mesh_of(img: &RgbaImage, step: u32, mode: ColorMode) -> ColorMesh {
    ColorMesh::from_image(&DynamicImage::ImageRgba8(img.clone()), step, mode).unwrap()
}

/// A degree-5 spline on a 4x3 grid over [0, 39] x [0, 29], shifted by (dx, dy).
fn spline(dx: i64, dy: i64) -> Spline {
    let mesh = Mesh::grid(4, 3, 39.0, 29.0, MeshOptions::default()).unwrap();
    let id = Spline::identity(mesh.clone(), 5).unwrap();
    let pts: Vec<Vec<Rat>> =
        id.points().iter().map(|p| vec![&p[0] + rat_int(dx), &p[1] + rat_int(dy)]).collect();
    Spline::from_points(mesh, 5, pts, None).unwrap()
}

fn close(a: [f64; 2], b: [f64; 2], tol: f64) -> bool {
    (a[0] - b[0]).abs() <= tol && (a[1] - b[1]).abs() <= tol
}

fn corner_color(m: &ColorMesh, t: usize, c: usize) -> [u8; 4] {
    match &m.colors {
        Colors::PerVertex(col) => col[m.triangles[t][c] as usize],
        Colors::PerTriangle(col) => col[t],
    }
}

#[test]
fn ply_round_trips_are_identical() {
    let dir = tempfile::tempdir().unwrap();
    let img = noisy(23, 17);
    for (mode, step) in [(ColorMode::PerVertex, 2), (ColorMode::Flat, 3)] {
        let mut m = mesh_of(&img, step, mode);
        // Non-integer coordinates and non-opaque colors survive too.
        m.vertices[5] = [4.123_456_789_012_3, -1e-7];
        match &mut m.colors {
            Colors::PerVertex(c) | Colors::PerTriangle(c) => c[1] = [1, 2, 3, 4],
        }
        for (name, fmt) in [
            ("m.ply", PlyFormat::BinaryLittleEndian),
            ("m-ascii.PLY", PlyFormat::Ascii),
            ("m-be.ply", PlyFormat::BinaryBigEndian),
        ] {
            let p = dir.path().join(name);
            save_ply(&m, &p, fmt).unwrap();
            let back = load(&p).unwrap();
            assert_eq!((&back.triangles, &back.colors), (&m.triangles, &m.colors), "{name}");
            assert_eq!(back.vertices.len(), m.vertices.len());
            for (a, b) in m.vertices.iter().zip(&back.vertices) {
                assert!(close(*a, *b, 1e-6), "{name}: {a:?} vs {b:?}");
            }
        }
        // `save` picks binary little endian for .ply.
        let p = dir.path().join("default.ply");
        save(&m, &p).unwrap();
        assert!(std::fs::read(&p).unwrap().starts_with(b"ply\nformat binary_little_endian 1.0\n"));
    }
}

#[test]
fn obj_round_trips_keep_triangles_colors_and_look() {
    let dir = tempfile::tempdir().unwrap();
    let img = noisy(23, 17);
    for (mode, step) in [(ColorMode::PerVertex, 2), (ColorMode::Flat, 3)] {
        let m = mesh_of(&img, step, mode);
        let p = dir.path().join("m.obj");
        save(&m, &p).unwrap();
        let back = load(&p).unwrap();
        // Vertices are renumbered in order of first use (flat meshes: three per triangle),
        // triangles keep their order and corners.
        assert!(matches!(back.colors, Colors::PerVertex(_)));
        assert_eq!(back.triangles.len(), m.triangles.len());
        for t in 0..m.triangles.len() {
            for c in 0..3 {
                let (a, b) = (m.triangles[t][c] as usize, back.triangles[t][c] as usize);
                assert!(close(m.vertices[a], back.vertices[b], 1e-6), "triangle {t}");
                let (ca, cb) = (corner_color(&m, t, c), corner_color(&back, t, c));
                assert!(ca.iter().zip(cb).all(|(x, y)| x.abs_diff(y) <= 1), "{ca:?} {cb:?}");
            }
        }
        let a = rasterize(&m, 23, 17, None).unwrap();
        let b = rasterize(&back, 23, 17, None).unwrap();
        // The same picture: identical where fully covered; along the mesh border the
        // antialiased coverage may differ by 1/255 (a flat mesh read back has separate
        // vertices per triangle, so its fill path is made differently).
        for (x, y) in a.pixels().iter().zip(b.pixels()) {
            if x.alpha() == 255 || y.alpha() == 255 {
                assert_eq!(x, y, "{mode:?}");
            }
            let (x, y) = (
                [x.red(), x.green(), x.blue(), x.alpha()],
                [y.red(), y.green(), y.blue(), y.alpha()],
            );
            assert!(x.iter().zip(y).all(|(p, q)| p.abs_diff(q) <= 1), "{mode:?}: {x:?} {y:?}");
        }
    }
}

#[test]
fn identity_spline_leaves_vertices_in_place() {
    let m = mesh_of(&noisy(40, 30), 1, ColorMode::PerVertex);
    let (d, dropped) = m.deform(&spline(0, 0));
    assert_eq!(dropped, 0);
    assert_eq!((&d.triangles, &d.colors), (&m.triangles, &m.colors));
    for (a, b) in m.vertices.iter().zip(&d.vertices) {
        assert!(close(*a, *b, 1e-9), "{a:?} -> {b:?}");
    }
}

fn rgba(pm: &Pixmap, x: u32, y: u32) -> [u8; 4] {
    let c = pm.pixel(x, y).unwrap().demultiply();
    [c.red(), c.green(), c.blue(), c.alpha()]
}

#[test]
fn a_shifted_spline_shifts_the_picture() {
    let img = noisy(40, 30);
    let (d, dropped) = mesh_of(&img, 1, ColorMode::PerVertex).deform(&spline(3, 2));
    assert_eq!(dropped, 0);
    let bg = [7, 8, 9, 255];
    let pm = rasterize(&d, 40, 30, Some(bg)).unwrap();
    for y in 0..30 {
        for x in 0..40 {
            // Pixels fully inside phi(mesh) = [3, 42] x [2, 31]: the source pixel, exactly;
            // pixels it does not reach: the background; the half-covered row and column
            // x = 3, y = 2 are a blend.
            if x >= 4 && y >= 3 {
                assert_eq!(rgba(&pm, x, y), img.get_pixel(x - 3, y - 2).0, "({x}, {y})");
            } else if x < 3 || y < 2 {
                assert_eq!(rgba(&pm, x, y), bg, "({x}, {y})");
            }
        }
    }
}

/// The message of an error, which must be a format error at `location`.
fn format_error(e: MeshFileError, location: Location) -> String {
    let text = e.to_string();
    match e {
        MeshFileError::Format { location: l, .. } => assert_eq!(l, location, "{text}"),
        other => panic!("not a format error: {other}"),
    }
    text
}

fn ascii_ply(vertices: &str, faces: &str) -> String {
    format!(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n{vertices}{faces}"
    )
}

#[test]
fn malformed_ply_files_are_errors_naming_the_problem() {
    let p = Path::new("bad.ply");
    let ok_v = "0 0 1 2 3\n5 0 4 5 6\n0 5 7 8 9\n";
    assert_eq!(read_ply(ascii_ply(ok_v, "3 0 1 2\n").as_bytes(), p).unwrap().triangles.len(), 1);
    // Bad index, on line 15 (the face line; 11 header lines, 3 vertex lines).
    let e = read_ply(ascii_ply(ok_v, "3 0 1 7\n").as_bytes(), p).unwrap_err();
    let msg = format_error(e, Location::Line(15));
    assert!(msg.contains("bad.ply: line 15: face 0: vertex index 7 out of range (3 vertices)"));
    // NaN coordinate.
    let e = read_ply(ascii_ply("0 0 1 2 3\nnan 0 4 5 6\n0 5 7 8 9\n", "3 0 1 2\n").as_bytes(), p)
        .unwrap_err();
    assert!(format_error(e, Location::Line(13)).contains("vertex 1: coordinates (NaN"));
    // Truncated binary file: the last face is cut.
    let m = mesh_of(&noisy(6, 5), 1, ColorMode::Flat);
    let bytes = write_ply(&m, PlyFormat::BinaryLittleEndian);
    let e = read_ply(&bytes[..bytes.len() - 3], p).unwrap_err();
    let last = Location::Element { name: "face".into(), index: m.triangles.len() as u64 - 1 };
    assert!(format_error(e, last).contains("face 39: unexpected end of file"));
    // A header claiming 10^12 vertices in a small file is refused before any allocation.
    let huge = ascii_ply(ok_v, "3 0 1 2\n").replace("vertex 3", "vertex 1000000000000");
    let e = read_ply(huge.as_bytes(), p).unwrap_err();
    assert!(format_error(e, Location::Header).contains("1000000000000 `vertex` elements"));
    // No colors at all.
    let plain = ascii_ply("0 0\n5 0\n0 5\n", "3 0 1 2\n")
        .replace("property uchar red\nproperty uchar green\nproperty uchar blue\n", "");
    let e = read_ply(plain.as_bytes(), p).unwrap_err();
    assert!(format_error(e, Location::Header).contains("no colors"));
    // Wrong value type and extra values.
    let e = read_ply(ascii_ply(ok_v, "3 0 1.5 2\n").as_bytes(), p).unwrap_err();
    assert!(format_error(e, Location::Line(15)).contains("`1.5`"));
    let e = read_ply(ascii_ply("0 0 1 2 3 4\n5 0 4 5 6\n0 5 7 8 9\n", "3 0 1 2\n").as_bytes(), p)
        .unwrap_err();
    assert!(format_error(e, Location::Line(12)).contains("extra value `4`"));
    let e = read_ply(b"ply\nformat ascii 1.0\nelement vertex 1\n", p).unwrap_err();
    assert!(format_error(e, Location::Line(4)).contains("end_header"));
    let e = read_ply(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x y\n", p);
    assert!(format_error(e.unwrap_err(), Location::Line(4)).contains("malformed property"));
}

#[test]
fn ply_face_colors_polygons_and_other_elements() {
    // Float face colors and alpha, a quad (fan-triangulated), a `vertex_index` list of uint
    // with an int count, an extra vertex property and an unknown element, all skipped.
    let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n\
                property double z\nproperty float confidence\nelement face 1\n\
                property list int uint vertex_index\nproperty float red\nproperty float green\n\
                property float blue\nproperty uchar alpha\nelement edge 1\n\
                property int vertex1\nproperty int vertex2\nend_header\n\
                0 0 0 0.5\n4 0 0 0.5\n4 3 0 0.5\n0 3 0 0.5\n4 0 1 2 3 1 0.5 0 128\n0 1\n";
    let m = read_ply(text.as_bytes(), Path::new("x.ply")).unwrap();
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(m.colors, Colors::PerTriangle(vec![[255, 128, 0, 128]; 2]));
    assert_eq!(m.vertices[2], [4.0, 3.0]);
    // Float colors outside 0..1 are an error.
    let e = read_ply(text.replace(" 1 0.5 0 128", " 2 0.5 0 128").as_bytes(), Path::new("x.ply"))
        .unwrap_err();
    assert!(format_error(e, Location::Line(22)).contains("red = 2 is outside 0..1"));
}

#[test]
fn obj_reads_colors_objects_and_polygons() {
    let p = Path::new("m.obj");
    let text = "o a\nv 0 0 0 1 0 0\nv 4 0 0 0 1 0\nv 4 3 0 0 0 1\nv 0 3 0 1 1 1\nf 1 2 3 4\n\
                o b\nv 9 9 0.5 0.2 0.4 0.6\nf -1 1 2\n";
    let m = read_obj(text.as_bytes(), p).unwrap();
    m.validate().unwrap();
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6]]);
    assert_eq!(m.vertices[4], [9.0, 9.0]);
    let Colors::PerVertex(c) = &m.colors else { panic!("per vertex") };
    assert_eq!((c[0], c[3], c[4]), ([255, 0, 0, 255], [255; 4], [51, 102, 153, 255]));
    // 0..255 colors when a component exceeds 1.
    let m = read_obj(b"v 0 0 0 10 1 0\nv 1 0 0 0 0 0\nv 0 1 0 0 0 0\nf 1 2 3\n", p).unwrap();
    let black = [0, 0, 0, 255];
    assert_eq!(m.colors, Colors::PerVertex(vec![[10, 1, 0, 255], black, black]));
}

#[test]
fn malformed_obj_files_are_errors_naming_the_line() {
    let cases: [(&str, Location, &str); 6] = [
        ("v 0 0 0 1 1 1\nv 1 0 0\nf 1 2 1\n", Location::Line(2), "vertex without a color"),
        ("v 0 0 0 1 1 1\nv nan 0 0 1 1 1\n", Location::Line(2), "vertex coordinate NaN"),
        ("v 0 0 0 1 1 1\nv 0 x 0 1 1 1\n", Location::Line(2), "`x` is not a number"),
        ("v 0 0 0 1 1 1\nv 0 0 0 1 1 -1\n", Location::Line(2), "color component -1"),
        ("v 0 0 0 1 1 1\n\nf 1 2 1\n", Location::Line(3), "face vertex index out of bounds"),
        ("v 0 0 0 1 1 1\n", Location::File, "no triangles"),
    ];
    for (text, at, want) in cases {
        let e = read_obj(text.as_bytes(), Path::new("m.obj")).unwrap_err();
        let msg = format_error(e, at.clone());
        assert!(msg.starts_with(&format!("m.obj: {at}: {want}")), "{msg}");
    }
    let e = read_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", Path::new("m.obj")).unwrap_err();
    assert!(e.to_string().contains("(or use PLY)"), "{e}");
}

#[test]
fn files_names_and_invalid_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh_of(&noisy(4, 4), 1, ColorMode::PerVertex);
    let p = dir.path().join("m.stl");
    assert!(matches!(save(&m, &p), Err(MeshFileError::UnknownFormat { .. })));
    assert!(matches!(load(&p), Err(MeshFileError::UnknownFormat { .. })));
    let missing = dir.path().join("missing.OBJ");
    let e = load(&missing).unwrap_err();
    assert!(matches!(e, MeshFileError::Read { .. }) && e.to_string().contains("missing.OBJ"));
    // An invalid mesh is not written, and an older file stays.
    let p = dir.path().join("m.ply");
    save(&m, &p).unwrap();
    let mut bad = m.clone();
    bad.triangles[0][0] = 99;
    assert!(matches!(
        save(&bad, &p),
        Err(MeshFileError::Mesh(ColorMeshError::Index { triangle: 0, index: 99, .. }))
    ));
    assert_eq!(load(&p).unwrap(), m);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn a_binary_ply_error_names_its_element_once() {
    // Found by the adversarial pass: "face 0: face 0: vertex index ..." in binary files,
    // where the location already names the element.
    let m = mesh_of(&noisy(6, 5), 1, ColorMode::Flat);
    let mut bytes = write_ply(&m, PlyFormat::BinaryLittleEndian);
    let body = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    // Vertex 1's x (doubles x, y, z per vertex; flat colours are per face).
    bytes[body + 24..body + 32].copy_from_slice(&f64::NAN.to_le_bytes());
    let e = read_ply(&bytes, Path::new("bad.ply")).unwrap_err();
    let msg = format_error(e, Location::Element { name: "vertex".into(), index: 1 });
    assert!(msg.contains("vertex 1: coordinates (NaN"), "{msg}");
    assert!(!msg.contains("vertex 1: vertex 1"), "{msg}");
}

//! Criterion benches of colored triangle meshes (issue "Warping", point 3), on a 512x512 RGB
//! image at step 2 (about 131,000 triangles):
//!
//! * `from_image_512_step2`: image to per-vertex colored mesh;
//! * `deform_512_step2`: every vertex through a degree-5 identity spline on a 10x10-cell grid
//!   (200 triangles);
//! * `rasterize_512`: color field plus one antialiased tiny-skia fill at 512x512.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use image::{DynamicImage, Rgb, RgbImage};
use std::hint::black_box;
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::render::colormesh::rasterize;
use trimorph::spline::Spline;
use trimorph::warp::colormesh::{ColorMesh, ColorMode};

fn bench(c: &mut Criterion) {
    let img = DynamicImage::ImageRgb8(RgbImage::from_fn(512, 512, |x, y| {
        Rgb([(x / 2) as u8, (y / 2) as u8, ((x ^ y) & 0xff) as u8])
    }));
    let mesh = ColorMesh::from_image(&img, 2, ColorMode::PerVertex).expect("mesh");
    let grid = Mesh::grid(10, 10, 511.0, 511.0, MeshOptions::default()).expect("grid");
    let spline = Spline::identity(grid, 5).expect("spline");
    eprintln!(
        "color mesh: {} vertices, {} triangles; spline mesh: {} triangles",
        mesh.vertices.len(),
        mesh.triangles.len(),
        spline.mesh().num_triangles()
    );
    let (deformed, dropped) = mesh.deform(&spline);
    assert_eq!(dropped, 0);

    let mut g = c.benchmark_group("colormesh");
    g.throughput(Throughput::Elements(mesh.triangles.len() as u64));
    g.bench_function("from_image_512_step2", |b| {
        b.iter(|| ColorMesh::from_image(black_box(&img), 2, ColorMode::PerVertex))
    });
    g.bench_function("deform_512_step2", |b| b.iter(|| black_box(&mesh).deform(&spline)));
    g.bench_function("rasterize_512", |b| {
        b.iter(|| rasterize(black_box(&deformed), 512, 512, Some([255, 255, 255, 255])))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

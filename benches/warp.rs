//! Criterion benches of warping (issue: warping).
//!
//! * `warp_4096_gray8_bilinear`: a 4096 x 4096 8-bit gray image through a 200-triangle
//!   degree-5 deformation (two interior anchors dragged), bilinear, including the inverse
//!   map (coarse Newton nodes + certified interpolation, 0.01 px); target 100 MP/s.
//! * `warp_4096_gray8_bilinear_mild`: the same with drags of 1% of the image size.
//! * `preimages_4096`: the inverse map alone (into one full-size buffer).
//! * `forward_1e6`: 10^6 points forward; target 20 M points/s.
//! * `warp_2048_{gray8,la8,rgb8,rgba8,gray16,la16,rgb16,rgba16,rgb32f,rgba32f}_bilinear`:
//!   every pixel type of `image::DynamicImage` the warp takes, through the mild deformation
//!   at 2048 x 2048 (inverse map included).
//! * `resample_1024_{u8,u16,f32}x{1,2,3,4}`: bilinear resampling alone
//!   (`warp::sample::fill_pixels`, one thread) of a 1024 x 1024 image at the positions of a
//!   small rotation, for every sample type and channel count (the vector paths of
//!   `sample_simd*`; f32 gray and gray + alpha are reachable only through
//!   `warp_samples_into` and tiles).
//! * `resample_1024_{u8,u16,f32}x{1,2,3,4}_bicubic`: the same, bicubic (the AVX2 kernels
//!   of `sample_simd_cubic` for u8, `sample_simd_cubic_wide` for u16 and f32).
//! * `resample_1024_{u8,u16,f32}x{1,2,3,4}_nearest`: the same, nearest, every sample type
//!   and channel count (the AVX2 kernels of `sample_simd_nearest`).
//! * `warp_2048_gray8_bent` and `warp_2048_gray8_mild`: the strongly bent map of
//!   `tests/data/warp_bent_2048.json` (60 landmarks, displacements up to 40 px) against a mild
//!   one; target: bent within 2x of mild (issue 18).
//! * `warp_150x225_gray8_folded`: the folded map of `tests/data/warp_folded_150x225.json`;
//!   target under 10 ms (issue 18).
//! * `tiles_4096_gray8_1024`: the 4096 x 4096 warp of `warp_4096_gray8_bilinear` done as 16
//!   tiles of 1024 x 1024, each planned and warped from its own input window
//!   (`warp::tiles`, what a Dask task does), one after the other: the tiling's overhead
//!   (issue 21).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use image::{DynamicImage, GrayImage, ImageBuffer, Luma, LumaA, Rgb, Rgba};
use std::hint::black_box;
use trimorph::edit::select::Neighborhood;
use trimorph::edit::{Editor, Mode};
use trimorph::exact::rat_int;
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::{ControlPoint, Spline};
use trimorph::warp::remap::{preimage_grid, RemapOptions};
use trimorph::warp::sample::{fill_pixels, Source, Texel};
use trimorph::warp::tiles::{warp_tile_into, Rect, TileLayout, TilePlanner};
use trimorph::warp::{forward, warp_pages, Interp, Samples, SamplesMut, WarpOptions};

/// A 10 x 10 grid (200 triangles) over `[0, size-1]^2`, degree 5, with two interior vertices
/// dragged by a few percent of the image size.
pub fn deformation(size: f64) -> Spline {
    deformation_with(size, 40.0)
}

/// As [`deformation`], the drags `size / div` long.
pub fn deformation_with(size: f64, div: f64) -> Spline {
    let mesh = Mesh::grid(10, 10, size - 1.0, size - 1.0, MeshOptions::default()).unwrap();
    let mut ed = Editor::new(Spline::identity(mesh.clone(), 5).unwrap());
    let inner: Vec<usize> =
        (0..mesh.num_vertices()).filter(|&v| !mesh.is_border_vertex(v)).collect();
    let step = (size / div) as i64;
    for (k, &v) in [inner[20], inner[50]].iter().enumerate() {
        ed.select(&[ControlPoint(v)], &[], &Neighborhood::Radius(2), Mode::Xy).unwrap();
        ed.translate(&[rat_int(step * (k as i64 * 2 - 1)), rat_int(step / 2)]).unwrap();
    }
    ed.into_spline()
}

fn bench(c: &mut Criterion) {
    let n = 4096u32;
    let s = deformation(n as f64);
    assert_eq!(s.mesh().num_triangles(), 200);
    let img = DynamicImage::ImageLuma8(GrayImage::from_fn(n, n, |x, y| {
        Luma([((x / 7 + y / 5) % 2 * 200 + (x ^ y) % 50) as u8])
    }));
    let opts = WarpOptions::default();
    let (_, rep) = warp_pages(&s, std::slice::from_ref(&img), &opts, &|_| {}).unwrap();
    eprintln!(
        "4096^2: {} Newton solves, {:.1}% interpolated, max error bound {:.2e} px",
        rep.newton_solves,
        100.0 * rep.interpolated as f64 / rep.pixels as f64,
        rep.max_error_bound
    );
    let mut g = c.benchmark_group("warp");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64 * n as u64));
    g.bench_function("warp_4096_gray8_bilinear", |b| {
        b.iter(|| {
            let (out, _) = warp_pages(&s, std::slice::from_ref(&img), &opts, &|_| {}).unwrap();
            black_box(out)
        })
    });
    // A milder deformation (drags of 1% of the image size, the scale of registration
    // corrections): fewer lattice refinements.
    let mild = deformation_with(n as f64, 100.0);
    g.bench_function("warp_4096_gray8_bilinear_mild", |b| {
        b.iter(|| {
            let (out, _) = warp_pages(&mild, std::slice::from_ref(&img), &opts, &|_| {}).unwrap();
            black_box(out)
        })
    });
    // Tile by tile, each from its planned window (the copy into the window included).
    let planner = TilePlanner::with_resolution(&s, (n, n), &opts.remap, 102.4);
    let tiles: Vec<(Rect, Rect)> = (0..16u32)
        .map(|k| {
            let t = Rect { x0: k % 4 * 1024, y0: k / 4 * 1024, w: 1024, h: 1024 };
            (t, planner.input_rect(t).expect("every tile has input"))
        })
        .collect();
    let raw = img.as_luma8().expect("gray image").as_raw();
    let mut out = vec![0u8; 1024 * 1024];
    g.bench_function("tiles_4096_gray8_1024", |b| {
        b.iter(|| {
            for &(tile, win) in &tiles {
                let mut w = Vec::with_capacity(win.len());
                for y in win.y0..win.y0 + win.h {
                    let a = (y * n + win.x0) as usize;
                    w.extend_from_slice(&raw[a..a + win.w as usize]);
                }
                let layout = TileLayout { size: (n, n), tile, window: win, channels: 1 };
                let pages = [Samples::U8(&w)];
                warp_tile_into(&s, layout, &pages, &mut [SamplesMut::U8(&mut out)], &opts).unwrap();
                black_box(&out);
            }
        })
    });
    g.bench_function("preimages_4096", |b| {
        b.iter(|| black_box(preimage_grid(&s, n, n, RemapOptions::default())))
    });
    let pts: Vec<[f64; 2]> =
        (0..1_000_000).map(|k| [(k % 1000) as f64 * 4.09, (k / 1000) as f64 * 4.09]).collect();
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("forward_1e6", |b| b.iter(|| black_box(forward(&s, &pts))));
    g.finish();
    by_type_and_hard_maps(c);
}

/// A map written by `examples/warp_maps.rs`.
fn test_map(text: &str) -> Spline {
    trimorph::io::deformation::from_str(text).expect("test map").0
}

fn by_type_and_hard_maps(c: &mut Criterion) {
    let n = 2048u32;
    let v = |x: u32, y: u32| ((x / 7 + y / 5) % 2 * 200 + (x ^ y) % 50) as u8;
    let gray = DynamicImage::ImageLuma8(GrayImage::from_fn(n, n, |x, y| Luma([v(x, y)])));
    let images = [
        ("gray8", gray.clone()),
        (
            "la8",
            DynamicImage::ImageLumaA8(ImageBuffer::from_fn(n, n, |x, y| {
                LumaA([v(x, y), 255 - v(x, y) / 4])
            })),
        ),
        (
            "rgb8",
            DynamicImage::ImageRgb8(ImageBuffer::from_fn(n, n, |x, y| {
                Rgb([v(x, y), v(x, y) / 2 + 60, 255 - v(x, y)])
            })),
        ),
        (
            "rgba8",
            DynamicImage::ImageRgba8(ImageBuffer::from_fn(n, n, |x, y| {
                Rgba([v(x, y), v(x, y) / 2 + 60, 255 - v(x, y), 200])
            })),
        ),
        (
            "gray16",
            DynamicImage::ImageLuma16(ImageBuffer::from_fn(n, n, |x, y| {
                Luma([v(x, y) as u16 * 257])
            })),
        ),
        (
            "la16",
            DynamicImage::ImageLumaA16(ImageBuffer::from_fn(n, n, |x, y| {
                LumaA([v(x, y) as u16 * 257, 65535 - v(x, y) as u16 * 64])
            })),
        ),
        (
            "rgb16",
            DynamicImage::ImageRgb16(ImageBuffer::from_fn(n, n, |x, y| {
                let g = v(x, y) as u16 * 257;
                Rgb([g, g / 2 + 9000, 65535 - g])
            })),
        ),
        (
            "rgba16",
            DynamicImage::ImageRgba16(ImageBuffer::from_fn(n, n, |x, y| {
                let g = v(x, y) as u16 * 257;
                Rgba([g, g / 2 + 9000, 65535 - g, 52000])
            })),
        ),
        (
            "rgb32f",
            DynamicImage::ImageRgb32F(ImageBuffer::from_fn(n, n, |x, y| {
                let f = v(x, y) as f32 / 255.0;
                Rgb([f, 0.5 * f, 1.0 - f])
            })),
        ),
        (
            "rgba32f",
            DynamicImage::ImageRgba32F(ImageBuffer::from_fn(n, n, |x, y| {
                let f = v(x, y) as f32 / 255.0;
                Rgba([f, 0.5 * f, 1.0 - f, 0.8])
            })),
        ),
    ];
    let mild = deformation_with(n as f64, 100.0);
    let bent = test_map(include_str!("../tests/data/warp_bent_2048.json"));
    let folded = test_map(include_str!("../tests/data/warp_folded_150x225.json"));
    let opts = WarpOptions::default();
    let mut g = c.benchmark_group("warp_types");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64 * n as u64));
    for (name, img) in &images {
        g.bench_function(format!("warp_2048_{name}_bilinear"), |b| {
            b.iter(|| black_box(warp_pages(&mild, std::slice::from_ref(img), &opts, &|_| {})))
        });
    }
    for (name, s) in [("mild", &mild), ("bent", &bent)] {
        let (_, rep) = warp_pages(s, std::slice::from_ref(&gray), &opts, &|_| {}).unwrap();
        eprintln!("2048^2 {name}: {}", rep.paths_line());
        g.bench_function(format!("warp_2048_gray8_{name}"), |b| {
            b.iter(|| black_box(warp_pages(s, std::slice::from_ref(&gray), &opts, &|_| {})))
        });
    }
    let small = DynamicImage::ImageLuma8(GrayImage::from_fn(150, 225, |x, y| Luma([v(x, y)])));
    let (_, rep) = warp_pages(&folded, std::slice::from_ref(&small), &opts, &|_| {}).unwrap();
    eprintln!("150x225 folded: {}", rep.paths_line());
    g.throughput(Throughput::Elements(150 * 225));
    g.bench_function("warp_150x225_gray8_folded", |b| {
        b.iter(|| black_box(warp_pages(&folded, std::slice::from_ref(&small), &opts, &|_| {})))
    });
    g.finish();
    resample_by_type(c);
}

/// Bilinear, bicubic and nearest resampling alone, every sample type and channel count: a
/// 1024 x 1024 image at the positions of a 2-degree rotation about its centre
/// (a few pixels near the corners fall outside and take the scalar path, as in a warp).
fn resample_by_type(c: &mut Criterion) {
    let n = 1024usize;
    let (s, co) = (2f64.to_radians().sin(), 2f64.to_radians().cos());
    let m = (n - 1) as f64 / 2.0;
    let pos: Vec<[f64; 2]> = (0..n * n)
        .map(|k| {
            let (x, y) = ((k % n) as f64 - m, (k / n) as f64 - m);
            [m + co * x - s * y, m + s * x + co * y]
        })
        .collect();
    let v = |k: usize| ((k / 7 + k / 5000) % 2 * 200 + k % 50) as f32;
    let mut g = c.benchmark_group("resample");
    g.sample_size(10);
    g.throughput(Throughput::Elements((n * n) as u64));
    fn one<T: Texel, const NC: usize>(
        g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
        name: &str,
        data: &[T],
        n: usize,
        pos: &[[f64; 2]],
        interp: Interp,
    ) {
        let src = Source { data, w: n, h: n, nc: NC };
        let mut out = vec![T::from_f32(0.0); NC * pos.len()];
        let suffix = match interp {
            Interp::Bicubic => "_bicubic",
            Interp::Nearest => "_nearest",
            Interp::Bilinear => "",
        };
        g.bench_function(format!("resample_{n}_{name}x{NC}{suffix}"), |b| {
            b.iter(|| {
                fill_pixels::<T, NC>(&src, pos, &mut out, interp, 0.0);
                black_box(&out);
            })
        });
    }
    let u8s: Vec<u8> = (0..4 * n * n).map(|k| v(k) as u8).collect();
    let u16s: Vec<u16> = (0..4 * n * n).map(|k| v(k) as u16 * 257).collect();
    let f32s: Vec<f32> = (0..4 * n * n).map(|k| v(k) / 255.0).collect();
    for interp in [Interp::Bilinear, Interp::Bicubic] {
        one::<u8, 1>(&mut g, "u8", &u8s[..n * n], n, &pos, interp);
        one::<u8, 2>(&mut g, "u8", &u8s[..2 * n * n], n, &pos, interp);
        one::<u8, 3>(&mut g, "u8", &u8s[..3 * n * n], n, &pos, interp);
        one::<u8, 4>(&mut g, "u8", &u8s, n, &pos, interp);
    }
    for interp in [Interp::Bilinear, Interp::Bicubic, Interp::Nearest] {
        if interp == Interp::Nearest {
            one::<u8, 1>(&mut g, "u8", &u8s[..n * n], n, &pos, interp);
            one::<u8, 2>(&mut g, "u8", &u8s[..2 * n * n], n, &pos, interp);
            one::<u8, 3>(&mut g, "u8", &u8s[..3 * n * n], n, &pos, interp);
            one::<u8, 4>(&mut g, "u8", &u8s, n, &pos, interp);
        }
        one::<u16, 1>(&mut g, "u16", &u16s[..n * n], n, &pos, interp);
        one::<u16, 2>(&mut g, "u16", &u16s[..2 * n * n], n, &pos, interp);
        one::<u16, 3>(&mut g, "u16", &u16s[..3 * n * n], n, &pos, interp);
        one::<u16, 4>(&mut g, "u16", &u16s, n, &pos, interp);
        one::<f32, 1>(&mut g, "f32", &f32s[..n * n], n, &pos, interp);
        one::<f32, 2>(&mut g, "f32", &f32s[..2 * n * n], n, &pos, interp);
        one::<f32, 3>(&mut g, "f32", &f32s[..3 * n * n], n, &pos, interp);
        one::<f32, 4>(&mut g, "f32", &f32s, n, &pos, interp);
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

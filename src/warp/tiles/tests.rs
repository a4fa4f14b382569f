//! Tiled warps (issue 21): every tiling gives exactly the whole-image warp, each tile reading
//! only its planned input window; a window too small is refused, not sampled wrong.

use super::*;
use crate::mesh::{Mesh, MeshOptions};
use crate::warp::{warp_samples_into, Interp, Layout, RemapOptions};
use proptest::prelude::*;

/// The maps written by `examples/warp_maps.rs`: a folded one and a strongly bent one.
fn load(name: &str) -> Spline {
    let text = match name {
        "folded" => include_str!("../../../tests/data/warp_folded_150x225.json"),
        _ => include_str!("../../../tests/data/warp_bent_2048.json"),
    };
    crate::io::deformation::from_str(text).expect("test map").0
}

fn image(w: u32, h: u32, nc: usize) -> Vec<u8> {
    (0..w as usize * h as usize * nc).map(|k| ((k * 37 + k / 7 * 11) % 251) as u8).collect()
}

fn whole(s: &Spline, w: u32, h: u32, nc: usize, img: &[u8], opts: &WarpOptions) -> Vec<u8> {
    let mut out = vec![0u8; img.len()];
    let layout = Layout { width: w, height: h, channels: nc };
    warp_samples_into(
        s,
        layout,
        &[Samples::U8(img)],
        &mut [SamplesMut::U8(&mut out)],
        opts,
        &|_| {},
    )
    .unwrap();
    out
}

/// The rectangle `r` of an interleaved `w`-wide image.
fn crop<T: Copy>(img: &[T], w: u32, nc: usize, r: Rect) -> Vec<T> {
    let mut out = Vec::with_capacity(r.len() * nc);
    for y in r.y0..r.y0 + r.h {
        let a = (y as usize * w as usize + r.x0 as usize) * nc;
        out.extend_from_slice(&img[a..a + r.w as usize * nc]);
    }
    out
}

/// Warps every `tw x th` tile from its planned window only and checks it against `full`.
fn check_tiling(s: &Spline, w: u32, h: u32, nc: usize, tw: u32, th: u32, opts: &WarpOptions) {
    let img = image(w, h, nc);
    let full = whole(s, w, h, nc, &img, opts);
    let planner = TilePlanner::new(s, (w, h), &opts.remap);
    for y0 in (0..h).step_by(th as usize) {
        for x0 in (0..w).step_by(tw as usize) {
            let tile = Rect { x0, y0, w: tw.min(w - x0), h: th.min(h - y0) };
            let expect = crop(&full, w, nc, tile);
            let mut out = vec![0u8; tile.len() * nc];
            // No input at all when nothing can reach the tile: a 1 x 1 window stands in.
            let window = planner.input_rect(tile).unwrap_or(Rect { x0: 0, y0: 0, w: 1, h: 1 });
            let win = crop(&img, w, nc, window);
            warp_tile_into(
                s,
                TileLayout { size: (w, h), tile, window, channels: nc },
                &[Samples::U8(&win)],
                &mut [SamplesMut::U8(&mut out)],
                opts,
            )
            .unwrap_or_else(|e| panic!("tile {tile:?}: {e}"));
            assert!(out == expect, "tile {tile:?} of {w}x{h} ({nc} channels, {:?})", opts.interp);
        }
    }
}

fn opts(interp: Interp) -> WarpOptions {
    WarpOptions {
        interp,
        background: 17.0,
        remap: RemapOptions::default(),
        mode: Default::default(),
    }
}

#[test]
fn tiles_of_a_folded_map_are_bit_identical_to_the_whole_warp() {
    let s = load("folded");
    for interp in [Interp::Nearest, Interp::Bilinear, Interp::Bicubic] {
        check_tiling(&s, 150, 225, 1, 37, 41, &opts(interp));
    }
    check_tiling(&s, 150, 225, 4, 64, 64, &opts(Interp::Bilinear));
    check_tiling(&s, 150, 225, 3, 150, 1, &opts(Interp::Bilinear));
    check_tiling(&s, 150, 225, 1, 1, 225, &opts(Interp::Bicubic));
}

#[test]
fn tiles_of_a_strongly_bent_map_are_bit_identical_and_read_little() {
    let s = load("bent");
    let o = opts(Interp::Bilinear);
    check_tiling(&s, 2048, 2048, 1, 512, 384, &o);
    // Each 512 x 512 tile reads far less than the whole image.
    let planner = TilePlanner::new(&s, (2048, 2048), &o.remap);
    let tile = Rect { x0: 1024, y0: 1024, w: 512, h: 512 };
    let r = planner.input_rect(tile).unwrap();
    assert!(r.len() < 2048 * 2048 / 4, "{r:?}");
}

/// Issue 51: over a default fit's far-field rings the planner makes pieces only where the
/// frame can be reached (the rings' triangles are hundreds of pieces across), and the tiles
/// stay bit-identical to the whole warp.
#[test]
fn tiles_of_a_fit_with_far_rings_are_bit_identical_and_plan_few_pieces() {
    let s = crate::warp::remap::tests::ringed_fit(511.0);
    let o = opts(Interp::Bilinear);
    check_tiling(&s, 511, 511, 1, 128, 200, &o);
    let planner = TilePlanner::new(&s, (511, 511), &o.remap);
    // The frame and its margin need a few thousand pieces (5,844 when written); the rings'
    // sixteen triangles alone would add about 800,000 (k = 107 and 425 pieces across).
    assert!(planner.pieces.len() < 20_000, "{} pieces", planner.pieces.len());
}

#[test]
fn sixteen_bit_and_float_tiles_match_too() {
    let s = load("folded");
    let (w, h) = (150u32, 225u32);
    let o = opts(Interp::Bicubic);
    let img16: Vec<u16> = image(w, h, 1).iter().map(|&v| v as u16 * 257).collect();
    let imgf: Vec<f32> = image(w, h, 3).iter().map(|&v| v as f32 / 7.0).collect();
    let (mut full16, mut fullf) = (vec![0u16; img16.len()], vec![0f32; imgf.len()]);
    let l1 = Layout { width: w, height: h, channels: 1 };
    warp_samples_into(
        &s,
        l1,
        &[Samples::U16(&img16)],
        &mut [SamplesMut::U16(&mut full16)],
        &o,
        &|_| {},
    )
    .unwrap();
    let l3 = Layout { width: w, height: h, channels: 3 };
    warp_samples_into(
        &s,
        l3,
        &[Samples::F32(&imgf)],
        &mut [SamplesMut::F32(&mut fullf)],
        &o,
        &|_| {},
    )
    .unwrap();
    let planner = TilePlanner::new(&s, (w, h), &o.remap);
    let tile = Rect { x0: 40, y0: 90, w: 70, h: 50 };
    let win = planner.input_rect(tile).unwrap();
    let mut out16 = vec![0u16; tile.len()];
    let c16 = crop(&img16, w, 1, win);
    warp_tile_into(
        &s,
        TileLayout { size: (w, h), tile, window: win, channels: 1 },
        &[Samples::U16(&c16)],
        &mut [SamplesMut::U16(&mut out16)],
        &o,
    )
    .unwrap();
    assert_eq!(out16, crop(&full16, w, 1, tile));
    let mut outf = vec![0f32; tile.len() * 3];
    let cf = crop(&imgf, w, 3, win);
    warp_tile_into(
        &s,
        TileLayout { size: (w, h), tile, window: win, channels: 3 },
        &[Samples::F32(&cf)],
        &mut [SamplesMut::F32(&mut outf)],
        &o,
    )
    .unwrap();
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&outf), bits(&crop(&fullf, w, 3, tile)));
}

#[test]
fn a_window_without_the_margin_is_refused() {
    let s = load("folded");
    let (w, h) = (150u32, 225u32);
    let o = opts(Interp::Bilinear);
    let planner = TilePlanner::new(&s, (w, h), &o.remap);
    let tile = Rect { x0: 50, y0: 80, w: 40, h: 40 };
    let need = planner.input_rect(tile).unwrap();
    // The tile's own rectangle as the window: the map moves pixels, so some preimage
    // leaves it.
    let small = Rect { x0: need.x0 + 20, y0: need.y0 + 20, w: 10, h: 10 };
    let img = image(w, h, 1);
    let win = crop(&img, w, 1, small);
    let mut out = vec![0u8; tile.len()];
    let r = warp_tile_into(
        &s,
        TileLayout { size: (w, h), tile, window: small, channels: 1 },
        &[Samples::U8(&win)],
        &mut [SamplesMut::U8(&mut out)],
        &o,
    );
    assert!(matches!(r, Err(WarpError::Tile(TileError::Window { .. }))), "{r:?}");
    // Rectangles outside the image and wrong buffer lengths are refused by name.
    let big = Rect { x0: 140, y0: 0, w: 20, h: 10 };
    let r = warp_tile_into(
        &s,
        TileLayout { size: (w, h), tile: big, window: need, channels: 1 },
        &[Samples::U8(&win)],
        &mut [SamplesMut::U8(&mut out)],
        &o,
    );
    assert!(matches!(r, Err(WarpError::Tile(TileError::Outside { what: "tile", .. }))), "{r:?}");
    let r = warp_tile_into(
        &s,
        TileLayout { size: (w, h), tile, window: need, channels: 1 },
        &[Samples::U8(&win)],
        &mut [SamplesMut::U8(&mut out)],
        &o,
    );
    assert!(matches!(r, Err(WarpError::Layout(LayoutError::Length { index: 0, .. }))), "{r:?}");
}

#[test]
fn tiles_outside_the_deformed_mesh_need_no_input() {
    // A small mesh in a large image: far tiles are all background and read nothing.
    let mesh = Mesh::grid(3, 3, 40.0, 40.0, MeshOptions::default()).unwrap();
    let s = Spline::identity(mesh, 5).unwrap();
    let planner = TilePlanner::new(&s, (400, 300), &RemapOptions::default());
    assert_eq!(planner.input_rect(Rect { x0: 200, y0: 200, w: 64, h: 64 }), None);
    let near = planner.input_rect(Rect { x0: 0, y0: 0, w: 16, h: 16 }).unwrap();
    assert!(near.x0 == 0 && near.y0 == 0 && near.w <= 40 && near.h <= 40, "{near:?}");
    check_tiling(&s, 400, 300, 1, 64, 64, &opts(Interp::Bilinear));
}

#[test]
fn patch_boxes_and_jacobian_bounds_hold_on_samples() {
    let s = load("folded");
    let (m, c) = (s.mesh(), s.eval_cache());
    let mut worst = 0.0f64;
    for t in 0..m.num_triangles() {
        let (lo, hi) = c.patch_bbox(t);
        let l = c.jacobian_bound(t);
        for i in 0..=8 {
            for j in 0..=8 - i {
                let b = [i as f64 / 8.0, j as f64 / 8.0, (8 - i - j) as f64 / 8.0];
                let q = c.value(t, b);
                assert!((0..2).all(|a| q[a] >= lo[a] - 1e-9 && q[a] <= hi[a] + 1e-9), "{t}");
                let jm = c.jacobian(t, b);
                // The spectral norm, from the singular values of the 2x2 Jacobian.
                let f2 = jm.iter().flatten().map(|v| v * v).sum::<f64>();
                let det = jm[0][0] * jm[1][1] - jm[0][1] * jm[1][0];
                let s2 = ((f2 + (f2 * f2 - 4.0 * det * det).max(0.0).sqrt()) / 2.0).sqrt();
                assert!(s2 <= l * (1.0 + 1e-12), "{t}: {s2} > {l}");
                worst = worst.max(s2 / l);
            }
        }
    }
    // Not a vacuous bound: somewhere it is nearly reached.
    assert!(worst > 0.5, "{worst}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Any tile size, any interpolation: tiles are the whole warp.
    #[test]
    fn any_tiling_of_the_folded_map_is_the_whole_warp(
        tw in 1u32..160, th in 1u32..240, k in 0usize..3, nc in 1usize..5
    ) {
        let interp = [Interp::Nearest, Interp::Bilinear, Interp::Bicubic][k];
        check_tiling(&load("folded"), 150, 225, nc, tw, th, &opts(interp));
    }
}

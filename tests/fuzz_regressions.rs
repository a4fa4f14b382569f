//! Replays every saved fuzz input (`tests/fuzz_regressions/<target>/*`) through the same
//! function the fuzz target calls (`fuzz/targets.rs`): crashes the fuzzer found (each fixed
//! since) and a few interesting inputs from the corpora. A panic fails the test; the
//! `ldu_rebuild` target also asserts that A is rebuilt exactly from its factors.
//!
//! CI runs these files, not the fuzzer; see `fuzz/README.md` for the fuzzing runs.

#[path = "../fuzz/targets.rs"]
mod targets;

use std::path::Path;

fn replay(target: &str) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions").join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{}: no regression inputs", dir.display());
    for f in files {
        let data = std::fs::read(&f).unwrap();
        let name = f.display().to_string();
        let r = std::panic::catch_unwind(|| targets::run(target, &data));
        assert!(r.is_ok(), "{name} panics in fuzz target {target}");
    }
}

#[test]
fn every_target_has_a_regression_folder() {
    for t in targets::TARGETS {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions").join(t);
        assert!(dir.is_dir(), "{}", dir.display());
    }
}

#[test]
fn deformation_json() {
    replay("deformation_json");
}

#[test]
fn solve_json() {
    replay("solve_json");
}

#[test]
fn model_obj() {
    replay("model_obj");
}

#[test]
fn model_ply() {
    replay("model_ply");
}

#[test]
fn landmarks_csv() {
    replay("landmarks_csv");
}

#[test]
fn landmarks_bigwarp() {
    replay("landmarks_bigwarp");
}

#[test]
fn edit_script() {
    replay("edit_script");
}

#[test]
fn ldu_rebuild() {
    replay("ldu_rebuild");
}

#[test]
fn image_decode_warp() {
    replay("image_decode_warp");
}

#[test]
fn editor_api() {
    replay("editor_api");
}

/// The image seeds of `image_decode_warp` (`fuzz/seeds/image_decode_warp/`), tiny images of
/// every format and pixel type the reader keeps, written by `trimorph::io::raster` and the
/// `image` crate: name, bytes.
fn image_seeds() -> Vec<(String, Vec<u8>)> {
    use image::{DynamicImage, ImageBuffer, Luma, LumaA, Rgb, Rgba};
    use trimorph::io::raster::{write_stack, Stack};
    let v = |x: u32, y: u32, k: u32| (x * 37 + y * 11 + k * 5) % 256;
    let (w, h) = (7, 5);
    let one = |p: DynamicImage| Stack { pages: vec![p], gray_float: false };
    let luma8 =
        DynamicImage::ImageLuma8(ImageBuffer::from_fn(w, h, |x, y| Luma([v(x, y, 0) as u8])));
    let rgb8 = DynamicImage::ImageRgb8(ImageBuffer::from_fn(w, h, |x, y| {
        Rgb([v(x, y, 0) as u8, v(x, y, 1) as u8, v(x, y, 2) as u8])
    }));
    let stacks: Vec<(&str, Stack)> = vec![
        ("gray8.png", one(luma8.clone())),
        (
            "graya8.png",
            one(DynamicImage::ImageLumaA8(ImageBuffer::from_fn(w, h, |x, y| {
                LumaA([v(x, y, 0) as u8, v(x, y, 3) as u8])
            }))),
        ),
        (
            "rgba16.png",
            one(DynamicImage::ImageRgba16(ImageBuffer::from_fn(w, h, |x, y| {
                Rgba([v(x, y, 0) as u16 * 257, 9, v(x, y, 1) as u16 * 200, 65535])
            }))),
        ),
        ("rgb8.jpg", one(rgb8.clone())),
        ("gray8.jpg", one(luma8.clone())),
        (
            "gray16.tif",
            one(DynamicImage::ImageLuma16(ImageBuffer::from_fn(w, h, |x, y| {
                Luma([v(x, y, 0) as u16 * 250])
            }))),
        ),
        (
            "grayf32.tif",
            Stack {
                pages: vec![DynamicImage::ImageRgb32F(ImageBuffer::from_fn(4, 3, |x, y| {
                    let g = x as f32 * 0.25 - y as f32;
                    Rgb([g, g, g])
                }))],
                gray_float: true,
            },
        ),
        ("rgb8x2.tif", Stack { pages: vec![rgb8.clone(), rgb8.clone()], gray_float: false }),
        ("gray8.pgm", one(luma8.clone())),
        ("rgb8.ppm", one(rgb8.clone())),
        (
            "rgba8.pam",
            one(DynamicImage::ImageRgba8(ImageBuffer::from_fn(w, h, |x, y| {
                Rgba([v(x, y, 0) as u8, 1, 2, v(x, y, 4) as u8])
            }))),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let mut out = Vec::new();
    for (name, stack) in stacks {
        let p = dir.path().join(name);
        write_stack(&p, &stack).unwrap_or_else(|e| panic!("{name}: {e}"));
        out.push((name.to_string(), std::fs::read(&p).unwrap()));
    }
    let mut gif = Vec::new();
    image::codecs::gif::GifEncoder::new(&mut gif)
        .encode(rgb8.to_rgba8().as_raw(), w, h, image::ExtendedColorType::Rgba8)
        .unwrap();
    out.push(("rgba8.gif".into(), gif));
    // A bomb: 20000 x 20000 gray declared in 20 bytes, over the target's 256 MiB budget.
    out.push(("bomb.pgm".into(), b"P5\n20000 20000\n255\n\0\0".to_vec()));
    out
}

/// The committed image seeds are the images [`image_seeds`] writes (run with
/// `TRIMORPH_WRITE_SEEDS=1` to write them again), each under 2 KB and each decoding except
/// the bomb, which the target's budget refuses.
#[test]
fn image_seeds_are_the_generated_images() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/image_decode_warp");
    let write = std::env::var_os("TRIMORPH_WRITE_SEEDS").is_some();
    for (name, bytes) in image_seeds() {
        assert!(bytes.len() < 2048, "{name}: {} bytes", bytes.len());
        let p = dir.join(&name);
        if write {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&p, &bytes).unwrap();
        }
        let committed = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        assert!(committed == bytes, "{name} differs from the generated image");
        trimorph::memory::set_limit(Some(targets::IMAGE_BUDGET));
        match trimorph::io::raster::decode_stack(&bytes, &p) {
            Ok(s) => assert!(name != "bomb.pgm" && !s.pages.is_empty(), "{name} decodes"),
            Err(e) => {
                assert!(name == "bomb.pgm", "{name}: {e}");
                assert!(e.to_string().contains("over the budget"), "{e}");
            }
        }
        targets::run("image_decode_warp", &bytes);
    }
}

/// The `editor_api` seeds reach the engine: the drags and pair edits are accepted, the
/// refused edits are refused, and the gate's refusals happen (so the fuzzer starts from both
/// sides of each check).
#[test]
fn editor_seeds_reach_the_engine() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/editor_api");
    let run = |name: &str| targets::editor_api_statuses(&std::fs::read(dir.join(name)).unwrap());
    let drag = run("drag.txt");
    assert_eq!(drag, [200, 200, 200, 200, 200, 200, 200, 422, 200, 200], "drag.txt");
    let refused = run("refused.txt");
    assert_eq!(refused[0], 200, "select");
    assert!(refused[1..11].iter().all(|&s| s == 400 || s == 422), "{refused:?}");
    assert_eq!(refused[11..], [422, 200, 200], "{refused:?}");
    let pairs = run("pairs.txt");
    assert_eq!(pairs[..3], [200, 200, 200], "{pairs:?}");
    assert_eq!(pairs[3..6], [422, 422, 422], "{pairs:?}");
    assert!(pairs[6..].iter().all(|&s| s == 200), "{pairs:?}");
    let files = run("files.txt");
    assert!(files[..9].iter().all(|&s| s == 200), "{files:?}");
    assert_eq!(files[9], 403, "{files:?}");
    // Through the HTTP layer: chunked, no token, a foreign Origin, text/plain, two Host
    // headers, a raw request, a raw chunk-length overflow cut short, Expect: 100-continue.
    let gate = run("gate.txt");
    assert_eq!(gate, [200, 401, 403, 415, 400, 200, 400, 200], "gate.txt");
}

#[test]
fn landmarks_points() {
    replay("landmarks_points");
}

#[test]
fn ngff_metadata() {
    replay("ngff_metadata");
}

/// The OME-Zarr seeds reach the reader: each is a store that reads as an image (so the
/// fuzzer starts from inputs that pass the metadata checks).
#[test]
fn ngff_seeds_read_as_images() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/ngff_metadata");
    for f in std::fs::read_dir(&dir).unwrap() {
        let f = f.unwrap().path();
        let store = targets::ngff_store(&std::fs::read(&f).unwrap()).unwrap();
        let img = trimorph::io::ngff::read_image(&store);
        assert!(img.is_ok(), "{}: {:?}", f.display(), img.err());
    }
}

//! The memory budget (`--max-memory`, `trimorph::memory`): image bombs and oversized inputs
//! are refused with exit 1 and a message naming the file, before anything large is
//! allocated. The `ulimit -v` tests run the binary in a child shell whose address space is
//! capped at 2 GiB: without the budget these inputs abort the process (or are killed).

use crate::common;

use common::{ok, s, trimorph};
use std::fs;
use std::path::Path;
use std::process::{Command, Output};

/// The address-space cap of the capped runs, in KiB (2 GiB: the default budget is then
/// 1 GiB).
const CAP_KIB: u64 = 2 << 20;

/// Runs trimorph under `ulimit -v CAP_KIB` (no `--max-memory`: the default budget applies,
/// half of the capped address space).
fn capped(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {CAP_KIB} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_trimorph"))
        .args(args)
        .env_remove("TRIMORPH_MAX_MEMORY")
        .output()
        .expect("runs")
}

/// Exit 1, no panic, stderr names `file` and contains every needle.
fn refused(o: &Output, file: &Path, needles: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "panicked: {err}");
    assert_eq!(o.status.code(), Some(1), "status {:?}, stderr: {err}", o.status);
    assert!(err.contains(s(file)), "stderr does not name {}: {err}", file.display());
    for n in needles {
        assert!(err.contains(n), "expected `{n}` in: {err}");
    }
}

/// A small deformation to warp through.
fn deformation(dir: &Path) -> String {
    let p = dir.join("def.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "64,64", "-o", s(&p)]));
    s(&p).to_string()
}

/// A baseline JPEG of 16 x 16 whose frame header (SOF0) is patched to declare
/// `w x h`: a few hundred bytes that decode to `3 w h` bytes.
fn jpeg_bomb(path: &Path, w: u16, h: u16) {
    let img = image::RgbImage::from_fn(16, 16, |x, y| image::Rgb([x as u8 * 9, y as u8 * 9, 7]));
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new(&mut bytes).encode_image(&img).unwrap();
    let sof = bytes.windows(2).position(|m| m == [0xFF, 0xC0]).expect("a baseline frame");
    // FF C0, length (2), precision (1), height (2), width (2).
    bytes[sof + 5..sof + 7].copy_from_slice(&h.to_be_bytes());
    bytes[sof + 7..sof + 9].copy_from_slice(&w.to_be_bytes());
    fs::write(path, bytes).unwrap();
}

/// A multi-page TIFF of `pages` gray 8-bit pages of `side x side`, PackBits-compressed,
/// every page pointing at one shared strip of zeros: about `side^2 / 64` bytes on disk for
/// `pages * side^2` decoded.
fn tiff_bomb(path: &Path, side: u32, pages: u32) {
    let strip: Vec<u8> =
        std::iter::repeat_n([0x81u8, 0x00], (side * side / 128) as usize).flatten().collect();
    fs::write(path, tiff_directories_first(side, pages, 32773, &strip)).unwrap();
}

/// A little-endian TIFF of `pages` gray 8-bit pages of `side x side` with the directories
/// first and one strip (`compression` 1 = none, 32773 = PackBits) shared by every page, as
/// microscopy writers lay files out (directory, then data).
fn tiff_directories_first(side: u32, pages: u32, compression: u16, strip: &[u8]) -> Vec<u8> {
    let mut b: Vec<u8> = b"II*\0".to_vec();
    b.extend_from_slice(&8u32.to_le_bytes());
    let ifd_len = 2 + 9 * 12 + 4;
    let strip_at = 8 + pages * ifd_len;
    for p in 0..pages {
        let entry = |b: &mut Vec<u8>, tag: u16, kind: u16, v: u32| {
            b.extend_from_slice(&tag.to_le_bytes());
            b.extend_from_slice(&kind.to_le_bytes());
            b.extend_from_slice(&1u32.to_le_bytes());
            if kind == 3 {
                b.extend_from_slice(&(v as u16).to_le_bytes());
                b.extend_from_slice(&[0, 0]);
            } else {
                b.extend_from_slice(&v.to_le_bytes());
            }
        };
        b.extend_from_slice(&9u16.to_le_bytes());
        entry(&mut b, 256, 4, side); // ImageWidth
        entry(&mut b, 257, 4, side); // ImageLength
        entry(&mut b, 258, 3, 8); // BitsPerSample
        entry(&mut b, 259, 3, compression as u32); // Compression
        entry(&mut b, 262, 3, 1); // Photometric: black is zero
        entry(&mut b, 273, 4, strip_at); // StripOffsets
        entry(&mut b, 277, 3, 1); // SamplesPerPixel
        entry(&mut b, 278, 4, side); // RowsPerStrip
        entry(&mut b, 279, 4, strip.len() as u32); // StripByteCounts
        let next = if p + 1 < pages { 8 + (p + 1) * ifd_len } else { 0 };
        b.extend_from_slice(&next.to_le_bytes());
    }
    assert_eq!(b.len() as u32, strip_at);
    b.extend_from_slice(strip);
    b
}

/// CRC-32 (ISO-HDLC, as PNG uses) of `data`.
fn crc32(data: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &x in data {
        c ^= x as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// A PNG whose header declares `w x h` RGBA 16-bit (8 bytes a pixel) over a few bytes of
/// image data.
fn png_bomb(path: &Path, w: u32, h: u32) {
    let img = image::Rgba::<u16>([1, 2, 3, 4]);
    let small = image::ImageBuffer::from_pixel(4, 4, img);
    let mut bytes = Vec::new();
    image::DynamicImage::ImageRgba16(small)
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .unwrap();
    // Signature (8), IHDR length (4), "IHDR" (4), width, height, then CRC over type + data.
    bytes[16..20].copy_from_slice(&w.to_be_bytes());
    bytes[20..24].copy_from_slice(&h.to_be_bytes());
    let crc = crc32(&bytes[12..29]);
    bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    fs::write(path, bytes).unwrap();
}

#[test]
fn a_small_jpeg_declaring_a_huge_frame_is_refused_under_a_memory_cap() {
    let dir = tempfile::tempdir().unwrap();
    let def = deformation(dir.path());
    let bomb = dir.path().join("bomb.jpg");
    jpeg_bomb(&bomb, 30000, 30000); // 2.7 GB decoded, then as much again for the warp
    assert!(fs::metadata(&bomb).unwrap().len() < 2000);
    let out = dir.path().join("out.png");
    let o = capped(&["warp", &def, "--image", s(&bomb), "-o", s(&out)]);
    // Refused from the header: decoded, warped and encoded, 3 x 2.5 GiB (issue 54).
    refused(&o, &bomb, &["needs 7.5 GiB", "over the budget", "--max-memory"]);
    assert!(!out.exists(), "nothing is written");
    // A budget given on the command line is the one used.
    let o = trimorph(&["warp", &def, "--image", s(&bomb), "-o", s(&out), "--max-memory", "1G"]);
    refused(&o, &bomb, &["over the budget of 1.0 GiB"]);
}

#[test]
fn a_multi_page_tiff_bomb_is_refused_at_the_page_that_exceeds_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let def = deformation(dir.path());
    let bomb = dir.path().join("bomb.tif");
    tiff_bomb(&bomb, 4096, 320); // 5 GiB of pages from about 300 KB
    assert!(fs::metadata(&bomb).unwrap().len() < 400_000);
    let out = dir.path().join("out.tif");
    let o = capped(&["warp", &def, "--image", s(&bomb), "-o", s(&out)]);
    refused(&o, &bomb, &["page(s) of 4096 x 4096", "over the budget"]);
    assert!(!out.exists());
    // 256 MiB holds the input, output and encoding of 5 pages, not 6 (issue 54: the warp's
    // copies are counted from the headers, before a page is decoded).
    let o = trimorph(&["warp", &def, "--image", s(&bomb), "-o", s(&out), "--max-memory", "256M"]);
    refused(&o, &bomb, &["decoding 6 page(s) of 4096 x 4096 Gray(8) for warping"]);
    // A few pages of the same file are a normal input.
    let few = dir.path().join("few.tif");
    tiff_bomb(&few, 256, 3);
    ok(&trimorph(&["warp", &def, "--image", s(&few), "-o", s(&out)]));
    assert!(out.exists());
}

#[test]
fn a_png_declaring_8_gib_of_16_bit_rgba_is_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let def = deformation(dir.path());
    let bomb = dir.path().join("bomb.png");
    png_bomb(&bomb, 32768, 32768); // within the 2^30 pixel limit, 8 GiB decoded
    let out = dir.path().join("out.png");
    let o = capped(&["warp", &def, "--image", s(&bomb), "-o", s(&out)]);
    // 8 GiB decoded, 3 copies for the warp.
    refused(&o, &bomb, &["needs 24.0 GiB", "over the budget"]);
    let o = trimorph(&["check", &def, "--max-memory", "nonsense"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("memory size \"nonsense\""));
}

#[test]
fn a_deformation_file_too_large_for_the_budget_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let def = dir.path().join("big.json");
    ok(&trimorph(&["mesh", "--grid", "60x60", "--size", "600,600", "-o", s(&def)]));
    let len = fs::metadata(&def).unwrap().len();
    assert!(len > (1 << 20) / 64, "the file is {len} bytes");
    let o = trimorph(&["check", s(&def), "--max-memory", "1M"]);
    refused(&o, &def, &["reading a deformation file of", "over the budget of 1.0 MiB"]);
    ok(&trimorph(&["check", s(&def)]));
}

#[test]
fn truncated_jpeg_and_tiff_files_are_refused_not_half_decoded() {
    let dir = tempfile::tempdir().unwrap();
    let def = deformation(dir.path());
    let out = dir.path().join("out.png");
    // JPEG: the entropy-coded data cut before the end-of-image marker.
    // Noise, so that most of the file is scan data, and the cut falls inside the scan.
    let img = image::RgbImage::from_fn(128, 128, |x, y| {
        image::Rgb([(x * 7919 + y * 104729) as u8, (x * y) as u8, (x ^ y) as u8])
    });
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new(&mut jpeg).encode_image(&img).unwrap();
    // TIFF: directory first, then the pixels, cut in the middle of the pixels.
    let pixels: Vec<u8> = (0..64 * 64).map(|i| (i % 251) as u8).collect();
    let tiff = tiff_directories_first(64, 1, 1, &pixels);
    for (name, bytes) in [("cut.jpg", jpeg), ("cut.tif", tiff)] {
        let whole = dir.path().join(format!("whole-{name}"));
        fs::write(&whole, &bytes).unwrap();
        ok(&trimorph(&["warp", &def, "--image", s(&whole), "-o", s(&out)]));
        let cut = dir.path().join(name);
        fs::write(&cut, &bytes[..bytes.len() * 9 / 10]).unwrap();
        let o = trimorph(&["warp", &def, "--image", s(&cut), "-o", s(&out)]);
        refused(&o, &cut, &["truncated"]);
    }
}

/// Issue 23: `morph` held every frame in memory and refused a morph whose frames together
/// exceeded the budget. Frames are now streamed: with a budget below what all frames need
/// (but above one batch) it succeeds; with one below a single frame and the encoders it is
/// refused with exit 1 and a message, and nothing is written.
#[test]
fn a_morph_larger_than_the_budget_streams_and_one_frame_over_it_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h, n) = (480u32, 200u32, 40u64);
    let im = |dx: f64, name: &str| {
        let p = dir.path().join(name);
        image::GrayImage::from_fn(w, h, |x, y| {
            let (u, v) = (x as f64 - dx, y as f64);
            image::Luma([(128.0 + 60.0 * (u / 9.0).sin() * (v / 7.0).cos()) as u8])
        })
        .save(&p)
        .unwrap();
        p
    };
    let (a, b) = (im(0.0, "a.png"), im(4.0, "b.png"));
    let l = dir.path().join("l.csv");
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    for (i, [x, y]) in [[60, 40], [420, 40], [60, 160], [420, 160], [240, 100]].iter().enumerate() {
        csv += &format!("p{i},{x},{y},{},{y}\n", x + 4);
    }
    fs::write(&l, csv).unwrap();
    let budget: u64 = 12 << 20;
    // Every frame and its RGBA copy, as the old check counted them: over the budget.
    assert!(n * u64::from(w * h) * (1 + 4) > budget);
    let out = dir.path().join("out");
    let frames = n.to_string();
    let run = |mem: &str, out: &std::path::Path| {
        trimorph(&[
            "morph",
            s(&a),
            s(&b),
            "--landmarks",
            s(&l),
            "--frames",
            &frames,
            "-o",
            s(out),
            "--quiet",
            "--max-memory",
            mem,
        ])
    };
    ok(&run("12M", &out));
    assert!(out.join(format!("frame_{:03}.png", n - 1)).exists());
    let gif = fs::read(out.join("morph.gif")).unwrap();
    use image::AnimationDecoder;
    let count = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(gif))
        .unwrap()
        .into_frames()
        .count();
    assert_eq!(count as u64, n);
    let dec = png::Decoder::new(std::io::Cursor::new(fs::read(out.join("morph.apng")).unwrap()));
    assert_eq!(dec.read_info().unwrap().info().animation_control().unwrap().num_frames as u64, n);
    // One frame of 480 x 200 with the encoders' buffers is over 1 MiB.
    let out2 = dir.path().join("out2");
    let o = run("1M", &out2);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(o.status.code(), Some(1), "{err}");
    for needle in ["1 frame(s) of 480 x 200 at a time", "over the budget of 1.0 MiB"] {
        assert!(err.contains(needle), "expected `{needle}` in: {err}");
    }
    assert!(!out2.exists(), "nothing is written");
}

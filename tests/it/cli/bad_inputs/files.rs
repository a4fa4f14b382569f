//! Bad files built byte by byte for `tests/bad_inputs.rs`: image headers declaring what
//! their data do not hold.

/// A PNG declaring `w x h` 8-bit RGB: signature, IHDR, a tiny IDAT and IEND, all with valid
/// CRCs, but nowhere near `w x h` pixels of data.
pub fn png_header(w: u32, h: u32) -> Vec<u8> {
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    for (kind, data) in
        [(&b"IHDR"[..], &ihdr[..]), (b"IDAT", &[0x78, 0x9c, 0x03, 0]), (b"IEND", &[])]
    {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut chunk = kind.to_vec();
        chunk.extend_from_slice(data);
        out.extend_from_slice(&chunk);
        out.extend_from_slice(&crc32(&chunk).to_be_bytes());
    }
    out
}

/// A complete 4 x 4 CMYK TIFF (a channel layout trimorph does not read).
pub fn cmyk_tiff() -> Vec<u8> {
    use tiff::encoder::{colortype::CMYK8, TiffEncoder};
    let mut out = std::io::Cursor::new(Vec::new());
    TiffEncoder::new(&mut out).unwrap().write_image::<CMYK8>(4, 4, &[9u8; 64]).unwrap();
    out.into_inner()
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// A little-endian TIFF declaring one `w x h` strip image with `spp` 8-bit samples per pixel
/// (`photometric` 1 = gray, 2 = RGB, 5 = CMYK), its strip pointing past the end.
pub fn tiff_header(w: u32, h: u32, spp: u16, photometric: u16) -> Vec<u8> {
    let entries: Vec<(u16, u16, u32)> = vec![
        (256, 4, w),
        (257, 4, h),
        (258, 3, 8),
        (259, 3, 1),
        (262, 3, photometric as u32),
        (273, 4, 4096),
        (277, 3, spp as u32),
        (278, 4, h),
        (279, 4, w.saturating_mul(h).saturating_mul(spp as u32)),
    ];
    let mut out = b"II*\0".to_vec();
    out.extend_from_slice(&8u32.to_le_bytes());
    out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    for (tag, ty, v) in entries {
        out.extend_from_slice(&tag.to_le_bytes());
        out.extend_from_slice(&ty.to_le_bytes());
        out.extend_from_slice(&1u32.to_le_bytes());
        if ty == 3 {
            out.extend_from_slice(&(v as u16).to_le_bytes());
            out.extend_from_slice(&[0, 0]);
        } else {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out.extend_from_slice(&0u32.to_le_bytes());
    out
}

/// A baseline JPEG of 16 x 16 whose frame header (SOF0) is patched to declare `w x h`: a
/// few hundred bytes that decode to `3 w h` bytes.
pub fn jpeg_bomb(w: u16, h: u16) -> Vec<u8> {
    let img = image::RgbImage::from_fn(16, 16, |x, y| image::Rgb([x as u8 * 9, y as u8 * 9, 7]));
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new(&mut bytes).encode_image(&img).unwrap();
    let sof = bytes.windows(2).position(|m| m == [0xFF, 0xC0]).expect("a baseline frame");
    bytes[sof + 5..sof + 7].copy_from_slice(&h.to_be_bytes());
    bytes[sof + 7..sof + 9].copy_from_slice(&w.to_be_bytes());
    bytes
}

/// A complete 4 x 4 32-bit float gray TIFF.
pub fn float_tiff() -> Vec<u8> {
    use tiff::encoder::{colortype::Gray32Float, TiffEncoder};
    let mut out = std::io::Cursor::new(Vec::new());
    let px: Vec<f32> = (0..16).map(|i| i as f32 / 16.0).collect();
    TiffEncoder::new(&mut out).unwrap().write_image::<Gray32Float>(4, 4, &px).unwrap();
    out.into_inner()
}

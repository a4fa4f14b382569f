//! Netpbm output (`.pgm`, `.ppm`, `.pnm`, `.pam`) for [`super::raster::write_stack`], and
//! the formats that hold a page's samples (named in refusals).

use image::DynamicImage;
use std::path::Path;

/// One page as the Netpbm type the extension names (binary samples, 16-bit big-endian):
/// `.pgm` 8- or 16-bit gray (P5), `.ppm` 8-bit RGB (P6), `.pam` any integer type (P7), `.pnm`
/// whichever of PGM and PPM holds the page. Other types are refused with the format to use.
pub(super) fn encode_pnm(
    path: &Path,
    page: &DynamicImage,
    gray_float: bool,
) -> Result<Vec<u8>, String> {
    use image::codecs::pnm::{GraymapHeader, PixmapHeader, PnmEncoder, PnmHeader, SampleEncoding};
    use image::ImageEncoder;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let (w, h) = (page.width(), page.height());
    let kind = if gray_float { "float gray".to_string() } else { format!("{:?}", page.color()) };
    let gray = |maxwhite| -> PnmHeader {
        GraymapHeader { encoding: SampleEncoding::Binary, width: w, height: h, maxwhite }.into()
    };
    let rgb8: PnmHeader =
        PixmapHeader { encoding: SampleEncoding::Binary, width: w, height: h, maxval: 255 }.into();
    let header = match (ext.as_str(), page) {
        ("pgm" | "pnm", DynamicImage::ImageLuma8(_)) => Some(gray(255)),
        ("pgm" | "pnm", DynamicImage::ImageLuma16(_)) => Some(gray(65535)),
        ("ppm" | "pnm", DynamicImage::ImageRgb8(_)) => Some(rgb8),
        ("pam", p)
            if !matches!(p, DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_)) =>
        {
            None
        }
        ("pgm", _) => {
            return Err(format!(
                "a PGM holds 8- or 16-bit gray, not {kind} (use {})",
                holders(page, gray_float, "pgm")
            ))
        }
        ("ppm", _) => {
            return Err(format!(
                "a PPM holds 8-bit RGB, not {kind} (use {})",
                holders(page, gray_float, "ppm")
            ))
        }
        ("pnm", _) => {
            return Err(format!(
                "a PNM holds 8- or 16-bit gray or 8-bit RGB, not {kind} (use {})",
                holders(page, gray_float, "pnm")
            ))
        }
        ("pam", _) => return Err(format!("a PAM holds integer samples, not {kind} (use .tif)")),
        _ => return Err("a PBM holds black and white only; write .pgm for gray".into()),
    };
    let mut out = Vec::new();
    let enc = PnmEncoder::new(&mut out);
    let enc = match header {
        Some(hd) => enc.with_header(hd),
        None => enc.with_subtype(image::codecs::pnm::PnmSubtype::ArbitraryMap),
    };
    enc.write_image(page.as_bytes(), w, h, page.color().into()).map_err(|e| e.to_string())?;
    Ok(out)
}

/// The extensions whose formats hold `page`'s samples, other than `except`: `.ppm` for
/// 8-bit RGB, `.pam` and `.png` for integer samples, `.tif` for all (`.a, .b or .c`).
fn holders(page: &DynamicImage, gray_float: bool, except: &str) -> String {
    let float =
        gray_float || matches!(page, DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_));
    let mut v: Vec<&str> = Vec::new();
    if matches!(page, DynamicImage::ImageRgb8(_)) {
        v.push("ppm");
    }
    if !float {
        v.extend(["pam", "png"]);
    }
    v.push("tif");
    let v: Vec<String> = v.into_iter().filter(|e| *e != except).map(|e| format!(".{e}")).collect();
    match v.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => v.concat(),
    }
}

//! Checks of a TIFF page's tags before it is decoded ([`super::raster`]): its colour type,
//! with gray+alpha recognised ([`colortype`]), and its strips or tiles inside the file
//! ([`check_strips`]).

use std::io::{Read, Seek};
use tiff::decoder::Decoder;
use tiff::tags::Tag;
use tiff::ColorType;

/// The page's colour type. The `tiff` crate reads gray with a second sample as
/// `Multiband { 2 samples }` whatever the second sample is; it is gray+alpha
/// (`ColorType::GrayA`) when the `ExtraSamples` tag marks it as unassociated alpha (2), as
/// trimorph, ImageMagick and libtiff write it. Other extra samples are refused with what
/// they are (issue 54: a gray+alpha TIFF was refused as an unsupported `Multiband`, with a
/// message telling the user to give gray+alpha).
///
/// Errors: `Ok(tiff error)` when the tags cannot be read, `Err(reason)` for samples that are
/// not gray+alpha.
pub(super) fn colortype<R: Read + Seek>(
    dec: &mut Decoder<R>,
) -> Result<ColorType, Result<tiff::TiffError, String>> {
    let ct = dec.colortype().map_err(Ok)?;
    let ColorType::Multiband { bit_depth, num_samples: 2 } = ct else { return Ok(ct) };
    let photometric = dec.get_tag_u32(Tag::PhotometricInterpretation).ok();
    let extra = dec.find_tag_unsigned_vec::<u16>(Tag::ExtraSamples).ok().flatten();
    let float = dec.get_tag_u32(Tag::SampleFormat).is_ok_and(|f| f == 3);
    let kinds = "gray+alpha is read with 8 or 16 bits per sample, black at zero \
                 (PhotometricInterpretation 1) and ExtraSamples 2 (unassociated alpha)";
    match (photometric, extra.as_deref(), bit_depth, float) {
        (Some(1), Some([2]), 8 | 16, false) => Ok(ColorType::GrayA(bit_depth)),
        (Some(1), Some([1]), ..) => Err(Err(format!(
            "gray with associated (premultiplied) alpha (ExtraSamples 1); {kinds}: save the \
             image with unassociated alpha, or as RGBA"
        ))),
        (Some(1), Some([0]) | None, ..) => Err(Err(format!(
            "gray with a second sample that is not marked as alpha (ExtraSamples {}); {kinds}: \
             if it is alpha, save the image again as gray+alpha or RGBA, else split the two \
             samples into separate images",
            if extra.is_some() { "0, unspecified" } else { "missing" }
        ))),
        _ => Err(Err(format!(
            "two samples of {bit_depth} bits{} with PhotometricInterpretation {}; {kinds}",
            if float { " (floating point)" } else { "" },
            photometric.map_or("missing".to_string(), |p| p.to_string())
        ))),
    }
}

/// Checks that the current TIFF page's strips or tiles lie inside the file: a truncated
/// file is refused instead of decoding to a partly flat page.
pub(super) fn check_strips<R: Read + Seek>(
    dec: &mut Decoder<R>,
    file_len: u64,
) -> Result<(), String> {
    let pairs = [
        (Tag::StripOffsets, Tag::StripByteCounts, "strip"),
        (Tag::TileOffsets, Tag::TileByteCounts, "tile"),
    ];
    for (off_tag, len_tag, what) in pairs {
        let Ok(Some(offsets)) = dec.find_tag_unsigned_vec::<u64>(off_tag) else { continue };
        let Ok(Some(counts)) = dec.find_tag_unsigned_vec::<u64>(len_tag) else { continue };
        for (i, (&o, &n)) in offsets.iter().zip(&counts).enumerate() {
            if o.saturating_add(n) > file_len {
                return Err(format!(
                    "{what} {i} ends at byte {} but the file has {file_len} bytes (the file is truncated)",
                    o.saturating_add(n)
                ));
            }
        }
    }
    Ok(())
}

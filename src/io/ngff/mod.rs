//! OME-Zarr (OME-NGFF) input and output: images and displacement-field transforms.
//!
//! Every byte of Zarr goes through the `zarrs` crate (Zarr v2 and v3, codecs blosc, zstd,
//! gzip, crc32c and sharding); this module only reads and writes the NGFF metadata. Built
//! without the `zarr` Cargo feature, [`read_image`], [`write_image`] and
//! [`write_displacements`] return [`NgffError::Unsupported`] (and [`is_zarr_path`] still
//! recognises a store, so such a path is never mistaken for another format).
//!
//! # Images ([`read_image`], [`write_image`])
//!
//! An OME-Zarr image is a Zarr group whose attributes hold `multiscales` (NGFF 0.4: in
//! `.zattrs` of a Zarr v2 group; 0.5: under `ome` in the `zarr.json` of a Zarr v3 group;
//! the 0.6 proposal's `coordinateSystems` are read too, its last system being the
//! image's own). Only the full-resolution level, `datasets[0]`, is read. Supported:
//!
//! * axes: exactly two `space` axes, last (`y`, `x`), optionally preceded by a `time`
//!   and/or a `channel` axis (`(y, x)`, `(c, y, x)`, `(t, y, x)`, `(t, c, y, x)`); a third
//!   spatial axis (`z`) or any other axis type is refused;
//! * data types uint8, uint16 and float32 (any byte order the codecs describe).
//!
//! The data is returned as one page per `(t, c)` plane, in C order of the leading axes
//! (plane `k` holds `array[k / C, k % C, :, :]` for `(t, c, y, x)`), as 8/16-bit gray
//! pages or, for float32, RGB float pages with three equal channels (like float gray TIFF
//! pages in [`crate::io::raster`]). Pixel `(x, y)` of a page is `array[.., y, x]`: the
//! NGFF coordinate convention (pixel centres at integer coordinates, the first pixel's
//! centre at the origin) is trimorph's pixel convention, so no half-pixel shift applies.
//!
//! [`write_image`] writes warped planes back as an OME-Zarr image with the input's Zarr
//! version, array metadata (shape, data type, chunk shape, codecs, fill value, dimension
//! names) and group attributes, except that `multiscales[0].datasets` keeps only level 0
//! (the lower resolutions are not recomputed, so they are not written).
//!
//! # Displacement fields ([`write_displacements`])
//!
//! See [`field`] for the store layout, the direction table and the NGFF proposal sections
//! followed.
//!
//! # Atomic output
//!
//! A store is a directory. It is written into a temporary directory beside the target
//! (`.NAME.PID-N.tmp`) and renamed into place; an existing store under the target name is
//! first renamed aside and removed only after the new one is in place, so the final name
//! never holds a half-written store. A target that exists but is not a Zarr store (no
//! `zarr.json`, `.zgroup`, `.zattrs` or `.zarray`) is never replaced.

#[cfg(feature = "zarr")]
pub mod field;

#[cfg(feature = "zarr")]
pub use field::{write_displacements, NGFF_VERSION};

use super::IoError;
use image::DynamicImage;
#[cfg(feature = "zarr")]
use image::ImageBuffer;
use std::path::{Path, PathBuf};
#[cfg(feature = "zarr")]
use std::sync::Arc;
#[cfg(feature = "zarr")]
use zarrs::array::{Array, ArrayMetadataOptions};
#[cfg(feature = "zarr")]
use zarrs::filesystem::FilesystemStore;
#[cfg(feature = "zarr")]
use zarrs::group::{Group, GroupMetadataOptions};

/// Errors of OME-Zarr input and output; each names the store and the element involved.
#[derive(Debug, thiserror::Error)]
pub enum NgffError {
    /// File-system error.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The path is not a Zarr group.
    #[error("{store}: not a Zarr store: {reason}")]
    NotAStore {
        /// The store.
        store: PathBuf,
        /// What is missing.
        reason: String,
    },
    /// The group has no usable `multiscales` metadata.
    #[error("{store}: {reason} (is this an OME-Zarr image?)")]
    Metadata {
        /// The store.
        store: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The axes are not a 2D image with optional time / channel axes.
    #[error("{store}, multiscales axes [{axes}]: {reason}")]
    Axes {
        /// The store.
        store: PathBuf,
        /// The axes found, by name.
        axes: String,
        /// What is wrong.
        reason: String,
    },
    /// An array cannot be opened or decoded.
    #[error("{store}, array `{array}`: {reason}")]
    Array {
        /// The store.
        store: PathBuf,
        /// The array's path inside the store.
        array: String,
        /// What went wrong.
        reason: String,
    },
    /// The array's data type is not supported.
    #[error(
        "{store}, array `{array}`: unsupported data type {dtype} (use uint8, uint16 or float32)"
    )]
    DataType {
        /// The store.
        store: PathBuf,
        /// The array's path inside the store.
        array: String,
        /// The data type found.
        dtype: String,
    },
    /// Writing the store failed.
    #[error("{store}: cannot write the OME-Zarr store: {reason}")]
    Write {
        /// The store.
        store: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// This build has no OME-Zarr support (built without the `zarr` feature).
    #[cfg(not(feature = "zarr"))]
    #[error("{store}: this build of trimorph has no OME-Zarr support (Cargo feature `zarr`)")]
    Unsupported {
        /// The store.
        store: PathBuf,
    },
}

/// Sample type of an OME-Zarr image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleType {
    /// uint8.
    U8,
    /// uint16.
    U16,
    /// float32.
    F32,
}

/// Kind of an NGFF axis (its `type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisKind {
    /// `space`.
    Space,
    /// `time`.
    Time,
    /// `channel`.
    Channel,
}

/// One axis of an image, in array order.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The axis name (`t`, `c`, `y`, `x`, ...).
    pub name: String,
    /// Its type.
    pub kind: AxisKind,
    /// Its unit, if given.
    pub unit: Option<String>,
}

/// The full-resolution level of an OME-Zarr image, one page per `(t, c)` plane.
#[derive(Clone, Debug)]
pub struct NgffImage {
    /// Zarr format of the store: 2 or 3.
    pub zarr_format: u8,
    /// Axes in array order; the last two are `y`, `x`.
    pub axes: Vec<Axis>,
    /// Path of level 0 inside the store (`datasets[0].path`).
    pub dataset: String,
    /// Array shape, in axis order.
    pub shape: Vec<u64>,
    /// Chunk shape of level 0, in axis order.
    pub chunks: Vec<u64>,
    /// Sample type.
    pub dtype: SampleType,
    /// One page per plane, in C order of the leading axes (see the module docs).
    pub pages: Vec<DynamicImage>,
    #[cfg(feature = "zarr")]
    group_meta: zarrs::metadata::GroupMetadata,
    #[cfg(feature = "zarr")]
    array_meta: zarrs::metadata::ArrayMetadata,
}

impl NgffImage {
    /// Width (length of the `x` axis).
    pub fn width(&self) -> u32 {
        self.shape[self.shape.len() - 1] as u32
    }

    /// Height (length of the `y` axis).
    pub fn height(&self) -> u32 {
        self.shape[self.shape.len() - 2] as u32
    }

    /// Number of `(t, c)` planes: the product of the leading axes' lengths.
    pub fn planes(&self) -> usize {
        self.shape[..self.shape.len() - 2].iter().product::<u64>() as usize
    }
}

/// Does `path` name a Zarr store (a `.zarr` name, or a directory)?
pub fn is_zarr_path(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("zarr"))
        || path.is_dir()
}

#[cfg(feature = "zarr")]
fn open_store(path: &Path) -> Result<Arc<FilesystemStore>, NgffError> {
    let not = |reason: String| NgffError::NotAStore { store: path.to_path_buf(), reason };
    if !path.is_dir() {
        return Err(not(if path.exists() {
            "it is a file; a Zarr store is a directory".into()
        } else {
            "no such directory".into()
        }));
    }
    if !["zarr.json", ".zgroup", ".zattrs"].iter().any(|f| path.join(f).is_file()) {
        return Err(not(
            "the directory has no group metadata (zarr.json for Zarr v3, .zgroup/.zattrs for v2)"
                .into(),
        ));
    }
    FilesystemStore::new(path).map(Arc::new).map_err(|e| not(e.to_string()))
}

#[cfg(feature = "zarr")]
/// The axes of `multiscales[0]`: `axes` (0.4, 0.5; names alone in 0.3) or the last of the
/// 0.6 proposal's `coordinateSystems`.
fn parse_axes(store: &Path, ms: &serde_json::Value) -> Result<Vec<Axis>, NgffError> {
    let meta = |reason: &str| NgffError::Metadata { store: store.into(), reason: reason.into() };
    let list = match ms.get("axes") {
        Some(a) => a,
        None => ms
            .get("coordinateSystems")
            .and_then(|c| c.as_array())
            .and_then(|c| c.last())
            .and_then(|c| c.get("axes"))
            .ok_or_else(|| meta("multiscales[0] has neither `axes` nor `coordinateSystems`"))?,
    };
    let list = list.as_array().ok_or_else(|| meta("multiscales[0].axes is not a list"))?;
    let names: Vec<String> = list
        .iter()
        .map(|a| match a {
            serde_json::Value::String(s) => s.clone(),
            a => a.get("name").and_then(|n| n.as_str()).unwrap_or("?").to_string(),
        })
        .collect();
    let axes_err =
        |reason: String| NgffError::Axes { store: store.into(), axes: names.join(", "), reason };
    let mut axes = Vec::new();
    for (a, name) in list.iter().zip(&names) {
        let ty = match a {
            // NGFF 0.3: names only.
            serde_json::Value::String(s) => match s.as_str() {
                "x" | "y" | "z" => "space",
                "t" => "time",
                "c" => "channel",
                _ => "",
            }
            .to_string(),
            a => a.get("type").and_then(|t| t.as_str()).unwrap_or("").to_string(),
        };
        let kind = match ty.as_str() {
            "space" => AxisKind::Space,
            "time" => AxisKind::Time,
            "channel" => AxisKind::Channel,
            other => {
                return Err(axes_err(format!(
                "axis `{name}` has type `{other}`; only space, time and channel axes are supported"
            )))
            }
        };
        let unit = a.get("unit").and_then(|u| u.as_str()).map(str::to_string);
        axes.push(Axis { name: name.clone(), kind, unit });
    }
    let spatial = axes.iter().filter(|a| a.kind == AxisKind::Space).count();
    if spatial != 2 {
        return Err(axes_err(format!(
            "{spatial} spatial axes; only 2D images (two space axes, y and x) are supported; extract a z plane first"
        )));
    }
    let n = axes.len();
    if axes[n - 2].kind != AxisKind::Space || axes[n - 1].kind != AxisKind::Space {
        return Err(axes_err("the two space axes must be the last two (y, x)".into()));
    }
    for kind in [AxisKind::Time, AxisKind::Channel] {
        if axes.iter().filter(|a| a.kind == kind).count() > 1 {
            return Err(axes_err(format!("more than one {kind:?} axis").to_lowercase()));
        }
    }
    Ok(axes)
}

#[cfg(feature = "zarr")]
/// The `multiscales` list of a group's attributes (under `ome` for NGFF 0.5 and later).
fn multiscales(attrs: &serde_json::Map<String, serde_json::Value>) -> Option<&serde_json::Value> {
    attrs.get("ome").and_then(|o| o.get("multiscales")).or_else(|| attrs.get("multiscales"))
}

#[cfg(feature = "zarr")]
/// Reads the full-resolution level of an OME-Zarr image (see the module docs).
pub fn read_image(path: &Path) -> Result<NgffImage, NgffError> {
    let store = open_store(path)?;
    let meta = |reason: String| NgffError::Metadata { store: path.to_path_buf(), reason };
    let group = Group::open(store.clone(), "/")
        .map_err(|e| meta(format!("cannot open the root group: {e}")))?;
    let ms = multiscales(group.attributes())
        .and_then(|m| m.as_array())
        .and_then(|m| m.first())
        .ok_or_else(|| meta("the root group's attributes have no `multiscales` list".into()))?;
    let axes = parse_axes(path, ms)?;
    let dataset = ms
        .get("datasets")
        .and_then(|d| d.as_array())
        .and_then(|d| d.first())
        .and_then(|d| d.get("path"))
        .and_then(|p| p.as_str())
        .ok_or_else(|| meta("multiscales[0].datasets[0].path is missing".into()))?
        .trim_matches('/')
        .to_string();
    let arr_err = |reason: String| NgffError::Array {
        store: path.to_path_buf(),
        array: dataset.clone(),
        reason,
    };
    let dir = path.join(&dataset);
    if !dir.join(".zarray").is_file() && !dir.join("zarr.json").is_file() {
        return Err(arr_err(
            "no array metadata (.zarray for Zarr v2, zarr.json for Zarr v3)".into(),
        ));
    }
    let array = Array::open(store, &format!("/{dataset}")).map_err(|e| arr_err(e.to_string()))?;
    let shape = array.shape().to_vec();
    if shape.len() != axes.len() {
        return Err(arr_err(format!(
            "{} dimensions, but multiscales[0] has {} axes",
            shape.len(),
            axes.len()
        )));
    }
    let dt = array.data_type();
    use zarrs::array::data_type as zdt;
    let dtype = if *dt == zdt::uint8() {
        SampleType::U8
    } else if *dt == zdt::uint16() {
        SampleType::U16
    } else if *dt == zdt::float32() {
        SampleType::F32
    } else {
        return Err(NgffError::DataType {
            store: path.to_path_buf(),
            array: dataset.clone(),
            dtype: dt.to_string(),
        });
    };
    let (h, w) = (shape[shape.len() - 2], shape[shape.len() - 1]);
    // Checked products: a shape like [2^33, 2^31] wrapped `w * h` to 0 and passed.
    let pixels = super::image_use::page_pixels(w, h);
    if pixels.is_none() || w > u64::from(u32::MAX) || h > u64::from(u32::MAX) {
        return Err(arr_err(format!(
            "planes of {w} x {h} pixels, outside 1 .. 2^30 pixels; crop or split the image"
        )));
    }
    let lead = &shape[..shape.len() - 2];
    let planes = lead.iter().try_fold(1u64, |a, &b| a.checked_mul(b));
    let Some(planes) = planes.filter(|&p| p > 0) else {
        return Err(arr_err(format!(
            "shape {shape:?} holds {} planes; an image needs at least one, and at most 2^64 samples",
            if lead.contains(&0) { "no".to_string() } else { "more than 2^64".to_string() }
        )));
    };
    // The decoded samples and the pages built from them (float planes become RGB), checked
    // against the memory budget before anything is read.
    let per_sample: u64 = match dtype {
        SampleType::U8 => 2,
        SampleType::U16 => 4,
        SampleType::F32 => 16,
    };
    let samples = planes.saturating_mul(pixels.unwrap_or(u64::MAX));
    crate::memory::check(samples.saturating_mul(per_sample), || {
        format!("{}: decoding {planes} planes of {w} x {h} pixels", path.display())
    })
    .map_err(|e| arr_err(e.to_string()))?;
    let chunks = array
        .chunk_shape(&vec![0; shape.len()])
        .map_err(|e| arr_err(e.to_string()))?
        .iter()
        .map(|c| c.get())
        .collect();
    let all = array.subset_all();
    let (w, h) = (w as u32, h as u32);
    let plane = w as usize * h as usize;
    let bad = || arr_err("decoded data does not fill the array".into());
    let pages: Vec<DynamicImage> = match dtype {
        SampleType::U8 => {
            let d: Vec<u8> =
                array.retrieve_array_subset(&all).map_err(|e| arr_err(e.to_string()))?;
            d.chunks(plane)
                .map(|c| ImageBuffer::from_raw(w, h, c.to_vec()).map(DynamicImage::ImageLuma8))
                .collect::<Option<_>>()
                .ok_or_else(bad)?
        }
        SampleType::U16 => {
            let d: Vec<u16> =
                array.retrieve_array_subset(&all).map_err(|e| arr_err(e.to_string()))?;
            d.chunks(plane)
                .map(|c| ImageBuffer::from_raw(w, h, c.to_vec()).map(DynamicImage::ImageLuma16))
                .collect::<Option<_>>()
                .ok_or_else(bad)?
        }
        SampleType::F32 => {
            let d: Vec<f32> =
                array.retrieve_array_subset(&all).map_err(|e| arr_err(e.to_string()))?;
            d.chunks(plane)
                .map(|c| {
                    let rgb: Vec<f32> = c.iter().flat_map(|&v| [v, v, v]).collect();
                    ImageBuffer::from_raw(w, h, rgb).map(DynamicImage::ImageRgb32F)
                })
                .collect::<Option<_>>()
                .ok_or_else(bad)?
        }
    };
    if pages.len() as u64 != planes {
        return Err(bad());
    }
    let zarr_format = match array.metadata() {
        zarrs::metadata::ArrayMetadata::V2(_) => 2,
        zarrs::metadata::ArrayMetadata::V3(_) => 3,
    };
    Ok(NgffImage {
        zarr_format,
        axes,
        dataset,
        shape,
        chunks,
        dtype,
        pages,
        group_meta: group.metadata().clone(),
        array_meta: array.metadata().clone(),
    })
}

#[cfg(feature = "zarr")]
/// Writes `pages` (one per plane, [`NgffImage::planes`] of them, of `like`'s size and page
/// type) as an OME-Zarr image with `like`'s Zarr version, array metadata and group
/// attributes, level 0 only (see the module docs). Atomic. `like.pages` is not used, so
/// a caller may move the pages out of it.
pub fn write_image(path: &Path, like: &NgffImage, pages: &[DynamicImage]) -> Result<(), NgffError> {
    let werr = |reason: String| NgffError::Write { store: path.to_path_buf(), reason };
    if pages.len() != like.planes() {
        return Err(werr(format!(
            "{} planes given for {} in the image",
            pages.len(),
            like.planes()
        )));
    }
    let (w, h) = (like.width(), like.height());
    let plane = w as usize * h as usize;
    let mut bytes: Vec<u8> = Vec::new();
    let mut u16s: Vec<u16> = Vec::new();
    let mut f32s: Vec<f32> = Vec::new();
    for (i, p) in pages.iter().enumerate() {
        if (p.width(), p.height()) != (w, h) {
            return Err(werr(format!("plane {i} is {}x{}, not {w}x{h}", p.width(), p.height())));
        }
        match (like.dtype, p) {
            (SampleType::U8, DynamicImage::ImageLuma8(b)) => bytes.extend_from_slice(b.as_raw()),
            (SampleType::U16, DynamicImage::ImageLuma16(b)) => u16s.extend_from_slice(b.as_raw()),
            (SampleType::F32, DynamicImage::ImageRgb32F(b)) => {
                f32s.extend(b.as_raw().chunks(3).map(|c| c[0]))
            }
            (t, p) => {
                return Err(werr(format!("plane {i} is {:?}, the image holds {t:?}", p.color())))
            }
        }
    }
    debug_assert!(bytes.len().max(u16s.len()).max(f32s.len()) == plane * pages.len());
    write_store_atomic(path, |tmp| {
        let store: Arc<FilesystemStore> =
            Arc::new(FilesystemStore::new(tmp).map_err(|e| werr(e.to_string()))?);
        let mut group = Group::new_with_metadata(store.clone(), "/", like.group_meta.clone())
            .map_err(|e| werr(e.to_string()))?;
        keep_level0(group.attributes_mut());
        group
            .store_metadata_opt(&GroupMetadataOptions::default())
            .map_err(|e| werr(e.to_string()))?;
        let mut meta = like.array_meta.clone();
        codecs_as_objects(&mut meta);
        let array = Array::new_with_metadata(store, &format!("/{}", like.dataset), meta)
            .map_err(|e| werr(e.to_string()))?;
        array
            .store_metadata_opt(&ArrayMetadataOptions::default().with_include_zarrs_metadata(false))
            .map_err(|e| werr(e.to_string()))?;
        let all = array.subset_all();
        let r = match like.dtype {
            SampleType::U8 => array.store_array_subset(&all, &bytes[..]),
            SampleType::U16 => array.store_array_subset(&all, &u16s[..]),
            SampleType::F32 => array.store_array_subset(&all, &f32s[..]),
        };
        r.map_err(|e| werr(e.to_string()))
    })
}

#[cfg(feature = "zarr")]
/// Writes every Zarr v3 codec (and the chunk grid, chunk key encoding and storage
/// transformers) of `meta` in the object form `{"name": ...}`, also inside a codec's
/// configuration (a sharding codec's `codecs` and `index_codecs`).
///
/// zarrs writes an entry without configuration, such as the `bytes` codec of a uint8 array
/// (no byte order), as the bare string `"bytes"`: Zarr 3.1 allows that short form, but
/// zarr-python 3.1 refuses such an array ("Expected dict, got <class 'str'>"), and the
/// specification's examples and every writer use objects. An empty configuration makes
/// zarrs write `{"name": "bytes"}`. The data type keeps its string form (`"uint8"`), the
/// form the specification gives for core types. Zarr v2 metadata is left as it is.
fn codecs_as_objects(meta: &mut zarrs::metadata::ArrayMetadata) {
    use zarrs::metadata::v3::MetadataV3;
    use zarrs::metadata::Configuration;
    fn nested(conf: &mut serde_json::Map<String, serde_json::Value>) {
        for key in ["codecs", "index_codecs"] {
            for c in conf.get_mut(key).and_then(|l| l.as_array_mut()).into_iter().flatten() {
                if let serde_json::Value::String(name) = c {
                    *c = serde_json::json!({ "name": name });
                } else if let Some(inner) =
                    c.get_mut("configuration").and_then(|v| v.as_object_mut())
                {
                    nested(inner);
                }
            }
        }
    }
    fn object(m: &mut MetadataV3) {
        let mut conf = m.configuration().cloned().map(serde_json::Map::from).unwrap_or_default();
        nested(&mut conf);
        let must = m.must_understand();
        *m = MetadataV3::new_with_configuration(m.name().to_string(), Configuration::from(conf))
            .with_must_understand(must);
    }
    if let zarrs::metadata::ArrayMetadata::V3(v3) = meta {
        v3.codecs.iter_mut().for_each(object);
        v3.storage_transformers.iter_mut().for_each(object);
        object(&mut v3.chunk_grid);
        object(&mut v3.chunk_key_encoding);
    }
}

#[cfg(feature = "zarr")]
/// Keeps only `datasets[0]` in every `multiscales` entry.
fn keep_level0(attrs: &mut serde_json::Map<String, serde_json::Value>) {
    let ms = match attrs.get_mut("ome").and_then(|o| o.get_mut("multiscales")) {
        Some(m) => Some(m),
        None => attrs.get_mut("multiscales"),
    };
    if let Some(list) = ms.and_then(|m| m.as_array_mut()) {
        for m in list {
            if let Some(d) = m.get_mut("datasets").and_then(|d| d.as_array_mut()) {
                d.truncate(1);
            }
        }
    }
}

/// [`read_image`] in a build without the `zarr` feature: always
/// [`NgffError::Unsupported`].
#[cfg(not(feature = "zarr"))]
pub fn read_image(path: &Path) -> Result<NgffImage, NgffError> {
    Err(NgffError::Unsupported { store: path.to_path_buf() })
}

/// [`write_image`] in a build without the `zarr` feature: always
/// [`NgffError::Unsupported`].
#[cfg(not(feature = "zarr"))]
pub fn write_image(
    path: &Path,
    _like: &NgffImage,
    _pages: &[DynamicImage],
) -> Result<(), NgffError> {
    Err(NgffError::Unsupported { store: path.to_path_buf() })
}

/// `field::write_displacements` in a build without the `zarr` feature: always
/// [`NgffError::Unsupported`].
#[cfg(not(feature = "zarr"))]
pub fn write_displacements(
    path: &Path,
    _forward: Option<&crate::warp::field::Field64>,
    _inverse: Option<&crate::warp::field::Field64>,
    _physical: &crate::spline::Physical,
) -> Result<(), NgffError> {
    Err(NgffError::Unsupported { store: path.to_path_buf() })
}

/// Runs `fill` on a fresh temporary directory beside `path`, then renames it to `path`
/// (see "Atomic output" in the module docs). On error the temporary directory is removed
/// and `path` is untouched.
pub fn write_store_atomic(
    path: &Path,
    fill: impl FnOnce(&Path) -> Result<(), NgffError>,
) -> Result<(), NgffError> {
    let werr = |source: std::io::Error| IoError::Write { path: path.to_path_buf(), source };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        let e = std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a directory name");
        return Err(werr(e).into());
    };
    if path.exists() {
        let is_store = path.is_dir()
            && ["zarr.json", ".zgroup", ".zattrs", ".zarray"].iter().any(|f| path.join(f).exists());
        if !is_store {
            return Err(NgffError::Write {
                store: path.to_path_buf(),
                reason: "exists and is not a Zarr store; it is not replaced (remove it or choose another name)".into(),
            });
        }
    }
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let stem = format!(".{name}.{}-{n}", std::process::id());
    let tmp = dir.join(format!("{stem}.tmp"));
    std::fs::create_dir(&tmp).map_err(werr)?;
    if let Err(e) = fill(&tmp) {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    let old = dir.join(format!("{stem}.old"));
    let had_old = path.exists();
    let result = (|| {
        if had_old {
            std::fs::rename(path, &old)?;
        }
        if let Err(e) = std::fs::rename(&tmp, path) {
            if had_old {
                let _ = std::fs::rename(&old, path);
            }
            return Err(e);
        }
        Ok(())
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(werr(e).into());
    }
    if had_old {
        let _ = std::fs::remove_dir_all(&old);
    }
    Ok(())
}

#[cfg(all(test, feature = "zarr"))]
mod tests;

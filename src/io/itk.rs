//! ITK HDF5 transform files holding a `DisplacementFieldTransform_double_2_2`.
//!
//! Built without the `hdf5` Cargo feature, the HDF5 encoding and decoding ([`to_h5_bytes`],
//! [`from_h5_bytes`], so [`write_h5`] and [`read_h5`]) return [`ItkError::Hdf5`] naming the
//! missing feature; the field itself ([`displacement_transform`]) is computed as usual.
//!
//! **Which way the file runs.** ITK's `DisplacementFieldTransform` maps a point `x` to
//! `T(x) = x + d(x)`, where `d` is the stored displacement interpolated linearly between
//! grid points. ITK's resampling (`itk::ResampleImageFilter`, SimpleITK's
//! `Resample(moving, reference, transform)`) computes `O(q) = I(T(q))`: the transform maps
//! *output* points into the *input* image. trimorph's image warp is `O(q) = I(phi^-1(q))`
//! ([`crate::warp`]), so the file that makes ITK resample like `trimorph warp --image` holds
//!
//! * [`FieldDirection::Resampling`] (the default of `trimorph field F.h5`):
//!   `d(q) = v(q) = phi^-1(q) - q`, so `T = phi^-1` and `T(q)` equals
//!   `trimorph warp --points --inverse` at `q`;
//! * [`FieldDirection::Forward`] (`--inverse`): `d(p) = u(p) = phi(p) - p`, so `T = phi` and
//!   `T(p)` equals `trimorph warp --points` at `p`. Resampling with it warps the other way.
//!
//! This is the opposite of the `.npy` / `.tif` default of `trimorph field` (which stores
//! `u` and needs `--inverse` for `v`): each format's default is what its consumers expect.
//!
//! **Grid, in pixel units by default.** Grid point `(i, j)` (column `i`, row `j`) is at the
//! physical point `origin + direction * diag(spacing) * (i, j)`. By default that is `(i, j)`:
//! origin `(0, 0)`, spacing `(1, 1)`, identity direction. trimorph's pixel `(x, y)` has its
//! centre at `(x, y)` (mesh coordinates, x right, y down), so grid point `(i, j)` is the
//! centre of pixel `(i, j)` of an image read by ITK with the same default geometry. Values
//! are `f64`, computed in `f64`: `u` from the spline
//! ([`crate::warp::field::forward_field_f64`]) and `v` from the certified preimages of the
//! image warp ([`crate::warp::field::inverse_field_f64`]), each within the inverse tolerance
//! (0.01 px by default) of the Newton solution of `warp --points --inverse`.
//!
//! **Physical space.** With a [`Physical`] placement (spacing `s`, origin `o`, identity
//! direction: pixel centre `(i, j)` at `o + s * (i, j)` per axis, the frame both images
//! share) the grid gets that origin and spacing, and each displacement is scaled per axis:
//! `d(o + s q) = s * v(q)`. Then `T(o + s q) = o + s phi^-1(q)`, so `Resample` of an ITK image
//! with that spacing and origin onto itself still reproduces `trimorph warp --image` of its
//! pixel array.
//!
//! **Where the map is undefined** (a pixel outside the mesh, or with no preimage in it) both
//! components are NaN. ITK then transforms that grid point to `(NaN, NaN)`, which no image
//! buffer contains, so `Resample` writes its default (background) value there, as
//! `trimorph warp` does; points inside a grid cell that touches such a corner also map to
//! NaN (linear interpolation), and grid points next to it are exact. Points *outside* the
//! grid `[-0.5, W - 0.5) x [-0.5, H - 0.5)` get ITK's zero displacement (identity), so
//! resample onto a reference within the grid (the default is the deformation's mesh extent).
//!
//! **Layout** (ITK's `HDF5TransformIO`): variable-length ASCII string datasets `/ITKVersion`,
//! `/HDFVersion`, `/OSName`, `/OSVersion` and `/TransformGroup/0/TransformType` (one element
//! each), and 1-D `f64` datasets `/TransformGroup/0/TranformFixedParameters` =
//! `[W, H, origin x, origin y, spacing x, spacing y, d00, d01, d10, d11]` (size, origin,
//! spacing, direction row-major) and `/TransformGroup/0/TranformParameters` =
//! `[dx(0,0), dy(0,0), dx(1,0), dy(1,0), ...]` (x fastest, components interleaved, `2 W H`
//! values). The parameter names keep ITK's historical misspelling, which every ITK version
//! reads (ITK 5 also reads the spelling it now writes, `TransformFixedParameters`; [`read_h5`]
//! accepts both).

use super::{write_atomic, IoError};
use crate::spline::{Physical, Spline};
use crate::warp::field::{forward_field_f64, inverse_field_f64};
use crate::warp::inverse::InverseOptions;
use std::path::{Path, PathBuf};

/// ITK's name of the transform class this module writes.
pub const TRANSFORM_TYPE: &str = "DisplacementFieldTransform_double_2_2";

/// The largest grid written, in pixels: [`crate::io::MAX_RASTER_PIXELS`], as for `.npy` /
/// `.tif` fields.
pub const MAX_PIXELS: u64 = crate::io::MAX_RASTER_PIXELS;

/// The file extensions ITK's HDF5 transform writer accepts (`CanWriteFile`), lower case.
pub const EXTENSIONS: [&str; 8] = ["hdf", "h4", "hdf4", "h5", "hdf5", "he4", "he5", "hd5"];

/// The dataset names of ITK's HDF5 transform files.
#[cfg(feature = "hdf5")]
const GROUP: &str = "TransformGroup";
#[cfg(feature = "hdf5")]
const FIXED: &str = "TranformFixedParameters";
#[cfg(feature = "hdf5")]
const PARAMS: &str = "TranformParameters";
#[cfg(feature = "hdf5")]
const FIXED_NEW: &str = "TransformFixedParameters";
#[cfg(feature = "hdf5")]
const PARAMS_NEW: &str = "TransformParameters";

/// Errors of ITK transform files, with the path.
#[derive(Debug, thiserror::Error)]
pub enum ItkError {
    /// File-system error.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The output name has no HDF5 extension (ITK picks its reader by extension).
    #[error("{path}: an ITK transform file is named .h5 (or .hdf5, .hdf, .hd5, .he5)")]
    Extension {
        /// The file.
        path: PathBuf,
    },
    /// The grid is empty or too large.
    #[error("field size {width}x{height} is empty or too large (at most 10^8 pixels)")]
    Size {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// The physical placement is out of range (spacing not positive, origin not finite).
    #[error("physical placement: {0}")]
    Placement(String),
    /// The HDF5 library could not encode or decode the file.
    #[error("{path}: HDF5: {message}")]
    Hdf5 {
        /// The file.
        path: PathBuf,
        /// The library's message.
        message: String,
    },
    /// The file is HDF5 but not a 2-D displacement-field transform as written here.
    #[error("{path}: {what}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the dataset.
        what: String,
    },
}

/// Which map the displacements describe (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldDirection {
    /// `v(q) = phi^-1(q) - q`: ITK's `TransformPoint` is `phi^-1`, and `Resample` reproduces
    /// `trimorph warp --image`. The default of `trimorph field F.h5`.
    Resampling,
    /// `u(p) = phi(p) - p`: `TransformPoint` is `phi` (`trimorph field F.h5 --inverse`).
    Forward,
}

/// A 2-D displacement field on a regular grid, as ITK's `DisplacementFieldTransform` holds
/// it: the transform is `T(x) = x + d(x)` with `d` interpolated linearly.
#[derive(Clone, Debug, PartialEq)]
pub struct ItkDisplacementField {
    /// Grid size `(W, H)`.
    pub size: [u32; 2],
    /// Physical point of grid index `(0, 0)`.
    pub origin: [f64; 2],
    /// Physical distance between grid points along each axis.
    pub spacing: [f64; 2],
    /// Direction cosines, row-major `[d00, d01, d10, d11]`.
    pub direction: [f64; 4],
    /// `(dx, dy)` per grid point, row-major (x fastest); NaN where the map is undefined.
    pub data: Vec<[f64; 2]>,
}

impl ItkDisplacementField {
    /// ITK's fixed parameters: size, origin, spacing, direction (10 values).
    pub fn fixed_parameters(&self) -> [f64; 10] {
        let (s, o, sp, d) = (self.size, self.origin, self.spacing, self.direction);
        [s[0] as f64, s[1] as f64, o[0], o[1], sp[0], sp[1], d[0], d[1], d[2], d[3]]
    }

    /// Grid points where the map is undefined (NaN displacement).
    pub fn undefined(&self) -> usize {
        self.data.iter().filter(|v| v[0].is_nan() || v[1].is_nan()).count()
    }
}

/// The displacement field of `s` on the `w x h` pixel grid placed in physical space by
/// `physical` (identity direction; [`Physical::pixels`] gives ITK's default geometry), in
/// the given direction: `phi^-1(q) - q` for [`FieldDirection::Resampling`] (preimages within
/// `opts.tolerance`), `phi(p) - p` for [`FieldDirection::Forward`], each scaled per axis by
/// the spacing (see the module docs). NaN where undefined.
pub fn displacement_transform(
    s: &Spline,
    w: u32,
    h: u32,
    direction: FieldDirection,
    opts: InverseOptions,
    physical: &Physical,
) -> Result<ItkDisplacementField, ItkError> {
    if w == 0 || h == 0 || w as u64 * h as u64 > MAX_PIXELS {
        return Err(ItkError::Size { width: w, height: h });
    }
    physical.validate().map_err(|e| ItkError::Placement(e.to_string()))?;
    let mut data = match direction {
        FieldDirection::Resampling => inverse_field_f64(s, w, h, opts),
        FieldDirection::Forward => forward_field_f64(s, w, h),
    }
    .data;
    if physical.spacing != [1.0; 2] {
        for v in &mut data {
            *v = physical.vector(*v);
        }
    }
    Ok(ItkDisplacementField {
        size: [w, h],
        origin: physical.origin,
        spacing: physical.spacing,
        direction: [1.0, 0.0, 0.0, 1.0],
        data,
    })
}

/// Whether `path` has an extension ITK's HDF5 transform writer accepts ([`EXTENSIONS`]).
pub fn is_h5_path(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
}

/// The file's bytes (`path` only names it in errors).
#[cfg(feature = "hdf5")]
pub fn to_h5_bytes(f: &ItkDisplacementField, path: &Path) -> Result<Vec<u8>, ItkError> {
    let n = f.size[0] as usize * f.size[1] as usize;
    if f.data.len() != n {
        return Err(ItkError::Format {
            path: path.to_path_buf(),
            what: format!("{} displacements for a {}x{} grid", f.data.len(), f.size[0], f.size[1]),
        });
    }
    let mut b = hdf5_pure::FileBuilder::new();
    // ITK writes its own version, its HDF5 library's and the OS's here; nothing reads them.
    // These say who wrote the file instead (no ITK or HDF5 C library was involved).
    let writer = format!("trimorph {} (ITK 5 transform layout)", env!("CARGO_PKG_VERSION"));
    let meta = [
        ("ITKVersion", writer.as_str()),
        ("HDFVersion", "hdf5-pure 0.47 (pure Rust)"),
        ("OSName", std::env::consts::OS),
        ("OSVersion", std::env::consts::ARCH),
    ];
    for (name, value) in meta {
        ascii_vlen(b.create_dataset(name), value);
    }
    let params: Vec<f64> = f.data.iter().flat_map(|v| [v[0], v[1]]).collect();
    let mut group = b.create_group(GROUP);
    let mut t = group.create_group("0");
    ascii_vlen(t.create_dataset("TransformType"), TRANSFORM_TYPE);
    t.create_dataset(FIXED).with_f64_data(&f.fixed_parameters());
    t.create_dataset(PARAMS).with_f64_data(&params);
    group.add_group(t.finish());
    b.add_group(group.finish());
    b.finish().map_err(|e| ItkError::Hdf5 { path: path.to_path_buf(), message: e.to_string() })
}

/// A one-element variable-length ASCII string dataset, the type ITK reads strings as
/// (`H5::StrType(C_S1, H5T_VARIABLE)`; HDF5 does not convert UTF-8 to ASCII, so a UTF-8
/// string fails to read in ITK).
#[cfg(feature = "hdf5")]
fn ascii_vlen(d: &mut hdf5_pure::DatasetBuilder, value: &str) {
    d.with_vlen_strings(&[value]).with_dtype(hdf5_pure::Datatype::VariableLength {
        is_string: true,
        padding: Some(hdf5_pure::StringPadding::NullTerminate),
        charset: Some(hdf5_pure::CharacterSet::Ascii),
        base_type: Box::new(hdf5_pure::make_u8_type()),
    });
}

/// Writes `f` to `path` (an HDF5 extension, [`is_h5_path`]) atomically (temporary file,
/// then rename).
pub fn write_h5(f: &ItkDisplacementField, path: &Path) -> Result<(), ItkError> {
    if !is_h5_path(path) {
        return Err(ItkError::Extension { path: path.to_path_buf() });
    }
    write_atomic(path, &to_h5_bytes(f, path)?)?;
    Ok(())
}

/// Reads a 2-D displacement-field transform from an ITK HDF5 transform file (one written by
/// [`write_h5`], ITK or SimpleITK; either spelling of the parameter datasets).
pub fn read_h5(path: &Path) -> Result<ItkDisplacementField, ItkError> {
    let bytes =
        std::fs::read(path).map_err(|source| IoError::Read { path: path.to_path_buf(), source })?;
    from_h5_bytes(bytes, path)
}

/// [`read_h5`] from the file's bytes (`path` only names it in errors).
#[cfg(feature = "hdf5")]
pub fn from_h5_bytes(bytes: Vec<u8>, path: &Path) -> Result<ItkDisplacementField, ItkError> {
    let hdf =
        |e: hdf5_pure::Error| ItkError::Hdf5 { path: path.to_path_buf(), message: e.to_string() };
    let bad = |what: String| ItkError::Format { path: path.to_path_buf(), what };
    let file = hdf5_pure::File::from_bytes(bytes).map_err(hdf)?;
    let ty = file
        .dataset(&format!("{GROUP}/0/TransformType"))
        .and_then(|d| d.read_string())
        .map_err(|e| bad(format!("no /{GROUP}/0/TransformType string ({e})")))?;
    if ty.first().map(String::as_str) != Some(TRANSFORM_TYPE) {
        return Err(bad(format!(
            "/{GROUP}/0/TransformType is {:?}, expected {TRANSFORM_TYPE}",
            ty.first().map(String::as_str).unwrap_or("")
        )));
    }
    let read = |names: [&str; 2]| -> Result<Vec<f64>, ItkError> {
        let mut last = None;
        for name in names {
            match file.dataset(&format!("{GROUP}/0/{name}")).and_then(|d| d.read_f64()) {
                Ok(v) => return Ok(v),
                Err(e) => last = Some(e),
            }
        }
        Err(bad(format!(
            "no /{GROUP}/0/{} array of f64 ({})",
            names[0],
            last.map(|e| e.to_string()).unwrap_or_default()
        )))
    };
    let fixed = read([FIXED, FIXED_NEW])?;
    let params = read([PARAMS, PARAMS_NEW])?;
    if fixed.len() != 10 {
        return Err(bad(format!(
            "/{GROUP}/0/{FIXED} has {} values; a 2-D displacement field has 10 (size, origin, spacing, direction)",
            fixed.len()
        )));
    }
    let dim = |v: f64, axis: &str| -> Result<u32, ItkError> {
        if v >= 1.0 && v.fract() == 0.0 && v <= u32::MAX as f64 {
            Ok(v as u32)
        } else {
            Err(bad(format!("/{GROUP}/0/{FIXED}: grid {axis} {v} is not a positive whole number")))
        }
    };
    let size = [dim(fixed[0], "width")?, dim(fixed[1], "height")?];
    let n = size[0] as u64 * size[1] as u64;
    if params.len() as u64 != 2 * n {
        return Err(bad(format!(
            "/{GROUP}/0/{PARAMS} has {} values; a {}x{} grid of 2-vectors has {}",
            params.len(),
            size[0],
            size[1],
            2 * n
        )));
    }
    Ok(ItkDisplacementField {
        size,
        origin: [fixed[2], fixed[3]],
        spacing: [fixed[4], fixed[5]],
        direction: [fixed[6], fixed[7], fixed[8], fixed[9]],
        data: params.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
    })
}

/// Built without the `hdf5` feature: [`ItkError::Hdf5`] naming the missing feature.
#[cfg(not(feature = "hdf5"))]
fn no_hdf5(path: &Path) -> ItkError {
    ItkError::Hdf5 {
        path: path.to_path_buf(),
        message: "this build of trimorph has no HDF5 support (Cargo feature `hdf5`)".into(),
    }
}

/// The file's bytes: always [`ItkError::Hdf5`] in a build without the `hdf5` feature.
#[cfg(not(feature = "hdf5"))]
pub fn to_h5_bytes(_f: &ItkDisplacementField, path: &Path) -> Result<Vec<u8>, ItkError> {
    Err(no_hdf5(path))
}

/// [`read_h5`] from the file's bytes: always [`ItkError::Hdf5`] in a build without the
/// `hdf5` feature.
#[cfg(not(feature = "hdf5"))]
pub fn from_h5_bytes(_bytes: Vec<u8>, path: &Path) -> Result<ItkDisplacementField, ItkError> {
    Err(no_hdf5(path))
}

#[cfg(all(test, feature = "hdf5"))]
mod tests {
    use super::*;

    fn field() -> ItkDisplacementField {
        ItkDisplacementField {
            size: [3, 2],
            origin: [0.0; 2],
            spacing: [1.0; 2],
            direction: [1.0, 0.0, 0.0, 1.0],
            data: vec![
                [0.5, -0.25],
                [1.0, 2.0],
                [f64::NAN; 2],
                [3.0, 4.0],
                [-1.0, 0.0],
                [0.1, 0.2],
            ],
        }
    }

    #[test]
    fn bytes_round_trip_with_nan_kept() {
        let p = Path::new("t.h5");
        let f = field();
        let back = from_h5_bytes(to_h5_bytes(&f, p).unwrap(), p).unwrap();
        assert_eq!(back.size, f.size);
        assert_eq!(back.fixed_parameters(), [3.0, 2.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 1.0]);
        assert_eq!(back.undefined(), 1);
        for (a, b) in f.data.iter().zip(&back.data) {
            assert!(a == b || (a[0].is_nan() && b[0].is_nan()), "{a:?} vs {b:?}");
        }
        // 0.1 survives bit for bit: the values are f64 on disk.
        assert_eq!(back.data[5], [0.1, 0.2]);
    }

    #[test]
    fn the_type_string_is_variable_length_ascii() {
        let p = Path::new("t.h5");
        let file = hdf5_pure::File::from_bytes(to_h5_bytes(&field(), p).unwrap()).unwrap();
        let d = file.dataset("TransformGroup/0/TransformType").unwrap();
        assert_eq!(d.read_string().unwrap(), vec![TRANSFORM_TYPE.to_string()]);
        match d.datatype().unwrap() {
            hdf5_pure::Datatype::VariableLength { is_string, charset, .. } => {
                assert!(is_string);
                assert_eq!(charset, Some(hdf5_pure::CharacterSet::Ascii));
            }
            other => panic!("TransformType is {other:?}"),
        }
        for name in ["ITKVersion", "HDFVersion", "OSName", "OSVersion"] {
            assert_eq!(file.dataset(name).unwrap().read_string().unwrap().len(), 1, "{name}");
        }
    }

    #[test]
    fn extensions_and_sizes_are_checked() {
        assert!(is_h5_path(Path::new("a/F.h5")) && is_h5_path(Path::new("F.HDF5")));
        assert!(!is_h5_path(Path::new("F.npy")) && !is_h5_path(Path::new("F")));
        let e = write_h5(&field(), Path::new("out.mha")).unwrap_err();
        assert!(matches!(e, ItkError::Extension { .. }) && e.to_string().contains("out.mha"));
        let mut f = field();
        f.data.pop();
        let e = to_h5_bytes(&f, Path::new("x.h5")).unwrap_err().to_string();
        assert!(e.contains("x.h5") && e.contains("5 displacements"), "{e}");
    }

    /// ITK 5 writes `TransformFixedParameters` / `TransformParameters` (spelled right); the
    /// reader takes those too (the layout SimpleITK 2.5 / ITK 5.4 writes).
    #[test]
    fn the_spelling_itk_5_writes_is_read() {
        let mut b = hdf5_pure::FileBuilder::new();
        let mut group = b.create_group(GROUP);
        let mut t = group.create_group("0");
        ascii_vlen(t.create_dataset("TransformType"), TRANSFORM_TYPE);
        t.create_dataset(FIXED_NEW).with_f64_data(&field().fixed_parameters());
        let params: Vec<f64> = (0..12).map(f64::from).collect();
        t.create_dataset(PARAMS_NEW).with_f64_data(&params);
        group.add_group(t.finish());
        b.add_group(group.finish());
        let f = from_h5_bytes(b.finish().unwrap(), Path::new("sitk.h5")).unwrap();
        assert_eq!(f.size, [3, 2]);
        assert_eq!(f.data[1], [2.0, 3.0], "x fastest, components interleaved");
    }

    #[test]
    fn foreign_files_are_refused_with_the_dataset_named() {
        let p = Path::new("other.h5");
        let mut b = hdf5_pure::FileBuilder::new();
        b.create_dataset("x").with_f64_data(&[1.0]);
        let e = from_h5_bytes(b.finish().unwrap(), p).unwrap_err().to_string();
        assert!(e.contains("other.h5") && e.contains("TransformType"), "{e}");
        let e = from_h5_bytes(b"not hdf5".to_vec(), p).unwrap_err().to_string();
        assert!(e.contains("other.h5"), "{e}");
    }
}

//! Warping files through a deformation `phi` (`trimorph warp`, `trimorph colormesh`):
//!
//! * images and stacks (PNG, TIFF, JPEG, PNM, OME-Zarr): `O(q) = I(phi^-1(q))`, same size,
//!   type and bit depth ([`ImageInput`], [`ImageInput::warp_to`]), with a fold report;
//! * colored triangle meshes: vertices through `phi`, saved (OBJ, PLY) or rasterized
//!   ([`MeshInput`]);
//! * points (CSV): forward `p -> phi(p)` or inverse `q -> phi^-1(q)` ([`warp_points`]);
//! * an image as a fine colored triangle mesh ([`colormesh`]).

use super::OptionError;
use super::{raster_fits, JobError, JobResult};
use crate::exact::rat_to_f64;
use crate::io::ngff::{self, NgffImage, SampleType};
use crate::io::points::{optional_points_csv, read_optional_points};
use crate::io::raster::Stack;
use crate::io::{read_text, write_atomic};
use crate::spline::Spline;
use crate::warp::colormesh::{ColorMesh, ColorMode};
use crate::warp::inverse::InverseOptions;
use crate::warp::remap::RemapPlan;
use crate::warp::{forward, inverse, warp_pages, WarpOptions, WarpReport};
use image::ColorType;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// An image read for warping: the pages of a raster file or stack, or an OME-Zarr image
/// (kept as the template of an OME-Zarr output).
pub struct ImageInput {
    path: PathBuf,
    stack: Stack,
    ngff: Option<NgffImage>,
    decode_ms: f64,
}

impl ImageInput {
    /// Reads `path` to warp it: an OME-Zarr image when it is one ([`ngff::is_zarr_path`]),
    /// else any raster file ([`crate::io::raster::read_stack_as`] with
    /// [`crate::io::raster::ImageUse::WARP`]).
    pub fn read(path: &Path) -> JobResult<ImageInput> {
        let t = Instant::now();
        let (stack, ngff) = if ngff::is_zarr_path(path) {
            let mut img = ngff::read_image(path)?;
            let pages = std::mem::take(&mut img.pages);
            (Stack { pages, gray_float: img.dtype == SampleType::F32 }, Some(img))
        } else {
            // Refused from its header when the warp's input, output and encoding would
            // not fit the budget (issue 54: a 20000 x 20000 JPEG bomb was decoded first).
            let usage = crate::io::raster::ImageUse::WARP;
            (crate::io::raster::read_stack_as(path, &usage)?, None)
        };
        let decode_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok(ImageInput { path: path.to_path_buf(), stack, ngff, decode_ms })
    }

    /// The pages.
    pub fn pages(&self) -> &[image::DynamicImage] {
        &self.stack.pages
    }

    /// Width and height of the first page.
    pub fn size(&self) -> (u32, u32) {
        self.stack.pages.first().map_or((0, 0), |p| (p.width(), p.height()))
    }

    /// Rows to warp over all pages (the units of [`ImageInput::warp_to`]'s progress).
    pub fn rows(&self) -> u64 {
        self.size().1 as u64 * self.stack.pages.len().max(1) as u64
    }

    /// Whether the warp is large enough to show progress for (4 Mpixels or more).
    pub fn is_large(&self) -> bool {
        self.size().0 as u64 * self.rows() >= 4 << 20
    }

    /// Warps every page through `s` (read from the file `deformation`, which errors name)
    /// and writes the result to `output`: an OME-Zarr image like the input's when `output`
    /// is `.zarr`, else the raster writers. The input, the output and its encoding are
    /// checked against the memory budget first. `progress` is called with rows done, over
    /// all pages ([`ImageInput::rows`] in all). Fails when no output pixel has a preimage
    /// (the deformation was made for another image).
    pub fn warp_to(
        &self,
        s: &Spline,
        deformation: &Path,
        output: &Path,
        opts: &WarpOptions,
        progress: &(dyn Fn(u64) + Sync),
    ) -> JobResult<ImageWarpReport> {
        if let Some(what) = collapsed_onto(s) {
            return Err(JobError::Collapsed { deformation: deformation.to_path_buf(), what });
        }
        let pages = &self.stack.pages;
        let (w, h) = self.size();
        let color = pages.first().map_or(ColorType::L8, |p| p.color());
        // The input stays while the output is computed and then encoded in memory.
        let in_bytes: u64 = pages.iter().map(|p| p.as_bytes().len() as u64).sum();
        crate::memory::check(in_bytes.saturating_mul(3), || {
            format!(
                "warping {} page(s) of {w} x {h} {color:?} (input, output and its encoding)",
                pages.len()
            )
        })
        .map_err(|e| JobError::context(self.path.display().to_string(), e))?;
        let t_warp = Instant::now();
        let (warped, warp) = warp_pages(s, pages, opts, &|n| progress(n * pages.len() as u64))?;
        let warp_ms = t_warp.elapsed().as_secs_f64() * 1e3;
        if warp.pixels > 0 && warp.outside == warp.pixels {
            return Err(JobError::NoOverlap {
                deformation: deformation.to_path_buf(),
                image: self.path.clone(),
                size: (w, h),
            });
        }
        let out_stack = Stack { pages: warped, gray_float: self.stack.gray_float };
        let t_encode = Instant::now();
        write_image_output(output, &out_stack, self.ngff.as_ref())?;
        let encode_ms = t_encode.elapsed().as_secs_f64() * 1e3;
        Ok(ImageWarpReport {
            size: (w, h),
            color,
            pages: pages.len(),
            output: output.to_path_buf(),
            warp,
            decode_ms: self.decode_ms,
            warp_ms,
            encode_ms,
        })
    }
}

/// Writes warped pages: an OME-Zarr image like `like` when `path` is `.zarr`, else the
/// raster writers ([`crate::io::raster::write_stack`]).
pub fn write_image_output(path: &Path, stack: &Stack, like: Option<&NgffImage>) -> JobResult<()> {
    if !ngff::is_zarr_path(path) {
        crate::io::raster::write_stack(path, stack)?;
        return Ok(());
    }
    let Some(like) = like else {
        return Err(OptionError::OutputType {
            path: path.to_path_buf(),
            expected: "an OME-Zarr output copies the axes and metadata of an OME-Zarr input; give --image IN.zarr, or write .tif",
        }
        .into());
    };
    ngff::write_image(path, like, &stack.pages)?;
    Ok(())
}

/// What [`ImageInput::warp_to`] did.
#[derive(Clone, Debug)]
pub struct ImageWarpReport {
    /// Width and height of each page.
    pub size: (u32, u32),
    /// The pages' pixel type.
    pub color: ColorType,
    /// Number of pages.
    pub pages: usize,
    /// The output file.
    pub output: PathBuf,
    /// The warp's own report (pixels outside, error bound, folds, inverse-map paths).
    pub warp: WarpReport,
    /// Decoding time, ms.
    pub decode_ms: f64,
    /// Inverse map and resampling time, ms.
    pub warp_ms: f64,
    /// Encoding and writing time, ms.
    pub encode_ms: f64,
}

impl ImageWarpReport {
    /// `WxH Type[, N pages] -> OUT: K pixels outside the deformed mesh (background), max
    /// inverse error bound E px`.
    pub fn summary_line(&self) -> String {
        let (w, h) = self.size;
        format!(
            "{w}x{h} {:?}{} -> {}: {} pixels outside the deformed mesh (background), max inverse error bound {:.2e} px",
            self.color,
            if self.pages > 1 { format!(", {} pages", self.pages) } else { String::new() },
            self.output.display(),
            self.warp.outside,
            self.warp.max_error_bound
        )
    }

    /// `Ok(line)` when the output is certified fold-free, `Err(warning)` (with the folded
    /// pixels and their box) otherwise.
    pub fn folds(&self) -> Result<String, String> {
        match self.warp.fold_box {
            None => Ok(
                "folds: none in the output (certified: every interpolated piece keeps det J > 0)"
                    .to_string(),
            ),
            Some(b) => Err(format!(
                "phi folds over the output: {} pixels in [{}, {}] - [{}, {}] come from pieces with det J <= 0; each shows one layer: the last rasterized, else the first solved by Newton (see `trimorph field --jacobian`)",
                self.warp.folded, b[0], b[1], b[2], b[3]
            )),
        }
    }

    /// The phase times, how many pixels took each path of the inverse map, and the
    /// inverse-map plan of `s` for this size (built again, and timed).
    pub fn timing_lines(&self, s: &Spline, opts: &WarpOptions) -> [String; 3] {
        let (w, h) = self.size;
        let mp = (w as f64 * h as f64 * self.pages.max(1) as f64) / 1e6;
        let t_plan = Instant::now();
        let plan = RemapPlan::new(s, w, h, opts.remap);
        let counts = plan.debug_counts();
        [
            format!(
                "time: decode {:.1} ms, inverse map + resampling {:.1} ms ({:.0} MP/s), encode {:.1} ms",
                self.decode_ms,
                self.warp_ms,
                mp / (self.warp_ms / 1e3).max(1e-9),
                self.encode_ms
            ),
            format!("inverse map: {}", self.warp.paths_line()),
            format!(
                "inverse map plan: {counts} ({:.1} ms to build again)",
                t_plan.elapsed().as_secs_f64() * 1e3
            ),
        ]
    }

    /// A warning when the inverse error bound exceeds `tolerance` somewhere.
    pub fn tolerance_warning(&self, tolerance: f64) -> Option<String> {
        (self.warp.max_error_bound > tolerance).then(|| {
            format!(
                "the inverse error bound {:.2e} px exceeds --tolerance {tolerance} somewhere",
                self.warp.max_error_bound
            )
        })
    }
}

/// A colored triangle mesh moved through a deformation (`trimorph warp --mesh`).
pub struct MeshInput {
    /// The mesh as read.
    pub mesh: ColorMesh,
    /// The mesh through `phi`, without the triangles that left the deformation's mesh.
    pub moved: ColorMesh,
    /// Triangles dropped (a vertex outside the deformation's reference mesh).
    pub dropped: usize,
}

impl MeshInput {
    /// Reads the colored mesh `input` (OBJ with vertex colours, or PLY) and moves its
    /// vertices through `s`.
    pub fn deform(s: &Spline, input: &Path) -> JobResult<MeshInput> {
        let mesh = crate::io::colormesh::load(input)?;
        let (moved, dropped) = mesh.deform(s);
        Ok(MeshInput { mesh, moved, dropped })
    }

    /// The warning for dropped triangles, naming the input `path`.
    pub fn dropped_warning(&self, path: &Path) -> Option<String> {
        (self.dropped > 0).then(|| {
            format!(
                "{} triangles of {} have a vertex outside the deformation's mesh and were dropped",
                self.dropped,
                path.display()
            )
        })
    }

    /// Whether [`MeshInput::save`] draws a picture to `output` (a `.png`), the only output
    /// that takes a size.
    pub fn draws(output: &Path) -> bool {
        super::ext_of(output) == "png"
    }

    /// Saves the moved mesh (`.obj`, `.ply`) or draws it antialiased (`.png`: `size` or
    /// the undeformed mesh's extent; `background` a gray level 0..255, default
    /// transparent). Returns the report line.
    pub fn save(
        &self,
        output: &Path,
        size: Option<(u32, u32)>,
        background: Option<f64>,
    ) -> JobResult<String> {
        let moved = &self.moved;
        match super::ext_of(output).as_str() {
            "png" => {
                let (w, h) = match size {
                    Some((w, h)) => {
                        if !raster_fits(w, h) {
                            return Err(OptionError::PictureSize { size: (w, h) }.into());
                        }
                        (w, h)
                    }
                    None => {
                        // The undeformed mesh's extent (vertices at pixel centres 0 .. w-1).
                        let mx = self
                            .mesh
                            .vertices
                            .iter()
                            .fold([0.0f64; 2], |m, v| [m[0].max(v[0]), m[1].max(v[1])]);
                        ((mx[0].ceil() as u32 + 1).max(1), (mx[1].ceil() as u32 + 1).max(1))
                    }
                };
                let bg = match background {
                    None => None,
                    Some(v) if (0.0..=255.0).contains(&v) => {
                        let g = v.round() as u8;
                        Some([g, g, g, 255])
                    }
                    Some(v) => return Err(OptionError::MeshBackground(v).into()),
                };
                let pix = crate::render::colormesh::rasterize(moved, w, h, bg)?;
                crate::render::deformation::save_png(&pix, output)?;
                Ok(format!(
                    "{} triangles through phi -> {} ({w}x{h}, antialiased)",
                    moved.triangles.len(),
                    output.display()
                ))
            }
            "obj" | "ply" => {
                crate::io::colormesh::save(moved, output)?;
                Ok(format!(
                    "{} triangles through phi -> {}",
                    moved.triangles.len(),
                    output.display()
                ))
            }
            _ => Err(OptionError::OutputType {
                path: output.to_path_buf(),
                expected: "a warped mesh is saved as .obj or .ply, or drawn as .png",
            }
            .into()),
        }
    }
}

/// What [`warp_points`] did.
#[derive(Clone, Debug)]
pub struct PointsReport {
    /// Rows of the input (blank rows stay blank).
    pub rows: usize,
    /// Points with no image (outside the mesh), written as empty fields.
    pub missing: usize,
    /// Whether the points went through `phi^-1`.
    pub inverse: bool,
    /// The output file.
    pub output: PathBuf,
}

impl PointsReport {
    /// `N points through phi (forward) -> OUT`.
    pub fn summary_line(&self) -> String {
        let dir = if self.inverse { "phi^-1 (inverse)" } else { "phi (forward)" };
        format!("{} points through {dir} -> {}", self.rows, self.output.display())
    }

    /// The warning for points outside the mesh, if any.
    pub fn missing_warning(&self) -> Option<String> {
        (self.missing > 0).then(|| {
            format!(
                "{} points are outside the {} (written as empty fields)",
                self.missing,
                if self.inverse { "deformed mesh" } else { "reference mesh" }
            )
        })
    }
}

/// Maps the points of the CSV `input` (`x,y` rows; empty rows stay empty) through `s`
/// (forward, or with `inverse` through `phi^-1` within `opts.tolerance`) and writes them
/// to `output` as CSV (points without an image as empty fields).
pub fn warp_points(
    s: &Spline,
    input: &Path,
    output: &Path,
    inverse_map: bool,
    opts: InverseOptions,
) -> JobResult<PointsReport> {
    let rows = read_optional_points(&read_text(input)?, &input.display().to_string())?;
    let pts: Vec<[f64; 2]> = rows.iter().flatten().copied().collect();
    let mapped: Vec<Option<[f64; 2]>> = if inverse_map {
        inverse(s, &pts, opts).into_iter().map(|r| r.map(|r| r.p)).collect()
    } else {
        forward(s, &pts)
    };
    let mut it = mapped.into_iter();
    let res: Vec<Option<[f64; 2]>> =
        rows.iter().map(|r| r.and_then(|_| it.next().expect("one per point"))).collect();
    let missing = res.iter().filter(|r| r.is_none()).count();
    write_atomic(output, optional_points_csv(&res).as_bytes())?;
    Ok(PointsReport { rows: rows.len(), missing, inverse: inverse_map, output: output.into() })
}

/// What a deformation whose control points all lie on one point or one line maps the
/// mesh onto (`None` when they span an area), decided exactly.
pub fn collapsed_onto(s: &Spline) -> Option<String> {
    let pts = s.points();
    let show = |p: &[crate::exact::Rat]| format!("({}, {})", rat_to_f64(&p[0]), rat_to_f64(&p[1]));
    let p0 = pts.first()?;
    let Some(p1) = pts.iter().find(|p| p[..2] != p0[..2]) else {
        return Some(format!("the point {}", show(p0)));
    };
    let (dx, dy) = (&p1[0] - &p0[0], &p1[1] - &p0[1]);
    let on_line = |p: &Vec<crate::exact::Rat>| &dx * (&p[1] - &p0[1]) == &dy * (&p[0] - &p0[0]);
    pts.iter().all(on_line).then(|| format!("a line through {} and {}", show(p0), show(p1)))
}

/// Converts the first page of `image` into a mesh of colored triangles (two per `step` x
/// `step` cell, vertices at pixel centres; one colour per triangle with `flat`) and saves
/// it as PLY or OBJ. Returns the report line.
pub fn colormesh(image: &Path, output: &Path, step: u32, flat: bool) -> JobResult<String> {
    let stack = crate::io::raster::read_stack(image)?;
    let mode = if flat { ColorMode::Flat } else { ColorMode::PerVertex };
    let mesh = ColorMesh::from_image(&stack.pages[0], step, mode)
        .map_err(|e| JobError::context(image.display().to_string(), e))?;
    crate::io::colormesh::save(&mesh, output)?;
    Ok(format!(
        "{} vertices, {} triangles ({}) -> {}",
        mesh.vertices.len(),
        mesh.triangles.len(),
        if flat { "flat colours" } else { "per-vertex colours" },
        output.display()
    ))
}

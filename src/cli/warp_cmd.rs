//! `trimorph warp DEF (--image IN | --points IN.csv) -o OUT`.

use super::common::{parse_raster_size, progress_bar, raster_fits};
use crate::io::points::{optional_points_csv, read_optional_points};
use crate::io::raster::Stack;
use crate::io::{read_text, write_atomic};
use crate::warp::inverse::InverseOptions;
use crate::warp::remap::RemapOptions;
use crate::warp::{forward, inverse, warp_pages, Interp, WarpOptions};
use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::Path;

/// Options of `trimorph warp`.
pub struct WarpArgs<'a> {
    pub deformation: &'a Path,
    pub image: Option<&'a Path>,
    pub points: Option<&'a Path>,
    pub mesh: Option<&'a Path>,
    pub model: Option<&'a Path>,
    pub output: &'a Path,
    pub size: Option<&'a str>,
    pub inverse: bool,
    pub interp: Interp,
    pub background: Option<f64>,
    pub tolerance: f64,
    /// Print phase times and the pixels of each inverse-map path.
    pub verbose: bool,
    /// The up axis of a --model.
    pub up: crate::io::model::UpAxis,
}

/// `trimorph warp DEF --mesh IN.(obj|ply) -o OUT.(png|obj|ply)`: moves the vertices of a
/// colored triangle mesh through phi, then saves the mesh or rasterizes it (antialiased).
fn warp_mesh(
    s: &crate::spline::Spline,
    input: &Path,
    output: &Path,
    size: Option<&str>,
    background: Option<f64>,
    out: &mut impl Write,
) -> Result<()> {
    let mesh = crate::io::colormesh::load(input)?;
    let (moved, dropped) = mesh.deform(s);
    if dropped > 0 {
        eprintln!(
            "warning: {dropped} triangles of {} have a vertex outside the deformation's mesh and were dropped",
            input.display()
        );
    }
    let ext = output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("png") => {
            let (w, h) = match size {
                Some(sz) => {
                    let (w, h) = parse_raster_size(sz)?;
                    if !raster_fits(w, h) {
                        bail!("--size {w},{h}: each side must be positive and the area at most 10^8 pixels");
                    }
                    (w, h)
                }
                None => {
                    // The undeformed mesh's extent (vertices at pixel centres 0 .. w-1).
                    let mx = mesh
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
                Some(v) => bail!("--background for a mesh picture is a gray level 0..255, not {v}"),
            };
            let pix = crate::render::colormesh::rasterize(&moved, w, h, bg)?;
            crate::render::deformation::save_png(&pix, output)?;
            writeln!(
                out,
                "{} triangles through phi -> {} ({w}x{h}, antialiased)",
                moved.triangles.len(),
                output.display()
            )?;
        }
        Some("obj" | "ply") => {
            crate::io::colormesh::save(&moved, output)?;
            writeln!(
                out,
                "{} triangles through phi -> {}",
                moved.triangles.len(),
                output.display()
            )?;
        }
        _ => {
            bail!("{}: a warped mesh is saved as .obj or .ply, or drawn as .png", output.display())
        }
    }
    Ok(())
}

/// `trimorph colormesh IMAGE -o MESH.(ply|obj) [--step N] [--flat]`.
pub fn colormesh(image: &Path, output: &Path, step: u32, flat: bool) -> Result<()> {
    use crate::warp::colormesh::{ColorMesh, ColorMode};
    let stack = crate::io::raster::read_stack(image)?;
    let mode = if flat { ColorMode::Flat } else { ColorMode::PerVertex };
    let mesh = ColorMesh::from_image(&stack.pages[0], step, mode)
        .with_context(|| format!("{}", image.display()))?;
    crate::io::colormesh::save(&mesh, output)?;
    println!(
        "{} vertices, {} triangles ({}) -> {}",
        mesh.vertices.len(),
        mesh.triangles.len(),
        if flat { "flat colours" } else { "per-vertex colours" },
        output.display()
    );
    Ok(())
}

/// Runs `trimorph warp`.
pub fn run(a: WarpArgs) -> Result<()> {
    if let Some(m) = a.model {
        if a.image.is_some() || a.points.is_some() || a.mesh.is_some() {
            bail!("give exactly one of --image, --points, --mesh or --model");
        }
        return super::model_cmd::warp_model(a.deformation, m, a.output, a.up);
    }
    let text = read_text(a.deformation)?;
    let (s, _) = crate::io::deformation::from_str(&text)
        .with_context(|| format!("cannot read deformation {}", a.deformation.display()))?;
    if !(a.tolerance > 0.0 && a.tolerance.is_finite()) {
        bail!("--tolerance must be a positive number of pixels");
    }
    let opts = InverseOptions { tolerance: a.tolerance, ..Default::default() };
    let mut out = std::io::stdout().lock();
    let background = a.background.unwrap_or(0.0);
    match (a.image, a.points, a.mesh) {
        (Some(img_path), None, None) => {
            if a.inverse {
                bail!("--inverse applies to --points; images are always warped as O(q) = I(phi^-1(q))");
            }
            let interp = a.interp;
            if !background.is_finite() {
                bail!("--background must be a finite number");
            }
            let t_decode = std::time::Instant::now();
            let (stack, ngff_in) = super::ngff_cmd::read_input(img_path)?;
            let decode_s = t_decode.elapsed().as_secs_f64();
            let first = &stack.pages[0];
            let (w, h) = (first.width(), first.height());
            let wo = WarpOptions {
                interp,
                background,
                remap: RemapOptions { inverse: opts, ..Default::default() },
            };
            // The input stays while the output is computed and then encoded in memory.
            let in_bytes: u64 = stack.pages.iter().map(|p| p.as_bytes().len() as u64).sum();
            crate::memory::check(in_bytes.saturating_mul(3), || {
                format!(
                    "warping {} page(s) of {w} x {h} {:?} (input, output and its encoding)",
                    stack.pages.len(),
                    first.color()
                )
            })
            .with_context(|| img_path.display().to_string())?;
            let rows = h as u64 * stack.pages.len().max(1) as u64;
            let bar = progress_bar(rows, w as u64 * rows >= 4 << 20, "warping");
            let t_warp = std::time::Instant::now();
            let (warped, rep) =
                warp_pages(&s, &stack.pages, &wo, &|n| bar.inc(n * stack.pages.len() as u64))?;
            let warp_s = t_warp.elapsed().as_secs_f64();
            bar.finish_and_clear();
            if rep.pixels > 0 && rep.outside == rep.pixels {
                bail!(
                    "{}: the deformed mesh does not overlap the {w}x{h} image {} at all (every output pixel would be background); mesh coordinates are the image's pixels: use the deformation made for this image",
                    a.deformation.display(),
                    img_path.display()
                );
            }
            let out_stack = Stack { pages: warped, gray_float: stack.gray_float };
            let t_encode = std::time::Instant::now();
            super::ngff_cmd::write_output(a.output, &out_stack, ngff_in.as_ref())?;
            let encode_s = t_encode.elapsed().as_secs_f64();
            writeln!(
                out,
                "{w}x{h} {:?}{} -> {}: {} pixels outside the deformed mesh (background), max inverse error bound {:.2e} px",
                first.color(),
                if stack.pages.len() > 1 { format!(", {} pages", stack.pages.len()) } else { String::new() },
                a.output.display(),
                rep.outside,
                rep.max_error_bound
            )?;
            match rep.fold_box {
                None => writeln!(
                    out,
                    "folds: none in the output (certified: every interpolated piece keeps det J > 0)"
                )?,
                Some(b) => eprintln!(
                    "warning: phi folds over the output: {} pixels in [{}, {}] - [{}, {}] come from pieces with det J <= 0; each shows the layer drawn last (see `trimorph field --jacobian`)",
                    rep.folded, b[0], b[1], b[2], b[3]
                ),
            }
            if a.verbose {
                let mp = (w as f64 * h as f64 * stack.pages.len().max(1) as f64) / 1e6;
                writeln!(
                    out,
                    "time: decode {:.1} ms, inverse map + resampling {:.1} ms ({:.0} MP/s), encode {:.1} ms",
                    decode_s * 1e3,
                    warp_s * 1e3,
                    mp / warp_s.max(1e-9),
                    encode_s * 1e3
                )?;
                writeln!(out, "inverse map: {}", rep.paths_line())?;
                let t_plan = std::time::Instant::now();
                let plan = crate::warp::remap::RemapPlan::new(&s, w, h, wo.remap);
                writeln!(
                    out,
                    "inverse map plan: {} ({:.1} ms to build again)",
                    plan.debug_counts(),
                    t_plan.elapsed().as_secs_f64() * 1e3
                )?;
            }
            if rep.max_error_bound > opts.tolerance {
                eprintln!(
                    "warning: the inverse error bound {:.2e} px exceeds --tolerance {} somewhere",
                    rep.max_error_bound, opts.tolerance
                );
            }
        }
        (None, None, Some(m)) => warp_mesh(&s, m, a.output, a.size, a.background, &mut out)?,
        (None, Some(p), None) => {
            let rows = read_optional_points(&read_text(p)?, &p.display().to_string())?;
            let pts: Vec<[f64; 2]> = rows.iter().flatten().copied().collect();
            let mapped: Vec<Option<[f64; 2]>> = if a.inverse {
                inverse(&s, &pts, opts).into_iter().map(|r| r.map(|r| r.p)).collect()
            } else {
                forward(&s, &pts)
            };
            let mut it = mapped.into_iter();
            let res: Vec<Option<[f64; 2]>> =
                rows.iter().map(|r| r.and_then(|_| it.next().expect("one per point"))).collect();
            let missing = res.iter().filter(|r| r.is_none()).count();
            write_atomic(a.output, optional_points_csv(&res).as_bytes())?;
            let dir = if a.inverse { "phi^-1 (inverse)" } else { "phi (forward)" };
            writeln!(out, "{} points through {dir} -> {}", rows.len(), a.output.display())?;
            if missing > 0 {
                eprintln!(
                    "warning: {missing} points are outside the {} (written as empty fields)",
                    if a.inverse { "deformed mesh" } else { "reference mesh" }
                );
            }
        }
        _ => bail!("give exactly one of --image, --points, --mesh or --model"),
    }
    Ok(())
}

/// `trimorph field DEF -o FIELD.(tif|npy|h5|zarr) [--inverse] [--both] [--jacobian JAC.png]
/// [--size W,H]`.
pub fn field(
    def: &Path,
    output: &Path,
    inverse_field: bool,
    both: bool,
    jacobian: Option<&Path>,
    size: Option<&str>,
) -> Result<()> {
    use crate::warp::field as wf;
    let ext_of = |p: &Path| p.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
    let ext = ext_of(output);
    let itk = crate::io::itk::is_h5_path(output);
    if !itk && !matches!(ext.as_str(), "npy" | "tif" | "tiff" | "zarr") {
        bail!(
            "{}: use a .npy or .tif output (or .h5 for an ITK transform, .zarr for an OME-Zarr store)",
            output.display()
        );
    }
    if both && ext != "zarr" {
        bail!(
            "{}: --both writes an NGFF bijection, which only an OME-Zarr (.zarr) store holds",
            output.display()
        );
    }
    if let Some(jp) = jacobian.filter(|jp| ext_of(jp) != "png") {
        bail!("{}: the Jacobian map is a PNG picture; name it .png", jp.display());
    }
    let text = read_text(def)?;
    let (s, _) = crate::io::deformation::from_str(&text)
        .with_context(|| format!("cannot read deformation {}", def.display()))?;
    let (w, h) = match size {
        Some(sz) => parse_raster_size(sz)?,
        None => {
            let (_, hi) = s.mesh().bbox();
            (hi[0].max(0.0).floor() as u32 + 1, hi[1].max(0.0).floor() as u32 + 1)
        }
    };
    if !raster_fits(w, h) {
        bail!(
            "{}: field size {w}x{h} is empty or too large (at most 10^8 pixels); give --size W,H",
            def.display()
        );
    }
    // Two f64 components per pixel, and their encoded copy.
    let field_bytes = crate::memory::bytes_of(w as u64 * h as u64, 2 * 8 * 2);
    crate::memory::check(field_bytes, || format!("a {w} x {h} displacement field"))
        .with_context(|| def.display().to_string())?;
    let mut out = std::io::stdout().lock();
    if itk {
        super::itk_cmd::field_h5(&s, w, h, output, inverse_field, &mut out)?;
        return jacobian_map(&s, w, h, jacobian, &mut out);
    }
    if ext == "zarr" {
        super::ngff_cmd::field_zarr(&s, output, (w, h), inverse_field, both, &mut out)?;
        return jacobian_map(&s, w, h, jacobian, &mut out);
    }
    let f = if inverse_field {
        wf::inverse_field(&s, w, h, InverseOptions::default())
    } else {
        wf::forward_field(&s, w, h)
    };
    let bytes = match ext.as_str() {
        "npy" => wf::to_npy(&f),
        // "tif" | "tiff", checked above.
        _ => {
            let mut c = std::io::Cursor::new(Vec::new());
            image::DynamicImage::ImageRgb32F(wf::to_rgb32f(&f))
                .write_to(&mut c, image::ImageFormat::Tiff)
                .context("cannot encode the float TIFF")?;
            c.into_inner()
        }
    };
    write_atomic(output, &bytes)?;
    let undefined = f.data.iter().filter(|v| v[0].is_nan()).count();
    writeln!(
        out,
        "{} displacement field {w}x{h} -> {} ({undefined} pixels undefined)",
        if inverse_field { "inverse (phi^-1(q) - q)" } else { "forward (phi(p) - p)" },
        output.display()
    )?;
    jacobian_map(&s, w, h, jacobian, &mut out)
}

/// `--jacobian JAC.png` of `trimorph field`: the colour map of `det J` (field pixel `(x, y)`
/// at picture pixel `(x, y)`) with its colour bar below, and its report lines.
fn jacobian_map(
    s: &crate::spline::Spline,
    w: u32,
    h: u32,
    jacobian: Option<&Path>,
    out: &mut impl Write,
) -> Result<()> {
    use crate::warp::field as wf;
    if let Some(jp) = jacobian {
        let (dets, rep) = wf::jacobian_det(s, w, h);
        let (pm, bar) = crate::render::colorbar::jacobian_picture(&dets, w, h)?;
        let png = pm.encode_png().context("cannot encode the Jacobian map")?;
        write_atomic(jp, &png)?;
        writeln!(
            out,
            "Jacobian determinant map {w}x{h} with its colour bar below ({}x{} in all) -> {} (min det J {:.4}; {} of {} samples fold{})",
            bar.width,
            bar.height,
            jp.display(),
            rep.min_det,
            rep.folds,
            rep.samples,
            rep.fold_bbox
                .map(|b| format!(", in x {}..{}, y {}..{}", b[0], b[2], b[1], b[3]))
                .unwrap_or_default()
        )?;
        writeln!(out, "{}", super::spline_cmds::det_j_line(&rep.certificate))?;
    }
    Ok(())
}

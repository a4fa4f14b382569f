//! The `trimorph` command line.
//!
//! Exit codes: 0 success; 1 bad input or I/O failure; 2 the edit is not solvable
//! (`trimorph solve`). Outputs are written atomically (temporary file, then rename).

mod bench;
mod common;
mod demo;
mod demo_fit;
mod editor_cmd;
mod fit_args;
mod fit_batch;
mod fit_cmd;
mod itk_cmd;
mod match_cmd;
mod model_cmd;
mod morph_cmd;
mod ngff_cmd;
mod solve;
pub mod spline_cmds;
mod warp_cmd;

use clap::{Parser, Subcommand};
use common::{exit_code, parse_memory, usage_exit};
pub use common::{Exit, EXIT_INPUT, EXIT_UNSOLVABLE};
use std::path::PathBuf;

/// Smooth (C1), exactly constrained, editable deformations.
#[derive(Parser, Debug)]
#[command(name = "trimorph", version, about, long_about = None)]
pub struct Cli {
    /// Memory budget for large buffers, e.g. 4G or 512M (default: half of the memory this
    /// process may use; also TRIMORPH_MAX_MEMORY). Inputs that need more are refused.
    #[arg(long, global = true, value_name = "SIZE", value_parser = parse_memory)]
    max_memory: Option<u64>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Edit parameters under exact affine constraints (ECLES) from a JSON problem.
    Solve {
        /// Problem file (JSON; `-` for standard input).
        system: PathBuf,
        /// Output file (JSON); standard output when absent.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Run the demonstration on bundled data (ECLES examples, a C1 edit over a cell image).
    Demo {
        /// Folder for the demo's outputs.
        #[arg(short, long, default_value = "out/demo")]
        output: PathBuf,
    },
    /// Build a reference mesh and write the identity deformation over it.
    Mesh {
        /// Points (CSV `x,y`) to triangulate (Delaunay).
        #[arg(long)]
        points: Option<PathBuf>,
        /// With --points: an outline polygon (CSV `x,y`, in order) for a constrained Delaunay.
        #[arg(long)]
        outline: Option<PathBuf>,
        /// A regular grid of COLSxROWS cells (e.g. 6x4), with --size.
        #[arg(long)]
        grid: Option<String>,
        /// Width and height covered by --grid, e.g. 640,480 (pixels).
        #[arg(long)]
        size: Option<String>,
        /// A 2D reference mesh in OBJ (`v` and `f` lines).
        #[arg(long)]
        obj: Option<PathBuf>,
        /// A mesh adapted to landmarks (CSV, BigWarp or JSON; their sources are vertices),
        /// over the --size frame grown by --margin, refined by Delaunay refinement.
        #[arg(long)]
        landmarks: Option<PathBuf>,
        /// With --landmarks: pixels added around the frame (default: a tenth of its larger
        /// side, at least 8).
        #[arg(long)]
        margin: Option<f64>,
        /// With --landmarks: longest edge in pixels (default: a quarter of the larger side).
        #[arg(long)]
        max_edge: Option<f64>,
        /// With --landmarks: the refinement's smallest angle in degrees (at most 33).
        #[arg(long, default_value_t = 20.0)]
        min_angle: f64,
        /// Spline degree (5 or more for local edits).
        #[arg(long, default_value_t = 5)]
        degree: usize,
        /// Vertex coordinates are snapped to multiples of 1/SNAP (default 16; with
        /// --landmarks the smallest of 16, 80, 400, 2000, 10000, 50000 on which every source
        /// is exact).
        #[arg(long)]
        snap: Option<i64>,
        /// Make a 2.5D deformation with prisms over [A, B] (e.g. -10,10).
        #[arg(long, allow_hyphen_values = true)]
        z_range: Option<String>,
        /// Output deformation (JSON).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Apply a JSON script of editing operations (translate, rotate, scale) to a deformation.
    Edit {
        /// Input deformation.
        deformation: PathBuf,
        /// JSON array of operations.
        #[arg(long)]
        script: PathBuf,
        /// Output deformation.
        #[arg(short, long)]
        output: PathBuf,
        /// Bounded exactness: after each operation round the free points of the minimal
        /// determining set to multiples of 2^-BITS (anchors land within 1e-4; sizes stay
        /// bounded over long histories).
        #[arg(long, default_value_t = 24)]
        bounded_bits: u32,
        /// Keep every value exactly as ECLES computes it (anchors exact; sizes grow with the
        /// edit history).
        #[arg(long)]
        unbounded: bool,
    },
    /// Report the C1 residuals (exact), Jacobian determinants and folds of a deformation.
    Check {
        /// The deformation.
        deformation: PathBuf,
        /// Samples per triangle side for the Jacobian scan.
        #[arg(long, default_value_t = 12)]
        samples: usize,
        #[command(flatten)]
        report: spline_cmds::CheckOptions,
    },
    /// Draw a deformation (deformed mesh, control net, C1 conditions, points) as a PNG.
    Render {
        /// The deformation.
        deformation: PathBuf,
        /// Output PNG.
        #[arg(short, long)]
        output: PathBuf,
        /// Background image (PNG, JPEG, TIFF or PNM); mesh coordinates are its pixels.
        #[arg(long)]
        background: Option<PathBuf>,
        /// Layers: comma list of mesh, net, constraints, points, reference, all.
        #[arg(long, default_value = "mesh,points")]
        show: String,
        /// Output size without a background, e.g. 800,600.
        #[arg(long, default_value = "800,600")]
        size: String,
        /// A 3D model (OBJ, OFF, PLY, XYZ) to draw through a 2.5D deformation.
        #[arg(long)]
        model: Option<PathBuf>,
        /// With --model: `top` (the xy projection, mesh and points) or `oblique` (both z
        /// surfaces, the walls and the model, depth-sorted).
        #[arg(long, default_value = "top")]
        view: String,
        #[command(flatten)]
        up: model_cmd::UpArgs,
        #[command(flatten)]
        marks: spline_cmds::RenderMarks,
    },
    /// Move an image or points through a deformation. Images: O(q) = I(phi^-1(q)), same
    /// size, type and bit depth. Points: forward p -> phi(p), or --inverse q -> phi^-1(q).
    Warp {
        /// The deformation.
        deformation: PathBuf,
        /// Input image (PNG, TIFF, JPEG, PNM), or an OME-Zarr image (.zarr, Zarr v2 or v3: 2D
        /// with optional t and c axes, level 0; every (t, c) plane is warped the same way).
        #[arg(long)]
        image: Option<PathBuf>,
        /// Input points (CSV `x,y`).
        #[arg(long)]
        points: Option<PathBuf>,
        /// Input colored triangle mesh (OBJ with vertex colours, or PLY).
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// Input 3D model (OBJ, OFF, PLY or XYZ) to move through the 2.5D deformation psi.
        #[arg(long)]
        model: Option<PathBuf>,
        /// Output image (.png, .tif, .jpg, .pgm, .ppm, .pam; .zarr for an OME-Zarr input: same axes, dtype,
        /// chunks and metadata, level 0 only), CSV, or (for --mesh) .png / .obj / .ply.
        #[arg(short, long)]
        output: PathBuf,
        /// Size W,H of the picture drawn from --mesh (default: the undeformed mesh's extent).
        #[arg(long)]
        size: Option<String>,
        /// Points: map q -> phi^-1(q) instead of p -> phi(p).
        #[arg(long)]
        inverse: bool,
        /// Image resampling: nearest, bilinear or bicubic.
        #[arg(long, default_value = "bilinear")]
        interp: String,
        /// Value of pixels whose preimage is outside the mesh (images: default 0; meshes:
        /// a gray level 0..255, default transparent).
        #[arg(long)]
        background: Option<f64>,
        /// Largest accepted error of an inverse point (pixels).
        #[arg(long, default_value_t = 0.01)]
        tolerance: f64,
        /// Images: also print the time of each phase (decode, inverse map and resampling,
        /// encode) and how many pixels took each path of the inverse map.
        #[arg(long)]
        verbose: bool,
        #[command(flatten)]
        up: model_cmd::UpArgs,
    },
    /// Morph image A into image B through landmark pairs (src in A, dst in B): frames
    /// `frame_000.png` ... in the output folder, an animated GIF and APNG,
    /// `contact-sheet.png`, and the two fitted deformations `phi_ab.json` and `phi_ba.json`.
    /// B is first brought into A's frame by the landmarks' similarity (printed). Frames have
    /// A's size and the richer type of the two images.
    Morph {
        /// Image A (first frame).
        a: PathBuf,
        /// Image B (last frame).
        b: PathBuf,
        /// Landmark pairs (CSV `name,src_x,src_y,dst_x,dst_y[,weight]`, BigWarp CSV or JSON).
        #[arg(long, required_unless_present = "phi_ab", conflicts_with = "phi_ab")]
        landmarks: Option<PathBuf>,
        /// Instead of landmarks: a deformation (format v1) mapping A's pixel coordinates to
        /// B's, e.g. the output of `trimorph fit`.
        #[arg(long, value_name = "DEF")]
        phi_ab: Option<PathBuf>,
        /// With --phi-ab: the deformation mapping B to A (default: fitted to samples of
        /// --phi-ab).
        #[arg(long, value_name = "DEF", requires = "phi_ab")]
        phi_ba: Option<PathBuf>,
        /// With --phi-ab and no --phi-ba: mesh cells per side of the grid mesh over B on
        /// which B->A is fitted (1 to 48). Landmark morphs use landmark-adapted meshes.
        #[arg(long, default_value_t = 8)]
        cells: usize,
        /// Keep B's raw pixel coordinates (no similarity alignment of B to A).
        #[arg(long)]
        no_align: bool,
        /// Print the time of each phase (read, fits, frames, encodings, writes) to stderr.
        #[arg(long)]
        timings: bool,
        /// Background where neither image has a preimage: one value for every channel, in
        /// the images' sample units (0..255 for 8-bit, 0..65535 for 16-bit, 0..1 for float;
        /// alpha is 0 there when the images have alpha).
        #[arg(long, default_value_t = 0.0)]
        background: f64,
        /// Number of frames (t = k / (frames - 1)), 2 to 1000.
        #[arg(long, default_value_t = 30)]
        frames: usize,
        /// Times T0,T1 of the first and last frame; outside 0,1 is a caricature
        /// (e.g. `-0.25,1.25`); times lie within -100..100.
        #[arg(long, default_value = "0,1", allow_hyphen_values = true)]
        range: String,
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
        /// Animated GIF (default OUTPUT/morph.gif).
        #[arg(long)]
        gif: Option<PathBuf>,
        /// Animated PNG (default OUTPUT/morph.apng).
        #[arg(long)]
        apng: Option<PathBuf>,
        /// Shape schedule alpha_shape(t): linear or smooth.
        #[arg(long, default_value = "linear")]
        shape: String,
        /// Colour schedule alpha_color(t): linear or smooth.
        #[arg(long, default_value = "linear")]
        color: String,
        /// Image resampling: nearest, bilinear or bicubic.
        #[arg(long, default_value = "bilinear")]
        interp: String,
        /// Fast preview: draw A as a colour mesh with a vertex every STEP pixels instead of
        /// warping both images.
        #[arg(long, value_name = "STEP")]
        preview: Option<u32>,
        /// Delay between animation frames (milliseconds).
        #[arg(long, default_value_t = 100)]
        delay: u32,
        /// No progress bar or summary.
        #[arg(long)]
        quiet: bool,
    },
    /// Interactive editor in the browser: serves a page on 127.0.0.1 (only) and prints its
    /// address. Without arguments it opens the bundled worm scene over time-lapse frame 0.
    /// Files are loaded and saved inside the current folder only.
    Editor {
        /// Deformation or scene to edit (format v1; a scene's "model" and "image" keys are
        /// loaded too). Default: an identity over --image, or the bundled scene.
        deformation: Option<PathBuf>,
        /// 3D model (OBJ, OFF, PLY) bound to the prism layer.
        #[arg(long)]
        model: Option<PathBuf>,
        /// Background image: the microscope frame to match.
        #[arg(long)]
        image: Option<PathBuf>,
        /// Port on 127.0.0.1 (0: any free port).
        #[arg(long, default_value_t = 8080)]
        port: u16,
    },
    /// 2.5D models: bind a 3D model to a prism mesh, or write the bundled organism.
    #[command(subcommand)]
    Model(ModelCommand),
    /// Converts an image into a fine mesh of colored triangles (two per `step` x `step`
    /// cell, vertices at pixel centres), saved as PLY or OBJ with vertex colours.
    Colormesh {
        /// Input image (PNG, TIFF, JPEG; the first page of a stack).
        image: PathBuf,
        /// Output mesh (.ply or .obj).
        #[arg(short, long)]
        output: PathBuf,
        /// Lattice step in pixels.
        #[arg(long, default_value_t = 2)]
        step: u32,
        /// One colour per triangle (the mean of its pixels) instead of per vertex.
        #[arg(long)]
        flat: bool,
    },
    /// Dense displacement field as float TIFF or .npy (forward phi(p) - p, or --inverse
    /// phi^-1(q) - q), as an ITK transform (.h5: phi^-1(q) - q, or --inverse phi(p) - p), or
    /// as an OME-Zarr NGFF `displacements` store (.zarr: by default the resampling direction
    /// phi^-1(q) - q, warped -> original pixels; --inverse phi(p) - p; --both a `bijection`
    /// holding the two), and optionally a Jacobian-determinant map (PNG) with a fold report.
    Field {
        /// The deformation.
        deformation: PathBuf,
        /// Output field (.tif: RGB float32 dx, dy, valid; .npy: float32 (H, W, 2), NaN
        /// outside; .h5: ITK HDF5 DisplacementFieldTransform_double_2_2 in pixel units, f64,
        /// NaN where undefined, by default phi^-1(q) - q so that ITK's Resample reproduces
        /// `trimorph warp --image`; .zarr: float64 (2, H, W) = (c, y, x), c = 0 the y
        /// displacement, NaN where undefined).
        #[arg(short, long)]
        output: PathBuf,
        /// The other direction: .npy/.tif hold phi^-1(q) - q instead of phi(p) - p; .h5 and
        /// .zarr hold phi(p) - p instead of phi^-1(q) - q.
        #[arg(long)]
        inverse: bool,
        /// .zarr only: write both fields as an NGFF `bijection` (forward phi(p) - p,
        /// inverse phi^-1(q) - q).
        #[arg(long)]
        both: bool,
        /// Also write the Jacobian determinant as a colour map (PNG): blue compression, white
        /// 1, orange expansion, red folds.
        #[arg(long)]
        jacobian: Option<PathBuf>,
        /// Grid size W,H in pixels (default: the mesh's extent from 0).
        #[arg(long)]
        size: Option<String>,
    },
    /// Automatic landmarks between two images (ORB, ratio and cross check, then an affine,
    /// homography or local model): `src` in A's pixel coordinates, `dst` in B's.
    Match(match_cmd::MatchCli),
    /// Fit a deformation to landmarks (`fit DEF --landmarks L -o OUT.json`), or a scene to
    /// every frame of a sequence (`fit --model SCENE.json --frames DIR --landmarks L -o DIR`).
    Fit(fit_args::FitCli),
    /// Measurements and experiments.
    Bench {
        #[command(subcommand)]
        which: BenchCommand,
    },
}

#[derive(Subcommand, Debug)]
enum ModelCommand {
    /// Writes an identity 2.5D deformation (format v1 with z_range, z0, z1) around a model.
    Bind {
        /// The 3D model (OBJ, OFF, PLY or XYZ).
        #[arg(long)]
        model: PathBuf,
        /// Reference mesh: a 2D OBJ whose vertices have z = b (prisms over [-b, b]).
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// Fit a grid around the model's bounding box instead.
        #[arg(long)]
        auto: bool,
        /// Grid of the automatic mesh, COLSxROWS.
        #[arg(long, default_value = "4x2")]
        grid: String,
        /// Margin of the automatic mesh, as a fraction of the model's largest side.
        #[arg(long, default_value_t = 0.05)]
        margin: f64,
        /// Prism range A,B (exact decimals or fractions; default from the mesh or model).
        #[arg(long)]
        range: Option<String>,
        /// Spline degree.
        #[arg(long, default_value_t = 5)]
        degree: usize,
        /// Output deformation file.
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        extra: model_cmd::BindExtra,
    },
    /// Writes the bundled C. elegans-like model (20,000 triangles), its landmarks and a
    /// reference prism mesh into a folder.
    Worm {
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
    },
}

#[derive(Subcommand, Debug)]
enum BenchCommand {
    /// Bit-size growth of the fraction-free LDU factors (thesis figs. 7.1-7.10): CSV + PNG.
    Bitgrowth {
        /// Output folder.
        #[arg(short, long, default_value = "out/bitgrowth")]
        output: PathBuf,
        /// Random matrices per point.
        #[arg(long, default_value_t = 20)]
        trials: usize,
        /// Fewer x values (for a fast check).
        #[arg(long)]
        quick: bool,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Run only the experiments whose id contains this text (e.g. fig7_1).
        #[arg(long)]
        only: Option<String>,
    },
}

/// Parses the arguments, runs the command and returns the exit code.
pub fn run() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_exit(&e),
    };
    crate::memory::set_limit(cli.max_memory);
    let result = match cli.command {
        Command::Solve { system, output } => solve::run(&system, output.as_deref()),
        Command::Demo { output } => demo::run(&output),
        Command::Mesh {
            points,
            outline,
            grid,
            size,
            obj,
            landmarks,
            margin,
            max_edge,
            min_angle,
            degree,
            snap,
            z_range,
            output,
        } => spline_cmds::mesh(spline_cmds::MeshArgs {
            points: points.as_deref(),
            outline: outline.as_deref(),
            grid: grid.as_deref(),
            size: size.as_deref(),
            obj: obj.as_deref(),
            landmarks: landmarks.as_deref(),
            margin,
            max_edge,
            min_angle,
            degree,
            snap,
            z_range: z_range.as_deref(),
            output: &output,
        }),
        Command::Edit { deformation, script, output, bounded_bits, unbounded } => {
            let bounded = if unbounded { None } else { Some(bounded_bits) };
            spline_cmds::edit(&deformation, &script, &output, bounded)
        }
        Command::Check { deformation, samples, report } => {
            spline_cmds::check(&deformation, samples, report)
        }
        Command::Render {
            deformation,
            output,
            background,
            size,
            model: Some(m),
            view,
            up,
            marks,
            ..
        } => marks.refuse_with_model().and_then(|()| {
            let bg = background.as_deref();
            model_cmd::render_model(&deformation, &m, &output, bg, &view, &size, up.up)
        }),
        Command::Render {
            deformation, output, background, show, size, model: None, marks, ..
        } => {
            spline_cmds::render(&deformation, &output, background.as_deref(), &show, &size, &marks)
        }
        Command::Model(ModelCommand::Bind {
            model,
            mesh,
            auto,
            grid,
            margin,
            range,
            degree,
            output,
            extra,
        }) => model_cmd::bind_cmd(model_cmd::BindArgs {
            model: &model,
            mesh: mesh.as_deref(),
            auto,
            grid: &grid,
            margin,
            range: range.as_deref(),
            degree,
            output: &output,
            extra,
        }),
        Command::Model(ModelCommand::Worm { output }) => model_cmd::worm_cmd(&output),
        Command::Colormesh { image, output, step, flat } => {
            warp_cmd::colormesh(&image, &output, step, flat)
        }
        Command::Warp {
            deformation,
            image,
            points,
            mesh,
            model,
            output,
            size,
            inverse,
            interp,
            background,
            tolerance,
            verbose,
            up,
        } => warp_cmd::run(warp_cmd::WarpArgs {
            deformation: &deformation,
            image: image.as_deref(),
            points: points.as_deref(),
            mesh: mesh.as_deref(),
            model: model.as_deref(),
            output: &output,
            size: size.as_deref(),
            inverse,
            interp: &interp,
            background,
            tolerance,
            verbose,
            up: up.up,
        }),
        Command::Morph {
            a,
            b,
            landmarks,
            phi_ab,
            phi_ba,
            cells,
            no_align,
            timings,
            background,
            frames,
            range,
            output,
            gif,
            apng,
            shape,
            color,
            interp,
            preview,
            delay,
            quiet,
        } => morph_cmd::run(morph_cmd::MorphArgs {
            a: &a,
            b: &b,
            landmarks: landmarks.as_deref(),
            phi_ab: phi_ab.as_deref(),
            phi_ba: phi_ba.as_deref(),
            cells,
            align: !no_align,
            timings,
            background,
            frames,
            range: &range,
            output: &output,
            gif: gif.as_deref(),
            apng: apng.as_deref(),
            shape: &shape,
            color: &color,
            interp: &interp,
            preview,
            delay_ms: delay,
            quiet,
        }),
        Command::Editor { deformation, model, image, port } => {
            editor_cmd::run(editor_cmd::EditorArgs {
                deformation: deformation.as_deref(),
                model: model.as_deref(),
                image: image.as_deref(),
                port,
            })
        }
        Command::Field { deformation, output, inverse, both, jacobian, size } => warp_cmd::field(
            &deformation,
            &output,
            inverse,
            both,
            jacobian.as_deref(),
            size.as_deref(),
        ),
        Command::Match(m) => match_cmd::run(m),
        Command::Fit(fit_args::FitCli {
            deformation,
            landmarks,
            output,
            report,
            loss,
            loss_scale,
            bend,
            hard,
            holdout,
            seed,
            radius,
            pin,
            min_det,
            no_barrier,
            max_iters,
            model,
            model_file,
            frames,
            track,
            anchor,
            key_every,
            background,
            shard,
            size,
            margin,
            max_edge,
            min_angle,
        }) => {
            let solver = fit_cmd::SolverArgs {
                loss: &loss,
                loss_scale,
                bend: &bend,
                hard,
                radius,
                min_det,
                no_barrier,
                max_iters,
            };
            let frame = size.as_deref().map(|sz| fit_cmd::FrameArgs {
                size: sz,
                margin,
                max_edge,
                min_angle,
            });
            match (deformation, model, frames) {
                (d, None, None) if d.is_some() != frame.is_some() => fit_cmd::run_single(
                    match (&d, &frame) {
                        (Some(d), _) => fit_cmd::Start::Deformation(d),
                        (None, Some(f)) => fit_cmd::Start::Frame(f),
                        (None, None) => unreachable!("the guard requires one of them"),
                    },
                    &landmarks,
                    &output,
                    report.as_deref(),
                    holdout,
                    seed,
                    pin.as_deref(),
                    &solver,
                ),
                (d, Some(scene), Some(fr)) if d.is_none() => fit_batch::run(fit_batch::BatchArgs {
                    scene: &scene,
                    model: model_file.as_deref(),
                    frames: &fr,
                    landmarks: &landmarks,
                    track,
                    anchor: anchor.as_deref(),
                    key_every,
                    holdout,
                    seed,
                    background,
                    output: &output,
                    report: report.as_deref(),
                    shard: shard.as_deref(),
                    solver,
                }),
                _ => Err(anyhow::anyhow!(
                    "give DEF.json (one fit), or --size W,H instead of DEF (one fit over a mesh adapted to the landmarks), or --model SCENE.json with --frames (a sequence)"
                )),
            }
        }
        Command::Bench { which: BenchCommand::Bitgrowth { output, trials, quick, seed, only } } => {
            bench::bitgrowth(&output, trials, quick, seed, only.as_deref())
        }
    };
    exit_code(result)
}

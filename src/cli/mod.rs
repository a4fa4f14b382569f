//! The `trimorph` command line.
//!
//! Exit codes: 0 success; 1 bad input or I/O failure; 2 the edit is not solvable
//! (`trimorph solve`). Outputs are written atomically (temporary file, then rename).

mod args;
mod bench;
mod common;
mod demo;
mod dispatch;
mod editor_cmd;
mod files;
mod fit_args;
mod fit_batch;
mod fit_cmd;
mod match_cmd;
mod model_cmd;
mod morph_cmd;
pub mod reference;
mod register_cmd;
mod solve;
mod spline_cmds;
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
    Mesh(args::MeshCli),
    /// Apply a JSON script of editing operations (translate, rotate, scale) to a deformation.
    Edit(args::EditCli),
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
    Render(args::RenderCli),
    /// Move an image or points through a deformation. Images: O(q) = I(phi^-1(q)), same
    /// size, type and bit depth. Points: forward p -> phi(p), or --inverse q -> phi^-1(q).
    Warp(args::WarpCli),
    /// Morph image A into image B through landmark pairs (src in A, dst in B): frames
    /// `frame_000.png` ... in the output folder, an animated GIF and APNG,
    /// `contact-sheet.png`, and the two fitted deformations `phi_ab.json` and `phi_ba.json`.
    /// B is first brought into A's frame by the landmarks' similarity (printed). Frames have
    /// A's size and the richer type of the two images.
    Morph(args::MorphCli),
    /// Interactive editor in the browser: serves a page on 127.0.0.1 (only) and prints its
    /// address. Without arguments it opens the bundled worm scene over time-lapse frame 0.
    /// Files are loaded and saved inside the current folder only.
    Editor(args::EditorCli),
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
    Field(args::FieldCli),
    /// Automatic landmarks between two images (ORB, ratio and cross check, then an affine,
    /// homography or local model): `src` in A's pixel coordinates, `dst` in B's.
    Match(match_cmd::MatchCli),
    /// Fit a deformation to landmarks (`fit DEF --landmarks L -o OUT.json`), or a scene to
    /// every frame of a sequence (`fit --model SCENE.json --frames DIR --landmarks L -o DIR`).
    Fit(fit_args::FitCli),
    /// Register MOVING to FIXED from the images themselves (ncc, ssd or Mattes mutual
    /// information; affine pre-alignment, then the C1 spline coarse to fine, certified
    /// fold-free), optionally with landmarks (soft or exact) or from a start deformation.
    Register(Box<register_cmd::RegisterCli>),
    /// Measurements and experiments.
    Bench {
        #[command(subcommand)]
        which: BenchCommand,
    },
}

#[derive(Subcommand, Debug)]
enum ModelCommand {
    /// Writes an identity 2.5D deformation (format v1 with z_range, z0, z1) around a model.
    Bind(Box<args::BindCli>),
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
    if let Err(e) = files::files(&cli.command).check() {
        return exit_code(Err(e.into()));
    }
    let result = match cli.command {
        Command::Solve { system, output } => solve::run(&system, output.as_deref()),
        Command::Demo { output } => demo::run(&output),
        Command::Mesh(a) => a.run(),
        Command::Edit(a) => a.run(),
        Command::Check { deformation, samples, report } => {
            spline_cmds::check(&deformation, samples, report)
        }
        Command::Render(a) => a.run(),
        Command::Model(ModelCommand::Bind(a)) => (*a).run(),
        Command::Model(ModelCommand::Worm { output }) => model_cmd::worm_cmd(&output),
        Command::Colormesh { image, output, step, flat } => {
            warp_cmd::colormesh(&image, &output, step, flat)
        }
        Command::Warp(a) => a.run(),
        Command::Morph(a) => a.run(),
        Command::Editor(a) => a.run(),
        Command::Field(a) => a.run(),
        Command::Match(m) => match_cmd::run(m),
        Command::Fit(f) => f.run(),
        Command::Register(r) => register_cmd::run(*r),
        Command::Bench { which: BenchCommand::Bitgrowth { output, trials, quick, seed, only } } => {
            bench::bitgrowth(&output, trials, quick, seed, only.as_deref())
        }
    };
    exit_code(result)
}

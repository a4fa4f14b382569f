//! The options of the subcommands (clap), one struct each; `cli::run` hands each to its
//! command module. The subcommand's help text is the doc comment of its `Command` variant.

use super::common::{choice, text};
use super::model_cmd;
use crate::fit::Bend;
use crate::jobs::model::AutoGrid;
use crate::jobs::values::{
    parse_canvas_size, parse_extent, parse_grid, parse_origin, parse_raster_size, parse_sample,
    parse_spacing, parse_time_range,
};
use crate::morph::Schedule;
use crate::prism::ZRange;
use crate::render::deformation::Layers;
use crate::render::model::View;
use crate::warp::{EdgeMode, Interp};
use std::path::PathBuf;

/// The command line of `trimorph mesh`.
#[derive(clap::Args, Debug)]
pub struct MeshCli {
    /// Points (CSV `x,y`) to triangulate (Delaunay).
    #[arg(long)]
    pub points: Option<PathBuf>,
    /// With --points: an outline polygon (CSV `x,y`, in order) for a constrained Delaunay.
    #[arg(long)]
    pub outline: Option<PathBuf>,
    /// A regular grid of COLSxROWS cells (e.g. 6x4), with --size.
    #[arg(long, value_parser = text(parse_grid))]
    pub grid: Option<(usize, usize)>,
    /// The image size W,H in pixels, e.g. 640,480: --grid spans [0, W] x [0, H] (every pixel
    /// centre of a W x H image) and records the W x H frame, the default size of fields;
    /// with --landmarks the frame (whole pixels).
    #[arg(long, value_parser = text(parse_extent))]
    pub size: Option<[f64; 2]>,
    /// A 2D reference mesh in OBJ (`v` and `f` lines).
    #[arg(long)]
    pub obj: Option<PathBuf>,
    /// A mesh adapted to landmarks (CSV, BigWarp or JSON; their sources are vertices),
    /// over the --size frame grown by --margin, refined by Delaunay refinement.
    #[arg(long)]
    pub landmarks: Option<PathBuf>,
    /// With --landmarks: pixels added around the frame (default: a tenth of its larger
    /// side, at least 8).
    #[arg(long)]
    pub margin: Option<f64>,
    /// With --landmarks: longest edge in pixels (default: a quarter of the larger side).
    #[arg(long)]
    pub max_edge: Option<f64>,
    /// With --landmarks: the refinement's smallest angle in degrees (at most 33).
    #[arg(long, default_value_t = crate::mesh::DEFAULT_MIN_ANGLE)]
    pub min_angle: f64,
    /// With --landmarks: far-field rings around the domain, each 4 times the size of the
    /// one inside (0 to 4; `trimorph fit --size` uses 2).
    #[arg(long, default_value_t = 0)]
    pub far_rings: usize,
    /// Spline degree (5 or more for local edits).
    #[arg(long, default_value_t = 5)]
    pub degree: usize,
    /// Vertex coordinates are snapped to multiples of 1/SNAP (default 16; with
    /// --landmarks the smallest of 16, 80, 400, 2000, 10000, 50000 on which every source
    /// is exact).
    #[arg(long)]
    pub snap: Option<i64>,
    /// Make a 2.5D deformation with prisms over [A, B] (e.g. -10,10; exact decimals or
    /// fractions, A < B).
    #[arg(long, allow_hyphen_values = true, value_parser = text(str::parse::<ZRange>))]
    pub z_range: Option<ZRange>,
    /// Output deformation (JSON).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// The command line of `trimorph edit`.
#[derive(clap::Args, Debug)]
pub struct EditCli {
    /// Input deformation.
    pub deformation: PathBuf,
    /// JSON array of operations.
    #[arg(long)]
    pub script: PathBuf,
    /// Output deformation.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Bounded exactness: after each operation round the free points of the minimal
    /// determining set to multiples of 2^-BITS (anchors land within 1e-4; sizes stay
    /// bounded over long histories).
    #[arg(long, default_value_t = 24)]
    pub bounded_bits: u32,
    /// Keep every value exactly as ECLES computes it (anchors exact; sizes grow with the
    /// edit history).
    #[arg(long)]
    pub unbounded: bool,
}

/// The command line of `trimorph render`.
#[derive(clap::Args, Debug)]
pub struct RenderCli {
    /// The deformation.
    pub deformation: PathBuf,
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Background image (PNG, JPEG, TIFF or PNM); mesh coordinates are its pixels.
    #[arg(long)]
    pub background: Option<PathBuf>,
    /// Layers: comma list of mesh, net, constraints, points, reference, all.
    #[arg(long, default_value = "mesh,points", value_parser = text(str::parse::<Layers>))]
    pub show: Layers,
    /// Output size without a background, e.g. 800,600.
    #[arg(long, default_value = "800,600", value_parser = text(parse_canvas_size))]
    pub size: (u32, u32),
    /// A 3D model (OBJ, OFF, PLY, XYZ) to draw through a 2.5D deformation.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// With --model: `top` (the xy projection, mesh and points) or `oblique` (both z
    /// surfaces, the walls and the model, depth-sorted).
    #[arg(long, default_value = "top", value_parser = choice::<View>(&View::NAMES))]
    pub view: View,
    #[command(flatten)]
    pub up: model_cmd::UpArgs,
    #[command(flatten)]
    pub marks: RenderMarks,
}

/// The command line of `trimorph warp`.
#[derive(clap::Args, Debug)]
pub struct WarpCli {
    /// The deformation.
    pub deformation: PathBuf,
    /// Input image (PNG, TIFF, JPEG, PNM), or an OME-Zarr image (.zarr, Zarr v2 or v3: 2D
    /// with optional t and c axes, level 0; every (t, c) plane is warped the same way).
    #[arg(long)]
    pub image: Option<PathBuf>,
    /// Input points (CSV `x,y`).
    #[arg(long)]
    pub points: Option<PathBuf>,
    /// Input colored triangle mesh (OBJ with vertex colours, or PLY).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Input 3D model (OBJ, OFF, PLY or XYZ) to move through the 2.5D deformation psi.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Output image (.png, .tif, .jpg, .pgm, .ppm, .pam; .zarr for an OME-Zarr input: same axes, dtype,
    /// chunks and metadata, level 0 only), CSV, or (for --mesh) .png / .obj / .ply.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Size W,H of the picture drawn from --mesh (default: the undeformed mesh's extent).
    #[arg(long, value_parser = text(parse_raster_size))]
    pub size: Option<(u32, u32)>,
    /// Points: map q -> phi^-1(q) instead of p -> phi(p).
    #[arg(long)]
    pub inverse: bool,
    /// Image resampling.
    #[arg(long, default_value = "bilinear", value_parser = choice::<Interp>(&Interp::NAMES))]
    pub interp: Interp,
    /// Value of pixels whose preimage is outside the mesh, or (with --mode constant)
    /// outside the input image (images: default 0, alpha 0; meshes: a gray level 0..255,
    /// default transparent).
    #[arg(long, value_parser = text(parse_sample))]
    pub background: Option<f64>,
    /// Images: what samples read outside the input image, scikit-image's `mode`: constant
    /// (the --background value, as in ITK, elastix and scikit-image), edge (the edge pixels
    /// repeat, OpenCV's BORDER_REPLICATE) or reflect (mirrored about the edge pixels'
    /// centres, OpenCV's BORDER_REFLECT_101).
    #[arg(long, default_value = "constant", value_parser = text(str::parse::<EdgeMode>))]
    pub mode: EdgeMode,
    /// Largest accepted error of an inverse point (pixels).
    #[arg(long, default_value_t = 0.01)]
    pub tolerance: f64,
    /// Images: also print the time of each phase (decode, inverse map and resampling,
    /// encode) and how many pixels took each path of the inverse map.
    #[arg(long)]
    pub verbose: bool,
    #[command(flatten)]
    pub up: model_cmd::UpArgs,
}

/// The command line of `trimorph morph`.
#[derive(clap::Args, Debug)]
pub struct MorphCli {
    /// Image A (first frame).
    pub a: PathBuf,
    /// Image B (last frame).
    pub b: PathBuf,
    /// Landmark pairs (CSV `name,src_x,src_y,dst_x,dst_y[,weight]`, BigWarp CSV or JSON).
    #[arg(long, required_unless_present_any = ["phi_ab", "landmarks_src"],
          conflicts_with = "phi_ab")]
    pub landmarks: Option<PathBuf>,
    /// Instead of --landmarks: the landmarks in A, one point file (iBUG/menpo .pts,
    /// 1-based; ITK/elastix point set; or CSV `x,y`), paired point by point with
    /// --landmarks-dst.
    #[arg(long, value_name = "FILE", requires = "landmarks_dst",
          conflicts_with_all = ["landmarks", "phi_ab"])]
    pub landmarks_src: Option<PathBuf>,
    /// The landmarks in B (see --landmarks-src): as many as in that file, in the same order.
    #[arg(long, value_name = "FILE", requires = "landmarks_src")]
    pub landmarks_dst: Option<PathBuf>,
    /// Instead of landmarks: a deformation (format v1) mapping A's pixel coordinates to
    /// B's, e.g. the output of `trimorph fit`.
    #[arg(long, value_name = "DEF")]
    pub phi_ab: Option<PathBuf>,
    /// With --phi-ab: the deformation mapping B to A (default: fitted to samples of
    /// --phi-ab).
    #[arg(long, value_name = "DEF", requires = "phi_ab")]
    pub phi_ba: Option<PathBuf>,
    /// With --phi-ab and no --phi-ba: mesh cells per side of the grid mesh over B on
    /// which B->A is fitted (1 to 48). Landmark morphs use landmark-adapted meshes.
    #[arg(long, default_value_t = 8)]
    pub cells: usize,
    /// Keep B's raw pixel coordinates (no similarity alignment of B to A).
    #[arg(long)]
    pub no_align: bool,
    /// Weight of the fits' bending energy, as in `fit --bend`: `auto` (leave-one-out) or a
    /// scale-free number. Default 1e-11: both maps interpolate their landmarks (within 0.1
    /// px, unless that would fold the map; the fold barrier acts as in `fit`).
    #[arg(long, value_parser = text(str::parse::<Bend>))]
    pub bend: Option<Bend>,
    /// The landmarks become hard constraints of both fits (met exactly, through ECLES); a
    /// map that would fold is refused, naming the landmarks.
    #[arg(long, conflicts_with = "phi_ab")]
    pub hard: bool,
    /// Keep A's frame border still in every frame (after B's alignment): points along the
    /// border become landmarks of both fits, so only what the landmarks move moves.
    #[arg(long, conflicts_with = "phi_ab")]
    pub pin_frame: bool,
    /// What a frame shows where neither image has a preimage on its pixels (as `warp
    /// --mode`): constant (the --background, alpha 0), edge (the dissolve of the edge
    /// pixels) or reflect (of the mirrored pixels).
    #[arg(long, default_value = "constant", value_parser = text(str::parse::<EdgeMode>))]
    pub mode: EdgeMode,
    /// Print the time of each phase (read, fits, frames, encodings, writes) to stderr.
    #[arg(long)]
    pub timings: bool,
    /// Background where neither image has a preimage: one value for every channel, in
    /// the images' sample units (0..255 for 8-bit, 0..65535 for 16-bit, 0..1 for float;
    /// alpha is 0 there when the images have alpha).
    #[arg(long, default_value = "0", value_parser = text(parse_sample))]
    pub background: f64,
    /// Number of frames (t = k / (frames - 1)), 2 to 10,000.
    #[arg(long, default_value_t = 30)]
    pub frames: usize,
    /// Times T0,T1 of the first and last frame; outside 0,1 is a caricature
    /// (e.g. `-0.25,1.25`); times lie within -100..100.
    #[arg(long, default_value = "0,1", allow_hyphen_values = true, value_parser = text(parse_time_range))]
    pub range: (f64, f64),
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Animated GIF (default OUTPUT/morph.gif).
    #[arg(long)]
    pub gif: Option<PathBuf>,
    /// Animated PNG (default OUTPUT/morph.apng).
    #[arg(long)]
    pub apng: Option<PathBuf>,
    /// Shape schedule alpha_shape(t) (smooth: 3t^2 - 2t^3).
    #[arg(long, default_value = "linear", value_parser = choice::<Schedule>(&Schedule::NAMES))]
    pub shape: Schedule,
    /// Colour schedule alpha_color(t).
    #[arg(long, default_value = "linear", value_parser = choice::<Schedule>(&Schedule::NAMES))]
    pub color: Schedule,
    /// Image resampling.
    #[arg(long, default_value = "bilinear", value_parser = choice::<Interp>(&Interp::NAMES))]
    pub interp: Interp,
    /// Fast preview: draw A as a colour mesh with a vertex every STEP pixels instead of
    /// warping both images.
    #[arg(long, value_name = "STEP")]
    pub preview: Option<u32>,
    /// Delay between animation frames (milliseconds).
    #[arg(long, default_value_t = 100)]
    pub delay: u32,
    /// No progress bar or summary.
    #[arg(long)]
    pub quiet: bool,
}

/// The command line of `trimorph editor`.
#[derive(clap::Args, Debug)]
pub struct EditorCli {
    /// Deformation or scene to edit (format v1; a scene's "model", "image" and "fixed" keys
    /// are loaded too, and the "landmarks" of a scene or of a `fit` / `register` output come
    /// in as pairs). Default: an identity over --image, or the bundled scene.
    pub deformation: Option<PathBuf>,
    /// 3D model (OBJ, OFF, PLY) bound to the prism layer.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Background image: the microscope frame to match.
    #[arg(long)]
    pub image: Option<PathBuf>,
    /// Two images side by side, BigWarp-style: the moving image (the deformation maps its
    /// pixels onto the fixed image's; shown un-warped on the left). The same as --image.
    #[arg(long, conflicts_with = "image")]
    pub moving: Option<PathBuf>,
    /// The fixed image (right panel, with the warped moving image over it); landmark
    /// pairs are clicked in each panel.
    #[arg(long)]
    pub fixed: Option<PathBuf>,
    /// Port on 127.0.0.1 (0: any free port).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
}

/// The command line of `trimorph field`.
#[derive(clap::Args, Debug)]
pub struct FieldCli {
    /// The deformation.
    pub deformation: PathBuf,
    /// Output field (.tif: RGB float32 dx, dy, valid; .npy: float32 (H, W, 2), NaN
    /// outside; .h5: ITK HDF5 DisplacementFieldTransform_double_2_2 in pixel units, f64,
    /// NaN where undefined, by default phi^-1(q) - q so that ITK's Resample reproduces
    /// `trimorph warp --image`; .zarr: float64 (2, H, W) = (c, y, x), c = 0 the y
    /// displacement, NaN where undefined).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The other direction: .npy/.tif hold phi^-1(q) - q instead of phi(p) - p; .h5 and
    /// .zarr hold phi(p) - p instead of phi^-1(q) - q.
    #[arg(long)]
    pub inverse: bool,
    /// .zarr only: write both fields as an NGFF `bijection` (forward phi(p) - p,
    /// inverse phi^-1(q) - q).
    #[arg(long)]
    pub both: bool,
    /// Also write the Jacobian determinant as a colour map (PNG): blue compression, white
    /// 1, orange expansion, red folds.
    #[arg(long)]
    pub jacobian: Option<PathBuf>,
    /// Grid size W,H in pixels (default: the frame the deformation was made for, else the
    /// mesh's extent from 0).
    #[arg(long, value_parser = text(parse_raster_size))]
    pub size: Option<(u32, u32)>,
    /// .h5 and .zarr only: the physical distance SX,SY between pixel centres (default: the
    /// spacing recorded with the deformation's frame, else 1). Displacements are then
    /// written in physical units, spacing times pixels.
    #[arg(long, value_parser = text(parse_spacing), value_name = "SX,SY")]
    pub spacing: Option<[f64; 2]>,
    /// .h5 and .zarr only: the physical position OX,OY of pixel (0, 0)'s centre (default:
    /// the recorded origin, else 0,0). Negative values: --origin=-5,2.
    #[arg(long, value_parser = text(parse_origin), value_name = "OX,OY", allow_hyphen_values = true)]
    pub origin: Option<[f64; 2]>,
    /// .zarr only: the unit of spacing and origin written on the NGFF space axes (e.g.
    /// micrometer; default: the recorded unit, else none).
    #[arg(long)]
    pub unit: Option<String>,
}

/// The command line of `trimorph model bind`.
#[derive(clap::Args, Debug)]
pub struct BindCli {
    /// The 3D model (OBJ, OFF, PLY or XYZ).
    #[arg(long)]
    pub model: PathBuf,
    /// Reference mesh: a 2D OBJ whose vertices have z = b (prisms over [-b, b]).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Fit a grid around the model's bounding box instead.
    #[arg(long)]
    pub auto: bool,
    /// Grid of the automatic mesh, COLSxROWS (at most 10000 cells).
    #[arg(long, default_value = "4x2", value_parser = text(str::parse::<AutoGrid>))]
    pub grid: AutoGrid,
    /// Margin of the automatic mesh, as a fraction of the model's largest side.
    #[arg(long, default_value_t = 0.05)]
    pub margin: f64,
    /// Prism range A,B (exact decimals or fractions, A < B; default from the mesh or
    /// model).
    #[arg(long, allow_hyphen_values = true, value_parser = text(str::parse::<ZRange>))]
    pub range: Option<ZRange>,
    /// Spline degree.
    #[arg(long, default_value_t = 5)]
    pub degree: usize,
    /// Output deformation file.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub extra: model_cmd::BindExtra,
}

/// Landmark options of `trimorph render`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct RenderMarks {
    /// Landmarks to draw (CSV, BigWarp CSV or JSON, as `fit` reads them): each source as an
    /// orange cross, phi(source) as a green dot, the target as a magenta ring, and a line
    /// from phi(source) to the target (the residual).
    #[arg(long)]
    pub landmarks: Option<std::path::PathBuf>,
}

impl RenderMarks {
    /// `--landmarks` draws on the deformation's picture, not on a model's.
    pub fn refuse_with_model(&self) -> anyhow::Result<()> {
        if let Some(l) = &self.landmarks {
            anyhow::bail!(
                "{}: --landmarks draws on a deformation's picture; omit --model",
                l.display()
            );
        }
        Ok(())
    }
}

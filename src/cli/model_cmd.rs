//! `trimorph model bind | worm` and `trimorph warp DEF --model M -o OUT` (2.5D).

use crate::exact::{parse_rat, rat_to_f64, Rat};
use crate::io::model::{load_model_up, save_landmarks, save_model, save_model_up, UpAxis};
use crate::io::{deformation, read_text, write_atomic};
use crate::mesh::MeshOptions;
use crate::prism::{auto_mesh, auto_mesh_on, bind, deform, identity_layers, organism};
use crate::spline::Spline;
use anyhow::{anyhow, bail, Context, Result};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Options of `trimorph model bind`.
pub struct BindArgs<'a> {
    pub model: &'a Path,
    pub mesh: Option<&'a Path>,
    pub auto: bool,
    pub grid: &'a str,
    pub margin: f64,
    pub range: Option<&'a str>,
    pub degree: usize,
    pub output: &'a Path,
    pub extra: BindExtra,
}

/// `--up x|y|z` of the model commands.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct UpArgs {
    /// The model's up axis, the prisms' height: `x` or `y` turn the model (a cyclic
    /// permutation of its axes) so that axis becomes z, and back on output, so written
    /// models keep the file's axes.
    #[arg(long, default_value = "z", value_parser = parse_up)]
    pub up: UpAxis,
}

fn parse_up(s: &str) -> Result<UpAxis, String> {
    s.parse()
}

/// The options of `trimorph model bind` beside the original ones.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct BindExtra {
    #[command(flatten)]
    pub up: UpArgs,
    /// Vertex coordinates of the reference mesh (and the prism range) on multiples of 1/SNAP
    /// (default 16, as `mesh --snap`); a unit-size model wants a finer grid, e.g. 1024.
    #[arg(long)]
    pub snap: Option<i64>,
}

/// A rational close to `v` on a 1/`grid` grid, rounded outwards (`up`) or inwards.
fn snap_to(v: f64, grid: i64, up: bool) -> Rat {
    let s = v * grid as f64;
    let k = if up { s.ceil() } else { s.floor() };
    Rat::new((k as i64).into(), grid.into())
}

/// [`snap_to`] the default grid, 1/16.
fn snap16(v: f64, up: bool) -> Rat {
    snap_to(v, 16, up)
}

/// `trimorph model bind`: an identity 2.5D deformation around a model.
pub fn bind_cmd(a: BindArgs) -> Result<()> {
    let grid = a.extra.snap.unwrap_or(16);
    if !(1..=1 << 20).contains(&grid) {
        bail!("--snap must be between 1 and 1048576 (grid steps per unit)");
    }
    let model = load_model_up(a.model, a.extra.up.up)
        .with_context(|| format!("cannot load model {}", a.model.display()))?;
    let (mesh, range) = match (a.mesh, a.auto) {
        (Some(t), false) => {
            // A 2D OBJ whose vertices have z = b; the prisms span [-b, b] (thesis 18.2),
            // unless --range says otherwise.
            let text = read_text(t)?;
            let mesh = crate::io::obj::read_mesh(&text, MeshOptions { grid })
                .with_context(|| format!("cannot read the reference mesh {}", t.display()))?;
            let b = text
                .lines()
                .filter_map(|l| l.strip_prefix("v "))
                .filter_map(|l| l.split_whitespace().nth(2).and_then(|z| z.parse::<f64>().ok()))
                .fold(f64::NEG_INFINITY, f64::max);
            let r = if b.is_finite() && b > 0.0 { Some([-b, b]) } else { None };
            (mesh, r)
        }
        (None, true) => {
            let (c, r) = a
                .grid
                .split_once('x')
                .and_then(|(c, r)| {
                    Some((c.trim().parse::<usize>().ok()?, r.trim().parse::<usize>().ok()?))
                })
                .filter(|&(c, r)| c >= 1 && r >= 1 && c.checked_mul(r).is_some_and(|n| n <= 10_000))
                .ok_or_else(|| anyhow!("--grid: expected COLSxROWS, e.g. 4x2"))?;
            if !(a.margin >= 0.0 && a.margin <= 10.0) {
                bail!("--margin is a fraction of the model's size, between 0 and 10");
            }
            let (m, ab) = auto_mesh_on(&model, c, r, a.margin, MeshOptions { grid })
                .with_context(|| format!("{}", a.model.display()))?;
            (m, Some(ab))
        }
        _ => bail!("give exactly one of --mesh T.obj or --auto"),
    };
    let (lo, hi) = match (a.range, range) {
        (Some(r), _) => {
            let (x, y) = r.split_once(',').ok_or_else(|| anyhow!("--range: expected A,B"))?;
            (
                parse_rat(x).map_err(|e| anyhow!("--range: {e}"))?,
                parse_rat(y).map_err(|e| anyhow!("--range: {e}"))?,
            )
        }
        (None, Some([x, y])) => (snap_to(x, grid, false), snap_to(y, grid, true)),
        (None, None) => {
            bail!("the reference mesh has no z = b > 0 on its vertices: give --range A,B")
        }
    };
    let mut s = Spline::identity(mesh, a.degree)?;
    let z = identity_layers(&s, lo, hi)?;
    s.set_z_layers(Some(z));
    let t = Instant::now();
    let b = bind(&model, &s)?;
    let bind_time = t.elapsed();
    // The scene: the deformation plus the model's path (an extra key the format allows),
    // relative to the scene's folder when both share one, so `fit --model SCENE` finds it.
    let mut v = deformation::to_json(&s, None);
    v["model"] = serde_json::Value::from(scene_relative(a.output, a.model));
    a.extra.up.up.record_in(&mut v);
    write_atomic(a.output, crate::io::json_rows(&v).as_bytes())?;
    let z = s.z_layers().expect("set_z_layers(Some(..)) was called above");
    writeln!(
        std::io::stdout(),
        "{} vertices, {} triangles bound to {} prisms over [{}, {}] in {:.1} ms; {} outside\n-> {}",
        model.vertices.len(),
        model.triangles.len(),
        s.mesh().num_triangles(),
        rat_to_f64(&z.range[0]),
        rat_to_f64(&z.range[1]),
        bind_time.as_secs_f64() * 1e3,
        b.outside.len(),
        a.output.display()
    )?;
    if !b.outside.is_empty() {
        warn_outside(&b.outside);
    }
    Ok(())
}

/// `model` as seen from the folder of `scene`: relative when `model` lies under it,
/// absolute otherwise.
fn scene_relative(scene: &Path, model: &Path) -> String {
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let dir = abs(scene.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")));
    let m = abs(model);
    m.strip_prefix(&dir).unwrap_or(&m).to_string_lossy().into_owned()
}

fn warn_outside(outside: &[usize]) {
    let first: Vec<String> = outside.iter().take(5).map(|i| i.to_string()).collect();
    eprintln!(
        "warning: {} model vertices are outside the prisms and stay in place (first: {}); rebuild with `trimorph model bind --auto --margin ...`",
        outside.len(),
        first.join(", ")
    );
}

/// `trimorph warp DEF --model M -o OUT.(obj|ply|xyz)`: the model through psi.
pub fn warp_model(def: &Path, model_path: &Path, output: &Path, up: UpAxis) -> Result<()> {
    let (s, _) = deformation::from_str(&read_text(def)?)
        .with_context(|| format!("cannot read deformation {}", def.display()))?;
    let model = load_model_up(model_path, up)
        .with_context(|| format!("cannot load model {}", model_path.display()))?;
    let t = Instant::now();
    let b = bind(&model, &s)?;
    let t_bind = t.elapsed();
    let t = Instant::now();
    let moved = deform(&model, &b, &s);
    let t_def = t.elapsed();
    save_model_up(&model, &moved, output, up)?;
    writeln!(
        std::io::stdout(),
        "{} vertices through psi (bind {:.1} ms, deform {:.1} ms) -> {}",
        model.vertices.len(),
        t_bind.as_secs_f64() * 1e3,
        t_def.as_secs_f64() * 1e3,
        output.display()
    )?;
    if !b.outside.is_empty() {
        warn_outside(&b.outside);
    }
    Ok(())
}

/// `trimorph model worm -o DIR`: the bundled organism-like model, its landmarks and a
/// reference prism mesh at the scale of thesis Table 19.1 (a 4 x 2 grid: 16 triangles).
pub fn worm_cmd(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let w = organism::worm(&organism::WormOptions::default());
    let obj = dir.join("worm.obj");
    save_model(&w, &w.vertices, &obj)?;
    save_landmarks(&w, &w.vertices, &obj)?;
    let (mesh, [_, b]) = auto_mesh(&w, 4, 2, 0.05)?;
    let b = rat_to_f64(&snap16(b, true));
    let mut t = String::from(
        "# reference prism mesh for worm.obj: vertices at z = b, prisms over [-b, b]\n",
    );
    for v in mesh.vertices() {
        t.push_str(&format!("v {} {} {}\n", v[0], v[1], b));
    }
    for tri in mesh.triangles() {
        t.push_str(&format!("f {} {} {}\n", tri[0] + 1, tri[1] + 1, tri[2] + 1));
    }
    let tpath = dir.join("worm_prisms.obj");
    write_atomic(&tpath, t.as_bytes())?;
    println!(
        "{} vertices, {} triangles, landmarks {} -> {}; reference prisms ({} triangles) -> {}",
        w.vertices.len(),
        w.triangles.len(),
        w.landmarks.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", "),
        obj.display(),
        mesh.num_triangles(),
        tpath.display()
    );
    Ok(())
}

/// `trimorph render DEF --model M --view top|oblique -o OUT.png [--background IMG]`.
pub fn render_model(
    def: &Path,
    model_path: &Path,
    output: &Path,
    background: Option<&Path>,
    view: crate::render::model::View,
    size: &str,
    up: UpAxis,
) -> Result<()> {
    use crate::render::deformation as rd;
    use crate::render::model::{render_model as draw, ModelRenderOptions};
    let (s, _) = deformation::from_str(&read_text(def)?)
        .with_context(|| format!("cannot read deformation {}", def.display()))?;
    let model = load_model_up(model_path, up)
        .with_context(|| format!("cannot load model {}", model_path.display()))?;
    let (w, h) = super::common::parse_canvas_size(size)?;
    let b = bind(&model, &s)?;
    let moved = deform(&model, &b, &s);
    let bg = background.map(rd::load_background).transpose()?;
    let opts = ModelRenderOptions { width: w, height: h, view, ..Default::default() };
    let pm = draw(&s, &model, &moved, bg.as_ref(), &opts)?;
    rd::save_png(&pm, output)?;
    writeln!(std::io::stdout(), "{}x{} -> {}", pm.width(), pm.height(), output.display())?;
    if !b.outside.is_empty() {
        warn_outside(&b.outside);
    }
    Ok(())
}

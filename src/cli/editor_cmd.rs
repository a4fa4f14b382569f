//! `trimorph editor [DEF.json] [--model M.obj] [--image FRAME] [--port 8080]`: the local web
//! editor ([`crate::server`]).

use crate::bundled::scene as bundled_scene;
use crate::io::{deformation, read_text};
use crate::mesh::{Mesh, MeshOptions};
use crate::prism::identity_layers;
use crate::server::doc::Doc;
use crate::server::Server;
use crate::spline::Spline;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Options of `trimorph editor`.
pub struct EditorArgs<'a> {
    pub deformation: Option<&'a Path>,
    pub model: Option<&'a Path>,
    pub image: Option<&'a Path>,
    pub port: u16,
}

/// A path from a file's key, relative to that file's folder.
fn beside(file: &Path, rel: &str) -> PathBuf {
    let p = PathBuf::from(rel);
    if p.is_absolute() {
        p
    } else {
        file.parent().unwrap_or(Path::new(".")).join(p)
    }
}

/// The document the editor starts with (see the CLI help).
pub fn initial_doc(a: &EditorArgs<'_>, root: &Path) -> Result<Doc> {
    let mut model_path = a.model.map(Path::to_path_buf);
    let mut image_path = a.image.map(Path::to_path_buf);
    let mut pinned = Vec::new();
    let mut pairs = None;
    let mut up = crate::io::model::UpAxis::Z;
    let spline = match a.deformation {
        Some(d) => {
            let text = read_text(d)?;
            let (s, _) = deformation::from_str(&text)
                .with_context(|| format!("cannot read deformation {}", d.display()))?;
            pinned = deformation::pinned_from_str(&text)
                .with_context(|| format!("cannot read deformation {}", d.display()))?;
            let v: serde_json::Value = serde_json::from_str(&text)?;
            let key = |k: &str| v.get(k).and_then(|x| x.as_str()).map(|r| beside(d, r));
            if model_path.is_none() {
                model_path = key("model");
                up = crate::io::model::UpAxis::of_scene(&v)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", d.display()))?;
            }
            image_path = image_path.or_else(|| key("image"));
            pairs = crate::server::doc::pairs::pairs_from_scene(&v, &d.display().to_string())?;
            s
        }
        None if model_path.is_none() && image_path.is_none() => {
            let (s, model, frame) = bundled_scene()?;
            let mut doc = Doc::new(s, root);
            doc.set_model(PathBuf::from("bundled:worm.obj"), model)?;
            doc.set_frame(PathBuf::from("bundled:frame_00.png"), frame)?;
            doc.set_name(Some("bundled worm scene".into()));
            return Ok(doc);
        }
        None => {
            // An identity over the image (8 x 8 cells), 2.5D when a model is given.
            let (w, h) = match &image_path {
                Some(p) => {
                    let img = crate::io::raster::read_image(p)
                        .with_context(|| format!("cannot read image {}", p.display()))?;
                    (f64::from(img.width().max(2) - 1), f64::from(img.height().max(2) - 1))
                }
                None => (512.0, 512.0),
            };
            let mesh = Mesh::grid(8, 8, w, h, MeshOptions::default())?;
            let mut s = Spline::identity(mesh, 5)?;
            if let Some(p) = &model_path {
                let m = crate::io::model::load_model(p)
                    .with_context(|| format!("cannot load model {}", p.display()))?;
                let (lo, hi) = m.bbox();
                let b = (lo[2].abs().max(hi[2].abs()) * 1.25).ceil().max(1.0) as i64;
                let z = identity_layers(&s, crate::exact::rat_int(-b), crate::exact::rat_int(b))?;
                s.set_z_layers(Some(z));
            }
            s
        }
    };
    let mut doc = Doc::new(spline, root);
    doc.set_name(a.deformation.map(|d| d.display().to_string()));
    doc.add_pinned(&pinned);
    if let Some(p) = pairs {
        doc.set_pairs(p)?;
    }
    if let Some(p) = model_path {
        let m = crate::io::model::load_model_up(&p, up)
            .with_context(|| format!("cannot load model {}", p.display()))?;
        doc.set_model_up(p, m, up)?;
    }
    if let Some(p) = image_path {
        let img = crate::io::raster::read_image(&p)
            .with_context(|| format!("cannot read image {}", p.display()))?;
        doc.set_frame(p, img)?;
    }
    Ok(doc)
}

/// Runs the editor until the process is stopped (Ctrl-C).
pub fn run(a: EditorArgs<'_>) -> Result<()> {
    let root = std::env::current_dir()?;
    let mut doc = initial_doc(&a, &root)?;
    let server = Server::bind(a.port)?;
    // Printing must not fail the server: whoever started it may close our stdout once it
    // has read the address (tests/cli_editor.rs does).
    use std::io::Write;
    let mut out = std::io::stdout();
    let _ = writeln!(out, "trimorph editor at {} (files: {})", server.url(), root.display());
    let _ = writeln!(
        out,
        "Open that address (the token in it is this session's key; keep it private). \
         Ctrl-C stops the editor; save first (Ctrl+S in the page)."
    );
    let _ = out.flush();
    server.run(&mut doc, &|| false);
    Ok(())
}

//! Using trimorph from Rust (the README's example): a mesh over an image, an edit script,
//! a fit to landmarks, and the image warped through the result.
//!
//! Run with `cargo run --example library`; it writes `library_warped.png` into the system's
//! temporary folder.

use trimorph::edit::script::Script;
use trimorph::edit::Editor;
use trimorph::fit::landmarks::Landmark;
use trimorph::fit::{fit, FitOptions};
use trimorph::mesh::{Mesh, MeshOptions};
use trimorph::spline::Spline;
use trimorph::warp::inverse::InverseOptions;
use trimorph::warp::{warp_image, Interp};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The image: the bundled microscope picture (any `image::DynamicImage` will do).
    let img = image::load_from_memory(trimorph::bundled::CELL_PNG)?;
    let (w, h) = (img.width(), img.height());

    // An identity deformation of degree 5 over a 6 x 6 grid of the image.
    let mesh = Mesh::grid(6, 6, f64::from(w), f64::from(h), MeshOptions::default())?;
    let identity = Spline::identity(mesh, 5)?;

    // An edit script, as JSON text (the format of `trimorph edit`).
    let script = Script::from_json_str(
        r#"[
            {"anchors": {"near": [[275, 330]]}, "neighborhood": 3, "op": "translate", "by": [-20, 15]},
            {"op": "constrain", "pin": [0]}
        ]"#,
    )?;
    let mut ed = Editor::new(identity);
    let done = script.run(&mut ed)?;
    println!("{} operations: {:?}", done.len(), done);
    let edited = ed.into_spline();
    edited.check_c1()?;

    // A fit to four landmarks, starting from the edited deformation.
    let lm = |src: [f64; 2], dst: [f64; 2]| Landmark { name: None, src, dst, weight: 1.0 };
    let landmarks = [
        lm([100.0, 100.0], [104.0, 98.0]),
        lm([450.0, 110.0], [446.0, 112.0]),
        lm([120.0, 560.0], [118.0, 566.0]),
        lm([430.0, 540.0], [436.0, 536.0]),
    ];
    let fitted = fit(&edited, &landmarks, &FitOptions::default())?;
    println!("fit: rms {:.3} px", fitted.report.fit.rms);
    fitted.spline.check_c1()?;

    // The image warped through phi: O(q) = I(phi^-1(q)) (bilinear, black outside the mesh).
    let (warped, report) =
        warp_image(&fitted.spline, &img, Interp::Bilinear, 0.0, InverseOptions::default())?;
    println!("warp: {} of {} pixels outside the deformed mesh", report.outside, report.pixels);
    let out = std::env::temp_dir().join("library_warped.png");
    warped.save(&out)?;
    println!("-> {}", out.display());
    Ok(())
}

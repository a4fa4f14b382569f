//! The cases of `tests/bad_inputs.rs`: how each bad input of `docs/errors.md` is made and
//! which command reads it.

use super::common::{ok, s, trimorph};
use super::files::{cmyk_tiff, png_header, tiff_header};
use std::fs;
use std::path::{Path, PathBuf};

/// Valid files the bad inputs are derived from, in a temporary folder.
pub struct Fixture {
    /// The folder.
    pub dir: PathBuf,
    /// An identity deformation over a 2 x 2 grid of 40 x 40 pixels.
    pub def: PathBuf,
    /// Its text.
    pub def_text: String,
    /// A 40 x 40 gray PNG.
    pub image: PathBuf,
}

impl Fixture {
    /// Writes the valid files into `dir`.
    pub fn new(dir: &Path) -> Fixture {
        let def = dir.join("ok.json");
        ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", s(&def)]));
        let image = dir.join("ok.png");
        image::GrayImage::from_fn(40, 40, |x, y| image::Luma([(x * 5 + y * 3) as u8]))
            .save(&image)
            .unwrap();
        let def_text = fs::read_to_string(&def).unwrap();
        Fixture { dir: dir.to_path_buf(), def, def_text, image }
    }

    /// Writes `bytes` to `name` in the folder.
    pub fn file(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.dir.join(name);
        fs::write(&p, bytes).unwrap();
        p
    }

    /// The valid deformation with `f` applied to its JSON document.
    pub fn def_with(&self, name: &str, f: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
        let mut v: serde_json::Value = serde_json::from_str(&self.def_text).unwrap();
        f(&mut v);
        self.file(name, v.to_string())
    }

    /// An output path in the folder.
    pub fn out(&self, name: &str) -> String {
        s(&self.dir.join(name)).to_string()
    }
}

/// One bad input: `setup` writes it and returns the command line and the bad file.
pub struct Case {
    /// The row id in `docs/errors.md`.
    pub id: &'static str,
    /// Writes the input; returns the arguments and the file that the message must name.
    pub setup: fn(&Fixture, &str) -> (Vec<String>, PathBuf),
}

pub(super) fn args(a: &[&str]) -> Vec<String> {
    a.iter().map(|x| x.to_string()).collect()
}

/// `trimorph check FILE` on a deformation file with `text`.
fn check_text(fx: &Fixture, id: &str, text: &str) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.json"), text);
    (args(&["check", s(&p)]), p)
}

/// `trimorph check FILE` on the valid deformation changed by `f`.
pub(super) fn check_doc(
    fx: &Fixture,
    id: &str,
    f: impl FnOnce(&mut serde_json::Value),
) -> (Vec<String>, PathBuf) {
    let p = fx.def_with(&format!("{id}.json"), f);
    (args(&["check", s(&p)]), p)
}

/// `trimorph mesh --points FILE` with `text`.
fn mesh_points(fx: &Fixture, id: &str, text: &str) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.csv"), text);
    (args(&["mesh", "--points", s(&p), "-o", &fx.out("m.json")]), p)
}

/// `trimorph mesh --obj FILE` with `text`.
fn mesh_obj(fx: &Fixture, id: &str, text: &str) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.obj"), text);
    (args(&["mesh", "--obj", s(&p), "-o", &fx.out("m.json")]), p)
}

/// `trimorph model bind --model FILE --auto` with `bytes`.
pub(super) fn model(fx: &Fixture, id: &str, ext: &str, bytes: &[u8]) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.{ext}"), bytes);
    (args(&["model", "bind", "--model", s(&p), "--auto", "-o", &fx.out("b.json")]), p)
}

/// `trimorph fit OK --landmarks FILE` with `text` (and `extra` options).
pub(super) fn fit(
    fx: &Fixture,
    id: &str,
    ext: &str,
    text: &str,
    extra: &[&str],
) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.{ext}"), text);
    let mut a = args(&["fit", s(&fx.def), "--landmarks", s(&p), "-o", &fx.out("f.json")]);
    a.extend(args(extra));
    (a, p)
}

/// `trimorph fit --size 40,40 --landmarks FILE -o f.json` (no deformation) with `text`.
fn fit_size(fx: &Fixture, id: &str, text: &str) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.csv"), text);
    (args(&["fit", "--size", "40,40", "--landmarks", s(&p), "-o", &fx.out("f.json")]), p)
}

/// `trimorph fit --size 40,40 --landmarks-src FILE --landmarks-dst B -o f.json`, FILE a point
/// file with `text`, B a valid ITK point set of three points.
fn fit_pair(fx: &Fixture, id: &str, ext: &str, text: &str) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.{ext}"), text);
    let b = fx.file("pair_dst.txt", "point\n3\n10 10\n20 30\n30 5\n");
    let a = ["fit", "--size", "40,40", "--landmarks-src", s(&p), "--landmarks-dst", s(&b)];
    (args(&[&a[..], &["-o", &fx.out("f.json")]].concat()), p)
}

/// `trimorph warp OK --image FILE -o out.png` with `bytes`.
pub(super) fn warp_image(
    fx: &Fixture,
    id: &str,
    ext: &str,
    bytes: &[u8],
) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.{ext}"), bytes);
    (args(&["warp", s(&fx.def), "--image", s(&p), "-o", &fx.out("w.png")]), p)
}

/// The bundled microscope image (550 x 660, textured enough for ORB).
fn cell_image() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/microscopy/cell.png")
}

/// `trimorph edit OK --script FILE` with `text`.
fn edit(fx: &Fixture, id: &str, text: &str) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.json"), text);
    (args(&["edit", s(&fx.def), "--script", s(&p), "-o", &fx.out("e.json")]), p)
}

/// `trimorph solve FILE` with `text`.
fn solve(fx: &Fixture, id: &str, text: &str) -> (Vec<String>, PathBuf) {
    let p = fx.file(&format!("{id}.json"), text);
    (args(&["solve", s(&p)]), p)
}

pub(super) const LM_HEAD: &str = "name,src_x,src_y,dst_x,dst_y\n";

/// Every case, in the order of the table.
pub fn cases() -> Vec<Case> {
    let mut all = earlier_cases();
    all.extend(super::cases_54::cases());
    all
}

fn earlier_cases() -> Vec<Case> {
    vec![
        // Deformation files.
        Case { id: "def_empty", setup: |fx, id| check_text(fx, id, "") },
        Case {
            id: "def_truncated",
            setup: |fx, id| check_text(fx, id, &fx.def_text[..fx.def_text.len() / 2]),
        },
        Case {
            id: "def_malformed",
            setup: |fx, id| check_text(fx, id, "{\"format\": \"trimorph.deformation\",, }"),
        },
        Case { id: "def_not_deformation", setup: |fx, id| check_text(fx, id, "[1, 2, 3]") },
        Case {
            id: "def_wrong_type",
            setup: |fx, id| check_doc(fx, id, |v| v["degree"] = "five".into()),
        },
        Case { id: "def_version", setup: |fx, id| check_doc(fx, id, |v| v["version"] = 7.into()) },
        Case {
            id: "def_duplicate_key",
            setup: |fx, id| {
                let t = fx.def_text.replacen('{', "{\"degree\": 5, ", 1);
                check_text(fx, id, &t)
            },
        },
        Case { id: "def_grid", setup: |fx, id| check_doc(fx, id, |v| v["grid"] = 0.into()) },
        Case {
            id: "def_nan",
            setup: |fx, id| check_doc(fx, id, |v| v["exact"]["points"][3][0] = "NaN".into()),
        },
        Case {
            id: "def_huge",
            setup: |fx, id| check_doc(fx, id, |v| v["exact"]["vertices"][0][0] = "1e300".into()),
        },
        Case {
            id: "def_patch_index",
            setup: |fx, id| check_doc(fx, id, |v| v["patches"][0][0] = 99999.into()),
        },
        Case {
            id: "def_huge_degree",
            setup: |fx, id| check_doc(fx, id, |v| v["degree"] = 1_000_000_000u64.into()),
        },
        Case {
            id: "def_not_c1",
            setup: |fx, id| {
                let p = fx.def_with(&format!("{id}.json"), |v| {
                    let n = v["exact"]["points"].as_array().unwrap().len();
                    v["exact"]["points"][n / 2][0] = "1/3".into();
                });
                (args(&["render", s(&p), "-o", &fx.out("r.png")]), p)
            },
        },
        // Points and meshes.
        Case { id: "points_empty", setup: |fx, id| mesh_points(fx, id, "") },
        Case { id: "points_nan", setup: |fx, id| mesh_points(fx, id, "x,y\n0,0\n10,nan\n0,10\n") },
        Case { id: "points_inf", setup: |fx, id| mesh_points(fx, id, "0,0\n10,0\n0,inf\n") },
        Case {
            id: "points_first_row_typo",
            setup: |fx, id| mesh_points(fx, id, "0,0x\n10,0\n0,10\n"),
        },
        Case { id: "points_off_grid", setup: |fx, id| mesh_points(fx, id, "0,0\n10,0\n0,1e12\n") },
        Case {
            id: "points_duplicate",
            setup: |fx, id| mesh_points(fx, id, "0,0\n10,0\n0,10\n10,0.001\n"),
        },
        Case {
            id: "points_collinear",
            setup: |fx, id| mesh_points(fx, id, "0,0\n1,1\n2,2\n3,3\n"),
        },
        Case {
            id: "obj_malformed",
            setup: |fx, id| mesh_obj(fx, id, "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n"),
        },
        Case {
            id: "obj_index",
            setup: |fx, id| mesh_obj(fx, id, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
        },
        Case {
            id: "obj_degenerate",
            setup: |fx, id| {
                mesh_obj(fx, id, "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n")
            },
        },
        Case {
            id: "obj_clockwise",
            setup: |fx, id| mesh_obj(fx, id, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 3 2\n"),
        },
        Case {
            id: "obj_non_manifold",
            setup: |fx, id| {
                mesh_obj(
                    fx,
                    id,
                    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 1 1 0\nf 1 2 3\nf 1 4 2\nf 1 2 5\n",
                )
            },
        },
        Case { id: "obj_empty", setup: |fx, id| mesh_obj(fx, id, "") },
        // 3D models.
        Case {
            id: "model_obj_line",
            setup: |fx, id| model(fx, id, "obj", b"v 0 0 0\nv 1 0\nv 0 1 0\n"),
        },
        Case {
            id: "model_obj_index",
            setup: |fx, id| model(fx, id, "obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -7\n"),
        },
        Case { id: "model_empty", setup: |fx, id| model(fx, id, "obj", b"# nothing\n") },
        Case {
            id: "model_up_auto_cube",
            setup: |fx, id| {
                let (mut a, p) = model(
                    fx,
                    id,
                    "obj",
                    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\nf 1 2 3\nf 1 2 4\n",
                );
                a.extend(args(&["--up", "auto"]));
                (a, p)
            },
        },
        Case {
            id: "model_off_index",
            setup: |fx, id| model(fx, id, "off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
        },
        Case {
            id: "model_off_truncated",
            setup: |fx, id| model(fx, id, "off", b"OFF\n# a triangle\n3 1 0\n0 0 0\n1 0 0\n"),
        },
        Case {
            id: "model_ply_truncated",
            setup: |fx, id| {
                model(
                    fx,
                    id,
                    "ply",
                    b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                      property float y\nproperty float z\nend_header\n\0\0\0\0\0\0",
                )
            },
        },
        Case {
            id: "model_ply_huge_count",
            setup: |fx, id| {
                model(
                    fx,
                    id,
                    "ply",
                    b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n\
                      property float x\nproperty float y\nproperty float z\nend_header\n",
                )
            },
        },
        Case {
            id: "model_ply_header",
            setup: |fx, id| model(fx, id, "ply", b"ply\nformat ascii 1.0\nelement vertex 1\n"),
        },
        Case {
            id: "model_ply_nan",
            setup: |fx, id| {
                model(
                    fx,
                    id,
                    "ply",
                    b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n\
                      property float y\nproperty float z\nend_header\n0 0 0\n1 nan 0\n",
                )
            },
        },
        // Landmarks.
        Case {
            id: "fit_too_large",
            setup: |fx, id| {
                let def = fx.dir.join(format!("{id}.json"));
                ok(&trimorph(&["mesh", "--grid", "64x64", "--size", "640,640", "-o", s(&def)]));
                let lms = fx.file("too_large.csv", format!("{LM_HEAD}a,50,50,52,52\n"));
                (args(&["fit", s(&def), "--landmarks", s(&lms), "-o", &fx.out("f.json")]), def)
            },
        },
        Case {
            id: "fit_size_one_landmark",
            setup: |fx, id| fit_size(fx, id, &format!("{LM_HEAD}a,10,10,12,11\n")),
        },
        Case {
            id: "fit_size_collinear",
            setup: |fx, id| {
                fit_size(fx, id, &format!("{LM_HEAD}a,5,5,6,6\nb,10,10,11,11\nc,20,20,21,21\n"))
            },
        },
        Case {
            id: "fit_size_outside",
            setup: |fx, id| {
                fit_size(fx, id, &format!("{LM_HEAD}a,5,5,6,6\nb,90,5,91,5\nc,20,30,21,31\n"))
            },
        },
        Case { id: "lm_empty", setup: |fx, id| fit(fx, id, "csv", "", &[]) },
        Case {
            id: "lm_short_row",
            setup: |fx, id| fit(fx, id, "csv", &format!("{LM_HEAD}a,1,2,3,4\nb,5,6\n"), &[]),
        },
        Case {
            id: "lm_nan",
            setup: |fx, id| fit(fx, id, "csv", &format!("{LM_HEAD}a,1,2,3,4\nb,5,6,nan,8\n"), &[]),
        },
        Case {
            id: "lm_inf",
            setup: |fx, id| fit(fx, id, "csv", &format!("{LM_HEAD}a,1,2,3,4\nb,5,6,inf,8\n"), &[]),
        },
        Case {
            id: "lm_huge",
            setup: |fx, id| {
                fit(fx, id, "csv", &format!("{LM_HEAD}a,10,10,11,11\nb,20,20,1e300,21\n"), &[])
            },
        },
        Case {
            id: "lm_pts_row",
            setup: |fx, id| fit_pair(fx, id, "pts", "n_points: 2\n{\n1 2\n3\n}\n"),
        },
        Case {
            id: "lm_itk_truncated",
            setup: |fx, id| fit_pair(fx, id, "txt", "point\n3\n1 2\n3 4\n"),
        },
        Case {
            id: "lm_pair_counts",
            setup: |fx, id| fit_pair(fx, id, "pts", "n_points: 2\n{\n11 11\n21 31\n}\n"),
        },
        Case {
            id: "lm_duplicate",
            setup: |fx, id| {
                fit(fx, id, "csv", &format!("{LM_HEAD}a,1,2,3,4\nb,5,6,7,8\na,9,9,9,9\n"), &[])
            },
        },
        Case {
            id: "lm_outside",
            setup: |fx, id| {
                fit(fx, id, "csv", &format!("{LM_HEAD}a,10,10,11,11\nfar,90,10,91,11\n"), &[])
            },
        },
        Case {
            id: "lm_contradictory",
            setup: |fx, id| {
                fit(fx, id, "csv", &format!("{LM_HEAD}a,20,20,25,20\nb,20,20,15,20\n"), &["--hard"])
            },
        },
        Case {
            id: "lm_bigwarp",
            setup: |fx, id| fit(fx, id, "csv", "\"Pt-0\",\"true\",\"1\",\"2\",\"x\",\"4\"\n", &[]),
        },
        Case {
            id: "lm_json",
            setup: |fx, id| fit(fx, id, "json", "{\"landmarks\": [{\"name\": \"a\",", &[]),
        },
        Case {
            id: "lm_json_type",
            setup: |fx, id| {
                let text = r#"{"landmarks": [{"name": "a", "src": "here", "dst": [1, 2]}]}"#;
                fit(fx, id, "json", text, &[])
            },
        },
        Case {
            id: "render_landmarks_bad",
            setup: |fx, id| {
                let p = fx.file(&format!("{id}.csv"), format!("{LM_HEAD}a,10,10,x,12\n"));
                let out = fx.out("r.png");
                (args(&["render", s(&fx.def), "-o", &out, "--landmarks", s(&p)]), p)
            },
        },
        Case {
            id: "render_landmarks_model",
            setup: |fx, id| {
                let p = fx.file(&format!("{id}.csv"), format!("{LM_HEAD}a,10,10,12,12\n"));
                let model = fx.file("render_model.obj", "v 1 1 1\nv 5 1 1\nv 1 5 1\nf 1 2 3\n");
                let mut a = args(&["render", s(&fx.def), "-o", &fx.out("r.png")]);
                a.extend(args(&["--model", s(&model), "--landmarks", s(&p)]));
                (a, p)
            },
        },
        // Images.
        Case { id: "img_empty", setup: |fx, id| warp_image(fx, id, "png", b"") },
        Case {
            id: "img_truncated",
            setup: |fx, id| {
                let b = fs::read(&fx.image).unwrap();
                warp_image(fx, id, "png", &b[..b.len() / 2])
            },
        },
        Case {
            id: "img_truncated_pnm",
            setup: |fx, id| {
                let mut b = b"P5\n40 40\n255\n".to_vec();
                b.extend(std::iter::repeat_n(9u8, 40 * 20));
                warp_image(fx, id, "pgm", &b)
            },
        },
        Case {
            id: "img_pgm_color",
            setup: |fx, id| {
                let p = fx.dir.join(format!("{id}.png"));
                image::RgbImage::from_pixel(40, 40, image::Rgb([1, 2, 3])).save(&p).unwrap();
                let out = fx.dir.join(format!("{id}.pgm"));
                (args(&["warp", s(&fx.def), "--image", s(&p), "-o", s(&out)]), out)
            },
        },
        Case { id: "img_zero", setup: |fx, id| warp_image(fx, id, "png", &png_header(0, 0)) },
        Case {
            id: "img_one_pixel",
            setup: |fx, id| {
                let p = fx.dir.join(format!("{id}.png"));
                image::GrayImage::from_pixel(1, 1, image::Luma([7])).save(&p).unwrap();
                (args(&["colormesh", s(&p), "-o", &fx.out("c.ply")]), p)
            },
        },
        Case {
            id: "img_huge_png",
            setup: |fx, id| warp_image(fx, id, "png", &png_header(100_000, 100_000)),
        },
        Case {
            id: "img_huge_tiff",
            setup: |fx, id| warp_image(fx, id, "tif", &tiff_header(100_000, 100_000, 1, 1)),
        },
        Case { id: "img_channels", setup: |fx, id| warp_image(fx, id, "tif", &cmyk_tiff()) },
        Case {
            id: "img_huge_background",
            setup: |fx, id| {
                let p = fx.file(&format!("{id}.png"), png_header(100_000, 100_000));
                (args(&["render", s(&fx.def), "--background", s(&p), "-o", &fx.out("r.png")]), p)
            },
        },
        Case {
            id: "img_huge_frame",
            setup: |fx, id| {
                let frames = fx.dir.join(format!("{id}_frames"));
                fs::create_dir_all(&frames).unwrap();
                let p = frames.join("f0.png");
                fs::write(&p, png_header(100_000, 100_000)).unwrap();
                let lms = fx.file(&format!("{id}.csv"), format!("{LM_HEAD}a,10,10,10,10\n"));
                let mut a = args(&["fit", "--model", s(&fx.def), "--frames", s(&frames)]);
                a.extend(args(&["--landmarks", s(&lms), "-o", &fx.out("batch")]));
                (a, p)
            },
        },
        Case {
            id: "frames_lost",
            setup: |fx, id| {
                let frames = fx.dir.join(format!("{id}_frames"));
                fs::create_dir_all(&frames).unwrap();
                for name in ["a.png", "b.png"] {
                    image::GrayImage::from_pixel(1, 1, image::Luma([9]))
                        .save(frames.join(name))
                        .unwrap();
                }
                let lms = fx.file(&format!("{id}.csv"), format!("{LM_HEAD}m,0.5,0.5,0.5,0.5\n"));
                let mut a = args(&["fit", "--model", s(&fx.def), "--frames", s(&frames)]);
                a.extend(args(&["--landmarks", s(&lms), "--track", "-o", &fx.out("lost")]));
                (a, frames.join("b.png"))
            },
        },
        Case { id: "img_not_image", setup: |fx, id| warp_image(fx, id, "png", b"hello") },
        Case {
            id: "img_memory_budget",
            setup: |fx, id| {
                let big = image::ImageBuffer::from_pixel(512, 512, image::Rgba([1u16, 2, 3, 4]));
                let p = fx.dir.join(format!("{id}.png"));
                image::DynamicImage::ImageRgba16(big).save(&p).unwrap();
                let out = fx.out("w.png");
                (args(&["warp", s(&fx.def), "--image", s(&p), "-o", &out, "--max-memory", "1M"]), p)
            },
        },
        Case {
            id: "img_truncated_jpeg",
            setup: |fx, id| {
                // Noise, so that most of the file is scan data, cut inside the scan.
                let img = image::RgbImage::from_fn(128, 128, |x, y| {
                    image::Rgb([(x * 7919 + y * 104729) as u8, (x * y) as u8, (x ^ y) as u8])
                });
                let mut b = Vec::new();
                image::codecs::jpeg::JpegEncoder::new(&mut b).encode_image(&img).unwrap();
                warp_image(fx, id, "jpg", &b[..b.len() * 9 / 10])
            },
        },
        Case {
            id: "img_truncated_tiff",
            setup: |fx, id| {
                // Directory first, then the strip (as microscopy writers lay files out); the
                // file ends before the strip does.
                let mut t = tiff_header(40, 40, 1, 1);
                t.extend(std::iter::repeat_n(7u8, 800));
                warp_image(fx, id, "tif", &t)
            },
        },
        Case {
            id: "mesh_outside_image",
            setup: |fx, id| {
                let pts = fx.file(&format!("{id}.csv"), "1000,1000\n1040,1000\n1000,1040\n");
                let p = fx.dir.join(format!("{id}.json"));
                ok(&trimorph(&["mesh", "--points", s(&pts), "-o", s(&p)]));
                (args(&["warp", s(&p), "--image", s(&fx.image), "-o", &fx.out("w.png")]), p)
            },
        },
        // Edit scripts.
        Case { id: "edit_malformed", setup: |fx, id| edit(fx, id, "[{\"op\": \"translate\",") },
        Case { id: "edit_not_array", setup: |fx, id| edit(fx, id, "{\"op\": \"translate\"}") },
        Case {
            id: "edit_unknown_op",
            setup: |fx, id| edit(fx, id, r#"[{"op": "shear", "anchors": [0]}]"#),
        },
        Case {
            id: "edit_empty_anchors",
            setup: |fx, id| edit(fx, id, r#"[{"op": "translate", "anchors": [], "by": [1, 0]}]"#),
        },
        Case {
            id: "edit_anchor_range",
            setup: |fx, id| {
                edit(fx, id, r#"[{"op": "translate", "anchors": [100000], "by": [1, 0]}]"#)
            },
        },
        Case {
            id: "edit_anchor_derived",
            setup: |fx, id| {
                edit(
                    fx,
                    id,
                    r#"[{"op": "translate", "anchors": [3], "derived": [3], "by": [1, 0]}]"#,
                )
            },
        },
        Case {
            id: "edit_by_nan",
            setup: |fx, id| {
                edit(fx, id, r#"[{"op": "translate", "anchors": [3], "by": ["NaN", 0]}]"#)
            },
        },
        Case {
            id: "edit_unsolvable",
            setup: |fx, id| {
                let text = r#"[{"op": "constrain", "pin": [3]},
                    {"op": "translate", "anchors": [3], "by": [1, 0]}]"#;
                edit(fx, id, text)
            },
        },
        // `trimorph solve` problems.
        Case { id: "solve_malformed", setup: |fx, id| solve(fx, id, "{\"R\": [[1, -1]") },
        Case {
            id: "solve_wrong_type",
            setup: |fx, id| {
                solve(fx, id, r#"{"R": [[1, -1]], "P": [[0], [1]], "anchors": {"0": ["x"]}}"#)
            },
        },
        Case {
            id: "solve_unsolvable",
            setup: |fx, id| {
                let text = fs::read_to_string(
                    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/unsolvable.json"),
                )
                .unwrap();
                solve(fx, id, &text)
            },
        },
        // `trimorph match` and `trimorph field`.
        Case {
            id: "match_small",
            setup: |fx, _| {
                let cell = cell_image();
                (args(&["match", s(&fx.image), s(&cell), "-o", &fx.out("m.csv")]), fx.image.clone())
            },
        },
        Case {
            id: "match_flat",
            setup: |fx, id| {
                let cell = cell_image();
                let flat = fx.dir.join(format!("{id}.png"));
                image::GrayImage::from_pixel(96, 96, image::Luma([128])).save(&flat).unwrap();
                (args(&["match", s(&cell), s(&flat), "-o", &fx.out("m.csv")]), flat)
            },
        },
        Case {
            id: "field_output_ext",
            setup: |fx, id| {
                let out = fx.dir.join(format!("{id}.png"));
                (args(&["field", s(&fx.def), "-o", s(&out)]), out)
            },
        },
        Case {
            id: "field_jacobian_ext",
            setup: |fx, id| {
                let jac = fx.dir.join(format!("{id}.tif"));
                (args(&["field", s(&fx.def), "-o", &fx.out("f.npy"), "--jacobian", s(&jac)]), jac)
            },
        },
        Case {
            id: "field_size",
            setup: |fx, _| {
                let a = args(&["field", s(&fx.def), "-o", &fx.out("f.npy"), "--size", "0,0"]);
                (a, fx.def.clone())
            },
        },
        // `trimorph morph` and `trimorph editor`.
        Case {
            id: "morph_landmark_outside",
            setup: |fx, id| {
                let lms = fx.file(
                    &format!("{id}.csv"),
                    format!("{LM_HEAD}a,5,5,5,5\nb,30,5,90,5\nc,5,30,5,30\n"),
                );
                let img = s(&fx.image);
                (args(&["morph", img, img, "--landmarks", s(&lms), "-o", &fx.out("m")]), lms)
            },
        },
        Case {
            id: "morph_phi_ab_bad",
            setup: |fx, id| {
                let bad = fx.file(&format!("{id}.json"), "[1, 2]");
                let img = s(&fx.image);
                (args(&["morph", img, img, "--phi-ab", s(&bad), "-o", &fx.out("m")]), bad)
            },
        },
        Case {
            id: "editor_bad_deformation",
            setup: |fx, id| {
                let bad = fx.file(&format!("{id}.json"), "{\"format\": \"trimorph-deformation\"");
                (args(&["editor", s(&bad), "--port", "0"]), bad)
            },
        },
        Case {
            id: "frames_same_name",
            setup: |fx, id| {
                let frames = fx.dir.join(format!("{id}_frames"));
                fs::create_dir_all(&frames).unwrap();
                for name in ["a.png", "a.tif"] {
                    image::GrayImage::from_pixel(8, 8, image::Luma([9]))
                        .save(frames.join(name))
                        .unwrap();
                }
                let lms = fx.file(&format!("{id}.csv"), format!("{LM_HEAD}m,2,2,2,2\n"));
                let mut a = args(&["fit", "--model", s(&fx.def), "--frames", s(&frames)]);
                a.extend(args(&["--landmarks", s(&lms), "-o", &fx.out("same")]));
                (a, frames.join("a.tif"))
            },
        },
        Case {
            id: "scene_model_up_bad",
            setup: |fx, id| {
                let scene = fx.def_with(&format!("{id}.json"), |v| v["model_up"] = "w".into());
                let frames = fx.dir.join(format!("{id}_frames"));
                fs::create_dir_all(&frames).unwrap();
                image::GrayImage::from_pixel(8, 8, image::Luma([9]))
                    .save(frames.join("a.png"))
                    .unwrap();
                let lms = fx.file(&format!("{id}.csv"), format!("{LM_HEAD}m,2,2,2,2\n"));
                let mut a = args(&["fit", "--model", s(&scene), "--frames", s(&frames)]);
                a.extend(args(&["--landmarks", s(&lms), "-o", &fx.out("up")]));
                (a, scene)
            },
        },
        Case {
            id: "def_point_not_finite",
            setup: |fx, id| {
                let huge = format!("1{}", "0".repeat(400));
                check_doc(fx, id, |v| v["exact"]["points"][3][0] = huge.into())
            },
        },
        Case {
            id: "lm_first_row_typo",
            setup: |fx, id| fit(fx, id, "csv", "a,1,2x,3,4\nb,5,6,7,8\nc,9,1,9,2\n", &[]),
        },
        Case {
            id: "lm_too_many",
            setup: |fx, id| {
                // 22 landmarks below the diagonal of the first 20 px cell: one triangle.
                let mut text = LM_HEAD.to_string();
                for i in 0..22 {
                    let (x, y) = (2.0 + 0.75 * i as f64, 1.0 + 0.2 * (i % 5) as f64);
                    text += &format!("p{i},{x},{y},{},{y}\n", x + 1.0);
                }
                fit(fx, id, "csv", &text, &["--hard"])
            },
        },
    ]
}

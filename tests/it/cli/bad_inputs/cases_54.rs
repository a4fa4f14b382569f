//! The cases of `docs/errors.md` added by the third reliability pass (issue 54): bombs
//! refused from their headers, and the messages that were unclear or wrong.

use super::cases::{args, check_doc, fit, model, warp_image, Case, LM_HEAD};
use super::common::s;
use super::files::{float_tiff, jpeg_bomb, png_header, tiff_header};
use std::path::PathBuf;

/// No file: a case whose message names an option, not a file.
pub(super) fn no_file() -> PathBuf {
    PathBuf::new()
}

/// The cases, in the order of the table.
pub fn cases() -> Vec<Case> {
    vec![
        Case {
            id: "img_jpeg_bomb_warp",
            setup: |fx, id| {
                let p = fx.file(&format!("{id}.jpg"), jpeg_bomb(20000, 20000));
                let out = fx.out("w.png");
                (args(&["warp", s(&fx.def), "--image", s(&p), "-o", &out, "--max-memory", "2G"]), p)
            },
        },
        Case {
            id: "img_editor_picture_too_large",
            setup: |fx, id| {
                let p = fx.file(&format!("{id}.png"), png_header(30000, 30000));
                (args(&["editor", "--image", s(&p), "--port", "0"]), p)
            },
        },
        Case {
            id: "img_tiff_gray_two_samples",
            setup: |fx, id| warp_image(fx, id, "tif", &tiff_header(8, 8, 2, 1)),
        },
        Case {
            id: "img_pgm_float",
            setup: |fx, id| {
                let p = fx.file(&format!("{id}.tif"), float_tiff());
                let out = fx.dir.join(format!("{id}.pgm"));
                (args(&["warp", s(&fx.def), "--image", s(&p), "-o", s(&out)]), out)
            },
        },
        Case {
            id: "fit_hard_all_pinned",
            setup: |fx, id| {
                let all: Vec<String> = (0..121).map(|i| i.to_string()).collect();
                let pin = all.join(",");
                let text = format!("{LM_HEAD}a,10,10,11,10\nb,30,12,30,13\n");
                fit(fx, id, "csv", &text, &["--hard", "--pin", &pin])
            },
        },
        Case {
            id: "def_collapsed",
            setup: |fx, id| {
                let p = fx.def_with(&format!("{id}.json"), |v| {
                    for key in ["points", "exact"] {
                        let pts = if key == "exact" { &mut v[key]["points"] } else { &mut v[key] };
                        for q in pts.as_array_mut().unwrap() {
                            *q = if key == "exact" {
                                serde_json::json!(["5", "5"])
                            } else {
                                serde_json::json!([5, 5])
                            };
                        }
                    }
                });
                (args(&["warp", s(&p), "--image", s(&fx.image), "-o", &fx.out("w.png")]), p)
            },
        },
        Case {
            id: "def_point_three_coordinates",
            setup: |fx, id| {
                check_doc(fx, id, |v| v["exact"]["points"][3] = serde_json::json!(["1", "2", "3"]))
            },
        },
        Case {
            id: "grid_too_large",
            setup: |fx, _| {
                let a = ["mesh", "--grid", "3000x3000", "--size", "100,100"];
                (args(&[&a[..], &["-o", &fx.out("g.json")]].concat()), no_file())
            },
        },
        Case {
            id: "morph_frames_too_many",
            setup: |fx, _| {
                let img = s(&fx.image);
                let lms = fx.file(
                    "frames_lms.csv",
                    format!("{LM_HEAD}a,5,5,5,5\nb,30,5,30,5\nc,5,30,5,30\n"),
                );
                let mut a = args(&["morph", img, img, "--landmarks", s(&lms)]);
                a.extend(args(&["--frames", "10001", "-o", &fx.out("mf")]));
                (a, no_file())
            },
        },
        Case {
            id: "model_auto_coincident",
            setup: |fx, id| model(fx, id, "obj", b"v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n"),
        },
        Case {
            id: "render_model_2d",
            setup: |fx, _| {
                let m = fx.file("render_2d.obj", "v 1 1 1\nv 5 1 1\nv 1 5 1\nf 1 2 3\n");
                let a = args(&["render", s(&fx.def), "--model", s(&m), "-o", &fx.out("r.png")]);
                (a, fx.def.clone())
            },
        },
        Case {
            id: "outline_crossing",
            setup: |fx, id| {
                let pts =
                    fx.file(&format!("{id}_points.csv"), "x,y\n0,0\n40,0\n40,40\n0,40\n20,20\n");
                let o = fx.file(&format!("{id}.csv"), "5,5\n30,5\n5,30\n30,30\n");
                let a = ["mesh", "--points", s(&pts), "--outline", s(&o)];
                (args(&[&a[..], &["-o", &fx.out("m.json")]].concat()), o)
            },
        },
        Case {
            id: "outline_point_on_points",
            setup: |fx, id| {
                let pts =
                    fx.file(&format!("{id}_points.csv"), "x,y\n0,0\n40,0\n40,40\n0,40\n20,20\n");
                let o = fx.file(&format!("{id}.csv"), "0,0\n40,0\n40,40\n");
                let a = ["mesh", "--points", s(&pts), "--outline", s(&o)];
                (args(&[&a[..], &["-o", &fx.out("m.json")]].concat()), o)
            },
        },
        Case {
            // Bug (issue 56): the background's refusal was put under the landmark file.
            id: "morph_background_type",
            setup: |fx, id| {
                let lms = fx.file(
                    &format!("{id}.csv"),
                    format!("{LM_HEAD}a,5,5,6,5\nb,30,5,30,6\nc,5,30,5,30\n"),
                );
                let img = s(&fx.image);
                let a = ["morph", img, img, "--landmarks", s(&lms), "--background=300"];
                (args(&[&a[..], &["-o", &fx.out("m")]].concat()), no_file())
            },
        },
    ]
}

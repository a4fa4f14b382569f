//! OME-Zarr from outside: `trimorph field -o F.zarr` read back with zarrs, and
//! `trimorph warp --image X.zarr` against warping each plane as a TIFF.

use crate::common;
use common::*;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use trimorph::warp::inverse::InverseOptions;
use zarrs::array::Array;
use zarrs::filesystem::FilesystemStore;
use zarrs::group::Group;

/// Largest difference between a stored inverse displacement (from the interpolated,
/// certified preimage grid) and `warp::inverse` at the same pixel centre (Newton): each is
/// within the default tolerance 0.01 px of the true preimage.
const INVERSE_AGREEMENT_PX: f64 = 0.02;

fn manifest(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// A real deformation: fitted to the bundled nucleus tracks of the 511 x 511 time-lapse
/// (frame 0 to frame 9), made once per test binary.
fn fitted() -> &'static Path {
    static DEF: OnceLock<PathBuf> = OnceLock::new();
    DEF.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap().keep();
        let def = dir.join("fit.json");
        let lm = manifest("data/microscopy/timelapse/tracks_0_9.csv");
        // No far-field rings: the mesh then ends a margin beyond the frame, and the field
        // tests below reach past it to see undefined pixels.
        ok(&trimorph(&[
            "fit",
            "--landmarks",
            s(&lm),
            "--size",
            "511,511",
            "--far-rings",
            "0",
            "-o",
            s(&def),
        ]));
        def
    })
}

fn spline(def: &Path) -> trimorph::spline::Spline {
    let text = std::fs::read_to_string(def).unwrap();
    trimorph::io::deformation::from_str(&text).unwrap().0
}

fn open(p: &Path) -> Arc<FilesystemStore> {
    Arc::new(FilesystemStore::new(p).unwrap())
}

fn attrs(store: &Arc<FilesystemStore>, path: &str) -> serde_json::Value {
    serde_json::Value::Object(Group::open(store.clone(), path).unwrap().attributes().clone())
}

/// The `(2, H, W)` array of field `name`, checked for shape, type and metadata.
fn field_array(store: &Arc<FilesystemStore>, name: &str, w: u64, h: u64) -> Vec<f64> {
    let g = attrs(store, &format!("/coordinateTransformations/{name}"));
    let ms = &g["ome"]["multiscales"][0];
    let axes = &ms["coordinateSystems"][0]["axes"];
    assert_eq!(ms["name"], name);
    // The field's points are those of its transformation's input system.
    let input = if name == "inverse" { "warped" } else { "original" };
    assert_eq!(ms["coordinateSystems"][0]["name"], input);
    assert_eq!(g["ome"]["version"], "0.6");
    assert_eq!(axes[0]["type"], "displacement");
    assert_eq!(axes[0]["discrete"], true);
    assert_eq!((axes[1]["name"].as_str(), axes[2]["name"].as_str()), (Some("y"), Some("x")));
    assert_eq!(ms["datasets"][0]["path"], "0");
    let a = Array::open(store.clone(), &format!("/coordinateTransformations/{name}/0")).unwrap();
    assert_eq!(a.shape(), &[2, h, w]);
    assert_eq!(*a.data_type(), zarrs::array::data_type::float64());
    let names: Vec<_> = a
        .dimension_names()
        .as_ref()
        .unwrap()
        .iter()
        .map(|n| n.as_deref().unwrap_or("").to_string())
        .collect();
    assert_eq!(names, ["c", "y", "x"]);
    a.retrieve_array_subset(&a.subset_all()).unwrap()
}

#[test]
fn field_zarr_is_the_resampling_direction_at_pixel_centres() {
    let dir = tempfile::tempdir().unwrap();
    let def = fitted();
    let f = dir.path().join("F.zarr");
    // Beyond the fitted mesh on the right and bottom, so some pixels are undefined.
    let (w, h) = (120u64, 700u64);
    ok(&trimorph(&["field", s(def), "-o", s(&f), "--size", &format!("{w},{h}")]));
    let store = open(&f);
    let root = attrs(&store, "/");
    let t = &root["ome"]["scene"]["coordinateTransformations"][0];
    assert_eq!(t["type"], "displacements");
    assert_eq!(
        (t["input"]["name"].as_str(), t["output"]["name"].as_str()),
        (Some("warped"), Some("original"))
    );
    assert_eq!(t["path"], "coordinateTransformations/inverse");
    let systems: Vec<_> = root["ome"]["scene"]["coordinateSystems"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(systems, ["original", "warped"]);
    assert!(!f.join("coordinateTransformations/forward").exists());
    let data = field_array(&store, "inverse", w, h);
    let n = (w * h) as usize;
    let sp = spline(def);
    let pts: Vec<[f64; 2]> =
        (0..h).flat_map(|y| (0..w).map(move |x| [x as f64, y as f64])).collect();
    let inv = trimorph::warp::inverse(&sp, &pts, InverseOptions::default());
    let (mut both, mut nan, mut worst) = (0, 0, 0.0f64);
    for (i, (q, r)) in pts.iter().zip(&inv).enumerate() {
        let (dy, dx) = (data[i], data[n + i]);
        match r {
            Some(r) if !dx.is_nan() => {
                both += 1;
                worst = worst.max((q[0] + dx - r.p[0]).abs()).max((q[1] + dy - r.p[1]).abs());
            }
            None => {
                assert!(dx.is_nan() && dy.is_nan(), "pixel {q:?} has no preimage but {dx},{dy}");
                nan += 1;
            }
            Some(r) => panic!("pixel {q:?}: NaN stored, preimage {:?}", r.p),
        }
    }
    assert!(worst <= INVERSE_AGREEMENT_PX, "c = 0 is dy, c = 1 is dx: worst {worst}");
    assert!(both > n / 2 && nan > 0, "{both} defined, {nan} undefined");
    // The fitted map is not a translation: the check is not trivially satisfied.
    let spread =
        (0..n).filter(|&i| !data[n + i].is_nan()).map(|i| data[n + i].abs()).fold(0.0, f64::max);
    assert!(spread > 1.0, "x displacements up to {spread} px");
}

#[test]
fn field_zarr_both_is_a_bijection_and_inverse_flag_is_forward() {
    let dir = tempfile::tempdir().unwrap();
    let def = fitted();
    let (w, h) = (90u64, 60u64);
    let sz = format!("{w},{h}");
    let b = dir.path().join("B.zarr");
    ok(&trimorph(&["field", s(def), "-o", s(&b), "--both", "--size", &sz]));
    let store = open(&b);
    let t = attrs(&store, "/")["ome"]["scene"]["coordinateTransformations"][0].clone();
    assert_eq!(t["type"], "bijection");
    assert_eq!(
        (t["input"]["name"].as_str(), t["output"]["name"].as_str()),
        (Some("original"), Some("warped"))
    );
    assert_eq!(t["forward"]["type"], "displacements");
    assert_eq!(t["forward"]["path"], "coordinateTransformations/forward");
    assert_eq!(t["inverse"]["path"], "coordinateTransformations/inverse");
    let fwd = field_array(&store, "forward", w, h);
    let inv = field_array(&store, "inverse", w, h);
    let sp = spline(def);
    let pts: Vec<[f64; 2]> =
        (0..h).flat_map(|y| (0..w).map(move |x| [x as f64, y as f64])).collect();
    let n = pts.len();
    for (i, (p, q)) in pts.iter().zip(trimorph::warp::forward(&sp, &pts)).enumerate() {
        let q = q.expect("the fitted mesh covers the frame");
        assert_eq!([fwd[n + i], fwd[i]], [q[0] - p[0], q[1] - p[1]], "forward at {p:?}");
    }
    // --inverse alone: the same forward field, as a displacements transform original -> warped.
    let f = dir.path().join("F.zarr");
    ok(&trimorph(&["field", s(def), "-o", s(&f), "--inverse", "--size", &sz]));
    let store = open(&f);
    let t = attrs(&store, "/")["ome"]["scene"]["coordinateTransformations"][0].clone();
    assert_eq!(t["type"], "displacements");
    assert_eq!(
        (t["input"]["name"].as_str(), t["output"]["name"].as_str()),
        (Some("original"), Some("warped"))
    );
    assert_eq!(field_array(&store, "forward", w, h), fwd);
    assert!(!f.join("coordinateTransformations/inverse").exists());
    // The bijection's inverse equals the default store's.
    let d = dir.path().join("D.zarr");
    ok(&trimorph(&["field", s(def), "-o", s(&d), "--size", &sz]));
    let again = field_array(&open(&d), "inverse", w, h);
    assert!(again.iter().zip(&inv).all(|(a, b)| a == b || (a.is_nan() && b.is_nan())));
    // Writing over an existing store replaces it.
    ok(&trimorph(&["field", s(def), "-o", s(&d), "--inverse", "--size", &sz]));
    assert!(d.join("coordinateTransformations/forward").exists());
    assert!(!d.join("coordinateTransformations/inverse").exists());
}

/// A deformation of the 64 x 48 test image: a 3x3 grid with one vertex moved.
fn small_def(dir: &Path) -> PathBuf {
    let id = dir.join("id.json");
    ok(&trimorph(&["mesh", "--grid", "3x3", "--size", "63,47", "-o", s(&id)]));
    let script = dir.join("e.json");
    std::fs::write(
        &script,
        r#"[{"anchors": {"near": [[31.5, 23.5]]}, "op": "translate", "by": [3, -2]}]"#,
    )
    .unwrap();
    let ed = dir.join("ed.json");
    ok(&trimorph(&["edit", s(&id), "--script", s(&script), "-o", s(&ed)]));
    ed
}

#[test]
fn warp_of_a_v2_blosc_tcyx_image_equals_warping_each_plane_as_tiff() {
    let dir = tempfile::tempdir().unwrap();
    let def = small_def(dir.path());
    let input = manifest("tests/data/ngff_tcyx_u16_v2_blosc.zarr");
    let out = dir.path().join("out.zarr");
    ok(&trimorph(&["warp", s(&def), "--image", s(&input), "-o", s(&out), "--interp", "bicubic"]));
    let got = trimorph::io::ngff::read_image(&out).unwrap();
    assert_eq!(got.zarr_format, 2);
    assert_eq!(got.shape, vec![2, 2, 48, 64]);
    assert_eq!(got.chunks, vec![1, 1, 32, 32]);
    let zarray: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("0/.zarray")).unwrap()).unwrap();
    assert_eq!(zarray["compressor"]["id"], "blosc");
    assert_eq!(zarray["dtype"], "<u2");
    let zattrs: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join(".zattrs")).unwrap()).unwrap();
    assert_eq!(zattrs["multiscales"][0]["datasets"].as_array().unwrap().len(), 1);
    assert_eq!(zattrs["multiscales"][0]["axes"][0]["unit"], "second");
    assert_eq!(zattrs["omero"]["channels"][1]["label"], "frame odd");
    let mut changed = 0;
    for k in 0..4 {
        // Plane (t, c) = (k / 2, k % 2) is a crop of frame k (see tests/data/make_ngff.py).
        let frame = image::open(manifest(&format!("data/microscopy/timelapse/frame_0{k}.png")))
            .unwrap()
            .to_luma8();
        let plane = image::ImageBuffer::<image::Luma<u16>, _>::from_fn(64, 48, |x, y| {
            image::Luma([frame.get_pixel(200 + x, 180 + y).0[0] as u16 * 257])
        });
        let tif = dir.path().join(format!("p{k}.tif"));
        plane.save(&tif).unwrap();
        let wt = dir.path().join(format!("w{k}.tif"));
        ok(&trimorph(&["warp", s(&def), "--image", s(&tif), "-o", s(&wt), "--interp", "bicubic"]));
        let want = image::open(&wt).unwrap();
        assert_eq!(got.pages[k].as_bytes(), want.as_bytes(), "plane {k}");
        changed += (want.to_luma16() != plane) as usize;
    }
    assert_eq!(changed, 4, "the deformation moves every plane");
    // A raster output of a zarr input: a 4-page TIFF with the same planes.
    let tif = dir.path().join("all.tif");
    ok(&trimorph(&["warp", s(&def), "--image", s(&input), "-o", s(&tif), "--interp", "bicubic"]));
    let st = trimorph::io::raster::read_stack(&tif).unwrap();
    assert_eq!(st.pages.len(), 4);
    for (a, b) in st.pages.iter().zip(&got.pages) {
        assert_eq!(a.as_bytes(), b.as_bytes());
    }
}

#[test]
fn warp_of_a_v3_float_cyx_image_equals_warping_each_plane() {
    use zarrs::array::{codec::ZstdCodec, data_type, ArrayBuilder};
    let dir = tempfile::tempdir().unwrap();
    let def = fitted();
    let p = dir.path().join("img.zarr");
    let store = Arc::new(FilesystemStore::new(&p).unwrap());
    let attrs = serde_json::json!({"ome": {"version": "0.5", "multiscales": [{
        "axes": [{"name": "c", "type": "channel"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}],
        "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1.0, 1.0, 1.0]}]}]
    }]}});
    zarrs::group::GroupBuilder::new()
        .attributes(attrs.as_object().unwrap().clone())
        .build(store.clone(), "/")
        .unwrap()
        .store_metadata()
        .unwrap();
    let frames: Vec<image::GrayImage> = (0..2)
        .map(|k| {
            image::open(manifest(&format!("data/microscopy/timelapse/frame_0{k}.png")))
                .unwrap()
                .to_luma8()
        })
        .collect();
    let data: Vec<f32> =
        frames.iter().flat_map(|f| f.pixels().map(|p| p.0[0] as f32 / 255.0)).collect();
    let a = ArrayBuilder::new(vec![2, 511, 511], vec![1, 128, 128], data_type::float32(), 0.0f32)
        .bytes_to_bytes_codecs(vec![Arc::new(ZstdCodec::new(3, false))])
        .build(store, "/0")
        .unwrap();
    a.store_metadata().unwrap();
    a.store_array_subset(&a.subset_all(), &data[..]).unwrap();
    let out = dir.path().join("out.zarr");
    ok(&trimorph(&["warp", s(def), "--image", s(&p), "-o", s(&out)]));
    let got = trimorph::io::ngff::read_image(&out).unwrap();
    assert_eq!((got.zarr_format, got.shape.clone()), (3, vec![2, 511, 511]));
    assert_eq!(got.chunks, vec![1, 128, 128]);
    for (k, f) in frames.iter().enumerate() {
        let plane = image::ImageBuffer::<image::Luma<f32>, _>::from_fn(511, 511, |x, y| {
            image::Luma([f.get_pixel(x, y).0[0] as f32 / 255.0])
        });
        let tif = dir.path().join(format!("p{k}.tif"));
        let st = trimorph::io::raster::Stack {
            pages: vec![image::DynamicImage::ImageRgb32F(image::ImageBuffer::from_fn(
                511,
                511,
                |x, y| {
                    let v = plane.get_pixel(x, y).0[0];
                    image::Rgb([v, v, v])
                },
            ))],
            gray_float: true,
        };
        trimorph::io::raster::write_stack(&tif, &st).unwrap();
        let wt = dir.path().join(format!("w{k}.tif"));
        ok(&trimorph(&["warp", s(def), "--image", s(&tif), "-o", s(&wt)]));
        let want = trimorph::io::raster::read_stack(&wt).unwrap();
        assert_eq!(got.pages[k].as_bytes(), want.pages[0].as_bytes(), "plane {k}");
    }
}

fn fails_with(args: &[&str], needles: &[&str]) {
    let o = trimorph(args);
    assert_eq!(o.status.code(), Some(1), "{args:?} should exit 1");
    let e = String::from_utf8_lossy(&o.stderr);
    for n in needles {
        assert!(e.contains(n), "{args:?}: `{n}` not in: {e}");
    }
}

#[test]
fn bad_ome_zarr_inputs_exit_1_naming_store_and_element() {
    let dir = tempfile::tempdir().unwrap();
    let def = small_def(dir.path());
    let src = manifest("tests/data/ngff_tcyx_u16_v2_blosc.zarr");
    let copy = |name: &str| {
        let d = dir.path().join(name);
        for e in walk(&src) {
            let rel = e.strip_prefix(&src).unwrap();
            let t = d.join(rel);
            std::fs::create_dir_all(t.parent().unwrap()).unwrap();
            std::fs::copy(&e, &t).unwrap();
        }
        d
    };
    let out = dir.path().join("o.zarr");
    // Missing .zarray of level 0.
    let m = copy("missing.zarr");
    std::fs::remove_file(m.join("0/.zarray")).unwrap();
    fails_with(
        &["warp", s(&def), "--image", s(&m), "-o", s(&out)],
        &["missing.zarr", "array `0`", ".zarray"],
    );
    // Unsupported dtype: int32.
    let i = copy("int32.zarr");
    let za = i.join("0/.zarray");
    let t = std::fs::read_to_string(&za).unwrap().replace("<u2", "<i4");
    std::fs::write(&za, t).unwrap();
    fails_with(
        &["warp", s(&def), "--image", s(&i), "-o", s(&out)],
        &["int32.zarr", "array `0`", "unsupported data type"],
    );
    // Three spatial axes (4-D t, z, y, x).
    let z = copy("zyx.zarr");
    let zt = z.join(".zattrs");
    let mut za: serde_json::Value = serde_json::from_slice(&std::fs::read(&zt).unwrap()).unwrap();
    za["multiscales"][0]["axes"][1] = serde_json::json!({"name": "z", "type": "space"});
    std::fs::write(&zt, za.to_string()).unwrap();
    fails_with(
        &["warp", s(&def), "--image", s(&z), "-o", s(&out)],
        &["zyx.zarr", "t, z, y, x", "3 spatial axes"],
    );
    // Bug (issue 54): shapes that wrapped `w * h` to 0, held no plane, or declared 5,000
    // planes of 1000 x 1000 in a few bytes of JSON (decoded, then refused, or aborted).
    for (name, shape, needles) in [
        (
            "wrap.zarr",
            "[1, 1, 8589934592, 2147483648]",
            &["planes of 2147483648 x 8589934592 pixels", "crop or split"][..],
        ),
        ("none.zarr", "[0, 2, 48, 64]", &["holds no planes"][..]),
        (
            "many.zarr",
            "[5000, 1, 1000, 1000]",
            &["decoding 5000 planes of 1000 x 1000 pixels", "over the budget"][..],
        ),
    ] {
        let z = copy(name);
        let za = z.join("0/.zarray");
        let mut meta: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&za).unwrap()).unwrap();
        meta["shape"] = serde_json::from_str(shape).unwrap();
        std::fs::write(&za, meta.to_string()).unwrap();
        let mut want = vec![name, "array `0`"];
        want.extend_from_slice(needles);
        fails_with(
            &["--max-memory", "1G", "warp", s(&def), "--image", s(&z), "-o", s(&out)],
            &want,
        );
    }
    // No group metadata at all.
    let e = dir.path().join("empty.zarr");
    std::fs::create_dir(&e).unwrap();
    fails_with(
        &["warp", s(&def), "--image", s(&e), "-o", s(&out)],
        &["empty.zarr", "not a Zarr store"],
    );
    // A .zarr output needs a .zarr input; --both needs a .zarr output.
    let png = dir.path().join("a.png");
    image::GrayImage::from_pixel(64, 48, image::Luma([9])).save(&png).unwrap();
    fails_with(
        &["warp", s(&def), "--image", s(&png), "-o", s(&out)],
        &["o.zarr", "OME-Zarr input"],
    );
    fails_with(
        &["field", s(&def), "-o", s(&dir.path().join("f.npy")), "--both"],
        &["f.npy", "--both"],
    );
    assert!(!out.exists());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

fn walk(d: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(d).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
fn field_zarr_with_spacing_origin_and_unit_is_placed_in_physical_space() {
    let dir = tempfile::tempdir().unwrap();
    let def = fitted();
    let (w, h) = (70u64, 50u64);
    let sz = format!("{w},{h}");
    let px = dir.path().join("px.zarr");
    ok(&trimorph(&["field", s(def), "-o", s(&px), "--both", "--size", &sz]));
    let ph = dir.path().join("ph.zarr");
    let out = trimorph(&[
        "field",
        s(def),
        "-o",
        s(&ph),
        "--both",
        "--size",
        &sz,
        "--spacing",
        "0.5,0.25",
        "--origin=-3,7.5",
        "--unit",
        "micrometer",
    ]);
    ok(&out);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(said.contains("spacing 0.5,0.25 origin -3,7.5 micrometer"), "{said}");
    let (a, b) = (open(&px), open(&ph));
    let root = attrs(&b, "/");
    for cs in root["ome"]["scene"]["coordinateSystems"].as_array().unwrap() {
        for ax in cs["axes"].as_array().unwrap() {
            assert_eq!(ax["unit"], "micrometer", "{cs}");
        }
    }
    for name in ["forward", "inverse"] {
        let g = attrs(&b, &format!("/coordinateTransformations/{name}"));
        let ms = &g["ome"]["multiscales"][0];
        let axes = &ms["coordinateSystems"][0]["axes"];
        assert_eq!(
            (axes[1]["unit"].as_str(), axes[2]["unit"].as_str()),
            (Some("micrometer"), Some("micrometer"))
        );
        assert!(axes[0].get("unit").is_none(), "the displacement axis has no unit");
        let t = &ms["datasets"][0]["coordinateTransformations"][0];
        assert_eq!(t["type"], "sequence");
        assert_eq!(t["input"]["path"], "0");
        assert_eq!(t["transformations"][0]["scale"], serde_json::json!([1.0, 0.25, 0.5]));
        assert_eq!(t["transformations"][1]["translation"], serde_json::json!([0.0, 7.5, -3.0]));
        // Physical displacements: the y component times 0.25, the x component times 0.5.
        let (p, q) = (field_array(&a, name, w, h), field_array(&b, name, w, h));
        let n = (w * h) as usize;
        for i in 0..n {
            for (c, sc) in [(0, 0.25), (1, 0.5)] {
                let (u, v) = (p[c * n + i], q[c * n + i]);
                assert!(u.is_nan() && v.is_nan() || u * sc == v, "{name} c={c} at {i}: {u} -> {v}");
            }
        }
    }
    // The placement alone, without a unit: a plain scale, and no unit on the axes.
    let sc = dir.path().join("sc.zarr");
    ok(&trimorph(&["field", s(def), "-o", s(&sc), "--size", &sz, "--spacing", "2,2"]));
    let g = attrs(&open(&sc), "/coordinateTransformations/inverse");
    let t = &g["ome"]["multiscales"][0]["datasets"][0]["coordinateTransformations"][0];
    assert_eq!(
        (t["type"].as_str(), &t["scale"]),
        (Some("scale"), &serde_json::json!([1.0, 2.0, 2.0]))
    );
    assert!(g["ome"]["multiscales"][0]["coordinateSystems"][0]["axes"][1].get("unit").is_none());
    // Out of range: refused, nothing written.
    let bad = dir.path().join("bad.zarr");
    let out = trimorph(&["field", s(def), "-o", s(&bad), "--size", &sz, "--spacing", "0,1"]);
    assert_eq!(out.status.code(), Some(1), "refused");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("positive"), "{err}");
    assert!(!bad.exists());
}

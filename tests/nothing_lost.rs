//! Nothing is lost: a failed command leaves earlier outputs byte for byte as they were, and a
//! batch killed (SIGKILL) at random moments never leaves a half-written output, resumes where
//! it stopped, ends with the same results as an uninterrupted run, and removes the temporary
//! files the killed runs left.

mod common;
use common::{ok, s, trimorph};
use std::collections::BTreeMap;
use std::fs;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

#[test]
fn failed_commands_leave_earlier_outputs_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let def = d.join("def.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", s(&def)]));
    let img = d.join("in.png");
    image::GrayImage::from_fn(40, 40, |x, y| image::Luma([(x * 6 + y) as u8])).save(&img).unwrap();
    let bad_script = d.join("bad.json");
    fs::write(&bad_script, r#"[{"op": "translate", "anchors": [3], "by": [1, 0]}, {"op": 7}]"#)
        .unwrap();
    let bad_points = d.join("bad.csv");
    fs::write(&bad_points, "0,0\n1,0\n0,nan\n").unwrap();
    let bad_image = d.join("bad.png");
    fs::write(&bad_image, &fs::read(&img).unwrap()[..200]).unwrap();
    let bad_lms = d.join("bad_lms.csv");
    fs::write(&bad_lms, "name,src_x,src_y,dst_x,dst_y\na,1,2,3\n").unwrap();
    let out = |name: &str| d.join(name);
    // (command, output it would write): each output exists beforehand with known bytes.
    let cases: Vec<(Vec<&str>, std::path::PathBuf)> = vec![
        (vec!["edit", s(&def), "--script", s(&bad_script), "-o"], out("e.json")),
        (vec!["mesh", "--points", s(&bad_points), "-o"], out("m.json")),
        (vec!["warp", s(&def), "--image", s(&bad_image), "-o"], out("w.png")),
        (vec!["colormesh", s(&bad_image), "-o"], out("c.ply")),
        (vec!["fit", s(&def), "--landmarks", s(&bad_lms), "-o"], out("f.json")),
        (vec!["render", s(&bad_script), "-o"], out("r.png")),
    ];
    for (args, target) in cases {
        let before = format!("earlier output of {}", args[0]).into_bytes();
        fs::write(&target, &before).unwrap();
        let mut a = args.clone();
        a.push(s(&target));
        let o = trimorph(&a);
        assert_eq!(o.status.code(), Some(1), "{a:?}: {}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(fs::read(&target).unwrap(), before, "{a:?} changed its earlier output");
    }
    let leftovers: Vec<_> = fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

/// A textured frame shifted by (dx, dy).
fn frame(dx: f64, dy: f64) -> image::GrayImage {
    image::GrayImage::from_fn(160, 120, |x, y| {
        let (u, v) = (x as f64 - dx, y as f64 - dy);
        let g = 128.0 + 60.0 * (u / 7.0).sin() * (v / 9.0).cos() + 40.0 * ((u + v) / 13.0).sin();
        image::Luma([g.clamp(0.0, 255.0) as u8])
    })
}

struct Batch {
    dir: tempfile::TempDir,
    args: Vec<String>,
}

impl Batch {
    fn new(frames: usize) -> Batch {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let fr = d.join("frames");
        fs::create_dir_all(&fr).unwrap();
        for k in 0..frames {
            frame(1.5 * k as f64, -(k as f64)).save(fr.join(format!("f{k:02}.png"))).unwrap();
        }
        let scene = d.join("scene.json");
        ok(&trimorph(&["mesh", "--grid", "4x3", "--size", "160,120", "-o", s(&scene)]));
        let lms = d.join("l.csv");
        let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
        for (i, p) in
            [[40, 30], [120, 30], [40, 90], [120, 90], [80, 60], [60, 45]].iter().enumerate()
        {
            csv += &format!("m{i},{},{},{},{}\n", p[0], p[1], p[0], p[1]);
        }
        fs::write(&lms, csv).unwrap();
        let args = ["fit", "--model", s(&scene), "--frames", s(&fr), "--landmarks", s(&lms)];
        let mut args: Vec<String> = args.iter().map(|x| x.to_string()).collect();
        args.push("--track".into());
        Batch { dir, args }
    }

    fn command(&self, out: &Path) -> Command {
        let mut c = Command::new(env!("CARGO_BIN_EXE_trimorph"));
        c.args(&self.args).arg("-o").arg(out);
        c.stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null());
        c
    }
}

/// Every output in `out` is complete; temporary files (hidden, `.tmp`) are the only others.
/// A frame with a report has all its outputs (the report is written last).
fn assert_consistent(out: &Path) {
    let Ok(entries) = fs::read_dir(out) else { return };
    let mut reports = Vec::new();
    for e in entries {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with('.') && name.ends_with(".tmp") {
            continue;
        }
        if name.ends_with(".json") {
            let text = fs::read_to_string(&p).unwrap();
            let v: serde_json::Value = serde_json::from_str(&text)
                .unwrap_or_else(|e| panic!("{name} is half-written: {e}"));
            if let Some(stem) = name.strip_suffix(".report.json") {
                reports.push(stem.to_string());
            } else {
                assert_eq!(v["format"], "trimorph.deformation", "{name}");
            }
        } else if name.ends_with(".png") {
            image::open(&p).unwrap_or_else(|e| panic!("{name} is half-written: {e}"));
        } else {
            panic!("unexpected file {name} in the output folder");
        }
    }
    for stem in reports {
        for ext in ["json", "registered.png", "overlay.png"] {
            assert!(out.join(format!("{stem}.{ext}")).exists(), "{stem}.{ext} missing");
        }
    }
}

/// The outputs of a finished batch: deformations and images byte for byte, reports without
/// their timings.
fn results(out: &Path) -> BTreeMap<String, Vec<u8>> {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                m.retain(|k, _| !k.contains("time"));
                m.values_mut().for_each(strip);
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut map = BTreeMap::new();
    for e in fs::read_dir(out).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with(".tmp") {
            continue;
        }
        let mut bytes = fs::read(&p).unwrap();
        if name.ends_with(".report.json") {
            let mut v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
            strip(&mut v);
            bytes = v.to_string().into_bytes();
        }
        map.insert(name, bytes);
    }
    map
}

#[test]
fn a_batch_killed_at_random_moments_resumes_and_never_leaves_a_half_written_output() {
    let batch = Batch::new(8);
    let reference = batch.dir.path().join("reference");
    let t0 = Instant::now();
    assert!(batch.command(&reference).status().unwrap().success());
    let full = t0.elapsed();
    let want = results(&reference);
    assert_eq!(want.len(), 8 * 4, "{:?}", want.keys().collect::<Vec<_>>());

    let out = batch.dir.path().join("killed");
    let seed = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap();
    let mut rng = seed.as_nanos() as u64 | 1;
    let mut kills = 0;
    for round in 0..12 {
        // xorshift: a kill moment uniform in [0, full run time).
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        let at = full.mul_f64((rng % 1000) as f64 / 1000.0);
        let mut child = batch.command(&out).spawn().unwrap();
        std::thread::sleep(at);
        let killed = child.try_wait().unwrap().is_none();
        if killed {
            child.kill().unwrap();
            kills += 1;
        }
        child.wait().unwrap();
        assert_consistent(&out);
        let what = if killed { "killed" } else { "finished before" };
        eprintln!("round {round}: {what} {at:?} (seed {})", seed.as_nanos());
    }
    assert!(kills > 0, "no run was interrupted");
    // The killed runs' temporary files, made older than `io::STALE_AFTER`: the next run
    // removes them (their processes are gone).
    let an_hour_ago = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
    let mut aged = 0;
    for e in fs::read_dir(&out).unwrap() {
        let p = e.unwrap().path();
        if p.to_string_lossy().ends_with(".tmp") {
            let f = fs::File::options().write(true).open(&p).unwrap();
            f.set_modified(an_hour_ago).unwrap();
            aged += 1;
        }
    }
    eprintln!("{aged} temporary files left by the killed runs");
    assert!(batch.command(&out).status().unwrap().success());
    assert_consistent(&out);
    let left: Vec<_> = fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left behind: {left:?}");
    let got = results(&out);
    assert_eq!(got.keys().collect::<Vec<_>>(), want.keys().collect::<Vec<_>>());
    for (name, bytes) in &want {
        assert!(got[name] == *bytes, "{name} differs from the uninterrupted run");
    }
}

//! Nothing is lost: a failed command leaves earlier outputs byte for byte as they were, and a
//! batch killed (SIGKILL) at random moments never leaves a half-written output, resumes where
//! it stopped, ends with the same results as an uninterrupted run, and removes the temporary
//! files the killed runs left.

use crate::common;
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

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    v.sort();
    v
}

/// Bug (reliability pass): temp + rename replaced special outputs, so `-o FIFO` left a regular
/// file where the pipe was (and as root `-o /dev/null` would replace `/dev/null`). A FIFO
/// output is now written in place: a reader on the pipe gets the file and the pipe stays.
#[cfg(unix)]
#[test]
fn a_fifo_output_is_written_through_not_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.json");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || fs::read_to_string(fifo).unwrap())
    };
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", s(&fifo)]));
    let text = reader.join().unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["format"], "trimorph.deformation");
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the FIFO was replaced");
    assert_eq!(names(dir.path()), ["pipe.json"], "no temporary file");
}

/// A TIFF output that cannot seek (a FIFO) is encoded in memory and written through, opened
/// once: the reader gets the same bytes a regular file gets. (Found in review, session 25:
/// the streaming TIFF writer first closed and reopened such an output, and a reader that
/// read between the two saw an empty file; that race is too narrow to provoke here.)
#[cfg(unix)]
#[test]
fn a_tiff_to_a_fifo_arrives_whole_in_one_open() {
    use std::io::Read;
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("in.png");
    image::GrayImage::from_fn(64, 48, |x, y| image::Luma([(x * 3 + y) as u8])).save(&img).unwrap();
    let def = dir.path().join("id.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "63,47", "-o", s(&def)]));
    let file = dir.path().join("out.tif");
    ok(&trimorph(&["warp", s(&def), "--image", s(&img), "-o", s(&file)]));
    let fifo = dir.path().join("pipe.tif");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let mut all = Vec::new();
            fs::File::open(fifo).unwrap().read_to_end(&mut all).unwrap();
            all
        })
    };
    ok(&trimorph(&["warp", s(&def), "--image", s(&img), "-o", s(&fifo)]));
    assert_eq!(reader.join().unwrap(), fs::read(&file).unwrap(), "the reader got the whole TIFF");
}

/// Bug (reliability pass): a symlinked output was replaced by a regular file. Now the link
/// stays a link and its target (in another folder) gets the new content, written by temp +
/// rename beside the target.
#[cfg(unix)]
#[test]
fn a_symlinked_output_stays_a_link_and_its_target_is_updated() {
    let dir = tempfile::tempdir().unwrap();
    let real = dir.path().join("real");
    let links = dir.path().join("links");
    fs::create_dir_all(&real).unwrap();
    fs::create_dir_all(&links).unwrap();
    let target = real.join("def.json");
    fs::write(&target, "old").unwrap();
    let link = links.join("def.json");
    std::os::unix::fs::symlink("../real/def.json", &link).unwrap();
    let png_target = real.join("r.png");
    let png_link = links.join("r.png");
    std::os::unix::fs::symlink(&png_target, &png_link).unwrap(); // dangling: created
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", s(&link)]));
    ok(&trimorph(&["render", s(&link), "-o", s(&png_link)]));
    for (l, t) in [(&link, &target), (&png_link, &png_target)] {
        assert!(fs::symlink_metadata(l).unwrap().file_type().is_symlink(), "{l:?} replaced");
        assert!(t.is_file(), "{t:?} not written");
    }
    let v: serde_json::Value = serde_json::from_str(&fs::read_to_string(&target).unwrap()).unwrap();
    assert_eq!(v["format"], "trimorph.deformation");
    image::open(&png_target).unwrap();
    assert_eq!(names(&links), ["def.json", "r.png"]);
    assert_eq!(names(&real), ["def.json", "r.png"]);
}

/// Bug (reliability pass): a 0600 output came back 0644 (the new file had the default mode).
/// Replaced files keep their permission bits, through every writer (JSON, PNG, images).
#[cfg(unix)]
#[test]
fn a_private_output_keeps_its_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let def = d.join("def.json");
    let png = d.join("r.png");
    let warped = d.join("w.pgm");
    let img = d.join("in.png");
    image::GrayImage::from_fn(40, 40, |x, y| image::Luma([(x * 6 + y) as u8])).save(&img).unwrap();
    for p in [&def, &png, &warped] {
        fs::write(p, "old").unwrap();
        fs::set_permissions(p, fs::Permissions::from_mode(0o600)).unwrap();
    }
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", s(&def)]));
    ok(&trimorph(&["render", s(&def), "-o", s(&png)]));
    ok(&trimorph(&["warp", s(&def), "--image", s(&img), "-o", s(&warped)]));
    for p in [&def, &png, &warped] {
        let mode = fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600, "{p:?}");
        assert_ne!(fs::read(p).unwrap(), b"old", "{p:?} not rewritten");
    }
    // A new file still gets the usual mode (the umask's).
    let fresh = d.join("fresh.json");
    ok(&trimorph(&["mesh", "--grid", "2x2", "--size", "40,40", "-o", s(&fresh)]));
    assert_ne!(fs::metadata(&fresh).unwrap().permissions().mode() & 0o777, 0o600);
}

/// Two 64 x 64 textured images shifted by 3 pixels and landmarks between them.
fn morph_inputs(d: &Path) -> [String; 3] {
    let im = |dx: f64, name: &str| {
        let p = d.join(name);
        image::GrayImage::from_fn(64, 64, |x, y| {
            let (u, v) = (x as f64 - dx, y as f64);
            image::Luma([(128.0 + 60.0 * (u / 5.0).sin() * (v / 7.0).cos()) as u8])
        })
        .save(&p)
        .unwrap();
        p.display().to_string()
    };
    let (a, b) = (im(0.0, "a.png"), im(3.0, "b.png"));
    let l = d.join("l.csv");
    let mut csv = String::from("name,src_x,src_y,dst_x,dst_y\n");
    for (i, [x, y]) in [[16, 16], [48, 16], [16, 48], [48, 48], [32, 32]].iter().enumerate() {
        csv += &format!("p{i},{x},{y},{},{y}\n", x + 3);
    }
    fs::write(&l, csv).unwrap();
    [a, b, l.display().to_string()]
}

fn morph(inputs: &[String; 3], out: &Path, frames: &str, extra: &[&str]) -> std::process::Output {
    let [a, b, l] = inputs;
    let mut args = vec!["morph", a, b, "--landmarks", l, "--frames", frames, "-o", s(out)];
    args.extend(extra);
    trimorph(&args)
}

/// Every file of `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    names(dir).into_iter().map(|n| (n.clone(), fs::read(dir.join(&n)).unwrap())).collect()
}

/// Bug (reliability pass): a rerun of `morph` with fewer frames left the earlier run's extra
/// frames beside the new ones. The folder is now swapped as a whole.
#[test]
fn a_shorter_morph_leaves_no_stale_frames() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = morph_inputs(dir.path());
    let out = dir.path().join("out");
    ok(&morph(&inputs, &out, "5", &[]));
    assert!(out.join("frame_004.png").exists());
    ok(&morph(&inputs, &out, "3", &[]));
    let got = names(&out);
    let frames: Vec<&String> = got.iter().filter(|n| n.starts_with("frame_")).collect();
    assert_eq!(frames, ["frame_000.png", "frame_001.png", "frame_002.png"], "{got:?}");
    assert_eq!(names(dir.path()), ["a.png", "b.png", "l.csv", "out"], "no stage left");
    // With a file of the user's in the folder, the frames are replaced one by one: the user's
    // file stays, the stale frames still go.
    fs::write(out.join("notes.txt"), "mine").unwrap();
    ok(&morph(&inputs, &out, "2", &[]));
    assert!(!out.join("frame_002.png").exists());
    assert_eq!(fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
}

/// Bug (reliability pass): a morph failing after its first files were written left old and
/// new frames mixed. Here the animation cannot be written (its name is taken by a folder,
/// which the finished animation cannot be renamed over), after every frame is done: the
/// earlier output is byte for byte as it was. (A missing folder no longer fails: `morph`
/// makes the folders of `--gif` and `--apng`, issue 54.)
#[test]
fn a_morph_that_fails_midway_leaves_the_old_folder_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = morph_inputs(dir.path());
    let out = dir.path().join("out");
    ok(&morph(&inputs, &out, "4", &["--no-align"]));
    let before = snapshot(&out);
    let gif = dir.path().join("m.gif");
    fs::create_dir(&gif).unwrap();
    fs::write(gif.join("mine.txt"), "mine").unwrap();
    let o = morph(&inputs, &out, "3", &["--gif", s(&gif)]);
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("m.gif"));
    assert!(snapshot(&out) == before, "the failed morph changed its earlier output");
    assert_eq!(names(dir.path()), ["a.png", "b.png", "l.csv", "m.gif", "out"], "no stage left");
    assert_eq!(fs::read_to_string(gif.join("mine.txt")).unwrap(), "mine");
}

/// Bug (reliability pass): `demo -o D` deleted `D/fit/out` recursively, with whatever the
/// user kept there. It now removes only the files an earlier demo wrote.
#[test]
fn demo_keeps_user_files_in_its_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fit").join("out");
    fs::create_dir_all(out.join("sub")).unwrap();
    fs::write(out.join("mine.txt"), "keep me").unwrap();
    fs::write(out.join("sub").join("deep.txt"), "and me").unwrap();
    for _ in 0..2 {
        ok(&trimorph(&["demo", "-o", s(dir.path())]));
        assert_eq!(fs::read_to_string(out.join("mine.txt")).unwrap(), "keep me");
        assert_eq!(fs::read_to_string(out.join("sub").join("deep.txt")).unwrap(), "and me");
        assert!(out.join("frame_09.report.json").exists());
    }
}

/// `fit --frames` with `a.png` and `a.tif`: both frames would write `a.json`, `a.report.json`,
/// ...; the batch is refused before anything is written.
#[test]
fn same_stem_frames_are_refused_before_writing() {
    let batch = Batch::new(2);
    let fr = batch.dir.path().join("frames");
    image::open(fr.join("f01.png")).unwrap().save(fr.join("f01.tif")).unwrap();
    let out = batch.dir.path().join("out");
    let o = batch.command(&out).stderr(std::process::Stdio::piped()).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("f01.png") && err.contains("f01.tif"), "{err}");
    assert!(!out.exists() || names(&out).is_empty(), "{:?}", names(&out));
}

/// Resume checks every output, not only the report: a deleted `FRAME.json` is fitted again,
/// and the batch ends with the results of an uninterrupted run.
#[test]
fn resume_refits_a_frame_whose_output_was_deleted() {
    let batch = Batch::new(3);
    let out = batch.dir.path().join("out");
    assert!(batch.command(&out).status().unwrap().success());
    let want = results(&out);
    for deleted in ["f01.json", "f02.overlay.png"] {
        fs::remove_file(out.join(deleted)).unwrap();
        let o = batch.command(&out).stdout(std::process::Stdio::piped()).output().unwrap();
        assert!(o.status.success());
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("1 frames fitted, 2 skipped"), "{deleted}: {text}");
        assert!(results(&out) == want, "{deleted}: results differ after the refit");
    }
}

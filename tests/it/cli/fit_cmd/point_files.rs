//! Landmark point files through `trimorph fit`: pairs of `.pts`, ITK and CSV `x,y` files,
//! and landmarks on the frame's outer edge.

use super::smooth;
use crate::common::{ok, s, trimorph};
use std::fs;
use std::path::Path;

/// Issue 52: `--landmarks-src A --landmarks-dst B` pairs two point files (iBUG `.pts`,
/// 1-based; ITK point set; CSV `x,y`) point by point; the fit equals the one from the
/// equivalent landmark CSV, byte for byte.
#[test]
fn point_file_pairs_fit_as_the_equivalent_landmark_csv() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    // Sources on whole pixels (the .pts shift by 1 is exact), targets anywhere.
    let (mut csv, mut pts, mut itk, mut xy) = (
        String::from("name,src_x,src_y,dst_x,dst_y\n"),
        String::from("version: 1\nn_points: 12\n{\n"),
        String::from("point\n12\n"),
        String::from("x,y\n"),
    );
    for i in 0..12 {
        let s = [15.0 + (i * 37 % 170) as f64, 12.0 + (i * 53 % 120) as f64];
        let t = smooth(s);
        csv += &format!(",{},{},{},{}\n", s[0], s[1], t[0], t[1]);
        pts += &format!("{} {}\n", s[0] + 1.0, s[1] + 1.0);
        itk += &format!("{} {}\n", t[0], t[1]);
        xy += &format!("{},{}\n", t[0], t[1]);
    }
    pts += "}\n";
    let (l_csv, a_pts, b_txt, b_csv) = (p("l.csv"), p("a.pts"), p("b.txt"), p("b.csv"));
    for (name, text) in [(&l_csv, &csv), (&a_pts, &pts), (&b_txt, &itk), (&b_csv, &xy)] {
        fs::write(name, text).unwrap();
    }
    let fit = |landmarks: &[&str], out: &str| {
        let out = p(out);
        let mut a = vec!["fit", "--size", "200,150", "-o", &out];
        a.extend_from_slice(landmarks);
        ok(&trimorph(&a));
        fs::read_to_string(out).unwrap()
    };
    let want = fit(&["--landmarks", &l_csv], "csv.json");
    let got = fit(&["--landmarks-src", &a_pts, "--landmarks-dst", &b_txt], "1.json");
    assert!(got == want, "pts + ITK differs from the CSV fit");
    let got = fit(&["--landmarks-src", &a_pts, "--landmarks-dst", &b_csv], "2.json");
    assert!(got == want, "pts + CSV x,y differs from the CSV fit");

    // Refused: different counts (both files named), a malformed point (file, line, point),
    // and the options that exclude each other.
    let (short, bad) = (p("short.csv"), p("bad.pts"));
    fs::write(&short, "1,2\n3,4\n").unwrap();
    fs::write(&bad, "version: 1\nn_points: 2\n{\n1 2\n3\n}\n").unwrap();
    let out = p("refused.json");
    let cases: [(Vec<&str>, Vec<&str>); 5] = [
        (
            vec!["--landmarks-src", &a_pts, "--landmarks-dst", &short],
            vec!["a.pts has 12 points and", "short.csv has 2"],
        ),
        (
            vec!["--landmarks-src", &bad, "--landmarks-dst", &short],
            vec!["bad.pts: line 5: point 1: expected two numbers"],
        ),
        (vec!["--landmarks", &l_csv, "--landmarks-src", &a_pts], vec!["--landmarks-src"]),
        (vec!["--landmarks-src", &a_pts], vec!["--landmarks-dst"]),
        (vec!["--landmarks-dst", &b_txt], vec!["--landmarks-src"]),
    ];
    for (extra, msgs) in cases {
        let mut a = vec!["fit", "--size", "200,150", "-o", &out];
        a.extend_from_slice(&extra);
        let o = trimorph(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{extra:?}: {err}");
        for m in msgs {
            assert!(err.contains(m), "{extra:?}: expected `{m}` in: {err}");
        }
        assert!(!Path::new(&out).exists());
    }
    // A sequence reads landmark files (or a folder of them) only.
    let o = trimorph(&[
        "fit",
        "--model",
        &l_csv,
        "--frames",
        s(dir.path()),
        "--landmarks-src",
        &a_pts,
        "--landmarks-dst",
        &b_txt,
        "-o",
        &p("seq"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("--frames") && err.contains("--landmarks-src"), "{err}");
}

/// Issue 52: landmarks on the frame's outer edge are accepted: half a pixel past the last
/// pixel centre (`x = w - 0.5`, the frame's edge) and one pixel past it (`x = w`, as ITK
/// files write the far edge; a 1-based `.pts` point at `w + 1`); `x = w + 1.5` is refused,
/// naming the landmark and the file.
#[test]
fn border_landmarks_are_accepted_up_to_one_pixel_past_the_last_centre() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let inner = "10 10\n200 15\n110 150\n30 120\n";
    let src = |last: &str| format!("point\n5\n{inner}{last}\n");
    let dst = p("dst.txt");
    fs::write(&dst, "point\n5\n12 11\n198 17\n111 148\n31 118\n219 80\n").unwrap();
    let rep = p("rep.json");
    for (name, last) in [("half", "220.5 80"), ("edge", "221 80"), ("corner", "221 160")] {
        let (f, out) = (p(&format!("{name}.txt")), p(&format!("{name}.json")));
        fs::write(&f, src(last)).unwrap();
        let size = ["fit", "--size", "221,160", "-o", &out, "--report", &rep];
        ok(&trimorph(&[&size[..], &["--landmarks-src", &f, "--landmarks-dst", &dst]].concat()));
        let r: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(&rep).unwrap()).unwrap();
        assert_eq!(r["fold_free"], true, "{name}: {r}");
        assert!(r["fit"]["max"].as_f64().unwrap() < 1.0, "{name}: {r}");
    }
    // The same edge in a 1-based .pts (222 = 221 + 1), with --margin 0: the domain still
    // holds the landmark (the margin grows to it).
    let pts = p("edge.pts");
    fs::write(&pts, "version: 1\nn_points: 5\n{\n11 11\n201 16\n111 151\n31 121\n222 81\n}\n")
        .unwrap();
    let out = p("pts.json");
    let a = ["fit", "--size", "221,160", "--margin", "0", "-o", &out, "--report", &rep];
    ok(&trimorph(&[&a[..], &["--landmarks-src", &pts, "--landmarks-dst", &dst]].concat()));
    let r: serde_json::Value = serde_json::from_str(&fs::read_to_string(&rep).unwrap()).unwrap();
    assert_eq!(r["frame"]["margin"], 0.5, "{r}");
    // One and a half pixels past the last centre is refused, naming the landmark; the same
    // point in a landmark CSV too.
    let (far, far_csv) = (p("far.txt"), p("far.csv"));
    fs::write(&far, src("222.5 80")).unwrap();
    let csv = "name,src_x,src_y,dst_x,dst_y\na,10,10,12,11\nb,200,15,198,17\nc,110,150,111,148\n\
               d,30,120,31,118\ne,222.5,80,219,80\n";
    fs::write(&far_csv, csv).unwrap();
    for (landmarks, file, which) in [
        (vec!["--landmarks-src", &far, "--landmarks-dst", &dst], "far.txt and ", "landmark 4 (-)"),
        (vec!["--landmarks", &far_csv], "far.csv", "landmark 4 (e)"),
    ] {
        let out = p("far.json");
        let a = ["fit", "--size", "221,160", "-o", &out];
        let o = trimorph(&[&a[..], &landmarks].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(file) && err.contains(which), "{err}");
        assert!(err.contains("(222.5, 80) lies outside the 221 x 160 frame"), "{err}");
        assert!(!Path::new(&out).exists());
    }
}

//! Morphing the bundled real pair `data/morph/` (A 184 x 184 RGB8, B 250 x 230 grey16, B
//! rotated and scaled against A; see `data/SOURCES.md`): alignment, full coverage,
//! certified fold-free frames, the exact C1 blend, the output type, and smoothness against
//! the classic Delaunay morph (`tests/common/delaunay.rs`).

mod common;

use common::delaunay::{crease, morph_frame, Grey};
use image::DynamicImage;
use std::path::{Path, PathBuf};
use trimorph::exact::Rat;
use trimorph::fit::landmarks::Landmark;
use trimorph::io::landmarks::read_landmarks;
use trimorph::morph::{frame_times_exact, Morph, MorphOptions};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/morph").join(name)
}

fn pair() -> (DynamicImage, DynamicImage, Vec<Landmark>) {
    let a = image::open(data("nuclei_a.png")).unwrap();
    let b = image::open(data("nuclei_b.png")).unwrap();
    (a, b, read_landmarks(&data("nuclei_landmarks.csv")).unwrap())
}

/// The pair's similarity is the one the bundled B was made with, up to the nuclei's own
/// motion between frames 0 and 9 (`examples/make_morph_pair.rs`: scale 0.6 / (184 / 511)
/// from A's pixels to B's, rotation 12 degrees, so B -> A has scale 0.600 and -12 degrees).
#[test]
fn the_real_pair_is_aligned_by_a_similarity_near_the_one_b_was_made_with() {
    let (a, b, lms) = pair();
    let m = Morph::new(&a, &b, &lms, &MorphOptions::default()).unwrap();
    let r = m.similarity().report();
    let want = (184.0 / 511.0) / 0.6;
    assert!((r.scale - want).abs() < 0.03 * want, "{r:?}");
    assert!((r.rotation_deg + 12.0).abs() < 3.0, "{r:?}");
    // Without alignment the maps run in B's raw coordinates.
    let raw = Morph::new(&a, &b, &lms, &MorphOptions { align: false, ..MorphOptions::default() })
        .unwrap();
    assert!(raw.similarity().is_identity());
}

/// Every frame is covered (with `--mode edge`, where the dissolve of edge-clamped samples
/// fills the pixels neither image has on its pixels), certified fold-free and exactly C1. In
/// the default constant mode those pixels show the background instead, and every other
/// pixel is the same.
#[test]
fn every_frame_of_the_real_pair_is_covered_fold_free_and_exactly_c1() {
    let (a, b, lms) = pair();
    let edge = MorphOptions { mode: trimorph::warp::EdgeMode::Edge, ..MorphOptions::default() };
    let m = Morph::new(&a, &b, &lms, &edge).unwrap();
    let constant = Morph::new(&a, &b, &lms, &MorphOptions::default()).unwrap();
    let [ab, ba] = m.fit_summaries().unwrap().clone();
    assert!(ab.fold_free && ba.fold_free && ab.covers_frame && ba.covers_frame, "{ab:?} {ba:?}");
    // One certificate covers every frame with s in [0, 1] (the CLI then skips the per-frame
    // certificates); the per-frame certificates below agree with it.
    assert_eq!(m.certify_blends(), [true, true]);
    for t in frame_times_exact(11) {
        let (f, st) = m.frame_with_stats(&t).unwrap();
        assert_eq!((f.width(), f.height()), (184, 184));
        assert_eq!(st.uncovered, 0, "t = {t}: {st:?}");
        let (g, sc) = constant.frame_with_stats(&t).unwrap();
        let (f16, g16) = (f.to_rgb16(), g.to_rgb16());
        let differ = f16.pixels().zip(g16.pixels()).filter(|(x, y)| x != y).count();
        let background = g16.pixels().zip(f16.pixels()).filter(|(y, x)| x != y && y.0 == [0; 3]);
        assert_eq!(differ, background.count(), "t = {t}: only uncovered pixels change");
        assert!(differ <= sc.uncovered, "t = {t}: {differ} > {sc:?}");
        let c = m.check_frame(&t).unwrap();
        assert!(c.fold_free[0] && c.fold_free[1], "t = {t}: {c:?}");
        assert!(c.covers_frame[0], "t = {t}: {c:?}");
        // The blends are exactly C1 (re-checked in rationals).
        m.phi_a_exact(&t).unwrap().check_c1().unwrap();
        m.phi_b_exact(&t).unwrap().check_c1().unwrap();
    }
}

#[test]
fn the_richer_type_wins_rgb8_and_grey16_give_rgb16() {
    let (a, b, lms) = pair();
    assert_eq!((a.color(), b.color()), (image::ColorType::Rgb8, image::ColorType::L16));
    let m = Morph::new(&a, &b, &lms, &MorphOptions::default()).unwrap();
    let f = m.frame(0.5).unwrap();
    assert_eq!(f.color(), image::ColorType::Rgb16);
    // Frame 0 is A, exactly up to the 8 -> 16 bit scaling (x 257) and one level.
    let f0 = m.frame(0.0).unwrap().to_rgb16();
    let a16 = a.to_rgb16();
    let worst = f0.as_raw().iter().zip(a16.as_raw()).map(|(x, y)| x.abs_diff(*y)).max().unwrap();
    assert!(worst <= 257, "frame 0 differs from A by {worst} / 65535");
}

/// A ramp `r(q) = (0.7 q_x + 0.3 q_y) / 300` in `A`'s frame coordinates, as `A` (`w x h`)
/// and, through the similarity, as `B` (`r(S(p))` over `B`'s pixels).
fn ramps(m: &Morph, a: &DynamicImage, b: &DynamicImage) -> (DynamicImage, DynamicImage) {
    let r = |q: [f64; 2]| ((0.7 * q[0] + 0.3 * q[1]) / 300.0) as f32;
    let ra = image::Rgb32FImage::from_fn(a.width(), a.height(), |x, y| {
        let v = r([f64::from(x), f64::from(y)]);
        image::Rgb([v, v, v])
    });
    let s = m.similarity().clone();
    let rb = image::Rgb32FImage::from_fn(b.width(), b.height(), |x, y| {
        let v = r(s.apply([f64::from(x), f64::from(y)]));
        image::Rgb([v, v, v])
    });
    (ra.into(), rb.into())
}

/// The quality figure: the gradient-magnitude jump across the Delaunay baseline's
/// triangle edges, trimorph against the baseline, on the real pair at t = 0.5 and on a ramp
/// carried through the same maps (where every jump is the warp's crease).
#[test]
fn trimorph_frames_are_smoother_than_the_delaunay_baseline_across_its_edges() {
    let (a, b, lms) = pair();
    let m = Morph::new(&a, &b, &lms, &MorphOptions::default()).unwrap();
    let s = m.similarity().clone();
    let la: Vec<[f64; 2]> = lms.iter().map(|l| l.src).collect();
    let lb: Vec<[f64; 2]> = lms.iter().map(|l| l.dst).collect();
    let half = frame_times_exact(3)[1].clone();
    let mut figures = Vec::new();
    for (name, (ia, ib)) in [("real", (a.clone(), b.clone())), ("ramp", ramps(&m, &a, &b))] {
        let mm = if name == "real" {
            m.clone()
        } else {
            Morph::new(&ia, &ib, &lms, &MorphOptions::default()).unwrap()
        };
        let tri = Grey::of(&mm.frame_exact(&half).unwrap());
        let base = morph_frame(
            &Grey::of(&ia),
            &Grey::of(&ib),
            &la,
            &lb,
            |p| s.apply(p),
            |p| s.inverse(p),
            0.5,
        );
        let (ct, cb) = (
            crease(&tri, &base.vertices, &base.triangles, 2.0),
            crease(&base.frame, &base.vertices, &base.triangles, 2.0),
        );
        println!("{name}: gradient-magnitude jump across the baseline's edges: trimorph {ct:.6}, Delaunay {cb:.6} (ratio {:.3})", ct / cb);
        figures.push((name, ct, cb));
        // Full coverage: the baseline's ring spans the frame, and so do trimorph's maps.
        assert!(tri.v.iter().all(|v| v.is_finite()));
    }
    // The ramp figure is printed, not asserted: on it trimorph measures *higher* than the
    // baseline (0.000092 vs 0.000034 on the bundled pair), see the report.
    let (_, qt, qb) = figures[0];
    assert!(qt < qb, "real pair: trimorph {qt} vs baseline {qb}");
}

/// Two neighbouring landmarks whose targets swap force a fold: both fits stay certified
/// fold-free and name the crossing pair.
#[test]
fn crossing_landmarks_are_named_and_the_morph_stays_fold_free() {
    let (a, b, mut lms) = pair();
    // track3 and track5 are neighbours; swap their targets.
    let (i, j) = (
        lms.iter().position(|l| l.name.as_deref() == Some("track3")).unwrap(),
        lms.iter().position(|l| l.name.as_deref() == Some("track5")).unwrap(),
    );
    let (di, dj) = (lms[i].dst, lms[j].dst);
    lms[i].dst = dj;
    lms[j].dst = di;
    let m = Morph::new(&a, &b, &lms, &MorphOptions::default()).unwrap();
    let [ab, ba] = m.fit_summaries().unwrap().clone();
    assert!(ab.fold_free && ba.fold_free);
    let named = |c: &[[String; 2]]| {
        c.iter().any(|p| {
            p.iter().any(|n| n.contains("track3")) && p.iter().any(|n| n.contains("track5"))
        })
    };
    assert!(named(&ab.conflicts) || named(&ba.conflicts), "{:?} {:?}", ab.conflicts, ba.conflicts);
    // Both fits are certified, but a blend of them need not be: here some middle frames'
    // maps are not certified fold-free (the CLI warns with their times). Printed, and the end
    // frames (the fits themselves) asserted.
    // The family certificate cannot hold when a middle frame is not fold-free.
    let family = m.certify_blends();
    for t in frame_times_exact(5) {
        let c = m.check_frame(&t).unwrap();
        println!("t = {t}: {c:?} (family {family:?})");
        assert!(!family[0] || c.fold_free[0], "t = {t}: {c:?}");
        assert!(!family[1] || c.fold_free[1], "t = {t}: {c:?}");
        if t == Rat::from_integer(0.into()) || t == Rat::from_integer(1.into()) {
            assert!(c.fold_free[0] && c.fold_free[1], "t = {t}: {c:?}");
        }
    }
}

/// The README's contact sheets of trimorph and of the Delaunay baseline on the real pair
/// (11 frames) are current: made again here, each equals `docs/img/`'s within 2 grey levels
/// on all but 0.1 % of its values. With `TRIMORPH_DOC_IMAGES` set, writes them there instead.
#[test]
fn doc_images_of_the_real_pair() {
    use trimorph::morph::frame_times;
    use trimorph::morph::output::contact_sheet;
    let (a, b, lms) = pair();
    let m = Morph::new(&a, &b, &lms, &MorphOptions::default()).unwrap();
    let s = m.similarity().clone();
    let la: Vec<[f64; 2]> = lms.iter().map(|l| l.src).collect();
    let lb: Vec<[f64; 2]> = lms.iter().map(|l| l.dst).collect();
    let (ga, gb) = (Grey::of(&a), Grey::of(&b));
    let times = frame_times(11);
    let frames = m.frames(11, &|| {}).unwrap();
    let base: Vec<DynamicImage> = times
        .iter()
        .map(|&t| {
            let f = morph_frame(&ga, &gb, &la, &lb, |p| s.apply(p), |p| s.inverse(p), t).frame;
            let px: Vec<u8> =
                f.v.iter().map(|v| (v * 255.0).round().clamp(0.0, 255.0) as u8).collect();
            image::GrayImage::from_raw(f.w as u32, f.h as u32, px).unwrap().into()
        })
        .collect();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/img");
    let update = std::env::var_os("TRIMORPH_DOC_IMAGES").is_some();
    for (name, fr) in [("morph_real_contact.png", &frames), ("morph_delaunay_contact.png", &base)] {
        let sheet = contact_sheet(fr, &times, 6, 160).unwrap();
        if update {
            sheet.save_png(dir.join(name)).unwrap();
            continue;
        }
        let committed = image::open(dir.join(name)).unwrap().to_rgba8();
        assert_eq!(
            (committed.width(), committed.height()),
            (sheet.width(), sheet.height()),
            "{name}"
        );
        let off = committed
            .as_raw()
            .iter()
            .zip(sheet.data())
            .filter(|(a, b)| (i16::from(**a) - i16::from(**b)).abs() > 2)
            .count();
        assert!(
            off * 1000 <= committed.as_raw().len(),
            "docs/img/{name} is stale ({off} values differ): run TRIMORPH_DOC_IMAGES=1 cargo test \
             --test morph_real doc_images_of_the_real_pair"
        );
    }
}

/// The library writes a morph's folder as `trimorph morph` does: frames, animations, sheet
/// and the two deformations, which read back into the same morph; a second write with fewer
/// frames leaves no stale frame, and a refused write leaves the folder as it was.
#[test]
fn write_morph_writes_the_folder_all_or_nothing_and_the_deformations_read_back() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use trimorph::io::deformation;
    use trimorph::jobs::morph::{write_morph, MorphFileOptions, MorphFilesError};
    use trimorph::morph::align::{Similarity, SIMILARITY_KEY};
    let (a, b, lms) = pair();
    let edge = MorphOptions { mode: trimorph::warp::EdgeMode::Edge, ..MorphOptions::default() };
    let m = Morph::new(&a, &b, &lms, &edge).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m");
    let calls = AtomicUsize::new(0);
    let rep = write_morph(&m, &MorphFileOptions::new(&out, 5), &|| {
        calls.fetch_add(1, Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!(calls.load(Ordering::Relaxed), 5);
    assert!(rep.uncertified.is_empty() && rep.uncovered == 0, "{rep:?}");
    assert!(rep.largest_residual < 1.0, "{rep:?}");
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let mut want: Vec<String> = (0..5).map(|k| format!("frame_{k:03}.png")).collect();
    want.extend(
        ["contact-sheet.png", "morph.apng", "morph.gif", "phi_ab.json", "phi_ba.json"]
            .map(String::from),
    );
    want.sort();
    assert_eq!(names(&out), want);
    // The last frame is B in A's frame: the same as the library's own frame at t = 1.
    let last = image::open(out.join("frame_004.png")).unwrap();
    let (f1, _) = m.frame_with_stats(&frame_times_exact(2)[1]).unwrap();
    assert_eq!(last.to_rgb8(), f1.to_rgb8());
    // phi_ab.json holds phi_{A->B} exactly and the similarity: reading both back gives the
    // same morph (the same middle frame).
    let text = std::fs::read_to_string(out.join("phi_ab.json")).unwrap();
    let (ab, _) = deformation::from_str(&text).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let sim: Similarity = serde_json::from_value(doc[SIMILARITY_KEY].clone()).unwrap();
    let (ba, _) =
        deformation::from_str(&std::fs::read_to_string(out.join("phi_ba.json")).unwrap()).unwrap();
    let again = Morph::from_deformations_with(&a, &b, ab, Some(ba), Some(sim), &edge).unwrap();
    let half = frame_times_exact(3)[1].clone();
    assert_eq!(again.frame_with_stats(&half).unwrap().0, m.frame_with_stats(&half).unwrap().0);
    // Fewer frames: no stale frame_003/004.
    write_morph(&m, &MorphFileOptions::new(&out, 3), &|| {}).unwrap();
    assert_eq!(names(&out).iter().filter(|n| n.starts_with("frame_")).count(), 3);
    // A refused write (one frame) changes nothing.
    let before = std::fs::read(out.join("frame_001.png")).unwrap();
    let e = write_morph(&m, &MorphFileOptions::new(&out, 1), &|| {}).unwrap_err();
    assert!(
        matches!(e, MorphFilesError::TooFewFrames { frames: 1 })
            && e.to_string().contains("--frames"),
        "{e}"
    );
    assert_eq!(std::fs::read(out.join("frame_001.png")).unwrap(), before);
    assert_eq!(names(&out).len(), 8);
}

//! Unit tests of [`super`]: the warm-start rules, the reference, shards, keys, refusals.

use super::*;

fn frame(name: &str, w: u32, h: u32) -> Frame {
    let seed = name.bytes().map(u32::from).sum::<u32>();
    let img = image::GrayImage::from_fn(w, h, |x, y| image::Luma([(x * 7 + y * 3 + seed) as u8]));
    Frame::new(name, format!("dir/{name}.png"), image::DynamicImage::ImageLuma8(img))
}

#[test]
fn warm_start_sources_follow_the_rules_on_both_sides() {
    let r = 5;
    let src = |w: WarmStart| (0..12).map(|k| w.source(k, r)).collect::<Vec<_>>();
    // Chain: the neighbour towards the reference; the reference's neighbours start from
    // their own pre-alignment.
    assert_eq!(
        src(WarmStart::Chain),
        [
            Some(1),
            Some(2),
            Some(3),
            Some(4),
            None,
            None,
            None,
            Some(6),
            Some(7),
            Some(8),
            Some(9),
            Some(10)
        ]
    );
    // Key frames every 3 from the reference: 8 and 11 (and 2) are key frames.
    assert_eq!(
        src(WarmStart::KeyFrames(3)),
        [Some(2), Some(2), None, None, None, None, None, None, None, Some(8), Some(8), Some(8)]
    );
    assert!(src(WarmStart::None).iter().all(Option::is_none));
    // A source is always nearer the reference than its frame, on the same side.
    for w in [WarmStart::Chain, WarmStart::KeyFrames(2), WarmStart::KeyFrames(4)] {
        for k in 0..12 {
            if let Some(s) = w.source(k, r) {
                assert!(s.abs_diff(r) < k.abs_diff(r) && (s > r) == (k > r), "{w} {k} {s}");
            }
        }
    }
}

#[test]
fn warm_start_names_and_key_spacing_are_checked() {
    assert_eq!(WarmStart::from_name("chain", None).unwrap(), WarmStart::Chain);
    assert_eq!(WarmStart::from_name("none", None).unwrap(), WarmStart::None);
    assert_eq!(WarmStart::from_name("keyframes", Some(4)).unwrap(), WarmStart::KeyFrames(4));
    for (name, every, says) in [
        ("keyframes", None, "needs --key-every"),
        ("keyframes", Some(0), "at least 1"),
        ("chain", Some(3), "goes with --warm-start keyframes"),
        ("first", None, "unknown rule `first`"),
    ] {
        let e = WarmStart::from_name(name, every).unwrap_err().to_string();
        assert!(e.contains(says), "{name} {every:?}: {e}");
    }
    for n in WarmStart::NAMES {
        let every = (n == "keyframes").then_some(2);
        assert!(WarmStart::from_name(n, every).is_ok(), "{n}");
    }
}

#[test]
fn the_reference_is_found_by_name_file_or_index() {
    let frames = [frame("a", 20, 20), frame("b", 20, 20), frame("7", 20, 20)];
    assert_eq!(find_reference(&frames, "b").unwrap(), 1);
    assert_eq!(find_reference(&frames, "b.png").unwrap(), 1);
    assert_eq!(find_reference(&frames, "0").unwrap(), 0);
    // A name wins over an index.
    assert_eq!(find_reference(&frames, "7").unwrap(), 2);
    let e = find_reference(&frames, "3").unwrap_err().to_string();
    assert!(e.contains("--reference 3") && e.contains("a, b, 7"), "{e}");
}

#[test]
fn a_shard_runs_its_frames_outwards_from_the_reference() {
    let frames: Vec<Frame> = (0..7).map(|k| frame(&format!("f{k}"), 20, 20)).collect();
    let opts = |shard| FramesOptions { reference: 3, shard, ..FramesOptions::default() };
    let all = RegisterFrames::new(&frames, opts(None)).unwrap();
    assert_eq!(all.order(), [3, 4, 5, 6, 2, 1, 0]);
    let s = RegisterFrames::new(&frames, opts(Some((1, 3)))).unwrap();
    assert_eq!(s.range(), (2, 4));
    assert_eq!(s.order(), [3, 2]);
    assert!(RegisterFrames::new(&frames, opts(Some((3, 3)))).is_err());
    // Keys differ by frame and by option, not by run.
    assert_eq!(all.key(4), RegisterFrames::new(&frames, opts(None)).unwrap().key(4));
    assert_eq!(all.key(4).changed(&all.key(5)), ["frame", "frame_pixels"]);
    let mut o = opts(None);
    o.register.bend = 3.0;
    assert_eq!(RegisterFrames::new(&frames, o).unwrap().key(4).changed(&all.key(4)), ["options"]);
}

#[test]
fn bad_sequences_are_refused_before_anything_runs() {
    let two = [frame("a", 20, 20), frame("b", 20, 20)];
    let one = &two[..1];
    assert!(RegisterFrames::new(one, FramesOptions::default()).is_err());
    let o = FramesOptions { reference: 2, ..FramesOptions::default() };
    assert!(RegisterFrames::new(&two, o).is_err());
    let small = [frame("a", 20, 20), frame("b", 20, 12)];
    let e = RegisterFrames::new(&small, FramesOptions::default()).err().unwrap().to_string();
    assert!(e.contains("dir/b.png") && e.contains("too small"), "{e}");
    let mask = Mask { w: 20, h: 19, on: vec![true; 380] };
    let o = FramesOptions {
        mask_moving: Some((mask, PathBuf::from("m.png"))),
        ..FramesOptions::default()
    };
    let e = RegisterFrames::new(&two, o).err().unwrap().to_string();
    assert!(e.contains("m.png") && e.contains("dir/b.png"), "{e}");
    let mut o = FramesOptions::default();
    o.register.hard = true;
    assert!(RegisterFrames::new(&two, o).is_err());
    let same = [frame("a", 20, 20), frame("a", 20, 20)];
    assert!(RegisterFrames::new(&same, FramesOptions::default()).is_err());
}

/// Bug found in session 42: the stored report was read through `#[serde(flatten)]`, which
/// cannot read numbers with serde_json's `arbitrary_precision`; every rerun then took the
/// reports for unkeyed ones and registered every frame again.
#[test]
fn a_stored_report_reads_back_its_key_and_figures() {
    let frames = [frame("a", 20, 20), frame("b", 20, 20)];
    let seq = RegisterFrames::new(&frames, FramesOptions::default()).unwrap();
    let mesh = super::super::frame_mesh(20, 20, 10.0).unwrap();
    let result = FrameRegistration {
        index: 0,
        frame: "a".into(),
        reference: "a".into(),
        spline: Spline::identity(mesh, 5).unwrap(),
        report: None,
        warm_start: None,
        key: seq.key(0),
    };
    let stored = StoredFrame { report: Some(result.report_text()), ..StoredFrame::default() };
    let (key, figures) = stored.parsed().unwrap();
    assert_eq!(key.unwrap(), seq.key(0));
    assert_eq!(figures.fold_free, Some(true));
    assert_eq!(figures.det_j_lower_bound, Some(1.0));
}

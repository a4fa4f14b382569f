//! Edit-script tests: each operation kind, the error of every malformed field naming the
//! operation index and key, all-or-nothing runs, and the JSON round trip.

use super::*;
use crate::exact::{parse_rat, rat_int};
use crate::mesh::{Mesh, MeshOptions};
use crate::spline::{ControlPoint, Spline, ZLayers};
use proptest::prelude::*;
use serde_json::json;

/// An identity quintic over a 2 x 2 grid of 8 x 8 pixels (as the fuzz target).
fn editor() -> Editor {
    let mesh = Mesh::grid(2, 2, 8.0, 8.0, MeshOptions { grid: 16 }).unwrap();
    Editor::new(Spline::identity(mesh, 5).unwrap())
}

/// A point in the middle of the grid (an interior vertex).
fn centre(ed: &Editor) -> usize {
    ed.nearest_points(&[[4.0, 4.0]])[0].index()
}

fn parse_err(v: Value) -> String {
    Script::from_value(&v).unwrap_err().to_string()
}

#[test]
fn translate_moves_the_anchor_exactly_and_reports_the_selection() {
    let mut ed = editor();
    let c = centre(&ed);
    let s = Script::from_value(&json!([
        {"anchors": [c], "neighborhood": 1, "op": "translate", "by": [12.5, "-7/2"]}
    ]))
    .unwrap();
    let r = s.run(&mut ed).unwrap();
    assert_eq!(
        ed.spline().points()[c],
        vec![rat_int(4) + parse_rat("12.5").unwrap(), rat_int(4) + parse_rat("-7/2").unwrap()]
    );
    ed.spline().check_c1().unwrap();
    let OpReport::Moved { anchors, derived, strong, .. } = &r[0] else { panic!("{r:?}") };
    assert_eq!(anchors, &vec![ControlPoint(c)]);
    assert!(!derived.is_empty() && *strong);
    assert_eq!(last_edit(&r).unwrap().anchors, vec![ControlPoint(c)]);
    // Control points are bare indices in JSON, in scripts and in reports.
    assert_eq!(serde_json::to_value(&r[0]).unwrap()["anchors"], json!([c]));
    let op = &s.ops[0];
    assert!(
        matches!(op, Op::Move { target, .. } if target.anchors == Anchors::Points(vec![ControlPoint(c)]))
    );
    assert_eq!(op.to_value()["anchors"], json!([c]));
    let with_derived = json!({"anchors": [c], "derived": [1, 2], "op": "translate", "by": [1, 0]});
    let Op::Move { target, .. } = Op::from_value(&with_derived).unwrap() else { panic!() };
    assert_eq!(target.derived, vec![ControlPoint(1), ControlPoint(2)]);
    assert_eq!(
        Op::Move {
            target,
            motion: Motion::Translate(Translate { by: vec![rat_int(1), rat_int(0)] })
        }
        .to_value()["derived"],
        json!([1, 2])
    );
}

#[test]
fn the_server_spelling_v_is_the_same_translation() {
    let a: Op =
        serde_json::from_value(json!({"anchors": [3], "op": "translate", "v": [1, 2]})).unwrap();
    let b: Op =
        serde_json::from_value(json!({"anchors": [3], "op": "translate", "by": [1, 2]})).unwrap();
    assert_eq!(a, b);
    let m = Motion::<f64>::from_value(&json!({"op": "translate", "v": [0.5, 2]})).unwrap();
    assert_eq!(m, Motion::Translate(Translate { by: vec![0.5, 2.0] }));
}

#[test]
fn rotate_and_scale_keep_c1_and_move_the_anchors_exactly() {
    let mut ed = editor();
    let c = centre(&ed);
    let s = Script::from_value(&json!([
        {"anchors": [c], "op": "rotate", "center": [0, 0], "angle": std::f64::consts::PI},
        {"anchors": [c], "neighborhood": "all", "op": "scale", "center": [0, 0], "factor": "1/2"}
    ]))
    .unwrap();
    s.run(&mut ed).unwrap();
    ed.spline().check_c1().unwrap();
    // The scale starts from the rotated position (-4, -4): half of it.
    assert_eq!(ed.spline().points()[c], vec![rat_int(-2), rat_int(-2)]);
}

#[test]
fn near_anchors_are_found_in_the_current_spline() {
    let mut ed = editor();
    let c = centre(&ed);
    let s = Script::from_value(&json!([
        {"anchors": [c], "op": "translate", "by": [1, 0]},
        {"anchors": {"near": [[5, 4], [5, 4]]}, "op": "translate", "by": [1, 0]}
    ]))
    .unwrap();
    let r = s.run(&mut ed).unwrap();
    // The repeated position gives one anchor: the moved centre.
    assert_eq!(r[1].last_edit().unwrap().anchors, vec![ControlPoint(c)]);
    assert_eq!(ed.spline().points()[c][0], rat_int(6));
}

#[test]
fn z_modes_edit_the_layers() {
    let mut ed = editor();
    let n = ed.spline().num_points();
    let mut s = ed.spline().clone();
    s.set_z_layers(Some(ZLayers {
        z0: vec![rat_int(-1); n],
        z1: vec![rat_int(1); n],
        range: [rat_int(-1), rat_int(1)],
    }));
    ed = Editor::new(s);
    let c = centre(&ed);
    let script =
        Script::from_value(&json!([{"anchors": [c], "mode": "z1", "op": "translate", "by": [3]}]))
            .unwrap();
    script.run(&mut ed).unwrap();
    assert_eq!(ed.spline().z_layers().unwrap().z1[c], rat_int(4));
    assert_eq!(ed.spline().points()[c], vec![rat_int(4), rat_int(4)]);
}

#[test]
fn constrain_adds_constraints_and_pinned_points_refuse_to_move() {
    let mut ed = editor();
    let c = centre(&ed);
    let s = Script::from_value(&json!([{"op": "constrain", "pin": [c]}])).unwrap();
    let r = s.run(&mut ed).unwrap();
    assert_eq!(r, vec![OpReport::Constrained { added: 1, in_force: 1 }]);
    let e = Script::from_value(&json!([{"op": "translate", "anchors": [c], "by": [1, 0]}]))
        .unwrap()
        .run(&mut ed)
        .unwrap_err();
    assert!(e.is_unsolvable(), "{e}");
    assert_eq!(e.index(), Some(0));
    assert!(e.to_string().starts_with("operation 0 (translate): not weakly solvable"), "{e}");
}

#[test]
fn a_failed_operation_leaves_the_editor_as_before_the_script() {
    let mut ed = editor();
    let c = centre(&ed);
    let before = ed.spline().points().to_vec();
    let s = Script::from_value(&json!([
        {"op": "translate", "anchors": [c], "by": [1, 0]},
        {"op": "constrain", "pin": [0]},
        {"op": "translate", "anchors": [c], "by": [1]}
    ]))
    .unwrap();
    let e = s.run(&mut ed).unwrap_err();
    assert_eq!(e.index(), Some(2));
    assert!(e.to_string().contains("2 values"), "{e}");
    assert_eq!(ed.spline().points(), &before[..]);
    assert!(ed.constraints().is_empty());
    assert!(ed.selection().is_none());
    // The progress callback saw the operations that ran before the failure.
    let mut seen = Vec::new();
    let _ = run_script(&mut ed, &s.ops, &mut |k, _| seen.push(k));
    assert_eq!(seen, vec![0, 1]);
}

#[test]
fn malformed_operations_name_their_index_and_key() {
    let cases = [
        (
            json!([{"op": "translate", "anchors": [0], "by": ["NaN", 0]}]),
            "operation 0: by: `NaN` is not an exact number",
        ),
        (
            json!([{"op": "translate", "anchors": [0], "by": 3}]),
            "operation 0: by: expected an array of numbers",
        ),
        (json!([{"op": "translate", "anchors": [0]}]), "operation 0: translate needs \"by\""),
        (
            json!([{"anchors": [0], "op": "translate", "by": [1, 1]}, {"op": "shear", "anchors": [0]}]),
            "operation 1: unknown op `shear` (use translate, rotate or scale)",
        ),
        (json!([{"anchors": [0], "by": [1, 1]}]), "operation 0: missing \"op\""),
        (json!([{"op": "translate", "by": [1, 1]}]), "operation 0: missing \"anchors\""),
        (
            json!([{"op": "translate", "anchors": [1.5], "by": [1, 1]}]),
            "operation 0: anchors: `1.5` is not a point index",
        ),
        (
            json!([{"op": "translate", "anchors": {"far": 1}, "by": [1, 1]}]),
            "operation 0: anchors: expected {\"near\"",
        ),
        (
            json!([{"op": "translate", "anchors": {"near": [[1]]}, "by": [1, 1]}]),
            "operation 0: anchors: near: `[1]` is not [x, y]",
        ),
        (
            json!([{"op": "translate", "anchors": [0], "derived": 4, "by": [1, 1]}]),
            "operation 0: derived: expected an array, found 4",
        ),
        (
            json!([{"op": "translate", "anchors": [0], "neighborhood": -1, "by": [1, 1]}]),
            "operation 0: neighborhood: expected a whole number or \"all\"",
        ),
        (
            json!([{"op": "translate", "anchors": [0], "mode": "zz", "by": [1, 1]}]),
            "operation 0: mode: unknown mode `zz`",
        ),
        (
            json!([{"op": "rotate", "anchors": [0], "center": [1, 2, 3], "angle": 1}]),
            "operation 0: center: expected [x, y]",
        ),
        (
            json!([{"op": "rotate", "anchors": [0], "center": [1, 2], "angle": "x"}]),
            "operation 0: angle: expected a number (radians)",
        ),
        (
            json!([{"op": "scale", "anchors": [0], "center": [1, 2], "factor": true}]),
            "operation 0: factor: `true` is not a number",
        ),
        (json!([{"op": "constrain"}]), "operation 0 (constrain): no constraint given"),
        (
            json!([{"op": "constrain", "pin": "x"}]),
            "operation 0 (constrain): pin: expected an array of point indices",
        ),
        (
            json!([{"op": "constrain", "horizontal": 1}]),
            "operation 0 (constrain): horizontal: expected an array of index lists, found 1",
        ),
        (
            json!([{"op": "constrain", "equal_displacement": [[1, 2, 3]]}]),
            "operation 0 (constrain): equal_displacement: each entry is [a, b]",
        ),
        (json!([7]), "operation 0: expected an object"),
    ];
    for (v, want) in cases {
        let got = parse_err(v.clone());
        assert!(got.starts_with(want), "{v}: `{got}` does not start with `{want}`");
    }
    assert_eq!(parse_err(json!({"op": "translate"})), ScriptError::NotArray.to_string());
    let e = Script::from_json_str("[{\"op\": \"translate\",").unwrap_err();
    assert!(matches!(e, ScriptError::Json { line: 1, .. }), "{e}");
    assert!(e.to_string().contains("EOF while parsing"), "{e}");
}

/// serde's wording for a missing field, which [`read`] turns into `KIND needs "KEY"`.
#[test]
fn serde_missing_field_wording_is_recognised() {
    let e = read::<Scale<Rat>>(&json!({"center": [1, 2]}), "scale").unwrap_err();
    assert_eq!(e.to_string(), "scale needs \"factor\"");
}

#[test]
fn constraint_errors_name_the_operation() {
    let mut ed = editor();
    let e = Script::from_value(&json!([{"op": "constrain", "horizontal": [[0]]}]))
        .unwrap()
        .run(&mut ed)
        .unwrap_err();
    assert!(matches!(e, ScriptError::Constraint { index: 0, .. }), "{e}");
    assert!(e.to_string().starts_with("operation 0 (constrain): "), "{e}");
    assert!(!e.is_unsolvable());
}

#[test]
fn the_server_reads_finite_doubles_and_makes_them_exact() {
    let big = serde_json::from_str::<Value>(r#"{"op": "translate", "v": [1e400, 0]}"#).unwrap();
    assert!(Motion::<f64>::from_value(&big).is_err());
    let m = Motion::<f64>::from_value(&json!({"op": "scale", "center": [0.1, 2], "factor": 2}))
        .unwrap();
    let Motion::Scale(s) = m.to_exact().unwrap() else { panic!() };
    // 0.1 as the double it is, not the decimal 1/10 a script would mean.
    assert_eq!(s.center[0], crate::exact::rat_from_f64(0.1).unwrap());
    assert_ne!(s.center[0], parse_rat("0.1").unwrap());
}

fn arb_op() -> impl Strategy<Value = Op> {
    let target = (
        prop_oneof![
            prop::collection::vec(0usize..50, 1..4)
                .prop_map(|p| Anchors::Points(ControlPoint::from_indices(&p))),
            prop::collection::vec((-50i32..50, -50i32..50), 1..3).prop_map(|v| {
                Anchors::Near(
                    v.into_iter().map(|(x, y)| [f64::from(x) / 4.0, f64::from(y)]).collect(),
                )
            }),
        ],
        prop::collection::vec(0usize..50, 0..3).prop_map(|p| ControlPoint::from_indices(&p)),
        prop_oneof![(0usize..5).prop_map(Neighborhood::Radius), Just(Neighborhood::All)],
        prop_oneof![Just(Mode::Xy), Just(Mode::Z0), Just(Mode::Z1)],
    )
        .prop_map(|(anchors, derived, neighborhood, mode)| Target {
            anchors,
            derived,
            neighborhood,
            mode,
        });
    let rat = (-1000i64..1000, 1i64..64)
        .prop_map(|(p, q)| Rat::new(crate::exact::Int::from(p), crate::exact::Int::from(q)));
    let motion = prop_oneof![
        prop::collection::vec(rat.clone(), 1..3).prop_map(|by| Motion::Translate(Translate { by })),
        (rat.clone(), rat.clone(), -3.0f64..3.0)
            .prop_map(|(x, y, angle)| Motion::Rotate(Rotate { center: [x, y], angle })),
        (prop::collection::vec(rat.clone(), 1..3), rat)
            .prop_map(|(center, factor)| Motion::Scale(Scale { center, factor })),
    ];
    let constrain = (
        prop::collection::vec(0usize..50, 0..3),
        prop::collection::vec(prop::collection::vec(0usize..50, 2..4), 0..2),
        prop::collection::vec((0usize..50, 0usize..50).prop_map(|(a, b)| [a, b]), 0..2),
    )
        .prop_filter("at least one constraint", |(p, h, e)| {
            !(p.is_empty() && h.is_empty() && e.is_empty())
        })
        .prop_map(|(pin, horizontal, equal_displacement)| {
            Op::Constrain(Constraints {
                pin,
                vertical: horizontal.clone(),
                horizontal,
                equal_displacement,
            })
        });
    prop_oneof![
        (target, motion).prop_map(|(target, motion)| Op::Move { target, motion }),
        constrain
    ]
}

proptest! {
    /// Writing a script as JSON and reading it back gives the same operations (exact
    /// numbers as strings, anchors of both forms, every default written out).
    #[test]
    fn json_round_trip(ops in prop::collection::vec(arb_op(), 0..5)) {
        let s = Script { ops };
        let text = serde_json::to_string(&s).unwrap();
        prop_assert_eq!(Script::from_json_str(&text).unwrap(), s.clone());
        prop_assert_eq!(Script::from_value(&serde_json::to_value(&s).unwrap()).unwrap(), s);
    }
}

"""Edit scripts and the check report, against `trimorph edit` / `trimorph check`."""

import json

import pytest

import trimorph


def grid_and_row():
    d = trimorph.Deformation.mesh_grid(4, 3, (80, 60))
    doc = json.loads(d.to_json())
    vertex = {tuple(v): i for i, v in enumerate(doc["vertices"])}
    row = [vertex[(x, 20.0)] for x in (0.0, 20.0, 40.0, 60.0, 80.0)]
    return d, row, vertex[(40.0, 40.0)]


OPS = [
    {"anchors": {"near": [[40, 20]]}, "neighborhood": 2, "op": "translate", "by": [3.5, "-7/2"]},
    {"anchors": {"near": [[20, 40]]}, "op": "rotate", "center": [20, 40], "angle": 0.2},
    {"anchors": {"near": [[60, 40]]}, "neighborhood": "all", "op": "scale", "center": [60, 40], "factor": 1.25},
]


def test_edit_equals_cli_edit(cli, tmp_path):
    d, _, _ = grid_and_row()
    base, script, out = tmp_path / "id.json", tmp_path / "s.json", tmp_path / "out.json"
    d.save(base)
    script.write_text(json.dumps(OPS))
    cli("edit", base, "--script", script, "-o", out)
    reports = d.edit(OPS)
    assert len(reports) == 3 and all(r["kind"] == "moved" and r["anchors"] for r in reports)
    assert d.to_json() == out.read_text()
    assert d.check()["c1_holds"] is True


def test_unbounded_edit_equals_cli_unbounded(cli, tmp_path):
    d, _, _ = grid_and_row()
    base, script, out = tmp_path / "id.json", tmp_path / "s.json", tmp_path / "out.json"
    d.save(base)
    script.write_text(json.dumps(OPS))
    cli("edit", base, "--script", script, "-o", out, "--unbounded")
    d.edit(OPS, bounded_bits=None)
    assert d.to_json() == out.read_text()
    with pytest.raises(ValueError, match="bounded_bits"):
        d.edit(OPS, bounded_bits=3)


def test_constraints_persist_through_save_and_make_moves_unsolvable(tmp_path):
    d, row, a = grid_and_row()
    d.edit([
        {"op": "constrain", "horizontal": [row], "pin": [a]},
        {"anchors": [row[2]], "neighborhood": 1, "op": "translate", "by": [1, 3]},
    ])
    doc = json.loads(d.to_json())
    assert len(doc["constraints"]) == 2
    assert all(doc["exact"]["points"][p][1] == "23" for p in row)
    path = tmp_path / "c.json"
    d.save(path)
    again = trimorph.Deformation.load(path)
    before = again.to_json()
    assert before == d.to_json()
    with pytest.raises(trimorph.UnsolvableError, match="not weakly solvable") as e:
        again.edit([{"anchors": [a], "op": "translate", "by": [1, 0]}])
    assert e.value.kind == "NotWeaklySolvable"
    assert again.to_json() == before, "a failed edit leaves the deformation as it was"


def test_malformed_operations_name_index_and_key_and_change_nothing():
    d, _, _ = grid_and_row()
    before = d.to_json()
    for ops, msg in [
        ([{"anchors": [0], "op": "fly"}], "unknown op"),
        ([OPS[0], {"anchors": [0], "op": "translate", "by": [1]}], "operation 1"),
        ([{"anchors": [99999], "op": "translate", "by": [1, 1]}], "does not exist"),
    ]:
        with pytest.raises(ValueError, match=msg):
            d.edit(ops)
        assert d.to_json() == before


def test_kept_keys_survive_a_round_trip(tmp_path):
    d, _, _ = grid_and_row()
    doc = json.loads(d.to_json())
    doc["pinned"] = [3, 4]
    doc["model"] = "worm.obj"
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(doc))
    back = json.loads(trimorph.Deformation.load(path).to_json())
    assert back["pinned"] == [3, 4] and back["model"] == "worm.obj"


def test_check_equals_cli_check(fitted, cli):
    d, path = fitted
    ref = json.loads(cli("check", path).stdout)
    assert d.check() == ref and "c1_residuals" not in ref
    full = json.loads(cli("check", path, "--residuals").stdout)
    assert d.check(residuals=True) == full
    assert len(full["c1_residuals"]) == full["c1_conditions"]
    with pytest.raises(ValueError, match="samples"):
        d.check(samples=0)

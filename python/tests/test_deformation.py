"""Deformation files, meshes and point maps against the command line."""

import json

import numpy as np
import pytest

import trimorph


def read_points(path):
    rows = path.read_text().splitlines()[1:]
    return np.array(
        [[float(v) if v else np.nan for v in r.split(",")] for r in rows], dtype=np.float64
    )


def test_save_load_round_trip_keeps_the_file_byte_for_byte(fitted, tmp_path):
    d, path = fitted
    again = trimorph.Deformation.load(path)
    out = tmp_path / "again.json"
    again.save(out)
    assert out.read_bytes() == path.read_bytes()
    assert trimorph.Deformation.from_json(path.read_text()).to_json() == path.read_text()


def test_saved_file_is_a_valid_deformation_for_the_cli(fitted, cli):
    _, path = fitted
    p = cli("check", path)
    assert "C1" in p.stdout or "c1" in p.stdout.lower()


def test_mesh_grid_equals_cli_mesh_grid(cli, tmp_path):
    out = tmp_path / "grid.json"
    cli("mesh", "--grid", "6x4", "--size", "120,80", "-o", out)
    d = trimorph.Deformation.mesh_grid(6, 4, (120, 80))
    assert d.to_json() == out.read_text()
    assert d.num_triangles == 48 and d.degree == 5
    assert d.bbox == ((0.0, 0.0), (120.0, 80.0))
    # The grid records its 120 x 80 frame: fields cover the image's pixels (bug: they were
    # the 121 x 81 pixel centres of the mesh's extent).
    assert d.frame["size"] == [120.0, 80.0]
    assert d.field().shape == (80, 120, 2)


def test_mesh_grid_of_whole_pixels_records_its_frame_as_the_cli(cli, tmp_path):
    """Bug (issue 55): `mesh_grid(4, 4, (100, 80)).field()` was (81, 101, 2), the pixel
    centres of the grid's extent, while `trimorph mesh --grid 4x4 --size 100,80` records
    the 100 x 80 frame; it goes through the library's mesh source now."""
    d = trimorph.Deformation.mesh_grid(4, 4, (100, 80))
    assert d.frame == {"size": [100.0, 80.0]}
    assert d.field().shape == (80, 100, 2)
    assert d.field(inverse=True).shape == (80, 100, 2)
    out = tmp_path / "g.json"
    cli("mesh", "--grid", "4x4", "--size", "100,80", "-o", out)
    assert trimorph.Deformation.load(out).frame == d.frame
    assert d.to_json() == out.read_text()
    # A fractional size is no image: no frame, fields over the extent's pixel centres.
    odd = trimorph.Deformation.mesh_grid(4, 4, (100.5, 80))
    assert odd.frame is None
    assert odd.field().shape == (81, 101, 2)


def test_mesh_landmarks_equals_cli_mesh_landmarks(cli, nuclei, tmp_path):
    out = tmp_path / "lm.json"
    cli("mesh", "--landmarks", nuclei["landmarks"], "--size", "184,184", "-o", out)
    d = trimorph.Deformation.mesh_landmarks(nuclei["src"], (184, 184))
    assert d.to_json() == out.read_text()


def test_map_points_equal_cli_forward_points(fitted, cli, tmp_path):
    d, path = fitted
    pts = np.array([[0.0, 0.0], [10.25, 33.5], [92.0, 92.0], [183.0, 183.0], [-500.0, 3.0]])
    csv = tmp_path / "p.csv"
    csv.write_text("x,y\n" + "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in pts))
    out = tmp_path / "q.csv"
    cli("warp", path, "--points", csv, "-o", out)
    ours = d.map_points(pts)
    assert ours.dtype == np.float64 and ours.shape == (5, 2)
    np.testing.assert_array_equal(ours, read_points(out))
    assert np.isnan(ours[4]).all(), "a point outside the mesh maps to a NaN row"


def test_inverse_points_equal_cli_inverse_and_undo_phi(fitted, cli, tmp_path):
    d, path = fitted
    rng = np.random.default_rng(7)
    p = rng.uniform(5, 178, size=(40, 2))
    q = d.map_points(p)
    csv = tmp_path / "q.csv"
    csv.write_text("x,y\n" + "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in q))
    out = tmp_path / "p.csv"
    cli("warp", path, "--points", csv, "--inverse", "-o", out)
    back = d.inverse_points(q)
    np.testing.assert_array_equal(back, read_points(out))
    # Certified to the default tolerance of 0.01 px.
    assert np.abs(back - p).max() < 0.01


def test_points_accept_lists_and_empty_input(fitted):
    d, _ = fitted
    assert d.map_points([[1.0, 2.0]]).shape == (1, 2)
    assert d.map_points(np.zeros((0, 2))).shape == (0, 2)


def test_field_equals_cli_npy_both_directions(fitted, cli, tmp_path):
    d, path = fitted
    for inverse in (False, True):
        out = tmp_path / f"f{inverse}.npy"
        args = ["field", path, "-o", out, "--size", "60,50"] + (["--inverse"] if inverse else [])
        cli(*args)
        ref = np.load(out)
        ours = d.field(inverse=inverse, size=(60, 50))
        assert ours.dtype == np.float32 and ours.shape == (50, 60, 2)
        np.testing.assert_array_equal(ours, ref)


def test_field_direction_matches_the_point_maps(fitted):
    d, _ = fitted
    f = d.field(size=(40, 30))
    y, x = 17, 23
    np.testing.assert_allclose(
        f[y, x], d.map_points([[x, y]])[0] - [x, y], rtol=0, atol=1e-4
    )


def test_copy_has_the_same_map_and_report(fitted):
    d, _ = fitted
    c = d.copy()
    assert c.to_json() == d.to_json()
    assert c.report == d.report
    assert repr(c) == repr(d) and "triangles=" in repr(d)

"""The napari-free helpers on real data: coordinates, warps, Jacobian, mesh, export."""

import numpy as np
import pytest
from napari.layers import Image, Points

import trimorph
from trimorph_napari import _core

from conftest import xy_to_rc


def test_points_to_pixels_respects_scale_and_translate(frames, tracks):
    f0, _ = frames
    src, _ = tracks
    # Plain layers: data (row, col) = (y, x).
    img = Image(f0)
    pts = Points(xy_to_rc(src))
    np.testing.assert_allclose(_core.points_to_pixels(pts, img), src)
    # The same landmarks drawn on a scaled, translated image: the Points layer lives in
    # world units (scale 1) at world = pixel * scale + translate.
    scale, translate = np.array([0.5, 2.0]), np.array([10.0, -30.0])
    img_s = Image(f0, scale=scale, translate=translate)
    pts_world = Points(xy_to_rc(src) * scale + translate)
    np.testing.assert_allclose(_core.points_to_pixels(pts_world, img_s), src, atol=1e-9)
    # ... or carrying the image's scale and translate themselves.
    pts_same = Points(xy_to_rc(src), scale=scale, translate=translate)
    np.testing.assert_allclose(_core.points_to_pixels(pts_same, img_s), src, atol=1e-9)
    # Back: the layers the plugin makes take the frame's transform.
    kw = _core.frame_transform_kwargs(img_s)
    np.testing.assert_allclose(kw["scale"], scale)
    np.testing.assert_allclose(kw["translate"], translate)


def test_points_of_a_stack_and_rgb_frame(frames, tracks):
    f0, _ = frames
    src, _ = tracks
    stack = Image(np.stack([f0, f0, f0]), scale=(5.0, 2.0, 2.0))
    pts = Points(np.c_[np.ones(len(src)), xy_to_rc(src) * 2.0])  # 3-D points, world units
    np.testing.assert_allclose(_core.points_to_pixels(pts, stack), src, atol=1e-9)
    assert _core.frame_size(stack) == (511, 511)
    rgb = Image(np.dstack([f0, f0, f0]), rgb=True)
    assert _core.frame_size(rgb) == (511, 511)


def test_fit_warp_and_labels(frames, tracks, labels_of):
    f0, _ = frames
    src, dst = tracks
    d = _core.fit_from_pixels(src, dst, (511, 511))
    s = _core.report_summary(d)
    assert s["fold_free"] and s["covers_frame"] and 0 < s["rms"] < 30
    # Images: dtype and shape kept; bit-identical to Deformation.warp.
    w = _core.warp_image(d, f0)
    assert w.dtype == np.uint8 and w.shape == f0.shape
    np.testing.assert_array_equal(w, d.warp(f0))
    # A stack of 3 planes (not H x W x 3 colour) and a float64 image.
    st = _core.warp_image(d, np.stack([f0, f0[::-1], f0]))
    np.testing.assert_array_equal(st[1], d.warp(np.ascontiguousarray(f0[::-1])))
    rgb = np.dstack([f0, f0[::-1], f0.T]).copy()
    np.testing.assert_array_equal(_core.warp_image(d, rgb, rgb=True), d.warp(rgb))
    f64 = _core.warp_image(d, f0.astype(np.float64))
    assert f64.dtype == np.float64
    np.testing.assert_allclose(f64, d.warp(f0.astype(np.float32)), atol=1e-4)
    # Labels: nearest, dtype kept, only existing values, also beyond uint16's range.
    lab = labels_of(f0).astype(np.int64) * 100_000
    out = _core.warp_labels(d, lab)
    assert out.dtype == np.int64 and out.shape == lab.shape
    assert set(np.unique(out)) <= set(np.unique(lab)) | {0}
    assert len(np.unique(out)) > 3
    np.testing.assert_array_equal(
        out // 100_000, d.warp(labels_of(f0).astype(np.uint16), interp="nearest")
    )


def test_mismatched_points_are_refused(tracks):
    src, dst = tracks
    with pytest.raises(ValueError, match="paired by index"):
        _core.fit_from_pixels(src, dst[:-1], (511, 511))


def test_jacobian_identity_and_fit(tracks):
    ident = trimorph.Deformation.mesh_grid(4, 4, (100.0, 80.0))
    for frame in ("reference", "deformed"):
        j = _core.jacobian_map(ident, (100, 80), frame=frame)
        assert j.shape == (80, 100) and j.dtype == np.float32
        np.testing.assert_allclose(j[np.isfinite(j)], 1.0, atol=1e-4)
        assert np.isfinite(j).mean() > 0.95
    # A uniform 2x scaling (x and y): det J = 4 everywhere.
    sq = np.array([[10.0, 10.0], [90.0, 10.0], [90.0, 70.0], [10.0, 70.0], [50.0, 40.0]])
    d = trimorph.fit(sq, sq * 2, size=(100, 80), hard=True)
    j = _core.jacobian_map(d, (100, 80), frame="reference")
    assert abs(np.nanmedian(j) - 4.0) < 0.05


def test_mesh_paths_follow_the_map(tracks):
    src, dst = tracks
    d = _core.fit_from_pixels(src, dst, (511, 511))
    verts, tris = _core.mesh_of(d)
    assert len(tris) == d.num_triangles and len(verts) == d.num_vertices
    paths = _core.mesh_paths(d, samples=4, size=(511, 511))
    everything = _core.mesh_paths(d, samples=4)
    assert 0 < len(paths) < len(everything) == len(_core.mesh_edges(tris))
    p = paths[0]
    assert p.shape == (5, 2)
    # The ends of each path are images of mesh vertices (row, col).
    mapped = d.map_points(verts)[:, ::-1]
    assert np.min(np.linalg.norm(mapped - p[0], axis=1)) < 1e-9


def test_export_formats(tmp_path, tracks):
    src, dst = tracks
    d = _core.fit_from_pixels(src, dst, (511, 511))
    r = _core.export(d, tmp_path / "phi.h5", size=(511, 511))
    assert r.kind == "itk" and (tmp_path / "phi.h5").stat().st_size > 0
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "phi.h5", "r") as f:
        params = np.asarray(f["TransformGroup/0/TranformParameters"])
        kind = f["TransformGroup/0/TransformType"][0]
    assert params.size == 511 * 511 * 2
    assert b"DisplacementFieldTransform" in (kind if isinstance(kind, bytes) else kind.encode())
    _core.export(d, tmp_path / "phi.zarr", direction="both", size=(511, 511))
    assert (tmp_path / "phi.zarr").is_dir()
    _core.export(d, tmp_path / "phi.json")
    again = trimorph.Deformation.load(tmp_path / "phi.json")
    np.testing.assert_allclose(again.map_points(src), d.map_points(src))
    with pytest.raises(ValueError, match="one direction"):
        _core.export(d, tmp_path / "x.h5", direction="both")


def test_export_places_the_field_at_the_layer_scale_and_translate(tmp_path, tracks):
    """A frame layer with a physical scale and translate exports a field in that space:
    SimpleITK's ``Resample`` of the image at that spacing and origin reproduces the warp."""
    sitk = pytest.importorskip("SimpleITK")
    src, dst = tracks
    d = _core.fit_from_pixels(src, dst, (511, 511))
    img = (np.add.outer(np.arange(511.0), np.arange(511.0)) % 97).astype(np.float32)
    layer = Image(img, scale=(0.25, 0.5), translate=(-4.0, 12.5))
    placed = _core.placement(layer)
    assert placed == {"spacing": (0.5, 0.25), "origin": (12.5, -4.0)}
    _core.export(d, tmp_path / "phi.h5", size=(511, 511), **placed)
    moving = sitk.GetImageFromArray(img)
    moving.SetSpacing(placed["spacing"])
    moving.SetOrigin(placed["origin"])
    t = sitk.ReadTransform(str(tmp_path / "phi.h5"))
    got = sitk.GetArrayFromImage(sitk.Resample(moving, moving, t, sitk.sitkLinear, -1.0,
                                               sitk.sitkFloat32))
    want = d.warp(img, background=-1.0)
    # Compared where the preimage lies a pixel inside the image: at the border ITK's linear
    # interpolator and trimorph's `constant` mode differ (the README's "One difference").
    ys, xs = np.mgrid[0:511, 0:511]
    pre = d.inverse_points(np.stack([xs.ravel(), ys.ravel()], 1).astype(float))
    inside = ((pre >= 1) & (pre <= 509)).all(axis=1).reshape(511, 511)
    assert inside.mean() > 0.9
    assert np.abs(got - want)[inside].max() < 1e-3
    # The .json file records the placement with its frame.
    _core.export(d, tmp_path / "phi.json", size=(511, 511), **placed)
    f = trimorph.Deformation.load(tmp_path / "phi.json").frame
    assert (f["spacing"], f["origin"]) == ([0.5, 0.25], [12.5, -4.0])
    # A rotated layer has no axis-aligned placement: pixels.
    assert _core.placement(Image(img, rotate=30)) == {}

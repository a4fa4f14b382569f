"""The dock widget in a real (offscreen) napari viewer, on the bundled time-lapse."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from napari.layers import Image, Labels, Shapes

import trimorph
from trimorph_napari import _core
from trimorph_napari._widget import TrimorphWidget

from conftest import xy_to_rc

WAIT_MS = 60_000


def wait(qtbot, widget):
    """Waits for the widget's workers; fails on the error the widget reported."""
    qtbot.waitUntil(lambda: not widget.busy, timeout=WAIT_MS)
    assert "failed" not in widget.status.value, widget.status.value


def setup(viewer_factory, frames, tracks, scale=(1.0, 1.0), translate=(0.0, 0.0)):
    f0, f9 = frames
    src, dst = tracks
    viewer = viewer_factory()
    scale, translate = np.asarray(scale), np.asarray(translate)
    moving = viewer.add_image(f0, name="frame 0", scale=scale, translate=translate)
    fixed = viewer.add_image(f9, name="frame 9", scale=scale, translate=translate)
    # Points in world units on top of the images (napari's default for a new Points layer).
    mp = viewer.add_points(xy_to_rc(src) * scale + translate, name="moving", face_color="green")
    fp = viewer.add_points(xy_to_rc(dst) * scale + translate, name="fixed", face_color="magenta")
    widget = TrimorphWidget(viewer)
    viewer.window.add_dock_widget(widget, name="trimorph")
    widget.frame.value = fixed
    widget.moving_points.value = mp
    widget.fixed_points.value = fp
    widget.warp_layer.value = moving
    return viewer, widget


def test_fit_warp_jacobian_mesh_export(viewer_factory, qtbot, frames, tracks, labels_of, tmp_path):
    viewer, widget = setup(viewer_factory, frames, tracks)
    src, dst = tracks
    f0, _ = frames
    # 1. Fit
    widget.fit_button.clicked.emit()
    wait(qtbot, widget)
    d = widget.deformation
    assert d is not None and d.frame["size"] == [511.0, 511.0]
    s = _core.report_summary(d)
    assert s["fold_free"] and s["covers_frame"] and s["rms"] < 30
    assert "rms" in widget.result.value and "fold-free" in widget.result.value
    mapped = viewer.layers["phi(moving points)"]
    assert mapped.metadata["trimorph"]["role"] == "fit"
    again = _core.deformation_from_layer(mapped)
    np.testing.assert_allclose(again.map_points(src), d.map_points(src))
    np.testing.assert_allclose(mapped.data, d.map_points(src)[:, ::-1])
    # The same fit as trimorph.fit on the CSV's pixels.
    direct = trimorph.fit(src, dst, size=(511, 511))
    np.testing.assert_allclose(d.map_points(src), direct.map_points(src), atol=1e-9)

    # 3. Warp an Image and a Labels layer
    widget.warp_button.clicked.emit()
    wait(qtbot, widget)
    warped = viewer.layers["frame 0 warped"]
    assert isinstance(warped, Image) and warped.data.dtype == np.uint8
    np.testing.assert_array_equal(warped.data, d.warp(f0))
    assert warped.metadata["trimorph"]["role"] == "warp"
    lab = labels_of(f0)
    labels = viewer.add_labels(lab, name="nuclei")
    widget.warp(labels)
    wait(qtbot, widget)
    wl = viewer.layers["nuclei warped"]
    assert isinstance(wl, Labels) and wl.data.dtype == lab.dtype
    assert set(np.unique(wl.data)) <= set(np.unique(lab))
    assert len(np.unique(wl.data)) > 3

    # 4. Jacobian map and mesh
    widget.jacobian_button.clicked.emit()
    wait(qtbot, widget)
    jac = viewer.layers["det J"]
    vals = jac.data[np.isfinite(jac.data)]
    assert vals.size > 0.9 * jac.data.size
    lb = d.report["det_j_lower_bound"]
    assert vals.min() >= lb - 1e-3 and 0.5 < np.median(vals) < 2.0
    assert jac.colormap.name == "PiYG"
    if hasattr(jac, "colorbar"):
        assert jac.colorbar.visible
    widget.mesh_button.clicked.emit()
    wait(qtbot, widget)
    mesh = viewer.layers["deformed mesh"]
    assert isinstance(mesh, Shapes) and mesh.nshapes > 50
    assert set(mesh.shape_type) == {"path"}
    assert len(mesh.data[0]) == widget.mesh_samples.value + 1

    # 6. Export ITK .h5 and NGFF
    h5 = tmp_path / "phi.h5"
    widget.export_path.value = h5
    widget.export_button.clicked.emit()
    wait(qtbot, widget)
    assert h5.stat().st_size > 511 * 511 * 16
    assert "exported itk" in widget.status.value
    h5py = pytest.importorskip("h5py")
    with h5py.File(h5, "r") as f:
        assert f["TransformGroup/0/TranformParameters"].size == 511 * 511 * 2
    widget.export(tmp_path / "phi.zarr", direction="forward")
    wait(qtbot, widget)
    assert (tmp_path / "phi.zarr").is_dir()

    # 5. Edit a landmark and re-fit automatically; the output layers follow.
    before = warped.data.copy()
    widget.auto_refit.value = True
    moving = viewer.layers["moving"]
    data = moving.data.copy()
    data[0] += (0.0, 25.0)  # 25 px to the right (a column shift)
    moving.data = data
    qtbot.waitUntil(lambda: widget.deformation is not d, timeout=WAIT_MS)
    wait(qtbot, widget)
    new_src = src.copy()
    new_src[0, 0] += 25.0
    np.testing.assert_allclose(
        widget.deformation.map_points(new_src),
        trimorph.fit(new_src, dst, size=(511, 511)).map_points(new_src),
        atol=1e-9,
    )
    assert not np.array_equal(viewer.layers["frame 0 warped"].data, before)


def test_scaled_translated_layers_give_the_same_fit(viewer_factory, qtbot, frames, tracks):
    src, dst = tracks
    viewer, widget = setup(
        viewer_factory, frames, tracks, scale=(0.5, 2.0), translate=(10.0, -30.0)
    )
    # The Points layers are in world units (scale 1): convert back to the frame's pixels.
    np.testing.assert_allclose(
        _core.points_to_pixels(widget.moving_points.value, widget.frame.value), src
    )
    widget.fit()
    wait(qtbot, widget)
    direct = trimorph.fit(src, dst, size=(511, 511))
    np.testing.assert_allclose(
        widget.deformation.map_points(src), direct.map_points(src), atol=1e-9
    )
    # The outputs overlay the frame in world coordinates.
    mapped = viewer.layers["phi(moving points)"]
    np.testing.assert_allclose(mapped.scale, (0.5, 2.0))
    np.testing.assert_allclose(mapped.translate, (10.0, -30.0))
    widget.mesh()
    wait(qtbot, widget)
    np.testing.assert_allclose(viewer.layers["deformed mesh"].scale, (0.5, 2.0))


@pytest.mark.parametrize("metric", ["ncc", "mi"])
def test_register(viewer_factory, qtbot, frames, metric):
    f0, f9 = frames
    viewer = viewer_factory()
    # A 256 x 256 crop keeps the test short.
    fixed = viewer.add_image(f9[128:384, 128:384], name="fixed")
    moving = viewer.add_image(f0[128:384, 128:384], name="moving")
    widget = TrimorphWidget(viewer)
    viewer.window.add_dock_widget(widget)
    widget.fixed_image.value = fixed
    widget.moving_image.value = moving
    widget.metric.value = metric
    widget.register_button.clicked.emit()
    wait(qtbot, widget)
    d = widget.deformation
    assert d.report["fold_free"] and d.report["metric"] == metric
    out = viewer.layers["moving registered"]
    assert out.data.shape == (256, 256) and out.data.dtype == np.uint8
    assert out.metadata["trimorph"]["role"] == "register"
    assert widget.frame_layer is fixed


def test_cancel_stops_a_registration(viewer_factory, qtbot, frames):
    """The Cancel button (shown while work runs) stops it: trimorph raises
    trimorph.Cancelled in the worker, the status says so and no result appears."""
    f0, f9 = frames
    viewer = viewer_factory()
    fixed = viewer.add_image(f9, name="fixed")
    moving = viewer.add_image(f0, name="moving")
    widget = TrimorphWidget(viewer)
    viewer.window.add_dock_widget(widget)
    widget.fixed_image.value = fixed
    widget.moving_image.value = moving
    widget.register_button.clicked.emit()
    assert widget.busy and not widget.cancel_button.native.isHidden()
    widget.cancel_button.clicked.emit()
    qtbot.waitUntil(lambda: not widget.busy, timeout=WAIT_MS)
    assert widget.status.value == "register cancelled", widget.status.value
    assert widget.deformation is None
    assert "moving registered" not in viewer.layers
    assert widget.cancel_button.native.isHidden()


def test_identity_jacobian_layer(viewer_factory, qtbot):
    viewer = viewer_factory()
    img = viewer.add_image(np.zeros((80, 100), np.uint8), name="frame")
    widget = TrimorphWidget(viewer)
    viewer.window.add_dock_widget(widget)
    widget.deformation = trimorph.Deformation.mesh_grid(5, 4, (100.0, 80.0))
    widget.frame_layer = img
    widget.jacobian()
    wait(qtbot, widget)
    j = viewer.layers["det J"].data
    np.testing.assert_allclose(j[np.isfinite(j)], 1.0, atol=1e-4)


def test_stack_warp_and_closed_dock(viewer_factory, qtbot, frames, tracks):
    f0, _ = frames
    viewer, widget = setup(viewer_factory, frames, tracks)
    widget.fit()
    wait(qtbot, widget)
    d = widget.deformation
    stack = viewer.add_image(np.stack([f0, f0[::-1], f0.T]).astype(np.uint16), name="stack")
    widget.warp(stack)  # a generator worker: one yield (progress step) per plane
    wait(qtbot, widget)
    out = viewer.layers["stack warped"].data
    assert out.shape == (3, 511, 511) and out.dtype == np.uint16
    np.testing.assert_array_equal(out[2], d.warp(np.ascontiguousarray(f0.T).astype(np.uint16)))
    # Closing the dock widget leaves the viewer working.
    viewer.window.remove_dock_widget(widget.native)
    widget.native.deleteLater()
    qtbot.wait(50)
    viewer.add_image(f0, name="after")
    assert "after" in viewer.layers


def test_errors_are_reported_not_raised(viewer_factory, qtbot, frames, tracks):
    viewer, widget = setup(viewer_factory, frames, tracks)
    viewer.layers["fixed"].data = viewer.layers["fixed"].data[:-1]
    widget.fit()
    qtbot.waitUntil(lambda: not widget.busy, timeout=WAIT_MS)
    assert "fit failed" in widget.status.value and "paired by index" in widget.status.value
    assert widget.deformation is None


def test_npe2_manifest_validates():
    npe2 = Path(sys.executable).parent / "npe2"
    cmd = [str(npe2)] if npe2.exists() else [sys.executable, "-m", "npe2"]
    r = subprocess.run(cmd + ["validate", "trimorph-napari"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    from npe2 import PluginManifest

    pm = PluginManifest.from_distribution("trimorph-napari")
    assert [w.display_name for w in pm.contributions.widgets] == [
        "Deformation (fit, register, warp, export)"
    ]


def test_the_plugin_menu_entry_opens_the_widget(viewer_factory, qtbot, frames, tracks):
    """Through npe2, as Plugins -> trimorph does: napari injects the viewer (as a
    PublicOnlyProxy: the widget must use napari's public API only)."""
    f0, f9 = frames
    src, dst = tracks
    viewer = viewer_factory()
    dock, widget = viewer.window.add_plugin_dock_widget(
        "trimorph-napari", "Deformation (fit, register, warp, export)"
    )
    assert isinstance(widget, TrimorphWidget)
    viewer.add_image(f0, name="frame 0")
    viewer.add_image(f9, name="frame 9")
    viewer.add_points(xy_to_rc(src), name="moving")
    viewer.add_points(xy_to_rc(dst), name="fixed")
    named = {layer.name: layer for layer in widget.frame.choices if layer is not None}
    assert sorted(named) == ["frame 0", "frame 9"]
    widget.frame.value = named["frame 9"]
    widget.warp_layer.value = named["frame 0"]
    pts = {layer.name: layer for layer in widget.moving_points.choices if layer is not None}
    widget.moving_points.value, widget.fixed_points.value = pts["moving"], pts["fixed"]
    for step in (widget.fit, widget.warp, widget.jacobian, widget.mesh):
        step()
        wait(qtbot, widget)
    for name in ("phi(moving points)", "frame 0 warped", "det J", "deformed mesh"):
        assert name in viewer.layers

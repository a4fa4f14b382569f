"""`trimorph.register` from numpy: a known warp of the bundled immunohistochemistry image
recovered, the report, landmarks met exactly with hard=True, bad input refused."""

import numpy as np
import pytest

import trimorph
from conftest import REPO


def pair():
    rgb = trimorph.read_image(str(REPO / "data/microscopy/ihc.png"))
    rgb = np.asarray(rgb[0] if isinstance(rgb, list) else rgb)
    m = rgb[96:288, 128:320].astype(np.float32).mean(axis=2) / 255.0
    h, w = m.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(float)

    def psi(x, y):  # FIXED -> MOVING
        return x - 2.0 + 1.0 * np.cos(y / 25.0), y + 1.5 + 1.0 * np.sin(x / 31.0)

    qx, qy = psi(xx, yy)
    qx, qy = np.clip(qx, 0, w - 1.001), np.clip(qy, 0, h - 1.001)
    i, j = np.floor(qy).astype(int), np.floor(qx).astype(int)
    fy, fx = qy - i, qx - j
    f = ((1 - fy) * ((1 - fx) * m[i, j] + fx * m[i, j + 1])
         + fy * ((1 - fx) * m[i + 1, j] + fx * m[i + 1, j + 1]))
    return f.astype(np.float32), m, psi


def test_register_recovers_a_known_warp_from_numpy():
    f, m, psi = pair()
    d = trimorph.register(f, m)
    r = d.report
    assert r["fold_free"] is True and r["det_j_lower_bound"] > 0
    assert r["metric_after"] < 0.5 * r["metric_before"]
    assert d.frame["size"] == [f.shape[1], f.shape[0]]
    # phi(psi(x)) ~ x inside.
    xs = np.array([[x, y] for x in range(40, 160, 30) for y in range(40, 160, 30)], float)
    q = np.stack(psi(xs[:, 0], xs[:, 1]), axis=1)
    err = np.hypot(*(d.map_points(q) - xs).T).mean()
    assert err < 0.4, err
    warped = d.warp(m)
    assert warped.shape == m.shape


def test_hard_landmarks_are_met_and_bad_input_is_refused():
    f, m, psi = pair()
    dst = np.array([[50.0, 60.0], [120.0, 80.0], [90.0, 140.0]])
    src = np.stack(psi(dst[:, 0], dst[:, 1]), axis=1) + 0.3
    d = trimorph.register(f, m, src=src, dst=dst, hard=True, levels=2, iterations=10)
    assert np.abs(d.map_points(src) - dst).max() < 1e-9
    assert d.report["landmarks"]["hard"] is True
    with pytest.raises(ValueError, match="constant"):
        trimorph.register(f, np.full_like(m, 0.5))
    with pytest.raises(ValueError, match="metric"):
        trimorph.register(f, m, metric="cc")
    with pytest.raises(ValueError, match="hard"):
        trimorph.register(f, m, hard=True)


def test_the_mesh_pyramid_is_reported_and_its_options_are_checked():
    f, m, _ = pair()
    d = trimorph.register(f, m, levels=3, mesh_levels=3, spacing=24.0)
    r = d.report
    assert r["mesh_levels"] == 3 and len(r["refinements"]) == 2
    tris = [lv["triangles"] for lv in r["levels"] if lv["stage"] == "spline"]
    # Every triangle split in four between levels (refine_share=1).
    assert tris[1] == 4 * tris[0] and tris[2] == 4 * tris[1] == r["triangles"]
    assert r["fold_free"] is True
    one = trimorph.register(f, m, levels=3, mesh_levels=1, spacing=24.0).report
    assert one["mesh_levels"] == 1 and one["refinements"] == []
    with pytest.raises(ValueError, match="mesh levels"):
        trimorph.register(f, m, mesh_levels=0)
    with pytest.raises(ValueError, match="refinement share"):
        trimorph.register(f, m, refine_share=1.5)

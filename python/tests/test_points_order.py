"""(x, y) and (row, col) points (issue 55, point 2): `order="rc"` on every point API and the
helpers `points_from_rc` / `points_to_rc` give exactly the (x, y) path's results, columns
swapped."""

import numpy as np
import pytest

import trimorph


def rc(a):
    return np.ascontiguousarray(np.asarray(a, float)[:, ::-1])


def grid_points(lo, hi, n):
    v = np.linspace(lo, hi, n)
    return np.array([[x, y] for x in v for y in v[::-1]])


def test_helpers_swap_the_columns_both_ways():
    xy = np.array([[1.5, 2.0], [10.0, -3.25], [0.0, 183.0]])
    r = trimorph.points_to_rc(xy)
    np.testing.assert_array_equal(r, [[2.0, 1.5], [-3.25, 10.0], [183.0, 0.0]])
    np.testing.assert_array_equal(trimorph.points_from_rc(r), xy)
    assert r.dtype == np.float64 and r.flags["C_CONTIGUOUS"]
    assert trimorph.points_from_rc([[3, 4]]).tolist() == [[4.0, 3.0]]
    assert trimorph.points_from_rc([]).shape == (0, 2)
    with pytest.raises(ValueError, match=r"shape \(n, 2\)"):
        trimorph.points_to_rc(np.zeros((3, 3)))


def test_map_and_inverse_points_in_row_col_order(fitted):
    d, _ = fitted
    xy = grid_points(-60, 250, 12)  # some outside the mesh: NaN rows
    fwd = d.map_points(xy)
    assert np.isnan(fwd[:, 0]).any() and not np.isnan(fwd[:, 0]).all()
    np.testing.assert_array_equal(d.map_points(rc(xy), order="rc"), rc(fwd))
    np.testing.assert_array_equal(trimorph.points_to_rc(fwd), d.map_points(rc(xy), order="rc"))
    inv = d.inverse_points(xy, tolerance=0.005)
    np.testing.assert_array_equal(d.inverse_points(rc(xy), tolerance=0.005, order="rc"), rc(inv))
    # A round trip in (row, col) comes back.
    inside = rc(xy[~np.isnan(fwd[:, 0])])
    back = d.inverse_points(d.map_points(inside, order="rc"), order="rc")
    ok = ~np.isnan(back[:, 0])
    assert ok.sum() > len(inside) // 2
    assert np.abs(back[ok] - inside[ok]).max() < 0.02


def test_order_is_checked_by_name(fitted):
    d, _ = fitted
    with pytest.raises(ValueError, match=r'order must be "xy".*or "rc".*got "yx"'):
        d.map_points([[1.0, 2.0]], order="yx")
    with pytest.raises(ValueError, match="order must be"):
        trimorph.fit([[1.0, 2.0]], [[1.0, 2.0]], size=(10, 10), order="ij")


def test_fit_mesh_and_morph_in_row_col_order_equal_the_xy_path(nuclei):
    src, dst = nuclei["src"], nuclei["dst"]
    a = trimorph.fit(src, dst, size=(184, 150))
    b = trimorph.fit(rc(src), rc(dst), size=(184, 150), order="rc")
    assert b.frame == {"size": [184.0, 150.0]}, "size stays (w, h)"
    probe = grid_points(0, 183, 15)
    np.testing.assert_array_equal(a.map_points(probe), b.map_points(probe))
    assert a.bbox == b.bbox and a.num_points == b.num_points
    m1 = trimorph.Deformation.mesh_landmarks(src, (184, 184))
    m2 = trimorph.Deformation.mesh_landmarks(rc(src), (184, 184), order="rc")
    assert m1.to_json() == m2.to_json()
    ia, ib = trimorph.read_image(nuclei["a"]), trimorph.read_image(nuclei["b"])
    f1 = trimorph.morph(ia, ib, src, dst, frames=2)
    f2 = trimorph.morph(ia, ib, rc(src), rc(dst), frames=2, order="rc")
    for x, y in zip(f1, f2):
        np.testing.assert_array_equal(x, y)


def test_register_landmarks_in_row_col_order_equal_the_xy_path():
    from test_register import pair

    f, m, psi = pair()
    dst = np.array([[50.0, 60.0], [120.0, 80.0], [90.0, 140.0]])
    src = np.stack(psi(dst[:, 0], dst[:, 1]), axis=1) + 0.3
    kw = dict(hard=True, levels=1, iterations=3)
    a = trimorph.register(f, m, src=src, dst=dst, **kw)
    b = trimorph.register(f, m, src=rc(src), dst=rc(dst), order="rc", **kw)
    assert np.abs(b.map_points(rc(src), order="rc") - rc(dst)).max() < 1e-9
    probe = grid_points(10, 180, 9)
    np.testing.assert_array_equal(a.map_points(probe), b.map_points(probe))

"""Image warps: bit-identical to `trimorph warp --image`, dtypes and shapes kept."""

import numpy as np
import pytest
import tifffile

import trimorph

from conftest import DATA


def cli_warp(cli, path, image, out, *extra):
    cli("warp", path, "--image", image, "-o", out, *extra)
    return trimorph.read_image(out)


@pytest.mark.parametrize(
    "image",
    [DATA / "morph" / "nuclei_a.png", DATA / "morph" / "nuclei_b.png", DATA / "microscopy" / "cell.png"],
    ids=["rgb8", "gray16", "gray8"],
)
@pytest.mark.parametrize("interp", ["nearest", "bilinear", "bicubic"])
def test_warp_is_bit_identical_to_the_cli(fitted, cli, tmp_path, image, interp):
    d, path = fitted
    src = trimorph.read_image(image)
    ref = cli_warp(cli, path, image, tmp_path / "o.png", "--interp", interp, "--background", "7")
    ours = d.warp(src, interp=interp, background=7)
    assert ours.dtype == src.dtype and ours.shape == src.shape
    np.testing.assert_array_equal(ours, ref)


def test_float32_gray_tiff_is_bit_identical_to_the_cli(fitted, cli, tmp_path):
    d, path = fitted
    rng = np.random.default_rng(3)
    img = rng.normal(100.0, 30.0, size=(190, 170)).astype(np.float32)
    tif = tmp_path / "f.tif"
    tifffile.imwrite(tif, img)
    out = tmp_path / "o.tif"
    cli("warp", path, "--image", tif, "-o", out, "--background", "0.5")
    ref = tifffile.imread(out)
    ours = d.warp(img, background=0.5)
    assert ours.dtype == np.float32 and ours.shape == img.shape
    np.testing.assert_array_equal(ours, ref)


def test_rgba_keeps_alpha_zero_outside_like_the_cli(fitted, cli, tmp_path):
    d, path = fitted
    rgb = trimorph.read_image(DATA / "morph" / "nuclei_a.png")
    rgba = np.dstack([rgb, np.full(rgb.shape[:2], 255, np.uint8)])
    # Shift the map far enough that part of the output has no preimage.
    shifted = trimorph.Deformation.mesh_grid(2, 2, (120, 120))
    ours = shifted.warp(rgba)
    assert ours.shape == rgba.shape
    outside = ours[:, :, 3] == 0
    assert outside.any(), "pixels beyond the 120 px mesh have alpha 0"
    assert (ours[outside][:, :3] == 0).all()


def test_rgba_tiff_is_bit_identical_to_the_cli(fitted, cli, tmp_path):
    d, path = fitted
    rgb = trimorph.read_image(DATA / "morph" / "nuclei_a.png")
    alpha = np.linspace(0, 255, rgb.shape[0] * rgb.shape[1]).astype(np.uint8)
    rgba = np.dstack([rgb, alpha.reshape(rgb.shape[:2])])
    tif = tmp_path / "rgba.tif"
    tifffile.imwrite(tif, rgba, photometric="rgb", extrasamples=["unassalpha"])
    np.testing.assert_array_equal(trimorph.read_image(tif), rgba)
    out = tmp_path / "o.tif"
    cli("warp", path, "--image", tif, "-o", out)
    np.testing.assert_array_equal(d.warp(rgba), trimorph.read_image(out))


def test_dtypes_and_shapes_are_kept(fitted):
    d, _ = fitted
    rng = np.random.default_rng(1)
    for dtype in (np.uint8, np.uint16, np.float32):
        for shape in ((50, 60), (50, 60, 1), (50, 60, 2), (50, 60, 3), (50, 60, 4)):
            a = (rng.random(shape) * 200).astype(dtype)
            o = d.warp(a)
            assert o.dtype == a.dtype and o.shape == a.shape, (dtype, shape)


def test_single_channel_axis_equals_the_2d_warp(fitted):
    d, _ = fitted
    a = (np.random.default_rng(2).random((64, 64)) * 255).astype(np.uint8)
    np.testing.assert_array_equal(d.warp(a[:, :, None])[:, :, 0], d.warp(a))


def test_many_channels_are_warped_as_independent_planes(fitted):
    d, _ = fitted
    a = (np.random.default_rng(5).random((40, 50, 6)) * 60000).astype(np.uint16)
    o = d.warp(a, interp="bicubic", channel_axis=-1)
    for k in range(6):
        np.testing.assert_array_equal(o[:, :, k], d.warp(np.ascontiguousarray(a[:, :, k]), interp="bicubic"))


def test_non_contiguous_input_gives_the_contiguous_result(fitted):
    d, _ = fitted
    a = (np.random.default_rng(4).random((80, 90)) * 255).astype(np.uint8)
    view = np.asfortranarray(a)
    assert not view.flags["C_CONTIGUOUS"]
    np.testing.assert_array_equal(d.warp(view), d.warp(a))
    strided = np.zeros((80, 180), np.uint8)
    strided[:, ::2] = a
    np.testing.assert_array_equal(d.warp(strided[:, ::2]), d.warp(a))


def test_identity_warp_returns_the_input(tmp_path):
    ident = trimorph.Deformation.mesh_grid(3, 3, (63, 47))
    a = (np.random.default_rng(0).random((48, 64, 3)) * 255).astype(np.uint8)
    np.testing.assert_array_equal(ident.warp(a), a)


def _zoom_out(size):
    """A fitted similarity that shrinks the content by 0.75 about the centre and turns it by
    10 degrees: the output's border pixels have preimages outside the image, inside the mesh."""
    w, h = size
    c = np.array([(w - 1) / 2, (h - 1) / 2])
    t = np.deg2rad(10.0)
    r = 0.75 * np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    src = np.array([[0.2 * w, 0.2 * h], [0.8 * w, 0.25 * h], [0.5 * w, 0.8 * h], [0.3 * w, 0.6 * h]])
    dst = (src - c) @ r.T + c
    return trimorph.fit(src, dst, size=size, bend=1e-3)


@pytest.mark.parametrize("mode", ["constant", "edge", "reflect"])
def test_edge_modes_match_scikit_image(mode):
    """Issue 52: `mode=` is scikit-image's. Our warp against `skimage.transform.warp` given
    our certified preimages (0.01 px) as coordinates, bilinear, on the real cell image."""
    skimage_transform = pytest.importorskip("skimage.transform")
    img = trimorph.read_image(DATA / "microscopy" / "cell.png")
    h, w = img.shape
    d = _zoom_out((w, h))
    ours = d.warp(img, interp="bilinear", background=40, mode=mode)
    ys, xs = np.mgrid[0:h, 0:w]
    q = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
    p = d.inverse_points(q)
    assert not np.isnan(p).any(), "the mesh covers the frame"
    coords = np.stack([p[:, 1].reshape(h, w), p[:, 0].reshape(h, w)])
    ref = skimage_transform.warp(
        img.astype(np.float64), coords, order=1, mode=mode, cval=40, preserve_range=True
    )
    diff = np.abs(ours.astype(np.float64) - ref)
    # Rounding to uint8 (0.5) plus the preimages' 0.01 px times the image's gradient.
    assert np.percentile(diff, 99.9) <= 1.0, np.percentile(diff, [50, 99, 99.9, 100])
    assert diff.max() <= 4.0, diff.max()
    # The modes differ where they should: outside the image the corner shows the background,
    # the edge pixel or the mirrored content.
    outside = (p[:, 0] < -1) | (p[:, 0] > w) | (p[:, 1] < -1) | (p[:, 1] > h)
    assert outside.sum() > 1000
    if mode == "constant":
        assert (ours.ravel()[outside] == 40).all()


def test_modes_are_checked_and_dask_refuses_reflect():
    img = trimorph.read_image(DATA / "microscopy" / "cell.png")
    d = _zoom_out((img.shape[1], img.shape[0]))
    with pytest.raises(ValueError, match="mode"):
        d.warp(img, mode="wrap")
    edge = d.warp(img, mode="edge")
    const = d.warp(img)
    assert (edge != const).sum() > 1000
    dask_mod = pytest.importorskip("trimorph.dask")
    with pytest.raises(ValueError, match="reflect"):
        dask_mod.warp(img, d, mode="reflect")
    import dask.array as da

    arr = da.from_array(img, chunks=(200, 200))
    for mode in ["constant", "edge"]:
        np.testing.assert_array_equal(dask_mod.warp(arr, d, mode=mode).compute(), d.warp(img, mode=mode))

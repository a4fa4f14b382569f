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
    o = d.warp(a, interp="bicubic")
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

"""Image axes (issue 55, point 1): `channel_axis` and `stack_axis` of `Deformation.warp` and
`trimorph.dask.warp`, as in scikit-image; ambiguous 3-D arrays refused; both APIs agree.

Real data: the bundled time-lapse frames (511 x 511 gray) and the immunohistochemistry
image (RGB), warped by the nucleus tracks' fit (frame 0 -> 9).
"""

import numpy as np
import pytest

import trimorph
from conftest import DATA, read_landmarks_csv

FRAMES = DATA / "microscopy" / "timelapse"


@pytest.fixture(scope="module")
def tracks():
    names, src, dst = read_landmarks_csv(FRAMES / "tracks_0_9.csv")
    return trimorph.fit(src, dst, size=(511, 511), names=names)


@pytest.fixture(scope="module")
def frames():
    """(5, 511, 511) uint8: frames 0 to 4 of the time-lapse."""
    return np.stack([trimorph.read_image(FRAMES / f"frame_0{k}.png") for k in range(5)])


@pytest.fixture(scope="module")
def rgb():
    """(Y, X, 3) uint8: the immunohistochemistry image, cropped to the fit's frame."""
    a = trimorph.read_image(DATA / "microscopy" / "ihc.png")
    assert a.ndim == 3 and a.shape[2] == 3
    return np.ascontiguousarray(a[:300, :400])


def test_a_time_lapse_stack_is_refused_without_keywords_naming_both_readings(tracks, frames):
    """Bug: a (T, Y, X) stack was read as (Y, X, C) = (T, 511, 511 channels): right shape,
    most pixels wrong. Now refused, naming the readings and their keywords."""
    with pytest.raises(ValueError) as e:
        tracks.warp(frames)
    msg = str(e.value)
    assert "(5, 511, 511)" in msg and "ambiguous" in msg
    assert "stack of 5 planes" in msg and "stack_axis=0" in msg
    assert "5 channels first" in msg and "channel_axis=0" in msg
    assert "511 channels last" in msg and "channel_axis=2" in msg
    with pytest.raises(ValueError, match="3 channels first.*channel_axis=0"):
        tracks.warp(np.ascontiguousarray(frames[:3]))
    with pytest.raises(ValueError, match="ambiguous"):
        tracks.warp(np.zeros((4, 5, 3), np.uint8))


def test_a_stack_is_warped_plane_by_plane_on_any_axis(tracks, frames):
    want = np.stack([tracks.warp(p, interp="bicubic", background=9) for p in frames])
    assert not np.array_equal(want, frames)
    got = tracks.warp(frames, stack_axis=0, interp="bicubic", background=9)
    np.testing.assert_array_equal(got, want)
    last = np.moveaxis(frames, 0, -1)  # (Y, X, T), a view
    got = tracks.warp(last, stack_axis=-1, interp="bicubic", background=9)
    assert got.flags["C_CONTIGUOUS"] and got.shape == last.shape
    np.testing.assert_array_equal(got, np.moveaxis(want, 0, -1))
    img, report, secs = tracks.warp_profiled(frames, stack_axis=0, interp="bicubic", background=9)
    np.testing.assert_array_equal(img, want)
    assert report["pixels"] > 0 and secs >= 0


def test_channels_on_any_axis_and_stacks_of_colour_images(tracks, rgb, frames):
    want = tracks.warp(rgb)  # (Y, X, 3), unambiguous
    assert not np.array_equal(want, rgb)
    np.testing.assert_array_equal(tracks.warp(rgb, channel_axis=-1), want)
    first = np.ascontiguousarray(np.moveaxis(rgb, -1, 0))  # (C, Y, X)
    np.testing.assert_array_equal(tracks.warp(first, channel_axis=0), np.moveaxis(want, -1, 0))
    # (T, Y, X, C): stack_axis alone, the planes being unambiguous (Y, X, C).
    stack = np.stack([rgb, rgb[::-1], 255 - rgb])
    got = tracks.warp(stack, stack_axis=0)
    for k in range(3):
        np.testing.assert_array_equal(got[k], tracks.warp(np.ascontiguousarray(stack[k])))
    # (C, T, Y, X): both keywords, anywhere.
    ctyx = np.ascontiguousarray(np.moveaxis(stack, -1, 0))
    np.testing.assert_array_equal(
        tracks.warp(ctyx, channel_axis=0, stack_axis=1), np.moveaxis(got, -1, 0)
    )
    # OME-Zarr's (T, C, Y, X) with every plane warped alike: two stack axes.
    tcyx = np.stack([frames[:2], frames[2:4]])
    got = tracks.warp(tcyx, stack_axis=(0, 1))
    for t in range(2):
        for c in range(2):
            np.testing.assert_array_equal(got[t, c], tracks.warp(tcyx[t, c]))


def test_many_channels_need_channel_axis_and_are_warped_alike(tracks, frames):
    """(Y, X, 5) was read as 5 channels without a keyword; it is ambiguous with a stack of
    Y planes, so it now names channel_axis."""
    a = np.ascontiguousarray(np.moveaxis(frames, 0, -1))
    with pytest.raises(ValueError, match="channel_axis=2"):
        tracks.warp(a)
    got = tracks.warp(a, channel_axis=-1)
    np.testing.assert_array_equal(got, np.moveaxis(tracks.warp(frames, stack_axis=0), 0, -1))


def test_impossible_axes_are_refused_naming_the_argument(tracks, frames):
    f = frames[0]
    with pytest.raises(ValueError, match="no room for y and x besides channel_axis=1"):
        tracks.warp(f, channel_axis=1)
    with pytest.raises(ValueError, match="stack_axis=3 is out of range"):
        tracks.warp(frames, stack_axis=3)
    with pytest.raises(ValueError, match="named twice"):
        tracks.warp(frames, stack_axis=0, channel_axis=-3)
    with pytest.raises(ValueError, match="1 more axis than y, x and channel_axis=3: name the axes"):
        tracks.warp(frames[:, :, :, None], channel_axis=-1)
    with pytest.raises(ValueError, match="stack_axis"):
        tracks.warp(np.zeros((2, 10, 10, 3), np.uint8))
    with pytest.raises(TypeError, match="stack_axis must be an int or a tuple"):
        tracks.warp(frames, stack_axis="t")


def test_the_axis_rule(tracks):
    ax = trimorph._trimorph._image_axes
    assert ax((511, 511)) == ([], None)
    assert ax((511, 600, 3)) == ([], 2)
    assert ax((5, 600, 1)) == ([], 2)
    assert ax((20, 511, 511, 3), stack_axis=0) == ([0], 3)
    assert ax((511, 511, 20), stack_axis=-1) == ([2], None)
    assert ax((2, 3, 511, 511), stack_axis=(1, 0)) == ([0, 1], None)
    assert ax((3, 511, 511), channel_axis=0) == ([], 0)
    with pytest.raises(ValueError, match=r"planes besides stack_axis=0\)"):
        ax((20, 3, 511, 511), stack_axis=0)


da = pytest.importorskip("dask.array")
import trimorph.dask as tdask  # noqa: E402


def test_dask_reads_a_napari_rgb_array_as_deformation_warp_does(tracks, rgb):
    """Bug: `trimorph.dask.warp` took the last two axes of (Y, X, 3) as y and x."""
    want = tracks.warp(rgb, interp="bicubic")
    got = tdask.warp(da.from_array(rgb, chunks=(100, 128, 1)), tracks, interp="bicubic")
    assert got.shape == rgb.shape
    np.testing.assert_array_equal(got.compute(), want)
    first = np.ascontiguousarray(np.moveaxis(rgb, -1, 0))
    got = tdask.warp(da.from_array(first, chunks=(1, 128, 128)), tracks, channel_axis=0, interp="bicubic")
    np.testing.assert_array_equal(got.compute(), np.moveaxis(want, -1, 0))


def test_dask_stacks_and_channels_equal_deformation_warp(tracks, frames, rgb):
    with pytest.raises(ValueError, match="stack_axis=0"):
        tdask.warp(da.from_array(frames), tracks)
    want = tracks.warp(frames, stack_axis=0, background=5)
    got = tdask.warp(da.from_array(frames, chunks=(2, 200, 256)), tracks, stack_axis=0, background=5)
    np.testing.assert_array_equal(got.compute(), want)
    last = np.ascontiguousarray(np.moveaxis(frames, 0, -1))
    got = tdask.warp(da.from_array(last, chunks=(128, 128, 2)), tracks, stack_axis=2, chunks=(100, 100))
    np.testing.assert_array_equal(got.compute(), np.moveaxis(tracks.warp(frames, stack_axis=0), 0, -1))
    # More than 4 channels: independent planes in both.
    got = tdask.warp(da.from_array(last, chunks=(128, 128, 2)), tracks, channel_axis=-1)
    np.testing.assert_array_equal(got.compute(), tracks.warp(last, channel_axis=-1))
    # Gray + alpha keeps the alpha convention in both (0 where there is no preimage).
    ga = np.stack([frames[0], frames[1]], axis=-1)
    want = tracks.warp(ga, background=40)
    got = tdask.warp(da.from_array(ga, chunks=(128, 128, 1)), tracks, background=40)
    np.testing.assert_array_equal(got.compute(), want)
    # (T, Y, X, C).
    stack = np.stack([rgb, 255 - rgb])
    got = tdask.warp(da.from_array(stack, chunks=(1, 150, 150, 3)), tracks, stack_axis=0)
    np.testing.assert_array_equal(got.compute(), tracks.warp(stack, stack_axis=0))


def test_dask_takes_one_deformation_per_plane(tracks, frames):
    """A sequence registered frame by frame: deformation k warps plane k."""
    ident = trimorph.Deformation.mesh_grid(4, 4, (511, 511))
    shifted = ident.copy()
    shifted.edit([{"op": "translate", "anchors": list(range(shifted.num_vertices)), "by": [3, -2]}])
    defs = [tracks, ident, shifted, tracks, shifted]
    a = da.from_array(frames, chunks=(3, 256, 256))
    got = tdask.warp(a, defs, stack_axis=0, interp="bicubic").compute()
    for k, d in enumerate(defs):
        np.testing.assert_array_equal(got[k], d.warp(frames[k], interp="bicubic"))
    np.testing.assert_array_equal(got[1], frames[1])
    # On another axis.
    last = np.ascontiguousarray(np.moveaxis(frames, 0, -1))
    got_last = tdask.warp(da.from_array(last), defs, stack_axis=-1, interp="bicubic").compute()
    np.testing.assert_array_equal(got_last, np.moveaxis(got, 0, -1))
    with pytest.raises(ValueError, match="3 deformations for 5 planes along stack_axis=0"):
        tdask.warp(a, defs[:3], stack_axis=0)
    with pytest.raises(ValueError, match="needs one stack axis"):
        tdask.warp(da.from_array(frames[0]), [tracks])
    with pytest.raises(TypeError, match=r"deformation\[1\] is str"):
        tdask.warp(a, [tracks, "x", tracks, tracks, tracks], stack_axis=0)
    with pytest.raises(TypeError, match="Deformation or a sequence"):
        tdask.warp(a, 3, stack_axis=0)

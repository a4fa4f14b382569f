"""Zarr outputs that zarr-python 3 opens (issue 55, point 4): the CLI's warp of a uint8 Zarr
v3 image wrote its codec as the bare string "bytes" (zarr-python 3.1: "Expected dict"), and
`trimorph.dask.to_ome_zarr` dropped `dimension_names`.

The JSON checks need no zarr-python (the v3 input is written by hand); reading the outputs
with zarr-python needs zarr >= 3 (skipped otherwise).
"""

import json

import numpy as np
import pytest

import trimorph
from conftest import DATA, read_landmarks_csv

FRAMES = DATA / "microscopy" / "timelapse"


def zarr3():
    zarr = pytest.importorskip("zarr")
    if int(zarr.__version__.split(".")[0]) < 3:
        pytest.skip(f"zarr-python {zarr.__version__}: reading Zarr v3 needs zarr >= 3")
    return zarr


@pytest.fixture(scope="module")
def frames():
    """(2, 511, 511) uint8: frames 0 and 1 of the time-lapse."""
    return np.stack([trimorph.read_image(FRAMES / f"frame_0{k}.png") for k in range(2)])


@pytest.fixture(scope="module")
def tracks(tmp_path_factory):
    names, src, dst = read_landmarks_csv(FRAMES / "tracks_0_9.csv")
    d = trimorph.fit(src, dst, size=(511, 511), names=names)
    path = tmp_path_factory.mktemp("tracks") / "tracks.json"
    d.save(path)
    return d, path


AXES = [{"name": "t", "type": "time"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}]


def write_v3_uint8(path, data, dimension_names=("t", "y", "x")):
    """An OME-Zarr 0.5 image (Zarr v3, uint8) written by hand: one chunk per plane, the
    `bytes` codec alone, so each chunk file is the plane's raw bytes."""
    path.mkdir()
    ms = [{"axes": AXES, "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1.0, 1.0, 1.0]}]}]}]
    group = {"zarr_format": 3, "node_type": "group", "attributes": {"ome": {"version": "0.5", "multiscales": ms}}}
    (path / "zarr.json").write_text(json.dumps(group))
    t, h, w = data.shape
    arr = {
        "zarr_format": 3,
        "node_type": "array",
        "shape": [t, h, w],
        "data_type": "uint8",
        "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": [1, h, w]}},
        "chunk_key_encoding": {"name": "default", "configuration": {"separator": "/"}},
        "fill_value": 0,
        "codecs": [{"name": "bytes"}],
        "attributes": {},
    }
    if dimension_names:
        arr["dimension_names"] = list(dimension_names)
    (path / "0").mkdir()
    (path / "0" / "zarr.json").write_text(json.dumps(arr))
    for k in range(t):
        chunk = path / "0" / "c" / str(k) / "0" / "0"
        chunk.parent.mkdir(parents=True)
        chunk.write_bytes(np.ascontiguousarray(data[k]).tobytes())


def assert_codec_objects(meta):
    codecs = meta["codecs"]
    assert codecs and all(isinstance(c, dict) and isinstance(c.get("name"), str) for c in codecs), codecs
    assert isinstance(meta["chunk_grid"], dict) and isinstance(meta["chunk_key_encoding"], dict)


def test_cli_warp_of_a_uint8_v3_image_writes_codec_objects_and_dimension_names(cli, tracks, frames, tmp_path):
    """Bug: the codec was written as the bare string "bytes". Checked on the JSON itself."""
    d, path = tracks
    src = tmp_path / "in.zarr"
    write_v3_uint8(src, frames)
    out = tmp_path / "out.zarr"
    cli("warp", path, "--image", src, "-o", out)
    meta = json.loads((out / "0" / "zarr.json").read_text())
    assert_codec_objects(meta)
    assert {"name": "bytes"} in meta["codecs"]
    assert meta["data_type"] == "uint8"
    assert meta["dimension_names"] == ["t", "y", "x"]
    arr, axes = trimorph.read_ome_zarr(out)
    assert axes == ["t", "y", "x"]
    np.testing.assert_array_equal(arr, d.warp(frames, stack_axis=0))


def test_zarr_python_3_reads_the_cli_outputs_v2_and_v3(cli, tracks, frames, tmp_path):
    zarr = zarr3()
    d, path = tracks
    want = d.warp(frames, stack_axis=0)
    src = tmp_path / "in3.zarr"
    write_v3_uint8(src, frames)
    out = tmp_path / "out3.zarr"
    cli("warp", path, "--image", src, "-o", out)
    a = zarr.open_array(str(out / "0"), mode="r")
    assert a.metadata.zarr_format == 3 and tuple(a.metadata.dimension_names) == ("t", "y", "x")
    np.testing.assert_array_equal(a[:], want)
    # Zarr v2 (written by zarr-python), uint8 too.
    g = zarr.open_group(str(tmp_path / "in2.zarr"), mode="w", zarr_format=2)
    g.create_array("0", shape=frames.shape, chunks=(1, 256, 256), dtype=frames.dtype)[:] = frames
    g.attrs["multiscales"] = [{"version": "0.4", "axes": AXES, "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1.0] * 3}]}]}]
    out2 = tmp_path / "out2.zarr"
    cli("warp", path, "--image", tmp_path / "in2.zarr", "-o", out2)
    b = zarr.open_array(str(out2 / "0"), mode="r")
    assert b.metadata.zarr_format == 2
    np.testing.assert_array_equal(b[:], want)


def test_dask_to_ome_zarr_keeps_dimension_names_and_zarr_python_reads_it(tracks, frames, tmp_path):
    """Bug: `to_ome_zarr` dropped the source array's `dimension_names` (NGFF 0.5 asks for
    them); v3 outputs keep them, or get the axes' names; v2 outputs are read as before."""
    zarr = zarr3()
    tdask = pytest.importorskip("trimorph.dask")
    d, _ = tracks
    want = d.warp(frames, stack_axis=0)
    for names, fmt in [(("t", "y", "x"), 3), (None, 3), (None, 2)]:
        src = tmp_path / f"src{fmt}{bool(names)}.zarr"
        if fmt == 3:
            write_v3_uint8(src, frames, names)
        else:
            g = zarr.open_group(str(src), mode="w", zarr_format=2)
            g.create_array("0", shape=frames.shape, chunks=(1, 256, 256), dtype=frames.dtype)[:] = frames
            g.attrs["multiscales"] = [{"version": "0.4", "axes": AXES, "datasets": [{"path": "0"}]}]
        arr, like = tdask.read_ome_zarr(src)
        out = src.with_suffix(".out.zarr")
        tdask.to_ome_zarr(tdask.warp(arr, d, stack_axis=0), out, like)
        a = zarr.open_array(str(out / "0"), mode="r")
        assert a.metadata.zarr_format == fmt
        np.testing.assert_array_equal(a[:], want)
        if fmt == 3:
            meta = json.loads((out / "0" / "zarr.json").read_text())
            assert_codec_objects(meta)
            assert meta["dimension_names"] == ["t", "y", "x"], (names, meta)
            assert tuple(a.metadata.dimension_names) == ("t", "y", "x")
        back, _ = trimorph.read_ome_zarr(out)
        np.testing.assert_array_equal(back, want)

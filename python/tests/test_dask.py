"""trimorph.dask.warp (issue 21): chunked warps on Dask, bit-identical to the in-memory
warp, each chunk reading only the input its certified preimage needs; on a LocalCluster of
worker processes with memory limits below the image size, and with a worker killed
mid-run.
"""

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

import trimorph

da = pytest.importorskip("dask.array")
distributed = pytest.importorskip("distributed")
from dask.core import get_dependencies  # noqa: E402

import trimorph.dask as tdask  # noqa: E402

from conftest import DATA, read_landmarks_csv  # noqa: E402

FRAMES = DATA / "microscopy" / "timelapse"


@pytest.fixture(scope="module")
def tracks():
    """A real map: the nucleus tracks of the bundled time-lapse (frame 0 -> 9), fitted over
    the 511 x 511 frame, and the frame itself."""
    names, src, dst = read_landmarks_csv(FRAMES / "tracks_0_9.csv")
    d = trimorph.fit(src, dst, size=(511, 511), names=names)
    img = trimorph.read_image(FRAMES / "frame_00.png")
    return d, np.ascontiguousarray(img if img.ndim == 2 else img[..., 0])


def scaled_map(k):
    """The same tracks fitted over a frame `k` times larger (landmarks scaled by `k`)."""
    names, src, dst = read_landmarks_csv(FRAMES / "tracks_0_9.csv")
    size = 511 * k
    return trimorph.fit(src * k, dst * k, size=(size, size), names=names), size


def smooth_image(h, w, dtype):
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    v = 0.5 + 0.25 * np.sin(x / 37.0) + 0.25 * np.cos(y / 23.0 + x / 101.0)
    if dtype == np.float32:
        return v.astype(np.float32)
    return (v * np.iinfo(dtype).max).astype(dtype)


@pytest.mark.parametrize("interp", ["nearest", "bilinear", "bicubic"])
def test_chunked_warp_is_bit_identical_to_the_in_memory_warp(tracks, interp):
    d, img = tracks
    expect = d.warp(img, interp=interp, background=7)
    for chunks in [(100, 77), (511, 511), (64, 300)]:
        a = da.from_array(img, chunks=(128, 96))
        got = tdask.warp(a, d, interp=interp, background=7, chunks=chunks).compute()
        assert got.dtype == img.dtype and got.shape == img.shape
        assert np.array_equal(got, expect), chunks


def test_leading_axes_and_every_dtype(tracks):
    d, img = tracks
    for dtype in (np.uint8, np.uint16, np.float32):
        base = img.astype(dtype) * (257 if dtype == np.uint16 else 1)
        stack = np.stack([np.stack([base, base[::-1], base[:, ::-1]]) for _ in range(2)])
        stack[1] = stack[1] // 2 if dtype != np.float32 else stack[1] / 3
        a = da.from_array(stack, chunks=(1, 2, 200, 170))
        got = tdask.warp(a, d, interp="bicubic", background=3, stack_axis=(0, 1)).compute()
        expect = np.stack(
            [np.stack([d.warp(p, interp="bicubic", background=3) for p in t]) for t in stack]
        )
        assert np.array_equal(got.view(np.uint8), expect.view(np.uint8)), dtype


def test_each_chunk_depends_only_on_the_input_chunks_its_preimage_touches(tracks):
    d, img = tracks
    a = da.from_array(img, chunks=(64, 64))
    out = tdask.warp(a, d, chunks=(64, 64))
    dsk = dict(out.__dask_graph__())
    plan = tdask.warp_graph_inputs(img.shape, out.chunks, d)
    input_keys = {k for k in dsk if isinstance(k, tuple) and k[0] == a.name}
    some_local = False
    for (i, j), (tile, rect) in plan.items():
        key = (out.name, i, j)
        deps = {k for k in get_dependencies(dsk, key) if k in input_keys}
        y0, x0, h, w = tile
        # The true preimages of the tile's pixel centres (Newton, certified to 0.01 px).
        yy, xx = np.mgrid[y0 : y0 + h, x0 : x0 + w]
        q = np.stack([xx.ravel(), yy.ravel()], axis=1).astype(np.float64)
        p = d.inverse_points(q)
        p = p[~np.isnan(p[:, 0])]
        if rect is None:
            assert len(p) == 0 and not deps, (tile, len(p))
            continue
        ry0, rx0, rh, rw = rect
        # The rectangle holds every preimage with the bilinear taps around it.
        assert p[:, 0].min() - 1 >= rx0 or rx0 == 0, (tile, rect)
        assert p[:, 1].min() - 1 >= ry0 or ry0 == 0, (tile, rect)
        assert p[:, 0].max() + 2 <= rx0 + rw or rx0 + rw == 511, (tile, rect)
        assert p[:, 1].max() + 2 <= ry0 + rh or ry0 + rh == 511, (tile, rect)
        # The task reads exactly the input chunks that meet the rectangle.
        meet = {
            (a.name, bi, bj)
            for bi in range(len(a.chunks[0]))
            for bj in range(len(a.chunks[1]))
            if bi * 64 < ry0 + rh and (bi + 1) * 64 > ry0 and bj * 64 < rx0 + rw and (bj + 1) * 64 > rx0
        }
        assert deps == meet, (tile, rect)
        some_local |= len(deps) <= 9
    assert some_local
    # Far fewer reads than "every chunk needs every input chunk".
    total = sum(len({k for k in get_dependencies(dsk, (out.name, i, j)) if k in input_keys}) for (i, j) in plan)
    assert total < len(plan) * len(input_keys) / 4


def test_too_small_a_window_is_an_error_not_a_wrong_pixel(tracks):
    d, img = tracks
    tile = (200, 200, 50, 50)
    (rect,) = trimorph.tile_inputs(d, img.shape, [tile])
    y0, x0, h, w = rect
    win = img[y0 + 20 : y0 + 30, x0 + 20 : x0 + 30]
    with pytest.raises(ValueError, match="outside the window"):
        trimorph.warp_tile(d, np.ascontiguousarray(win), (y0 + 20, x0 + 20), img.shape, tile)
    ok = trimorph.warp_tile(d, np.ascontiguousarray(img[y0 : y0 + h, x0 : x0 + w]), (y0, x0), img.shape, tile)
    assert np.array_equal(ok, d.warp(img)[200:250, 200:250])


def test_deformations_pickle_exactly(tracks):
    import pickle

    d, img = tracks
    e = pickle.loads(pickle.dumps(d))
    assert e.to_json() == d.to_json()
    assert np.array_equal(e.warp(img), d.warp(img))


def _vm_hwm():
    """This process's peak resident memory (bytes): `VmHWM` of /proc/self/status, the high
    water mark of its own address space (`ru_maxrss` would also count the process it was
    forked from before the exec)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmHWM in /proc/self/status")


def worker_peaks(client):
    """Peak resident memory (bytes) of each worker process so far."""
    return client.run(_vm_hwm)


@pytest.fixture(scope="module")
def large(tmp_path_factory):
    """A 8176 x 8176 float32 zarr image (267 MB, chunks of 512 x 512) and a real map scaled to it (the
    nucleus tracks fitted over the frame times 16)."""
    zarr = pytest.importorskip("zarr")
    d, size = scaled_map(16)
    path = tmp_path_factory.mktemp("large") / "image.zarr"
    z = zarr.open_array(str(path), mode="w", shape=(size, size), chunks=(512, 512), dtype="f4")
    for y in range(0, size, 1024):
        z[y : y + 1024] = smooth_image(min(1024, size - y), size, np.float32) + y / size
    return d, path, size


def test_memory_stays_under_the_worker_limit_on_a_larger_image(large):
    zarr = pytest.importorskip("zarr")
    d, path, size = large
    image_bytes = size * size * 4
    limit = 250 * 2**20
    assert image_bytes > limit
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, memory_limit=limit, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        a = da.from_zarr(str(path))
        out = tdask.warp(a, d)
        target = tmp = str(path) + ".warped.zarr"
        z = zarr.open_array(tmp, mode="w", shape=a.shape, chunks=(512, 512), dtype="f4")
        da.store(out, z, lock=False)
        peaks = worker_peaks(client)
        assert len(peaks) == 2
        for addr, peak in peaks.items():
            assert peak < limit, (addr, peak, limit)
    # Spot-check chunks against the in-memory tile warp of the whole image.
    src = zarr.open_array(str(path), mode="r")
    got = zarr.open_array(target, mode="r")
    whole = d.warp(np.asarray(src[:]))
    assert np.array_equal(np.asarray(got[:]), whole)


def test_a_killed_worker_is_replaced_and_the_result_is_unchanged(tracks):
    d, size = scaled_map(6)
    img = smooth_image(size, size, np.uint16)
    expect = d.warp(img)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        a = da.from_array(img, chunks=(256, 256))
        fut = client.compute(tdask.warp(a, d, chunks=(128, 128)))

        def done(dask_scheduler=None):
            return sum(ts.state == "memory" and ts.key[0].startswith("trimorph-warp") for ts in dask_scheduler.tasks.values() if isinstance(ts.key, tuple))

        t0 = time.time()
        while client.run_on_scheduler(done) < 20 and time.time() - t0 < 60:
            time.sleep(0.02)
        pids = client.run(os.getpid)
        victim_addr, victim = next(iter(pids.items()))
        os.kill(victim, signal.SIGKILL)
        got = fut.result(timeout=300)
        after = client.run(os.getpid)
        assert victim not in after.values()
    assert np.array_equal(got, expect)


def test_ome_zarr_round_trip_keeps_the_ngff_metadata(tmp_path):
    zarr = pytest.importorskip("zarr")
    from conftest import REPO

    src = REPO / "tests" / "data" / "ngff_tcyx_u16_v2_blosc.zarr"
    arr, like = tdask.read_ome_zarr(src)
    assert arr.shape == (2, 2, 48, 64) and arr.dtype == np.uint16
    d = trimorph.Deformation.mesh_grid(3, 3, (63, 47))
    d.edit([{"anchors": {"near": [[31, 23]]}, "neighborhood": 1, "op": "translate", "by": [3, 2]}])
    out = tdask.warp(arr, d, interp="bicubic", stack_axis=(0, 1))
    dst = tmp_path / "warped.zarr"
    tdask.to_ome_zarr(out, dst, like)
    back, meta = tdask.read_ome_zarr(dst)
    ms_in = like["attrs"]["multiscales"][0]
    ms_out = meta["attrs"]["multiscales"][0]
    assert ms_out["axes"] == ms_in["axes"]
    assert ms_out["datasets"][0]["coordinateTransformations"] == ms_in["datasets"][0]["coordinateTransformations"]
    assert len(ms_out["datasets"]) == 1
    for key in like["attrs"]:
        if key != "multiscales":
            assert meta["attrs"][key] == like["attrs"][key]
    data = np.asarray(arr)
    expect = np.stack([np.stack([d.warp(p, interp="bicubic") for p in t]) for t in data])
    assert np.array_equal(np.asarray(back), expect)


def test_bad_input_is_refused_by_name(tracks):
    d, img = tracks
    with pytest.raises(ValueError, match="dtype"):
        tdask.warp(da.from_array(img.astype(np.int32)), d)
    with pytest.raises(ValueError, match="y and x axes"):
        tdask.warp(da.from_array(np.zeros(5, np.uint8)), d)
    with pytest.raises(ValueError, match="multiscales"):
        tdask.read_ome_zarr(FRAMES)


def test_a_failed_write_leaves_the_old_store_as_it_was(tmp_path):
    """to_ome_zarr writes beside the target and renames: a write that fails midway (here a
    chunk whose task raises) keeps the store that was there."""
    src = Path(__file__).resolve().parents[2] / "tests" / "data" / "ngff_tcyx_u16_v2_blosc.zarr"
    arr, like = tdask.read_ome_zarr(src)
    dst = tmp_path / "out.zarr"
    tdask.to_ome_zarr(arr, dst, like)
    before = np.asarray(tdask.read_ome_zarr(dst)[0])

    def boom(block, block_info=None):
        if block_info[None]["chunk-location"][-1] == 1:
            raise RuntimeError("disk full")
        return block + 1

    bad = arr.map_blocks(boom, dtype=arr.dtype)
    with pytest.raises(RuntimeError, match="disk full"):
        tdask.to_ome_zarr(bad, dst, like)
    assert np.array_equal(np.asarray(tdask.read_ome_zarr(dst)[0]), before)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.zarr"]
    tdask.to_ome_zarr(arr + 1, dst, like)
    assert np.array_equal(np.asarray(tdask.read_ome_zarr(dst)[0]), before + 1)

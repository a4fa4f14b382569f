"""A 16k x 16k uint16 zarr image warped through Dask on a LocalCluster (issue 21).

Two worker processes (one thread each), each with a memory limit below the image size.
Reports:

* throughput of the Dask warp, zarr to zarr (read, warp, compress, write);
* the same store copied without a warp (zarr I/O alone, same cluster);
* the in-process warp of the whole image in memory (``Deformation.warp``, both cores);
* peak resident memory of each worker (``VmHWM``);
* the task graph: chunks, tasks, input chunks read per output chunk, bytes read.

The map is real: the bundled nucleus tracks (frame 0 -> 9) fitted over the frame scaled
to the image size. Run: ``python python/benches/dask_warp.py [--size 16384] [--chunk 1024]
[--limit-mb 400] [--dir /tmp/dask_bench]``.
"""

import argparse
import shutil
import statistics
import time
from pathlib import Path

import numpy as np

import trimorph
import trimorph.dask as tdask

DATA = Path(__file__).resolve().parents[2] / "data" / "microscopy" / "timelapse"


def tracks_map(size):
    rows = [l.split(",") for l in (DATA / "tracks_0_9.csv").read_text().splitlines()[1:] if l.strip()]
    k = (size - 1) / 510.0
    src = np.array([[float(r[1]), float(r[2])] for r in rows]) * k
    dst = np.array([[float(r[3]), float(r[4])] for r in rows]) * k
    names = [r[0] for r in rows]
    return trimorph.fit(src, dst, size=(size, size), names=names)


def vm_hwm():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    return -1


def main():
    import dask.array as da
    import distributed
    import zarr
    from dask.core import get_dependencies

    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=16384)
    ap.add_argument("--chunk", type=int, default=1024)
    ap.add_argument("--limit-mb", type=int, default=400)
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--dir", default="/tmp/trimorph_dask_bench")
    a = ap.parse_args()
    n, c = a.size, a.chunk
    root = Path(a.dir)
    shutil.rmtree(root, ignore_errors=True)
    root.mkdir(parents=True)
    t0 = time.perf_counter()
    d = tracks_map(n)
    print(f"map: {d!r} fitted in {time.perf_counter() - t0:.1f} s")
    src = root / "src.zarr"
    z = zarr.open_array(str(src), mode="w", shape=(n, n), chunks=(c, c), dtype="u2")
    x = np.arange(n, dtype=np.float32)
    for y in range(0, n, c):
        yy = np.arange(y, min(y + c, n), dtype=np.float32)[:, None]
        v = 0.5 + 0.25 * np.sin(x / 37.0) + 0.25 * np.cos(yy / 23.0 + x / 101.0)
        z[y : y + len(yy)] = (v * 65535).astype(np.uint16)
    image_mb = n * n * 2 / 2**20
    print(f"image {n}x{n} uint16 = {image_mb:.0f} MiB in chunks of {c}x{c}; worker limit {a.limit_mb} MiB")

    arr = da.from_zarr(str(src))
    out = tdask.warp(arr, d)
    dsk = dict(out.__dask_graph__())
    plan = tdask.warp_graph_inputs((n, n), out.chunks, d)
    reads = []
    read_px = 0
    for (i, j), (tile, rect) in plan.items():
        deps = [k for k in get_dependencies(dsk, (out.name, i, j)) if k[0] == arr.name]
        reads.append(len(deps))
        read_px += rect[2] * rect[3] if rect else 0
    print(
        f"graph: {len(plan)} output chunks, {len(dsk)} tasks (with the input reads); input chunks "
        f"per output chunk: mean {statistics.mean(reads):.2f}, max {max(reads)}; input pixels "
        f"read / image = {read_px / (n * n):.2f}"
    )

    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True,
        memory_limit=a.limit_mb * 2**20, dashboard_address=None,
    ) as cluster, distributed.Client(cluster) as client:
        for rep in range(a.reps):
            dst = root / f"dst{rep}.zarr"
            zt = zarr.open_array(str(dst), mode="w", shape=(n, n), chunks=(c, c), dtype="u2")
            t0 = time.perf_counter()
            da.store(tdask.warp(da.from_zarr(str(src)), d), zt, lock=False)
            t = time.perf_counter() - t0
            print(f"dask warp zarr->zarr, run {rep + 1}: {t:.2f} s, {n * n / t / 1e6:.1f} Mpx/s")
        for rep in range(a.reps):
            dst = root / f"copy{rep}.zarr"
            zt = zarr.open_array(str(dst), mode="w", shape=(n, n), chunks=(c, c), dtype="u2")
            t0 = time.perf_counter()
            da.store(da.from_zarr(str(src)), zt, lock=False)
            t = time.perf_counter() - t0
            print(f"dask copy zarr->zarr (I/O alone), run {rep + 1}: {t:.2f} s")
        peaks = client.run(vm_hwm)
        for addr, p in peaks.items():
            print(f"worker {addr}: peak RSS {p / 2**20:.0f} MiB (limit {a.limit_mb} MiB)")

    img = np.asarray(zarr.open_array(str(src), mode="r")[:])
    for rep in range(a.reps):
        t0 = time.perf_counter()
        whole = d.warp(img)
        t = time.perf_counter() - t0
        print(f"in-process warp in memory, run {rep + 1}: {t:.2f} s, {n * n / t / 1e6:.1f} Mpx/s")
    got = np.asarray(zarr.open_array(str(root / "dst0.zarr"), mode="r")[:])
    print(f"dask result bit-identical to the in-process warp: {np.array_equal(got, whole)}")
    shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()

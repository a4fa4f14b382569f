"""A 1,000-frame synthetic sequence fitted through Dask (issue 21), against `trimorph fit
--frames` on the same inputs.

Inputs (generated in a work folder): frames of `--size` x `--size` uint8 pixels (a smooth
texture shifted by a known per-frame motion) as one multi-page TIFF, a scene (the identity
over a 2x2-cell grid, degree 5) and a folder of per-frame landmark CSVs (`--points`
landmarks, targets = sources moved by the frame's motion), so the frames are independent.

Timed: `fit_frames` on a `LocalCluster(n_workers=2, processes=True, threads_per_worker=1)`
(cluster start-up excluded, reading the inputs included), a rerun that skips every frame
(the resume check), and `trimorph fit --frames` (`TRIMORPH_BIN`, default
`<repo>/target/debug/trimorph`) into another folder; the per-frame deformations of the two
are compared. Run: `python python/benches/dask_fit_frames.py [--frames 1000] [--size 64]`.
"""

import argparse
import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import tifffile

import trimorph
from trimorph._dask_fit import fit_frames

REPO = Path(__file__).resolve().parents[2]


def motion(k: int) -> np.ndarray:
    """Frame k's shift (pixels): a slow circle of radius 2."""
    a = 2 * np.pi * k / 50.0
    return np.array([2.0 * np.cos(a) - 2.0, 2.0 * np.sin(a)])


def make_inputs(work: Path, frames: int, size: int, points: int) -> tuple:
    rng = np.random.default_rng(7)
    y, x = np.mgrid[0:size, 0:size].astype(np.float64)
    pages = []
    for k in range(frames):
        dx, dy = motion(k)
        tex = 127 + 60 * np.sin((x - dx) / 5.0) * np.cos((y - dy) / 7.0)
        pages.append(np.clip(tex, 0, 255).astype(np.uint8))
    stack = work / "seq.tif"
    tifffile.imwrite(stack, np.stack(pages))
    scene = work / "scene.json"
    trimorph.Deformation.mesh_grid(2, 2, (float(size), float(size))).save(scene)
    lms = work / "landmarks"
    lms.mkdir()
    src = rng.uniform(0.2 * size, 0.8 * size, size=(points, 2))
    for k in range(frames):
        dst = src + motion(k)
        rows = ["name,src_x,src_y,dst_x,dst_y"] + [
            f"p{i},{s[0]:.3f},{s[1]:.3f},{d[0]:.3f},{d[1]:.3f}" for i, (s, d) in enumerate(zip(src, dst))
        ]
        (lms / f"seq_{k:03}.csv").write_text("\n".join(rows) + "\n")
    return scene, stack, lms


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--points", type=int, default=5)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--batch", type=int, default=25, help="frames per task of the batched run")
    ap.add_argument("--skip-cli", action="store_true", help="time Dask only")
    args = ap.parse_args()
    from dask.distributed import Client, LocalCluster

    binary = os.environ.get("TRIMORPH_BIN", str(REPO / "target" / "debug" / "trimorph"))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        scene, stack, lms = make_inputs(work, args.frames, args.size, args.points)
        n = args.frames
        print(f"{n} frames of {args.size}x{args.size}, {args.points} landmarks, scene 2x2 cells")

        cluster = LocalCluster(
            n_workers=args.workers, processes=True, threads_per_worker=1, dashboard_address=None
        )
        client = Client(cluster)
        try:
            t0 = time.perf_counter()
            res = fit_frames(scene, stack, lms, work / "dask", client=client)
            t_dask = time.perf_counter() - t0
            assert all(r["status"] == "fitted" for r in res)
            t0 = time.perf_counter()
            again = fit_frames(scene, stack, lms, work / "dask", client=client)
            t_rerun = time.perf_counter() - t0
            assert all(r["status"] == "skipped" for r in again)
            t0 = time.perf_counter()
            res_b = fit_frames(scene, stack, lms, work / "dask_b", client=client, batch=args.batch)
            t_batch = time.perf_counter() - t0
            assert all(r["status"] == "fitted" for r in res_b)
        finally:
            client.close()
            cluster.close()
        print(f"dask ({args.workers} workers): {t_dask:.1f} s, {n / t_dask:.1f} frames/s")
        print(f"dask rerun (all skipped): {t_rerun:.1f} s, {n / t_rerun:.1f} frames/s")
        print(f"dask, batch={args.batch}: {t_batch:.1f} s, {n / t_batch:.1f} frames/s")

        mean_fit = np.mean([r["time_ms"] for r in res])
        print(f"mean fit time per frame (report time_ms): {mean_fit:.1f} ms")
        if args.skip_cli:
            return
        t0 = time.perf_counter()
        p = subprocess.run(
            [binary, "fit", "--model", str(scene), "--frames", str(stack), "--landmarks",
             str(lms), "-o", str(work / "cli")],
            capture_output=True, text=True,
        )
        t_cli = time.perf_counter() - t0
        if p.returncode != 0:
            raise SystemExit(f"trimorph fit --frames failed:\n{p.stderr}")
        print(f"trimorph fit --frames ({binary}): {t_cli:.1f} s, {n / t_cli:.1f} frames/s")
        same = sum(
            (work / "dask" / f"seq_{k:03}.json").read_text()
            == (work / "cli" / f"seq_{k:03}.json").read_text()
            == (work / "dask_b" / f"seq_{k:03}.json").read_text()
            for k in range(n)
        )
        print(f"deformations equal to the CLI's (both Dask runs): {same} of {n}")
        print(json.dumps({"frames": n, "dask_s": t_dask, "dask_rerun_s": t_rerun,
                          "dask_batch_s": t_batch, "cli_s": t_cli, "equal": same}))


if __name__ == "__main__":
    main()

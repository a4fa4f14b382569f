#!/usr/bin/env python3
"""Whole-process `trimorph warp` against OpenCV's remap with a precomputed map (issue 18).

Measured in one run on the same machine: for each input type (gray8, RGB8, gray16), the
wall time of a whole `trimorph warp DEF --image IN.tif -o OUT.tif` process (decode, inverse
map, resampling, encode; uncompressed TIFF in and out) and the time of `cv2.remap` alone
(bilinear, 2 threads) given the map `trimorph field --inverse` computed beforehand, so remap
gets its map for free. Best of `--runs` runs each; throughput in megapixels per second.

Setup (from PyPI):  pip install opencv-python-headless numpy tifffile
Run (repo root):    cargo build --release && python3 benches/remap_compare.py [--size 4096]

The deformation: a 10 x 10 grid over the image (degree 5) fitted to 12 landmarks, two
interior ones dragged by size/40 px (the scale of `benches/warp.rs`), the rest held. With
`--default-fit` (issue 51): the bundled time-lapse tracks of frames 0 and 9, scaled from 511
px to the size, fitted with all defaults (`trimorph fit --size N,N`: a landmark-adapted
mesh with far-field rings 16 times the frame), the map a new user warps through.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np
import tifffile


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    return r.stdout


def best(f, runs):
    t = float("inf")
    for _ in range(runs):
        t0 = time.perf_counter()
        f()
        t = min(t, time.perf_counter() - t0)
    return t


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trimorph", default="target/release/trimorph")
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--default-fit", action="store_true",
                    help="warp through a default fit of the scaled time-lapse tracks")
    a = ap.parse_args()
    n = a.size
    tm = a.trimorph
    with tempfile.TemporaryDirectory() as d:
        p = lambda name: os.path.join(d, name)
        run([tm, "mesh", "--grid", "10x10", "--size", f"{n - 1},{n - 1}", "-o", p("id.json")])
        s = n - 1
        drag = n / 40
        held = [(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9), (0.5, 0.1), (0.5, 0.9),
                (0.1, 0.5), (0.9, 0.5), (0.5, 0.5), (0.7, 0.3)]
        with open(p("lm.csv"), "w") as f:
            f.write("name,src_x,src_y,dst_x,dst_y\n")
            for k, (u, v) in enumerate(held):
                f.write(f"h{k},{u * s},{v * s},{u * s},{v * s}\n")
            f.write(f"a,{0.3 * s},{0.3 * s},{0.3 * s - drag},{0.3 * s + drag / 2}\n")
            f.write(f"b,{0.6 * s},{0.7 * s},{0.6 * s + drag},{0.7 * s + drag / 2}\n")
        if a.default_fit:
            k = n / 511
            src = os.path.join(os.path.dirname(__file__), "..", "data", "microscopy",
                               "timelapse", "tracks_0_9.csv")
            with open(src) as f, open(p("lm.csv"), "w") as o:
                o.write(f.readline())
                for line in f:
                    name, *v = line.strip().split(",")
                    o.write(name + "," + ",".join(f"{float(x) * k:.3f}" for x in v) + "\n")
            run([tm, "fit", "--size", f"{n},{n}", "--landmarks", p("lm.csv"), "-o", p("def.json")])
        else:
            run([tm, "fit", p("id.json"), "--landmarks", p("lm.csv"), "--bend", "1e-3",
                 "-o", p("def.json")])
        run([tm, "field", p("def.json"), "--inverse", "-o", p("inv.npy"), "--size", f"{n},{n}"])
        inv = np.load(p("inv.npy"))
        yy, xx = np.mgrid[0:n, 0:n].astype(np.float32)
        mapx = np.nan_to_num(xx + inv[..., 0], nan=-1.0).astype(np.float32)
        mapy = np.nan_to_num(yy + inv[..., 1], nan=-1.0).astype(np.float32)
        cv2.setNumThreads(a.threads)
        x = np.arange(n, dtype=np.uint32)[None, :]
        y = np.arange(n, dtype=np.uint32)[:, None]
        base = ((x // 7 + y // 5) % 2 * 200 + (x ^ y) % 50).astype(np.uint8)
        images = {
            "gray8": base,
            "RGB8": np.stack([base, base // 2 + 60, 255 - base], axis=-1),
            "gray16": base.astype(np.uint16) * 257,
        }
        print(f"# {n}x{n}, best of {a.runs}; trimorph: whole process, uncompressed TIFF in "
              f"and out; remap: cv2.remap bilinear alone, {a.threads} threads, map given")
        print("| input | trimorph | remap | ratio |")
        print("|---|---|---|---|")
        for name, img in images.items():
            tifffile.imwrite(p("in.tif"), img, photometric="rgb" if img.ndim == 3 else None)
            cmd = [tm, "warp", p("def.json"), "--image", p("in.tif"), "-o", p("out.tif")]
            t_tm = best(lambda: run(cmd), a.runs)
            t_cv = best(lambda: cv2.remap(img, mapx, mapy, cv2.INTER_LINEAR,
                                          borderMode=cv2.BORDER_CONSTANT), a.runs)
            mp = n * n / 1e6
            print(f"| {name} | {mp / t_tm:,.0f} MP/s | {mp / t_cv:,.0f} MP/s | "
                  f"{t_cv / t_tm:.2f} |")
            sys.stdout.flush()


if __name__ == "__main__":
    main()

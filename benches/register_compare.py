#!/usr/bin/env python3
"""trimorph register against elastix (itk-elastix) on real images with a known smooth warp.

For each pair: MOVING is a real microscopy image (grey); FIXED(x) = MOVING(psi(x)) + noise,
where psi (FIXED -> MOVING pixels) is a small rotation and shift plus a smooth random field
of a few pixels (cubic upsampling of a 6 x 6 Gaussian grid). The error of a registration is
the mean endpoint error of its FIXED -> MOVING map against psi over the image content
(pixels at least 16 px from the border whose smoothed gradient is in the top half):
`|phi^-1(x) - psi(x)|` for trimorph (`trimorph field --inverse`), `|T(x) - psi(x)|` for
elastix (`transformix` deformation field of its default B-spline registration).

Usage: register_compare.py TRIMORPH_BIN [--pairs ihc,cell,nuclei] [--mi] [--write-pair DIR]
(needs numpy, scipy, pillow, tifffile and itk-elastix)
Prints one JSON line per pair and method.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from PIL import Image
from scipy import ndimage

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "data", "microscopy")


def grey(path):
    a = np.asarray(Image.open(path).convert("RGB"), dtype=np.float64) / 255.0
    return 0.2126 * a[..., 0] + 0.7152 * a[..., 1] + 0.0722 * a[..., 2]


def images():
    return {
        "ihc": grey(os.path.join(DATA, "ihc.png")),
        "cell": grey(os.path.join(DATA, "cell.png")),
        "nuclei": grey(os.path.join(DATA, "timelapse", "frame_00.png")),
    }


def known_map(h, w, amp, seed, knots=6):
    """psi(x) - x as (dy, dx) arrays: rotation 1.5 deg and shift (2.5, -1.5) about the
    centre, plus a smooth random field of mean magnitude `amp` px (cubic through a
    `knots x knots` grid of random values: features about 1/knots of the image across)."""
    rng = np.random.default_rng(seed)
    g = rng.normal(size=(2, knots, knots))
    f = np.stack([ndimage.zoom(g[k], (h / knots, w / knots), order=3)[:h, :w] for k in (0, 1)])
    f *= amp / np.sqrt((f ** 2).sum(0)).mean()
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    cy, cx = (h - 1) / 2.0, (w - 1) / 2.0
    a = np.deg2rad(1.5)
    ry = cy + np.sin(a) * (xx - cx) + np.cos(a) * (yy - cy) - yy
    rx = cx + np.cos(a) * (xx - cx) - np.sin(a) * (yy - cy) - xx
    return f[0] + ry + 2.5, f[1] + rx - 1.5


def make_pair(m, amp, noise, seed, invert_gamma=False, knots=6):
    h, w = m.shape
    dy, dx = known_map(h, w, amp, seed, knots)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    f = ndimage.map_coordinates(m, [yy + dy, xx + dx], order=3, mode="nearest")
    if invert_gamma:
        f = (1.0 - np.clip(f, 0, 1)) ** 0.6
    rng = np.random.default_rng(seed + 1)
    f = f + rng.normal(scale=noise, size=f.shape)
    return f.astype(np.float32), dy, dx


def content_mask(m, dy, dx):
    h, w = m.shape
    g = ndimage.gaussian_gradient_magnitude(m, 2.0)
    yy, xx = np.mgrid[0:h, 0:w]
    g = ndimage.map_coordinates(g, [yy + dy, xx + dx], order=1, mode="nearest")
    inner = (yy >= 16) & (yy < h - 16) & (xx >= 16) & (xx < w - 16)
    return inner & (g >= np.median(g[inner]))


def run_elastix(f, m, metric_mi):
    import itk

    fixed = itk.GetImageFromArray(np.ascontiguousarray(f))
    moving = itk.GetImageFromArray(np.ascontiguousarray(m.astype(np.float32)))
    po = itk.ParameterObject.New()
    po.AddParameterMap(po.GetDefaultParameterMap("bspline"))
    t0 = time.perf_counter()
    _, tp = itk.elastix_registration_method(fixed, moving, parameter_object=po, log_to_console=False)
    secs = time.perf_counter() - t0
    # transformix writes deformationField.nii into its output directory (the working
    # directory unless told): keep it in a temporary one.
    with tempfile.TemporaryDirectory() as out:
        field = itk.GetArrayFromImage(
            itk.transformix_deformation_field(moving, tp, output_directory=out))
    return field[..., 1], field[..., 0], secs


def run_trimorph(binary, f, m, tmp, extra):
    import tifffile

    fp, mp = os.path.join(tmp, "fixed.tif"), os.path.join(tmp, "moving.tif")
    tifffile.imwrite(fp, f.astype(np.float32))
    tifffile.imwrite(mp, m.astype(np.float32))
    out, rep, inv = (os.path.join(tmp, n) for n in ("def.json", "report.json", "inv.npy"))
    t0 = time.perf_counter()
    subprocess.run([binary, "register", fp, mp, "-o", out, "--report", rep] + extra, check=True,
                   stdout=subprocess.DEVNULL)
    secs = time.perf_counter() - t0
    h, w = f.shape
    subprocess.run([binary, "field", out, "-o", inv, "--inverse", "--size", f"{w},{h}"], check=True,
                   stdout=subprocess.DEVNULL)
    d = np.load(inv)
    with open(rep) as fh:
        report = json.load(fh)
    return d[..., 1], d[..., 0], secs, report


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("binary")
    ap.add_argument("--pairs", default="ihc,cell,nuclei")
    ap.add_argument("--amp", type=float, default=3.0)
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--knots", type=int, default=6,
                    help="the known field's random grid (larger: finer deformation)")
    ap.add_argument("--mi", action="store_true", help="inverted + gamma FIXED, --metric mi")
    ap.add_argument("--extra", default="", help="extra trimorph register arguments")
    ap.add_argument("--scale", type=float, default=1.0,
                    help="upsample every image by this factor (cubic) first: the users' sizes")
    ap.add_argument("--write-pair", metavar="DIR",
                    help="only write the first pair as DIR/fixed.tif and DIR/moving.tif")
    args = ap.parse_args()
    imgs = images()
    if args.scale != 1.0:
        imgs = {k: np.clip(ndimage.zoom(v, args.scale, order=3), 0.0, 1.0)
                for k, v in imgs.items()}
    if args.write_pair:
        import tifffile

        m = imgs[args.pairs.split(",")[0]]
        f, _, _ = make_pair(m, args.amp, args.noise, 10, invert_gamma=args.mi, knots=args.knots)
        os.makedirs(args.write_pair, exist_ok=True)
        tifffile.imwrite(os.path.join(args.write_pair, "fixed.tif"), f)
        tifffile.imwrite(os.path.join(args.write_pair, "moving.tif"), m.astype(np.float32))
        return
    for k, name in enumerate(args.pairs.split(",")):
        m = imgs[name]
        f, dy, dx = make_pair(m, args.amp, args.noise, 10 + k, invert_gamma=args.mi, knots=args.knots)
        mask = content_mask(m, dy, dx)
        err = lambda ey, ex: float(np.nanmean(np.hypot(ey - dy, ex - dx)[mask]))
        base = float(np.mean(np.hypot(dy, dx)[mask]))
        extra = (["--metric", "mi"] if args.mi else []) + args.extra.split()
        with tempfile.TemporaryDirectory() as tmp:
            ty, tx, ts, rep = run_trimorph(args.binary, f, m, tmp, extra)
        ey, ex, es = run_elastix(f, m, args.mi)
        print(json.dumps({"pair": name, "size": list(m.shape[::-1]), "identity_error": base,
                          "trimorph_error": err(ty, tx), "trimorph_s": ts,
                          "fold_free": rep["fold_free"], "elastix_error": err(ey, ex),
                          "elastix_s": es}))
        sys.stdout.flush()


if __name__ == "__main__":
    main()

"""`trimorph register` against elastix's default B-spline registration (itk-elastix), on the
bundled real immunohistochemistry image warped by a known smooth map plus noise.

The error of a registration is the mean endpoint error of its FIXED -> MOVING map against the
known map psi over the image interior (16 px from the border): `phi^-1(x)` for trimorph
(`trimorph field --inverse`), `T(x)` for elastix (transformix's deformation field). Both run
on the same pair; trimorph must be at least as accurate and certified fold-free. With
`--metric mi` on FIXED inverted with gamma 0.6, it must stay under 1 px and within 1.25x of
elastix. The timings
are printed (the benchmark with timings is `benches/register_compare.py`).
"""

import json
import subprocess
import time

import numpy as np
import pytest
from conftest import REPO

itk = pytest.importorskip("itk")
tifffile = pytest.importorskip("tifffile")


def bilinear(img, y, x):
    h, w = img.shape
    y = np.clip(y, 0, h - 1.001)
    x = np.clip(x, 0, w - 1.001)
    i, j = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = y - i, x - j
    return ((1 - fy) * ((1 - fx) * img[i, j] + fx * img[i, j + 1])
            + fy * ((1 - fx) * img[i + 1, j] + fx * img[i + 1, j + 1]))


def known_pair(repo=REPO, seed=3, invert_gamma=False):
    rgb = itk.GetArrayFromImage(itk.imread(str(repo / "data/microscopy/ihc.png"))).astype(float) / 255
    m = (0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2])[96:352, 128:384]
    h, w = m.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    # psi - x: a shift, a small rotation and two smooth waves (a few pixels).
    a = np.deg2rad(1.2)
    cy, cx = (h - 1) / 2, (w - 1) / 2
    dy = cy + np.sin(a) * (xx - cx) + np.cos(a) * (yy - cy) - yy + 1.5 + 1.5 * np.sin(xx / 37.0)
    dx = cx + np.cos(a) * (xx - cx) - np.sin(a) * (yy - cy) - xx - 2.0 + 1.2 * np.cos(yy / 29.0)
    f = bilinear(m, yy + dy, xx + dx)
    if invert_gamma:
        f = (1.0 - np.clip(f, 0, 1)) ** 0.6
    f = f + np.random.default_rng(seed).normal(scale=0.02, size=f.shape)
    return f.astype(np.float32), m.astype(np.float32), dy, dx


def interior_error(ey, ex, dy, dx):
    b = 16
    e = np.hypot(ey - dy, ex - dx)[b:-b, b:-b]
    return float(np.nanmean(e))


@pytest.mark.parametrize("metric", ["ncc", "mi"])
def test_register_is_at_least_as_accurate_as_elastix_bspline(trimorph_bin, tmp_path, metric):
    # mi: FIXED inverted with gamma 0.6 (another modality); elastix's default map uses Mattes
    # mutual information either way.
    f, m, dy, dx = known_pair(invert_gamma=metric == "mi")
    fp, mp = tmp_path / "fixed.tif", tmp_path / "moving.tif"
    tifffile.imwrite(fp, f)
    tifffile.imwrite(mp, m)
    out, rep, inv = tmp_path / "def.json", tmp_path / "rep.json", tmp_path / "inv.npy"
    t0 = time.perf_counter()
    subprocess.run([str(trimorph_bin), "register", str(fp), str(mp), "-o", str(out),
                    "--report", str(rep), "--metric", metric], check=True, capture_output=True)
    t_trimorph = time.perf_counter() - t0
    h, w = f.shape
    subprocess.run([str(trimorph_bin), "field", str(out), "-o", str(inv), "--inverse",
                    "--size", f"{w},{h}"], check=True, capture_output=True)
    d = np.load(inv)
    e_trimorph = interior_error(d[..., 1], d[..., 0], dy, dx)
    report = json.loads(rep.read_text())
    assert report["fold_free"] is True and report["det_j_lower_bound"] > 0

    po = itk.ParameterObject.New()
    po.AddParameterMap(po.GetDefaultParameterMap("bspline"))
    t0 = time.perf_counter()
    _, tp = itk.elastix_registration_method(itk.GetImageFromArray(f), itk.GetImageFromArray(m),
                                            parameter_object=po, log_to_console=False)
    t_elastix = time.perf_counter() - t0
    # transformix writes deformationField.nii into its output directory (the working
    # directory unless told): a temporary one (bug: a stray copy was committed at the top).
    field = itk.GetArrayFromImage(itk.transformix_deformation_field(
        itk.GetImageFromArray(m), tp, output_directory=str(tmp_path)))
    e_elastix = interior_error(field[..., 1], field[..., 0], dy, dx)
    e_identity = interior_error(0 * dy, 0 * dx, dy, dx)
    print(f"{metric}: identity {e_identity:.3f} px, trimorph {e_trimorph:.3f} px ({t_trimorph:.2f} s), "
          f"elastix {e_elastix:.3f} px ({t_elastix:.2f} s)")
    assert e_identity > 2.0
    if metric == "ncc":
        assert e_trimorph <= e_elastix, (e_trimorph, e_elastix)
    else:
        # Issue 50's two-modality target: under 1 px and within 1.25x of elastix.
        assert e_trimorph < 1.0 and e_trimorph <= 1.25 * e_elastix, (e_trimorph, e_elastix)

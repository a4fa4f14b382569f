"""`trimorph field DEF -o F.h5` read by SimpleITK (issue 20, item 2).

The test drives the `trimorph` binary (env var TRIMORPH_BIN, else <repo>/target/debug/trimorph,
built by `cargo build`) on a real deformation: the bundled nucleus tracks of the time-lapse
(frame 0 -> frame 9, data/microscopy/timelapse/tracks_0_9.csv) fitted over a 6 x 6 grid on the
511 x 511 frame, which moves pixels by up to ~45 px and leaves part of the frame without a
preimage (the background region).

Which way the files run (see src/io/itk.rs):
* F.h5 (default) stores v(q) = phi^-1(q) - q: TransformPoint(q) = `warp --points --inverse`,
  Resample(moving, reference, T) = `warp --image`;
* F.h5 with --inverse stores u(p) = phi(p) - p: TransformPoint(p) = `warp --points`.
"""

import os
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest
import SimpleITK as sitk
import tifffile

REPO = Path(__file__).resolve().parents[2]
W = H = 511

# The inverse tolerance of `trimorph field` and `warp` (px): the field's preimages and the
# Newton preimages of `warp --points --inverse` are each within it (measured: 0.006 px).
INVERSE_TOL = 0.01
# Off-grid points: ITK interpolates the stored field linearly between pixel centres; with the
# inverse tolerance this stays within 0.02 px here (measured: 0.0056 px).
OFFGRID_TOL = 0.02
# The forward file at pixel centres: the same f64 evaluation, up to x + (phi(x) - x) rounding.
FORWARD_TOL = 1e-9
# Resample vs `warp --image` on a float32 image of range 1..254: both sample the same
# preimages bilinearly, in float32 (measured: 1.5e-5).
IMAGE_TOL = 1e-3
# Pixel centres on the rim of the defined region may be defined in one map only (a preimage
# within the inverse tolerance of the mesh boundary); at most this many (measured: 6).
RIM_MAX = 50
BACKGROUND = -1.0


def binary() -> str:
    path = os.environ.get("TRIMORPH_BIN") or str(REPO / "target" / "debug" / "trimorph")
    if not Path(path).is_file():
        pytest.fail(
            f"trimorph binary not found at {path}: run `cargo build` in {REPO} or set TRIMORPH_BIN"
        )
    return path


def run(*args) -> str:
    r = subprocess.run([binary(), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"trimorph {' '.join(map(str, args))}\n{r.stdout}\n{r.stderr}"
    return r.stdout


def read_points(path: Path) -> np.ndarray:
    """`x,y` rows as written by `warp --points`; empty rows (no image) are NaN."""
    rows = []
    for line in path.read_text().splitlines()[1:]:
        x, y = line.split(",")
        rows.append([float(x), float(y)] if x else [np.nan, np.nan])
    return np.array(rows)


def write_points(path: Path, pts: np.ndarray) -> None:
    path.write_text("x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in pts.tolist()))


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    d = tmp_path_factory.mktemp("itk")
    run("mesh", "--grid", "6x6", "--size", "510,510", "-o", d / "ref.json")
    tracks = REPO / "data" / "microscopy" / "timelapse" / "tracks_0_9.csv"
    run("fit", d / "ref.json", "--landmarks", tracks, "-o", d / "def.json")
    # The grid spans the pixel centres 0..510 exactly (so trimorph and ITK agree on every
    # pixel, see the README's "One difference"); its recorded frame is then 510 x 510, and
    # the field is asked for the image's 511 x 511 grid.
    line = run("field", d / "def.json", "-o", d / "F.h5", "--size", "511,511")
    assert "phi^-1(q) - q" in line and "511x511" in line, line
    line_fwd = run("field", d / "def.json", "--inverse", "-o", d / "Fi.h5", "--size", "511,511")
    assert "phi(p) - p" in line_fwd, line_fwd
    centres = np.array([[x, y] for y in range(H) for x in range(W)], dtype=float)
    write_points(d / "centres.csv", centres)
    run("warp", d / "def.json", "--points", d / "centres.csv", "--inverse", "-o", d / "inv.csv")
    run("warp", d / "def.json", "--points", d / "centres.csv", "-o", d / "fwd.csv")
    return {
        "dir": d,
        "line": line,
        "centres": centres,
        "inv": read_points(d / "inv.csv"),
        "fwd": read_points(d / "fwd.csv"),
    }


def test_h5py_sees_itk_layout(case):
    with h5py.File(case["dir"] / "F.h5", "r") as f:
        strings = ["ITKVersion", "HDFVersion", "OSName", "OSVersion"]
        for name in strings + ["TransformGroup/0/TransformType"]:
            ds = f[name]
            assert ds.shape == (1,), name
            # ITK reads its strings as variable-length ASCII (C_S1, H5T_VARIABLE).
            info = h5py.check_string_dtype(ds.dtype)
            assert info is not None and info.length is None and info.encoding == "ascii", name
        assert f["TransformGroup/0/TransformType"][0] == b"DisplacementFieldTransform_double_2_2"
        assert list(f["TransformGroup"].keys()) == ["0"]
        fixed = f["TransformGroup/0/TranformFixedParameters"]
        params = f["TransformGroup/0/TranformParameters"]
        assert fixed.dtype == np.float64 and params.dtype == np.float64
        assert fixed[()].tolist() == [W, H, 0, 0, 1, 1, 1, 0, 0, 1]
        assert params.shape == (2 * W * H,)
        # x fastest, (dx, dy) interleaved: entry (x, y) is phi^-1 at (x, y) minus (x, y).
        v = params[()].reshape(H, W, 2)
        x, y = 300, 123
        assert np.abs(v[y, x] - (case["inv"][y * W + x] - [x, y])).max() <= INVERSE_TOL


def test_sitk_reads_the_transform_with_its_pixel_grid(case):
    t = sitk.ReadTransform(str(case["dir"] / "F.h5"))
    assert t.GetName() == "DisplacementFieldTransform"
    field = sitk.DisplacementFieldTransform(t).GetDisplacementField()
    assert field.GetSize() == (W, H)
    assert field.GetOrigin() == (0.0, 0.0)
    assert field.GetSpacing() == (1.0, 1.0)
    assert field.GetDirection() == (1.0, 0.0, 0.0, 1.0)
    # ITK's grid index (x, y) is the physical point (x, y): trimorph's centre of pixel (x, y).
    for idx in [(0, 0), (5, 7), (300, 123), (W - 1, H - 1)]:
        assert field.TransformIndexToPhysicalPoint(idx) == (float(idx[0]), float(idx[1]))
    # ... and the value stored there is phi^-1 at that pixel centre, minus the centre.
    x, y = 300, 123
    want = case["inv"][y * W + x] - [x, y]
    got = np.array(field.GetPixel(x, y))
    assert np.abs(got - want).max() <= INVERSE_TOL, (got, want)
    undefined = int(np.isnan(sitk.GetArrayViewFromImage(field)[..., 0]).sum())
    assert undefined > 1000 and f"({undefined} pixels undefined" in case["line"], case["line"]


def test_transform_point_is_warp_points_inverse_at_pixel_centres(case):
    t = sitk.ReadTransform(str(case["dir"] / "F.h5"))
    got = np.array([t.TransformPoint(tuple(q)) for q in case["centres"].tolist()])
    ref = case["inv"]
    both = ~np.isnan(got[:, 0]) & ~np.isnan(ref[:, 0])
    assert both.sum() > 0.8 * W * H
    err = np.abs(got[both] - ref[both]).max()
    assert err <= INVERSE_TOL, err
    moved = np.hypot(*(ref[both] - case["centres"][both]).T).max()
    assert moved > 10.0, f"a visible deformation ({moved} px)"
    # Undefined pixels are NaN in ITK too, up to the rim of the defined region.
    differ = np.isnan(got[:, 0]) != np.isnan(ref[:, 0])
    assert differ.sum() <= RIM_MAX, differ.sum()
    nan = np.isnan(got[:, 0]).reshape(H, W)
    for i in np.flatnonzero(differ):
        y, x = divmod(int(i), W)
        neighbours = nan[max(y - 1, 0) : y + 2, max(x - 1, 0) : x + 2]
        assert neighbours.any(), f"({x}, {y}) differs away from the rim"


def test_transform_point_off_grid_interpolates_within_tolerance(case):
    d = case["dir"]
    rng = np.random.default_rng(20)
    pts = rng.uniform(0.0, W - 1.0, size=(4000, 2))
    write_points(d / "off.csv", pts)
    run("warp", d / "def.json", "--points", d / "off.csv", "--inverse", "-o", d / "off_inv.csv")
    ref = read_points(d / "off_inv.csv")
    t = sitk.ReadTransform(str(d / "F.h5"))
    got = np.array([t.TransformPoint(tuple(p)) for p in pts.tolist()])
    # A point is interpolated from the 4 pixel centres around it: all must be defined.
    nan = np.isnan(case["inv"][:, 0]).reshape(H, W)
    x0, y0 = np.floor(pts).astype(int).T
    x1, y1 = np.minimum(x0 + 1, W - 1), np.minimum(y0 + 1, H - 1)
    corners = nan[y0, x0] | nan[y0, x1] | nan[y1, x0] | nan[y1, x1]
    inside = ~corners & ~np.isnan(ref[:, 0])
    assert inside.sum() > 3000
    assert not np.isnan(got[inside]).any(), "NaN only next to an undefined pixel centre"
    err = np.abs(got[inside] - ref[inside]).max()
    assert err <= OFFGRID_TOL, err


def test_resample_reproduces_warp_image_with_background(case):
    d = case["dir"]
    frame = REPO / "data" / "microscopy" / "timelapse" / "frame_00.png"
    img = sitk.GetArrayFromImage(sitk.ReadImage(str(frame))).astype(np.float32)
    assert img.shape == (H, W)
    tifffile.imwrite(d / "in.tif", img)
    out = d / "out.tif"
    run("warp", d / "def.json", "--image", d / "in.tif", "-o", out, f"--background={BACKGROUND}")
    want = tifffile.imread(out)
    assert want.dtype == np.float32 and want.shape == (H, W)
    moving = sitk.GetImageFromArray(img)
    t = sitk.ReadTransform(str(d / "F.h5"))
    got = sitk.GetArrayFromImage(
        sitk.Resample(moving, moving, t, sitk.sitkLinear, BACKGROUND, sitk.sitkFloat32)
    )
    bg_want, bg_got = want == BACKGROUND, got == BACKGROUND
    assert bg_want.sum() > 1000, "the deformation leaves a background region"
    assert (bg_want == bg_got).all(), (bg_want != bg_got).sum()
    err = np.abs(got - want).max()
    assert err <= IMAGE_TOL, err
    assert np.abs(want[~bg_want] - img[~bg_want]).max() > 50, "the warp changes the image"


def test_inverse_file_is_the_forward_map(case):
    t = sitk.ReadTransform(str(case["dir"] / "Fi.h5"))
    got = np.array([t.TransformPoint(tuple(p)) for p in case["centres"].tolist()])
    ref = case["fwd"]
    assert not np.isnan(ref).any() and not np.isnan(got).any()
    err = np.abs(got - ref).max()
    assert err <= FORWARD_TOL, err


def test_python_to_itk_writes_the_cli_file(case, tmp_path):
    """`Deformation.to_itk` is `trimorph field -o F.h5`, in both directions."""
    import trimorph

    d = trimorph.Deformation.load(case["dir"] / "def.json")
    for inverse, name in [(False, "F.h5"), (True, "Fi.h5")]:
        out = tmp_path / name
        undefined = d.to_itk(out, inverse=inverse, size=(W, H))
        with h5py.File(out, "r") as ours, h5py.File(case["dir"] / name, "r") as ref:
            for key in ["TranformFixedParameters", "TranformParameters"]:
                np.testing.assert_array_equal(
                    ours[f"TransformGroup/0/{key}"][()], ref[f"TransformGroup/0/{key}"][()]
                )
            v = ours["TransformGroup/0/TranformParameters"][()]
            assert undefined == int(np.isnan(v[0::2]).sum())
    t = sitk.ReadTransform(str(tmp_path / "F.h5"))
    q = np.array([[300.0, 123.0], [17.0, 402.0]])
    np.testing.assert_allclose(
        [t.TransformPoint(tuple(p)) for p in q.tolist()], d.inverse_points(q), atol=INVERSE_TOL
    )
    with pytest.raises(ValueError, match=r"\.h5"):
        d.to_itk(tmp_path / "F.txt")


def test_resample_with_spacing_and_origin_reproduces_warp(case, tmp_path):
    """On a SimpleITK image with a physical spacing and origin, `Resample` through
    `to_itk(spacing=, origin=)` reproduces trimorph's warp of its pixel array (the issue's
    case: without the placement, spacing 0.5 differed by up to 87.5 grey levels)."""
    import trimorph

    spacing, origin = (0.5, 0.25), (12.5, -4.0)
    frame = REPO / "data" / "microscopy" / "timelapse" / "frame_00.png"
    img = sitk.GetArrayFromImage(sitk.ReadImage(str(frame))).astype(np.float32)
    d = trimorph.Deformation.load(case["dir"] / "def.json")
    want = d.warp(img, background=BACKGROUND)
    moving = sitk.GetImageFromArray(img)
    moving.SetSpacing(spacing)
    moving.SetOrigin(origin)

    def resample(h5):
        t = sitk.ReadTransform(str(h5))
        return sitk.GetArrayFromImage(
            sitk.Resample(moving, moving, t, sitk.sitkLinear, BACKGROUND, sitk.sitkFloat32)
        )

    placed = tmp_path / "placed.h5"
    d.to_itk(placed, size=(W, H), spacing=spacing, origin=origin)
    got = resample(placed)
    bg = want == BACKGROUND
    assert bg.sum() > 1000 and (bg == (got == BACKGROUND)).all()
    assert np.abs(got - want).max() <= IMAGE_TOL
    # The pixel-unit file on the same image is wrong: that is what the placement fixes.
    assert np.abs(resample(case["dir"] / "F.h5") - want).max() > 50
    with h5py.File(placed, "r") as f:
        fixed = f["TransformGroup/0/TranformFixedParameters"][()]
    np.testing.assert_array_equal(fixed[2:6], [*origin, *spacing])
    # Recorded with the frame: to_itk defaults to it, it survives save/load, and the CLI
    # writes the same file (with --spacing/--origin, or from the recorded frame).
    rec = d.with_frame(size=(W, H), spacing=spacing, origin=origin, unit="micrometer")
    assert rec.frame == {"size": [W, H], "spacing": list(spacing), "origin": list(origin),
                         "unit": "micrometer"}
    assert d.frame is None or "spacing" not in d.frame, "with_frame returns a copy"
    rec.save(tmp_path / "rec.json")
    again = trimorph.Deformation.load(tmp_path / "rec.json")
    assert again.frame == rec.frame
    for h5, make in [
        (tmp_path / "rec.h5", lambda p: again.to_itk(p)),
        (tmp_path / "cli.h5", lambda p: run("field", case["dir"] / "def.json", "-o", p,
                                            "--size", f"{W},{H}", "--spacing", "0.5,0.25",
                                            "--origin", "12.5,-4")),
        (tmp_path / "clirec.h5", lambda p: run("field", tmp_path / "rec.json", "-o", p)),
    ]:
        make(h5)
        with h5py.File(h5, "r") as a, h5py.File(placed, "r") as b:
            for key in ["TranformFixedParameters", "TranformParameters"]:
                np.testing.assert_array_equal(
                    a[f"TransformGroup/0/{key}"][()], b[f"TransformGroup/0/{key}"][()]
                )
    # A spacing that is not a binary fraction: ITK's own index arithmetic ((o + s i - o) / s
    # is not exactly i) then reaches the undefined (NaN) neighbours of some pixels next to
    # the background, which it resamples to the background too. Everywhere else it agrees.
    moving.SetSpacing((0.3, 0.7))
    d.to_itk(placed, size=(W, H), spacing=(0.3, 0.7), origin=origin)
    got = resample(placed)
    near = bg.copy()  # the background grown by one pixel, diagonals included
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            near |= np.roll(bg, (dy, dx), axis=(0, 1))
    assert ((got == BACKGROUND) != bg).sum() < 0.01 * bg.size
    assert not (((got == BACKGROUND) != bg) & ~near).any(), "only next to undefined pixels"
    both = ~bg & (got != BACKGROUND)
    assert np.abs(got - want)[both].max() <= IMAGE_TOL
    with pytest.raises(ValueError, match="spacing"):
        d.to_itk(tmp_path / "bad.h5", spacing=(0.0, 1.0))
    assert not (tmp_path / "bad.h5").exists()

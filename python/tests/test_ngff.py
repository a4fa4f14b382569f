"""OME-Zarr (NGFF) from Python: trimorph's displacement stores read with zarr-python, and
OME-Zarr images written by zarr-python warped by `trimorph warp`.

Drives the CLI binary: $TRIMORPH_BIN, else <repo>/target/debug/trimorph (`cargo build`).
"""

import csv
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import tifffile
import zarr
from numcodecs import Blosc

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests" / "data"))
from make_ngff import load as load_png  # noqa: E402  (8-bit gray PNG, stdlib zlib)

# A stored inverse displacement (interpolated certified preimages) and `warp --points
# --inverse` (Newton) are each within the default tolerance 0.01 px of the true preimage.
INVERSE_AGREEMENT_PX = 0.02
FRAMES = REPO / "data" / "microscopy" / "timelapse"


def binary():
    b = os.environ.get("TRIMORPH_BIN") or str(REPO / "target" / "debug" / "trimorph")
    if not Path(b).is_file():
        pytest.fail(f"trimorph binary not found at {b}: run `cargo build` or set TRIMORPH_BIN")
    return b


def run(*args):
    r = subprocess.run([binary(), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"{args}: exit {r.returncode}\n{r.stdout}\n{r.stderr}"
    return r


@pytest.fixture(scope="session")
def fitted(tmp_path_factory):
    """A real deformation fitted to the bundled nucleus tracks (frame 0 -> 9, 511 x 511),
    without far-field rings, so that its mesh ends a margin beyond the frame and a field
    taller than it has pixels with no preimage."""
    d = tmp_path_factory.mktemp("fit") / "fit.json"
    tracks = FRAMES / "tracks_0_9.csv"
    run("fit", "--landmarks", tracks, "--size", "511,511", "--far-rings", "0", "-o", d)
    return d


def points_through(defn, pts, tmp, inverse):
    p = tmp / "p.csv"
    with open(p, "w") as f:
        f.write("x,y\n")
        for x, y in pts:
            f.write(f"{x},{y}\n")
    q = tmp / "q.csv"
    run("warp", defn, "--points", p, "-o", q, *(["--inverse"] if inverse else []))
    with open(q) as f:
        rows = list(csv.reader(f))[1:]
    return np.array([[float(a) if a else np.nan for a in r] for r in rows])


def pixel_centres(w, h):
    ys, xs = np.mgrid[0:h, 0:w]
    return np.stack([xs.ravel(), ys.ravel()], axis=1).astype(float)


def test_field_store_is_read_by_zarr_python(fitted, tmp_path):
    w, h = 40, 620  # taller than the fitted mesh: some pixels have no preimage
    store = tmp_path / "F.zarr"
    run("field", fitted, "-o", store, "--size", f"{w},{h}")
    root = zarr.open_group(str(store), mode="r")
    ome = root.attrs["ome"]
    assert ome["version"] == "0.6"
    t = ome["scene"]["coordinateTransformations"][0]
    assert t["type"] == "displacements"
    assert (t["input"], t["output"]) == ({"name": "warped"}, {"name": "original"})
    assert [c["name"] for c in ome["scene"]["coordinateSystems"]] == ["original", "warped"]
    field_group = zarr.open_group(str(store / t["path"]), mode="r")
    ms = field_group.attrs["ome"]["multiscales"][0]
    axes = ms["coordinateSystems"][0]["axes"]
    assert [a["name"] for a in axes] == ["c", "y", "x"]
    assert axes[0]["type"] == "displacement"
    a = zarr.open_array(str(store / t["path"] / ms["datasets"][0]["path"]), mode="r")
    assert a.shape == (2, h, w) and a.dtype == np.float64
    v = a[:]
    pts = pixel_centres(w, h)
    pre = points_through(fitted, pts, tmp_path, inverse=True)
    dy, dx = v[0].ravel(), v[1].ravel()
    defined = ~np.isnan(pre[:, 0])
    assert np.array_equal(defined, ~np.isnan(dx)), "NaN exactly where no preimage exists"
    assert np.isnan(dy[~defined]).all() and 0 < defined.sum() < len(pts)
    err = np.maximum(np.abs(pts[defined, 0] + dx[defined] - pre[defined, 0]),
                     np.abs(pts[defined, 1] + dy[defined] - pre[defined, 1]))
    assert err.max() <= INVERSE_AGREEMENT_PX, err.max()
    assert np.nanmax(np.abs(dx)) > 1.0, "a real, non-trivial field"


def test_both_writes_a_bijection_with_the_forward_map(fitted, tmp_path):
    w, h = 64, 48
    store = tmp_path / "B.zarr"
    run("field", fitted, "-o", store, "--both", "--size", f"{w},{h}")
    t = zarr.open_group(str(store), mode="r").attrs["ome"]["scene"]["coordinateTransformations"][0]
    assert t["type"] == "bijection"
    assert (t["input"], t["output"]) == ({"name": "original"}, {"name": "warped"})
    fwd = zarr.open_array(str(store / t["forward"]["path"] / "0"), mode="r")[:]
    inv = zarr.open_array(str(store / t["inverse"]["path"] / "0"), mode="r")[:]
    assert fwd.shape == inv.shape == (2, h, w)
    pts = pixel_centres(w, h)
    img = points_through(fitted, pts, tmp_path, inverse=False)
    # Same f64 subtraction as trimorph's, of the same shortest-round-trip decimals: exact.
    assert np.array_equal(fwd[1].ravel(), img[:, 0] - pts[:, 0])
    assert np.array_equal(fwd[0].ravel(), img[:, 1] - pts[:, 1])
    # Forward then inverse comes back to the pixel (where the warped point stays inside).
    assert np.nanmax(np.abs(inv)) > 0


def ome_image(path, data, axes, zarr_format, compressors):
    g = zarr.open_group(str(path), mode="w", zarr_format=zarr_format)
    chunks = tuple(1 if i < data.ndim - 2 else 128 for i in range(data.ndim))
    a = g.create_array("0", shape=data.shape, chunks=chunks, dtype=data.dtype, compressors=compressors)
    a[:] = data
    ms = [{
        "axes": [{"name": n, "type": {"t": "time", "c": "channel"}.get(n, "space")} for n in axes],
        "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1.0] * data.ndim}]}],
    }]
    if zarr_format == 2:
        ms[0]["version"] = "0.4"
        g.attrs["multiscales"] = ms
    else:
        g.attrs["ome"] = {"version": "0.5", "multiscales": ms}


def check_warp_per_plane(fitted, tmp_path, src, data):
    out = tmp_path / "out.zarr"
    run("warp", fitted, "--image", src, "-o", out)
    got = zarr.open_array(str(out / "0"), mode="r")
    assert got.shape == data.shape and got.dtype == data.dtype
    got = got[:]
    planes = data.reshape(-1, *data.shape[-2:])
    for k, plane in enumerate(planes):
        tif = tmp_path / f"p{k}.tif"
        tifffile.imwrite(tif, plane)
        wt = tmp_path / f"w{k}.tif"
        run("warp", fitted, "--image", tif, "-o", wt)
        want = tifffile.imread(wt)
        assert np.array_equal(got.reshape(planes.shape)[k], want), f"plane {k}"
        assert not np.array_equal(want, plane), "the deformation moves the plane"
    return zarr.open_group(str(out), mode="r")


def test_v2_blosc_time_series_is_warped_plane_by_plane(fitted, tmp_path):
    data = np.stack([load_png(FRAMES / f"frame_0{k}.png") for k in range(3)])  # (t, y, x) uint8
    src = tmp_path / "t.zarr"
    ome_image(src, data, "tyx", 2, Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE))
    g = check_warp_per_plane(fitted, tmp_path, src, data)
    assert g.attrs["multiscales"][0]["axes"][0]["type"] == "time"
    assert g["0"].metadata.zarr_format == 2


def test_v3_channel_image_is_warped_plane_by_plane(fitted, tmp_path):
    frames = [load_png(FRAMES / f"frame_0{k}.png").astype(np.uint16) for k in (4, 5)]
    data = np.stack([frames[0] * 257, frames[1] * 100 + 7]).astype(np.uint16)  # (c, y, x)
    src = tmp_path / "c.zarr"
    ome_image(src, data, "cyx", 3, "auto")
    g = check_warp_per_plane(fitted, tmp_path, src, data)
    assert g.attrs["ome"]["multiscales"][0]["axes"][0]["type"] == "channel"
    assert g["0"].metadata.zarr_format == 3


def test_python_reads_ome_zarr_like_zarr_python_and_warps_like_the_cli(fitted, tmp_path):
    """`trimorph.read_ome_zarr` / `Deformation.warp` on an OME-Zarr image: the CLI's reader
    and warp, plane by plane."""
    import trimorph

    data = np.stack([load_png(FRAMES / f"frame_0{k}.png") for k in range(2)])  # (t, y, x)
    src = tmp_path / "t.zarr"
    ome_image(src, data, "tyx", 2, Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE))
    arr, axes = trimorph.read_ome_zarr(src)
    assert axes == ["t", "y", "x"] and arr.dtype == np.uint8
    np.testing.assert_array_equal(arr, data)
    np.testing.assert_array_equal(trimorph.read_image(src), data)
    d = trimorph.Deformation.load(fitted)
    out = tmp_path / "out.zarr"
    run("warp", fitted, "--image", src, "-o", out)
    cli = zarr.open_array(str(out / "0"), mode="r")[:]
    for k in range(2):
        np.testing.assert_array_equal(d.warp(arr[k]), cli[k])
    with pytest.raises(ValueError, match="not a Zarr store|Zarr"):
        trimorph.read_ome_zarr(tmp_path)


def test_python_to_ngff_writes_the_cli_store(fitted, tmp_path):
    import trimorph

    d = trimorph.Deformation.load(fitted)
    for flags, kw in [([], {}), (["--inverse"], {"inverse": True}), (["--both"], {"both": True})]:
        ref, ours = tmp_path / f"r{len(flags)}{kw}.zarr", tmp_path / f"o{len(flags)}{kw}.zarr"
        run("field", fitted, "-o", ref, "--size", "64,48", *flags)
        d.to_ngff(ours, size=(64, 48), **kw)
        gr, go = zarr.open_group(str(ref), mode="r"), zarr.open_group(str(ours), mode="r")
        assert dict(gr.attrs) == dict(go.attrs)
        for name, arr in gr.arrays() if hasattr(gr, "arrays") else []:
            np.testing.assert_array_equal(arr[:], go[name][:])
        t = gr.attrs["ome"]["scene"]["coordinateTransformations"][0]
        paths = [t[k]["path"] for k in ("forward", "inverse") if k in t] or [t["path"]]
        for p in paths:
            np.testing.assert_array_equal(
                zarr.open_array(str(ref / p / "0"), mode="r")[:],
                zarr.open_array(str(ours / p / "0"), mode="r")[:],
            )
    with pytest.raises(ValueError, match="both"):
        d.to_ngff(tmp_path / "x.zarr", inverse=True, both=True)


SCHEMAS = Path(__file__).resolve().parent / "data" / "ngff-0.6rc0"


def ngff_validators():
    """The NGFF 0.6 `scene` and `image` (multiscales) validators, from the specification's
    own JSON schemas (vendored, see their NOTICE.md). No PyPI validator reads 0.6 coordinate
    systems yet. The schemas' version enum says 0.6rc0; the released 0.6 is accepted too."""
    import json

    jsonschema = pytest.importorskip("jsonschema")
    referencing = pytest.importorskip("referencing")
    resources = {}
    for f in SCHEMAS.glob("*.schema"):
        doc = json.loads(f.read_text())
        if f.stem == "_version":
            doc = {**doc, "enum": [*doc["enum"], "0.6"]}
        resources[doc["$id"]] = referencing.Resource.from_contents(doc)
    registry = referencing.Registry().with_resources(resources.items())
    base = "https://ngff.openmicroscopy.org/0.6rc0/schemas/"
    return {
        name: jsonschema.Draft202012Validator(
            resources[base + f"{name}.schema"].contents, registry=registry
        )
        for name in ("scene", "image")
    }


def check_ngff(store, validators):
    """Every group of a displacement store is valid NGFF 0.6: the root a scene, the fields
    multiscale images."""
    root = zarr.open_group(str(store), mode="r")
    validators["scene"].validate(dict(root.attrs))
    ts = root.attrs["ome"]["scene"]["coordinateTransformations"]
    paths = [t[k]["path"] for t in ts for k in ("forward", "inverse") if k in t]
    paths += [t["path"] for t in ts if "path" in t]
    assert paths
    for p in paths:
        validators["image"].validate(dict(zarr.open_group(str(store / p), mode="r").attrs))
    return root


def test_displacement_stores_are_valid_ngff_0_6(fitted, tmp_path):
    v = ngff_validators()
    for i, flags in enumerate([[], ["--inverse"], ["--both"],
                               ["--both", "--spacing", "0.5,0.25", "--origin=-3,7.5",
                                "--unit", "micrometer"]]):
        store = tmp_path / f"s{i}.zarr"
        run("field", fitted, "-o", store, "--size", "40,30", *flags)
        check_ngff(store, v)
    # The validator is not a rubber stamp: the old layout (0.6.dev3: transformations at the
    # top of `ome`, input and output as bare names) fails it.
    import jsonschema

    old = {"ome": {"version": "0.6", "coordinateTransformations": [
        {"type": "displacements", "path": "x", "input": "warped", "output": "original"}]}}
    with pytest.raises(jsonschema.ValidationError):
        v["scene"].validate(old)


def test_to_ngff_places_the_field_in_physical_space(fitted, tmp_path):
    """`to_ngff(scale=, origin=, units=)` is `field --spacing --origin --unit`; the
    displacements are physical (pixels times the spacing along each axis), and a frame
    recorded with `with_frame` is the default."""
    import trimorph

    d = trimorph.Deformation.load(fitted)
    ref, ours, rec = tmp_path / "ref.zarr", tmp_path / "ours.zarr", tmp_path / "rec.zarr"
    px = tmp_path / "px.zarr"
    run("field", fitted, "-o", ref, "--both", "--size", "64,48", "--spacing", "0.5,0.25",
        "--origin=-3,7.5", "--unit", "micrometer")
    d.to_ngff(ours, both=True, size=(64, 48), scale=(0.5, 0.25), origin=(-3, 7.5),
              units="micrometer")
    d.with_frame(size=(64, 48), spacing=(0.5, 0.25), origin=(-3, 7.5),
                 unit="micrometer").to_ngff(rec, both=True)
    d.to_ngff(px, both=True, size=(64, 48))
    v = ngff_validators()
    for s in (ref, ours, rec):
        check_ngff(s, v)
        assert dict(zarr.open_group(str(s), mode="r").attrs) == dict(
            zarr.open_group(str(ref), mode="r").attrs)
    axes = zarr.open_group(str(ref), mode="r").attrs["ome"]["scene"]["coordinateSystems"][0]["axes"]
    assert [a.get("unit") for a in axes] == ["micrometer", "micrometer"]
    for name in ("forward", "inverse"):
        g = zarr.open_group(str(ref / "coordinateTransformations" / name), mode="r")
        t = g.attrs["ome"]["multiscales"][0]["datasets"][0]["coordinateTransformations"][0]
        assert t["type"] == "sequence"
        assert [x["type"] for x in t["transformations"]] == ["scale", "translation"]
        assert t["transformations"][0]["scale"] == [1.0, 0.25, 0.5]
        a = zarr.open_array(str(ref / "coordinateTransformations" / name / "0"), mode="r")[:]
        for s in (ours, rec):
            b = zarr.open_array(str(s / "coordinateTransformations" / name / "0"), mode="r")[:]
            np.testing.assert_array_equal(a, b)
        p = zarr.open_array(str(px / "coordinateTransformations" / name / "0"), mode="r")[:]
        np.testing.assert_array_equal(a[0], 0.25 * p[0])  # y displacement
        np.testing.assert_array_equal(a[1], 0.5 * p[1])  # x displacement
    with pytest.raises(ValueError, match="unit"):
        d.to_ngff(tmp_path / "bad.zarr", units="")
    assert not (tmp_path / "bad.zarr").exists()

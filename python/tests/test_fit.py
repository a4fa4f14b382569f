"""`trimorph.fit` and `trimorph.morph` against the command line."""

import json

import numpy as np
import pytest

import trimorph


def test_fit_equals_cli_fit_frame_and_report(nuclei, cli, tmp_path):
    out, rep = tmp_path / "phi.json", tmp_path / "rep.json"
    cli("fit", "--size", "184,184", "--landmarks", nuclei["landmarks"], "-o", out, "--report", rep)
    d = trimorph.fit(nuclei["src"], nuclei["dst"], size=(184, 184), names=nuclei["names"])
    # The same file, plus the report Python keeps in it (so it survives save and pickle).
    doc = json.loads(d.to_json())
    assert doc.pop("report") == d.report
    assert doc == json.loads(out.read_text())
    ref = json.loads(rep.read_text())
    # Everything but the wall-clock time is the same.
    assert {k: v for k, v in d.report.items() if k != "time_ms"} == {
        k: v for k, v in ref.items() if k != "time_ms"
    }
    assert d.report["time_ms"] > 0
    assert d.report["frame"]["covers_frame"] is True


def test_fit_moves_sources_onto_targets(fitted, nuclei):
    d, _ = fitted
    mapped = d.map_points(nuclei["src"])
    err = np.linalg.norm(mapped - nuclei["dst"], axis=1)
    # The fit smooths (bend chosen by cross-validation); it gets within a few pixels.
    assert err.max() < 10.0
    assert set(d.report) >= {"frame"}


def test_hard_fit_interpolates(nuclei):
    d = trimorph.fit(nuclei["src"], nuclei["dst"], size=(184, 184), hard=True)
    err = np.linalg.norm(d.map_points(nuclei["src"]) - nuclei["dst"], axis=1)
    assert err.max() < 1e-6


def test_fit_on_a_given_deformation_keeps_its_mesh(nuclei):
    base = trimorph.Deformation.mesh_grid(6, 6, (184, 184))
    d = trimorph.fit(nuclei["src"], nuclei["dst"], deformation=base, bend=0.01)
    assert d.num_triangles == base.num_triangles
    assert d.to_json() != base.to_json()


def test_fit_options_are_checked(nuclei):
    src, dst = nuclei["src"], nuclei["dst"]
    with pytest.raises(ValueError, match="size"):
        trimorph.fit(src, dst)
    with pytest.raises(ValueError, match="unknown loss"):
        trimorph.fit(src, dst, size=(184, 184), loss="l7")
    with pytest.raises(ValueError, match="bend"):
        trimorph.fit(src, dst, size=(184, 184), bend="lots")
    with pytest.raises(ValueError, match="targets? per source|dst has"):
        trimorph.fit(src, dst[:-1], size=(184, 184))
    with pytest.raises(ValueError, match="weights"):
        trimorph.fit(src, dst, size=(184, 184), weights=[1.0])
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        trimorph.fit(src.ravel(), dst, size=(184, 184))


def test_conflicting_hard_landmarks_raise_unsolvable(nuclei):
    src = np.vstack([nuclei["src"], nuclei["src"][:1]])
    dst = np.vstack([nuclei["dst"], nuclei["dst"][:1] + 5.0])
    with pytest.raises(trimorph.UnsolvableError) as e:
        trimorph.fit(src, dst, size=(184, 184), hard=True)
    assert e.value.kind == "Conflicting"
    assert isinstance(e.value, trimorph.TrimorphError)


def test_morph_frames_equal_the_cli_frames(nuclei, cli, tmp_path):
    a = trimorph.read_image(nuclei["a"])
    b = trimorph.read_image(nuclei["b"])
    frames = trimorph.morph(a, b, nuclei["src"], nuclei["dst"], frames=3)
    assert len(frames) == 3
    out = tmp_path / "m"
    cli("morph", nuclei["a"], nuclei["b"], "--landmarks", nuclei["landmarks"], "--frames", "3",
        "-o", out, "--quiet")
    files = sorted(out.glob("frame_*"))
    assert len(files) == 3, files
    for ours, f in zip(frames, files):
        ref = trimorph.read_image(f)
        assert ours.shape[:2] == a.shape[:2]
        np.testing.assert_array_equal(ours, ref)


def test_morph_bend_hard_and_pin_frame_equal_the_cli(nuclei, cli, tmp_path):
    """Issue 52: `morph(..., bend=, hard=, pin_frame=)` are the CLI's --bend --hard --pin-frame."""
    a = trimorph.read_image(nuclei["a"])
    b = trimorph.read_image(nuclei["b"])
    for kw, flags in [
        (dict(bend=1e-3), ["--bend", "1e-3"]),
        (dict(hard=True, pin_frame=True), ["--hard", "--pin-frame"]),
    ]:
        frames = trimorph.morph(a, b, nuclei["src"], nuclei["dst"], frames=3, **kw)
        out = tmp_path / ("m" + "".join(flags))
        cli("morph", nuclei["a"], nuclei["b"], "--landmarks", nuclei["landmarks"],
            "--frames", "3", "-o", out, "--quiet", *flags)
        files = sorted(out.glob("frame_*"))
        for ours, f in zip(frames, files):
            np.testing.assert_array_equal(ours, trimorph.read_image(f))
    plain = trimorph.morph(a, b, nuclei["src"], nuclei["dst"], frames=3)
    smooth = trimorph.morph(a, b, nuclei["src"], nuclei["dst"], frames=3, bend=1e-3)
    assert not np.array_equal(plain[1], smooth[1])
    with pytest.raises(ValueError, match="bend"):
        trimorph.morph(a, b, nuclei["src"], nuclei["dst"], frames=3, bend="stiff")


def test_morph_background_follows_the_cli_rule(nuclei, cli, tmp_path):
    """Issue 56: one rule for a morph's background, in the library: a sample of the type the
    morph works in (the deeper of the two images', 16-bit for this pair), refused before
    the fits in Python and in `trimorph morph` alike."""
    a = trimorph.read_image(nuclei["a"])
    b = trimorph.read_image(nuclei["b"])
    assert np.uint16 in (a.dtype, b.dtype)
    for bad in [70000.0, -5.0, 12.5]:
        with pytest.raises(ValueError, match="16-bit samples are whole numbers"):
            trimorph.morph(a, b, nuclei["src"], nuclei["dst"], frames=2, background=bad)
        out = tmp_path / f"m{bad}"
        r = cli("morph", nuclei["a"], nuclei["b"], "--landmarks", nuclei["landmarks"],
                "--frames", "2", "-o", out, "--quiet", f"--background={bad}", check=False)
        assert r.returncode == 1 and "16-bit samples are whole numbers" in r.stderr, r.stderr
        assert "landmarks" not in r.stderr, r.stderr
        assert not out.exists()
    assert len(trimorph.morph(a, b, nuclei["src"], nuclei["dst"], frames=2, background=255)) == 2


def test_far_rings_extend_the_fitted_mesh(nuclei):
    src, dst = nuclei["src"], nuclei["dst"]
    ringed = trimorph.fit(src, dst, size=(184, 184))
    free = trimorph.fit(src, dst, size=(184, 184), far_rings=0)
    (lo, hi), (flo, fhi) = ringed.bbox, free.bbox
    # Two rings by default: the mesh reaches 16 times the domain (frame plus margin).
    assert hi[0] - lo[0] > 10 * (fhi[0] - flo[0])
    assert flo[0] < 0 and fhi[0] > 183
    m = trimorph.Deformation.mesh_landmarks(src, (184, 184), far_rings=1)
    (mlo, mhi) = m.bbox
    assert 3.5 * (fhi[0] - flo[0]) < mhi[0] - mlo[0] < 4.5 * (fhi[0] - flo[0])


def test_a_fit_records_its_frame_and_fields_default_to_it(nuclei, tmp_path):
    """Issue 51: `fit(..., size=(w, h))` records the frame; `field()`, `to_itk` and `to_ngff`
    default to it, not to the far-field rings' extent (16 times the frame)."""
    d = trimorph.fit(nuclei["src"], nuclei["dst"], size=(184, 150))
    assert d.frame == {"size": [184.0, 150.0]}
    (x0, y0), (x1, y1) = d.bbox
    assert x1 - x0 > 1000, "far-field rings"
    assert d.field().shape == (150, 184, 2)
    assert d.field(size=(20, 10)).shape == (10, 20, 2)
    assert d.to_itk(tmp_path / "phi.h5") >= 0
    assert (tmp_path / "phi.h5").stat().st_size < 5_000_000
    # Kept by save / load, pickling and edits; meshes made from landmarks record it too.
    d.save(tmp_path / "d.json")
    assert trimorph.Deformation.load(tmp_path / "d.json").frame == d.frame
    import pickle

    assert pickle.loads(pickle.dumps(d)).frame == d.frame
    m = trimorph.Deformation.mesh_landmarks(nuclei["src"], size=(184, 184))
    assert m.frame == {"size": [184.0, 184.0]}
    assert trimorph.Deformation.mesh_grid(4, 4, (100, 80)).frame == {"size": [100.0, 80.0]}


def test_the_fit_report_survives_save_load_and_pickle(nuclei, tmp_path):
    import pickle

    d = trimorph.fit(nuclei["src"], nuclei["dst"], size=(184, 184))
    rep = d.report
    assert rep["frame"]["covers_frame"] is True
    d.save(tmp_path / "d.json")
    assert trimorph.Deformation.load(tmp_path / "d.json").report == rep
    assert pickle.loads(pickle.dumps(d)).report == rep
    assert d.copy().report == rep
    # An edit makes it stale: it is dropped.
    d.edit([{"op": "translate", "anchors": [0], "by": [0.25, 0.0]}])
    assert d.report is None


def test_fit_signature_shows_every_default():
    """Issue 55: `inspect.signature(trimorph.fit)` showed `far_rings=Ellipsis`."""
    import inspect

    params = inspect.signature(trimorph.fit).parameters
    assert params["far_rings"].default == 2
    assert all(p.default is not Ellipsis for p in params.values())


def test_stubs_match_the_runtime_signatures():
    """Issue 55: `far_rings` was missing from the stubs (`mesh_landmarks`). Every function
    and method of `_trimorph.pyi` has the runtime's parameters, in order, with its defaults."""
    import ast
    import inspect
    from pathlib import Path

    from trimorph import _trimorph

    tree = ast.parse((Path(trimorph.__file__).parent / "_trimorph.pyi").read_text())

    def stub_params(fn):
        a = fn.args
        pos = a.posonlyargs + a.args
        defaults = [None] * (len(pos) - len(a.defaults)) + a.defaults
        out = [(p.arg, d) for p, d in zip(pos, defaults)]
        out += list(zip([p.arg for p in a.kwonlyargs], a.kw_defaults))
        return [(n, ast.literal_eval(d) if d is not None else inspect.Parameter.empty) for n, d in out if n != "self"]

    def runtime_params(obj):
        sig = inspect.signature(obj)
        return [(n, p.default) for n, p in sig.parameters.items() if n != "self"]

    checked = 0
    for node in tree.body:
        items = []
        if isinstance(node, ast.FunctionDef):
            items = [(node, getattr(_trimorph, node.name))]
        elif isinstance(node, ast.ClassDef):
            cls = getattr(_trimorph, node.name)
            for f in node.body:
                if isinstance(f, ast.FunctionDef) and f.name != "__init__":
                    if any(isinstance(d, ast.Name) and d.id == "property" for d in f.decorator_list):
                        continue
                    items.append((f, getattr(cls, f.name)))
        for fn, obj in items:
            assert stub_params(fn) == runtime_params(obj), fn.name
            checked += 1
    assert checked > 20

"""The README's Python example runs as written (from the repository root)."""

import os
import re
import runpy

from conftest import REPO


def readme_example() -> str:
    text = (REPO / "README.md").read_text()
    m = re.search(r"<!-- python-example -->\n```python\n(.*?)```", text, re.S)
    assert m, "README.md has no block marked <!-- python-example -->"
    return m.group(1)


def test_readme_python_example_runs(tmp_path, capsys):
    script = tmp_path / "example.py"
    script.write_text(readme_example())
    cwd = os.getcwd()
    os.chdir(REPO)
    try:
        runpy.run_path(str(script), run_name="__main__")
    finally:
        os.chdir(cwd)
    out = capsys.readouterr().out
    assert "covers the frame: True" in out
    # SimpleITK and trimorph agree away from the border (float32 vs uint8 rounding).
    m = re.search(r"SimpleITK vs trimorph: ([0-9.]+)", out)
    assert m and float(m.group(1)) <= 0.501, out


def test_readme_dask_example_runs(tmp_path, capsys):
    """The "Larger than one machine" example: a LocalCluster warp of the bundled OME-Zarr
    store, written with its metadata, equal to the in-memory warp."""
    import pytest

    pytest.importorskip("distributed")
    text = (REPO / "README.md").read_text()
    m = re.search(r"<!-- dask-example -->\n```python\n(.*?)```", text, re.S)
    assert m, "README.md has no block marked <!-- dask-example -->"
    script = tmp_path / "dask_example.py"
    script.write_text(m.group(1).replace('"warped.ome.zarr"', repr(str(tmp_path / "w.zarr"))))
    cwd = os.getcwd()
    os.chdir(REPO)
    try:
        runpy.run_path(str(script), run_name="__main__")
    finally:
        os.chdir(cwd)
    assert "bit-identical to the in-memory warp: True" in capsys.readouterr().out

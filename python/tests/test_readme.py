"""The README's Python example runs as written (from the repository root)."""

import os
import re
import runpy

from conftest import REPO


def readme_block(marker: str) -> str:
    """The python block of README.md right after `<!-- marker -->`."""
    text = (REPO / "README.md").read_text()
    m = re.search(rf"<!-- {marker} -->\n```python\n(.*?)```", text, re.S)
    assert m, f"README.md has no block marked <!-- {marker} -->"
    return m.group(1)


def run_as_main(code: str, path) -> None:
    """Runs `code` as a script `__main__` from the repository root."""
    path.write_text(code)
    cwd = os.getcwd()
    os.chdir(REPO)
    try:
        runpy.run_path(str(path), run_name="__main__")
    finally:
        os.chdir(cwd)


def test_readme_python_example_runs(tmp_path, capsys):
    run_as_main(readme_block("python-example"), tmp_path / "example.py")
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
    code = readme_block("dask-example").replace('"warped.ome.zarr"', repr(str(tmp_path / "w.zarr")))
    run_as_main(code, tmp_path / "dask_example.py")
    assert "bit-identical to the in-memory warp: True" in capsys.readouterr().out

"""Shared fixtures of the Python tests: the repository, the command-line binary, real data.

The tests compare the package with the `trimorph` command line, so they need its binary:
`TRIMORPH_BIN` if set, else `<repo>/target/debug/trimorph` (built by `cargo build` or
`cargo test`); `.ci/run` builds it before running pytest.
"""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import trimorph

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "data"


def _binary() -> Path:
    env = os.environ.get("TRIMORPH_BIN")
    path = Path(env) if env else REPO / "target" / "debug" / "trimorph"
    if not path.is_file():
        raise RuntimeError(
            f"the trimorph binary {path} is missing: run `cargo build` in {REPO} "
            "or set TRIMORPH_BIN to a built binary"
        )
    return path


@pytest.fixture(scope="session")
def trimorph_bin() -> Path:
    return _binary()


@pytest.fixture(scope="session")
def cli(trimorph_bin):
    """`cli(*args)` runs the command line and returns the CompletedProcess (checked)."""

    def run(*args, check=True):
        p = subprocess.run(
            [str(trimorph_bin), *map(str, args)], capture_output=True, text=True
        )
        if check and p.returncode != 0:
            raise AssertionError(
                f"trimorph {' '.join(map(str, args))} exited {p.returncode}:\n{p.stderr}"
            )
        return p

    return run


def read_landmarks_csv(path: Path):
    """(names, src (n, 2), dst (n, 2)) of a `name,src_x,src_y,dst_x,dst_y` CSV."""
    rows = [line.split(",") for line in path.read_text().splitlines()[1:] if line.strip()]
    names = [r[0] for r in rows]
    src = np.array([[float(r[1]), float(r[2])] for r in rows])
    dst = np.array([[float(r[3]), float(r[4])] for r in rows])
    return names, src, dst


@pytest.fixture(scope="session")
def nuclei():
    """The real nuclei pair (data/morph, see data/SOURCES.md): images and landmarks."""
    names, src, dst = read_landmarks_csv(DATA / "morph" / "nuclei_landmarks.csv")
    return {
        "a": DATA / "morph" / "nuclei_a.png",
        "b": DATA / "morph" / "nuclei_b.png",
        "landmarks": DATA / "morph" / "nuclei_landmarks.csv",
        "names": names,
        "src": src,
        "dst": dst,
    }


@pytest.fixture(scope="session")
def fitted(tmp_path_factory, nuclei):
    """A deformation fitted to the nuclei landmarks over A's 184 x 184 frame, and its file.

    A map with visible displacement (tens of pixels), so warps and inverses are exercised.
    Fitted without far-field rings, so the mesh ends a margin beyond the frame and the tests
    can reach points outside it.
    """
    d = trimorph.fit(
        nuclei["src"], nuclei["dst"], size=(184, 184), names=nuclei["names"], far_rings=0
    )
    path = tmp_path_factory.mktemp("fitted") / "phi.json"
    d.save(path)
    return d, path

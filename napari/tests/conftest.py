"""Shared fixtures: real frames and landmarks from the repository's data/, headless Qt.

Headless: napari needs OpenGL, which Qt's ``offscreen`` platform does not give (see
``trimorph_napari._headless``). Before any Qt import, without a ``DISPLAY``, a private
Xvfb is started (``apt-get install xvfb``) and Qt uses it (``QT_QPA_PLATFORM=xcb``);
without Xvfb, Qt runs ``offscreen`` and the tests that draw layers are skipped.
``make_napari_viewer`` is napari's own fixture, from the pytest plugin napari registers
(entry point ``pytest11: napari``); it is named below too when plugin autoload is off.
"""

import os

from trimorph_napari._headless import ensure_display

HAS_GL = ensure_display()
if not HAS_GL and os.environ.get("TRIMORPH_NAPARI_REQUIRE_GL"):
    # CI installs Xvfb: there a skipped viewer test would hide a broken install.
    raise RuntimeError("no OpenGL display for napari (install xvfb): the viewer tests would skip")

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import trimorph  # noqa: E402

if os.environ.get("PYTEST_DISABLE_PLUGIN_AUTOLOAD"):
    pytest_plugins = ["pytestqt.plugin", "napari.utils._testsupport"]

REPO = Path(__file__).resolve().parents[2]
TIMELAPSE = REPO / "data" / "microscopy" / "timelapse"


@pytest.fixture(scope="session")
def frames():
    """Frames 0 and 9 of the bundled time-lapse, (511, 511) uint8."""
    f0 = trimorph.read_image(TIMELAPSE / "frame_00.png")
    f9 = trimorph.read_image(TIMELAPSE / "frame_09.png")
    return f0, f9


@pytest.fixture(scope="session")
def tracks():
    """The nucleus tracks of frames 0 -> 9: src (x, y) in frame 0, dst (x, y) in frame 9."""
    t = np.loadtxt(TIMELAPSE / "tracks_0_9.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3, 4))
    return t[:, :2].copy(), t[:, 2:].copy()


def xy_to_rc(xy):
    """trimorph (x, y) pixels -> napari (row, col)."""
    return np.asarray(xy, float)[:, ::-1].copy()


@pytest.fixture
def labels_of():
    """Labels from thresholding a frame: connected components of the bright nuclei."""

    def make(img):
        mask = img > np.percentile(img, 90)
        try:
            from skimage.measure import label
        except ImportError:  # numpy only: the mask's rows as labels (still integer, several values)
            return (mask * (1 + np.arange(img.shape[0]) // 64)[:, None]).astype(np.int32)
        return label(mask).astype(np.int32)

    return make


@pytest.fixture
def viewer_factory(request):
    """napari's ``make_napari_viewer``, skipping the test where nothing can draw (asked for
    only then: its teardown needs a test that ran)."""
    if not HAS_GL:
        pytest.skip(
            "napari needs OpenGL: no DISPLAY and no Xvfb (apt-get install xvfb), or "
            f"QT_QPA_PLATFORM={os.environ.get('QT_QPA_PLATFORM')}"
        )
    return request.getfixturevalue("make_napari_viewer")

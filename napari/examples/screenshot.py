"""The README picture of the napari plugin: python napari/examples/screenshot.py OUT.png

Opens a viewer without a screen (a private Xvfb when there is no DISPLAY, see
trimorph_napari._headless), loads frames 0 and 9 of the bundled time-lapse and the
nucleus tracks as two Points layers (CSV (x, y) -> napari (row, col)), docks the trimorph
widget, fits, warps frame 0, adds the Jacobian map and the deformed mesh, and saves the
window (canvas and dock) with viewer.screenshot(canvas_only=False).
Run from anywhere; the data come from the repository this file is in. The README's
picture: python napari/examples/screenshot.py docs/img/napari.png
"""

import sys
from pathlib import Path

from trimorph_napari._headless import ensure_display

ensure_display()

import numpy as np  # noqa: E402

import napari  # noqa: E402
import trimorph  # noqa: E402
from trimorph_napari._widget import TrimorphWidget  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
TIMELAPSE = REPO / "data" / "microscopy" / "timelapse"


def wait(widget, timeout=120.0):
    import time

    from qtpy.QtWidgets import QApplication

    t0 = time.time()
    while widget.busy:
        QApplication.processEvents()
        time.sleep(0.01)
        if time.time() - t0 > timeout:
            raise TimeoutError("the trimorph worker did not finish")
    QApplication.processEvents()
    if "failed" in widget.status.value:
        raise RuntimeError(widget.status.value)


def main(out: str) -> None:
    f0 = trimorph.read_image(TIMELAPSE / "frame_00.png")
    f9 = trimorph.read_image(TIMELAPSE / "frame_09.png")
    t = np.loadtxt(TIMELAPSE / "tracks_0_9.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3, 4))
    src_rc, dst_rc = t[:, [1, 0]], t[:, [3, 2]]  # (x, y) -> (row, col)

    viewer = napari.Viewer(show=False, title="trimorph in napari")
    viewer.window._qt_window.resize(1400, 820)
    fixed = viewer.add_image(f9, name="frame 9 (fixed)", colormap="magenta", blending="additive")
    moving = viewer.add_image(
        f0, name="frame 0 (moving)", colormap="green", blending="additive", visible=False
    )
    mp = viewer.add_points(src_rc, name="moving points", face_color="lime", size=9)
    fp = viewer.add_points(dst_rc, name="fixed points", face_color="magenta", size=9)
    widget = TrimorphWidget(viewer)
    viewer.window.add_dock_widget(widget, name="trimorph", area="right")
    widget.frame.value = fixed
    widget.moving_points.value = mp
    widget.fixed_points.value = fp
    widget.warp_layer.value = moving

    widget.fit()
    wait(widget)
    widget.warp()
    wait(widget)
    widget.jacobian()
    wait(widget)
    widget.mesh()
    wait(widget)

    warped = viewer.layers["frame 0 (moving) warped"]
    warped.colormap, warped.blending = "green", "additive"
    viewer.layers["det J"].visible = True
    viewer.layers["det J"].opacity = 0.45
    viewer.layers.selection.active = viewer.layers["det J"]
    # Stack order, bottom to top: images, Jacobian, mesh, points.
    names = [
        "frame 9 (fixed)",
        "frame 0 (moving)",
        "frame 0 (moving) warped",
        "det J",
        "deformed mesh",
        "moving points",
        "fixed points",
        "phi(moving points)",
    ]
    for i, n in enumerate(names):
        viewer.layers.move(viewer.layers.index(n), i)
    viewer.reset_view()
    shot = viewer.screenshot(canvas_only=False, flash=False)
    try:  # 256 colours keep the README picture small
        from PIL import Image

        Image.fromarray(shot[..., :3]).quantize(colors=256, dither=Image.Dither.NONE).save(
            out, optimize=True
        )
    except ImportError:
        from napari.utils.io import imsave

        imsave(out, shot)
    print(f"{out}: {widget.result.value}; {widget.status.value}")
    viewer.close()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__.splitlines()[0])
    main(sys.argv[1])

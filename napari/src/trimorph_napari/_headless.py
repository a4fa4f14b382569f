"""A display for napari without a screen (tests, the README screenshot).

napari draws with OpenGL (vispy). Qt's ``offscreen`` platform has no OpenGL context in
the PyQt5 wheels, so a viewer there cannot add an Image layer (``glGetString`` returns
None). Without a ``DISPLAY``, :func:`ensure_display` starts a private ``Xvfb`` (Debian
package ``xvfb``; Mesa's software OpenGL draws) on a free display number and selects
Qt's ``xcb`` platform; it is stopped when the process exits. Without ``Xvfb`` it falls
back to ``QT_QPA_PLATFORM=offscreen`` and returns False (no OpenGL: widgets only). A
``QT_QPA_PLATFORM`` other than ``xcb`` set by the caller is left alone.

Call it before anything imports Qt.
"""

from __future__ import annotations

import atexit
import os
import select
import shutil
import subprocess

_XVFB = None


def _die_with_parent() -> None:
    """In the child: SIGTERM when the parent dies, even killed (Linux prctl
    PR_SET_PDEATHSIG), so no Xvfb outlives a test run that was stopped."""
    try:
        import ctypes
        import signal

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, int(signal.SIGTERM), 0, 0, 0)
    except Exception:  # noqa: BLE001 - not Linux: atexit still stops it
        pass


def ensure_display() -> bool:
    """True when napari can draw: a ``DISPLAY`` was set, or a private Xvfb was started."""
    global _XVFB
    chosen = os.environ.get("QT_QPA_PLATFORM")
    if _XVFB is not None or os.environ.get("DISPLAY") or chosen not in (None, "", "xcb"):
        # A display, or a platform chosen by the caller (offscreen: no OpenGL).
        return chosen != "offscreen"
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
        return False
    r, w = os.pipe()
    proc = subprocess.Popen(
        [xvfb, "-displayfd", str(w), "-screen", "0", "1600x1000x24", "-nolisten", "tcp"],
        pass_fds=(w,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        preexec_fn=_die_with_parent,
    )
    os.close(w)
    number = b""
    try:
        while not number.endswith(b"\n"):
            ready, _, _ = select.select([r], [], [], 20.0)
            if not ready:
                break
            chunk = os.read(r, 16)
            if not chunk:
                break
            number += chunk
    finally:
        os.close(r)
    if not number.strip().isdigit():
        proc.terminate()
        proc.wait(10)
        os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
        return False
    _XVFB = proc

    def stop():
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()

    atexit.register(stop)
    os.environ["DISPLAY"] = f":{number.decode().strip()}"
    os.environ["QT_QPA_PLATFORM"] = "xcb"
    return True

"""Progress and cancellation of long calls (issue 55, point 5): `progress=callable` and
`cancel=trimorph.CancelToken()` on `Deformation.warp`, `Deformation.field`, `fit`,
`register` and `trimorph.dask.fit_frames`; Ctrl-C (`KeyboardInterrupt`) during a call.

Real data: the bundled time-lapse frames and their nucleus tracks, the bundled IHC image."""

import _thread
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import trimorph

REPO = Path(__file__).resolve().parents[2]
FRAMES = REPO / "data" / "microscopy" / "timelapse"


def tracks():
    rows = np.loadtxt(FRAMES / "tracks_0_9.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3, 4))
    return rows[:, :2], rows[:, 2:]


@pytest.fixture(scope="module")
def fitted():
    src, dst = tracks()
    return trimorph.fit(src, dst, size=(511, 511))


@pytest.fixture(scope="module")
def big():
    """A 4096 x 4096 float32 image (the time-lapse frame tiled): a warp of it takes long
    enough (hundreds of ms) to be stopped halfway."""
    frame = trimorph.read_image(FRAMES / "frame_00.png").astype(np.float32)
    return np.tile(frame, (9, 9))[:4096, :4096].copy()


@pytest.fixture(scope="module")
def big_def():
    src, dst = tracks()
    return trimorph.fit(src * 8, dst * 8, size=(4096, 4096))


def timed(f, *a, **k):
    t0 = time.perf_counter()
    r = f(*a, **k)
    return r, time.perf_counter() - t0


def test_warp_reports_rows_and_gives_the_same_image(fitted):
    img = trimorph.read_image(FRAMES / "frame_03.png")
    calls = []
    out = fitted.warp(img, progress=lambda done, total: calls.append((done, total)))
    assert np.array_equal(out, fitted.warp(img)), "progress changes nothing"
    assert calls and calls[-1] == (511, 511), calls
    done = [d for d, _ in calls]
    assert done == sorted(done) and all(t == 511 for _, t in calls)
    with pytest.raises(TypeError, match="callable"):
        fitted.warp(img, progress=3)


def test_a_raising_progress_stops_the_warp_between_bands(big, big_def):
    full, t_full = timed(big_def.warp, big)
    calls = []

    def stop(done, total):
        calls.append(done)
        raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        timed(big_def.warp, big, progress=stop)
    assert len(calls) == 1, "no call after the one that raised"
    # The warp stopped early: measured against the whole warp of the same image.
    _, t_stop = timed(lambda: pytest.raises(RuntimeError, big_def.warp, big, progress=stop))
    assert t_stop < 0.8 * t_full + 0.05, (t_stop, t_full)
    assert full.shape == big.shape


def test_a_token_cancelled_from_another_thread_stops_the_warp(big, big_def):
    _, t_full = timed(big_def.warp, big)
    token = trimorph.CancelToken()
    assert not token.cancelled and "cancelled=False" in repr(token)
    threading.Timer(0.1 * t_full, token.cancel).start()
    t0 = time.perf_counter()
    with pytest.raises(trimorph.Cancelled):
        big_def.warp(big, cancel=token)
    assert time.perf_counter() - t0 < 0.8 * t_full + 0.05
    assert token.cancelled
    assert issubclass(trimorph.Cancelled, trimorph.TrimorphError)
    # A cancelled token stops the next call before it starts.
    with pytest.raises(trimorph.Cancelled, match="before it started"):
        big_def.warp(big[:64, :64], cancel=token)


def test_ctrl_c_interrupts_a_warp(big, big_def):
    """Ctrl-C during the call raises KeyboardInterrupt then, not after the warp."""
    _, t_full = timed(big_def.warp, big)
    threading.Timer(0.1 * t_full, _thread.interrupt_main).start()
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        big_def.warp(big)
    assert time.perf_counter() - t0 < 0.8 * t_full + 0.05


def test_field_progress_and_cancel(fitted):
    calls = []
    f = fitted.field(inverse=True, progress=lambda d, t: calls.append((d, t)))
    np.testing.assert_array_equal(f, fitted.field(inverse=True))
    assert calls[-1] == (511, 511)
    g = fitted.field(progress=lambda d, t: calls.append((d, t)))
    np.testing.assert_array_equal(g, fitted.field())
    token = trimorph.CancelToken()
    token.cancel()
    with pytest.raises(trimorph.Cancelled):
        fitted.field(inverse=True, cancel=token)


def test_fit_progress_and_cancel():
    src, dst = tracks()
    calls = []
    d = trimorph.fit(src, dst, size=(511, 511), progress=lambda a, b: calls.append((a, b)))
    assert calls[-1] == (1, 1) and set(calls) <= {(0, 1), (1, 1)}, calls
    again = trimorph.fit(src, dst, size=(511, 511))
    np.testing.assert_array_equal(d.map_points(src), again.map_points(src))
    token = trimorph.CancelToken()
    token.cancel()
    with pytest.raises(trimorph.Cancelled):
        trimorph.fit(src, dst, size=(511, 511), cancel=token)


def test_register_reports_iterations_and_stops_when_asked():
    """A real pair (the IHC crop and a shifted copy): progress counts optimizer iterations
    against their caps; a progress that raises after 3 stops the registration there."""
    ihc = trimorph.read_image(REPO / "data" / "microscopy" / "ihc.png")
    grey = ihc.mean(axis=2).astype(np.float32) if ihc.ndim == 3 else ihc.astype(np.float32)
    fixed = grey[100:356, 100:356].copy()
    moving = grey[103:359, 98:354].copy()
    calls = []
    d, t_full = timed(trimorph.register, fixed, moving, levels=2,
                      progress=lambda a, b: calls.append((a, b)))
    total = calls[-1][1]
    assert calls[-1] == (total, total) and total == 2 * (60 + 30)
    assert len(calls) >= 2 and [a for a, _ in calls] == sorted(a for a, _ in calls)
    assert d.report["fold_free"] is True
    seen = []

    def three(a, b):
        seen.append(a)
        if a >= 3:
            raise KeyboardInterrupt

    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        trimorph.register(fixed, moving, levels=2, progress=three)
    assert time.perf_counter() - t0 < t_full
    assert max(seen) < total


def test_fit_frames_reports_frames_and_stops_between_tasks(cli, tmp_path):
    pytest.importorskip("dask")
    import dask

    from trimorph.dask import fit_frames

    cli("demo", "-o", tmp_path / "demo")
    lms = tmp_path / "demo" / "fit" / "landmarks"
    frames = tmp_path / "frames"
    frames.mkdir()
    for k in range(4):
        name = f"frame_{k:02}.png"
        (frames / name).write_bytes((tmp_path / "demo" / "fit" / "frames" / name).read_bytes())
    calls = []
    with dask.config.set(scheduler="sync"):
        res = fit_frames(None, frames, lms, tmp_path / "out", size=(511, 511),
                         progress=lambda a, b: calls.append((a, b)))
    assert [r["status"] for r in res] == ["fitted"] * 4
    assert calls == [(1, 4), (2, 4), (3, 4), (4, 4)]
    token = trimorph.CancelToken()

    def cancel_after_two(a, b):
        if a == 2:
            token.cancel()

    with dask.config.set(scheduler="sync"), pytest.raises(trimorph.Cancelled):
        fit_frames(None, frames, lms, tmp_path / "out2", size=(511, 511),
                   progress=cancel_after_two, cancel=token)
    written = sorted((tmp_path / "out2").glob("*.report.json"))
    assert len(written) == 2, "no task started after the cancel"
    # A rerun without the token resumes: the two written frames are skipped.
    res = fit_frames(None, frames, lms, tmp_path / "out2", size=(511, 511))
    assert sorted(r["status"] for r in res) == ["fitted", "fitted", "skipped", "skipped"]
    with pytest.raises(trimorph.Cancelled, match="before it started"):
        fit_frames(None, frames, lms, tmp_path / "out3", size=(511, 511), cancel=token)

"""``fit_frames``: a sequence fit (``trimorph fit --frames``) as a Dask task graph.

One task per frame, each ``FrameSequence.run_frame(k)`` (the library's
``Sequence::run_frame`` on the command line's file store), so every frame's outputs are the
files ``trimorph fit --model MODEL --frames FRAMES --landmarks LANDMARKS -o OUT_DIR`` writes,
with the same names and contents, each written atomically (temporary file renamed into
place, the report last).

Graph:

* independent frames (no ``track``): one task per frame, no edges; they run in parallel on
  as many workers as there are;
* tracked frames (``track=True``, any anchor): a chain, task ``k`` depends on task ``k - 1``.
  Frame ``k``'s fit is warm-started from frame ``k - 1``'s fitted deformation (the stored
  result), with every anchor (``chain``, ``first``, ``keyframes``: the anchor only decides
  where the *targets* are tracked from), so a key-frame segment cannot start before the
  previous segment's last fit without changing the results; ``fit --frames`` fits tracked
  frames in order, and so does this.

The sequence object is put into the graph once (one key); each worker reads the inputs once
when it first receives it (pickling rebuilds it from its arguments). Failed tasks are retried
(``retries``); a rerun resumes: a frame whose stored report's resume key is current (and
whose outputs all exist) is skipped, and its dict has ``status == "skipped"``.
"""

from __future__ import annotations

from os import PathLike
from typing import Any, Dict, List, Optional, Union

from ._trimorph import Cancelled, CancelToken, FrameSequence

_Path = Union[str, PathLike]

__all__ = ["fit_frames"]


def _run(seq: FrameSequence, ks: List[int], after: Any = None) -> List[Dict[str, Any]]:
    """The task of frames ``ks`` (in order); ``after`` (the previous task's result) only
    orders the chain."""
    return [seq.run_frame(k) for k in ks]


def fit_frames(
    model: Optional[_Path],
    frames: _Path,
    landmarks: _Path,
    out_dir: _Path,
    *,
    client: Optional[Any] = None,
    retries: int = 2,
    batch: int = 1,
    progress: Optional[Any] = None,
    cancel: Optional[CancelToken] = None,
    **options: Any,
) -> List[Dict[str, Any]]:
    """Fits the scene ``model`` to every frame on Dask; returns the per-frame report dicts.

    ``model``, ``frames``, ``landmarks`` and ``out_dir`` are ``trimorph fit --model``,
    ``--frames``, ``--landmarks`` and ``-o``; 2D frames need no scene: ``model=None`` with
    ``size=(w, h)`` fits from the identity over a mesh adapted to the landmarks (``trimorph
    fit --size W,H --frames``). ``options`` are the keywords of
    ``trimorph.FrameSequence`` (``size``, ``track``, ``anchor``, ``key_every``, ``holdout``, ``seed``,
    ``background``, ``model_file``, ``loss``, ``loss_scale``, ``bend``, ``hard``,
    ``barrier``, ``min_det``, ``max_iters``, ``radius``). The inputs are read and checked
    here first, so bad input raises ``ValueError`` (naming the file) before any task runs.

    ``client``: a ``dask.distributed.Client`` (tasks get ``retries`` retries); without one,
    the current default scheduler (a client made current, or Dask's local threads).
    ``batch``: frames per task (consecutive ones, fitted in order), to spread Dask's
    per-task cost over several small frames; the outputs are the same for any batch.
    Returns one dict per frame in frame order: the frame's report (as in
    ``<name>.report.json``) with ``status`` ("fitted" or "skipped") and ``reason``.

    ``progress(done, total)`` is called on the calling thread with the frames finished as
    each task ends; ``cancel`` takes a ``trimorph.CancelToken``. A cancelled token (raising
    ``trimorph.Cancelled``), an exception from ``progress`` or Ctrl-C stops the run between
    tasks: no task starts after it, the frames already written stay (a rerun resumes them),
    and pending futures of a ``client`` are cancelled.
    """
    import uuid

    import dask

    if not (isinstance(batch, int) and batch >= 1):
        raise ValueError(f"batch must be a whole number of frames >= 1, got {batch!r}")
    seq = FrameSequence(model, frames, landmarks, out_dir, **options)
    run_id = uuid.uuid4().hex[:12]
    n = len(seq)
    parts = [list(range(lo, min(lo + batch, n))) for lo in range(0, n, batch)]
    keys = [f"trimorph-fit-{ks[0]}-{run_id}" for ks in parts]
    if progress is not None and not callable(progress):
        raise TypeError("progress must be callable as progress(done, total)")
    if cancel is not None and cancel.cancelled:
        raise Cancelled("cancelled before it started")
    if client is not None:
        # Sent once to one worker; others fetch it (and read the inputs once each).
        seq_f = client.scatter(seq, hash=False)
        futures, prev = [], None
        for ks, key in zip(parts, keys):
            f = client.submit(_run, seq_f, ks, prev, key=key, retries=retries, pure=False)
            prev = f if seq.tracked else None
            futures.append(f)
        if progress is not None or cancel is not None:
            _watch_futures(futures, parts, n, progress, cancel, client)
        done = client.gather(futures)
    else:
        seq_d = dask.delayed(seq, pure=False, traverse=False)
        run = dask.delayed(_run, pure=False)
        tasks, prev = [], None
        for ks, key in zip(parts, keys):
            t = run(seq_d, ks, prev, dask_key_name=key)
            prev = t if seq.tracked else None
            tasks.append(t)
        with _Watch(dict(zip(keys, map(len, parts))), n, progress, cancel):
            done = dask.compute(*tasks)
    return [r for part in done for r in part]


def _watch_futures(futures, parts, n, progress, cancel, client) -> None:
    """Reports finished frames and stops on a cancelled token (distributed scheduler)."""
    from distributed import as_completed

    sizes = {f.key: len(ks) for f, ks in zip(futures, parts)}
    frames = 0
    try:
        for f in as_completed(futures):
            if cancel is not None and cancel.cancelled:
                raise Cancelled("fit_frames was cancelled")
            frames += sizes[f.key]
            if progress is not None:
                progress(frames, n)
    except BaseException:
        client.cancel(futures)
        raise


class _Watch:
    """A Dask local-scheduler callback: the frames finished to ``progress`` after each of
    our tasks, and ``trimorph.Cancelled`` before the next task once ``cancel`` is set (the
    local scheduler runs both hooks on the calling thread and stops on the exception)."""

    def __init__(self, sizes: Dict[str, int], n: int, progress, cancel) -> None:
        import dask.callbacks

        outer = self
        self.sizes, self.n, self.progress, self.cancel, self.frames = sizes, n, progress, cancel, 0

        class _Callback(dask.callbacks.Callback):
            def _pretask(self, key, dsk, state):
                if outer.cancel is not None and outer.cancel.cancelled:
                    raise Cancelled("fit_frames was cancelled")

            def _posttask(self, key, result, dsk, state, worker_id):
                k = key if isinstance(key, str) else str(key)
                if k in outer.sizes:
                    outer.frames += outer.sizes[k]
                    if outer.progress is not None:
                        outer.progress(outer.frames, outer.n)

        self.callback = _Callback()

    def __enter__(self):
        self.callback.__enter__()
        return self

    def __exit__(self, *exc):
        return self.callback.__exit__(*exc)

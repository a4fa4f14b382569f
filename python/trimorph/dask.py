"""trimorph on Dask: warps of images larger than memory, and batches of frames.

A spline map is small and global, so the solve stays on one machine and only the data
work is distributed (no scheduler of our own: Dask's, on a laptop or a cluster).

``warp(arr, deformation)`` returns a lazy dask array ``O(q) = I(phi^-1(q))`` of ``arr``'s
shape and dtype, its axes read as ``Deformation.warp`` reads them (``channel_axis``,
``stack_axis``), with one deformation or one per plane of a stack.
Each output chunk is one task that reads only the input chunks its preimage touches: the
input rectangle of a chunk comes from certified bounds on the spline
(``trimorph.tile_inputs``: its Jacobian and control points, not a solve), and the task
(``trimorph.warp_tile``) fails rather than sample outside it. Every chunk is bit-identical
to the same pixels of ``Deformation.warp`` on the whole array in memory.

``read_ome_zarr`` / ``to_ome_zarr`` open an OME-Zarr image as a dask array and write a
result with the source's NGFF metadata (axes, scale, omero) kept.

``fit_frames`` fits a sequence frame by frame on a ``dask.distributed`` client, writing
what ``trimorph fit --frames`` writes.
"""

from __future__ import annotations

import itertools
from bisect import bisect_right

import numpy as np

from . import _trimorph

__all__ = ["warp", "warp_graph_inputs", "read_ome_zarr", "to_ome_zarr", "fit_frames"]

_DTYPES = (np.uint8, np.uint16, np.float32)


def _bounds(chunks):
    """Start offsets of the chunks along one axis, and the end."""
    return [0, *itertools.accumulate(chunks)]


def _overlap(starts, lo, hi):
    """Indices of the chunks (with ``starts``) that meet ``[lo, hi)``."""
    first = bisect_right(starts, lo) - 1
    last = bisect_right(starts, hi - 1) - 1
    return range(max(first, 0), min(last, len(starts) - 2) + 1)


def _warp_block(deformation, blocks, origins, rect, tile, shape, interp, background, tolerance, mode, channels):
    """One output chunk: assemble the input window from the chunks it meets, warp it.
    Blocks are ``(..., y, x)``, or ``(..., y, x, c)`` with ``channels`` (1 to 4, one chunk)."""
    y0, x0, h, w = rect
    first = blocks[0][0]
    tail = (first.shape[-1],) if channels else ()
    lead = first.shape[: first.ndim - 2 - len(tail)]
    window = np.empty(lead + (h, w) + tail, dtype=first.dtype)
    rest = (slice(None),) * len(tail)
    for row, row_origins in zip(blocks, origins):
        for b, (by, bx) in zip(row, row_origins):
            b = np.asarray(b)
            bh, bw = b.shape[len(lead)], b.shape[len(lead) + 1]
            ya, xa = max(by, y0), max(bx, x0)
            yb, xb = min(by + bh, y0 + h), min(bx + bw, x0 + w)
            window[(Ellipsis, slice(ya - y0, yb - y0), slice(xa - x0, xb - x0)) + rest] = b[
                (Ellipsis, slice(ya - by, yb - by), slice(xa - bx, xb - bx)) + rest
            ]
    planes = window.reshape((-1, h, w) + tail)
    out = _trimorph.warp_tile(
        deformation, planes, (y0, x0), shape, tile, interp, background, tolerance, mode,
        channel_axis=-1 if channels else None,
    )
    return out.reshape(lead + (tile[2], tile[3]) + tail)


def _background_block(deformation, lead, dtype, shape, tile, interp, background, tolerance, mode, channels):
    """An output chunk no preimage reaches: the background, as the library converts it."""
    planes = int(np.prod(lead, dtype=np.int64)) if lead else 1
    tail = (channels,) if channels else ()
    dummy = np.zeros((planes, 1, 1) + tail, dtype=dtype)
    out = _trimorph.warp_tile(
        deformation, dummy, (0, 0), shape, tile, interp, background, tolerance, mode,
        channel_axis=-1 if channels else None,
    )
    return out.reshape(tuple(lead) + (tile[2], tile[3]) + tail)


def warp_graph_inputs(shape, chunks, deformation, tolerance=0.01, resolution=None, mode="constant"):
    """For each output tile (chunk indices ``(i, j)`` of the last two axes), the input
    rectangle ``(y0, x0, h, w)`` its warp reads, or ``None``: what ``warp`` builds its task
    graph from. ``shape`` is ``(H, W)``, ``chunks`` the output's ``(y chunks, x chunks)``."""
    ys, xs = _bounds(chunks[0]), _bounds(chunks[1])
    tiles = [
        (ys[i], xs[j], chunks[0][i], chunks[1][j])
        for i in range(len(chunks[0]))
        for j in range(len(chunks[1]))
    ]
    rects = _trimorph.tile_inputs(deformation, tuple(shape), tiles, tolerance, resolution, mode)
    nx = len(chunks[1])
    return {(k // nx, k % nx): (tiles[k], rects[k]) for k in range(len(tiles))}


def warp(
    arr,
    deformation,
    interp="bilinear",
    background=0.0,
    tolerance=0.01,
    chunks=None,
    resolution=None,
    mode="constant",
    channel_axis=None,
    stack_axis=None,
):
    """Warps a dask array lazily: ``O(q) = I(phi^-1(q))`` on every plane, same shape, dtype
    (uint8, uint16 or float32) and axis order, equal to ``Deformation.warp`` on the same
    array in memory.

    Axes are read as ``Deformation.warp`` reads them (``channel_axis``, ``stack_axis``: see
    its docstring): a 2-D array is ``(Y, X)``, a 3-D one ``(Y, X, C)`` when its last axis
    has 1 to 4 channels and its first more than 4 pixels, and anything else names its
    axes; e.g. ``stack_axis=0`` for a ``(T, Y, X)`` time-lapse, ``stack_axis=(0, 1)`` for an
    OME-Zarr ``(T, C, Y, X)`` image whose channels are warped alike.

    ``deformation``: one ``Deformation`` for every plane, or a sequence of them, one per
    plane along ``stack_axis`` (a single axis; a sequence registered frame by frame).

    ``chunks`` sets the output's chunks on the y and x axes (``(y, x)`` sizes, or anything
    ``dask.array.core.normalize_chunks`` takes); by default the input's. Stack axes keep
    the input's chunks (one plane per chunk with a sequence of deformations), and 1 to 4
    channels are one chunk. Each output chunk reads only the input chunks that meet its
    certified input rectangle (``warp_graph_inputs``), so memory per task is about one
    output chunk and its preimage, whatever the image size. ``mode`` is ``"constant"``
    (the background outside the image, the default) or ``"edge"``; ``"reflect"`` needs
    pixels outside a tile's window and is refused.
    """
    import dask.array as da

    arr = da.asarray(arr)
    if arr.dtype not in [np.dtype(t) for t in _DTYPES]:
        raise ValueError(f"unsupported dtype {arr.dtype} (use uint8, uint16 or float32; convert with .astype)")
    stacks, channel = _trimorph._image_axes(arr.shape, channel_axis, stack_axis)
    if 0 in arr.shape:
        raise ValueError(f"the image is empty (shape {arr.shape})")
    if not np.isfinite(background):
        raise ValueError("background must be a finite number")
    if mode not in ("constant", "edge"):
        raise ValueError(
            f"mode {mode!r}: dask warps take 'constant' or 'edge' ('reflect' reads pixels "
            "outside a tile's input window)"
        )
    per_plane = not isinstance(deformation, _trimorph.Deformation)
    if per_plane:
        try:
            deformation = list(deformation)
        except TypeError:
            raise TypeError(
                f"deformation must be a Deformation or a sequence of them (one per plane), "
                f"got {type(deformation).__name__}"
            ) from None
        if len(stacks) != 1:
            raise ValueError(
                f"deformation: a sequence of {len(deformation)} deformations needs one stack "
                f"axis to give them to (stack_axis=), the array of shape {arr.shape} has "
                f"{len(stacks)}"
            )
        n = arr.shape[stacks[0]]
        if len(deformation) != n:
            raise ValueError(
                f"deformation: {len(deformation)} deformations for {n} planes along "
                f"stack_axis={stacks[0]} (shape {arr.shape}); give one per plane"
            )
        bad = [i for i, d in enumerate(deformation) if not isinstance(d, _trimorph.Deformation)]
        if bad:
            raise TypeError(f"deformation[{bad[0]}] is {type(deformation[bad[0]]).__name__}, not a Deformation")
    # The array as (stacks..., y, x[, c]): stack axes first, channels last.
    nd = arr.ndim
    src = list(stacks) + ([channel] if channel is not None else [])
    dst = list(range(len(stacks))) + ([nd - 1] if channel is not None else [])
    canon = da.moveaxis(arr, src, dst) if src != dst else arr
    channels = None
    if channel is not None:
        c = canon.shape[-1]
        if c <= 4:
            channels = c
            if len(canon.chunks[-1]) > 1:
                canon = canon.rechunk({nd - 1: -1})
        else:
            # More than 4 channels are independent gray planes, as in Deformation.warp.
            canon = da.moveaxis(canon, -1, len(stacks))
    if per_plane and len(canon.chunks[0]) != canon.shape[0]:
        canon = canon.rechunk({0: 1})
    out = _warp_canonical(
        canon, deformation, per_plane, channels, interp, background, tolerance, chunks, resolution, mode
    )
    if channel is not None and channels is None:
        out = da.moveaxis(out, len(stacks), -1)
    return da.moveaxis(out, dst, src) if src != dst else out


def _warp_canonical(arr, deformation, per_plane, channels, interp, background, tolerance, chunks, resolution, mode):
    """``warp`` of an array laid out ``(lead..., y, x)``, or ``(lead..., y, x, c)`` with
    ``channels`` (1 to 4, one chunk); ``deformation`` a list with ``per_plane`` (one per
    index of the first axis, chunked by one)."""
    import dask.array as da
    from dask.base import tokenize
    from dask.highlevelgraph import HighLevelGraph

    tail = 1 if channels else 0
    nlead = arr.ndim - 2 - tail
    H, W = arr.shape[nlead], arr.shape[nlead + 1]
    in_yx = arr.chunks[nlead : nlead + 2]
    if chunks is None:
        yx = in_yx
    else:
        yx = da.core.normalize_chunks(chunks, (H, W), dtype=arr.dtype)
    lead_chunks = arr.chunks[:nlead]
    out_chunks = tuple(lead_chunks) + tuple(yx) + ((channels,),) * tail
    defs = deformation if per_plane else [deformation]
    plans, seen = [], {}
    for d in defs:
        if id(d) not in seen:
            seen[id(d)] = warp_graph_inputs((H, W), yx, d, tolerance, resolution, mode)
        plans.append(seen[id(d)])
    ys, xs = _bounds(in_yx[0]), _bounds(in_yx[1])
    token = tokenize(
        arr.name, [d.to_json() for d in defs], interp, background, tolerance, out_chunks, mode
    )
    name = f"trimorph-warp-{token}"
    dnames = [f"trimorph-deformation-{token}-{k}" for k in range(len(defs))]
    dsk = dict(zip(dnames, defs))
    ctail = (0,) * tail
    for lead in itertools.product(*[range(len(c)) for c in lead_chunks]):
        lead_shape = tuple(c[i] for c, i in zip(lead_chunks, lead))
        k = lead[0] if per_plane else 0
        for (i, j), (tile, rect) in plans[k].items():
            key = (name, *lead, i, j, *ctail)
            if rect is None:
                dsk[key] = (
                    _background_block, dnames[k], lead_shape, arr.dtype.str, (H, W), tile,
                    interp, float(background), float(tolerance), mode, channels,
                )
                continue
            y0, x0, h, w = rect
            iy, ix = _overlap(ys, y0, y0 + h), _overlap(xs, x0, x0 + w)
            blocks = [[(arr.name, *lead, a, b, *ctail) for b in ix] for a in iy]
            origins = [[(ys[a], xs[b]) for b in ix] for a in iy]
            dsk[key] = (
                _warp_block, dnames[k], blocks, origins, rect, tile, (H, W),
                interp, float(background), float(tolerance), mode, channels,
            )
    graph = HighLevelGraph.from_collections(name, dsk, dependencies=[arr])
    meta = np.empty((0,) * arr.ndim, dtype=arr.dtype)
    return da.Array(graph, name, out_chunks, meta=meta)


def read_ome_zarr(url, level=0):
    """An OME-Zarr image's resolution ``level`` as a dask array (its stored chunks), and the
    group's attributes (``multiscales``, ``omero``, ...) to pass to ``to_ome_zarr``."""
    import dask.array as da
    import zarr

    try:
        group = zarr.open_group(str(url), mode="r")
    except (FileNotFoundError, zarr.errors.GroupNotFoundError, ValueError) as e:
        raise ValueError(f"{url}: not an OME-Zarr image (no zarr group with multiscales metadata: {e})") from e
    attrs = dict(group.attrs)
    ms = attrs.get("multiscales") or attrs.get("ome", {}).get("multiscales")
    if not ms:
        raise ValueError(f"{url}: not an OME-Zarr image (no multiscales metadata)")
    datasets = ms[0].get("datasets", [])
    if not 0 <= level < len(datasets):
        raise ValueError(f"{url}: level {level} out of range ({len(datasets)} levels)")
    arr = group[datasets[level]["path"]]
    like = {"attrs": attrs, "level": level, "zarr_format": group.metadata.zarr_format}
    names = getattr(arr.metadata, "dimension_names", None)
    if names:
        like["dimension_names"] = list(names)
    return da.from_zarr(arr), like


def to_ome_zarr(arr, url, like, compute=True):
    """Writes ``arr`` (a dask array, e.g. ``warp``'s result) as a one-level OME-Zarr image at
    ``url``, with the metadata ``like`` from ``read_ome_zarr`` (axes, the level's scale and
    translation, omero channels and the rest of the group attributes kept; only the
    warped level is listed; a Zarr v3 array keeps the source's ``dimension_names``, else
    gets the axes' names, as NGFF 0.5 asks), chunk by chunk by Dask.

    A local path is written to a temporary store beside it and renamed into place when every
    chunk is written, so a failed run leaves an existing store as it was. With
    ``compute=False`` (the delayed write, to compute later with other work) the store is
    written in place."""
    import os
    import shutil
    import uuid

    local = compute and "://" not in str(url)
    if not local:
        return _write_ome_zarr(arr, url, like, compute)
    final = os.path.abspath(str(url))
    tmp = f"{final}.tmp-{uuid.uuid4().hex[:8]}"
    guard = _WriteGuard()
    try:
        _write_ome_zarr(arr, tmp, like, True, guard)
        if os.path.exists(final):
            old = f"{final}.old-{uuid.uuid4().hex[:8]}"
            os.replace(final, old)
            os.replace(tmp, final)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, final)
    finally:
        # A failed chunk makes da.store raise while other threads may still be writing
        # chunks into tmp: stop new writes and wait for running ones before removing it.
        guard.close()
        shutil.rmtree(tmp, ignore_errors=True)
    return None


class _WriteGuard:
    """Counts chunk writes in flight in this process; after ``close`` new writes are
    dropped and ``close`` returns once running ones are done. Pickled (to another process's
    worker) it is a plain pass-through: those writes cannot outlive the failed store call's
    cleanup there, which waits for its own tasks."""

    def __init__(self):
        import threading

        self._cond = threading.Condition()
        self._active = 0
        self._closed = False

    def __getstate__(self):
        return {}

    def __setstate__(self, _state):
        self._cond = None

    def enter(self):
        if self._cond is None:
            return True
        with self._cond:
            if self._closed:
                return False
            self._active += 1
            return True

    def leave(self):
        if self._cond is None:
            return
        with self._cond:
            self._active -= 1
            self._cond.notify_all()

    def close(self):
        with self._cond:
            self._closed = True
            while self._active:
                self._cond.wait()


class _GuardedTarget:
    """A zarr array whose ``__setitem__`` (the only method ``da.store`` uses) goes through a
    ``_WriteGuard``."""

    def __init__(self, target, guard):
        self.target, self.guard = target, guard
        self.shape, self.dtype = target.shape, target.dtype

    def __setitem__(self, key, value):
        if not self.guard.enter():
            return
        try:
            self.target[key] = value
        finally:
            self.guard.leave()


def _write_ome_zarr(arr, url, like, compute, guard=None):
    import copy

    import dask.array as da
    import zarr

    attrs = copy.deepcopy(like["attrs"])
    holder = attrs["ome"] if "multiscales" not in attrs and "ome" in attrs else attrs
    ms = holder["multiscales"][0]
    ds = dict(ms["datasets"][like["level"]])
    ds["path"] = "0"
    ms["datasets"] = [ds]
    fmt = like.get("zarr_format", 2)
    group = zarr.open_group(str(url), mode="w", zarr_format=fmt)
    group.attrs.update(attrs)
    # Regular chunks, the stored ones: each task writes whole stored chunks, no locks.
    chunks = tuple(c[0] for c in arr.chunks)
    arr = arr.rechunk(chunks)
    extra = {}
    if fmt == 3:
        # NGFF 0.5: a level's zarr.json holds dimension_names, the axes' names.
        names = like.get("dimension_names") or [a.get("name") for a in ms.get("axes", [])]
        if len(names) == arr.ndim and all(isinstance(n, str) for n in names):
            extra["dimension_names"] = list(names)
    target = group.create_array("0", shape=arr.shape, dtype=arr.dtype, chunks=chunks, **extra)
    if guard is not None:
        target = _GuardedTarget(target, guard)
    return da.store(arr, target, lock=False, compute=compute)


from ._dask_fit import fit_frames  # noqa: E402  (documented there)

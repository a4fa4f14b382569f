"""trimorph: smooth (C1), exactly constrained, editable spline deformations.

A deformation ``phi`` maps the reference domain to the deformed plane, both in pixels
(x to the right, y down, pixel ``(i, j)`` centred at ``(i, j)``):

* ``Deformation.map_points(p)`` is ``phi(p)``; ``Deformation.inverse_points(q)`` is
  ``phi^-1(q)`` (certified to a tolerance, NaN where there is no preimage);
* ``Deformation.warp(image)`` computes ``O(q) = I(phi^-1(q))``: a feature at ``p`` in the
  input appears at ``phi(p)`` in the output (bit-identical to ``trimorph warp --image``);
* ``trimorph.fit(src, dst, size=(w, h))`` fits ``phi`` with ``phi(src) ~ dst``.

Axes and coordinates
--------------------
Points are ``(n, 2)`` arrays of pixel coordinates. The same pixel has these coordinates in
the tools trimorph meets:

=====================================  ==================  ==============================
convention                             pixel in column i,  notes
                                       row j
=====================================  ==================  ==============================
trimorph (``order="xy"``, default)     ``(i, j)``          x right, y down; pixel centres
                                                           at integers
napari Points, scikit-image            ``(j, i)``          ``(row, col)``: pass
(``order="rc"``)                                           ``order="rc"`` or convert with
                                                           ``points_from_rc`` /
                                                           ``points_to_rc``
ITK / SimpleITK physical points        ``origin +          ``(x, y)``; ``to_itk`` writes
                                       spacing * (i, j)``  origin 0, spacing 1 (trimorph's
                                                           pixels) unless given
                                                           ``spacing=`` / ``origin=`` or a
                                                           frame placed by ``with_frame``
OME-Zarr (NGFF) arrays and fields      index ``[..., j,    axes ``(y, x)``; a displacement
                                       i]``                store is ``(c, y, x)`` with
                                                           ``c = 0`` the y displacement;
                                                           ``to_ngff(scale=(sx, sy))``
                                                           is written ``(1, sy, sx)``
=====================================  ==================  ==============================

Every API that takes or returns points (``map_points``, ``inverse_points``, ``fit``,
``register``, ``morph``, ``Deformation.mesh_landmarks``) has ``order="xy"`` or ``"rc"``;
it applies to point arrays only: sizes stay ``size=(w, h)`` and results keep the input's
order. No half-pixel shift is ever applied (all four put pixel centres at integers).

Image arrays are numpy's ``[row, col]`` = ``[y, x]``. ``Deformation.warp`` and
``trimorph.dask.warp`` read their axes as scikit-image does: ``channel_axis`` names the
channels, ``stack_axis`` the axis (or axes) of planes warped one by one, and the two left
are y, x. Without keywords a 2-D array is ``(Y, X)`` and a 3-D array ``(Y, X, C)`` only
when its last axis has 1 to 4 channels and its first more than 4 pixels; any other 3-D
array (a ``(T, Y, X)`` time-lapse, channels first ``(C, Y, X)``) is refused with a
``ValueError`` that names the readings and their keyword.

Long calls release the GIL. Bad input raises ``ValueError`` (``TypeError`` for an argument
of the wrong kind, ``FileNotFoundError`` for a missing file); unsolvable edits and hard
fits raise ``UnsolvableError`` (a ``TrimorphError``). Inputs that would exceed the memory
budget (``set_max_memory``, default half of the memory the process may use) raise
``MemoryError`` before anything large is allocated.

Long calls (``Deformation.warp``, ``Deformation.field``, ``fit``, ``register``,
``trimorph.dask.fit_frames``) take ``progress=callable`` (called as ``progress(done,
total)`` on the calling thread: rows, iterations or frames) and ``cancel=CancelToken()``.
Ctrl-C (``KeyboardInterrupt``), an exception raised by ``progress``, or
``token.cancel()`` from any thread (``trimorph.Cancelled``) stops them between bands of
rows, iterations or tasks; nothing keeps running after the call returns.

Images larger than memory and long sequences: ``trimorph.dask`` (needs ``dask``); its
building blocks ``tile_inputs`` and ``warp_tile`` warp one output tile from the input it
needs, bit-identical to ``Deformation.warp`` on the whole image.
"""

import numpy as _np

from ._trimorph import (  # noqa: F401
    Cancelled,
    CancelToken,
    Deformation,
    FrameSequence,
    TrimorphError,
    UnsolvableError,
    __version__,
    fit,
    max_memory,
    morph,
    read_image,
    read_ome_zarr,
    register,
    set_max_memory,
    tile_inputs,
    warp_tile,
)

__all__ = [
    "Cancelled",
    "CancelToken",
    "Deformation",
    "FrameSequence",
    "TrimorphError",
    "UnsolvableError",
    "fit",
    "max_memory",
    "morph",
    "points_from_rc",
    "points_to_rc",
    "read_image",
    "read_ome_zarr",
    "register",
    "set_max_memory",
    "tile_inputs",
    "warp_tile",
    "__version__",
]


def _deformation_from_json(text):
    """Rebuilds a pickled ``Deformation`` (see ``Deformation.__reduce__``)."""
    return Deformation.from_json(text)


def _swap_columns(points, what):
    a = _np.asarray(points, dtype=_np.float64)
    if a.ndim != 2 or a.shape[1] != 2:
        if a.shape == (0,):
            return _np.zeros((0, 2))
        raise ValueError(f"{what}: expected points of shape (n, 2), got shape {a.shape}")
    return _np.ascontiguousarray(a[:, ::-1])


def points_from_rc(points):
    """``(row, col)`` points (napari Points layers, scikit-image) as trimorph's ``(x, y)``:
    an ``(n, 2)`` float64 copy with the columns swapped. The inverse of ``points_to_rc``;
    the keyword ``order="rc"`` of the point APIs does the same on the way in and out."""
    return _swap_columns(points, "points")


def points_to_rc(points):
    """trimorph's ``(x, y)`` points as ``(row, col)`` (napari, scikit-image): an ``(n, 2)``
    float64 copy with the columns swapped. The inverse of ``points_from_rc``."""
    return _swap_columns(points, "points")

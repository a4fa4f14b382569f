"""trimorph: smooth (C1), exactly constrained, editable spline deformations.

A deformation ``phi`` maps the reference domain to the deformed plane, both in pixels
(x to the right, y down, pixel ``(i, j)`` centred at ``(i, j)``):

* ``Deformation.map_points(p)`` is ``phi(p)``; ``Deformation.inverse_points(q)`` is
  ``phi^-1(q)`` (certified to a tolerance, NaN where there is no preimage);
* ``Deformation.warp(image)`` computes ``O(q) = I(phi^-1(q))``: a feature at ``p`` in the
  input appears at ``phi(p)`` in the output (bit-identical to ``trimorph warp --image``);
* ``trimorph.fit(src, dst, size=(w, h))`` fits ``phi`` with ``phi(src) ~ dst``.

Long calls release the GIL. Bad input raises ``ValueError``; unsolvable edits and hard
fits raise ``UnsolvableError`` (a ``TrimorphError``). Inputs that would exceed the memory
budget (``set_max_memory``, default half of the memory the process may use) raise
``MemoryError`` before anything large is allocated.

Images larger than memory and long sequences: ``trimorph.dask`` (needs ``dask``); its
building blocks ``tile_inputs`` and ``warp_tile`` warp one output tile from the input it
needs, bit-identical to ``Deformation.warp`` on the whole image.
"""

from ._trimorph import (  # noqa: F401
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
    "Deformation",
    "FrameSequence",
    "TrimorphError",
    "UnsolvableError",
    "fit",
    "max_memory",
    "morph",
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

"""trimorph: smooth (C1), exactly constrained, editable spline deformations.

A deformation ``phi`` maps the reference domain to the deformed plane, both in pixels
(x to the right, y down, pixel ``(i, j)`` centred at ``(i, j)``):

* ``Deformation.map_points(p)`` is ``phi(p)``; ``Deformation.inverse_points(q)`` is
  ``phi^-1(q)`` (certified to a tolerance, NaN where there is no preimage);
* ``Deformation.warp(image)`` computes ``O(q) = I(phi^-1(q))``: a feature at ``p`` in the
  input appears at ``phi(p)`` in the output (bit-identical to ``trimorph warp --image``);
* ``trimorph.fit(src, dst, size=(w, h))`` fits ``phi`` with ``phi(src) ~ dst``.

Long calls release the GIL. Bad input raises ``ValueError``; unsolvable edits and hard
fits raise ``UnsolvableError`` (a ``TrimorphError``).
"""

from ._trimorph import (  # noqa: F401
    Deformation,
    FrameSequence,
    TrimorphError,
    UnsolvableError,
    __version__,
    fit,
    morph,
    read_image,
    read_ome_zarr,
)

__all__ = [
    "Deformation",
    "FrameSequence",
    "TrimorphError",
    "UnsolvableError",
    "fit",
    "morph",
    "read_image",
    "read_ome_zarr",
    "__version__",
]

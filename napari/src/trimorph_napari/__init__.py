"""napari plugin for trimorph (smooth C1 spline deformations).

The dock widget (Plugins menu -> trimorph -> Deformation) fits a deformation from two
Points layers, registers two Image layers, warps Image and Labels layers, shows the
Jacobian determinant map and the deformed mesh, and exports ITK ``.h5`` / NGFF ``.zarr``.

Coordinates: napari Points data are ``(row, col)`` in their layer's data space; the plugin
sends them through world coordinates to the pixel ``(x, y) = (col, row)`` of the chosen
frame Image layer, trimorph's convention (see :mod:`trimorph_napari._core`).
"""

from ._core import (  # noqa: F401
    METADATA_KEY,
    deformation_from_layer,
    frame_size,
    jacobian_map,
    mesh_paths,
    points_to_pixels,
    warp_image,
    warp_labels,
)

__version__ = "0.1.0"

__all__ = [
    "METADATA_KEY",
    "TrimorphWidget",
    "deformation_from_layer",
    "frame_size",
    "jacobian_map",
    "mesh_paths",
    "points_to_pixels",
    "warp_image",
    "warp_labels",
]


def __getattr__(name):
    # The widget imports Qt: only when asked for.
    if name == "TrimorphWidget":
        from ._widget import TrimorphWidget

        return TrimorphWidget
    raise AttributeError(name)

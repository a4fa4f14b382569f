"""The napari-free part of the plugin: coordinates, warps, Jacobian maps, mesh paths.

Coordinate conventions
======================

napari and trimorph name the same pixel differently:

* a napari layer's ``data`` holds coordinates in the layer's *data* space, axis order
  ``(..., row, col)``; napari draws a data point ``d`` at the *world* point
  ``w = A (d * scale) + translate`` ... in general ``w = M d`` with ``M`` the layer's
  data-to-world transform (``scale``, ``translate``, ``rotate``, ``shear``, then
  ``affine``). Layers of lower dimension are aligned on the last (trailing) world axes.
* trimorph works in the *pixel* coordinates of one image: ``(x, y)`` with ``x`` the
  column and ``y`` the row, pixel ``(i, j)`` centred at ``(i, j)`` -- the same centres as
  napari's data coordinates of that image, in the other order.

So a landmark of a Points layer becomes a trimorph point in three steps
(:func:`points_to_pixels`): its last two data coordinates ``(row, col)`` are sent to world
coordinates by the Points layer's transform, then to the data coordinates of the chosen
*frame* Image layer by the inverse of that layer's transform, and the order is swapped,
``x = col``, ``y = row``. Only the last two axes of each transform are used (the 2-D
block of the homogeneous matrix): rotations and shears that mix them with leading
(stack) axes are ignored. :func:`pixels_to_data` is the way back. The layers the plugin
makes from a result (warped images, the Jacobian map, the mesh, the mapped points) get
the frame layer's transform, so they overlay it in world coordinates
(:func:`frame_transform_kwargs`).

Directions (as in trimorph): a fit with ``src`` = the *moving* (reference) points and
``dst`` = the *fixed* points gives ``phi`` with ``phi(src) ~ dst``;
``Deformation.warp(I)`` is ``O(q) = I(phi^-1(q))``, so warping the moving image puts it
on the fixed image. ``trimorph.register(fixed, moving)`` gives the same direction.

The Jacobian map (:func:`jacobian_map`) is *sampled*: ``det D phi`` by central finite
differences of ``phi(p) = p + u(p)`` on the pixel grid, ``u = Deformation.field()``
(trimorph has no dense Jacobian call). The certified bound is the one of
``Deformation.check()["det_j_lower_bound"]`` (or the fit report's), which the sampled map
can only approach from above.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Tuple

import numpy as np

import trimorph

#: The key of ``layer.metadata`` that holds what the plugin stores with a layer.
METADATA_KEY = "trimorph"

#: The sample types ``Deformation.warp`` takes as they are.
NATIVE_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.float32))


# --------------------------------------------------------------------------------------
# Coordinates


def _affine_2d(layer) -> np.ndarray:
    """The 3 x 3 homogeneous data-to-world matrix of a layer's last two axes."""
    from napari.utils.transforms import Affine

    ndim = layer.ndim
    physical = Affine(
        scale=layer.scale,
        translate=layer.translate,
        rotate=layer.rotate,
        shear=layer.shear,
        ndim=ndim,
    )
    full = np.asarray(layer.affine.affine_matrix, float) @ np.asarray(physical.affine_matrix, float)
    idx = [ndim - 2, ndim - 1]
    m = np.eye(3)
    m[:2, :2] = full[np.ix_(idx, idx)]
    m[:2, 2] = full[idx, ndim]
    return m


def _apply(m: np.ndarray, rc: np.ndarray) -> np.ndarray:
    return rc @ m[:2, :2].T + m[:2, 2]


def data_to_world(layer, rc) -> np.ndarray:
    """``(n, 2)`` data ``(row, col)`` of ``layer``'s last two axes to world ``(row, col)``."""
    return _apply(_affine_2d(layer), np.asarray(rc, float).reshape(-1, 2))


def world_to_data(layer, rc) -> np.ndarray:
    """``(n, 2)`` world ``(row, col)`` to ``layer``'s data ``(row, col)`` (last two axes)."""
    return _apply(np.linalg.inv(_affine_2d(layer)), np.asarray(rc, float).reshape(-1, 2))


def points_to_pixels(points_layer, frame_layer) -> np.ndarray:
    """The points of a Points layer as trimorph ``(x, y)`` pixels of the frame Image layer.

    ``(row, col)`` data (the last two columns of ``points_layer.data``) -> world -> the
    frame layer's data ``(row, col)`` -> ``(x, y) = (col, row)``.
    """
    data = np.asarray(points_layer.data, float)
    if data.size == 0:
        return np.zeros((0, 2))
    rc = world_to_data(frame_layer, data_to_world(points_layer, data[:, -2:]))
    return rc[:, ::-1].copy()


def pixels_to_data(xy, layer) -> np.ndarray:
    """trimorph ``(x, y)`` pixels of the frame to ``(row, col)`` data of a layer with the
    same transform as the frame (the layers the plugin makes); NaN rows stay NaN."""
    return np.asarray(xy, float).reshape(-1, 2)[:, ::-1].copy()


def frame_shape(layer) -> Tuple[int, int]:
    """``(h, w)``: the pixel rows and columns of an Image or Labels layer's last two axes
    (before the colour axis of an RGB image)."""
    shape = tuple(layer.data.shape)
    if getattr(layer, "rgb", False):
        shape = shape[:-1]
    if len(shape) < 2:
        raise ValueError(f"layer {layer.name!r} has no 2-D pixel grid (shape {shape})")
    return int(shape[-2]), int(shape[-1])


def frame_size(layer) -> Tuple[int, int]:
    """trimorph's ``size = (w, h)`` of an Image layer (``w`` columns, ``h`` rows)."""
    h, w = frame_shape(layer)
    return w, h


def frame_transform_kwargs(frame_layer) -> Dict[str, Any]:
    """Layer keyword arguments that put a new 2-D layer on the frame layer's last two axes."""
    m = _affine_2d(frame_layer)
    lin = m[:2, :2]
    if np.allclose(lin, np.diag(np.diag(lin))):
        return {"scale": tuple(np.diag(lin)), "translate": tuple(m[:2, 2])}
    return {"affine": m}


def same_pixel_grid(a, b) -> bool:
    """Whether two layers' last two axes have the same data-to-world transform."""
    return bool(np.allclose(_affine_2d(a), _affine_2d(b)))


# --------------------------------------------------------------------------------------
# Results


def report_summary(d: trimorph.Deformation) -> Dict[str, Any]:
    """The numbers a person wants to see first: rms (fit), the certified det J lower bound,
    fold-free, whether the frame is covered, the metric (registration)."""
    rep = d.report or {}
    out: Dict[str, Any] = {}
    fit = rep.get("fit") or {}
    if "rms" in fit:
        out["rms"] = float(fit["rms"])
    if "max" in fit:
        out["max_residual"] = float(fit["max"])
    lb = rep.get("det_j_lower_bound")
    if lb is None:
        lb = d.check().get("det_j_lower_bound")
    if lb is not None:
        out["det_j_lower_bound"] = float(lb)
    ff = rep.get("fold_free")
    if ff is None and lb is not None:
        ff = float(lb) > 0.0
    out["fold_free"] = bool(ff) if ff is not None else None
    frame = rep.get("frame") or {}
    if "covers_frame" in frame:
        out["covers_frame"] = bool(frame["covers_frame"])
    for k in ("metric", "metric_before", "metric_after"):
        if k in rep:
            out[k] = rep[k]
    out["triangles"] = d.num_triangles
    return out


def format_summary(s: Dict[str, Any]) -> str:
    parts = []
    if "rms" in s:
        parts.append(f"rms {s['rms']:.2f} px")
    if "metric_after" in s:
        m = s.get("metric", "metric")
        before = s.get("metric_before")
        parts.append(
            f"{m} {before:.4f} -> {s['metric_after']:.4f}"
            if isinstance(before, (int, float)) and isinstance(s["metric_after"], (int, float))
            else f"{m} {s['metric_after']}"
        )
    if "det_j_lower_bound" in s:
        parts.append(f"det J >= {s['det_j_lower_bound']:.3f}")
    if s.get("fold_free") is not None:
        parts.append("fold-free (certified)" if s["fold_free"] else "NOT fold-free")
    if "covers_frame" in s:
        parts.append("covers the frame" if s["covers_frame"] else "does NOT cover the frame")
    parts.append(f"{s['triangles']} triangles")
    return ", ".join(parts)


def metadata(d: trimorph.Deformation, role: str, **extra) -> Dict[str, Any]:
    """What the plugin stores in ``layer.metadata["trimorph"]``: the deformation file's
    JSON text (``Deformation.from_json`` reads it back), the summary, the role of the
    layer (``fit``, ``register``, ``warp``, ``jacobian``, ``mesh``) and ``extra``."""
    return {
        METADATA_KEY: {
            "role": role,
            "deformation": d.to_json(),
            "summary": report_summary(d),
            **extra,
        }
    }


def deformation_from_layer(layer) -> Optional[trimorph.Deformation]:
    """The deformation the plugin stored with a layer, or None."""
    meta = (getattr(layer, "metadata", None) or {}).get(METADATA_KEY)
    if not meta or "deformation" not in meta:
        return None
    d = meta["deformation"]
    return d if isinstance(d, trimorph.Deformation) else trimorph.Deformation.from_json(d)


# --------------------------------------------------------------------------------------
# Fit


def fit_from_pixels(src_xy, dst_xy, size, **kwargs) -> trimorph.Deformation:
    """``trimorph.fit(src, dst, size=size, ...)`` after checks a person can act on."""
    src = np.asarray(src_xy, float).reshape(-1, 2)
    dst = np.asarray(dst_xy, float).reshape(-1, 2)
    if len(src) != len(dst):
        raise ValueError(
            f"the moving layer has {len(src)} points and the fixed layer {len(dst)}: "
            "they are paired by index, so the counts must match"
        )
    if len(src) < 3:
        raise ValueError(f"a fit needs at least 3 landmark pairs, got {len(src)}")
    return trimorph.fit(src, dst, size=tuple(float(v) for v in size), **kwargs)


# --------------------------------------------------------------------------------------
# Warps


def _planes(data: np.ndarray, rgb: bool) -> Tuple[Tuple[int, ...], int]:
    """The leading (stack) shape and the number of 2-D (or H x W x C) planes."""
    lead = data.shape[:-3] if rgb else data.shape[:-2]
    return tuple(lead), int(np.prod(lead, dtype=np.int64)) if lead else 1


def warp_image_iter(
    d: trimorph.Deformation,
    data,
    rgb: bool = False,
    interp: str = "bilinear",
    background: float = 0.0,
    mode: str = "constant",
    cancel: Optional[trimorph.CancelToken] = None,
) -> Iterator[Tuple[int, int, Optional[np.ndarray]]]:
    """Warps an Image layer's data plane by plane: yields ``(done, total, None)`` after
    each plane and finally ``(total, total, result)``. A cancelled ``cancel`` token stops
    the warp within a band of rows (``trimorph.Cancelled``).

    A 2-D array, or an RGB(A) ``(..., H, W, C)`` array with ``rgb=True``, is one plane;
    the leading axes of a stack ``(..., H, W)`` are warped plane by plane (trimorph would
    take a 3-D array as ``(H, W, C)``). uint8, uint16 and float32 go through as they
    are; other dtypes are warped as float32 and cast back (integers rounded and clipped
    to their range). Same shape and dtype out.
    """
    arr = np.asarray(data)
    if arr.ndim < (3 if rgb else 2):
        raise ValueError(f"expected an image, got shape {arr.shape}")
    dtype = arr.dtype
    work = dtype if dtype in NATIVE_DTYPES else np.dtype(np.float32)
    lead, n = _planes(arr, rgb)
    inner = arr.shape[len(lead) :]
    flat = arr.reshape((n,) + inner)
    out = np.empty((n,) + inner, dtype=dtype)
    for k in range(n):
        plane = np.ascontiguousarray(flat[k], dtype=work)
        w = d.warp(plane, interp=interp, background=background, mode=mode, cancel=cancel)
        if work != dtype:
            if np.issubdtype(dtype, np.integer):
                info = np.iinfo(dtype)
                w = np.clip(np.rint(w), info.min, info.max)
            elif dtype == np.bool_:
                w = w >= 0.5
        out[k] = w
        yield k + 1, n, None
    yield n, n, out.reshape(arr.shape)


def warp_image(d, data, **kwargs) -> np.ndarray:
    """:func:`warp_image_iter` run to its end."""
    return list(warp_image_iter(d, data, **kwargs))[-1][2]


def warp_labels_iter(
    d: trimorph.Deformation, data, cancel: Optional[trimorph.CancelToken] = None
) -> Iterator[Tuple[int, int, Optional[np.ndarray]]]:
    """Warps a Labels layer's data with nearest-neighbour interpolation: the output holds
    only values of the input (and 0, the background, where phi^-1 leaves the image or
    the mesh), in the input's integer dtype, whatever its range.

    The labels are renumbered to a compact index first (``0`` kept for label ``0``), the
    index image is warped as uint16 (or float32, exact up to 2^24 distinct labels), then
    the labels are looked up again -- so int32 / int64 / uint32 labels beyond uint16's range
    keep their values. Stacks go plane by plane (yields as :func:`warp_image_iter`).
    """
    arr = np.asarray(data)
    if arr.ndim < 2:
        raise ValueError(f"expected labels of 2 or more dimensions, got shape {arr.shape}")
    values, index = np.unique(
        np.concatenate([[0], arr.ravel()]).astype(arr.dtype), return_inverse=True
    )
    index = index[1:].reshape(arr.shape)
    zero = int(np.searchsorted(values, 0))  # values holds 0: the background's index
    if len(values) <= 65535:
        work = np.uint16
    elif len(values) <= 1 << 24:
        work = np.float32
    else:
        raise ValueError(f"{len(values)} distinct labels: more than 2^24 cannot be warped exactly")
    lead, n = _planes(arr, False)
    flat = index.reshape((n,) + arr.shape[-2:])
    out = np.empty((n,) + arr.shape[-2:], dtype=arr.dtype)
    for k in range(n):
        w = d.warp(
            np.ascontiguousarray(flat[k], dtype=work),
            interp="nearest",
            background=float(zero),
            mode="constant",
            cancel=cancel,
        )
        out[k] = values[np.asarray(w).astype(np.int64)]
        yield k + 1, n, None
    yield n, n, out.reshape(arr.shape)


def warp_labels(d, data) -> np.ndarray:
    """:func:`warp_labels_iter` run to its end."""
    return list(warp_labels_iter(d, data))[-1][2]


# --------------------------------------------------------------------------------------
# Jacobian


def _det_of_map(u: np.ndarray) -> np.ndarray:
    """det D(p + u(p)) by central differences (one-sided at the edges), pixel spacing 1;
    ``u`` is ``(H, W, 2)`` with ``u[..., 0]`` the x (column) component."""
    u = u.astype(np.float64)
    ux_y, ux_x = np.gradient(u[..., 0])  # axis 0 is y (rows), axis 1 is x (columns)
    uy_y, uy_x = np.gradient(u[..., 1])
    return (1.0 + ux_x) * (1.0 + uy_y) - ux_y * uy_x


def jacobian_map(
    d: trimorph.Deformation, size: Tuple[int, int], frame: str = "deformed"
) -> np.ndarray:
    """A sampled ``det D phi`` map, float32 ``(h, w)`` for ``size = (w, h)``, NaN where phi
    (or phi^-1) is undefined.

    ``frame="reference"``: ``det D phi(p)`` at the reference (moving) pixels ``p``, from
    ``u = Deformation.field()``. ``frame="deformed"``: the same value drawn where the
    point went, ``det D phi(phi^-1(q)) = 1 / det D(phi^-1)(q)`` at the deformed (fixed)
    pixels ``q``, from the inverse field -- it overlays the warped image and the mesh.
    1 is area kept, < 1 shrinking, > 1 growing; <= 0 would be a fold.
    """
    w, h = int(size[0]), int(size[1])
    if frame == "reference":
        return _det_of_map(d.field(size=(w, h))).astype(np.float32)
    if frame == "deformed":
        with np.errstate(divide="ignore", invalid="ignore"):
            return (1.0 / _det_of_map(d.field(inverse=True, size=(w, h)))).astype(np.float32)
    raise ValueError(f"frame must be 'reference' or 'deformed', got {frame!r}")


# --------------------------------------------------------------------------------------
# Mesh


def mesh_of(d: trimorph.Deformation) -> Tuple[np.ndarray, np.ndarray]:
    """The reference mesh: vertices ``(V, 2)`` as ``(x, y)`` and triangles ``(T, 3)``
    (read from the deformation file's JSON: the Python API has no accessor for them)."""
    doc = json.loads(d.to_json())
    return np.asarray(doc["vertices"], float).reshape(-1, 2), np.asarray(
        doc["triangles"], np.int64
    ).reshape(-1, 3)


def mesh_edges(triangles: np.ndarray) -> np.ndarray:
    """The unique edges ``(E, 2)`` (vertex indices, smaller first) of a triangle list."""
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    e.sort(axis=1)
    return np.unique(e, axis=0)


def mesh_paths(
    d: trimorph.Deformation,
    samples: int = 8,
    size: Optional[Tuple[float, float]] = None,
    deformed: bool = True,
) -> List[np.ndarray]:
    """The mesh's edges as paths of ``(row, col)`` points for a Shapes layer.

    Each edge (straight in the reference) is sampled at ``samples + 1`` points and sent
    through ``Deformation.map_points`` (``deformed=True``), so the paths follow the curved
    images of the edges in the deformed (fixed) frame. With ``size = (w, h)`` only the
    edges that touch the reference rectangle ``[0, w] x [0, h]`` are kept (the far-field
    rings a fit adds around the frame are left out). Points outside the mesh (NaN) are
    dropped from a path.
    """
    verts, tris = mesh_of(d)
    edges = mesh_edges(tris)
    a, b = verts[edges[:, 0]], verts[edges[:, 1]]
    if size is not None:
        w, h = float(size[0]), float(size[1])

        def inside(p):
            return (p[:, 0] >= 0) & (p[:, 0] <= w) & (p[:, 1] >= 0) & (p[:, 1] <= h)

        keep = inside(a) | inside(b) | inside((a + b) / 2)
        a, b = a[keep], b[keep]
    if len(a) == 0:
        return []
    t = np.linspace(0.0, 1.0, max(1, int(samples)) + 1)
    pts = a[:, None, :] + (b - a)[:, None, :] * t[None, :, None]  # (E, k, 2)
    flat = pts.reshape(-1, 2)
    if deformed:
        flat = d.map_points(flat)
    pts = flat.reshape(pts.shape)[..., ::-1]  # (x, y) -> (row, col)
    paths = []
    for p in pts:
        p = p[np.isfinite(p).all(axis=1)]
        if len(p) >= 2:
            paths.append(p)
    return paths


# --------------------------------------------------------------------------------------
# Export


@dataclass
class ExportResult:
    path: Path
    kind: str
    undefined: Optional[int] = None


def placement(frame_layer) -> Dict[str, Any]:
    """The physical placement of a frame layer's pixels as ``to_itk`` / ``to_ngff`` take it:
    ``spacing = (sx, sy)`` and ``origin = (ox, oy)`` from the layer's scale and translate
    (napari lists them (row, col): they are swapped here). Empty when the layer's transform
    is not a scale and translation (rotated or sheared layers are exported in pixels)."""
    m = _affine_2d(frame_layer)
    lin = m[:2, :2]
    if not np.allclose(lin, np.diag(np.diag(lin))) or (np.diag(lin) <= 0).any():
        return {}
    (sy, sx), (oy, ox) = np.diag(lin), m[:2, 2]
    return {"spacing": (float(sx), float(sy)), "origin": (float(ox), float(oy))}


def export(
    d: trimorph.Deformation,
    path,
    direction: str = "resampling",
    size: Optional[Tuple[int, int]] = None,
    spacing: Optional[Tuple[float, float]] = None,
    origin: Optional[Tuple[float, float]] = None,
) -> ExportResult:
    """Writes the deformation by the path's suffix: ``.h5`` (``.hdf5``) an ITK transform
    (``Deformation.to_itk``), ``.zarr`` an OME-Zarr NGFF displacement store
    (``Deformation.to_ngff``), ``.json`` the deformation file (``Deformation.save``).

    ``direction``: ``"resampling"`` (the files' default, ``phi^-1(q) - q``, what ITK and
    NGFF readers resample with), ``"forward"`` (``phi(p) - p``, ``inverse=True``), or for
    NGFF ``"both"``. ``size = (w, h)`` of the displacement grid (default: the frame).
    ``spacing = (sx, sy)`` and ``origin = (ox, oy)`` place the grid in physical (world)
    space, as :func:`placement` reads them from a layer; a ``.json`` file records them with
    its frame.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if direction not in ("resampling", "forward", "both"):
        raise ValueError(f"direction must be resampling, forward or both, got {direction!r}")
    size = None if size is None else (int(size[0]), int(size[1]))
    if suffix in (".h5", ".hdf5", ".hdf", ".hd5", ".he5"):
        if direction == "both":
            raise ValueError("an ITK .h5 file holds one direction: resampling or forward")
        n = d.to_itk(p, inverse=direction == "forward", size=size, spacing=spacing, origin=origin)
        return ExportResult(p, "itk", int(n))
    if suffix == ".zarr":
        d.to_ngff(p, inverse=direction == "forward", both=direction == "both", size=size,
                  scale=spacing, origin=origin)
        return ExportResult(p, "ngff")
    if suffix == ".json":
        if (spacing is not None or origin is not None) and (size or d.frame):
            d = d.with_frame(size=size, spacing=spacing, origin=origin)
        d.save(p)
        return ExportResult(p, "json")
    raise ValueError(f"unknown export format {suffix!r}: use .h5 (ITK), .zarr (NGFF) or .json")


def image_for_trimorph(data, rgb: bool = False) -> np.ndarray:
    """A 2-D (or ``(H, W, C)`` RGB) array as ``register`` takes it: uint8, uint16 or
    float32 kept, anything else as float32."""
    arr = np.asarray(data)
    if arr.ndim != (3 if rgb else 2):
        raise ValueError(
            f"registration needs a 2-D image (or an RGB one); got shape {arr.shape}: "
            "pick one plane of a stack into its own layer first"
        )
    if arr.dtype not in NATIVE_DTYPES:
        arr = arr.astype(np.float32)
    return np.ascontiguousarray(arr)

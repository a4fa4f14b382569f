"""Type stubs of the native module (see the package docstring for the map directions)."""

from os import PathLike
from pathlib import Path
from typing import Any, Callable, Dict, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike]
_Points = npt.ArrayLike  # (n, 2) float64 pixels, (x, y) or with order="rc" (row, col)
_Image = npt.NDArray[Union[np.uint8, np.uint16, np.float32]]
_Order = Literal["xy", "rc"]
_Axes = Union[int, Sequence[int]]

__version__: str

class TrimorphError(Exception):
    """Base class of the errors trimorph raises besides ValueError and OSError."""

class UnsolvableError(TrimorphError):
    """An edit or a hard fit with no solution."""

    kind: str
    """The library's error variant (e.g. "Conflicting", "NotWeaklySolvable")."""

class Cancelled(TrimorphError):
    """A call stopped because its ``cancel`` token was cancelled."""

class CancelToken:
    """Cancels long calls from any thread: pass it as ``cancel=`` and call ``cancel()``."""

    def __init__(self) -> None: ...
    def cancel(self) -> None:
        """Asks every call holding this token to stop (they raise ``Cancelled``)."""
    @property
    def cancelled(self) -> bool:
        """Whether ``cancel()`` was called."""

_Progress = Callable[[int, int], Any]

class Deformation:
    """A C1 spline deformation phi: R^2 -> R^2 over a triangle mesh, in pixels."""

    @staticmethod
    def load(path: _Path) -> "Deformation":
        """Reads a deformation file (JSON, as `trimorph` writes it)."""
    @staticmethod
    def from_json(text: str) -> "Deformation":
        """A deformation from the text of a deformation file."""
    def to_json(self) -> str:
        """The deformation file's text."""
    def save(self, path: _Path) -> None:
        """Writes the deformation file atomically (temporary file renamed into place)."""
    @staticmethod
    def mesh_grid(
        cols: int, rows: int, size: Tuple[float, float], degree: int = 5, snap: int = 16
    ) -> "Deformation":
        """The identity over a cols x rows grid of cells covering size = (w, h) pixels; a
        whole-pixel size is recorded as the frame (`field()` is h x w), as
        `trimorph mesh --grid --size`."""
    @staticmethod
    def mesh_landmarks(
        src: _Points,
        size: Tuple[float, float],
        margin: Optional[float] = None,
        max_edge: Optional[float] = None,
        min_angle: float = 15.0,
        degree: int = 5,
        snap: Optional[int] = None,
        far_rings: int = 0,
        order: _Order = "xy",
    ) -> "Deformation":
        """The identity over a mesh adapted to landmark sources in a w x h frame, with
        `far_rings` far-field rings around it (`trimorph mesh --far-rings`)."""
    def warp(
        self,
        array: _Image,
        interp: str = "bilinear",
        background: float = 0.0,
        tolerance: float = 0.01,
        mode: str = "constant",
        channel_axis: Optional[int] = None,
        stack_axis: Optional[_Axes] = None,
        progress: Optional[_Progress] = None,
        cancel: Optional[CancelToken] = None,
    ) -> _Image:
        """O(q) = I(phi^-1(q)), same shape, dtype and axis order; bit-identical to
        `trimorph warp`. `channel_axis` / `stack_axis` name the channels and the axes of
        planes (as scikit-image); without them a 2-D array is (Y, X) and a 3-D one (Y, X, C)
        only when its last axis has 1 to 4 channels and its first more than 4 pixels (other
        3-D arrays are refused, naming the readings)."""
    def warp_profiled(
        self,
        array: _Image,
        interp: str = "bilinear",
        background: float = 0.0,
        tolerance: float = 0.01,
        mode: str = "constant",
        channel_axis: Optional[int] = None,
        stack_axis: Optional[_Axes] = None,
    ) -> Tuple[_Image, Dict[str, Any], float]:
        """warp, plus the library's report and the seconds spent in the library alone."""
    def map_points(self, xy: _Points, order: _Order = "xy") -> npt.NDArray[np.float64]:
        """phi(p) per row of xy ((n, 2)); NaN rows outside the mesh. `order`: the columns
        of xy and of the result, "xy" or "rc" (row, col)."""
    def inverse_points(
        self, xy: _Points, tolerance: float = 0.01, order: _Order = "xy"
    ) -> npt.NDArray[np.float64]:
        """phi^-1(q) per row of xy ((n, 2)), certified to tolerance px; NaN without preimage.
        `order`: the columns of xy and of the result, "xy" or "rc" (row, col)."""
    def field(
        self,
        inverse: bool = False,
        size: Optional[Tuple[int, int]] = None,
        progress: Optional[_Progress] = None,
        cancel: Optional[CancelToken] = None,
    ) -> npt.NDArray[np.float32]:
        """(H, W, 2) displacements: phi(p) - p, or phi^-1(q) - q with inverse=True."""
    def edit(
        self, ops: Sequence[Dict[str, Any]], bounded_bits: Optional[int] = 24
    ) -> List[Dict[str, Any]]:
        """Applies edit-script operations (dicts, as in `trimorph edit` scripts), all or none."""
    def check(self, samples: int = 12, residuals: bool = False) -> Dict[str, Any]:
        """The report of `trimorph check`: exact C1, det J bounds, folds; the per-condition
        `c1_residuals` list only with residuals=True (`trimorph check --residuals`)."""
    def to_itk(
        self,
        path: _Path,
        inverse: bool = False,
        size: Optional[Tuple[int, int]] = None,
        tolerance: float = 0.01,
        spacing: Optional[Tuple[float, float]] = None,
        origin: Optional[Tuple[float, float]] = None,
    ) -> int:
        """Writes an ITK HDF5 displacement-field transform (resampling direction by default).
        `spacing=(sx, sy)` and `origin=(ox, oy)` (default: the frame's, else 1 and 0) place
        it in physical space, displacements in physical units."""
    def to_ngff(
        self,
        path: _Path,
        inverse: bool = False,
        both: bool = False,
        size: Optional[Tuple[int, int]] = None,
        tolerance: float = 0.01,
        scale: Optional[Tuple[float, float]] = None,
        origin: Optional[Tuple[float, float]] = None,
        units: Optional[str] = None,
    ) -> None:
        """Writes an OME-Zarr NGFF 0.6 displacement store ((2, H, W) float64, c = 0 is dy).
        `scale=(sx, sy)`, `origin=(ox, oy)` and `units` (default: the frame's, else pixels)
        place it in physical space, displacements in physical units."""
    @property
    def report(self) -> Optional[Dict[str, Any]]:
        """The fit report when made by `trimorph.fit`, else None (kept in the file: it
        survives save, load and pickling; an edit drops it)."""
    @property
    def frame(self) -> Optional[Dict[str, Any]]:
        """The image frame the deformation was made for (`size` = [w, h] pixels; `spacing`,
        `origin`, `unit` when known), or None. `field`, `to_itk`, `to_ngff` default to it."""
    @property
    def degree(self) -> int: ...
    @property
    def num_points(self) -> int: ...
    @property
    def num_vertices(self) -> int: ...
    @property
    def num_triangles(self) -> int: ...
    @property
    def bbox(self) -> Tuple[Tuple[float, float], Tuple[float, float]]: ...
    def with_frame(
        self,
        size: Optional[Tuple[float, float]] = None,
        spacing: Optional[Tuple[float, float]] = None,
        origin: Optional[Tuple[float, float]] = None,
        unit: Optional[str] = None,
    ) -> "Deformation":
        """A copy recording the image frame (size in pixels) and its physical placement:
        pixel centre (i, j) at origin + spacing * (i, j), in `unit`s. `field`, `to_itk` and
        `to_ngff` default to it."""
    def copy(self) -> "Deformation": ...

class FrameSequence:
    """One scene fitted to every frame of a sequence, one frame per call: the per-frame work
    of `trimorph fit --model MODEL --frames FRAMES --landmarks LANDMARKS -o OUT_DIR`.

    Reads the scene (and its model), the frames (a folder or a multi-page TIFF) and the
    landmarks (a file: first-frame targets, tracked with `track=True`; a folder: one
    `<frame>.csv`/`.json` per frame) as `fit --frames` does; bad input raises ValueError
    naming the file. Picklable: the receiver rebuilds it from its (absolute) arguments.
    2D frames need no scene: `model=None` with `size=(w, h)` starts every frame from the
    identity over a mesh adapted to the landmarks (`trimorph fit --size W,H --frames`).
    """

    def __init__(
        self,
        model: Optional[_Path],
        frames: _Path,
        landmarks: _Path,
        out_dir: _Path,
        *,
        size: Optional[Tuple[float, float]] = None,
        track: bool = False,
        anchor: Optional[str] = None,
        key_every: Optional[int] = None,
        holdout: int = 0,
        seed: int = 1,
        background: float = 0.0,
        model_file: Optional[_Path] = None,
        loss: str = "squares",
        loss_scale: float = 2.0,
        bend: Union[str, float, None] = None,
        hard: bool = False,
        barrier: bool = True,
        min_det: float = 0.1,
        max_iters: int = 200,
        radius: Optional[int] = None,
    ) -> None: ...
    def __len__(self) -> int:
        """Number of frames."""
    @property
    def names(self) -> List[str]:
        """The frames' names in order (outputs `<name>.json`, `<name>.report.json`, ...)."""
    @property
    def tracked(self) -> bool:
        """Whether frame k warm-starts from frame k - 1's stored result (run in order)."""
    @property
    def out_dir(self) -> Path:
        """The output folder (absolute)."""
    def run_frame(self, k: int) -> Dict[str, Any]:
        """Fits frame k and writes the files `fit --frames` writes for it (atomically, the
        report last), or skips it when they are current. Returns its report dict with
        `status` ("fitted" / "skipped") and `reason`. IndexError for k >= len()."""

def fit(
    src: _Points,
    dst: _Points,
    size: Optional[Tuple[float, float]] = None,
    weights: Optional[Sequence[float]] = None,
    names: Optional[Sequence[str]] = None,
    loss: str = "squares",
    loss_scale: float = 2.0,
    bend: Union[None, str, float] = None,
    hard: bool = False,
    barrier: bool = True,
    min_det: float = 0.1,
    max_iters: int = 200,
    radius: Optional[int] = None,
    margin: Optional[float] = None,
    max_edge: Optional[float] = None,
    min_angle: float = 15.0,
    deformation: Optional[Deformation] = None,
    far_rings: int = 2,
    order: _Order = "xy",
    progress: Optional[_Progress] = None,
    cancel: Optional[CancelToken] = None,
) -> Deformation:
    """Fits phi with phi(src) ~ dst; the result's `report` holds the fit report. With
    `size`, the mesh is adapted to the landmarks over that frame, with `far_rings`
    far-field rings around it (`trimorph fit --far-rings`); the frame is recorded
    (`Deformation.frame`). `order`: the columns of src and dst, "xy" or "rc" (row, col);
    `size` is (w, h) either way."""

def register(
    fixed: _Image,
    moving: _Image,
    metric: str = "ncc",
    mask_fixed: Optional[_Image] = None,
    mask_moving: Optional[_Image] = None,
    src: Optional[_Points] = None,
    dst: Optional[_Points] = None,
    weights: Optional[Sequence[float]] = None,
    hard: bool = False,
    landmark_weight: float = 0.25,
    init: Optional[Deformation] = None,
    prealign: str = "affine",
    levels: Optional[int] = None,
    spacing: float = 48.0,
    bend: float = 1.0,
    iterations: int = 30,
    samples: int = 32768,
    order: _Order = "xy",
    progress: Optional[_Progress] = None,
    cancel: Optional[CancelToken] = None,
    mesh_levels: Optional[int] = None,
    refine_share: float = 1.0,
) -> Deformation:
    """Registers MOVING to FIXED from the images (`trimorph register`): phi maps MOVING
    pixels to FIXED pixels, exactly C1 and certified fold-free; `report` holds the
    registration report. `mesh_levels`/`refine_share`: the mesh pyramid (`--mesh-levels`,
    `--refine-share`; default 3 levels). Releases the GIL."""

def morph(
    a: _Image,
    b: _Image,
    src: _Points,
    dst: _Points,
    frames: int = 11,
    shape: str = "linear",
    color: str = "linear",
    interp: str = "bilinear",
    align: bool = True,
    background: float = 0.0,
    t0: float = 0.0,
    t1: float = 1.0,
    bend: Union[float, str, None] = None,
    hard: bool = False,
    pin_frame: bool = False,
    mode: str = "constant",
    order: _Order = "xy",
) -> List[_Image]:
    """Frames of the morph from a to b (like `trimorph morph`), in a's frame."""

def read_image(path: _Path) -> _Image:
    """Pages of a PNG / TIFF / JPEG file as numpy (the command line's decoder)."""

def set_max_memory(size: Union[int, str, None] = None) -> None:
    """The process's memory budget (bytes, or "4G"); None restores the default."""

def max_memory() -> int:
    """The process's memory budget in bytes."""

def read_ome_zarr(path: _Path) -> Tuple[npt.NDArray[Any], List[str]]:
    """Level 0 of an OME-Zarr image in the store's axis order, and the axis names."""

_Rect = Tuple[int, int, int, int]

def tile_inputs(
    deformation: Deformation,
    shape: Tuple[int, int],
    tiles: Sequence[_Rect],
    tolerance: float = 0.01,
    resolution: Optional[float] = None,
    mode: str = "constant",
) -> List[Optional[_Rect]]:
    """For each output tile (y0, x0, h, w) of an (H, W) image, the input rectangle its warp
    reads (certified from bounds on the spline), or None when the tile is all background."""

def warp_tile(
    deformation: Deformation,
    window: _Image,
    origin: Tuple[int, int],
    shape: Tuple[int, int],
    tile: _Rect,
    interp: str = "bilinear",
    background: float = 0.0,
    tolerance: float = 0.01,
    mode: str = "constant",
    channel_axis: Optional[int] = None,
) -> _Image:
    """The output tile (y0, x0, h, w) warped from the input window at origin (y, x), 2-D or
    (planes, h, w), or with channel_axis=-1 (h, w, c) / (planes, h, w, c) with 1 to 4
    channels; bit-identical to Deformation.warp on the whole image."""

def _image_axes(
    shape: Sequence[int], channel_axis: Optional[int] = None, stack_axis: Optional[_Axes] = None
) -> Tuple[List[int], Optional[int]]:
    """(stack axes, channel axis) of an array of `shape` as Deformation.warp reads it."""

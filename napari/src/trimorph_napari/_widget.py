"""The trimorph dock widget: fit, register, warp, Jacobian map, mesh, export.

One widget holds the current result (``TrimorphWidget.deformation``) so that every
section works on the same deformation; every layer it makes carries that deformation in
``layer.metadata["trimorph"]`` (``"deformation"``: the deformation file's JSON text,
``trimorph.Deformation.from_json`` reads it back; ``"summary"``: rms, certified det J
bound, fold-free, covers-frame).

Coordinates (details in :mod:`trimorph_napari._core`): Points data are ``(row, col)`` in
the data space of their layer; they are converted through world coordinates to the pixel
``(x, y) = (col, row)`` of the chosen *frame* Image layer, whose size is the fit's
``size = (w, h)``. Layers made from a result get the frame layer's scale and translate.
"moving" points are the fit's sources (the reference), "fixed" points its targets:
``phi(moving) ~ fixed``, and warping the moving image puts it on the fixed one.

Long calls (fit, register, warp, Jacobian, mesh, export) run in a
``napari.qt.threading.thread_worker`` with a progress bar (and napari's activity
progress); trimorph releases the GIL, so the viewer stays responsive.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Dict, List, Optional

import numpy as np
from magicgui.widgets import (
    CheckBox,
    ComboBox,
    Container,
    FileEdit,
    FloatSpinBox,
    Label,
    LineEdit,
    ProgressBar,
    PushButton,
    SpinBox,
)

import napari
import trimorph
from napari.layers import Image, Labels, Points
from napari.qt.threading import thread_worker
from napari.utils.notifications import show_error, show_info, show_warning

from . import _core

JACOBIAN_CMAP = "PiYG"  # diverging: green < 1 (shrink), 1 white, magenta > 1 (grow)


_POOL = None


def _pool():
    """The plugin's own thread pool.

    Not Qt's global pool (where ``worker.start()`` would put the workers): Qt converts
    images on the global pool (``QImage.convertToFormat``, e.g. for napari's activity
    animation) while the GUI thread waits *holding the GIL*; workers that fill the global
    pool (2 threads on 2 cores) and wait for the GIL to return from trimorph deadlock it.
    """
    global _POOL
    if _POOL is None:
        from qtpy.QtCore import QThreadPool

        _POOL = QThreadPool()
        _POOL.setMaxThreadCount(2)
    return _POOL


def _layer_choices(viewer, kinds):
    def choices(_widget=None):
        return [(layer.name, layer) for layer in viewer.layers if isinstance(layer, kinds)]

    return choices


class TrimorphWidget(Container):
    """The plugin's dock widget (see the module docstring)."""

    def __init__(self, viewer: napari.viewer.Viewer):
        super().__init__(labels=True)
        self.viewer = viewer
        #: The current result (from the last fit or registration), or None.
        self.deformation: Optional[trimorph.Deformation] = None
        #: The Image layer whose pixel grid the current result is in.
        self.frame_layer: Optional[Image] = None
        #: The running worker, if any (tests wait on it).
        self.worker = None
        self._workers: List[Any] = []
        self._outputs: Dict[str, Callable[[], bool]] = {}
        self._watched: List[Points] = []
        self._refit_pending = False

        images = _layer_choices(viewer, Image)
        points = _layer_choices(viewer, Points)
        warpable = _layer_choices(viewer, (Image, Labels))

        # 1. Fit from landmarks
        self.frame = ComboBox(label="frame image", choices=images, nullable=True)
        self.frame.tooltip = (
            "Image layer whose pixels are trimorph's: size = (columns, rows); points are "
            "converted to its pixel coordinates through world coordinates"
        )
        self.moving_points = ComboBox(label="moving points (src)", choices=points, nullable=True)
        self.fixed_points = ComboBox(label="fixed points (dst)", choices=points, nullable=True)
        self.bend = LineEdit(label="bend", value="auto")
        self.bend.tooltip = "bending weight: 'auto' (cross-validation) or a number"
        self.hard = CheckBox(text="hard (interpolate exactly)", value=False)
        self.auto_refit = CheckBox(text="re-fit when the points change", value=False)
        self.fit_button = PushButton(text="Fit")

        # 2. Register from the images
        self.fixed_image = ComboBox(label="fixed image", choices=images, nullable=True)
        self.moving_image = ComboBox(label="moving image", choices=images, nullable=True)
        self.metric = ComboBox(label="metric", choices=["ncc", "ssd", "mi"], value="ncc")
        self.use_landmarks = CheckBox(text="add the landmarks (points above)", value=False)
        self.register_button = PushButton(text="Register")

        # 3. Apply the result
        self.warp_layer = ComboBox(label="layer to warp", choices=warpable, nullable=True)
        self.interp = ComboBox(
            label="interpolation", choices=["bilinear", "bicubic", "nearest"], value="bilinear"
        )
        self.mode = ComboBox(
            label="edges", choices=["constant", "edge", "reflect"], value="constant"
        )
        self.background = FloatSpinBox(label="background", value=0.0, min=-1e9, max=1e9)
        self.warp_button = PushButton(text="Warp layer")
        self.jacobian_frame = ComboBox(
            label="Jacobian frame", choices=["deformed", "reference"], value="deformed"
        )
        self.jacobian_button = PushButton(text="Jacobian map")
        self.mesh_samples = SpinBox(label="points per edge", value=8, min=1, max=64)
        self.mesh_button = PushButton(text="Deformed mesh")
        self.update_outputs = CheckBox(text="update these layers on a new result", value=True)

        # 4. Export
        self.export_path = FileEdit(
            label="export to", mode="w", filter="*.h5 *.zarr *.json", value=""
        )
        self.direction = ComboBox(
            label="direction", choices=["resampling", "forward", "both"], value="resampling"
        )
        self.direction.tooltip = (
            "resampling: phi^-1(q) - q (what ITK / NGFF readers resample with); "
            "forward: phi(p) - p; both: NGFF bijection"
        )
        self.export_button = PushButton(text="Export")

        # Status
        self.progress = ProgressBar(label="", value=0, min=0, max=1, visible=False)
        # Cancels the running work (fit, register, warp): its trimorph call stops within a
        # band of rows or an iteration and raises trimorph.Cancelled.
        self.cancel_button = PushButton(text="Cancel", visible=False)
        self._token = trimorph.CancelToken()
        self.result = Label(label="result", value="none yet")
        self.status = Label(label="", value="")
        for lab in (self.result, self.status):
            lab.native.setWordWrap(True)
            lab.native.setMinimumWidth(240)

        self.extend(
            [
                Label(value="<b>Fit from landmarks</b>"),
                self.frame,
                self.moving_points,
                self.fixed_points,
                self.bend,
                self.hard,
                self.auto_refit,
                self.fit_button,
                Label(value="<b>Register images</b>"),
                self.fixed_image,
                self.moving_image,
                self.metric,
                self.use_landmarks,
                self.register_button,
                Label(value="<b>Apply the result</b>"),
                self.warp_layer,
                self.interp,
                self.mode,
                self.background,
                self.warp_button,
                self.jacobian_frame,
                self.jacobian_button,
                self.mesh_samples,
                self.mesh_button,
                self.update_outputs,
                Label(value="<b>Export</b>"),
                self.export_path,
                self.direction,
                self.export_button,
                self.progress,
                self.cancel_button,
                self.result,
                self.status,
            ]
        )

        self.cancel_button.changed.connect(self.cancel)
        self.fit_button.changed.connect(self.fit)
        self.register_button.changed.connect(self.register)
        self.warp_button.changed.connect(lambda: self.warp())
        self.jacobian_button.changed.connect(lambda: self.jacobian())
        self.mesh_button.changed.connect(lambda: self.mesh())
        self.export_button.changed.connect(lambda: self.export())
        self.auto_refit.changed.connect(self._rewire)
        self.moving_points.changed.connect(self._rewire)
        self.fixed_points.changed.connect(self._rewire)

        from qtpy.QtCore import QTimer

        self._refit_timer = QTimer()
        self._refit_timer.setSingleShot(True)
        self._refit_timer.setInterval(400)
        self._refit_timer.timeout.connect(self._auto_fit)

        for ev in ("inserted", "removed", "moved", "reordered"):
            if hasattr(viewer.layers.events, ev):
                getattr(viewer.layers.events, ev).connect(self._layers_changed)
        self._layers_changed()

    # ----------------------------------------------------------------------------------
    # Plumbing

    def _layers_changed(self, event=None):
        try:
            self.reset_choices()
        except RuntimeError:  # the dock widget was closed: its Qt widgets are gone
            self._disconnect_viewer()
            return
        for layer in self.viewer.layers:
            try:
                layer.events.name.disconnect(self._on_rename)
            except (TypeError, ValueError, RuntimeError):
                pass
            layer.events.name.connect(self._on_rename)

    def _on_rename(self, event=None):
        self._layers_changed()

    def _disconnect_viewer(self):
        for ev in ("inserted", "removed", "moved", "reordered"):
            emitter = getattr(self.viewer.layers.events, ev, None)
            if emitter is not None:
                try:
                    emitter.disconnect(self._layers_changed)
                except (TypeError, ValueError, RuntimeError):
                    pass
        for layer in self.viewer.layers:
            try:
                layer.events.name.disconnect(self._on_rename)
            except (TypeError, ValueError, RuntimeError):
                pass
        self.auto_refit.value = False

    @property
    def busy(self) -> bool:
        """Whether a worker is running."""
        return bool(self._workers)

    def cancel(self):
        """Stops the running work: its trimorph call raises ``trimorph.Cancelled``."""
        self._token.cancel()

    def _new_token(self) -> trimorph.CancelToken:
        """A fresh token for the next piece of work (the Cancel button cancels it)."""
        self._token = trimorph.CancelToken()
        return self._token

    def _start(self, gen_or_fn, on_done: Callable[[Any], None], what: str, total: int = 0):
        """Runs ``gen_or_fn`` (a function, or a generator function yielding
        ``(done, total)``) in a thread worker; ``on_done(result)`` runs in the GUI thread."""
        import inspect

        is_gen = inspect.isgeneratorfunction(gen_or_fn)
        # Errors go to the status line and napari's notifications (ignore_errors: not
        # re-raised in the GUI thread on top of that).
        worker = thread_worker(
            gen_or_fn,
            progress={"total": total, "desc": f"trimorph: {what}"},
            ignore_errors=True,
        )()
        self.status.value = f"{what} ..."
        self.progress.visible = True
        self.progress.min = 0
        self.progress.max = total
        self.progress.value = 0
        self.cancel_button.visible = True
        if is_gen:

            def yielded(v):
                done, n = v
                self.progress.max = n
                self.progress.value = done

            worker.yielded.connect(yielded)

        def returned(result):
            try:
                on_done(result)
            except Exception as e:  # noqa: BLE001 - shown to the person
                self._error(e, what)

        def finished():
            if worker in self._workers:
                self._workers.remove(worker)
            if not self._workers:
                self.progress.visible = False
                self.cancel_button.visible = False
                self.progress.max = 1
            if self._refit_pending and not self.busy:
                self._refit_pending = False
                self._refit_timer.start()

        worker.returned.connect(returned)
        worker.errored.connect(lambda e: self._error(e, what))
        worker.finished.connect(finished)
        self._workers.append(worker)  # also keeps the Python object alive while it runs
        self.worker = worker
        _pool().start(worker)
        return worker

    def _error(self, e: BaseException, what: str):
        if isinstance(e, trimorph.Cancelled):
            self.status.value = f"{what} cancelled"
            show_info(self.status.value)
            return
        msg = f"{what} failed: {e}"
        self.status.value = msg
        show_error(msg)

    def _need_result(self) -> bool:
        if self.deformation is None:
            show_warning("trimorph: no result yet: fit or register first")
            return False
        return True

    def _put(self, name: str, data, kind: str, **kwargs):
        """Updates the layer called ``name`` in place, else adds a new one."""
        meta = kwargs.pop("metadata", {})
        if name in self.viewer.layers:
            layer = self.viewer.layers[name]
            if kind != "shapes" and isinstance(
                layer, {"image": Image, "labels": Labels, "points": Points}[kind]
            ):
                layer.data = data
                layer.metadata.update(meta)
                for k in ("scale", "translate", "affine"):
                    if k in kwargs:
                        setattr(layer, k, kwargs[k])
                return layer
            self.viewer.layers.remove(layer)
        add = getattr(self.viewer, f"add_{kind}")
        return add(data, name=name, metadata=meta, **kwargs)

    def _result(self, d: trimorph.Deformation, frame_layer: Image, role: str):
        self.deformation = d
        self.frame_layer = frame_layer
        s = _core.report_summary(d)
        self.result.value = f"{role}: " + _core.format_summary(s).replace(", ", "\n")
        self.status.value = f"{role} done"
        show_info(f"trimorph {role}: {_core.format_summary(s)}")
        if self.update_outputs.value:
            for key, refresh in list(self._outputs.items()):
                if not refresh():
                    del self._outputs[key]  # its source layer is gone

    # ----------------------------------------------------------------------------------
    # 1. Fit

    def _fit_inputs(self):
        frame, mov, fix = self.frame.value, self.moving_points.value, self.fixed_points.value
        if frame is None or mov is None or fix is None:
            raise ValueError("choose a frame image, the moving points and the fixed points")
        src = _core.points_to_pixels(mov, frame)
        dst = _core.points_to_pixels(fix, frame)
        size = _core.frame_size(frame)
        bend: Any = self.bend.value.strip() or "auto"
        if bend != "auto":
            bend = float(bend)
        return frame, mov, fix, src, dst, size, bend

    def fit(self, *_):
        """Fits phi(moving points) ~ fixed points over the frame image (in a worker)."""
        try:
            frame, mov, fix, src, dst, size, bend = self._fit_inputs()
        except Exception as e:  # noqa: BLE001
            self._error(e, "fit")
            return None
        hard = bool(self.hard.value)

        token = self._new_token()

        def work():
            return _core.fit_from_pixels(src, dst, size, bend=bend, hard=hard, cancel=token)

        def done(d):
            meta = _core.metadata(
                d, "fit", moving_points=mov.name, fixed_points=fix.name, frame=frame.name
            )
            mapped = d.map_points(src)
            self._put(
                "phi(moving points)",
                _core.pixels_to_data(mapped, frame),
                "points",
                metadata=meta,
                face_color="yellow",
                size=max(3.0, 0.015 * max(size)),
                **_core.frame_transform_kwargs(frame),
            )
            self._result(d, frame, "fit")

        return self._start(work, done, "fit")

    def _rewire(self, *_):
        for layer in self._watched:
            try:
                layer.events.data.disconnect(self._points_edited)
            except (TypeError, ValueError, RuntimeError):
                pass
        self._watched = []
        if self.auto_refit.value:
            for layer in (self.moving_points.value, self.fixed_points.value):
                if layer is not None and layer not in self._watched:
                    layer.events.data.connect(self._points_edited)
                    self._watched.append(layer)

    def _points_edited(self, event=None):
        action = str(getattr(event, "action", "") or "")
        if action.endswith("ing"):  # adding / changing / removing: wait for the -ed event
            return
        self._refit_timer.start()

    def _auto_fit(self):
        if self.busy:
            self._refit_pending = True
            return
        mov, fix = self.moving_points.value, self.fixed_points.value
        if mov is None or fix is None or len(mov.data) != len(fix.data):
            self.status.value = "points edited: waiting until both layers have as many points"
            return
        self.fit()

    # ----------------------------------------------------------------------------------
    # 2. Register

    def register(self, *_):
        """``trimorph.register(fixed, moving, metric=...)`` on two Image layers (in a worker)."""
        fixed, moving = self.fixed_image.value, self.moving_image.value
        try:
            if fixed is None or moving is None:
                raise ValueError("choose the fixed and the moving image")
            f = _core.image_for_trimorph(fixed.data, fixed.rgb)
            m = _core.image_for_trimorph(moving.data, moving.rgb)
            kwargs: Dict[str, Any] = {"metric": self.metric.value}
            if self.use_landmarks.value:
                mov, fix = self.moving_points.value, self.fixed_points.value
                if mov is None or fix is None:
                    raise ValueError("choose the moving and fixed points to add landmarks")
                # src in MOVING's pixels, dst in FIXED's.
                kwargs["src"] = _core.points_to_pixels(mov, moving)
                kwargs["dst"] = _core.points_to_pixels(fix, fixed)
        except Exception as e:  # noqa: BLE001
            self._error(e, "register")
            return None

        mdata, mrgb = moving.data, bool(moving.rgb)

        token = self._new_token()

        def work():
            d = trimorph.register(f, m, cancel=token, **kwargs)
            return d, _core.warp_image(d, mdata, rgb=mrgb, cancel=token)

        def done(result):
            d, warped = result
            self._put(
                f"{moving.name} registered",
                warped,
                "image",
                metadata=_core.metadata(
                    d, "register", fixed=fixed.name, moving=moving.name, metric=kwargs["metric"]
                ),
                rgb=moving.rgb,
                colormap=None if moving.rgb else moving.colormap.name,
                blending="additive",
                **_core.frame_transform_kwargs(fixed),
            )
            self._result(d, fixed, "register")

        return self._start(work, done, "register")

    # ----------------------------------------------------------------------------------
    # 3. Warp, Jacobian, mesh

    def warp(self, layer=None):
        """Warps an Image or Labels layer with the current result into a new layer
        ``"<name> warped"`` (Labels: nearest, dtype kept)."""
        if not self._need_result():
            return None
        layer = layer if layer is not None else self.warp_layer.value
        if layer is None:
            show_warning("trimorph: choose a layer to warp")
            return None
        d, frame = self.deformation, self.frame_layer
        if frame is not None and layer is not frame and not _core.same_pixel_grid(layer, frame):
            show_warning(
                f"trimorph: {layer.name!r} has another scale/translate than the frame "
                f"{frame.name!r}; it is warped in its own pixel grid"
            )
        is_labels = isinstance(layer, Labels)
        interp, mode, bg = self.interp.value, self.mode.value, float(self.background.value)
        rgb = bool(getattr(layer, "rgb", False))
        data = layer.data

        token = self._new_token()

        def work():
            it = (
                _core.warp_labels_iter(d, data, cancel=token)
                if is_labels
                else _core.warp_image_iter(
                    d, data, rgb=rgb, interp=interp, background=bg, mode=mode, cancel=token
                )
            )
            for done, n, res in it:
                if res is None:
                    yield done, n
                else:
                    return res

        name = f"{layer.name} warped"

        def done(out):
            kw: Dict[str, Any] = {
                "scale": layer.scale,
                "translate": layer.translate,
                "metadata": _core.metadata(
                    d, "warp", source=layer.name, interp="nearest" if is_labels else interp
                ),
            }
            if is_labels:
                self._put(name, out, "labels", **kw)
            else:
                kw.update(
                    rgb=rgb,
                    contrast_limits=layer.contrast_limits,
                    colormap=None if rgb else layer.colormap.name,
                )
                self._put(name, out, "image", **kw)
            self.status.value = f"warped {layer.name!r} -> {name!r}"
            self._outputs[f"warp:{id(layer)}"] = lambda: (
                layer in self.viewer.layers
                and name in self.viewer.layers
                and bool(self.warp(layer))
            )

        lead = data.shape[: data.ndim - (3 if rgb else 2)]
        total = int(np.prod(lead, dtype=np.int64)) if lead else 1
        return self._start(work, done, f"warp {layer.name}", total=total)

    def jacobian(self, frame: Optional[str] = None):
        """Adds the sampled det J map (layer ``"det J"``) with a diverging colour map
        centred on 1 and a colour bar where napari has one."""
        if not self._need_result():
            return None
        d, flayer = self.deformation, self.frame_layer
        which = frame or self.jacobian_frame.value
        size = _core.frame_size(flayer)

        def work():
            return _core.jacobian_map(d, size, frame=which)

        def done(j):
            finite = j[np.isfinite(j)]
            spread = float(np.max(np.abs(finite - 1.0))) if finite.size else 0.0
            spread = max(spread, 0.05)
            layer = self._put(
                "det J",
                j,
                "image",
                colormap=JACOBIAN_CMAP,
                contrast_limits=(1.0 - spread, 1.0 + spread),
                opacity=0.6,
                metadata=_core.metadata(
                    d,
                    "jacobian",
                    frame=which,
                    sampled_min=float(finite.min()) if finite.size else None,
                    sampled_max=float(finite.max()) if finite.size else None,
                ),
                **_core.frame_transform_kwargs(flayer),
            )
            if getattr(layer, "colorbar", None) is not None:
                try:
                    layer.colorbar.visible = True
                except Exception:  # noqa: BLE001 - older napari: no colour bar
                    pass
            lo, hi = (
                layer.metadata[_core.METADATA_KEY]["sampled_min"],
                layer.metadata[_core.METADATA_KEY]["sampled_max"],
            )
            self.status.value = (
                f"det J ({which} frame, sampled): {lo:.3f} .. {hi:.3f}"
                if lo is not None
                else "det J: undefined everywhere"
            )
            self._outputs["jacobian"] = lambda: (
                "det J" in self.viewer.layers and bool(self.jacobian(which))
            )

        return self._start(work, done, "Jacobian map")

    def mesh(self, samples: Optional[int] = None):
        """Adds the deformed triangle edges as paths of a Shapes layer ``"deformed mesh"``."""
        if not self._need_result():
            return None
        d, flayer = self.deformation, self.frame_layer
        k = int(samples or self.mesh_samples.value)
        size = _core.frame_size(flayer)

        def work():
            return _core.mesh_paths(d, samples=k, size=size)

        def done(paths):
            name = "deformed mesh"
            if name in self.viewer.layers:
                self.viewer.layers.remove(name)
            self.viewer.add_shapes(
                paths,
                shape_type="path",
                name=name,
                edge_color="cyan",
                edge_width=max(0.5, 0.002 * max(size)),
                metadata=_core.metadata(d, "mesh", samples_per_edge=k),
                **_core.frame_transform_kwargs(flayer),
            )
            self.status.value = f"deformed mesh: {len(paths)} edges"
            self._outputs["mesh"] = lambda: name in self.viewer.layers and bool(self.mesh(k))

        return self._start(work, done, "mesh")

    # ----------------------------------------------------------------------------------
    # 4. Export

    def export(self, path=None, direction: Optional[str] = None):
        """Writes the result: ``.h5`` ITK transform, ``.zarr`` NGFF store, ``.json`` file."""
        if not self._need_result():
            return None
        p = Path(path if path is not None else self.export_path.value)
        if str(p) in ("", "."):
            show_warning("trimorph: choose a file to export to (.h5, .zarr or .json)")
            return None
        d = self.deformation
        size = _core.frame_size(self.frame_layer) if self.frame_layer is not None else None
        placed = _core.placement(self.frame_layer) if self.frame_layer is not None else {}
        direction = direction or self.direction.value

        def work():
            return _core.export(d, p, direction=direction, size=size, **placed)

        def done(r):
            extra = f" ({r.undefined} undefined grid points)" if r.undefined else ""
            self.status.value = f"exported {r.kind} to {r.path}{extra}"
            show_info(self.status.value)

        return self._start(work, done, "export")


def make_widget(viewer: napari.viewer.Viewer) -> TrimorphWidget:
    """The widget for a viewer (the npe2 command names the class itself, whose
    ``viewer: napari.viewer.Viewer`` parameter napari fills in)."""
    return TrimorphWidget(viewer)

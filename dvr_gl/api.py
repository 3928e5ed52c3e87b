"""The Python API: :func:`render` takes data (an array, a field, a file, or a scene) and keywords, and
returns an :class:`Image` that shows itself in Jupyter, gives its pixels and saves.

    >>> import numpy as np, dvr_gl
    >>> image = dvr_gl.render(np.random.rand(32, 32, 32).astype(np.float32), size=64)
    >>> image.rgba.shape
    (64, 64, 4)

Keywords (each optional): ``spacing`` and ``origin`` (world units, x first, as in scene files) for
arrays; ``transfer_function`` (a preset name, control points ``[[value, r, g, b, opacity], ...]``, or a
:class:`~dvr_gl.transfer_function.TransferFunction`) and ``rescale_intercept`` for the CT presets
(HU = data + intercept); the camera (a :class:`~dvr_gl.camera.Camera`, or
``azimuth``, ``elevation``, ``distance``, ``projection``, ``fov``, ``up``); ``renderer`` (a registered
renderer's name) and any renderer setting by its scene-file name (``sample_distance_voxels=0.25``,
``compositing="mip"``, ``shading=True``); ``size`` (pixels: ``n`` or ``(width, height)``) and
``background`` (linear RGB or RGBA).  What is not given is resolved as a scene file would be: the
camera frames the data, a transfer function spans its values.

``progress``: ``True`` for a progress bar (tqdm; a widget in Jupyter) on long work (decompressing a
file, the ``tolerance`` search, a CPU reference's frame), shown after a second; or a callable
``callback(done, total)`` told each step (see :mod:`dvr_gl.progress`); default: silent.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import tempfile
from pathlib import Path

import numpy as np

from . import progress as _progress
from .camera import Camera
from .errors import SceneError
from .fields import Field
from .fields.grid import Volume
from .image import composite_over, encode_8bit, write_image
from .labels import as_label_table
from .orientation import view_orbit
from .renderers import create_renderer, registry
from .sandbox import Sandbox, active
from .scene.resolve import Scene, apply_overrides, default_unit_distance, load_scene, parse_scene, resolve_scene
from .scene.schema import ImageSpec, parse_table, spec_to_dict
from .transfer_function import TransferFunction, preset

_CAMERA_KEYS = ("azimuth", "elevation", "distance", "projection", "fov", "up", "view")


class Image:
    """A rendered image.

    rgba: premultiplied, linear, float32 ``(H, W, 4)``, row 0 at the top, background not applied (what
        renderers return).
    scene: the effective scene it was rendered from (``scene.to_toml()`` repeats it, for file data).
    stats: what the renderer reported (``seconds``, ``samples``, ...).
    depth: with ``render(..., depth=True)``, ``(H, W)`` float32: the distance along the view axis from the
        eye's plane (world units) where the ray's opacity crosses one half (MIP/MinIP: the extremum's sample;
        isosurface: the hit), ``inf`` where it never does (docs/picking.md); else None.
    """

    def __init__(self, rgba: np.ndarray, scene: Scene, stats: dict | None = None, depth: np.ndarray | None = None):
        self.rgba = rgba
        self.scene = scene
        self.stats = dict(stats or {})
        self.depth = depth

    @property
    def background(self) -> tuple:
        return tuple(self.scene.image.background)

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.rgba.shape

    def composited(self) -> np.ndarray:
        """Linear float32 RGBA over the scene's background (what EXR and TIFF files hold)."""
        return composite_over(self.rgba, self.background)

    def srgb8(self) -> np.ndarray:
        """8-bit sRGB ``(H, W, 4)`` uint8 over the background: what a PNG file holds and a screen shows."""
        return encode_8bit(self.composited())

    def annotated(self, colorbar: bool = False, scalebar: bool = False, axes: bool = False,
                  caption: str | None = None, length_unit: str | None = None,
                  value_unit: str | None = None) -> np.ndarray:
        """:meth:`srgb8` with annotations drawn over it (:mod:`dvr_gl.annotations`): the transfer function's
        colour bar in the data's units, a scale bar in world units, the orientation axes (anatomical letters
        where the file states an orientation), a caption.  8-bit only: :attr:`rgba` is never touched;
        ``save(path, annotations=...)`` writes it to .png or .jpg."""
        from .annotations import Annotations, annotate

        spec = Annotations(colorbar, scalebar, axes, caption, length_unit, value_unit)
        return annotate(self.srgb8(), self.scene, spec)

    def save(self, path, overwrite: bool = False, annotations=None) -> Path:
        """Write ``.png``/``.jpg`` (8-bit sRGB) or ``.exr``/``.tif`` (linear float), never replacing a
        file unless ``overwrite``; ``annotations``: a dict of :meth:`annotated`'s keywords (8-bit formats
        only)."""
        if annotations is not None and not isinstance(annotations, dict):
            raise SceneError(f"annotations: give a dict of annotated()'s keywords, got {annotations!r:.80}")
        write_image(path, self.annotated(**annotations) if annotations else self.composited(), overwrite)
        return Path(path)

    def _repr_png_(self) -> bytes:
        """Jupyter shows the image inline (the PNG :meth:`save` would write)."""
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "image.png"
            write_image(path, self.composited())
            return path.read_bytes()

    def __array__(self, dtype=None, copy=None):
        return self.rgba if dtype is None else self.rgba.astype(dtype)

    def __repr__(self) -> str:
        h, w, _ = self.rgba.shape
        seconds = self.stats.get("seconds")
        took = f", {1e3 * seconds:.0f} ms" if seconds is not None else ""
        return f"Image({w}x{h}, {self.scene.renderer.name}{took})"


def render(data, *, spacing=None, origin=None, transfer_function=None, rescale_intercept=None,
           camera: Camera | None = None, renderer: str | None = None, size=None, background=None, ctx=None,
           sandbox: Sandbox | None = None, progress=None, dask=None, compositing_method: str = "direct_send",
           depth: bool = False, **keywords) -> Image:
    """Render ``data`` (see the module doc): a numpy array indexed ``[z, y, x]``, a field
    (:mod:`dvr_gl.fields`), a path (a ``.toml`` scene file or a volume file), or a :class:`Scene`.
    ``ctx``: a moderngl context for GL renderers (default: a new headless one, released after).
    ``sandbox``: limits for scenes one did not write (:class:`dvr_gl.sandbox.Sandbox`: folders files may
    be read from, memory, time), for loading and rendering both.
    ``progress``: ``True`` (a bar), a callable ``callback(done, total)``, or ``None`` (as the caller's
    :func:`dvr_gl.progress.reporting` block says; silent outside one).
    ``dask``: render on Dask workers (the extra ``dask``; a renderer that composites sort-last, as the
    ray caster does: ``RendererPlugin.sort_last``): ``"local:N"`` (a local
    cluster of N processes, closed after), a scheduler's address, or a ``distributed.Client``; the
    bricks are composited sort-last by ``compositing_method`` (``"direct_send"`` or ``"binary_swap"``,
    which needs a power-of-two number of workers); see docs/distributed.md.
    ``depth``: also draw the depth image (:attr:`Image.depth`; renderers that declare
    ``RendererPlugin.depth_output``: the ray caster and the reference)."""
    with (active(sandbox) if sandbox is not None else contextlib.nullcontext(),
          _progress.reporting(progress) if progress is not None else contextlib.nullcontext()):
        return _render(data, spacing=spacing, origin=origin, transfer_function=transfer_function,
                       rescale_intercept=rescale_intercept, camera=camera, renderer=renderer, size=size,
                       background=background, ctx=ctx, dask=dask, compositing_method=compositing_method,
                       depth=depth, **keywords)


def _render(data, *, ctx=None, dask=None, compositing_method="direct_send", depth=False, **keywords) -> Image:
    scene = scene_of(data, **keywords)
    registry.check(scene)
    if depth:
        problem = registry.depth_refusal(scene) or (dask is not None and "depth images are drawn on one "
                                                    "machine, not on Dask workers: leave out dask=")
        if problem:
            raise SceneError(problem)
    if dask is not None:
        from .distributed.session import check_request, render_image

        check_request(scene, compositing_method)
        with create_renderer(scene.renderer.name, ctx=ctx) as r:
            rgba, stats = render_image(scene, dask, compositing_method, r)
        return Image(rgba, scene, stats)
    with create_renderer(scene.renderer.name, ctx=ctx) as r, _progress.task("rendering") as step:
        r.progress = step  # the CPU references' steps
        r.want_depth = depth
        rgba = r.render(scene)
        return Image(rgba, scene, r.stats, r.depth if depth else None)


def scene_of(data, *, spacing=None, origin=None, transfer_function=None, rescale_intercept=None,
             camera: Camera | None = None, renderer: str | None = None, size=None, background=None,
             channel_axis: int | None = None, time_axis: int | None = None, time: int | None = None,
             **keywords) -> Scene:
    """The :class:`Scene` :func:`render` would render (same arguments, no rendering)."""
    if isinstance(data, (str, os.PathLike)) and (channel_axis is not None or time_axis is not None):
        raise SceneError("channel_axis and time_axis apply to arrays; a file's header says its axes (pick with "
                         "volume.channel and time=)")
    if isinstance(data, (str, os.PathLike)) and time is not None:
        keywords_time = {"volume.time": int(time)}
    else:
        keywords_time = {}
        data = _time_step(data, time_axis, time)
    if channel_axis is not None or isinstance(data, (list, tuple)):
        data = _several(data, channel_axis, spacing, origin)
        spacing = origin = None
    if isinstance(transfer_function, (list, tuple)) and transfer_function and not _is_points(transfer_function):
        return _with_transfer_functions(data, transfer_function, rescale_intercept, camera=camera, renderer=renderer,
                                        size=size, background=background, **keywords)
    camera_keys = {k: keywords.pop(k) for k in _CAMERA_KEYS if k in keywords}
    settings = _renderer_settings(renderer, keywords)
    if isinstance(data, Scene):
        if spacing is not None or origin is not None:
            raise SceneError("spacing and origin apply to arrays; this is a scene (replace its field instead)")
        return _changed(data, transfer_function, camera, camera_keys, settings, size, background,
                        rescale_intercept or 0.0)
    overrides = {f"camera.{k}": (list(v) if k == "up" else v) for k, v in camera_keys.items()}
    overrides.update(keywords_time)
    overrides.update({f"renderer.{k}": v for k, v in settings.items()})
    overrides.update(_image_overrides(size, background))
    tf = None
    if isinstance(transfer_function, TransferFunction):
        tf = transfer_function
    elif isinstance(transfer_function, str):
        overrides["transfer_function.preset"] = transfer_function
        if rescale_intercept is not None:
            overrides["transfer_function.rescale_intercept"] = _number(rescale_intercept, "rescale_intercept")
    elif transfer_function is not None:
        overrides["transfer_function.points"] = _points(transfer_function).tolist()
    if isinstance(data, (str, os.PathLike)):
        path = Path(data)
        if path.suffix.lower() == ".toml":
            if spacing is not None or origin is not None:
                raise SceneError("spacing and origin of a scene file's volume: set volume.spacing in the file")
            scene = load_scene(path, overrides)
        else:
            if spacing is not None:
                overrides["volume.spacing"] = list(spacing)
            if origin is not None:
                overrides["volume.origin"] = list(origin)
            scene = load_scene(None, {"volume.path": str(path), **overrides})
        if tf is not None or camera is not None:
            scene = _changed(scene, tf, camera, {}, {}, None, None)
        return scene
    field = _field_of(data, spacing, origin)
    spec = parse_scene(apply_overrides({}, overrides), "render()")
    return resolve_scene(spec, field=field, camera=camera, transfer_function=tf)


def _or(value, default):
    """``value``, or ``default`` where it is None (an array has no truth value: ``or`` raised on one)."""
    return default if value is None else value


def _number(value, name: str) -> float:
    """``value`` as a float, or one line naming the argument."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{name} must be a number, got {value!r}") from None


def _points(tf) -> np.ndarray:
    """A transfer function's control points as float64 rows, or one line saying what they must be."""
    try:
        return np.asarray(tf, dtype=np.float64)
    except (TypeError, ValueError):
        raise SceneError(f"transfer_function: give control points as rows of numbers (value, r, g, b, opacity), "
                         f"a preset's name or a TransferFunction, got {tf!r:.80}") from None


def _is_points(tf) -> bool:
    """Whether a list is one transfer function's control points (rows of numbers), not one per field."""
    try:
        a = np.asarray(tf, dtype=np.float64)
    except (TypeError, ValueError):
        return False
    return a.ndim == 2


def _time_step(data, time_axis, time):
    """Step ``time`` of an array with a ``time_axis`` (exactly ``np.take(data, time, time_axis)``: what
    rendering that 3D array alone gives); the data itself without one."""
    if time_axis is None:
        if time is not None:
            raise SceneError("time: give time_axis too (the array's axis of time steps)")
        return data
    from .fields.series import from_array

    return from_array(np.asarray(data), time_axis).step(0 if time is None else time)


def _several(data, channel_axis, spacing, origin):
    """Several fields: the channels of one array along ``channel_axis`` (one grid), or a list of arrays,
    volumes and :class:`~dvr_gl.fields.layers.Member` s (each its own grid: ``spacing``/``origin`` one triple
    for all arrays or one per array)."""
    from .fields.layers import FieldSet, Member, as_data

    if channel_axis is not None:
        if isinstance(data, (list, tuple)):
            raise SceneError("channel_axis applies to one array; a list is several fields already")
        array = np.asarray(data)
        if array.ndim != 4 or not -4 <= channel_axis < 4:
            raise SceneError(f"channel_axis = {channel_axis}: expected a 4D array (three axes z, y, x and one of "
                             f"channels), got shape {array.shape}")
        items = [np.take(array, k, axis=channel_axis % 4) for k in range(array.shape[channel_axis])]
        names = [f"channel {k}" for k in range(len(items))]
        spacings, origins = [spacing] * len(items), [origin] * len(items)
    else:
        items, names = list(data), [f"field {k}" for k in range(len(data))]
        per = lambda v: list(v) if v is not None and np.ndim(v) == 2 else [v] * len(items)  # noqa: E731
        spacings, origins = per(spacing), per(origin)
        if len(spacings) != len(items) or len(origins) != len(items):
            raise SceneError(f"spacing/origin: give one triple, or one per field ({len(items)})")
    if not items:
        raise SceneError("data: an empty list; give one or more arrays or volumes")
    members = []
    for item, name, sp, og in zip(items, names, spacings, origins):
        if isinstance(item, Member):
            members.append(item)
        elif isinstance(item, FieldSet):
            members += item.members
        else:
            field = _field_of(item, sp, og)
            if isinstance(field, FieldSet):  # a colour volume: its one rgb member
                members += field.members
                continue
            members.append(Member(field, "scalar", field.name if field.name not in ("array", "volume") else name))
    return as_data(members)


def _with_transfer_functions(data, tfs, rescale_intercept, **keywords) -> Scene:
    """The scene of several fields with one transfer function each (a preset's name, control points or a
    transfer function; a label map's: a LabelTable, rows or a colour table file; None: the field's default)."""
    scene = scene_of(data, **keywords)
    layers = scene.layers
    if len(tfs) != len(layers):
        raise SceneError(f"transfer_function: {len(tfs)} given for {len(layers)} field{'s' * (len(layers) != 1)}; "
                         f"give one per field (channel), None for a field's default")
    out = []
    for tf, layer in zip(tfs, layers):
        if layer.role == "label" and tf is not None:  # a categorical table, never control points
            out.append(as_label_table(tf, layer.name))
        elif tf is None or not isinstance(tf, (str, list, tuple, np.ndarray)):
            out.append(layer.transfer_function if tf is None else tf)
        elif isinstance(tf, str):
            out.append(preset(tf, layer.field.value_range, rescale_intercept or 0.0))
        else:
            out.append(TransferFunction(_points(tf)))
    return dataclasses.replace(scene, transfer_function=out[0], transfer_functions=tuple(out) if len(out) > 1 else ())


def _field_of(data, spacing, origin):
    from .fields.layers import Member, as_data
    from .io.labelled import is_data_array

    if is_data_array(data):  # its dims name the axes and its coordinates give the geometry (Volume does it)
        return Volume(data, spacing=_or(spacing, (1.0, 1.0, 1.0)), origin=_or(origin, (0.0, 0.0, 0.0)))
    if isinstance(data, np.ndarray) or (hasattr(data, "__array__") and not isinstance(data, Field)):
        array = np.asarray(data)
        if array.ndim != 3:
            raise SceneError(f"data: expected a 3D array indexed [z, y, x], got shape {array.shape}")
        return Volume(array, spacing=_or(spacing, (1.0, 1.0, 1.0)), origin=_or(origin, (0.0, 0.0, 0.0)), name="array")
    if isinstance(data, Field) or getattr(data, "kind", None) == "fields" or isinstance(data, Member):
        if spacing is not None or origin is not None:
            raise SceneError("spacing and origin apply to arrays; a field has its own")
        if isinstance(data, Member) or getattr(data, "role", "scalar") != "scalar":  # one member: rgb, label
            return as_data([data if isinstance(data, Member) else Member(data, data.role, data.name)])
        return data
    raise SceneError(f"data: expected a numpy array [z, y, x], a field, a file path or a Scene, "
                     f"got {type(data).__name__}")


def _renderer_settings(renderer: str | None, keywords: dict) -> dict:
    """Renderer keywords as ``[renderer]`` keys (``shading=True`` enables shading; ``scattering=True``
    enables single scattering with its default light, or takes a dict of ``[renderer.scattering]`` keys,
    and turns shading off unless ``shading`` is given); unknown keywords are an error listing the
    valid ones."""
    valid = {s.name for s in registry.all_settings()}
    unknown = sorted(set(keywords) - valid)
    if unknown:
        raise SceneError(f"unknown keyword {', '.join(map(repr, unknown))}; renderer settings are "
                         f"{', '.join(sorted(valid))}, and the camera takes {', '.join(_CAMERA_KEYS)}")
    out = dict(keywords)
    if isinstance(out.get("shading"), bool):
        out["shading.enabled"] = out.pop("shading")
    scattering = out.get("scattering")
    if isinstance(scattering, (bool, dict)):
        table = {"enabled": scattering} if isinstance(scattering, bool) else {"enabled": True, **scattering}
        out.pop("scattering")
        out.update({f"scattering.{k}": v for k, v in table.items()})
        if table["enabled"] and "shading.enabled" not in out:
            out["shading.enabled"] = False  # scattering lights the samples instead
    if renderer is not None:
        out["name"] = renderer
    return out


def _image_overrides(size, background) -> dict:
    out = {}
    if size is not None:
        if not (np.isscalar(size) or (isinstance(size, (tuple, list)) and len(size) == 2)):
            raise SceneError(f"size: give pixels as n or (width, height), got {size!r}")
        width, height = (size, size) if np.isscalar(size) else size
        # numpy integers as ints; anything else as given, for parsing to accept or refuse (1.5 is no size)
        out["image.width"], out["image.height"] = (int(n) if isinstance(n, np.integer) else n for n in (width, height))
    if background is not None:
        if isinstance(background, str) or len(np.shape(background)) != 1 or len(background) not in (3, 4):
            raise SceneError(f"background: give linear RGB or RGBA numbers in [0, 1], got {background!r}")
        bg = [c.item() if isinstance(c, np.generic) else c for c in background]  # parsing checks the values
        out["image.background"] = bg + [1.0] * (4 - len(bg))
    return out


def _changed(scene: Scene, transfer_function, camera, camera_keys: dict, settings: dict, size, background,
             rescale_intercept: float = 0.0) -> Scene:
    """A scene with the keywords applied (renderer settings checked as a scene file's would be)."""
    image = _image_overrides(size, background)
    if image:
        changes = {k.removeprefix("image."): v for k, v in image.items()}
        scene = scene.replace(image=parse_table(ImageSpec, {**spec_to_dict(scene.image), **changes}, "image"))
    if transfer_function is not None:
        # the scene's unit distance (given, or one voxel of its data: docs/conventions.md)
        unit = getattr(scene.transfer_function, "unit_distance", None) or default_unit_distance(scene.field)
        tf = transfer_function if isinstance(transfer_function, TransferFunction) else (
            preset(transfer_function, scene.field.value_range, rescale_intercept, unit)
            if isinstance(transfer_function, str)
            else TransferFunction(_points(transfer_function), unit))
        scene = scene.replace(transfer_function=tf)
    if camera is not None:
        scene = scene.replace(camera=camera)
    if camera_keys:
        cam = scene.camera
        if camera_keys.get("view") is not None:
            view = camera_keys.pop("view")
            camera_keys["azimuth"], camera_keys["elevation"] = view_orbit(
                view, camera_keys.get("azimuth"), camera_keys.get("elevation"))
        if "projection" in camera_keys or "fov" in camera_keys or "up" in camera_keys:
            cam = cam.with_(**{k: (tuple(v) if k == "up" else v) for k, v in camera_keys.items()
                               if k in ("projection", "fov", "up")})
        cam = cam.orbited(camera_keys.get("azimuth"), camera_keys.get("elevation"), camera_keys.get("distance"))
        scene = scene.replace(camera=cam)
    if settings:
        nested = apply_overrides({}, {f"renderer.{k}": v for k, v in settings.items()})["renderer"]
        if "shading" in nested:
            nested["shading"] = dataclasses.replace(scene.renderer.shading, **nested["shading"])
        scene = scene.with_renderer(**nested)
    return scene

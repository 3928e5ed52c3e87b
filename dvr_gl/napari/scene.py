"""napari's 3D view as a dvr-gl scene: :func:`view_scene` and :func:`render_view` (docs/napari.md).

Reads only attributes of napari's viewer and layers (no import of napari), so the mapping is the same
whether napari or a test built them.  The conventions, napari's first:

* **Axes.** napari's world and data axes are in array order (z, y, x), as dvr-gl's arrays are indexed;
  dvr-gl's world vectors are (x, y, z), so every napari vector and matrix is read reversed.
* **Geometry.** A layer's data-to-world map (its ``scale``, ``translate``, ``rotate``, ``shear`` and
  ``affine`` together, read through ``layer.data_to_world``) must be a rotation times a positive diagonal
  scale plus an offset: its column norms are dvr-gl's ``spacing``, the unit columns its ``direction`` and
  the image of index 0 its ``origin``.  A shear is refused in one line.
* **Camera.** napari's ``view_direction`` and ``up_direction`` (world, displayed axes), its ``center`` (the
  target), ``perspective`` (the vertical field of view in degrees; 0: orthographic) and ``zoom`` (screen
  pixels per world unit): the view is ``canvas height / zoom`` world units high at the centre, in both
  projections (vispy's rule), so an orthographic camera gets that ``view_height`` and a perspective one
  the eye distance at which the centre plane is that high.  napari's default axis orientation (depth
  towards, vertical down, horizontal right) is right-handed in (z, y, x), so mirrored in (x, y, z): the
  picture's columns are flipped back where ``camera.handedness`` is ``right``.
* **Classification.** An image layer's colour at value ``v`` is its colormap at
  ``t = clip((v - lo) / (hi - lo), 0, 1) ** gamma`` (``lo, hi`` its contrast limits), decoded from sRGB to
  linear; its alpha ``opacity * colormap alpha * t``, per ``depth`` voxels (:data:`DEPTH_VOXELS`): the
  brightest value reaches the layer's opacity through that many voxels.  A labels layer is a label member
  whose table lists every label present but 0 in its napari colour, alpha ``opacity * colour alpha`` per
  voxel.
"""

from __future__ import annotations

import numpy as np

from ..api import Image, render, scene_of
from ..apps.animation import Animation, Frames
from ..camera import MIN_FOV, Camera
from ..errors import SceneError
from ..fields.grid import Volume
from ..fields.layers import Member, as_data
from ..labels import LabelTable, labels_present
from ..presets.colour import srgb_to_linear
from ..renderers import create_renderer
from ..transfer_function import TransferFunction

#: Voxels through which an image layer's brightest value reaches the layer's opacity (the unit distance of its
#: transfer function, in voxels of that layer).
DEPTH_VOXELS = 10.0
#: Samples of a colormap between the contrast limits (its transfer function's control points): napari's
#: colormaps are at most a few dozen linear segments, and a gamma curve is within 0.3 % of its chords at 64.
COLORMAP_SAMPLES = 64
#: napari's projecting renderings and dvr-gl's compositing of the same name (``projection`` of :func:`view_scene`).
PROJECTIONS = {"mip": "mip", "minip": "minip", "average": "average"}
#: napari's renderings dvr-gl has no mode for: the mode drawn instead, and what differs (``projection``).
APPROXIMATIONS = {
    "attenuated_mip": ("mip", "napari's attenuated_mip is drawn as mip: dvr-gl has no attenuation along the ray "
                              "(the layer's attenuation {attenuation:g} is not applied)"),
    "additive": ("average", "napari's additive is drawn as average: dvr-gl has no additive compositing (the mean "
                            "along each ray, not its sum)"),
}
#: How far from orthonormal a layer's axes may be (after dividing by the scale) before it is called a shear.
SHEAR_TOLERANCE = 1e-6


def _kind(layer) -> str:
    return type(layer).__name__.lower()


def rendered_layers(viewer, selected: bool = False) -> list:
    """The layers to render, in napari's order (bottom first): the visible image and labels layers (what the
    canvas shows), or with ``selected`` those of them that are selected (all of them when none is).  RGB image
    layers are left out: dvr-gl does not render them here, and the widget's own pictures are such layers."""
    usable = [la for la in viewer.layers if la.visible and _kind(la) in ("image", "labels")
              and not getattr(la, "rgb", False)]
    chosen = [la for la in usable if la in viewer.layers.selection] if selected else []
    return chosen or usable


def _current_volume(layer, viewer) -> tuple[np.ndarray, list[int]]:
    """The layer's 3D array at napari's current position, axes in the order of the displayed world axes, and
    those data axes."""
    if getattr(layer, "multiscale", False):
        raise SceneError(f"{layer.name}: a multiscale layer; render one of its levels as a layer of its own")
    world_ndim = len(viewer.dims.point)
    offset = world_ndim - layer.ndim
    axes = [d - offset for d in viewer.dims.displayed]
    if len(axes) != 3 or min(axes) < 0:
        raise SceneError(f"{layer.name}: needs three displayed axes of its own; switch napari to 3D "
                         f"(viewer.dims.ndisplay = 3) with a 3D layer")
    position = np.asarray(layer.world_to_data(viewer.dims.point), dtype=np.float64)
    data = np.asarray(layer.data) if layer.ndim == 3 else layer.data
    index = tuple(slice(None) if a in axes else int(np.clip(np.round(position[a]), 0, layer.data.shape[a] - 1))
                  for a in range(layer.ndim))
    data = np.asarray(data[index])
    kept = [a for a in range(layer.ndim) if a in axes]  # the order the sliced array keeps
    return np.transpose(data, [kept.index(a) for a in axes]), axes


def _geometry(layer, axes) -> tuple[tuple, tuple, np.ndarray]:
    """``(spacing, origin, direction)`` in (x, y, z) of the layer's data-to-world map on its displayed ``axes``
    (the layer's world has its own number of axes, the viewer's last ones: the same indices as its data's)."""
    def world(point):
        return np.asarray(layer.data_to_world(point), dtype=np.float64)[list(axes)]

    zero = np.zeros(layer.ndim)
    o = world(zero)
    columns = []
    for a in axes:
        e = zero.copy()
        e[a] = 1.0
        columns.append(world(e) - o)
    m = np.array(columns).T[::-1, ::-1]  # rows: world x, y, z; columns: the index axes x, y, z
    spacing = np.linalg.norm(m, axis=0)
    if spacing.min() <= 0:
        raise SceneError(f"{layer.name}: a zero scale; give every displayed axis a positive scale")
    direction = m / spacing
    if np.abs(direction.T @ direction - np.eye(3)).max() > SHEAR_TOLERANCE:
        raise SceneError(f"{layer.name}: its transform shears the axes (shear or a non-rigid affine); dvr-gl "
                         f"renders grids whose axes are orthogonal: remove the shear")
    return tuple(spacing), tuple(o[::-1]), direction


def _colormap_rgba(colormap, t: np.ndarray) -> np.ndarray:
    """napari colormap colours ``(N, 4)`` (sRGB, alpha) at positions ``t`` in [0, 1]."""
    return np.asarray(colormap.map(np.asarray(t, dtype=np.float64)), dtype=np.float64).reshape(len(t), 4)


def image_transfer_function(layer, voxel: float, depth: float = DEPTH_VOXELS, ramp: bool = True) -> TransferFunction:
    """An image layer's colormap, contrast limits, gamma and opacity as a transfer function (module doc);
    ``voxel``: the layer's smallest spacing (world units).  ``ramp=False``: alpha ``opacity * colormap alpha``
    at every value (a projection's: the projected value classified once, as napari colours its MIP)."""
    lo, hi = (float(c) for c in layer.contrast_limits)
    if not hi > lo:
        hi = lo + max(abs(lo), 1.0) * 1e-6
    s = np.linspace(0.0, 1.0, COLORMAP_SAMPLES)
    t = s ** float(layer.gamma)
    rgba = _colormap_rgba(layer.colormap, t)
    colour = np.clip(srgb_to_linear(np.clip(rgba[:, :3], 0.0, 1.0)), 0.0, 1.0)
    alpha = np.clip(float(layer.opacity) * rgba[:, 3] * (t if ramp else 1.0), 0.0, 1.0)
    points = np.column_stack([lo + s * (hi - lo), colour, alpha])
    return TransferFunction(points, unit_distance=depth * voxel)


def label_table(layer, data: np.ndarray, voxel: float) -> LabelTable:
    """A labels layer's colours (sRGB decoded) and opacity per voxel, every label present but 0."""
    labels = labels_present(data)
    labels = labels[labels != 0]
    if not len(labels):
        return LabelTable(np.zeros(0), np.zeros((0, 3)), np.zeros(0), unit_distance=voxel)
    rgba = np.asarray(layer.colormap.map(labels), dtype=np.float64).reshape(len(labels), 4)
    colour = np.clip(srgb_to_linear(np.clip(rgba[:, :3], 0.0, 1.0)), 0.0, 1.0)
    return LabelTable(labels, colour, np.clip(float(layer.opacity) * rgba[:, 3], 0.0, 1.0), unit_distance=voxel)


def _label_voxels(data: np.ndarray, name: str) -> np.ndarray:
    """Label voxels in a type dvr-gl takes (uint8, uint16, int16, or float32 holding whole numbers)."""
    if data.dtype in (np.uint8, np.uint16, np.int16):
        return data
    lo, hi = (int(data.min()), int(data.max())) if data.size else (0, 0)
    for dtype in (np.uint8, np.uint16, np.int16):
        info = np.iinfo(dtype)
        if info.min <= lo and hi <= info.max:
            return data.astype(dtype)
    if max(abs(lo), abs(hi)) > 2 ** 24:
        raise SceneError(f"{name}: labels beyond +-2^24 (float32's whole numbers); relabel them consecutively")
    return data.astype(np.float32)


def layer_members(viewer, depth: float = DEPTH_VOXELS, selected: bool = False) -> tuple[list, list]:
    """The rendered layers (:func:`rendered_layers`) as dvr-gl members and their transfer functions (label
    tables for labels)."""
    layers = rendered_layers(viewer, selected)
    if not layers:
        raise SceneError("no visible image or labels layer to render; add one or make one visible")
    members, tfs = [], []
    for layer in layers:
        data, axes = _current_volume(layer, viewer)
        spacing, origin, direction = _geometry(layer, axes)
        voxel = min(spacing)
        if _kind(layer) == "labels":
            data = _label_voxels(data, layer.name)
            volume = Volume(data, spacing, origin, name=layer.name, direction=direction)
            members.append(Member(volume, "label", layer.name))
            tfs.append(label_table(layer, volume.data, voxel))
        else:
            volume = Volume(data, spacing, origin, name=layer.name, direction=direction)
            members.append(Member(volume, "scalar", layer.name))
            tfs.append(image_transfer_function(layer, voxel, depth))
    first = members[0].field.direction
    for m in members[1:]:
        if not np.allclose(m.field.direction, first, atol=1e-6):
            raise SceneError(f"{m.name}: rotated differently from {members[0].name}; dvr-gl renders several layers "
                             f"in one frame: give them the same rotation (or render them one at a time)")
    return members, tfs


def view_size(viewer, width: int | None = None) -> tuple[int, int]:
    """The picture's ``(width, height)`` in pixels: the canvas's, or ``width`` wide at the canvas's aspect."""
    canvas = getattr(viewer, "canvas", None)  # napari 0.9's canvas model; before it, the viewer's _canvas_size
    size = canvas.viewbox_size(viewer.layers) if canvas is not None else viewer._canvas_size
    h, w = (int(round(float(x))) for x in size)
    if width is None:
        return max(w, 1), max(h, 1)
    return int(width), max(1, int(round(width * h / w)))


def view_camera(camera, canvas_height: float) -> Camera:
    """napari's camera (module doc) as a dvr-gl :class:`~dvr_gl.Camera`; ``canvas_height`` in screen pixels."""
    view = np.asarray(camera.view_direction, dtype=np.float64)[::-1]
    up = np.asarray(camera.up_direction, dtype=np.float64)[::-1]
    target = np.asarray(camera.center, dtype=np.float64)[-3:][::-1]
    height = float(canvas_height) / float(camera.zoom)  # world units at the centre plane
    fov = float(camera.perspective)
    if fov < MIN_FOV:  # napari's 0 (and what no perspective camera of dvr-gl takes): orthographic
        return Camera(tuple(target - view * height), tuple(target), tuple(up), projection="orthographic",
                      view_height=height)
    distance = height / (2.0 * np.tan(np.radians(fov) / 2.0))
    return Camera(tuple(target - view * distance), tuple(target), tuple(up), projection="perspective", fov=fov)


def napari_camera(viewer):
    """The viewer's camera model (``viewer.scene.camera`` since napari 0.9, ``viewer.camera`` before)."""
    scene = getattr(viewer, "scene", None)
    return getattr(scene, "camera", None) or viewer.camera


def mirrored(camera) -> bool:
    """Whether napari shows (x, y, z) mirrored (its right-handed (z, y, x) orientations): the picture's
    columns are flipped to match."""
    # napari before 0.6 had no orientation setting, and its fixed one (away, down, right) mirrors nothing
    return str(getattr(camera, "handedness", "left")).lower().endswith("right")


def rendering_mode(layer) -> tuple[dict, bool, str | None]:
    """An image layer's napari ``rendering`` as dvr-gl settings: ``(settings, projected, note)``.  ``translucent``:
    emission and absorption (no settings); ``mip``, ``minip``, ``average``: that compositing; ``iso``: the
    isosurface at the layer's ``iso_threshold`` (data units, as napari's); ``attenuated_mip`` and ``additive``:
    the nearest mode dvr-gl has (:data:`APPROXIMATIONS`) and a one-line note saying what differs.
    ``projected``: the value is classified once (the colormap at the layer's opacity, no ramp)."""
    mode = str(getattr(layer, "rendering", "translucent"))
    if mode in PROJECTIONS:
        return {"compositing": PROJECTIONS[mode]}, True, None
    if mode == "iso":
        return {"compositing": "isosurface", "iso_value": float(layer.iso_threshold)}, True, None
    if mode in APPROXIMATIONS:
        compositing, note = APPROXIMATIONS[mode]
        return {"compositing": compositing}, True, note.format(attenuation=float(getattr(layer, "attenuation", 0)))
    if mode != "translucent":
        return {}, False, f"napari's rendering {mode!r} has no dvr-gl mode; drawn with emission and absorption"
    return {}, False, None


def _followed_layer(viewer, selected: bool):
    """The one image layer whose rendering a view follows, or None (several layers, or a labels layer)."""
    layers = rendered_layers(viewer, selected)
    return layers[0] if len(layers) == 1 and _kind(layers[0]) == "image" else None


def rendering_note(viewer, selected: bool = False, projection: bool = True) -> str | None:
    """The one-line note of :func:`rendering_mode` for the view's followed layer (None when exact or not
    followed): what a status line says beside the picture."""
    layer = _followed_layer(viewer, selected) if projection else None
    return rendering_mode(layer)[2] if layer is not None else None


def view_scene(viewer, renderer: str | None = None, width: int | None = None, depth: float = DEPTH_VOXELS,
               selected: bool = False, projection: bool = False, background=(0.0, 0.0, 0.0, 1.0)):
    """The :class:`~dvr_gl.Scene` of napari's current 3D view of its rendered layers (:func:`rendered_layers`)
    with ``renderer`` (a registered name; default: the data's default), ``width`` pixels wide (default: the
    canvas's size).  ``projection``: where one image layer is rendered, napari's ``rendering`` of it as dvr-gl's
    mode (:func:`rendering_mode`; a projection or an isosurface classifies with the colormap at the layer's
    opacity); otherwise emission and absorption."""
    if viewer.dims.ndisplay != 3:
        raise SceneError("napari shows a 2D view; switch to 3D (the cube button, or viewer.dims.ndisplay = 3)")
    members, tfs = layer_members(viewer, depth, selected)
    settings = {}
    layer = _followed_layer(viewer, selected) if projection else None
    if layer is not None:
        settings, projected, _ = rendering_mode(layer)
        if projected:
            tfs = [image_transfer_function(layer, min(members[0].field.spacing), depth, ramp=False)]
    # napari steps about a voxel (and refines a projection's extremum); the ray caster's scene-chosen defaults
    # (one 8-bit step of RMS) step up to 2.75 voxels, which moved the bright block's outline 4 pixels from where
    # napari's canvas draws it: napari's view is drawn at half a voxel (tests/apps/test_napari_plugin.py).
    settings.setdefault("sample_distance_voxels", 0.5)
    w, h = view_size(viewer, width)
    canvas_height = view_size(viewer)[1]
    camera = view_camera(napari_camera(viewer), canvas_height)
    return scene_of(members, transfer_function=tfs, camera=camera, renderer=renderer, size=(w, h),
                    background=tuple(background), **settings)


def render_view(viewer, renderer: str | None = None, width: int | None = None, depth: float = DEPTH_VOXELS,
                selected: bool = False, projection: bool = False, ctx=None):
    """The :class:`~dvr_gl.Image` of :func:`view_scene`, its columns flipped where napari mirrors
    (:func:`mirrored`), so that it lies as napari's canvas does; ``ctx``: a moderngl context for GL renderers
    (default: a new one, released after; a kept one compiles each program once)."""
    image = render(view_scene(viewer, renderer, width, depth, selected, projection), ctx=ctx)
    if mirrored(napari_camera(viewer)):
        image = Image(np.ascontiguousarray(image.rgba[:, ::-1]), image.scene, image.stats)
    return image


def time_axis(viewer) -> int | None:
    """napari's first world axis that is not displayed and has more than one step (its time), or None."""
    for a in range(len(viewer.dims.point)):
        if a not in viewer.dims.displayed and viewer.dims.nsteps[a] > 1:
            return a
    return None


def render_animation(viewer, orbit: bool = True, time: bool = False, frames: int | None = None,
                     renderer: str | None = None, width: int | None = None, depth: float = DEPTH_VOXELS,
                     selected: bool = False, projection: bool = False, ctx=None, progress=None) -> list:
    """The pictures of an orbit (360 degrees about napari's up direction, frame 0 the current view) and/or a
    walk through napari's time axis (:func:`time_axis`), as ``dvr render --animate`` makes them
    (:mod:`dvr_gl.apps.animation`: every frame keeps the first step's classification).  ``frames``: default
    36 for an orbit, one per step for time alone.  ``ctx``: a moderngl context for GL renderers (default: a new
    one).  ``progress(done, total)`` is told after each frame."""
    scene = view_scene(viewer, renderer, width, depth, selected, projection)
    axis = time_axis(viewer) if time else None
    if time and axis is None:
        raise SceneError("no time axis: napari shows no axis beyond the three displayed with more than one step")
    steps = viewer.dims.nsteps[axis] if axis is not None else 1
    count = frames or (36 if orbit else steps)
    if count < 1:
        raise SceneError(f"frames must be at least 1, got {count}")
    start = viewer.dims.current_step

    def read_step(k: int):
        viewer.dims.set_current_step(axis, k)
        return as_data(layer_members(viewer, depth, selected)[0])

    make = Frames(scene, Animation(count, orbit, steps), read_step)
    flip = mirrored(napari_camera(viewer))
    images = []
    try:
        with create_renderer(scene.renderer.name, ctx=ctx) as r:
            for i in range(count):
                rgba = r.render(make(i))
                images.append(Image(np.ascontiguousarray(rgba[:, ::-1]) if flip else rgba, scene, r.stats))
                if progress is not None:
                    progress(i + 1, count)
    finally:
        viewer.dims.current_step = start
    return images

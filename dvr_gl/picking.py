"""Picking: what lies under one pixel, from the float64 model of that pixel's ray (docs/picking.md).

:func:`pick` traces the one ray the ray caster and the ``reference`` renderer trace for the pixel (the same
set-up, :meth:`dvr_gl.rays.RayBatch.for_camera`, and the same samples, :mod:`dvr_gl.reference.discrete`) and
finds its depth as :mod:`dvr_gl.reference.depth` defines it, so that a pick agrees with the depth image at
that pixel.  One ray: cheap enough for a viewer's cursor.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

from .clipping import ClipRegion
from .errors import SceneError
from .orientation import is_oriented, to_patient_frame, volume_frame_scene
from .rays import RayBatch


@dataclasses.dataclass(frozen=True)
class Pick:
    """What lies under pixel ``(x, y)``: column ``x`` from the left, row ``y`` from the top (row 0 is the
    image's top row, as in :class:`dvr_gl.Image`); the pixel's ray passes through its centre
    ``(x + 0.5, y + 0.5)`` in image coordinates.

    hit: whether the ray has a depth (see :mod:`dvr_gl.reference.depth`); the fields below are None, and the
        depths infinite, where it has not.
    value: the data value there, as stored (``rescale_intercept`` places presets, it does not change the data:
        CThead's 1624 is 600 HU), reconstructed by the scene's filter; for MIP/MinIP the maximum
        (minimum) itself, for an isosurface about the iso-value.
    index: the nearest voxel ``(z, y, x)`` (grids only; None for other fields).
    position: the world point ``(x, y, z)`` in the scene's frame (world units; the patient frame for
        oriented data).
    depth: the distance along the view axis from the eye's plane (world units): what the depth image's Z holds.
    distance: the distance along the ray from its origin (world units; the eye for perspective views).
    field: several fields: the name of the field holding the most extinction there; None for one field.
    values: several fields: every field's value there by name (a field whose box is elsewhere: NaN).
    """

    x: int
    y: int
    hit: bool
    value: Optional[float] = None
    index: Optional[tuple[int, int, int]] = None
    position: Optional[tuple[float, float, float]] = None
    depth: float = math.inf
    distance: float = math.inf
    field: Optional[str] = None
    values: Optional[dict] = None


def pick(scene_or_data, x, y, **render_options) -> Pick:
    """What lies under pixel ``(x, y)`` of the image :func:`dvr_gl.render` would draw with the same
    arguments (``scene_or_data`` and ``render_options`` as there): see :class:`Pick`.  ``x``, ``y``: the
    column from the left and the row from the top; fractional coordinates pick the pixel they fall in.
    Raises SceneError for a pixel outside the image or a mode without a depth (the average)."""
    from .api import scene_of
    from .reference import depth as depth_model
    from .reference import fields

    scene = scene_of(scene_or_data, **render_options)
    width, height = scene.image.width, scene.image.height
    col, row = _pixel(x, width, "x"), _pixel(y, height, "y")
    depth_model.check(scene)
    if fields.several(scene):
        fields.check(scene)
    local, mirrored = volume_frame_scene(scene)  # renderers draw in the volume's frame, columns turned back
    ref = _one_ray(local, width - 1 - col if mirrored else col, row)
    t = float(depth_model.ray_depths(ref)[0])
    if math.isnan(t):
        return Pick(col, row, False)
    point = ref.rays.points(np.array([0]), np.array([[t]]))
    depth = float(depth_model.view_depth(ref.rays, np.array([0]), np.array([t]), local.camera)[0])
    world = to_patient_frame(scene.field, point)[0] if is_oriented(scene.field) else point[0]
    found = dict(x=col, y=row, hit=True, position=tuple(float(c) for c in world), depth=depth, distance=t)
    if fields.several(scene):
        return Pick(**found, **_fields_at(ref, point))
    return Pick(**found, value=_value_at(ref, point), index=_voxel(scene.field, point[0]))


def _pixel(v, size: int, axis: str) -> int:
    """The pixel a coordinate falls in: pixel ``i`` spans ``[i, i + 1)``."""
    if not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v) or not 0 <= v < size:
        raise SceneError(f"pick: {axis} = {v!r} is outside the image (0 to {size - 1}); give a pixel of the "
                         f"{size}-pixel {'width' if axis == 'x' else 'height'}")
    return int(math.floor(v))


def _one_ray(scene, col: int, row: int):
    """The reference (:class:`~dvr_gl.reference.discrete.DiscreteReference`) over the one ray of pixel
    ``(col, row)``, set up as the image's rays are."""
    from .reference.discrete import DiscreteReference

    r, img = scene.renderer, scene.image
    rays = RayBatch.for_camera(scene.camera, img.width, img.height, scene.field.bounds,
                               r.jitter_seed if r.jitter else None, ClipRegion.of(r),
                               pixels=np.array([row * img.width + col]))
    return DiscreteReference(scene, rays=rays)


def _value_at(ref, point: np.ndarray) -> float | None:
    """The scalar at the picked point (a mesh's outside, where an opaque surface ended the ray: None)."""
    value = float(ref.model.scalar.sample(point)[0])
    return None if math.isnan(value) else value


def _voxel(field, point: np.ndarray) -> tuple[int, int, int] | None:
    """The nearest grid node ``(z, y, x)`` to a world point of the volume's frame (grids only)."""
    if getattr(field, "kind", None) != "grid":
        return None
    ijk = np.rint((point - np.asarray(field.origin, np.float64)) / np.asarray(field.spacing, np.float64))
    ijk = np.clip(ijk, 0, np.asarray(field.dims) - 1).astype(int)  # dims and ijk are (x, y, z)
    return int(ijk[2]), int(ijk[1]), int(ijk[0])


def _fields_at(ref, point: np.ndarray) -> dict:
    """Several fields: each member's value at the point, and the one holding the most extinction."""
    values, sigmas = {}, {}
    for member in ref.model.members:
        name = member.layer.name
        inside = bool(member.inside(point)[0])
        values[name] = float(member.model.scalar.sample(point)[0]) if inside else math.nan
        sigmas[name] = float(member.model.extinction(point)[0]) if inside else -1.0
    return {"values": values, "field": max(sigmas, key=sigmas.get)}

"""Switching renderer settings at run time (pure; no window), from the renderer registry.

Every change returns a new :class:`~dvr_gl.scene.resolve.Scene` whose renderer settings passed the same
checks as a scene file's (``dvr render`` would accept them) and that its renderer can render (the
registry's :func:`~dvr_gl.renderers.registry.check`: declared modes, classifications and filters,
and the renderer's own check), or raises :class:`~dvr_gl.errors.SceneError` with the one-line
reason; the viewer then shows the reason and keeps the previous settings.  :func:`refusal` tells,
without changing anything, why an option is unavailable (the panel greys it out).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..clipping import clipping_in_use
from ..errors import SceneError
from ..fields import diagonal
from ..orientation import direction_of
from ..renderers import registry
from ..scene.resolve import Scene
from ..scene.settings import SAMPLE_DISTANCE_VOXELS_RANGE, with_sample_distance

MIN_SAMPLE_VOXELS, MAX_SAMPLE_VOXELS = SAMPLE_DISTANCE_VOXELS_RANGE


def renderer_names() -> list[str]:
    """Every registered renderer, in the registry's order (the declared ``order``: the number keys)."""
    return registry.names()


def choices(key: str) -> tuple:
    """The options of a setting with named choices (``name``: the renderers)."""
    if key == "name":
        return tuple(renderer_names())
    return registry.setting(key).choices


def needs_gl(name: str) -> bool:
    return registry.plugin(name).needs_gl


def fixed_planes(name: str) -> bool:
    """The renderer samples the voxel planes: the sample distance does not apply."""
    return registry.plugin(name).fixed_planes


def change(scene: Scene, **changes) -> Scene:
    """The scene with renderer settings changed, checked as a scene file's would be and refused (with
    SceneError) if its renderer cannot render it."""
    changed = scene.with_renderer(**changes)
    registry.check(changed)
    return changed


def refusal(scene: Scene, **changes) -> str | None:
    """Why the change would be refused (None: it would not); for greying out options."""
    try:
        change(scene, **changes)
    except SceneError as exc:
        return str(exc)
    return None


def cycle(scene: Scene, key: str, step: int = 1) -> Scene:
    """The next (``step`` = 1) or previous (-1) choice of a setting with named choices that the
    renderer can render (SceneError with the reason for the next one if none can)."""
    options = choices(key)
    current = scene.renderer.name if key == "name" else getattr(scene.renderer, key)
    i = options.index(current) if current in options else -1
    first_error = None
    for k in range(1, len(options)):
        try:
            return change(scene, **{key: options[(i + step * k) % len(options)]})
        except SceneError as exc:
            first_error = first_error or exc
    raise first_error or SceneError(f"renderer.{key}: no other choice")


def toggle_shading(scene: Scene) -> Scene:
    shading = dataclasses.replace(scene.renderer.shading, enabled=not scene.renderer.shading.enabled)
    return change(scene, shading=shading)


def toggle_scattering(scene: Scene) -> Scene:
    """Single scattering on (gradient shading off: both light the samples) or off."""
    sc = scene.renderer.scattering
    if sc.enabled:
        return change(scene, scattering=dataclasses.replace(sc, enabled=False))
    return change(scene, scattering=dataclasses.replace(sc, enabled=True),
                  shading=dataclasses.replace(scene.renderer.shading, enabled=False))


def turn_light(scene: Scene, about_up: float = 0.0, tilt: float = 0.0) -> Scene:
    """The first scattering light turned by ``about_up`` degrees about the camera's up axis and tilted by
    ``tilt`` degrees about its right axis: a directional light's direction, a point light's position
    about the box's centre."""
    sc = scene.renderer.scattering
    if not sc.lights:
        raise SceneError("renderer.scattering has no light to turn")
    forward, right, up = (np.asarray(v, dtype=np.float64) for v in scene.camera.basis())
    d = direction_of(scene.field)  # the camera is in the patient frame, the lights in the volume's
    rotation = d.T @ _rotation(up, about_up) @ _rotation(right, tilt) @ d
    light = sc.lights[0]
    if light.type == "directional":
        light = dataclasses.replace(light, direction=tuple(float(x) for x in rotation @ light.direction))
    else:
        lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.field.bounds)
        centre = (lo + hi) / 2.0
        moved = centre + rotation @ (np.asarray(light.position) - centre)
        light = dataclasses.replace(light, position=tuple(float(x) for x in moved))
    return change(scene, scattering=dataclasses.replace(sc, lights=[light, *sc.lights[1:]]))


def _rotation(axis, degrees: float) -> np.ndarray:
    """Rodrigues' rotation matrix about a unit ``axis``."""
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    t = math.radians(degrees)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(t) * k + (1.0 - math.cos(t)) * (k @ k)


def toggle_clip_plane(scene: Scene) -> Scene:
    """A clipping plane facing the eye through the box's centre, keeping what lies beyond it (the volume
    cut open along the view), or none (a cropping box stays)."""
    clipping = scene.renderer.clipping
    if clipping.planes:
        return change(scene, clipping=dataclasses.replace(clipping, planes=[]))
    forward = np.asarray(scene.camera.basis()[0], dtype=np.float64) @ direction_of(scene.field)  # volume frame
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.field.bounds)
    plane = (*forward, -float(forward @ ((lo + hi) / 2.0)))
    return change(scene, clipping=dataclasses.replace(clipping, planes=[tuple(float(x) for x in plane)]))


def move_clip_plane(scene: Scene, fraction: float) -> Scene:
    """The first clipping plane moved along its normal (into the part kept: ``fraction`` > 0 clips more)
    by ``fraction`` of the box's diagonal."""
    clipping = scene.renderer.clipping
    if not clipping.planes:
        raise SceneError("renderer.clipping has no plane to move: press X to add one")
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.field.bounds)
    nx, ny, nz, d = clipping.planes[0]
    shift = fraction * float(np.linalg.norm(hi - lo)) * math.sqrt(nx * nx + ny * ny + nz * nz)
    return change(scene, clipping=dataclasses.replace(clipping, planes=[(nx, ny, nz, d - shift),
                                                                        *clipping.planes[1:]]))


def toggle_jitter(scene: Scene) -> Scene:
    return change(scene, jitter=not scene.renderer.jitter)


def sample_distance_voxels(scene: Scene) -> float:
    """The sample distance in voxels of the smallest spacing."""
    return scene.renderer.sample_distance / scene.field.sample_spacing


def set_sample_distance_voxels(scene: Scene, voxels: float) -> Scene:
    """The sample distance (the slice spacing, for view-aligned slices) in voxels, clamped to
    [:data:`MIN_SAMPLE_VOXELS`, :data:`MAX_SAMPLE_VOXELS`]."""
    voxels = min(MAX_SAMPLE_VOXELS, max(MIN_SAMPLE_VOXELS, float(voxels)))
    return scene.replace(renderer=with_sample_distance(scene.renderer, scene.field, voxels=voxels))


def scale_sample_distance(scene: Scene, factor: float) -> Scene:
    return set_sample_distance_voxels(scene, sample_distance_voxels(scene) * factor)


def sampling_text(scene: Scene) -> str:
    """How the renderer samples: the sample distance, slice spacing and count, or voxel planes."""
    r = scene.renderer
    if fixed_planes(r.name):
        return "one slice per voxel plane"
    voxels = sample_distance_voxels(scene)
    if registry.plugin(r.name).view_aligned_slices:
        count = math.ceil(diagonal(scene.field) / r.sample_distance)
        return f"slice spacing {voxels:.3g} voxel (up to {count} slices)"
    return f"sample distance {voxels:.3g} voxel"


def describe(scene: Scene) -> str:
    """One line naming the renderer and the settings that matter to it."""
    r = scene.renderer
    plugin = registry.plugin(r.name)
    parts = [r.name, r.compositing.replace("_", "-")]
    if r.compositing == "emission_absorption":
        parts.append(f"{r.classification}-classified")
    parts.append(f"filter {r.filter}")
    if r.compositing in ("emission_absorption", "isosurface") and plugin.declared("shading"):
        parts.append("shading on" if r.shading.enabled else "shading off")
    if r.scattering.enabled:
        parts.append(f"scattering ({r.scattering.method.replace('_', ' ')})")
    clipping = getattr(r, "clipping", None)
    if clipping_in_use(clipping):
        planes = len(clipping.planes)
        parts.append("clipped by " + " and ".join(
            ([f"{planes} plane{'s' * (planes != 1)}"] if planes else []) + (["a box"] if clipping.box else [])))
    meshes = len(getattr(r, "geometry", None) or [])
    if meshes:
        parts.append(f"{meshes} mesh{'es' * (meshes != 1)}")
    if plugin.declared("jitter"):
        parts.append("jitter on" if r.jitter else "jitter off")
    parts.append(sampling_text(scene))
    parts.append(scene.camera.projection)
    return " | ".join(parts)


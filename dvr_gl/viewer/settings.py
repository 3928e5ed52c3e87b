"""Switching renderer settings at run time (pure; no window).

Every change returns a new :class:`~dvr_gl.scene.Scene` whose renderer settings passed the same
checks as a scene file's (``dvr render`` would accept them), or raises
:class:`~dvr_gl.errors.SceneError` with the one-line reason; the viewer then shows the reason and
keeps the previous settings.  What a renderer refuses only when it renders (shear-warp with
shading, slicing with MIP) is caught the same way by the viewer when it renders.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..renderers.base import RENDERERS
from ..scene import Scene, resolve_renderer
from ..scene_schema import CLASSIFICATIONS, COMPOSITING_MODES, FILTERS

RENDERER_NAMES = tuple(RENDERERS)
GL_RENDERERS = ("raycast", "slicing3d", "slicing2d", "shearwarp")
# Renderers whose slices are the voxel planes: the sample distance does not apply.
VOXEL_PLANES = ("slicing2d", "shearwarp")
CHOICES = {"name": RENDERER_NAMES, "compositing": COMPOSITING_MODES, "classification": CLASSIFICATIONS,
           "filter": FILTERS}
MIN_SAMPLE_VOXELS, MAX_SAMPLE_VOXELS = 1.0 / 64, 8.0


def change(scene: Scene, **changes) -> Scene:
    """The scene with renderer settings changed, checked as a scene file's would be (SceneError if not)."""
    spec = scene.with_renderer(**changes).renderer
    return scene.replace(renderer=resolve_renderer(spec, scene.volume))


def cycle(scene: Scene, key: str, step: int = 1) -> Scene:
    """The next (``step`` = 1) or previous (-1) choice of a setting with named choices."""
    options = CHOICES[key]
    current = getattr(scene.renderer, key)
    i = options.index(current) if current in options else -1
    return change(scene, **{key: options[(i + step) % len(options)]})


def toggle_shading(scene: Scene) -> Scene:
    shading = dataclasses.replace(scene.renderer.shading, enabled=not scene.renderer.shading.enabled)
    return change(scene, shading=shading)


def toggle_jitter(scene: Scene) -> Scene:
    return change(scene, jitter=not scene.renderer.jitter)


def sample_distance_voxels(scene: Scene) -> float:
    """The sample distance in voxels of the smallest spacing."""
    return scene.renderer.sample_distance / min(scene.volume.spacing)


def set_sample_distance_voxels(scene: Scene, voxels: float) -> Scene:
    """The sample distance (slice spacing for ``slicing3d``) in voxels, clamped to
    [:data:`MIN_SAMPLE_VOXELS`, :data:`MAX_SAMPLE_VOXELS`]."""
    voxels = min(MAX_SAMPLE_VOXELS, max(MIN_SAMPLE_VOXELS, float(voxels)))
    return change(scene, sample_distance=scene.volume.voxels_to_world(voxels))


def scale_sample_distance(scene: Scene, factor: float) -> Scene:
    return set_sample_distance_voxels(scene, sample_distance_voxels(scene) * factor)


def sampling_text(scene: Scene) -> str:
    """How the renderer samples: the sample distance, slice spacing and count, or voxel planes."""
    r = scene.renderer
    if r.name in VOXEL_PLANES:
        return "one slice per voxel plane"
    voxels = sample_distance_voxels(scene)
    if r.name == "slicing3d":
        lo, hi = scene.volume.box
        count = math.ceil(float(np.linalg.norm(hi - lo)) / r.sample_distance)
        return f"slice spacing {voxels:.3g} voxel (up to {count} slices)"
    return f"sample distance {voxels:.3g} voxel"


def describe(scene: Scene) -> str:
    """One line naming the renderer and the settings that matter to it."""
    r = scene.renderer
    parts = [r.name, r.compositing.replace("_", "-")]
    if r.compositing == "emission_absorption":
        parts.append(f"{r.classification}-classified")
    parts.append(f"filter {r.filter}")
    if r.compositing in ("emission_absorption", "isosurface"):
        parts.append("shading on" if r.shading.enabled else "shading off")
    parts.append("jitter on" if r.jitter else "jitter off")
    parts.append(sampling_text(scene))
    parts.append(scene.camera.projection)
    return " | ".join(parts)

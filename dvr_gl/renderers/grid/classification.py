"""What every grid renderer's ``classify()`` (``dvr_gl/gl/shaders/common/classify.glsl``) needs: the
defines of filtering, classification, shading, gradients, clipping and scattering a scene asks for
(:func:`classification_features`), the uniforms of the transfer function, shading and lights
(:func:`optics_uniforms`), and the pre-classified voxels (:func:`classified_voxels`).

The ray caster and the slicers build their programs on these; a splatter's sheets shade and classify
with the same uniforms and shading defines.  Emission-absorption only: a compositing mode's own
defines are its renderer's.
"""

from __future__ import annotations

import numpy as np

from ...clipping import ClipRegion
from ...fields import gradient_epsilon
from ...gl.lights import shading_uniforms
from ...gl.scattering import scattering_defines, scattering_uniforms

# renderer.filter -> its define in common/filter.glsl
FILTER = {"nearest": "FILTER_NEAREST", "linear": "FILTER_LINEAR", "cubic_bspline": "FILTER_CUBIC_BSPLINE",
          "catmull_rom": "FILTER_CATMULL_ROM"}


def classification_features(scene) -> dict:
    """Defines for filtering, classification, shading and gradients (only those set: a define the
    scene does not use is not compiled), with clipping, the surfaces that end the samples and
    scattering."""
    r = scene.renderer
    defines = {FILTER[r.filter]: True}
    if r.filtering == "shader" and r.filter != "nearest":
        defines["FILTER_IN_SHADER"] = True
    if scene.camera.projection == "orthographic":
        defines["CAMERA_ORTHOGRAPHIC"] = True
    defines["CLASSIFY_PRE"] = r.classification == "pre"
    defines["CLASSIFY_PREINTEGRATED"] = r.classification == "preintegrated"
    defines["ASSOCIATED_COLORS"] = r.classification == "pre" and r.associated_colors
    defines["GRADIENT_OPACITY"] = r.gradient_opacity
    shading_defines(scene, defines)
    scattering_defines(scene, defines)
    clip = ClipRegion.of(r)
    if clip is not None:  # every mode: common/clipping.glsl
        defines.update(clip.defines())
    defines["GEOMETRY"] = bool(getattr(r, "geometry", None))  # samples end at the meshes' surfaces
    return {k: v for k, v in defines.items() if v is not False}


def shading_defines(scene, defines: dict):
    """Blinn-Phong shading (``common/shading.glsl``) into ``defines`` where the scene has lights, and
    where gradients come from (a texture, or the shader's central differences) wherever they are used."""
    r = scene.renderer
    if r.shading.enabled and r.shading.lights:
        defines.update(SHADING=True, NUM_LIGHTS=len(r.shading.lights), TWO_SIDED=r.shading.two_sided)
    if defines.get("SHADING") or defines.get("GRADIENT_OPACITY"):
        defines["GRADIENT_TEXTURE"] = r.gradient == "texture"


def optics_uniforms(scene, lut) -> dict:
    """Transfer function (``lut``: its table, whose domain maps data values to texels), shading, lights,
    the clipping region and scattering: what every ``classify()`` reads."""
    r, field, tf = scene.renderer, scene.field, scene.transfer_function
    lut_lo, lut_hi = lut.domain
    g_ref = r.gradient_opacity_reference  # None where gradient opacity is off (settings.resolve_renderer)
    u = {"u_unit_distance": tf.unit_distance, "u_gradient_reference": 1.0 if g_ref is None else g_ref,
         "u_lut_size": r.lut_size, "u_lut_lo": lut_lo, "u_lut_scale": (r.lut_size - 1) / (lut_hi - lut_lo),
         **shading_uniforms(r.shading)}
    if r.shading.enabled and r.shading.lights:  # what shading_defines shades: the value range only then
        u["u_gradient_epsilon"] = gradient_epsilon(field)
    clip = ClipRegion.of(r)
    return {**u, **scattering_uniforms(scene), **(clip.uniforms() if clip is not None else {})}


def classified_voxels(frame, scene) -> np.ndarray:
    """Pre-classified voxels (float32 RGBA, ``(nz, ny, nx, 4)``), kept in ``frame``'s cache
    (:class:`~dvr_gl.gl.frame.GLFrame`) and shared by their textures and block classes."""
    r, volume, tf = scene.renderer, scene.volume, scene.transfer_function
    return frame._cached("classified voxels", (volume, tf, r.associated_colors),
                         lambda: tf.classify_voxels(volume.data, r.associated_colors).astype(np.float32))

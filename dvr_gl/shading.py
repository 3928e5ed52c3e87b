"""Blinn-Phong shading from the gradient, in float64 (the references' and the CPU paths' version; the
shaders' is ``dvr_gl/gl/shaders/common/shading.glsl``).

``normal = -gradient / |gradient|`` (pointing toward lower values, i.e. out of
bright structures).  A gradient weaker than ``Volume.gradient_epsilon`` (1e-5 of
the volume's value scale per voxel) gives a zero normal, hence ambient light
only: in homogeneous regions the direction would be rounding noise (random in
float64, exactly zero in float32), so the model makes it zero for both.
Two-sided lighting flips the normal toward the viewer.  For each light with
direction ``l`` (toward the light) and colour ``I``:

    c' = c * (ambient + diffuse * sum I max(n.l, 0)) + specular * sum I [n.l > 0] max(n.h, 0)^shininess

with ``h = normalize(l + v)`` and ``v`` the direction toward the eye (``-ray``).
A headlight has ``l = v``; a directional light ``l = -direction``.
"""

from __future__ import annotations

import numpy as np

from .scene.model import ShadingSpec


def normals_from_gradient(gradient: np.ndarray, epsilon: float = 0.0) -> np.ndarray:
    g = np.asarray(gradient, dtype=np.float64)
    mag = np.linalg.norm(g, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.where(mag > epsilon, -g / mag, 0.0)
    return n


def blinn_phong(color: np.ndarray, normal: np.ndarray, ray_dir: np.ndarray, shading: ShadingSpec) -> np.ndarray:
    """Shaded colour ``(N, 3)`` from non-associated colour, normal and ray direction (all ``(N, 3)``)."""
    v = -np.asarray(ray_dir, dtype=np.float64)
    n = np.asarray(normal, dtype=np.float64)
    if shading.two_sided:
        n = np.where(np.sum(n * v, axis=1, keepdims=True) < 0, -n, n)
    diffuse = np.zeros_like(color)
    specular = np.zeros_like(color)
    for light in shading.lights:
        if light.type == "headlight":
            toward_light = v
        else:
            d = np.asarray(light.direction, dtype=np.float64)
            toward_light = np.broadcast_to(-d / np.linalg.norm(d), v.shape)
        intensity = np.asarray(light.color, dtype=np.float64)
        ndotl = np.sum(n * toward_light, axis=1, keepdims=True)
        diffuse += intensity * np.maximum(ndotl, 0.0)
        h = toward_light + v
        h = h / np.linalg.norm(h, axis=1, keepdims=True).clip(1e-300)
        ndoth = np.maximum(np.sum(n * h, axis=1, keepdims=True), 0.0)
        specular += intensity * np.where(ndotl > 0, ndoth ** shading.shininess, 0.0)
    return color * (shading.ambient + shading.diffuse * diffuse) + shading.specular * specular

"""Shear-warp's oracle: the same-discretization reference of the intermediate image, warped on the host.

Step 2 of the renderer (the slices composited into the intermediate image) is judged by the shared
float64 judge (:class:`~dvr_gl.reference.discrete.DiscreteReference`) with the 2D-stack plan across the
principal axis, sampled along the intermediate pixels' rays and stopping at ``ert_threshold`` as the
renderer does (:func:`intermediate_reference`); the four pixels around each final pixel's warped
position, interpolated bilinearly, make the final image's reference (:func:`oracle`).  Shading and
gradient opacity are looked up at the voxels through the renderer's own quantized tables
(:class:`.shading.VoxelShadedModel`).
"""

from __future__ import annotations

import numpy as np

from ...reference import plans
from ...reference.discrete import DiscreteReference
from .factorization import factorize, factorize_view, pixel_pyramids
from .renderer import intermediate_rays, on_border, shades
from .shading import VoxelShadedModel


def _same_slices_reference(scene, fact, rays, u, v, quantized: bool = True) -> np.ndarray:
    """Float64 RGBA ``(len(rays), 4)`` of rays (those of intermediate pixels ``(u, v)``) sampled where they
    cross the slices across the principal axis, stopping at ``ert_threshold`` as shear-warp does;
    ``quantized=False``: shaded with the voxels' own normals (:mod:`.shading`)."""
    def plan(rs):
        planes = plans.axis_planes(rs, scene.camera, scene.volume, fact.axis)
        planes.terminates = True
        return planes

    reference = DiscreteReference(scene, plan=plan, rays=rays)
    if reference.surface is not None:
        reference.surface[on_border(fact, np.asarray(u), np.asarray(v))] = 0.0
    if shades(scene):  # shading and gradient opacity at the voxels, by the same tables
        reference.model = VoxelShadedModel(reference.model, scene, quantized)
    return reference.render_float64(shape=(len(rays), 1))[:, 0]


def intermediate_reference(scene, fact=None) -> np.ndarray:
    """The same-discretization reference of the intermediate image, float64 ``(Hi, Wi, 4)``: the
    rays of its pixels, sampled where they cross the slices across the principal axis (``fact``: a
    pyramid's factorization, default the view's single one)."""
    fact = fact or factorize(scene.camera, scene.volume, scene.image.width, scene.image.height)
    width, height = fact.size
    v, u = (a.ravel() for a in np.mgrid[0:height, 0:width])
    return _same_slices_reference(scene, fact, intermediate_rays(fact, scene), u, v).reshape(height, width, 4)


def pixel_owners(facts, scene) -> np.ndarray:
    """``(H * W,)``: the index in ``facts`` of the factorization each final pixel is warped from (its
    ray's pyramid's; -1: a pyramid with no slices beyond the eye, which sees nothing)."""
    width, height = scene.image.width, scene.image.height
    if facts[0].pyramid is None:
        return np.zeros(width * height, dtype=np.int64)
    _, axes, signs = pixel_pyramids(scene.camera, scene.volume, width, height)
    owner = np.full(width * height, -1, dtype=np.int64)
    for n, fact in enumerate(facts):
        owner[(axes == fact.pyramid[0]) & (signs == fact.pyramid[1])] = n
    return owner


def oracle(scene) -> np.ndarray:
    """The float64 image ``(H, W, 4)`` that shear-warp must match: :func:`same_slices` with the normals
    quantized as the renderer's tables quantize them."""
    return same_slices(scene)


def same_slices(scene, quantized: bool = True) -> np.ndarray:
    """The same-discretization reference of the final image, float64 ``(H, W, 4)``: the four
    intermediate pixels around each final pixel's warped position, each by
    :func:`_same_slices_reference`, interpolated bilinearly (only the pixels needed are computed);
    with the eye inside, each pixel from its pyramid's intermediate image; ``quantized=False``:
    shaded with unquantized normals."""
    width, height = scene.image.width, scene.image.height
    facts = factorize_view(scene.camera, scene.volume, width, height)
    owner = pixel_owners(facts, scene)
    out = np.zeros((width * height, 4))
    for n, fact in enumerate(facts):
        mine = owner == n
        u, v, weights, valid = (a[:, mine] for a in _warp_taps(fact, width, height))
        wi, hi = fact.size
        key = np.where(valid, v * wi + u, -1)
        needed = np.unique(key[valid])
        values = np.zeros((len(needed) + 1, 4))  # the last row: transparent, for taps outside
        nu, nv = needed % wi, needed // wi
        values[:-1] = _same_slices_reference(scene, fact, intermediate_rays(fact, scene, nu, nv), nu, nv, quantized)
        rows = np.where(valid, np.searchsorted(needed, key), len(needed))
        out[mine] = np.einsum("tp,tpc->pc", weights, values[rows])
    return out.reshape(height, width, 4)


def _warp_taps(fact, width: int, height: int):
    """For every final pixel centre, its four bilinear taps in the intermediate image: ``u, v``
    ``(4, H * W)`` int, weights, and whether each tap lies in the image (else it reads zero)."""
    py, px = np.mgrid[0:height, 0:width] + 0.5
    uvw = np.linalg.inv(fact.warp) @ np.stack([px.ravel(), py.ravel(), np.ones(px.size)])
    u, v = uvw[0] / uvw[2], uvw[1] / uvw[2]
    u0, v0 = np.floor(u), np.floor(v)
    fu, fv = u - u0, v - v0
    du, dv = np.array([0, 1, 0, 1])[:, None], np.array([0, 0, 1, 1])[:, None]
    weights = np.stack([(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv])
    uu, vv = (u0 + du).astype(np.int64), (v0 + dv).astype(np.int64)
    wi, hi = fact.size
    valid = (uu >= 0) & (uu < wi) & (vv >= 0) & (vv < hi) & (uvw[2] > 0)
    return uu, vv, weights, valid


def warp_reference(fact, intermediate: np.ndarray, width: int, height: int) -> np.ndarray:
    """The warp on the host: each final pixel's intermediate coordinates, bilinear, zero outside."""
    u, v, weights, valid = _warp_taps(fact, width, height)
    taps = np.where(valid[..., None], intermediate[np.where(valid, v, 0), np.where(valid, u, 0)], 0.0)
    return np.einsum("tp,tpc->pc", weights, taps).reshape(height, width, 4)

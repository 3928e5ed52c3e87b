"""Depth along the rays of the same-discretization reference (:mod:`.discrete`): the judge of depth images.

Where along a ray a pixel "is", per compositing mode (docs/picking.md):

* ``emission_absorption`` and ``xray``: where the accumulated opacity crosses one half, i.e. the optical
  depth ``tau`` reaches ``ln 2``.  Each segment has one extinction in the model, so ``tau`` is linear
  within it and the crossing is interpolated there: exact for piecewise-constant material (a slab of
  extinction ``sigma`` is crossed ``ln 2 / sigma`` past its face).  Early termination applies as in the
  image (a ray terminated below one half has no depth).
* ``mip`` and ``minip``: the sample holding the maximum (minimum); the first such sample along the ray.
* ``isosurface``: the refined hit.

A ray with none of these (it misses, never reaches one half, or the average) has no depth: NaN here, and an
opaque mesh it meets (``renderer.geometry``) gives it the mesh's depth.  Depths are ray parameters ``t``
(world units along the unit direction from the ray's origin); :func:`view_depth` turns them into the
distance along the view axis that depth images hold.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError
from ..scene.model import CLASSIFIED_ALONG_RAY, DEPTH_MODES
from . import fields

#: The optical depth at which the opacity is one half.
HALF_OPACITY_DEPTH = math.log(2.0)


def check(scene) -> None:
    """Raise SceneError, in one line, where the model defines no depth for ``scene``."""
    mode = scene.renderer.compositing
    if mode not in DEPTH_MODES:
        raise SceneError(f"renderer.compositing = {mode!r} has no depth (a mean along the whole ray has no place); "
                         f"depth is defined for {', '.join(DEPTH_MODES)}")
    if fields.several(scene) and mode not in CLASSIFIED_ALONG_RAY:
        raise SceneError(f"depth of several fields is defined for emission_absorption and xray, not {mode} "
                         f"(each field has its own {mode}); render one field")


def ray_depths(ref) -> np.ndarray:
    """The depth of every ray of ``ref`` (a :class:`~.discrete.DiscreteReference`): its parameter ``t``
    (world units along the ray), NaN where it has none."""
    check(ref.scene)
    mode = ref.scene.renderer.compositing
    if mode in ("mip", "minip"):
        t = _extremum(ref, mode)
    elif mode == "isosurface":
        t = np.full(len(ref.rays), np.nan)
        rows, hits = ref.iso_hits()
        t[rows] = hits
    else:
        t = _half_opacity(ref)
    if ref.surface is not None:  # an opaque mesh ends the ray: past it nothing is seen
        t = np.where(np.isnan(t) & (ref.surface[:, 3] > 0), ref.rays.t1, t)
    return t


def view_depth(rays, rows, t: np.ndarray, camera) -> np.ndarray:
    """The distance along the view axis (world units, from the eye's plane) of the points at ``t`` on rays
    ``rows``: what OpenEXR's Z channel holds; NaN stays NaN."""
    forward = np.asarray(camera.basis()[0], np.float64)
    points = rays.origins[rows] + t[:, None] * rays.directions[rows]
    return (points - np.asarray(camera.eye, np.float64)) @ forward


def _half_opacity(ref) -> np.ndarray:
    """Where each ray's optical depth reaches ln 2, interpolated within the segment that crosses it."""
    n = len(ref.rays)
    t = np.full(n, np.nan)
    tau_acc = np.zeros(n)
    active = ref.n_seg > 0
    threshold = ref.scene.renderer.ert_threshold if ref.plan.terminates else 1.0
    for rows, k, m in ref._steps(active):
        grid = ref.plan.grid(rows, k, m)
        _, tau = ref._segments(grid)
        before = tau_acc[rows, None] + np.cumsum(tau, axis=1) - tau
        include = grid.valid & (-np.expm1(-before) < threshold)
        crossing = include & (before < HALF_OPACITY_DEPTH) & (before + tau >= HALF_OPACITY_DEPTH) & (tau > 0)
        found = crossing.any(axis=1)
        j = np.argmax(crossing, axis=1)[found]
        f = found.nonzero()[0]
        t[rows[f]] = grid.start[f, j] + grid.length[f, j] * (HALF_OPACITY_DEPTH - before[f, j]) / tau[f, j]
        tau_acc[rows] += np.sum(np.where(include, tau, 0.0), axis=1)
        active[rows] &= ~found & (-np.expm1(-tau_acc[rows]) < threshold)
    return t


def _extremum(ref, mode: str) -> np.ndarray:
    """The parameter of the first sample holding each ray's maximum (``mip``) or minimum (``minip``)."""
    n = len(ref.rays)
    sign = 1.0 if mode == "mip" else -1.0  # the minimum is the maximum of -s
    best = np.full(n, -np.inf)
    t = np.full(n, np.nan)
    for rows, k, m in ref._steps(ref.n_seg > 0):
        grid = ref.plan.grid(rows, k, m)
        s = sign * ref.model.scalar.sample(grid.points)
        s = grid.scatter(np.where(np.isnan(s), -np.inf, s), -np.inf)  # a mesh's outside is no extremum
        j = np.argmax(s, axis=1)
        top = s[np.arange(len(rows)), j]
        better = top > best[rows]  # strictly: an equal value later along the ray is not the first
        best[rows[better]] = top[better]
        t[rows[better]] = grid.t[better, j[better]]
    return t


def depth_image(ref) -> np.ndarray:
    """The depth image of ``ref``'s rays (after its render): ``(H, W)`` float32, the distance along the view
    axis (:func:`view_depth`), ``inf`` where a ray has no depth."""
    t = ray_depths(ref)
    rows = np.arange(len(t))
    z = view_depth(ref.rays, rows, np.nan_to_num(t, nan=0.0), ref.scene.camera)
    z = np.where(np.isnan(t), np.inf, z)
    return z.reshape(ref.scene.image.height, ref.scene.image.width).astype(np.float32)

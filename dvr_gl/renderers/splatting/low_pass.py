"""EWA's screen-space low-pass (Zwicker, Pfister, van Baar and Gross 2001) for the Gaussian kernel.

Point-sampled at pixel centres, a kernel smaller than a pixel falls between them: the image aliases
(a volume of several voxels per pixel shimmers as it turns, and a radiograph's flux is off by the
kernels that miss every centre).  EWA convolves each splat's footprint with a screen-space Gaussian,
the resampling filter.  Here the convolution is made in the kernel: the screen Gaussian of
``renderer.screen_low_pass`` pixels (standard deviation), taken at the depth of the kernel's centre
into the plane across the view axis (world standard deviation ``s``: that many pixels' widths at that
depth), is added to the kernel's covariance.  In voxel units, with ``a = right / spacing`` and
``b = up / spacing``::

    C = sigma^2 I + s^2 (a a^T + b b^T)

The kernel stays a Gaussian of unit integral (each splat's flux is kept), read through the metric
``G = sigma^2 C^-1`` (``|u|^2`` becomes ``u^T G u``) times ``sqrt(det G)``, and cut at
``renderer.kernel_radius`` standard deviations in that metric (an ellipsoid).

* Orthographic, the widened kernel's line integral is the footprint convolved with the screen
  Gaussian (up to the truncation, 1e-5 of the kernel's mass).  In perspective the pixel's width
  changes over the kernel's depth and the plane is across the view axis rather than each ray: EWA's
  local affine approximation, measured in ``tests/test_splatting.py``.
* Along the view the kernel reaches as far as before (``a`` and ``b`` lie across it), so the slabs
  take the same kernels; across it the kernel reaches ``s`` further, which the ghost layers, the
  quads and the culling's bounds take from the widest kernel (:func:`reach_voxels`).
* A kernel much wider than a pixel changes by ``s^2`` over its variance: the filter matters only where
  splats are small.  The box still clips the rays: its own silhouette is not low-passed.
"""

from __future__ import annotations

import math

import numpy as np

from ...gl.geometry import box_corners
from ...scene import settings as s

SCREEN_LOW_PASS = s.Setting("screen_low_pass", float, 0.0, "EWA's screen-space low-pass against aliasing where "
                            "Gaussian splats are smaller than a pixel: its standard deviation (0: none, each pixel "
                            "its centre's ray as every renderer; Zwicker et al. use 1)", check=s.between(0.0, 4.0),
                            units="pixels", group="splatting")


def enabled(scene) -> bool:
    return scene.renderer.screen_low_pass > 0


def pixel_width(scene, depth) -> np.ndarray:
    """A pixel's width (world units) at view ``depth`` (orthographic: everywhere the same; in perspective,
    zero at and behind the eye's plane)."""
    cam, img = scene.camera, scene.image
    _, hy = cam.half_extent(img.width / img.height)
    width = 2.0 * hy / img.height
    if cam.projection == "orthographic":
        return np.full(np.shape(depth), width)
    return width * np.maximum(depth, 0.0)


def widths(scene, positions: np.ndarray) -> np.ndarray:
    """``s`` of each kernel centred at world ``positions`` ``(N, 3)``: the screen Gaussian in world units."""
    forward = scene.camera.basis()[0]
    depth = (positions - np.asarray(scene.camera.eye, float)) @ forward
    return scene.renderer.screen_low_pass * pixel_width(scene, depth)


def metric(scene, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(G (N, 3, 3), sqrt(det G) (N,))`` of the kernels centred at world ``positions`` (module doc)."""
    _, right, up = scene.camera.basis()
    spacing = np.asarray(scene.volume.spacing, float)
    sigma = scene.renderer.kernel_width
    a, b = right / spacing, up / spacing
    w2 = widths(scene, positions) ** 2
    cov = (sigma * sigma * np.eye(3))[None] + w2[:, None, None] * (np.outer(a, a) + np.outer(b, b))[None]
    g = sigma * sigma * np.linalg.inv(cov)
    return g, np.sqrt(np.linalg.det(g))


def reach_voxels(scene) -> float:
    """The widest kernel's reach along any grid axis, whole voxels (at least the Gaussian's radius): the
    kernel at the box's farthest depth, along the axis of the smallest spacing, rounded up so that small
    camera moves keep the ghost layers and the culling masks."""
    radius = scene.renderer.kernel_radius * scene.renderer.kernel_width
    if not enabled(scene):
        return radius
    lo, hi = scene.field.bounds
    depth = (box_corners(lo, hi) - np.asarray(scene.camera.eye, float)) @ scene.camera.basis()[0]
    widest = scene.renderer.screen_low_pass * float(np.max(pixel_width(scene, depth)))
    ratio = widest / (scene.renderer.kernel_width * float(np.min(scene.volume.spacing)))
    return float(math.ceil(radius * math.sqrt(1.0 + ratio * ratio)))

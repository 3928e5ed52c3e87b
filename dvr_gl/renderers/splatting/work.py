"""Splatting's work estimate (:func:`splat_work`), checked before a frame against the bound of
:mod:`dvr_gl.limits`: a frame costs the fragments of its splats (each kernel's footprint, in pixels,
once for every sheet it is drawn into), the instances drawn (every splat once per sheet whose range
holds it, even where the vertex shader drops it) and, per sheet, compositing and clearing a sheet of
the image's pixels plus the draw calls around it.  All three in one unit, "splat fragments", at the
rates measured on llvmpipe (dvr_gl/renderers/splatting/README.md).

The footprint is each particle's own at its view depth, or for a grid the mean over an even sample
of its samples' depths, each at most the whole image (a kernel at the eye); the count of kernels is
every splat before culling (the grid's samples with their ghost layers, or every particle).  So the
estimate is an upper bound (culling and early termination only lower the cost).
"""

from __future__ import annotations

import math

import numpy as np

from ... import limits
from ...fields import sph
from ...gl.geometry import box_corners
from .sheets import is_grid, kernel_depth_reach, kernel_reach, occupied_slab_count
from .splats import ghost_layers

#: A splat instance (its four vertices, the host's occlusion test and re-upload per sheet), in fragments:
#: fitted to blobs 64^3 at 64x64 and 128x128 (15 s and 27 s, footprints of 26 and 72 pixels).
FRAGMENTS_PER_INSTANCE = 32.0
#: A sheet's draw calls, state changes and read-backs, in fragments (about a millisecond on llvmpipe).
FRAGMENTS_PER_SHEET = 2e4
#: Footprint fragments, instances and sheets: 5e6-1.3e7 a second measured on llvmpipe with other work on the
#: cores (README.md); the bound, about an hour there.
SPLAT_FRAGMENTS = limits.work_unit("splat fragments", bound=2e10, rate=5e6)
FIX = {True: "raise renderer.slab_width (--slab-width), narrow the kernel (renderer.kernel_width), lower --size, or "
             "use a smaller volume",
       False: "raise renderer.slab_width (--slab-width), lower --size, or use fewer particles"}


def pixel_size(scene, depth) -> np.ndarray:
    """The world size of a pixel at view depths ``depth`` (at least the near plane's) in perspective, the
    view's height over the image's rows when orthographic."""
    cam, img = scene.camera, scene.image
    _, half_h = cam.half_extent(img.width / img.height)
    if cam.projection == "orthographic":
        return np.full(np.shape(depth), 2.0 * half_h / img.height)
    return 2.0 * half_h * np.maximum(np.asarray(depth, float), max(cam.near, 1e-300)) / img.height


def footprint_pixels(scene, radius, depth) -> float:
    """The mean count of pixels kernels of bounding radius ``radius`` (world units, one or one each) at view
    depths ``depth`` cover: each disc a pixel wider each side, at most the image (kernels at the eye)."""
    pixels = float(scene.image.width) * scene.image.height
    across = np.minimum(np.asarray(radius, float) / pixel_size(scene, depth), pixels)  # (no overflow at the eye)
    area = math.pi * (across + 1.0) ** 2
    return float(np.minimum(area, pixels).mean())


def lattice_depths(scene, per_axis: int = 16) -> np.ndarray:
    """View depths of an even sample of a grid's samples (``per_axis`` a side): where its kernels lie."""
    lo, hi = (np.asarray(b, float) for b in scene.field.bounds)
    axes = [np.linspace(a, b, per_axis) for a, b in zip(lo, hi)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return (points - np.asarray(scene.camera.eye, float)) @ scene.camera.basis()[0]


def sheet_count(scene) -> float:
    """The sheets a frame composites: image-aligned slabs over the box's depth, one per voxel plane across
    the most squarely facing axis, none without sheets (a float: it may be huge)."""
    r = scene.renderer
    if r.sheet_buffer == "none" or r.compositing == "average" or (r.compositing == "xray"
                                                                 and r.classification == "pre"):
        return 0.0
    if r.sheet_buffer == "axis_aligned":
        return float(max(scene.volume.dims))
    cam = scene.camera
    if not is_grid(scene):  # the slabs some particle reaches, and one for each stretch between
        p = scene.field
        depth = (p.positions - np.asarray(cam.eye, float)) @ cam.basis()[0]
        return occupied_slab_count(scene, depth, float(sph.SUPPORT * p.smoothing_lengths.max()))
    lo, hi = scene.field.bounds
    depths = (box_corners(lo, hi) - np.asarray(cam.eye, float)) @ cam.basis()[0]
    width = r.slab_width * scene.field.sample_spacing
    depth = float(depths.max()) - max(float(depths.min()), cam.near)
    return max(math.ceil(depth / width), 1.0) if math.isfinite(depth / width) else math.inf


def splat_work(scene) -> limits.Work:
    """The frame's work in splat fragments (module doc)."""
    r, img = scene.renderer, scene.image
    pixels = float(img.width) * img.height
    sheets = sheet_count(scene)
    forward = scene.camera.basis()[0]
    slab = r.slab_width * scene.field.sample_spacing  # world units
    if is_grid(scene):
        reach = kernel_reach(scene)
        g = ghost_layers(reach) if reach < 1e15 else math.inf  # (not NaN: the settings are checked)
        kernels = float(np.prod([float(n) + 2.0 * g for n in scene.volume.dims]))
        footprint = footprint_pixels(scene, reach * float(np.max(scene.volume.spacing)), lattice_depths(scene))
        depth_reach = kernel_depth_reach(scene, forward)
        what = f"{kernels:.3g} kernels (the grid and {g} ghost layers)"
    else:
        support = sph.SUPPORT * scene.field.smoothing_lengths
        kernels = float(len(support))
        depth = (scene.field.positions - np.asarray(scene.camera.eye, float)) @ forward
        footprint = footprint_pixels(scene, support, depth)
        depth_reach = float(support.max())
        what = f"{kernels:.3g} particles"
    # a splat goes into every slab within its reach of its centre (the schedule's range), axis-aligned and
    # unsheeted frames draw it once
    per_kernel = min(2.0 * depth_reach / slab + 2.0, max(sheets, 1.0)) if r.sheet_buffer == "image_aligned" \
        and sheets else 1.0
    count = kernels * per_kernel * (footprint + FRAGMENTS_PER_INSTANCE) + sheets * (3.0 * pixels + FRAGMENTS_PER_SHEET)
    how = (f"{what} x {per_kernel:.3g} sheets each x {footprint:.3g} pixels a footprint, and {sheets:.3g} sheets of "
           f"{img.width}x{img.height}")
    return limits.Work(count if math.isfinite(count) else math.inf, SPLAT_FRAGMENTS, how, FIX[is_grid(scene)])


__all__ = ["splat_work"]

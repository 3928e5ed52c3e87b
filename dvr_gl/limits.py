"""GL limits and resource bounds: what a render may ask of the GL, the memory and the clock.

**GL limits** are read once per context (:func:`gl_limits`) and checked before anything is
drawn: a table longer than a texture row (``renderer.lut_size``), a pre-integration table or
an image larger than a texture side, is refused in one line naming the limit, its value on
this GL and the largest value the setting may take.  A volume larger than the 3D texture
limit (or, for 2D stacks, the texture side or the array-layer limit) is rendered in bricks
(:mod:`dvr_gl.renderers.grid.bricking`).

**Work** is estimated before rendering as the count of what the renderer's inner loop
does: ray samples (rays x samples on the longest ray) for the ray caster and the
same-discretization reference, slice fragments (slices x pixels) for view-aligned slicing,
pieces (rays x pieces per ray) for the converged reference.  Counts over a bound are
refused with the estimate and the setting to change.  The bounds are hours of work on this
project's slowest machine (two cores, llvmpipe); measured rates in docs/robustness.md.  A
sandbox with ``max_seconds`` lowers the bound to that many seconds at the measured rate.

**Memory** (host arrays, tables, images, the demo volume) is estimated as bytes and
checked against :func:`dvr_gl.sandbox.memory_budget` with :func:`dvr_gl.sandbox.check_bytes`.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

from .errors import SceneError
from .fields import diagonal
from .sandbox import check_bytes, current

# --- GL limits ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class GLLimits:
    """The limits of one GL context that the renderers can exceed (texels or pixels a side)."""

    texture_size: int          # GL_MAX_TEXTURE_SIZE: 1D and 2D textures (tables, render targets)
    texture_3d_size: int       # GL_MAX_3D_TEXTURE_SIZE: volume textures
    array_layers: int          # GL_MAX_ARRAY_TEXTURE_LAYERS: slices of a 2D stack
    renderbuffer_size: int     # GL_MAX_RENDERBUFFER_SIZE
    viewport: tuple[int, int]  # GL_MAX_VIEWPORT_DIMS

    def target(self) -> tuple[str, int]:
        """The limit on an image's width and height: the smallest of the texture side (render targets
        are float textures), the renderbuffer size and the viewport, with its name."""
        return min((("GL_MAX_TEXTURE_SIZE", self.texture_size),
                    ("GL_MAX_RENDERBUFFER_SIZE", self.renderbuffer_size),
                    ("GL_MAX_VIEWPORT_DIMS", min(self.viewport))), key=lambda item: item[1])


_READ: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def gl_limits(ctx) -> GLLimits:
    """The limits of ``ctx`` (a moderngl context), read from it once."""
    if ctx not in _READ:
        info = ctx.info
        _READ[ctx] = GLLimits(int(info["GL_MAX_TEXTURE_SIZE"]), int(info["GL_MAX_3D_TEXTURE_SIZE"]),
                              int(info["GL_MAX_ARRAY_TEXTURE_LAYERS"]), int(info["GL_MAX_RENDERBUFFER_SIZE"]),
                              tuple(int(v) for v in info["GL_MAX_VIEWPORT_DIMS"]))
    return _READ[ctx]


def check_image(scene, limits: GLLimits):
    """The image must fit a render target."""
    name, largest = limits.target()
    width, height = scene.image.width, scene.image.height
    if max(width, height) > largest:
        raise SceneError(f"image {width}x{height} exceeds {name} {largest} of this GL (the largest render "
                         f"target); use --size (image.width, image.height) of at most {largest} a side")


def check_table(key: str, entries: int, limits: GLLimits, what: str):
    """A table of ``entries`` texels a side (``what``: "one row", "N x N") must fit a 2D texture."""
    if entries > limits.texture_size:
        raise SceneError(f"{key} = {entries} exceeds GL_MAX_TEXTURE_SIZE {limits.texture_size} of this GL "
                         f"(the table is a texture of {what}); use at most {limits.texture_size}")


def check_texture(what: str, size: tuple[int, int], limits: GLLimits, fix: str):
    """A 2D texture of ``size`` (width, height) texels must fit."""
    if max(size) > limits.texture_size:
        raise SceneError(f"{what} of {size[0]}x{size[1]} texels exceeds GL_MAX_TEXTURE_SIZE "
                         f"{limits.texture_size} of this GL; {fix}")


# --- work --------------------------------------------------------------------------------------

# Bounds on the work of one frame, and the rates measured on the slowest machine this project
# runs on (two shared cores, Mesa llvmpipe; docs/robustness.md), in estimated units per second
# (the estimates are upper bounds: the longest ray for every ray).  The rates turn a sandbox's
# seconds into work and the estimate into hours in the message.  Each bound is about an hour
# there (seconds on a real GPU); legitimate heavy work stays inside: a 0.05-voxel step through a
# 512^3 volume at 1024^2 is 2e10 samples, a converged reference of it at 1024^2 5e9 pieces.
# A renderer with a unit of its own declares it beside its estimate (:func:`work_unit`).
BOUNDS = {"gpu samples": 1e12, "cpu samples": 3e10, "pieces": 1e10}
RATES = {"gpu samples": 3e8, "cpu samples": 1e7, "pieces": 2e6}
# surfaces in the CPU renderers (dvr_gl.geometry): ray-triangle tests the 2D bins allow; 1e7 a second
# measured on two shared cores (docs/geometry.md)
BOUNDS["ray-triangle tests"], RATES["ray-triangle tests"] = 3e10, 1e7
# mesh resampling (dvr_gl.fields.mesh_resample): point-in-cell tests the locator's bins allow; 1.6e4 grid
# points a second on the blunt fin at 128, about 2e6 tests a second on two shared cores
BOUNDS["point-in-cell tests"], RATES["point-in-cell tests"] = 7e9, 2e6

# Below this the converged reference's error estimates (differences of float64 sums of order 1,
# ~1e-16 each, over ~1e3 pieces a ray) are rounding noise: refinement never meets them (measured:
# 1e-14 converges on a 32^3 phantom, 1e-15 still runs after 2 minutes).
MIN_CONVERGED_TOLERANCE = 1e-12


def work_unit(unit: str, bound: float, rate: float) -> str:
    """Declare a unit of work (``bound``: the largest a frame may take; ``rate``: units a second on the
    slowest machine, as above) for a renderer that counts its own; returns ``unit``, for its
    :class:`Work`."""
    BOUNDS[unit], RATES[unit] = bound, rate
    return unit


@dataclass(frozen=True)
class Work:
    """A render's work: ``count`` of ``unit`` (a key of :data:`BOUNDS`), described by ``how`` (the
    factors, in words) and changed by ``fix`` (the settings to change)."""

    count: float
    unit: str
    how: str
    fix: str


def bound(unit: str) -> float:
    """The largest work allowed: :data:`BOUNDS`, lowered by the sandbox's ``max_seconds``."""
    seconds = current().max_seconds
    return BOUNDS[unit] if seconds is None else min(BOUNDS[unit], seconds * RATES[unit])


def check_work(work: Work | None, renderer: str):
    if work is None:
        return
    limit = bound(work.unit)
    if not work.count <= limit:  # also NaN
        duration = _duration(work.count / RATES[work.unit])
        raise SceneError(f"{renderer} would take {work.count:.3g} {work.unit} ({work.how}; about {duration} "
                         f"at the rate measured on two CPU cores), over the bound of {limit:.3g}; {work.fix}")


def estimated_seconds(work: Work | None) -> float:
    """Seconds ``work`` takes at the measured rate (0 for None: bounded by the data)."""
    return 0.0 if work is None else work.count / RATES[work.unit]


def _duration(seconds: float) -> str:
    """``seconds`` in the unit a person reads best (the count is an upper bound, the rate the fastest measured)."""
    for unit, size in (("hours", 3600.0), ("minutes", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


#: How far (in box diagonals) the eye or the box's centre may lie from the world's origin for the GPU renderers,
#: whose shaders take world coordinates in float32 (a relative precision of 6e-8).  Measured on a 16^3 blob (2026-11-29,
#: the ray caster against its image at the origin): the box 6.7e3 diagonals out 0.16/255 off, 6.7e4 out 0.77/255;
#: an orthographic eye 3.8e3 diagonals away 0.14/255, 3.8e4 away 1.4/255, and beyond about 1e6 the image is black.
#: So at most 1e4: within about half a display step.  The references compute in float64 and take any.  (Rendering
#: relative to the box's centre would lift this for the box; an orthographic eye could be brought nearer.)
FAR_FROM_ORIGIN = 1e4


def check_float32_frame(scene, renderer: str):
    """Refuse, in one line, a GPU frame whose eye or box lies more than :data:`FAR_FROM_ORIGIN` box diagonals from
    the world's origin, where float32 coordinates would blur or blank the picture."""
    lo, hi = scene.field.bounds
    size = diagonal(scene.field)
    centre = [0.5 * (a + b) for a, b in zip(lo, hi)]
    far = max(math.dist(scene.camera.eye, (0.0, 0.0, 0.0)), math.dist(centre, (0.0, 0.0, 0.0)))
    if size > 0 and far > FAR_FROM_ORIGIN * size:
        raise SceneError(f"{renderer} computes in float32, and the camera's eye or the volume lies {far:.3g} world "
                         f"units from the origin, {far / size:.3g} times the volume's size (at most "
                         f"{FAR_FROM_ORIGIN:g}): move volume.origin nearer 0, or the camera nearer the volume "
                         f"(camera.distance), or use a reference renderer (float64)")


def samples_per_ray(scene) -> float:
    """Samples on the longest ray: the field's diagonal over the sample distance (a float, possibly inf)."""
    ratio = diagonal(scene.field) / scene.renderer.sample_distance
    return float(math.ceil(ratio)) if math.isfinite(ratio) else math.inf


def pixels(scene) -> int:
    return scene.image.width * scene.image.height


SAMPLE_FIX = ("raise renderer.sample_distance_voxels (--sample-distance-voxels) or renderer.sample_distance, "
              "or lower --size")


def ray_samples(scene, unit: str) -> Work:
    """Rays x samples on the longest ray (ray caster, same-discretization reference)."""
    per_ray = samples_per_ray(scene)
    return Work(pixels(scene) * per_ray, unit,
                f"{scene.image.width}x{scene.image.height} rays x {per_ray:.3g} samples at {_distance(scene)}",
                SAMPLE_FIX)


def slice_fragments(scene) -> Work:
    """View-aligned slices x pixels (3D texture slicing)."""
    slices = samples_per_ray(scene)
    return Work(pixels(scene) * slices, "gpu samples",
                f"{slices:.3g} slices at {_distance(scene)} x {scene.image.width}x{scene.image.height} pixels",
                SAMPLE_FIX)


def _distance(scene) -> str:
    """The sample distance in world units and in voxels of the smallest spacing (a tiny spacing in a
    header makes a tiny default distance: the message shows it)."""
    d, voxel = scene.renderer.sample_distance, scene.field.sample_spacing
    return f"renderer.sample_distance {d:.3g} world units ({d / voxel:.3g} voxels of the smallest spacing, {voxel:.3g})"


def converged_pieces(scene) -> Work:
    """Rays x pieces per ray for the converged reference: the filter's knots a ray crosses (at most
    one per voxel plane of each axis), refined by a
    factor that grows slowly as the tolerance falls (Gauss-Legendre pieces converge like h^8;
    measured: about 1.1 at 1e-4 .. 1e-12 on the test phantom, so 2 is generous)."""
    tol = scene.renderer.converged_tolerance
    if tol < MIN_CONVERGED_TOLERANCE:
        raise SceneError(f"renderer.converged_tolerance = {tol:g} is below what float64 can resolve "
                         f"(rounding noise in the error estimates); use at least {MIN_CONVERGED_TOLERANCE:g}")
    field = scene.field
    planes = sum(field.dims) if hasattr(field, "dims") else 3.0 * diagonal(field) / field.sample_spacing
    if getattr(field, "kind", "") == "particles":  # a ray's knots: where it enters and leaves each support
        planes = min(planes, 2.0 * len(field))
    per_ray = (planes + 1.0) * 2.0
    return Work(pixels(scene) * per_ray, "pieces",
                f"{scene.image.width}x{scene.image.height} rays x about {per_ray:.3g} pieces",
                "lower --size or raise renderer.converged_tolerance")


# --- memory ------------------------------------------------------------------------------------

BYTES_PER_PIXEL = {"gpu": 128, "cpu": 256}   # render targets, read-backs, rays and the composited copies
BYTES_PER_LUT_ENTRY = 128                    # the float64 table and its tabulation's temporaries
BYTES_PER_PREINTEGRATION_ENTRY = 192         # both directions' float64 (C, tau) and the assembled table


def count(n) -> float:
    """An integer count as a float that cannot overflow when multiplied a few times (a Python int
    past 1e100 is refused all the same)."""
    return float(min(n, 10 ** 100))


def check_image_memory(scene, kind: str):
    width, height = scene.image.width, scene.image.height
    check_bytes(count(width) * count(height) * BYTES_PER_PIXEL[kind], f"a {width}x{height} image",
                "lower --size (image.width, image.height)")


def check_lut_memory(lut_size: int):
    check_bytes(count(lut_size) * BYTES_PER_LUT_ENTRY, f"renderer.lut_size = {lut_size} (the transfer-function "
                f"table)", "lower renderer.lut_size (4096 is the default)")


def check_preintegration_memory(size: int):
    check_bytes(count(size) ** 2 * BYTES_PER_PREINTEGRATION_ENTRY, f"renderer.preintegration_size = {size} "
                f"(a {size} x {size} pre-integration table)", "lower renderer.preintegration_size (256 is the default)")

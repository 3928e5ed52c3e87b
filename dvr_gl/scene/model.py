"""The rendering model's vocabulary: what the picture should be, independent of any file format.

The compositing modes, classifications, reconstruction filters and compositing orders, and the
lighting of gradient shading.  The float64 references, the renderers and the scene-file schema all
use these; the model never imports the schema (the schema imports the model).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Optional, Union

COMPOSITING_MODES = ("emission_absorption", "isosurface", "average", "mip", "minip", "xray")
#: ``xray``: a radiograph of the classified extinction, absorption only: alpha ``1 - exp(-tau)`` with
#: ``tau`` the optical depth along the ray, premultiplied colour alpha times the extinction-weighted mean
#: colour (the line integral of ``sigma c`` over that of ``sigma``); classified post or pre.
#: The modes that classify every point along the ray (where classification, post or pre, matters).
CLASSIFIED_ALONG_RAY = ("emission_absorption", "xray")
# The compositing modes with a depth (docs/picking.md): the opacity's one-half crossing, the extremum, the hit
DEPTH_MODES = ("emission_absorption", "xray", "mip", "minip", "isosurface")
CLASSIFICATIONS = ("post", "pre", "preintegrated")
FILTERS = ("nearest", "linear", "cubic_bspline", "catmull_rom", "gaussian", "m4")
#: The filters a texture unit helps with: splines on the voxel grid, evaluated from a few taps (the GPU
#: grid renderers); ``gaussian`` is a footprint kernel (``dvr_gl/fields/reconstruction.py``); ``m4``, the SPH
#: cubic spline, is the kernel of particle sets (``dvr_gl/fields/particles.py``), their only filter.
SPLINE_FILTERS = ("nearest", "linear", "cubic_bspline", "catmull_rom")
#: Where the Gaussian is cut, in standard deviations: its value there is exp(-5^2 / 2) = 3.7e-6 of its
#: peak and its mass beyond 1.5e-5, so the X-ray of one kernel (scaled to unit integral: its footprint
#: gains that mass) is a 2D Gaussian within 2e-5 of its peak, below the 1e-4 the footprint tests ask; at
#: 4.5 the mass beyond is 1.5e-4, and every tenth of a radius costs splats and taps.
GAUSSIAN_RADIUS = 5.0
#: The Gaussian's default standard deviation, voxels: about the smallest whose sum of kernels is flat to a
#: tenth of an 8-bit step: within (1 + 2 exp(-2 pi^2 sigma^2))^3 - 1 = 3.8e-4 (0.6 leaves 4.9e-3, more
#: than a step); a wider kernel blurs more.
DEFAULT_KERNEL_WIDTH = 0.7
ORDERS = ("front_to_back", "back_to_front")
LIGHT_TYPES = ("headlight", "directional")
SCATTERING_LIGHT_TYPES = ("directional", "point")
PHASE_FUNCTIONS = ("isotropic", "henyey_greenstein")
SCATTERING_METHODS = ("shadow_rays", "light_volume", "half_angle")

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]


def choices(*values, default, doc: str = "", excludes: tuple = ()):
    """A dataclass field restricted to ``values`` (scene parsing checks them), with one line of documentation
    (``excludes``: as :func:`doc`'s)."""
    return field(default=default, metadata=_metadata(doc, excludes, choices=values))


def doc(default, text: str, factory=None, excludes: tuple = ()):
    """A dataclass field with one line of documentation (the scene-format reference shows it).

    excludes: the keys of the same table that this one replaces (:func:`exclusive_keys`)."""
    if factory is not None:
        return field(default_factory=factory, metadata=_metadata(text, excludes))
    return field(default=default, metadata=_metadata(text, excludes))


def _metadata(text: str, excludes: tuple, **more) -> dict:
    return {**more, "doc": text, **({"excludes": tuple(excludes)} if excludes else {})}


def exclusive_keys(table, key: str) -> tuple[str, ...]:
    """The keys of dataclass ``table`` (a class or an instance) that ``key`` excludes: those it declares
    (its field's ``excludes`` metadata) and those that declare it.  Giving one of a scene's keys (an
    override, a setting changed at run time) drops the others; giving two at once is refused.  The one
    reading of the exclusions that scene files, flags, the API and the viewer share."""
    fields = dataclasses.fields(table)
    own = [k for f in fields if f.name == key for k in f.metadata.get("excludes", ())]
    others = [f.name for f in fields if key in f.metadata.get("excludes", ())]
    return tuple(dict.fromkeys(k for k in own + others if k != key))


@dataclass
class LightSpec:
    """A light: ``headlight`` (from the eye, along each ray) or ``directional``."""

    type: str = choices(*LIGHT_TYPES, default="headlight", doc="from the eye along each ray, or directional")
    direction: Vec3 = doc((0.0, 0.0, -1.0), "directional: the direction the light travels (world)")
    color: Vec3 = doc((1.0, 1.0, 1.0), "linear RGB intensity")


@dataclass
class ShadingSpec:
    """Blinn-Phong shading from the gradient (emission-absorption and isosurface)."""

    enabled: bool = doc(False, "Blinn-Phong from the gradient (emission-absorption, isosurface)")
    ambient: float = doc(0.2, "ambient coefficient (0 .. 10)")
    diffuse: float = doc(0.7, "diffuse coefficient (0 .. 10)")
    specular: float = doc(0.3, "specular coefficient (0 .. 10)")
    shininess: float = doc(32.0, "specular exponent")
    two_sided: bool = doc(True, "light both sides of a surface (the normal turned toward the viewer)")
    lights: list[LightSpec] = doc(None, "`[[renderer.shading.lights]]` tables (default: one headlight)",
                                  factory=lambda: [LightSpec()])


@dataclass
class ScatteringLightSpec:
    """A light of single scattering: ``directional`` (parallel rays) or ``point`` (from a position,
    falling off with the squared distance)."""

    type: str = choices(*SCATTERING_LIGHT_TYPES, default="directional", doc="parallel rays, or from a position")
    direction: Vec3 = doc((1.0, 2.0, -3.0), "directional: the direction the light travels (world; the default "
                                            "comes from above, beside the default eye)")
    position: Vec3 = doc((0.0, 0.0, 0.0), "point: where the light is (world units)")
    color: Vec3 = doc((1.0, 1.0, 1.0), "linear RGB")
    intensity: float = doc(1.0, "irradiance of a directional light; a point light's at unit distance "
                                "(intensity / distance^2)")


@dataclass
class ScatteringSpec:
    """Single scattering toward the eye with shadows (emission-absorption only; docs/scattering.md).

    The source term at a point is ``sigma c ((1 - albedo) + albedo sum_l 4 pi p(cos theta_l) E_l T_l)``:
    ``c`` and ``sigma`` from the transfer function, ``p`` the phase function normalised to 1 over the
    sphere, ``E_l`` a light's irradiance and ``T_l`` the transmittance toward it (1 without shadows).
    ``4 pi p`` is the phase normalised to 4 pi as VTK writes it, so a light of intensity 1 seen through
    an isotropic, unshadowed medium gives the colour emission-absorption would."""

    enabled: bool = doc(False, "single scattering of the lights below (a scene without it compiles and "
                               "computes none of it)")
    albedo: Optional[Union[float, str]] = doc(None, "the scattered fraction of the extinction (0 .. 1; the rest "
                                                    "emits the colour as in emission-absorption, the lit volume's "
                                                    "ambient term), or `transfer_function`: its sixth column per "
                                                    "data value (default: that column where the points have one, "
                                                    "else 0.8)")
    phase: str = choices(*PHASE_FUNCTIONS, default="isotropic", doc="the phase function")
    g: float = doc(0.0, "henyey_greenstein: the mean cosine of the scattering angle (-1 .. 1, > 0 forward)")
    shadows: bool = doc(True, "attenuate each light by the transmittance toward it")
    method: str = choices(*SCATTERING_METHODS, default="shadow_rays",
                          doc="how a GPU renderer finds the transmittance: a shadow ray per sample, the "
                              "light_volume's grid of shadow rays interpolated, or half_angle slicing's light "
                              "buffer (the renderers that declare each: dvr info)")
    light_volume_size: int = doc(64, "light_volume: the grid's nodes along the box's longest axis (2 .. 256)")
    light_buffer_size: int = doc(256, "half_angle: the light buffer's pixels along its longer side (8 .. 4096)")
    shadow_step_voxels: Optional[float] = doc(None, "shadow rays' segment length in voxels of the smallest "
                                                    "spacing (default: the view rays' sample distance)")
    lights: list[ScatteringLightSpec] = doc(None, "`[[renderer.scattering.lights]]` tables (default: one "
                                                  "directional light)", factory=lambda: [ScatteringLightSpec()])


@dataclass
class ClippingSpec:
    """What of the volume is kept: the side ``n . x + d >= 0`` of each plane and the inside of the box,
    both in world coordinates, applied to every sample (a ray's kept part is one interval, as the region
    is convex; its ends are shortened segments, as the volume box's are).  Nothing given: nothing clipped
    (docs/clipping.md)."""

    planes: list[Vec4] = doc(None, "`[[nx, ny, nz, d], ...]`: keep where nx x + ny y + nz z + d >= 0 "
                                   "(world units)", factory=list)
    box: Optional[tuple[Vec3, Vec3]] = doc(None, "`[[xmin, ymin, zmin], [xmax, ymax, zmax]]`: keep inside "
                                                 "(world units; a cropping box or region of interest)")


@dataclass
class GeometrySpec:
    """An opaque triangle mesh in the volume's world coordinates (docs/geometry.md): the renderers stop
    integrating at its surface and show it, Blinn-Phong shaded, behind what lies in front of it."""

    path: Optional[str] = doc(None, "an OBJ, PLY, STL or VTK polydata file (relative to the scene file; read "
                                    "by meshio: the `mesh` extra)")
    color: Vec3 = doc((0.8, 0.8, 0.8), "linear RGB, non-associated (opaque)")

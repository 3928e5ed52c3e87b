"""Renderer settings, each declared once: type, default, documentation, checks.

A renderer plugin (:mod:`dvr_gl.renderers.registry`) lists the settings it reads: shared
ones from this module, narrowed to the choices it supports where it supports fewer
(:meth:`Setting.only`), and its own.  The scene file's ``[renderer]`` table is the union
of what the registered renderers declare; the CLI flags, ``dvr info``, the viewer's
options and the scene-format reference (``docs/scene-files.md``) are generated from these
declarations.

*Model* settings (``must_support=True``) change what the picture should be: the compositing
mode, classification, reconstruction filter, shading, gradient opacity and jitter.  A
renderer that does not declare one refuses a scene that uses it (rather than render
another picture than the one asked for); one that declares it with fewer choices
refuses the others.  The other settings tune how closely a renderer approaches the
picture (sample distance, tables, early termination) or how it runs (budgets,
acceleration); a renderer that does not read one ignores it.

Values that depend on the data are resolved here, once, for every writer
(:func:`resolve_renderer`): the sample distance in world units (from voxels, the
default, or a tolerance), the iso-value and the gradient-opacity reference.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from ..checks import at_least, between, positive, world_coordinates
from ..clipping import check_clipping, clipping_in_use
from ..errors import SceneError
from ..fields import diagonal
from ..out_of_core import volume as out_of_core
from .model import (
    CLASSIFICATIONS,
    CLASSIFIED_ALONG_RAY,
    COMPOSITING_MODES,
    DEFAULT_KERNEL_WIDTH,
    FILTERS,
    GAUSSIAN_RADIUS,
    ORDERS,
    ClippingSpec,
    GeometrySpec,
    ScatteringSpec,
    ShadingSpec,
    exclusive_keys,
)

DEFAULT_SAMPLE_DISTANCE_VOXELS = 0.5
#: The sample distances, in voxels, that a choice made for the user stays within (the viewer's slider and keys;
#: finer costs more than 64 samples a voxel, coarser skips features of 8 voxels).
SAMPLE_DISTANCE_VOXELS_RANGE = (1.0 / 64, 8.0)
#: The groups of the settings every renderer may read (:attr:`Setting.group`); any other group is the name of
#: the renderer that owns the setting.
SHARED_GROUPS = ("model", "sampling", "gpu")


@dataclass(frozen=True)
class Setting:
    """One ``[renderer]`` key (see the module doc).

    name: the key; ``type``: float, int, bool, str, ``Optional[...]`` or a table dataclass.
    default: its value when the scene does not give one (``default_factory`` for tables).
    doc: one line for the CLI help, ``dvr info`` and the scene-format reference.
    choices: the values allowed (strings), if restricted.
    check: ``check(value)`` returns what is wrong with a value (a phrase completing
        "renderer.<name> ..."), or None; a table's check raises SceneError naming the key itself.
    units: for the documentation ("world units", "voxels", "MB").
    flag: a ``dvr render`` / ``dvr view`` flag ``--name-with-dashes`` (bools: ``--x/--no-x``).
    must_support: a renderer that does not declare it refuses a scene that uses it (the model
        settings, and promises such as a tolerance; see the module doc).
    in_use: whether a value uses the feature (default: it differs from the default).
    applies: whether the setting changes the picture, given the others (``applies(spec)``; shading
        and classification do not change a maximum intensity projection); default: always.
    group: where the reference lists it: one of :data:`SHARED_GROUPS`, or the name of the renderer that owns
        it (a setting of its own, declared in its folder: :attr:`owner`).
    aliases: ``(old, new)`` pairs: a scene's ``old`` value (of another type, as earlier versions wrote
        it) is read as ``new``.
    excludes: the settings this one replaces (a sample distance in world units or in voxels): giving it drops
        them, giving both at once is refused (:func:`dvr_gl.scene.model.exclusive_keys`, which also reads the
        exclusions the other way: a renderer's own setting may exclude shared ones).
    """

    name: str
    type: Any
    default: Any = None
    doc: str = ""
    choices: tuple = ()
    check: Optional[Callable[[Any], Optional[str]]] = None
    units: str = ""
    flag: bool = True
    must_support: bool = False
    in_use: Optional[Callable[[Any], bool]] = None
    group: str = "sampling"
    default_factory: Optional[Callable[[], Any]] = None
    applies: Optional[Callable[[Any], bool]] = None
    origin: Optional["Setting"] = field(default=None, compare=False)
    aliases: tuple = ()
    excludes: tuple = ()

    @property
    def key(self) -> str:
        return f"renderer.{self.name}"

    @property
    def owner(self) -> Optional[str]:
        """The renderer whose own setting this is (its ``group``), or None for a shared one."""
        return None if self.group in SHARED_GROUPS else self.group

    @property
    def base(self) -> "Setting":
        """The shared declaration this one narrows (itself if it narrows none)."""
        return self.origin or self

    def only(self, *values) -> "Setting":
        """This setting with fewer choices (what one renderer supports)."""
        unknown = [v for v in values if self.choices and v not in self.choices]
        if unknown:
            raise ValueError(f"{self.name}: {unknown} are not among its choices {self.choices}")
        return dataclasses.replace(self, choices=tuple(values), origin=self.base)

    def default_value(self):
        return self.default_factory() if self.default_factory else self.default

    def used(self, value) -> bool:
        """Whether ``value`` uses the feature (``must_support`` settings: a renderer without it refuses)."""
        return self.in_use(value) if self.in_use else value != self.default_value()

    def matters(self, spec) -> bool:
        """Whether this setting changes the picture of renderer settings ``spec``."""
        return self.applies(spec) if self.applies else True

    def validate(self, value):
        """Raise SceneError naming the key if ``value`` is not allowed (types are checked by parsing)."""
        if value is None:
            return
        problem = self.check(value) if self.check else None
        if problem:
            raise SceneError(f"renderer.{self.name} {problem}, got {value!r}")


# --- checks ----------------------------------------------------------------------------------

#: The largest ambient, diffuse and specular coefficient: ten times a surface's full reflection, past any
#: wanted exaggeration (the presets' are at most 1); larger ones ran colours off (diffuse 1e6: 27237 over alpha).
MAX_SHADING_COEFFICIENT = 10.0


def _check_shading(sh: ShadingSpec) -> None:
    """The [renderer.shading] table's values, each named by its own key."""
    for key in ("ambient", "diffuse", "specular"):
        if not 0 <= getattr(sh, key) <= MAX_SHADING_COEFFICIENT:
            raise SceneError(f"renderer.shading.{key} must be in [0, {MAX_SHADING_COEFFICIENT:g}], "
                             f"got {getattr(sh, key)}")
    if sh.shininess < 0:
        raise SceneError(f"renderer.shading.shininess must be >= 0, got {sh.shininess}")
    for i, light in enumerate(sh.lights):
        if light.type == "directional" and not any(light.direction):
            raise SceneError(f"renderer.shading.lights[{i}].direction must be a non-zero vector")
        if any(c < 0 for c in light.color):
            raise SceneError(f"renderer.shading.lights[{i}].color must be >= 0, got {list(light.color)}")


def _check_scattering(sc: ScatteringSpec) -> None:
    """The [renderer.scattering] table's values, each named by its own key."""
    if isinstance(sc.albedo, str) and sc.albedo != "transfer_function":
        raise SceneError(f"renderer.scattering.albedo must be a number in [0, 1] or 'transfer_function' (the "
                         f"points' sixth column), got {sc.albedo!r}")
    if isinstance(sc.albedo, float) and not 0.0 <= sc.albedo <= 1.0:
        raise SceneError(f"renderer.scattering.albedo must be in [0, 1], got {sc.albedo}")
    if not -1.0 < sc.g < 1.0:
        raise SceneError(f"renderer.scattering.g must be in (-1, 1) (the phase function is a delta at +-1), "
                         f"got {sc.g}")
    if sc.g != 0.0 and sc.phase == "isotropic":
        raise SceneError(f"renderer.scattering.g = {sc.g} applies to phase = 'henyey_greenstein'; set the "
                         f"phase or remove g")
    if sc.shadow_step_voxels is not None and not 1.0 / 64.0 <= sc.shadow_step_voxels <= 64.0:
        raise SceneError(f"renderer.scattering.shadow_step_voxels must be 1/64 to 64 voxels, got "
                         f"{sc.shadow_step_voxels}")
    if not 8 <= sc.light_buffer_size <= 4096:
        raise SceneError(f"renderer.scattering.light_buffer_size must be 8 to 4096 pixels, got {sc.light_buffer_size}")
    if sc.enabled and sc.method == "half_angle" and (len(sc.lights) != 1 or sc.lights[0].type != "directional"):
        raise SceneError("renderer.scattering.method = 'half_angle' slices halfway between the eye and one "
                         "directional light; give one directional light, or use shadow_rays or light_volume")
    if not 2 <= sc.light_volume_size <= 256:
        raise SceneError(f"renderer.scattering.light_volume_size must be 2 to 256 nodes, got {sc.light_volume_size}")
    if sc.method == "light_volume" and len(sc.lights) > 4:
        raise SceneError(f"renderer.scattering.method = 'light_volume' holds at most 4 lights (one channel each), "
                         f"got {len(sc.lights)}; use shadow_rays or fewer lights")
    if sc.enabled and not sc.lights:
        raise SceneError("renderer.scattering.lights is empty: give at least one [[renderer.scattering.lights]] "
                         "table, or set enabled = false")
    for i, light in enumerate(sc.lights):
        where = f"renderer.scattering.lights[{i}]"
        if light.type == "directional" and not any(light.direction):
            raise SceneError(f"{where}.direction must be a non-zero vector")
        if any(c < 0 for c in light.color):
            raise SceneError(f"{where}.color must be >= 0, got {list(light.color)}")
        if not light.intensity >= 0:
            raise SceneError(f"{where}.intensity must be >= 0, got {light.intensity}")
        problem = world_coordinates(light.position)
        if problem:
            raise SceneError(f"{where}.position {problem}, got {list(light.position)}")


# --- the model: what the picture should be ---------------------------------------------------

COMPOSITING = Setting("compositing", str, "emission_absorption", "compositing mode: emission-absorption, "
                      "the isosurface's first hit, average (the mean value along the ray), maximum or minimum "
                      "intensity projection, or xray (a radiograph of the classified extinction)",
                      choices=COMPOSITING_MODES, must_support=True, group="model")
#: The modes of the renderers that do not render the X-ray (the cell projectors).
COMPOSITING_BEFORE_XRAY = tuple(m for m in COMPOSITING_MODES if m != "xray")


def _emission(spec) -> bool:
    return spec.compositing == "emission_absorption"


def _classified_along(spec) -> bool:
    """Classification matters where each point is classified: emission-absorption and the X-ray."""
    return spec.compositing in CLASSIFIED_ALONG_RAY


def _lit(spec) -> bool:
    """Shading lights emission-absorption samples and the isosurface; projections classify a value."""
    return spec.compositing in ("emission_absorption", "isosurface")


CLASSIFICATION = Setting("classification", str, "post", "post (interpolate, then apply the transfer function), "
                         "pre (classify voxels, interpolate them) or preintegrated (each segment from a table "
                         "by its two end values)", choices=CLASSIFICATIONS, must_support=True, group="model",
                         applies=_classified_along)
ASSOCIATED_COLORS = Setting("associated_colors", bool, True, "pre-classification interpolates sigma*c (no colour "
                            "bleeding); false shows the artefact", group="model", flag=False)
FILTER = Setting("filter", str, "linear", "reconstruction filter (SPH particles: m4, their kernel, which linear "
                 "stands for)", choices=FILTERS, must_support=True, group="model")


def _gaussian(spec) -> bool:
    return spec.filter == "gaussian"


KERNEL_WIDTH = Setting("kernel_width", float, DEFAULT_KERNEL_WIDTH, "the Gaussian filter's standard deviation "
                       "(truncated at renderer.kernel_radius of them; the field is the sum of the samples' "
                       "kernels)", check=positive,
                       units="voxels", must_support=True, group="model", applies=_gaussian)
KERNEL_RADIUS = Setting("kernel_radius", float, GAUSSIAN_RADIUS, "where the Gaussian filter is cut, in its standard "
                        f"deviations (the kernel scaled to unit mass; {GAUSSIAN_RADIUS:g} drops 1.5e-5 of its mass, 4 "
                        "drops 1.1e-3 for about three quarters of splatting's time, 3 drops 2.9e-2)",
                        check=between(3.0, 6.0), units="standard deviations", must_support=True, group="model",
                        applies=_gaussian)
ISO_VALUE = Setting("iso_value", Optional[float], None, "isosurface value, data units (default: the middle of "
                    "the value range)", group="model")
GRADIENT_OPACITY = Setting("gradient_opacity", bool, False, "scale extinction by min(1, |gradient| / reference) "
                           "(emission-absorption)", must_support=True, group="model", flag=False,
                           applies=_emission)
def _line_integral(spec) -> bool:
    """Depth cueing weights what the line-integral modes add up: the average and the X-ray."""
    return spec.compositing in ("average", "xray")


DEPTH_CUE = Setting("depth_cue", float, 1.0, "linear depth cueing of the average and the X-ray (Totsuka and Levoy): "
                    "the weight of the scalar (average) or the emission (X-ray) at the volume's farthest depth, "
                    "1 at its nearest, linear in between (1: none)", check=between(0.0, 1.0), must_support=True,
                    group="model", applies=_line_integral)
HEMISPHERICAL_SHADING = Setting("hemispherical_shading", bool, False, "Totsuka and Levoy's shading of the "
                                "average and the X-ray: ambient times the value (X-ray: the emission) plus diffuse "
                                "times a voxel times (|gradient| + gradient . light) / 2, the coefficients and the "
                                "light from [renderer.shading] (its first light)", must_support=True, group="model",
                                flag=False, applies=_line_integral)
GRADIENT_OPACITY_REFERENCE = Setting("gradient_opacity_reference", Optional[float], None,
                                     "gradient magnitude giving full opacity (default: 0.1 value range per voxel)",
                                     check=positive, group="model", flag=False)
SHADING = Setting("shading", ShadingSpec, None, "Blinn-Phong shading from the gradient: the "
                  "[renderer.shading] table (enabled, ambient, diffuse, specular, shininess, two_sided, lights)",
                  check=_check_shading, must_support=True, in_use=lambda sh: sh.enabled, group="model",
                  default_factory=ShadingSpec, flag=False, applies=_lit)

SCATTERING = Setting("scattering", ScatteringSpec, None, "single scattering with shadows: the [renderer.scattering] "
                     "table (enabled, albedo, phase, g, shadows, method, lights); emission-absorption only",
                     check=_check_scattering, must_support=True, in_use=lambda sc: sc.enabled, group="model",
                     default_factory=ScatteringSpec, flag=False)

CLIPPING = Setting("clipping", ClippingSpec, None, "clipping planes and a cropping box, per sample: the "
                   "[renderer.clipping] table (planes, box; world units)", check=check_clipping, must_support=True,
                   in_use=clipping_in_use, group="model", default_factory=ClippingSpec, flag=False)

def _check_geometry(meshes) -> None:
    for i, g in enumerate(meshes):
        if not g.path:
            raise SceneError(f"renderer.geometry[{i}] has no path: give the mesh file (OBJ, PLY, STL or VTK)")
        if any(not 0.0 <= c <= 1.0 for c in g.color):
            raise SceneError(f"renderer.geometry[{i}].color must be in [0, 1], got {list(g.color)}")


GEOMETRY = Setting("geometry", list[GeometrySpec], None, "opaque triangle meshes in the volume's world: "
                   "[[renderer.geometry]] tables (path, color); integration stops at their surface",
                   check=_check_geometry, must_support=True, in_use=bool, group="model", default_factory=list,
                   flag=False)

# --- sampling: how closely a renderer approaches the picture ---------------------------------

SAMPLE_DISTANCE = Setting("sample_distance", Optional[float], None, "segment length (default 0.5 voxel; the ray "
                          "caster chooses its own by the scene unless shaded: docs/tolerance.md; at most a million "
                          "diagonals of the volume)",
                          check=positive, units="world units", excludes=("sample_distance_voxels",))
SAMPLE_DISTANCE_VOXELS = Setting("sample_distance_voxels", Optional[float], None,
                                 "segment length in voxels of the smallest spacing (at most a million diagonals of "
                                 "the volume)", check=positive,
                                 units="voxels", excludes=("sample_distance",))
ORDER = Setting("order", str, "front_to_back", "compositing order (back_to_front: the over operator; the same "
                "image within rounding)", choices=ORDERS)
ISO_REFINEMENT = Setting("iso_refinement", int, 8, "bisection steps refining the isosurface's first hit",
                         check=between(0, 64, what=" bisection steps"), flag=False)
EXTREMUM_REFINEMENT = Setting("extremum_refinement", Optional[int], None, "MIP and MinIP: parabolic steps "
                              "refining the extremum between the samples around the extreme one (0: the extreme "
                              "sample itself; default: the ray caster's defaults choose it with the sample distance, "
                              "docs/tolerance.md; 0 elsewhere)",
                              check=between(0, 8, what=" parabolic steps"), flag=False)
EXTREMUM_BRACKETS = Setting("extremum_brackets", Optional[int], None, "MIP and MinIP with extremum_refinement: "
                            "brackets refined, the extreme sample's (1) and also the best peak of the samples not next "
                            "to it, a second peak (2); default: the ray caster's defaults choose 2 with the sample "
                            "distance, docs/tolerance.md; 1 elsewhere",
                            check=between(1, 2, what=" brackets"), flag=False)
JITTER = Setting("jitter", bool, False, "per-pixel sample offset against wood-grain artefacts", must_support=True)
JITTER_SEED = Setting("jitter_seed", int, 0, "seed of the jitter offsets (32 bits: the shaders' hash)",
                      check=lambda v: None if 0 <= v < 2**32 else "must be in [0, 4294967295]")
# What early termination drops from a pixel is at most 1 - threshold: at 1 - 1/255, one step of an 8-bit
# display.  Chosen from the error-vs-time grid of the ray caster's benchmarks/defaults.py (docs/tradeoff.md,
# "Why these defaults"): 3-9 dB less error than 0.99 on opaque scenes for 0-12 % more time.
ERT_DEFAULT = 1.0 - 1.0 / 255.0
ERT_THRESHOLD = Setting("ert_threshold", float, ERT_DEFAULT, "early ray termination at this accumulated opacity "
                        "(1: off; the default 1 - 1/255 drops at most one 8-bit display step)",
                        check=between(0.0, 1.0, open_lo=True))
LUT_SIZE = Setting("lut_size", int, 4096, "transfer-function table entries", check=at_least(2))
PREINTEGRATION = Setting("preintegration", str, "exact", "the pre-integration table: exact, or fast (Engel et al.; "
                         "no self-attenuation within a segment)", choices=("exact", "fast"), flag=False)
PREINTEGRATION_SIZE = Setting("preintegration_size", int, 256, "pre-integration table entries per axis "
                              "(front value x back value)", check=at_least(2), flag=False)

# --- GPU renderers on grids ------------------------------------------------------------------

FILTERING = Setting("filtering", str, "hardware", "hardware (the texture unit interpolates; fast) or shader "
                    "(texelFetch and float weights: exact on any GPU)", choices=("hardware", "shader"), group="gpu")
GRADIENT = Setting("gradient", str, "central_differences", "shading gradients on the fly, or from a precomputed "
                   "texture (12 bytes per voxel, faster)", choices=("central_differences", "texture"), group="gpu")
TEXTURE_BUDGET_MB = Setting("texture_budget_mb", float, 2048.0, "GPU texture memory allowed; larger volumes are "
                            "rendered in bricks", check=positive, units="MB", group="gpu", flag=False)
MEMORY_BUDGET_MB = Setting("memory_budget_mb", float, out_of_core.MEMORY_BUDGET_MB,
                           "host memory allowed for the volume's resident voxels; larger volumes are read out of "
                           "core (volume.out_of_core, docs/out-of-core.md)",
                           check=positive, units="MB", group="gpu", flag=False)

#: Every renderer reads these (narrowed where it supports fewer choices).
MODEL_SETTINGS = (COMPOSITING, CLASSIFICATION, ASSOCIATED_COLORS, FILTER, KERNEL_WIDTH, KERNEL_RADIUS, ISO_VALUE,
                  GRADIENT_OPACITY, GRADIENT_OPACITY_REFERENCE, SHADING, DEPTH_CUE, HEMISPHERICAL_SHADING, SCATTERING,
                  CLIPPING, GEOMETRY)


# --- resolution ------------------------------------------------------------------------------

def _check_scattering_with(spec) -> None:
    """Scattering is a source term of emission-absorption: refused with the modes that have none, and
    with gradient shading, which lights the same samples another way."""
    sc = getattr(spec, "scattering", None)
    if sc is None or not sc.enabled:
        return
    if spec.compositing != "emission_absorption":
        raise SceneError(f"renderer.scattering lights emission-absorption only, not compositing = "
                         f"{spec.compositing!r}: set renderer.scattering.enabled = false or compositing = "
                         f"'emission_absorption'")
    if spec.shading.enabled:
        raise SceneError("renderer.scattering and renderer.shading both light the samples: turn one off "
                         "(renderer.shading.enabled = false)")
    if clipping_in_use(getattr(spec, "clipping", None)):
        raise SceneError("renderer.clipping with renderer.scattering: the lights' rays are not clipped yet (a "
                         "clipped part would still cast shadows); turn one of them off")


DEFAULT_ALBEDO = 0.8


def albedo_column(spec, transfer_function) -> bool:
    """Whether single scattering reads the albedo from the transfer function's sixth column: asked for by
    name, or by default where the points have one (a number given overrides it)."""
    albedo = spec.scattering.albedo
    return albedo == "transfer_function" or (albedo is None and transfer_function.has_albedo)


def constant_albedo(spec) -> float:
    """The albedo when it is one number: the one given, or the default."""
    albedo = spec.scattering.albedo
    return DEFAULT_ALBEDO if albedo is None or isinstance(albedo, str) else float(albedo)


def check_albedo(spec, transfer_function) -> None:
    """An albedo column asked for must exist, and is looked up per sample (post or pre-integrated
    classification: the pre-classified voxels hold colour and extinction only)."""
    sc = getattr(spec, "scattering", None)
    if sc is None or not sc.enabled or spec.compositing != "emission_absorption":
        return
    if sc.albedo == "transfer_function" and not transfer_function.has_albedo:
        raise SceneError("renderer.scattering.albedo = 'transfer_function' reads the points' sixth column, and "
                         "these have five: give [value, r, g, b, opacity, albedo] rows, or the albedo as a number")
    if albedo_column(spec, transfer_function) and spec.classification == "pre":
        raise SceneError("renderer.scattering: the transfer function's albedo column is looked up per sample, "
                         "and classification = 'pre' classifies the voxels: use post or preintegrated, or give "
                         "renderer.scattering.albedo as a number")


def shadow_step(spec, field) -> float:
    """The shadow rays' segment length, world units: ``scattering.shadow_step_voxels`` of the field's voxel,
    or the sample distance."""
    voxels = spec.scattering.shadow_step_voxels
    return spec.sample_distance if voxels is None else voxels * field.sample_spacing


def _sample_distance_key(spec) -> tuple:
    """The sample distance's key and value as the scene gives it (in voxels where so given; else in world units)."""
    if spec.sample_distance is None and spec.sample_distance_voxels is not None:
        return "sample_distance_voxels", spec.sample_distance_voxels
    return ("sample_distance",)


def resolve_sample_distance(spec, field) -> float:
    """The sample distance in world units: ``sample_distance``, or ``sample_distance_voxels`` (default
    0.5) times the field's voxel; the one place that turns voxels into world units."""
    if spec.sample_distance is not None and spec.sample_distance_voxels is not None:
        raise SceneError("renderer: give sample_distance or sample_distance_voxels, not both")
    if spec.sample_distance is not None:
        return spec.sample_distance
    voxels = spec.sample_distance_voxels if spec.sample_distance_voxels is not None else DEFAULT_SAMPLE_DISTANCE_VOXELS
    return voxels * field.sample_spacing


#: The longest sample distance, in diagonals of the field's box: past one diagonal a ray takes one sample
#: already; far past it float32 breaks (a distance of 1e39 overflowed to a black image).
MAX_SAMPLE_DIAGONALS = 1e6


def max_sample_distance(field) -> float:
    """The longest sample distance (world units) allowed for ``field``: :data:`MAX_SAMPLE_DIAGONALS` diagonals."""
    return MAX_SAMPLE_DIAGONALS * max(diagonal(field), field.sample_spacing)


def check_sample_distance(world: float, field, key: str = "sample_distance", given=None) -> float:
    """``world`` (the sample distance, world units) if positive and at most :data:`MAX_SAMPLE_DIAGONALS` times
    the field's diagonal; ``key`` and ``given`` name the setting as the user wrote it (one in voxels)."""
    given = world if given is None else given
    if world is None or not world > 0:  # each factor was checked positive; their product can underflow to 0
        raise SceneError(f"renderer.{key} must be positive, got {given}")
    limit = max_sample_distance(field)
    if not world <= limit:
        world_units = "" if key == "sample_distance" else f" ({world:.3g} world units)"
        raise SceneError(f"renderer.{key} = {given:g}{world_units} is over {limit:.3g} world units, "
                         f"{MAX_SAMPLE_DIAGONALS:g} times the volume's diagonal (one diagonal already takes one "
                         f"sample a ray); give less")
    return world


def resolve_renderer(spec, field, settings):
    """``spec`` with every declared setting checked and the data-dependent defaults made explicit:
    the sample distance in world units (``sample_distance_voxels`` dropped), the iso-value (middle of
    the value range) where the compositing is ``isosurface``, and the gradient-opacity reference (0.1 of
    the range per voxel) where gradient opacity is on.  Otherwise those two stay as given (``None`` by
    default) and the field's value range is not read; resolving again after a change (an isosurface asked
    for later) fills them then."""
    for setting in settings:
        setting.validate(getattr(spec, setting.name))
    d = check_sample_distance(resolve_sample_distance(spec, field), field, *_sample_distance_key(spec))
    if spec.classification == "preintegrated" and spec.compositing == "xray":
        raise SceneError("renderer.classification = preintegrated does not apply to xray (its tables attenuate "
                         "within a segment); use post or pre")
    if spec.classification == "preintegrated" and spec.jitter:
        raise SceneError("renderer.jitter does not apply to pre-integrated classification (which needs no "
                         "jitter against wood-grain); turn one of them off")
    _check_scattering_with(spec)
    iso, g_ref = spec.iso_value, spec.gradient_opacity_reference
    needs_iso = iso is None and spec.compositing == "isosurface"
    needs_g_ref = g_ref is None and spec.gradient_opacity
    # the value range only where a default reads it: a million SPH particles' is the interpolant at each of them
    if needs_iso or needs_g_ref:
        lo, hi = field.value_range
        if needs_iso:
            iso = (lo + hi) / 2.0
        if needs_g_ref:
            g_ref = 0.1 * max(hi - lo, 1e-30) / field.sample_spacing
    return dataclasses.replace(spec, sample_distance=d, sample_distance_voxels=None, iso_value=iso,
                               gradient_opacity_reference=g_ref)


def with_sample_distance(renderer_spec, field, world: float | None = None, voxels: float | None = None,
                         factor: float | None = None):
    """Renderer settings with another sample distance (world units, voxels, or a factor of the
    current one), checked as a scene file's would be."""
    if voxels is not None:
        world = resolve_sample_distance(dataclasses.replace(renderer_spec, sample_distance=None,
                                                            sample_distance_voxels=voxels), field)
    elif factor is not None:  # a coarser preview (the viewer's refinement): at most the longest allowed
        world = min(renderer_spec.sample_distance * factor, max_sample_distance(field))
    check_sample_distance(world, field, *(("sample_distance_voxels", voxels) if voxels is not None else ()))
    # a distance given by hand replaces what excludes it (one in voxels; a tolerance, which chose one)
    dropped = dict.fromkeys(exclusive_keys(renderer_spec, SAMPLE_DISTANCE.name))
    return dataclasses.replace(renderer_spec, **dropped, sample_distance=float(world))

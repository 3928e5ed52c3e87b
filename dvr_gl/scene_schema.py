"""Scene file schema: the TOML tables as dataclasses, with strict parsing.

Every table is a dataclass; its fields are the valid keys.  Parsing checks
names and types and names the offending key; unknown keys list the valid
ones.  ``choices`` in a field's metadata restrict string values.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from dataclasses import dataclass, field
from typing import Optional, Union

from .errors import SceneError

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]


def choices(*values, default=dataclasses.MISSING, doc: str = ""):
    return field(default=default, metadata={"choices": values, "doc": doc})


COMPOSITING_MODES = ("emission_absorption", "isosurface", "average", "mip", "minip")
FILTERS = ("nearest", "linear", "cubic_bspline", "catmull_rom")
CLASSIFICATIONS = ("post", "pre", "preintegrated")
ORDERS = ("front_to_back", "back_to_front")


@dataclass
class LightSpec:
    """A light: ``headlight`` (from the eye, along each ray) or ``directional``."""

    type: str = choices("headlight", "directional", default="headlight")
    direction: Vec3 = (0.0, 0.0, -1.0)   # directional: the direction the light travels (world)
    color: Vec3 = (1.0, 1.0, 1.0)        # linear RGB intensity


@dataclass
class ShadingSpec:
    """Blinn-Phong shading from the gradient (emission-absorption and isosurface)."""

    enabled: bool = False
    ambient: float = 0.2
    diffuse: float = 0.7
    specular: float = 0.3
    shininess: float = 32.0
    two_sided: bool = True
    lights: list[LightSpec] = field(default_factory=lambda: [LightSpec()])


@dataclass
class RendererSpec:
    """The renderer and its settings (each renderer uses those that apply to it)."""

    name: str = "raycast"
    sample_distance: Optional[float] = None           # world units
    sample_distance_voxels: Optional[float] = None    # in voxels of the smallest spacing (default 0.5)
    tolerance: Optional[float] = None                 # RMS error to meet: chooses sample distance,
                                                      # classification and early termination (raycast)
    compositing: str = choices(*COMPOSITING_MODES, default="emission_absorption")
    order: str = choices(*ORDERS, default="front_to_back")
    classification: str = choices(*CLASSIFICATIONS, default="post")
    associated_colors: bool = True                    # pre-classification: interpolate sigma*c, not c
    preintegration: str = choices("exact", "fast", default="exact")  # pre-integrated table: exact or Engel's
    preintegration_size: int = 256                    # pre-integrated table: entries per axis
    filter: str = choices(*FILTERS, default="linear")
    filtering: str = choices("hardware", "shader", default="hardware")  # GPU: texture unit or float weights
    gradient: str = choices("central_differences", "texture", default="central_differences")
    gradient_opacity: bool = False                    # scale extinction by min(1, |gradient| / reference)
    gradient_opacity_reference: Optional[float] = None  # default: 0.1 value range per smallest spacing
    iso_value: Optional[float] = None                 # isosurface; default: middle of the value range
    iso_refinement: int = 8                           # bisection steps refining the first hit
    jitter: bool = False
    jitter_seed: int = 0
    ert_threshold: float = 0.99                       # early ray termination at accumulated opacity
    lut_size: int = 4096                              # transfer-function table entries
    converged_tolerance: float = 1e-4                 # reference-converged: error budget per pixel
    texture_budget_mb: float = 2048.0                 # GPU: largest texture memory to use (MB)
    acceleration: bool = True                         # GPU: jump empty and constant blocks (same image)
    block_size: int = 8                               # voxels per block edge (4, 8, 16 or 32)
    homogeneity_tolerance: float = 0.0                # > 0: also jump nearly constant blocks (approximate)
    opacity_threshold: float = 0.0                    # shearwarp: voxels at most this opaque are skipped
    shading: ShadingSpec = field(default_factory=ShadingSpec)


@dataclass
class VolumeSpec:
    """Where the volume comes from: a file (``path``) or a built-in phantom (``demo``)."""

    path: Optional[str] = None
    demo: Optional[str] = None
    size: int = 64                          # demo volumes: samples per axis
    format: str = choices("auto", "raw", "nrrd", "nifti", "metaimage", "vtk", "npy", "tiff", default="auto")
    dims: Optional[tuple[int, int, int]] = None  # raw: (nx, ny, nz)
    dtype: Optional[str] = None                  # raw: uint8, int16, uint16, float32, ...
    endian: str = choices("little", "big", default="little")
    header_bytes: int = 0
    spacing: Optional[Vec3] = None          # override the file's spacing
    origin: Optional[Vec3] = None           # override the file's origin
    nan_value: Optional[float] = None       # replace NaN/Inf by this value (else they are an error)


@dataclass
class TransferFunctionSpec:
    """A preset by name, or explicit ``points = [[value, r, g, b, opacity], ...]``."""

    preset: Optional[str] = None
    points: Optional[list[list[float]]] = None
    unit_distance: float = 1.0
    opacity_model: str = choices("alpha", "extinction", default="alpha")
    rescale_intercept: float = 0.0          # CT presets: HU = data + rescale_intercept


@dataclass
class CameraSpec:
    """Look-at (``eye``) and/or orbit (``azimuth``, ``elevation``, ``distance``) about ``target``.

    With both, the orbit keys given replace the matching parameters of the eye's orbit.
    """

    projection: str = choices("perspective", "orthographic", default="perspective")
    fov: float = 30.0
    view_height: Optional[float] = None
    eye: Optional[Vec3] = None
    target: Optional[Vec3] = None
    up: Vec3 = (0.0, 0.0, 1.0)
    azimuth: Optional[float] = None
    elevation: Optional[float] = None
    distance: Optional[float] = None
    near: float = 0.0


@dataclass
class ImageSpec:
    width: int = 256
    height: int = 256
    background: Vec4 = (0.0, 0.0, 0.0, 1.0)   # linear RGBA, not premultiplied


@dataclass
class SceneSpec:
    volume: VolumeSpec = field(default_factory=VolumeSpec)
    transfer_function: TransferFunctionSpec = field(default_factory=TransferFunctionSpec)
    camera: CameraSpec = field(default_factory=CameraSpec)
    image: ImageSpec = field(default_factory=ImageSpec)
    renderer: RendererSpec = field(default_factory=RendererSpec)


# --- parsing ------------------------------------------------------------------------------------

def _type_name(tp) -> str:
    origin = typing.get_origin(tp)
    if origin in (Union, types.UnionType):
        return " or ".join(_type_name(a) for a in typing.get_args(tp) if a is not type(None))
    if origin is tuple:
        return f"a list of {len(typing.get_args(tp))} numbers"
    if origin is list:
        return "a list"
    if dataclasses.is_dataclass(tp):
        return "a table"
    return {float: "a number", int: "an integer", bool: "true or false", str: "a string"}.get(tp, str(tp))


def _convert(value, tp, where: str):
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        return _convert(value, inner[0], where)
    bad = SceneError(f"{where}: expected {_type_name(tp)}, got {value!r}")
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise bad
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise bad
        return value
    if tp in (bool, str):
        if not isinstance(value, tp):
            raise bad
        return value
    if origin is tuple:
        if not isinstance(value, (list, tuple)) or len(value) != len(args):
            raise bad
        return tuple(_convert(v, a, f"{where}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
    if origin is list:
        if not isinstance(value, (list, tuple)):
            raise bad
        return [_convert(v, args[0], f"{where}[{i}]") for i, v in enumerate(value)]
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise bad
        return parse_table(tp, value, where)
    raise TypeError(f"schema type {tp} not handled")


def parse_table(cls, table: dict, where: str):
    """Build dataclass ``cls`` from a TOML table, checking every key and value."""
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs = {}
    for key, value in table.items():
        if key not in fields:
            raise SceneError(f"{where}: unknown key {key!r}; valid keys are {', '.join(fields)}")
        here = f"{where}.{key}" if where else key
        converted = _convert(value, hints[key], here)
        allowed = fields[key].metadata.get("choices")
        if allowed and converted not in allowed:
            raise SceneError(f"{here}: {converted!r} is not one of {', '.join(map(str, allowed))}")
        kwargs[key] = converted
    return cls(**kwargs)


def spec_to_dict(obj) -> dict:
    """A dataclass tree as nested dicts for TOML, without None values."""
    out = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if v is None:
            continue
        if dataclasses.is_dataclass(v):
            v = spec_to_dict(v)
        elif isinstance(v, list) and v and dataclasses.is_dataclass(v[0]):
            v = [spec_to_dict(x) for x in v]
        elif isinstance(v, tuple):
            v = list(v)
        out[f.name] = v
    return out

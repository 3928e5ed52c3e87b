"""Scene file schema: the TOML tables as dataclasses, with strict parsing.

Every table is a dataclass; its fields are the valid keys.  Parsing checks
names and types and names the offending key; unknown keys list the valid
ones.  ``choices`` in a field's metadata restrict string values.  The
``[renderer]`` table is the union of what the registered renderers declare
(:mod:`dvr_gl.scene.settings`, :mod:`dvr_gl.renderers.registry`);
``docs/scene-files.md`` is generated from these declarations
(:mod:`dvr_gl.scene.reference`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
import typing
from dataclasses import dataclass, field
from typing import Optional, Union

from ..camera import LENS_CHECKS
from ..checks import at_least, between, world_coordinates, world_length
from ..errors import SceneError
from ..orientation import ANATOMICAL_VIEWS
from .model import choices, doc

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]


class RendererTable:
    """Marks the ``[renderer]`` table: its dataclass is built from the renderer registry (the union of
    the settings every registered renderer declares: :func:`dvr_gl.renderers.registry.renderer_spec_class`)."""


def checked(default, text: str, check):
    """A documented field whose parsed value must pass ``check`` (a phrase completing "<key> ...", as
    :class:`dvr_gl.scene.settings.Setting` checks are; None when the value is fine)."""
    return dataclasses.field(default=default, metadata={"doc": text, "check": check})


def each(check):
    """``check`` applied to every component of a list value (spacing, dims, a colour)."""
    def check_all(values):
        return next((p for p in map(check, values) if p), None)
    return check_all


def non_zero(vector) -> str | None:
    return None if any(vector) else "must be a non-zero vector"


def auto_or_bool(value) -> str | None:
    return None if value is True or value is False or value == "auto" else "must be auto, true or false"


def renderer_spec_class():
    from ..renderers.registry import renderer_spec_class as build

    return build()


def default_renderer_spec():
    return renderer_spec_class()()


@dataclass
class VolumeSpec:
    """Where the volume comes from: a file (``path``) or a built-in phantom (``demo``)."""

    path: Optional[str] = doc(None, "a volume file (relative to the scene file); or give `demo`", excludes=("demo",))
    demo: Optional[str] = doc(None, "a built-in phantom: `shepp-logan`, `marschner-lobb`, `blobs`, or `plummer` "
                                    "(SPH particles)")
    size: int = checked(64, "samples per axis of a demo phantom (`plummer`: (size / 2)^3 particles)", at_least(2))
    format: str = choices("auto", "raw", "nrrd", "nifti", "metaimage", "vtk", "npy", "tiff", "dicom", "vti", "zarr",
                          "vtu", "plot3d", "csv", "npz", "hdf5", default="auto",
                          doc="the reader; `auto` goes by the suffix (`.vtk` by its dataset, a folder by its files: "
                              "DICOM, TIFF or zarr)")
    dims: Optional[tuple[int, int, int]] = checked(None, "raw files: `[nx, ny, nz]`", each(at_least(1)))
    dtype: Optional[str] = doc(None, "raw files: `uint8`, `int8`, `uint16`, `int16`, `uint32`, `int32`, "
                                     "`float32`, `float64`")
    endian: str = choices("little", "big", default="little", doc="raw files: byte order")
    header_bytes: int = checked(0, "raw files: bytes to skip before the data", at_least(0))
    spacing: Optional[Vec3] = checked(None, "override the file's spacing (world units, x first)",
                                      each(world_length))
    origin: Optional[Vec3] = checked(None, "override the file's origin (world units, x first)", world_coordinates)
    nan_value: Optional[float] = doc(None, "replace NaN/Inf by this value; without it they are an error")
    array: Optional[str] = doc(None, "meshes: the scalar array to render (default: the first one-component "
                                     "array of finite values); SPH particles: the quantity (default: the density); "
                                     "`.vti`: the point-data array (default: the first); zarr: the array's path in "
                                     "its group")
    series: Optional[str] = doc(None, "DICOM: the series to read (its SeriesNumber or SeriesInstanceUID) when a "
                                      "folder holds several")
    level: Optional[int] = checked(None, "OME-Zarr: the resolution level (0, the default, is the full resolution)",
                                   at_least(0))
    solution: Optional[str] = doc(None, "PLOT3D grids: the q (solution) file (default: the grid's name with "
                                        "`xyz` replaced by `q`)")
    resample: Optional[int] = checked(None, "meshes: resample onto a grid of this many points along the longest "
                                            "axis (2 to 1024), for the grid renderers", between(2, 1024))
    out_of_core: Union[bool, str] = checked("auto", "read the voxels in part, brick by brick, never whole "
                                            "(docs/out-of-core.md): `auto` when they exceed "
                                            "`renderer.memory_budget_mb` and the format is read in part (raw, NRRD "
                                            "and MetaImage uncompressed, zarr), `true` always, `false` never",
                                            auto_or_bool)
    channel: Optional[int] = checked(None, "a file with channels (OME-Zarr `c`, an ImageJ/OME hyperstack, NIfTI "
                                           "4D/5D): the one to render (0 first); default: every channel, each a "
                                           "field composited per sample (docs/several-fields.md)", at_least(0))
    time: Optional[int] = checked(None, "a time series (OME-Zarr `t`, a hyperstack's frames, NIfTI 4D, a glob of "
                                        "files): the step to render (0 first; default 0)", at_least(0))
    fourth_axis: Optional[str] = choices("auto", "channel", "time", default=None,
                                         doc="NIfTI 4D: what the 4th axis (dim[4]) holds: `auto` (the default) by "
                                             "the header's intent (a vector: channels; otherwise time), or "
                                             "`channel` or `time` (docs/formats.md)")
    iso_value: Optional[float] = doc(None, "isosurface of several fields: this field's iso-value, data units "
                                           "(default: `renderer.iso_value` for the first field, the middle of "
                                           "its value range for the others)")
    role: str = choices("scalar", "label", "rgb", default="scalar",
                        doc="how a sample is classified: a value through the transfer function, a `label` map "
                            "through a colour table (docs/labels.md), or an `rgb` colour volume")


@dataclass
class TransferFunctionSpec:
    """A preset by name, a file, or explicit ``points = [[value, r, g, b, opacity], ...]``."""

    preset: Optional[str] = doc(None, "a name, any case: `grayscale`, `viridis`, `ct-bone-ivory`, `ct-skin`, "
                                      "`shepp-logan`, 3D Slicer's presets (`CT-AAA`, `MR-Default`, ...), a matplotlib "
                                      "colour map (default `grayscale`; `shepp-logan` for that demo; "
                                      "docs/transfer-functions.md)",
                                excludes=("points", "file", "name", "stretch"))
    file: Optional[str] = doc(None, "a Slicer `.vp` or presets `.xml`, or a ParaView colour-map `.json` "
                                    "(relative to the scene file); a label map (`volume.role = \"label\"`): a "
                                    "colour table, Slicer `.ctbl`/`.txt`, ITK-SNAP `.txt`/`.label` or a Slicer "
                                    "`.seg.nrrd` (docs/labels.md)", excludes=("points", "preset"))
    name: Optional[str] = doc(None, "with `file`: which of the file's maps or presets (any case)")
    stretch: Optional[bool] = doc(None, "stretch the file's values onto the data's value range (default: "
                                        "ParaView JSON yes, Slicer files no)")
    points: Optional[list[list[float]]] = doc(None, "`[[value, r, g, b, opacity], ...]`, values strictly "
                                                    "increasing, data units; or give `preset`; a sixth column "
                                                    "is scattering's albedo (docs/scattering.md)",
                                              excludes=("preset", "file", "name", "stretch"))
    labels: Optional[list[list[float]]] = doc(None, "a label map (`volume.role = \"label\"`): `[[label, r, g, b, "
                                                    "opacity], ...]`, colour linear; labels not listed (and 0 unless "
                                                    "listed) are transparent (docs/labels.md)",
                                              excludes=("points", "preset", "file", "name", "stretch"))
    unit_distance: Optional[float] = checked(None, "world length that `alpha` refers to (default: one voxel of the "
                                                   "data, its smallest spacing; docs/conventions.md)", world_length)
    opacity_model: str = choices("alpha", "extinction", default="alpha",
                                 doc="what the 5th column means: `alpha` per `unit_distance`, or `extinction` sigma")
    rescale_intercept: float = doc(0.0, "CT presets and Slicer files: HU = data + intercept (-1024 for CT "
                                        "stored as unsigned HU + 1024)")
    table_2d: Optional[list[list[list[float]]]] = doc(
        None, "a 2D transfer function over value and gradient magnitude: NV x NG nodes `[r, g, b, opacity]` "
              "(rows over value), bilinear between them (docs/transfer-functions.md); a ParaView state `.pvsm` "
              "as `file` gives one too", excludes=("points", "preset", "file", "name", "stretch", "boxes_2d"))
    boxes_2d: Optional[list[list[float]]] = doc(
        None, "a 2D transfer function as ParaView's boxes `[value, gradient, width, height, r, g, b, alpha]`, "
              "drawn on a table of `size_2d` nodes", excludes=("points", "preset", "file", "name", "stretch",
                                                              "table_2d"))
    value_range_2d: Optional[list[float]] = doc(None, "a 2D transfer function's value axis `[lo, hi]` (default: "
                                                      "the data's range; a .pvsm file's Range)",
                                                excludes=("points", "preset"))
    gradient_range_2d: Optional[list[float]] = doc(None, "a 2D transfer function's gradient-magnitude axis `[lo, "
                                                         "hi]`, value units per world unit (default: 0 to the "
                                                         "boxes' top; 0 to 1 for table_2d)",
                                                   excludes=("points", "preset"))
    size_2d: Optional[list[int]] = doc(None, "the nodes boxes are drawn on, `[NV, NG]` (default [256, 64])",
                                       excludes=("points", "preset"))


@dataclass
class KeyframeSpec:
    """A camera of a path (``[[camera.keyframe]]``): the ``[camera]`` table's keys it gives replace that table's
    (one that gives ``eye`` is a look-at: the table's orbit keys are dropped), at ``time`` seconds; between
    keyframes the camera turns on the sphere (docs/cli.md, Camera paths; :mod:`dvr_gl.camera_path`)."""

    time: Optional[float] = checked(None, "seconds along the path (required; increasing from one keyframe to the "
                                          "next)", between(-1e9, 1e9))
    eye: Optional[Vec3] = checked(None, "look-at: the eye (world)", world_coordinates)
    target: Optional[Vec3] = checked(None, "what the camera looks at (default: the `[camera]` table's)",
                                     world_coordinates)
    up: Optional[Vec3] = checked(None, "the up direction (default: the `[camera]` table's)", non_zero)
    azimuth: Optional[float] = checked(None, "orbit about the target, degrees", between(-1e6, 1e6))
    elevation: Optional[float] = checked(None, "orbit elevation, degrees", between(-90, 90))
    view: Optional[str] = choices(*ANATOMICAL_VIEWS, default=None, doc="an anatomical view (sets azimuth and "
                                                                       "elevation)", excludes=("azimuth", "elevation"))
    distance: Optional[float] = checked(None, "eye to target, world units", world_length)
    fov: Optional[float] = checked(None, "vertical field of view, degrees (perspective)", LENS_CHECKS["fov"])
    view_height: Optional[float] = checked(None, "view height, world units (orthographic)",
                                           LENS_CHECKS["view_height"])
    step: Optional[int] = checked(None, "a time series: the step shown at this keyframe (0 first; between "
                                        "keyframes it follows the time linearly, rounded down; in every keyframe or "
                                        "none)", between(0, 10**9))


@dataclass
class CameraSpec:
    """Look-at (``eye``) and/or orbit (``azimuth``, ``elevation``, ``distance``) about ``target``.

    With both, the orbit keys given replace the matching parameters of the eye's orbit.
    """

    projection: str = choices("perspective", "orthographic", default="perspective", doc="the projection")
    fov: float = checked(30.0, "vertical field of view, degrees (perspective)", LENS_CHECKS["fov"])
    view_height: Optional[float] = checked(None, "view height, world units (orthographic; default: frames the "
                                                 "data)", LENS_CHECKS["view_height"])
    eye: Optional[Vec3] = checked(None, "look-at: the eye (world)", world_coordinates)
    target: Optional[Vec3] = checked(None, "what the camera looks at (default: the box centre)", world_coordinates)
    up: Vec3 = checked((0.0, 0.0, 1.0), "the up direction", non_zero)
    azimuth: Optional[float] = doc(None, "orbit about the target, degrees (default 30); with `eye`, replaces "
                                         "the eye's")
    elevation: Optional[float] = doc(None, "orbit elevation, degrees (default 20)")
    view: Optional[str] = choices(*ANATOMICAL_VIEWS, default=None,
                                  doc="an anatomical view (sets azimuth and elevation about `up`; with the "
                                      "default up, superior, it shows the patient upright: docs/orientation.md)",
                                  excludes=("azimuth", "elevation"))
    distance: Optional[float] = checked(None, "eye to target, world units (default: frames the data)",
                                        world_length)
    near: float = checked(0.0, "near plane distance from the eye; rays start there or at the data",
                         LENS_CHECKS["near"])
    keyframe: list[KeyframeSpec] = doc(None, "`[[camera.keyframe]]` tables: a camera path that `--frames` "
                                             "renders (at least two; see below)", factory=list)


@dataclass
class ImageSpec:
    width: int = checked(256, "pixels", at_least(1))
    height: int = checked(256, "pixels", at_least(1))
    background: Vec4 = checked((0.0, 0.0, 0.0, 1.0), "linear RGBA, not premultiplied; composited once, after "
                                                      "rendering", each(between(0.0, 1.0)))


@dataclass
class LayerSpec(VolumeSpec):
    """A further field of a scene of several (the second and later ``[[volume]]`` tables): a volume's keys and
    its own ``[volume.transfer_function]``."""

    transfer_function: TransferFunctionSpec = field(default_factory=TransferFunctionSpec)


@dataclass
class SceneSpec:
    volume: VolumeSpec = field(default_factory=VolumeSpec)
    transfer_function: TransferFunctionSpec = field(default_factory=TransferFunctionSpec)
    camera: CameraSpec = field(default_factory=CameraSpec)
    image: ImageSpec = field(default_factory=ImageSpec)
    renderer: RendererTable = field(default_factory=default_renderer_spec)
    #: the second and later ``[[volume]]`` tables (:func:`split_volume_tables`); a scene file writes them all as
    #: ``[[volume]]``, the first one's transfer function in it
    volumes: list[LayerSpec] = field(default_factory=list)


def split_volume_tables(raw: dict) -> dict:
    """A scene dict whose ``volume`` is an array of tables (``[[volume]]``: several fields, each with its own
    ``transfer_function`` table) as the schema reads it: the first as ``volume`` (its transfer function as the
    scene's ``transfer_function``), the others as ``volumes``.  Other dicts unchanged."""
    tables = raw.get("volume")
    if not isinstance(tables, list):
        return raw
    if not tables or not all(isinstance(t, dict) for t in tables):
        raise SceneError("volume: expected a table, or an array of tables ([[volume]]) each naming a field")
    if "volumes" in raw:
        raise SceneError("volumes: write every field as a [[volume]] table")
    out = dict(raw)
    first = dict(tables[0])
    tf = first.pop("transfer_function", None)
    if tf is not None:
        if "transfer_function" in raw:
            raise SceneError("transfer_function and volume[0].transfer_function were both given: give the first "
                             "field's transfer function in its [[volume]] table")
        out["transfer_function"] = tf
    out["volume"] = first
    out["volumes"] = [dict(t) for t in tables[1:]]
    return out


# --- parsing ------------------------------------------------------------------------------------

def _type_name(tp) -> str:
    origin = typing.get_origin(tp)
    if origin in (Union, types.UnionType):
        return " or ".join(_type_name(a) for a in typing.get_args(tp) if a is not type(None))
    if origin is tuple:
        return f"a list of {len(typing.get_args(tp))} numbers"
    if origin is list:
        return "a list"
    if dataclasses.is_dataclass(tp) or tp is RendererTable:
        return "a table"
    return {float: "a number", int: "an integer", bool: "true or false", str: "a string"}.get(tp, str(tp))


def _clamped(n: int) -> float:
    """An int as a float, infinite when too large for one (Python's float() raises instead)."""
    try:
        return float(n)
    except OverflowError:
        return math.inf


def _convert(value, tp, where: str):
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return _convert(value, inner[0], where)
        # a number or a name (scattering's albedo), true/false or a name (volume.out_of_core): the value's
        # own type picks the one to check
        if isinstance(value, str) and str in inner:
            return value
        if isinstance(value, bool) and bool in inner:
            return value
        if isinstance(value, (int, float)) and not isinstance(value, bool) and float in inner:
            return _convert(value, float, where)
        raise SceneError(f"{where}: expected {_type_name(tp)}, got {value!r}")
    bad = SceneError(f"{where}: expected {_type_name(tp)}, got {value!r}")
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise bad
        if not math.isfinite(value if isinstance(value, float) else _clamped(value)):
            raise SceneError(f"{where} must be a finite number, got {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise bad
        if not -2**63 <= value < 2**63:  # what TOML allows; larger ones overflow every consumer
            raise SceneError(f"{where} must be an integer of at most 64 bits, got {value}")
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
    if tp is RendererTable:
        tp = renderer_spec_class()
        value = flat_renderer_table(value, tp) if isinstance(value, dict) else value
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise bad
        return parse_table(tp, value, where)
    raise TypeError(f"schema type {tp} not handled")


@functools.cache
def type_hints(cls) -> dict:
    """``typing.get_type_hints(cls)``, evaluated once per class (it evaluates every annotation's string on
    each call: 58 of the 88 s that 1789 load_scene calls took in the shader-variant test, measured
    2026-11-28).  Read only: the dict is shared."""
    return typing.get_type_hints(cls)


def parse_table(cls, table: dict, where: str):
    """Build dataclass ``cls`` from a TOML table, checking every key and value."""
    hints = type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs = {}
    for key, value in table.items():
        if key not in fields:
            raise SceneError(f"{where}: unknown key {key!r}; valid keys are {', '.join(fields)}")
        here = f"{where}.{key}" if where else key
        for old, new in fields[key].metadata.get("aliases", ()):
            if type(value) is type(old) and value == old:
                value = new
        converted = _convert(value, hints[key], here)
        allowed = fields[key].metadata.get("choices")
        if allowed and converted not in allowed:
            raise SceneError(f"{here}: {converted!r} is not one of {', '.join(map(str, allowed))}")
        check = fields[key].metadata.get("check")
        problem = check(converted) if check and converted is not None else None
        if problem:
            shown = list(converted) if isinstance(converted, tuple) else converted
            raise SceneError(f"{here} {problem}, got {shown!r}")
        kwargs[key] = converted
    return cls(**kwargs)


# --- a renderer's own keys ---------------------------------------------------------------------

def owned_keys(renderer_table) -> dict[str, str]:
    """The ``[renderer]`` keys that a renderer owns (declared in its own folder), each with its owner:
    ``{"tolerance": "raycast", ...}`` (``renderer_table``: the RendererSpec class or one of them)."""
    return {f.name: f.metadata["owner"] for f in dataclasses.fields(renderer_table) if f.metadata.get("owner")}


def own_settings(renderer) -> types.SimpleNamespace:
    """Renderer settings ``renderer``'s own renderer owns, as its namespace (``scene.own.block_size``)."""
    return types.SimpleNamespace(**{k: getattr(renderer, k) for k, owner in owned_keys(renderer).items()
                                    if owner == renderer.name})


def flat_renderer_table(table: dict, cls) -> dict:
    """A ``[renderer]`` table with its renderers' own tables (``[renderer.raycast] tolerance = 0.01``)
    read as the flat keys they spell (``renderer.tolerance``, the canonical spelling).  Refused, in
    one line: a key the table's renderer does not own, one owned by another renderer than the scene's
    ``renderer.name``, and a key given in both spellings."""
    owners = owned_keys(cls)
    spaces = set(owners.values())
    out = {k: v for k, v in table.items() if not (k in spaces and isinstance(v, dict))}
    for space, keys in table.items():
        if space not in spaces or not isinstance(keys, dict):
            continue
        for key, value in keys.items():
            where = f"renderer.{space}.{key}"
            if owners.get(key) != space:
                whose = (f"it is {owners[key]}'s: renderer.{owners[key]}.{key}" if key in owners else
                         f"write renderer.{key}" if key in {f.name for f in dataclasses.fields(cls)} else
                         f"its own are {', '.join(k for k, o in owners.items() if o == space)}")
                raise SceneError(f"{where}: {key!r} is not a setting of {space}'s own; {whose}")
            if table.get("name") != space:
                named = f"is {table['name']!r}" if table.get("name") is not None else "is not named (renderer.name)"
                raise SceneError(f"{where} is {space}'s own setting, and the scene's renderer {named}: remove it "
                                 f"or set renderer.name = {space!r}")
            if key in table:
                raise SceneError(f"renderer.{key} and {where} were both given: give one")
            out[key] = value
    return out


def tables_as_specs(spec, changes: dict, where: str) -> dict:
    """``changes`` to dataclass ``spec`` with each table given as a dict (or a list of them: meshes)
    read as a scene file's would be (``with_renderer(clipping={"planes": ...})``); other values as
    they are."""
    hints = type_hints(type(spec))

    def is_table(value):
        return isinstance(value, dict) or (isinstance(value, list) and any(isinstance(v, dict) for v in value))

    return {key: _convert(value, hints[key], f"{where}.{key}") if key in hints and is_table(value) else value
            for key, value in changes.items()}


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

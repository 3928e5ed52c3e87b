"""Scenes: what to render, read from TOML, resolved into the model, saved back.

``load_scene_spec`` reads and checks a file; ``apply_overrides`` changes keys
(the CLI's flags); ``resolve_scene`` loads the field, expands presets and
defaults, and returns a :class:`Scene` whose :meth:`Scene.to_toml` is the
*effective* scene: every value explicit, so rendering it again gives the same
image.

A :class:`Scene` remembers what was asked for (its ``spec``), so replacing its
field (``scene.replace(volume=...)``) re-frames the camera and re-resolves what
depended on the old data: a preset transfer function's range, the default
iso-value, a sample distance given in voxels.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import phantoms
from ..camera import DEFAULT_AZIMUTH, DEFAULT_ELEVATION, Camera, framing_distance, framing_view_height
from ..camera_path import CameraPath
from ..checks import WORLD_RANGE
from ..errors import DvrError, SceneError
from ..fields import diagonal
from ..io import load_field
from ..orientation import to_patient_frame, view_orbit
from ..sandbox import check_bytes, check_input_path, check_path_name
from ..toml_writer import dumps, loads_toml
from ..transfer_function import (
    TransferFunction,
    find_preset,
    from_property,
    preset,
    preset_property,
    read_transfer_function_file,
)
from ..transfer_function_2d import from_spec as transfer_function_2d
from ..transfer_function_2d import is_2d
from .model import exclusive_keys
from .schema import (
    CameraSpec,
    ImageSpec,
    KeyframeSpec,
    RendererTable,
    SceneSpec,
    TransferFunctionSpec,
    VolumeSpec,
    own_settings,
    owned_keys,
    parse_table,
    renderer_spec_class,
    spec_to_dict,
    split_volume_tables,
    tables_as_specs,
    type_hints,
)
from .settings import FILTER, check_albedo
from .settings import resolve_renderer as resolve_settings


def read_scene_dict(path: Path) -> dict:
    """The scene file's TOML: a regular file inside the sandbox's roots (:func:`dvr_gl.sandbox.check_input_path`)."""
    check_input_path(path, "scene file")
    check_bytes(os.path.getsize(path), f"{path}: the scene file", "scene files are a few kB; check the path")
    try:
        with open(path, "rb") as fh:
            return loads_toml(fh.read().decode("utf-8"), str(path))
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the scene file ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        hint = ("" if path.suffix.lower() == ".toml" else
                "; if it is a volume file, give its format: --volume FILE --format F (or volume.format)")
        raise SceneError(f"{path}: not valid TOML ({exc}){hint}") from exc
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not a UTF-8 text file ({exc})") from exc


def apply_overrides(raw: dict, overrides: dict[str, object]) -> dict:
    """A copy of the scene dict with dotted keys (``"renderer.filter"``, ``"renderer.raycast.tolerance"``) set.
    A key replaces its other spelling and the keys it excludes (:func:`dvr_gl.scene.model.exclusive_keys`:
    ``camera.view`` the orbit's angles, a sample distance a tolerance); two that exclude each other given
    together are refused."""
    out = copy.deepcopy(raw)
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if len(parts) < 2 or not all(parts):
            raise SceneError(f"override {dotted!r}: use section.key, e.g. renderer.filter")
        table, key = _overridden(parts)
        if key is not None:
            _drop(out, parts[0], key, table, keep=parts)
        node = out
        for p in parts[:-1]:
            node = node.setdefault(p, {})
            if not isinstance(node, dict):
                raise SceneError(f"override {dotted!r}: {p} is not a table")
        node[parts[-1]] = copy.deepcopy(value)  # a later dotted key must not change the caller's table
        for other in exclusive_keys(table, key) if key is not None else ():
            given = [k for k in overrides if _overridden(k.split("."))[1] == other and k.startswith(parts[0] + ".")]
            if value is not None and any(overrides[k] is not None for k in given):
                raise SceneError(f"{dotted} and {parts[0]}.{other} were both given; they exclude each other: "
                                 "give one")
            _drop(out, parts[0], other, table)
    return out


def _overridden(parts: list[str]):
    """(the table's dataclass, the key) that dotted ``parts`` set: ``section.key``, or a renderer's own key
    in its namespace (``renderer.raycast.tolerance``); (None, None) for a key inside a sub-table."""
    table = _table_class(parts[0])
    if table is None:
        return None, None
    if len(parts) == 2:
        return table, parts[1]
    if parts[0] == "renderer" and len(parts) == 3 and owned_keys(table).get(parts[2]) == parts[1]:
        return table, parts[2]
    return None, None


def _table_class(section: str):
    """The dataclass of scene table ``section`` (None for an unknown one: parsing names it)."""
    tp = type_hints(SceneSpec).get(section)
    return renderer_spec_class() if tp is RendererTable else tp


def _drop(raw: dict, section: str, key: str, table, keep=()) -> None:
    """Remove ``key`` from ``raw[section]`` in every spelling (a renderer's own key also in its namespace),
    except the one at dotted ``keep``."""
    node = raw.get(section, {})
    if not isinstance(node, dict):
        return
    if [section, key] != list(keep):
        node.pop(key, None)
    owner = owned_keys(table).get(key) if section == "renderer" else None
    space = node.get(owner)
    if isinstance(space, dict) and [section, owner, key] != list(keep):
        space.pop(key, None)
        if not space:
            node.pop(owner)


def parse_scene(raw: dict, source: str | None = None, base_dir: Path | str | None = None,
                lookup: "Lookup | None" = None) -> SceneSpec:
    """The checked spec of a scene dict; errors name the key, after ``source`` (the file) if given.
    A Slicer preset's (or file's) shading fills the ``renderer.shading`` keys the dict does not give
    (``base_dir``: where a relative ``transfer_function.file`` lies; default the working folder;
    ``lookup``: the preset or file already looked up, :func:`look_up_preset`)."""
    try:
        raw = split_volume_tables(raw)
        return parse_table(SceneSpec, _with_preset_shading(raw, Path(base_dir or Path.cwd()), lookup), "")
    except SceneError as exc:
        if source is None:
            raise
        raise SceneError(f"{source}: {exc}") from None


# --- resolution ---------------------------------------------------------------------------------

def _resolve_volume(spec: VolumeSpec, base_dir: Path, memory_budget_mb: float | None = None):
    """The field the spec names; a grid too large for ``memory_budget_mb`` (renderer.memory_budget_mb) read out
    of core where its format allows (``volume.out_of_core``: :mod:`dvr_gl.out_of_core`)."""
    if spec.path and spec.demo:
        raise SceneError("volume: give path or demo, not both")
    if spec.demo:
        for key in _FILE_KEYS:
            if getattr(spec, key) is not None:
                raise SceneError(f"volume.{key} applies to volume files, not to the demo {spec.demo!r} "
                                 f"(voxels of 1 world unit); remove it or give volume.path")
        if spec.out_of_core is True:
            raise SceneError(f"volume.out_of_core = true applies to volume files; the demo {spec.demo!r} is made in "
                             f"memory: remove it or give volume.path")
        return phantoms.demo_volume(spec.demo, spec.size), spec
    if not spec.path:
        raise SceneError("volume: no volume given; set volume.path (or --volume FILE) or volume.demo (--demo)")
    path = check_path_name(os.path.expanduser(spec.path), "volume file")
    if not path.is_absolute():
        path = base_dir / path
    solution = spec.solution
    if solution is not None and not check_path_name(os.path.expanduser(solution), "solution file").is_absolute():
        solution = str(base_dir / os.path.expanduser(solution))
    from ..out_of_core import MEMORY_BUDGET_MB, open_for_scene

    volume = open_for_scene(path, spec, MEMORY_BUDGET_MB if memory_budget_mb is None else memory_budget_mb)
    if volume is None:
        volume = load_field(path, spec.format, array=spec.array, solution=solution, dims=spec.dims, dtype=spec.dtype,
                            endian=spec.endian, header_bytes=spec.header_bytes, spacing=spec.spacing,
                            origin=spec.origin, nan_value=spec.nan_value, series=spec.series, level=spec.level,
                            **_selection(spec))
    if spec.resample is not None:
        if not hasattr(volume, "resampled"):
            raise SceneError(f"volume.resample applies to meshes; {path.name} is a {getattr(volume, 'kind', 'grid')}: "
                             f"remove it")
        volume = volume.resampled(spec.resample)
    return volume, dataclasses.replace(spec, path=str(path.resolve()))


_FILE_KEYS = ("dims", "dtype", "spacing", "origin", "nan_value", "array", "solution", "resample", "series", "level",
              "channel", "time", "fourth_axis")


def _selection(spec: VolumeSpec) -> dict:
    """The channel and time step a volume table picks, as the readers take them (only those given, so that a
    reader of files without channels or time need not know the keys); ``role = "rgb"``: read colour."""
    chosen = {k: getattr(spec, k) for k in ("channel", "time", "fourth_axis") if getattr(spec, k) is not None}
    return {**chosen, "role": "rgb"} if spec.role == "rgb" else chosen


def _members(field, spec: VolumeSpec) -> tuple:
    """The members a volume table gives: a file's channels (each a scalar field), or its one field in the
    table's role (:mod:`dvr_gl.fields.layers`)."""
    from ..fields.layers import FieldSet, Member, members_of

    if isinstance(field, FieldSet):
        if spec.role != "scalar":
            raise SceneError(f"volume.role = {spec.role}: {_source_name(field, spec)} has {len(field)} channels; "
                             f"pick one with volume.channel")
        return field.members
    if getattr(field, "role", None) == "rgb" and spec.role == "scalar":  # a file whose header says colour
        return (Member(field, "rgb", field.name),)
    if spec.role == "scalar":
        return members_of(field)
    return (Member(field, spec.role, getattr(field, "name", "")),)

def _check_extent(field, spec: VolumeSpec):
    """Refuse a field whose voxels, box or position are out of :data:`WORLD_RANGE`, naming where the
    numbers came from (the scene's ``volume.spacing``/``volume.origin`` or the file's header)."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in field.bounds)
    with np.errstate(over="ignore", invalid="ignore"):  # judged below, not warned about
        extent = float(np.max(hi - lo))
        reach = float(np.max(np.abs(np.concatenate([lo, hi]))))
    voxel = float(getattr(field, "sample_spacing", extent))
    small, large = WORLD_RANGE
    if not (voxel >= small and extent <= large):
        where = "volume.spacing" if spec.spacing is not None else f"{_source_name(field, spec)}: the spacing"
        raise SceneError(f"{where}: a voxel of {voxel:.3g} and a box of {extent:.3g} world units are out of "
                         f"range; voxels and extent must lie in [{small:g}, {large:g}]: give a spacing in range "
                         f"(volume.spacing, --spacing)")
    if not reach <= large:
        where = "volume.origin" if spec.origin is not None else f"{_source_name(field, spec)}: the origin"
        raise SceneError(f"{where}: the box reaches {reach:.3g} world units from the origin, beyond "
                         f"{large:g}; give an origin in range (volume.origin)")


def _source_name(field, spec: VolumeSpec) -> str:
    """Where a field's geometry came from, for messages: its file (header), its demo, or its name."""
    return spec.path or spec.demo or getattr(field, "name", None) or "the data"


def _resolve_transfer_function(spec: TransferFunctionSpec, field, demo: str | None,
                               base_dir: Path = Path("."), lookup: "Lookup | None" = None) -> TransferFunction:
    tf_2d = transfer_function_2d(spec, field, base_dir)  # table_2d, boxes_2d or a ParaView state file
    if tf_2d is not None:
        return tf_2d
    if spec.points is not None and (spec.preset is not None or spec.file is not None):
        raise SceneError(f"transfer_function: give {'preset' if spec.preset is not None else 'file'} or points, "
                         f"not both")
    if spec.file is not None and spec.preset is not None:
        raise SceneError("transfer_function: give preset or file, not both (transfer_function.name picks one of "
                         "a file's maps)")
    for key in ("stretch", "name"):
        if getattr(spec, key) is not None and spec.file is None:
            raise SceneError(f"transfer_function.{key} applies to a file (transfer_function.file); remove it")
    if getattr(spec, "labels", None) is not None:
        raise SceneError("transfer_function.labels applies to a label map (volume.role = \"label\", docs/labels.md); "
                         "this field is scalar: give points, a preset or a file")
    if spec.points is not None:
        tf = TransferFunction(spec.points, spec.unit_distance, spec.opacity_model)
    else:
        if spec.opacity_model != "alpha":
            raise SceneError("transfer_function: presets and files are written in alpha; use opacity_model = 'alpha'")
        if spec.file is not None:
            prop = _look_up(_source(None, spec.file, spec.name, spec.stretch, base_dir), lookup)
            tf = from_property(prop, field.value_range, spec.rescale_intercept, spec.unit_distance)
        else:
            name = _look_up(_source(spec.preset or _default_preset(VolumeSpec(demo=demo))), lookup)
            tf = preset(name, field.value_range, spec.rescale_intercept, spec.unit_distance)
    # a field with a value standing for "no material" (a mesh resampled onto a grid, outside its cells)
    outside = getattr(field, "transparent_outside", None)
    return tf if outside is None else outside(tf)


def _tf_path(file: str, base_dir: Path) -> Path:
    path = check_path_name(os.path.expanduser(file), "transfer function file")
    return path if path.is_absolute() else Path(base_dir) / path


@dataclass(frozen=True)
class Lookup:
    """A transfer function's preset or file, looked up once for a scene (:func:`load_scene`): the preset's
    shading (:func:`parse_scene`) and the transfer function (:func:`resolve_scene`) both read it.

    source: what was looked up (:func:`_source`); found: the preset's name as found
    (:func:`~dvr_gl.transfer_function.find_preset`) or the file's VolumeProperty; error: why it could not be
    (raised where the transfer function is resolved, as if looked up there)."""

    source: tuple
    found: object = None
    error: Exception | None = None


def _source(preset_name, file=None, name=None, stretch=None, base_dir: Path = Path(".")) -> tuple | None:
    """What a transfer function names: ``("file", path, name, stretch)`` or ``("preset", name)``; None if neither
    (values of the wrong type are left to parsing, which names them)."""
    if isinstance(file, str):
        return ("file", str(_tf_path(file, base_dir)), name if isinstance(name, str) else None,
                stretch if isinstance(stretch, bool) else None)
    return ("preset", preset_name) if isinstance(preset_name, str) else None


def _look_up(source: tuple, lookup: Lookup | None = None):
    """The preset's name as found, or the file's VolumeProperty: ``lookup``'s if it looked up the same source."""
    if lookup is not None and lookup.source == source:
        if lookup.error is not None:
            raise lookup.error
        return lookup.found
    if source[0] == "file":
        return read_transfer_function_file(Path(source[1]), source[2], source[3])
    return find_preset(source[1])


def look_up_preset(raw: dict, base_dir: Path) -> Lookup | None:
    """The preset or file that scene dict ``raw``'s transfer function names, looked up (None if it names
    none, or gives points)."""
    tf = raw.get("transfer_function")
    if not isinstance(tf, dict) or tf.get("points") is not None:
        return None
    source = _source(tf.get("preset"), tf.get("file"), tf.get("name"), tf.get("stretch"), base_dir)
    if source is None:
        return None
    try:
        return Lookup(source, _look_up(source))
    except (DvrError, TypeError, ValueError, OSError) as exc:
        return Lookup(source, error=exc)


def _with_preset_shading(raw: dict, base_dir: Path, lookup: Lookup | None = None) -> dict:
    """``raw`` with the shading of its transfer function's preset or file (Slicer's ``shade``, ambient,
    diffuse, specular, specular power) in the ``renderer.shading`` keys it does not set itself, where
    the renderer shades and scattering is off.  A dict this cannot read is returned as it is: parsing
    and resolution name what is wrong."""
    from ..renderers import registry

    tf, renderer = raw.get("transfer_function"), raw.get("renderer", {})
    if not isinstance(tf, dict) or not isinstance(renderer, dict) or tf.get("points") is not None:
        return raw
    source = _source(tf.get("preset"), tf.get("file"), tf.get("name"), tf.get("stretch"), base_dir)
    shading = renderer.get("shading", {})
    scattering = renderer.get("scattering", {})
    if source is None or not isinstance(shading, dict) or (isinstance(scattering, dict) and scattering.get("enabled")):
        return raw
    try:
        found = _look_up(source, lookup)
        prop = found if source[0] == "file" else preset_property(found)
        plugin = registry.plugin(renderer.get("name") or registry.default_for("grid"))
    except (DvrError, TypeError, ValueError, OSError):
        return raw
    if prop is None or not prop.shading or not prop.shading["enabled"] or "shading" not in plugin.setting_names:
        return raw
    out = copy.deepcopy(raw)
    out.setdefault("renderer", {})["shading"] = {**prop.shading, **shading}
    return out


def _default_preset(volume: VolumeSpec) -> str:
    return "shepp-logan" if volume.demo == "shepp-logan" else "grayscale"


def _resolve_camera(spec: CameraSpec, field, image: ImageSpec) -> Camera:
    """The camera: look-at or orbit; what is not given frames the field's box."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in field.bounds)
    radius = max(diagonal(field) / 2.0, 1e-12)
    aspect = image.width / image.height
    # the box centre in the patient frame, where the camera is stated (dvr_gl.orientation)
    target = spec.target if spec.target is not None else tuple(to_patient_frame(field, (lo + hi) / 2.0))
    view_height = spec.view_height or framing_view_height(radius, aspect)
    common = dict(projection=spec.projection, fov=spec.fov, view_height=view_height, near=spec.near)
    if spec.view is not None:
        azimuth, elevation = view_orbit(spec.view, spec.azimuth, spec.elevation)
        spec = dataclasses.replace(spec, azimuth=azimuth, elevation=elevation)
    orbit_keys = (spec.azimuth, spec.elevation, spec.distance)
    if spec.eye is not None:
        camera = Camera(spec.eye, target, spec.up, **common)
        return camera.orbited(*orbit_keys) if any(k is not None for k in orbit_keys) else camera
    if spec.distance is not None:
        distance = spec.distance
    elif spec.projection == "perspective":
        distance = framing_distance(radius, spec.fov, aspect)
    else:
        distance = 2.0 * radius * 1.5  # outside the volume; the view height does the framing
    return Camera.from_orbit(target, spec.up,
                             DEFAULT_AZIMUTH if spec.azimuth is None else spec.azimuth,
                             DEFAULT_ELEVATION if spec.elevation is None else spec.elevation,
                             distance, **common)


def camera_path_of(spec: CameraSpec, field, image: ImageSpec):
    """The :class:`~dvr_gl.camera_path.CameraPath` of ``spec``'s ``[[camera.keyframe]]`` tables (None when it
    has none): each keyframe's keys replace the ``[camera]`` table's and resolve as that table does (a
    keyframe that gives ``eye`` drops the table's orbit keys; ``view`` and ``azimuth``/``elevation`` replace
    each other); refused in one line naming the keyframe."""
    if not spec.keyframe:
        return None
    cameras = []
    for k, key in enumerate(spec.keyframe):
        if key.time is None:
            raise SceneError(f"camera.keyframe[{k}]: give its time (seconds along the path)")
        given = {f.name: getattr(key, f.name) for f in dataclasses.fields(key)
                 if f.name not in ("time", "step") and getattr(key, f.name) is not None}
        base = dataclasses.replace(spec, keyframe=[])
        if "eye" in given:
            base = dataclasses.replace(base, azimuth=None, elevation=None, view=None, distance=None)
        if "view" in given:
            base = dataclasses.replace(base, azimuth=None, elevation=None)
        if "azimuth" in given or "elevation" in given:
            base = dataclasses.replace(base, view=None)
        try:
            cameras.append(_resolve_camera(dataclasses.replace(base, **given), field, image))
        except SceneError as exc:
            raise SceneError(f"camera.keyframe[{k}]: {exc}") from None
    steps = [key.step for key in spec.keyframe]
    stepped = [k for k, step in enumerate(steps) if step is not None]
    if stepped and len(stepped) != len(steps):
        missing = next(k for k in range(len(steps)) if k not in stepped)
        raise SceneError(f"camera.keyframe[{missing}]: give its step too (keyframe {stepped[0]} gives one: every "
                         f"keyframe or none)")
    return CameraPath(cameras, [key.time for key in spec.keyframe], tuple(steps) if stepped else None)


def _check_image(spec: ImageSpec):
    """What the schema cannot check key by key (each key's own range is checked by parsing)."""
    if spec.width * spec.height > 64_000_000:
        raise SceneError(f"image: {spec.width}x{spec.height} is too large (at most 64 megapixels)")


def resolve_renderer(spec, field):
    """The renderer settings checked (the renderer exists; every setting as its declaration says) with
    the data-dependent defaults made explicit (:func:`dvr_gl.scene.settings.resolve_renderer`)."""
    from ..renderers import registry

    if spec.name is None:
        spec = dataclasses.replace(spec, name=registry.default_for(getattr(field, "kind", "grid")))
    own = getattr(field, "default_filter", None)
    if own is not None and spec.filter == FILTER.default:
        # the default filter stands for the data's own reconstruction (a particle set's: its SPH kernel)
        spec = dataclasses.replace(spec, filter=own)
    registry.plugin(spec.name)
    return resolve_settings(spec, field, registry.all_settings())


def camera_spec_of(camera: Camera) -> CameraSpec:
    """The explicit spec that resolves to ``camera`` (an orbit if it has one, else look-at)."""
    spec = CameraSpec(projection=camera.projection, fov=camera.fov, view_height=camera.view_height,
                      target=tuple(camera.target), up=tuple(camera.up), near=camera.near)
    if camera.orbit:
        az, el, dist = camera.orbit
        return dataclasses.replace(spec, azimuth=az, elevation=el, distance=dist)
    return dataclasses.replace(spec, eye=tuple(camera.eye))


def _reframed(camera: Camera) -> CameraSpec:
    """The view direction and lens of ``camera``, to be framed anew on another field."""
    az, el, _ = camera.orbit or camera.orbited().orbit
    return CameraSpec(projection=camera.projection, fov=camera.fov, up=tuple(camera.up), azimuth=az, elevation=el,
                      near=camera.near)


@dataclass(frozen=True, eq=False, repr=False)
class Scene:
    """A scene resolved into the model: what every renderer receives.

    field: the data (:mod:`dvr_gl.fields`; ``volume`` is the same field, for grids).
    transfer_function, camera, image: resolved.
    renderer: the renderer's settings, resolved (sample distance in world units, iso-value, ...).
    volume_source: where the field came from (a file or a demo), for the saved scene.
    spec: what was asked for (unresolved defaults), for re-resolution when the field changes.
    tolerance_choice: what ``renderer.tolerance`` chose (set by the declaring renderer's ``resolve``), if given.
    """

    field: object
    transfer_function: TransferFunction
    camera: Camera
    image: ImageSpec
    renderer: object
    volume_source: VolumeSpec = dataclasses.field(default_factory=VolumeSpec)
    spec: SceneSpec | None = None
    tolerance_choice: object = None
    transfer_functions: tuple = ()
    sources: tuple = ()

    def __post_init__(self):
        check_albedo(self.renderer, self.transfer_function)

    @property
    def layers(self) -> tuple:
        """Every field with its classification: ``(Layer(field, role, name, transfer_function), ...)``, one for
        a scene of one field (:mod:`dvr_gl.fields.layers`)."""
        from ..fields.layers import Layer, members_of

        tfs = self.transfer_functions or (self.transfer_function,)
        isos = [self.renderer.iso_value] + [None] * (len(tfs) - 1)
        for i, source in enumerate(self.sources):
            if source.iso_value is not None:
                isos[i] = source.iso_value
        for i, m in enumerate(members_of(self.field)):
            if isos[i] is None:
                lo, hi = m.field.value_range
                isos[i] = (lo + hi) / 2.0
        return tuple(Layer(m.field, m.role, m.name, tf, iso)
                     for m, tf, iso in zip(members_of(self.field), tfs, isos))

    @property
    def volume(self):
        """The field, when it is a regular grid (the grid renderers read it as ``scene.volume``)."""
        if getattr(self.field, "kind", None) != "grid":
            raise SceneError(f"this scene's data is {getattr(self.field, 'kind', 'unknown')}, not a regular grid")
        return self.field

    @property
    def sample_distance(self) -> float:
        return self.renderer.sample_distance

    @property
    def own(self):
        """The settings the scene's renderer owns (declared in its folder), as its namespace:
        ``scene.own.block_size`` for the ray caster (:func:`dvr_gl.scene.schema.own_settings`)."""
        return own_settings(self.renderer)

    def camera_path(self):
        """The scene's ``[[camera.keyframe]]`` path (:class:`~dvr_gl.camera_path.CameraPath`), or None."""
        return camera_path_of(self.spec.camera, self.field, self.image) if self.spec else None

    def with_camera_path(self, path) -> "Scene":
        """The scene with ``path`` (a :class:`~dvr_gl.camera_path.CameraPath`, or None to drop one) as its
        ``[[camera.keyframe]]`` tables: ``--save-scene`` and :meth:`to_toml` write them, ``--frames`` renders
        them (the keyframes as look-at cameras: :meth:`~dvr_gl.camera_path.CameraPath.keyframe_tables`)."""
        spec = self.spec or SceneSpec(renderer=self.renderer)
        keyframes = [parse_table(KeyframeSpec, t, f"camera.keyframe[{k}]")
                     for k, t in enumerate(path.keyframe_tables() if path is not None else [])]
        camera = dataclasses.replace(spec.camera, keyframe=keyframes)
        camera_path_of(camera, self.field, self.image)
        return dataclasses.replace(self, spec=dataclasses.replace(spec, camera=camera))

    def replace(self, *, choose_again: bool = True, **changes) -> "Scene":
        """The scene with parts replaced.  A new field (``field=`` or ``volume=``) re-frames the camera
        (same view direction and lens, the new box) and re-resolves what depended on the old data
        (a preset's value range, the default iso-value, a sample distance in voxels), unless those
        are replaced in the same call.  A new transfer function has the renderer choose its settings
        again where it chose them by the scene (:meth:`with_renderer`), unless ``choose_again`` is false
        (a transfer function being dragged: the choice costs 0.1-0.3 s at 256^3)."""
        if "volume" in changes:
            changes["field"] = changes.pop("volume")
        spec = self.spec or SceneSpec(renderer=self.renderer)
        if "camera" in changes:
            spec = dataclasses.replace(spec, camera=camera_spec_of(changes["camera"]))
        if "transfer_function" in changes:
            tf = changes["transfer_function"]
            spec = dataclasses.replace(spec, transfer_function=TransferFunctionSpec(**tf.to_table()) if is_2d(tf) else
                                       TransferFunctionSpec(points=tf.points.tolist(), unit_distance=tf.unit_distance,
                                                            opacity_model=tf.opacity_model))
        if "image" in changes:
            spec = dataclasses.replace(spec, image=changes["image"])
        if "renderer" in changes:
            spec = dataclasses.replace(spec, renderer=changes["renderer"])
        if "field" in changes and changes["field"] is not self.field:
            field = changes.pop("field")
            if "camera" not in changes:
                spec = dataclasses.replace(spec, camera=_reframed(self.camera))
            source = changes.pop("volume_source", VolumeSpec())
            tf_spec = spec.transfer_function
            given = (tf_spec.preset, tf_spec.points, tf_spec.table_2d, tf_spec.boxes_2d, tf_spec.file)
            if all(v is None for v in given):  # the old data's default preset, by name
                tf_spec = dataclasses.replace(tf_spec, preset=_default_preset(spec.volume))
            spec = dataclasses.replace(spec, volume=source, transfer_function=tf_spec)
            return resolve_scene(spec, field=field, volume_source=source,
                                 **{k: v for k, v in changes.items() if k in ("camera", "transfer_function")})
        scene = dataclasses.replace(self, spec=spec, **changes)
        if choose_again and "transfer_function" in changes and "renderer" not in changes and \
                scene._chosen_by_scene(spec, scene.renderer.name):
            return scene._choose_again(spec, scene.renderer.geometry)
        return scene

    def with_renderer(self, **changes) -> "Scene":
        """The scene with renderer settings changed, checked as a scene file's would be.  A sample
        distance given here replaces one in voxels and a tolerance (and the other way round).  Where the
        renderer chooses its settings by the scene (its plugin's ``resolve``; no sample distance and no
        tolerance asked for), it chooses them again for the changed settings."""
        changes = tables_as_specs(self.renderer, changes, "renderer")
        for key in list(changes):
            for other in exclusive_keys(self.renderer, key):
                changes.setdefault(other, None)
        requested = dataclasses.replace(self.spec.renderer if self.spec else self.renderer, **changes)
        spec = dataclasses.replace(self.spec or SceneSpec(), renderer=requested)
        if self.spec is not None and self._chosen_by_scene(spec, self.renderer.name):
            return self._choose_again(spec, changes.get("geometry", self.renderer.geometry))
        resolved = resolve_renderer(dataclasses.replace(self.renderer, **changes), self.field)
        return dataclasses.replace(self, renderer=resolved, spec=spec)

    @staticmethod
    def _chosen_by_scene(spec, name: str) -> bool:
        """Whether ``spec``'s renderer (``name`` where it names none) has its plugin choose settings by the
        scene (a ``resolve`` hook) and asks for none of the settings the plugin declares would keep its own
        (``resolve_unless``)."""
        from ..renderers import registry

        r = spec.renderer
        plugin = registry.plugin(r.name or name)
        return plugin.resolve is not None and all(getattr(r, key, None) is None for key in plugin.resolve_unless)

    def _choose_again(self, spec, geometry) -> "Scene":
        """The scene with its renderer resolved afresh from ``spec``'s request (the settings the plugin chose
        for the old scene dropped) and chosen again by the plugin's ``resolve``; ``geometry``: the meshes,
        their paths resolved already."""
        from ..renderers import registry

        renderer = resolve_renderer(dataclasses.replace(spec.renderer, name=spec.renderer.name or self.renderer.name,
                                                        geometry=geometry), self.field)
        scene = dataclasses.replace(self, renderer=renderer, spec=spec, tolerance_choice=None)
        return registry._load(registry.plugin(renderer.name).resolve)(scene)

    def to_dict(self, relative_to: Path | None = None) -> dict:
        """The effective scene as a TOML-ready dict (paths relative to ``relative_to`` if given)."""
        source = self.volume_source
        if not source.path and not source.demo:
            raise SceneError("this scene's data is in memory, so a scene file cannot name it; save it "
                             "(e.g. numpy.save('data.npy', array)) and load the scene from volume.path")
        if source.path and relative_to is not None:
            try:
                source = dataclasses.replace(source, path=os.path.relpath(source.path, relative_to))
            except ValueError:  # another drive on Windows
                pass
        tf = self.transfer_function
        if self.sources:  # several fields: every [[volume]] table with its transfer function
            return {"volume": [{**spec_to_dict(self._relative(s, relative_to)),
                                "transfer_function": _tf_dict(layer.transfer_function)}
                               for s, layer in zip(self.sources, self.layers)],
                    "camera": self._camera_dict(),
                    "image": spec_to_dict(self.image),
                    "renderer": _relative_geometry(effective_renderer_dict(self.renderer), relative_to)}
        return {
            "volume": spec_to_dict(source),
            "transfer_function": _tf_dict(tf),
            "camera": self._camera_dict(),
            "image": spec_to_dict(self.image),
            "renderer": _relative_geometry(effective_renderer_dict(self.renderer), relative_to),
        }

    def _camera_dict(self) -> dict:
        """The camera's table, with the keyframes of a path as they were given (relative to that table)."""
        keyframes = self.spec.camera.keyframe if self.spec else []
        return {**self.camera.to_dict(), **({"keyframe": [spec_to_dict(k) for k in keyframes]} if keyframes else {})}

    @staticmethod
    def _relative(source: VolumeSpec, relative_to) -> VolumeSpec:
        if not source.path and not source.demo:
            raise SceneError("this scene's data is in memory, so a scene file cannot name it; save it "
                             "(e.g. numpy.save('data.npy', array)) and load the scene from volume.path")
        if source.path and relative_to is not None:
            try:
                return dataclasses.replace(source, path=os.path.relpath(source.path, relative_to))
            except ValueError:  # another drive on Windows
                pass
        return source

    def to_toml(self, relative_to: Path | None = None) -> str:
        return dumps(self.to_dict(relative_to),
                     header="dvr-gl effective scene: every value explicit; `dvr render` of this file\n"
                            "repeats the image it was saved with.")

    def __repr__(self) -> str:
        r = self.renderer
        tf = self.transfer_function
        if hasattr(tf, "points"):
            lo, hi = tf.domain
            tf = f"<{len(tf.points)} points, {lo:g}..{hi:g}>"
        return (f"Scene({self.field!r}, transfer_function={tf}, "
                f"camera={self.camera!r}, image={self.image.width}x{self.image.height}, renderer={r.name!r})")


def _tf_dict(tf) -> dict:
    """A resolved transfer function as its scene table (a label table's own when it has one)."""
    if hasattr(tf, "to_table"):
        return tf.to_table()
    return {"points": tf.points.tolist(), "unit_distance": tf.unit_distance, "opacity_model": tf.opacity_model}


def effective_renderer_dict(renderer) -> dict:
    """The settings the scene's renderer reads, every one explicit, and any other setting that differs
    from its default (so that nothing the user gave is lost)."""
    from ..renderers import registry

    full = spec_to_dict(renderer)
    declared = set(registry.plugin(renderer.name).setting_names)
    defaults = spec_to_dict(renderer_spec_class()())
    return {k: v for k, v in full.items() if k == "name" or k in declared or defaults.get(k) != v}


def resolve_scene(spec: SceneSpec, base_dir: Path | str = ".", field=None, volume_source: VolumeSpec | None = None,
                  camera: Camera | None = None, transfer_function: TransferFunction | None = None,
                  lookup: Lookup | None = None) -> Scene:
    """Load the field (unless given) and turn presets and defaults into explicit values; then the
    scene's renderer resolves what is its own (the ray caster: a tolerance).  ``lookup``: the transfer
    function's preset or file, already looked up (:func:`look_up_preset`)."""
    from ..fields.layers import members_of
    from ..renderers import registry

    base_dir = Path(base_dir)
    _check_image(spec.image)
    tfs = None
    if isinstance(transfer_function, (list, tuple)):  # one per field (the API's several fields)
        tfs, transfer_function = tuple(transfer_function), None
    if field is None:
        budget = getattr(spec.renderer, "memory_budget_mb", None)  # declared by the renderers that read out of core
        field, sources, tf_specs = _resolve_volumes(spec, base_dir, budget)
        volume_source = sources[0]
    else:
        sources = (volume_source or VolumeSpec(),) * len(members_of(field))
        tf_specs = (spec.transfer_function,) * len(sources)
    members = members_of(field)
    for m, source in zip(members, sources):
        _check_extent(m.field, source)
    if tfs is not None and len(tfs) != len(members):
        raise SceneError(f"transfer_function: {len(tfs)} given for {len(members)} field"
                         f"{'s' * (len(members) != 1)}; give one per field (channel)")
    if tfs is None:
        tfs = tuple(transfer_function if transfer_function is not None and i == 0 else
                    _member_transfer_function(tf_specs[i], m, i, len(members), spec.volume.demo, base_dir,
                                              lookup if i == 0 else None)
                    for i, m in enumerate(members))
    tf = tfs[0]
    if spec.transfer_function.file is not None:  # absolute, so that a new field re-resolves it from anywhere
        spec = dataclasses.replace(spec, transfer_function=dataclasses.replace(
            spec.transfer_function, file=str(_tf_path(spec.transfer_function.file, base_dir).resolve())))
    camera = camera or _resolve_camera(spec.camera, field, spec.image)
    camera_path_of(spec.camera, field, spec.image)  # keyframes refused here, before any rendering
    renderer = _resolve_geometry(resolve_renderer(spec.renderer, field), base_dir)
    scene = Scene(field, tf, camera, spec.image, renderer, volume_source or VolumeSpec(), spec,
                  transfer_functions=tfs if len(tfs) > 1 else (), sources=tuple(sources) if len(tfs) > 1 else ())
    hook = registry.plugin(renderer.name).resolve
    return registry._load(hook)(scene) if hook is not None else scene


def _resolve_volumes(spec: SceneSpec, base_dir: Path, budget):
    """The scene's data from its volume tables (``[volume]``, or every ``[[volume]]``): one field, or a
    :class:`~dvr_gl.fields.layers.FieldSet`; with each member's source (its table, a file's channel named) and
    transfer-function spec."""
    from ..fields.layers import FieldSet, as_data

    members, sources, tf_specs = [], [], []
    for table in [spec.volume, *spec.volumes]:
        field, source = _resolve_volume(table, base_dir, budget)
        these = _members(field, table)
        members += these
        channels = isinstance(field, FieldSet)
        sources += [dataclasses.replace(_as_volume_spec(source), channel=k) if channels else _as_volume_spec(source)
                    for k in range(len(these))]
        tf = getattr(table, "transfer_function", spec.transfer_function)
        if table.role == "label":  # a Slicer segmentation names its segments' colours in its header
            from ..labels import segment_colours

            tf = segment_colours(tf, table.path)
        tf_specs += [tf] * len(these)
    return as_data(members), tuple(sources), tuple(tf_specs)


def _as_volume_spec(table) -> VolumeSpec:
    """A ``[[volume]]`` table's volume keys (without its transfer function)."""
    if type(table) is VolumeSpec:
        return table
    return VolumeSpec(**{f.name: getattr(table, f.name) for f in dataclasses.fields(VolumeSpec)})


def _unset(tf: TransferFunctionSpec) -> bool:
    """Whether a transfer-function table names no function (points, preset, file, or a 2D table or boxes)."""
    return tf.preset is None and tf.points is None and tf.file is None and tf.table_2d is None and tf.boxes_2d is None


def default_unit_distance(field) -> float:
    """The world length a transfer function's alpha refers to when the scene gives none: one voxel of
    the data, its ``sample_spacing`` (a grid's smallest spacing, a mesh's median edge length, particles'
    median smoothing length), so that the same data at another spacing looks the same (docs/conventions.md);
    an analytic field keeps 1 (its alpha is per world unit, as its closed forms are written)."""
    return 1.0 if field.kind == "analytic" else float(field.sample_spacing)


def with_unit_distance(tf_spec, field):
    """``tf_spec`` with its unit distance resolved: the scene's, else :func:`default_unit_distance` of
    ``field``.  The one place a default unit distance is chosen: every transfer function (points, presets,
    files, 2D tables, label tables, colour volumes, channels) is built from the resolved spec."""
    if tf_spec.unit_distance is not None:
        return tf_spec
    return dataclasses.replace(tf_spec, unit_distance=default_unit_distance(field))


def _member_transfer_function(tf_spec, member, k: int, count: int, demo, base_dir: Path, lookup):
    """The transfer function of member ``k`` of ``count``: its table's; a channel of several that names none
    gets a colour of its own (:func:`~dvr_gl.transfer_function.channel_transfer_function`); a label map a
    colour table (:mod:`dvr_gl.labels`), an RGB volume an opacity of its fourth component
    (:mod:`dvr_gl.fields.color`)."""
    tf_spec = with_unit_distance(tf_spec, member.field)
    if member.role == "label":
        from ..labels import label_transfer_function

        return label_transfer_function(tf_spec, member.field, base_dir)
    if member.role == "rgb":
        from ..fields.color import rgb_transfer_function

        return rgb_transfer_function(tf_spec, member.field, base_dir)
    if count > 1 and _unset(tf_spec):
        from ..transfer_function import channel_transfer_function

        return channel_transfer_function(k, member.field.value_range, tf_spec.unit_distance)
    return _resolve_transfer_function(tf_spec, member.field, demo, base_dir, lookup)


def _resolve_geometry(renderer, base_dir: Path):
    """``[[renderer.geometry]]`` paths made absolute (relative to the scene file) and their meshes read,
    so that a missing or unreadable mesh is one line before anything renders."""
    meshes = getattr(renderer, "geometry", None)
    if not meshes:
        return renderer
    from ..geometry import read_mesh

    resolved = []
    for g in meshes:
        path = check_path_name(g.path, "mesh file").expanduser()
        path = path if path.is_absolute() else base_dir / path
        read_mesh(path)
        resolved.append(dataclasses.replace(g, path=str(path.resolve())))
    return dataclasses.replace(renderer, geometry=resolved)


def _relative_geometry(renderer: dict, relative_to: Path | None) -> dict:
    """A saved scene's mesh paths relative to its folder, as its volume's."""
    if relative_to is None or not renderer.get("geometry"):
        return renderer
    out = []
    for g in renderer["geometry"]:
        try:
            out.append({**g, "path": os.path.relpath(g["path"], relative_to)})
        except ValueError:  # another drive on Windows
            out.append(g)
    return {**renderer, "geometry": out}


def is_volume_path(path) -> bool:
    """Whether a path names data (a volume, mesh or particle file, a folder of slices, a glob) rather than a
    scene file: anything but ``.toml`` whose suffix a reader knows."""
    from ..errors import VolumeError
    from ..io import detect_format
    from ..io.series import is_pattern

    p = check_path_name(os.path.expanduser(str(path)), "input file")
    if p.suffix.lower() == ".toml":
        return False
    if p.is_dir() or is_pattern(p):
        return True
    try:
        detect_format(p)
    except VolumeError:
        return False
    return True


def load_scene(path: Path | str | None = None, overrides: dict | None = None, base: dict | None = None) -> Scene:
    """Read a scene file (or start from ``base``, or an empty scene), apply overrides, resolve."""
    raw = read_scene_dict(Path(path)) if path is not None else copy.deepcopy(base or {})
    raw = split_volume_tables(raw)  # [[volume]]: several fields
    if overrides:
        raw = apply_overrides(raw, overrides)
    base_dir = Path(path).parent if path is not None else Path.cwd()
    lookup = look_up_preset(raw, base_dir)  # once: the preset's shading and the transfer function read it
    spec = parse_scene(raw, str(path) if path is not None else None, base_dir, lookup)
    return resolve_scene(spec, base_dir, lookup=lookup)

"""Scenes: what to render, read from TOML, resolved into the model, saved back.

``load_scene_spec`` reads and checks a file; ``apply_overrides`` changes keys
(the CLI's flags); ``resolve_scene`` loads the volume, expands presets and
defaults, and returns a :class:`Scene` whose :meth:`Scene.to_toml` is the
*effective* scene: every value explicit, so rendering it again gives the same
image.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import phantoms
from .camera import (DEFAULT_AZIMUTH, DEFAULT_ELEVATION, Camera, framing_distance, framing_view_height)
from .errors import SceneError
from .io import load_volume
from .scene_schema import (ImageSpec, RendererSpec, SceneSpec, TransferFunctionSpec, VolumeSpec,
                           parse_table, spec_to_dict)
from .toml_writer import dumps
from .transfer_function import PRESETS, TransferFunction, preset
from .volume import Volume

DEFAULT_SAMPLE_DISTANCE_VOXELS = 0.5

# Keys that replace one another when overridden (giving one drops the others).
_EXCLUSIVE = {
    ("volume", "path"): ("demo",), ("volume", "demo"): ("path",),
    ("transfer_function", "preset"): ("points",), ("transfer_function", "points"): ("preset",),
    ("renderer", "sample_distance"): ("sample_distance_voxels", "tolerance"),
    ("renderer", "sample_distance_voxels"): ("sample_distance", "tolerance"),
    ("renderer", "tolerance"): ("sample_distance", "sample_distance_voxels"),
}


def read_scene_dict(path: Path) -> dict:
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise SceneError(f"{path}: scene file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML ({exc})") from exc
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not a UTF-8 text file ({exc})") from exc


def apply_overrides(raw: dict, overrides: dict[str, object]) -> dict:
    """A copy of the scene dict with dotted keys (``"renderer.filter"``) set."""
    out = copy.deepcopy(raw)
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if len(parts) < 2 or not all(parts):
            raise SceneError(f"override {dotted!r}: use section.key, e.g. renderer.filter")
        node = out
        for p in parts[:-1]:
            node = node.setdefault(p, {})
            if not isinstance(node, dict):
                raise SceneError(f"override {dotted!r}: {p} is not a table")
        node[parts[-1]] = value
        for other in _EXCLUSIVE.get((parts[0], parts[-1]), ()) if len(parts) == 2 else ():
            out.get(parts[0], {}).pop(other, None)
    return out


def parse_scene(raw: dict, source: str = "scene") -> SceneSpec:
    try:
        return parse_table(SceneSpec, raw, "")
    except SceneError as exc:
        raise SceneError(f"{source}: {exc}") from None


# --- resolution ---------------------------------------------------------------------------------

def _resolve_volume(spec: VolumeSpec, base_dir: Path) -> tuple[Volume, VolumeSpec]:
    if spec.path and spec.demo:
        raise SceneError("volume: give path or demo, not both")
    if spec.demo:
        if spec.size < 2:
            raise SceneError(f"volume.size must be at least 2, got {spec.size}")
        return phantoms.demo_volume(spec.demo, spec.size), spec
    if not spec.path:
        raise SceneError("volume: no volume given; set volume.path (or --volume FILE) or volume.demo (--demo)")
    path = Path(os.path.expanduser(spec.path))
    if not path.is_absolute():
        path = base_dir / path
    volume = load_volume(path, spec.format, dims=spec.dims, dtype=spec.dtype, endian=spec.endian,
                         header_bytes=spec.header_bytes, spacing=spec.spacing, origin=spec.origin,
                         nan_value=spec.nan_value)
    return volume, dataclasses.replace(spec, path=str(path.resolve()))


def _resolve_transfer_function(spec: TransferFunctionSpec, volume: Volume, demo: str | None) -> TransferFunction:
    if spec.preset and spec.points:
        raise SceneError("transfer_function: give preset or points, not both")
    if spec.points:
        rows = spec.points
        if any(len(r) != 5 for r in rows):
            raise SceneError("transfer_function.points: each point is [value, r, g, b, opacity]")
        return TransferFunction(np.array(rows), spec.unit_distance, spec.opacity_model)
    name = spec.preset or ("shepp-logan" if demo == "shepp-logan" else "grayscale")
    if spec.opacity_model != "alpha":
        raise SceneError("transfer_function: presets are written in alpha; use opacity_model = 'alpha'")
    return preset(name, volume.value_range, spec.rescale_intercept, spec.unit_distance)


def _resolve_camera(spec, volume: Volume, image: ImageSpec) -> Camera:
    lo, hi = volume.box
    radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-12)
    aspect = image.width / image.height
    target = spec.target if spec.target is not None else tuple((lo + hi) / 2.0)
    view_height = spec.view_height or framing_view_height(radius, aspect)
    common = dict(projection=spec.projection, fov=spec.fov, view_height=view_height, near=spec.near)
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


def _check_image(spec: ImageSpec):
    if spec.width < 1 or spec.height < 1:
        raise SceneError(f"image: width and height must be at least 1, got {spec.width}x{spec.height}")
    if spec.width * spec.height > 64_000_000:
        raise SceneError(f"image: {spec.width}x{spec.height} is too large (at most 64 megapixels)")
    if any(not 0.0 <= c <= 1.0 for c in spec.background):
        raise SceneError(f"image.background: components must be in [0, 1], got {list(spec.background)}")


def resolve_renderer(spec: RendererSpec, volume: Volume) -> RendererSpec:
    if spec.sample_distance is not None and spec.sample_distance_voxels is not None:
        raise SceneError("renderer: give sample_distance or sample_distance_voxels, not both")
    d = spec.sample_distance
    if d is None:
        voxels = spec.sample_distance_voxels or DEFAULT_SAMPLE_DISTANCE_VOXELS
        if voxels <= 0:
            raise SceneError(f"renderer.sample_distance_voxels must be positive, got {voxels}")
        d = volume.voxels_to_world(voxels)
    if not d > 0:
        raise SceneError(f"renderer.sample_distance must be positive, got {d}")
    if not 0.0 < spec.ert_threshold <= 1.0:
        raise SceneError(f"renderer.ert_threshold must be in (0, 1], got {spec.ert_threshold}")
    if spec.lut_size < 2:
        raise SceneError(f"renderer.lut_size must be at least 2, got {spec.lut_size}")
    if not 0 <= spec.iso_refinement <= 64:
        raise SceneError(f"renderer.iso_refinement must be between 0 and 64 bisection steps, got "
                         f"{spec.iso_refinement}")
    if not spec.converged_tolerance > 0:
        raise SceneError(f"renderer.converged_tolerance must be positive, got {spec.converged_tolerance}")
    sh = spec.shading
    for key in ("ambient", "diffuse", "specular", "shininess"):
        if getattr(sh, key) < 0:
            raise SceneError(f"renderer.shading.{key} must be >= 0, got {getattr(sh, key)}")
    for i, light in enumerate(sh.lights):
        if light.type == "directional" and not any(light.direction):
            raise SceneError(f"renderer.shading.lights[{i}].direction must be a non-zero vector")
        if any(c < 0 for c in light.color):
            raise SceneError(f"renderer.shading.lights[{i}].color must be >= 0")
    if spec.classification == "preintegrated" and spec.jitter:
        raise SceneError("renderer.jitter does not apply to pre-integrated classification (which needs no "
                         "jitter against wood-grain); turn one of them off")
    if spec.preintegration_size < 2:
        raise SceneError(f"renderer.preintegration_size must be at least 2, got {spec.preintegration_size}")
    if spec.block_size not in (4, 8, 16, 32):
        raise SceneError(f"renderer.block_size must be 4, 8, 16 or 32, got {spec.block_size}")
    if not spec.homogeneity_tolerance >= 0:
        raise SceneError(f"renderer.homogeneity_tolerance must be >= 0, got {spec.homogeneity_tolerance}")
    if not 0.0 <= spec.opacity_threshold < 1.0:
        raise SceneError(f"renderer.opacity_threshold must be in [0, 1), got {spec.opacity_threshold}")
    if not spec.texture_budget_mb > 0:
        raise SceneError(f"renderer.texture_budget_mb must be positive, got {spec.texture_budget_mb}")
    iso = spec.iso_value if spec.iso_value is not None else sum(volume.value_range) / 2.0
    g_ref = spec.gradient_opacity_reference
    if g_ref is None:
        lo, hi = volume.value_range
        g_ref = 0.1 * max(hi - lo, 1e-30) / min(volume.spacing)
    if not g_ref > 0:
        raise SceneError(f"renderer.gradient_opacity_reference must be positive, got {g_ref}")
    return dataclasses.replace(spec, sample_distance=d, sample_distance_voxels=None, iso_value=iso,
                               gradient_opacity_reference=g_ref)


@dataclass(frozen=True, eq=False)
class Scene:
    """A scene resolved into the model: what every renderer receives."""

    volume: Volume
    transfer_function: TransferFunction
    camera: Camera
    image: ImageSpec
    renderer: RendererSpec
    volume_source: VolumeSpec
    tolerance_choice: object = None   # what renderer.tolerance chose (dvr_gl.tolerance.Choice), if given

    @property
    def sample_distance(self) -> float:
        return self.renderer.sample_distance

    def replace(self, **changes) -> "Scene":
        return dataclasses.replace(self, **changes)

    def with_renderer(self, **changes) -> "Scene":
        return dataclasses.replace(self, renderer=dataclasses.replace(self.renderer, **changes))

    def to_dict(self, relative_to: Path | None = None) -> dict:
        """The effective scene as a TOML-ready dict (paths relative to ``relative_to`` if given)."""
        source = self.volume_source
        if source.path and relative_to is not None:
            try:
                source = dataclasses.replace(source, path=os.path.relpath(source.path, relative_to))
            except ValueError:  # another drive on Windows
                pass
        tf = self.transfer_function
        return {
            "volume": spec_to_dict(source),
            "transfer_function": {"points": tf.points.tolist(), "unit_distance": tf.unit_distance,
                                  "opacity_model": tf.opacity_model},
            "camera": self.camera.to_dict(),
            "image": spec_to_dict(self.image),
            "renderer": spec_to_dict(self.renderer),
        }

    def to_toml(self, relative_to: Path | None = None) -> str:
        return dumps(self.to_dict(relative_to),
                     header="dvr-gl effective scene: every value explicit; `dvr render` of this file\n"
                            "repeats the image it was saved with.")


def resolve_scene(spec: SceneSpec, base_dir: Path | str = ".") -> Scene:
    """Load the volume and turn presets and defaults into explicit values."""
    base_dir = Path(base_dir)
    _check_image(spec.image)
    volume, source = _resolve_volume(spec.volume, base_dir)
    tf = _resolve_transfer_function(spec.transfer_function, volume, spec.volume.demo)
    camera = _resolve_camera(spec.camera, volume, spec.image)
    renderer = resolve_renderer(spec.renderer, volume)
    scene = Scene(volume, tf, camera, spec.image, renderer, source)
    return _meet_tolerance(scene, spec.renderer) if renderer.tolerance is not None else scene


def _meet_tolerance(scene: Scene, spec: RendererSpec) -> Scene:
    """Replace ``renderer.tolerance`` by the settings the error model chooses for it (so the
    effective scene holds those settings, and rendering it again repeats the image)."""
    from . import tolerance

    if spec.sample_distance is not None or spec.sample_distance_voxels is not None:
        raise SceneError("renderer: give tolerance or a sample distance, not both (the tolerance chooses it)")
    chosen, choice = tolerance.apply(scene.with_renderer(tolerance=None), spec.tolerance)
    return chosen.replace(tolerance_choice=choice)


def load_scene(path: Path | str | None = None, overrides: dict | None = None, base: dict | None = None) -> Scene:
    """Read a scene file (or start from ``base``, or an empty scene), apply overrides, resolve."""
    raw = read_scene_dict(Path(path)) if path is not None else copy.deepcopy(base or {})
    if overrides:
        raw = apply_overrides(raw, overrides)
    source = str(path) if path is not None else "scene"
    spec = parse_scene(raw, source)
    return resolve_scene(spec, Path(path).parent if path is not None else Path.cwd())


def available_presets() -> list[str]:
    return list(PRESETS)

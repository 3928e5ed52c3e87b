"""The scene-format reference (``docs/scene-files.md``), generated from the schema and the registry.

Every key of every table, with its default, its choices and its one line of documentation, from the
dataclasses of :mod:`dvr_gl.scene.schema` and :mod:`dvr_gl.scene.model` and the settings the registered
renderers declare (:mod:`dvr_gl.scene.settings`), with the renderers that read each.  A test checks that
the page in the repository is what this module writes; after changing a key, write it again::

    python -m dvr_gl.scene.reference docs/scene-files.md
"""

from __future__ import annotations

import dataclasses
import sys
import typing
from pathlib import Path

from ..renderers import registry
from .model import LightSpec, ShadingSpec, exclusive_keys
from .schema import CameraSpec, ImageSpec, KeyframeSpec, TransferFunctionSpec, VolumeSpec, type_hints

INTRO = """\
# Scene files

A scene (volume, transfer function, camera, image and renderer settings) is a TOML file, read with
the standard library. Unknown keys are an error naming the key and listing the valid ones; relative
paths are relative to the scene file. Examples are in `examples/` (`shepp-logan.toml` spells out
every key the demo sets). The rules the keys follow (indexing, units, opacity model) are in
[Conventions](conventions.md); the command-line flags that override keys are in
[Command line](cli.md).

*This page is generated from the schema and the registered renderers' declarations
(`python -m dvr_gl.scene.reference docs/scene-files.md`); `tests/project/test_docs.py` fails when it is not
current.*

```toml
[volume]
path = "../../shared/data/regular/cthead.nhdr"   # or: demo = "shepp-logan" (and size = 96)

[transfer_function]
preset = "ct-bone-ivory"              # or points = [[value, r, g, b, opacity], ...]
rescale_intercept = -1024.0     # CT presets are in Hounsfield units: HU = data + intercept

[camera]
up = [0.0, 0.0, -1.0]
azimuth = 20.0                  # degrees; or eye = [x, y, z] (look-at)
elevation = 10.0

[image]
width = 384
height = 384

[renderer]
name = "reference"
compositing = "emission_absorption"
sample_distance_voxels = 0.5

[renderer.shading]
enabled = true

[[renderer.shading.lights]]
type = "headlight"
```
"""

CAMERA_PATHS = """\
A camera path: two or more keyframes at increasing `time` (seconds), each a camera whose keys replace the
`[camera]` table's (one that gives `eye` is a look-at and drops the table's orbit keys; `view` and
`azimuth`/`elevation` replace each other). `dvr render scene.toml --frames N -o path.gif` renders N frames
evenly over the keyframes' span, the first and last keyframes being the first and last frames
(`--animate path`, the default of `--frames` for such a scene; `time,path` with a time series). Between
keyframes the camera's rotation moves on the sphere of rotations (Shoemake's SQUAD: through every keyframe,
smooth; between two keyframes, slerp: the view turns about one axis at a constant rate), the eye-to-target
distance and an orthographic view height in log space, the target and the field of view along a cubic
(Catmull-Rom slopes; with two keyframes, straight lines); up stays orthogonal to the view. In Python:
`dvr_gl.CameraPath(cameras, times).camera_at(t)`, or `scene.camera_path()`. With a time series, a `step` in
every keyframe chooses each frame's step (the keyframes' steps joined by straight lines in time, rounded down).
Refused in one line: fewer than
two keyframes, a keyframe without `time`, times that do not increase, an eye on the target, a look-at
keyframe whose up is parallel to its view.

```toml
[[camera.keyframe]]
time = 0.0
azimuth = 0.0

[[camera.keyframe]]
time = 2.0
azimuth = 120.0
elevation = 30.0
distance = 400.0
```
"""

SAVE_SCENE = """\
## What `--save-scene` writes

`--save-scene` writes the *effective* scene: presets expanded into points, defaults filled in, the
camera as the orbit or eye it used, the volume path relative to the saved file, and under
`[renderer]` every setting the chosen renderer reads (and any other that differs from its default).
Rendering it again repeats the image.
"""

#: The titles of the shared settings' groups (:data:`dvr_gl.scene.settings.SHARED_GROUPS`); any other group
#: is a renderer's own.
GROUPS = {"model": "The model: what the picture should be (every renderer reads these; one that supports fewer "
                   "choices refuses the others)",
          "sampling": "Sampling: how closely a renderer approaches the picture",
          "gpu": "GPU renderers of regular grids"}


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|")


def _default(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f"`{value}`"
    if isinstance(value, tuple):
        return "`[" + ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value) + "]`"
    if isinstance(value, float):
        return f"{value:g}"
    if dataclasses.is_dataclass(value) or isinstance(value, list):
        return "see below"
    return str(value)


def _type(tp) -> str:
    args = [a for a in typing.get_args(tp) if a is not type(None)]
    origin = typing.get_origin(tp)
    if origin is tuple:
        return f"{len(typing.get_args(tp))} numbers"
    if origin is list:
        return "list"
    if args and origin is not None and origin is not list:
        return _type(args[0])
    if dataclasses.is_dataclass(tp):
        return "table"
    return {float: "number", int: "integer", bool: "true/false", str: "string"}.get(tp, str(tp))


def _replaces(cls, key: str, prefix: str) -> str:
    """The keys that ``key`` excludes (:func:`dvr_gl.scene.model.exclusive_keys`), as the page says it."""
    others = exclusive_keys(cls, key)
    return f"; replaces {', '.join(f'`{prefix}{k}`' for k in others)}" if others else ""


def _table_rows(cls, prefix: str) -> list[str]:
    hints = type_hints(cls)
    rows = []
    for f in dataclasses.fields(cls):
        default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
        choices = f.metadata.get("choices")
        meaning = f.metadata.get("doc", "")
        if choices:
            meaning += f" (one of {', '.join(f'`{c}`' for c in choices)})"
        meaning += _replaces(cls, f.name, prefix)
        rows.append(f"| `{prefix}{f.name}` | {_type(hints[f.name])} | {_default(default)} | {_cell(meaning)} |")
    return rows


def _table(title: str, cls, prefix: str, note: str = "") -> list[str]:
    out = [f"## `[{prefix.rstrip('.')}]`" if title is None else f"## {title}", ""]
    if note:
        out += [note, ""]
    out += ["| key | type | default | meaning |", "|---|---|---|---|", *_table_rows(cls, prefix), ""]
    return out


def _builtin(plugin) -> bool:
    """A renderer of dvr-gl itself (the page documents those, whatever else is installed)."""
    target = plugin.renderer if isinstance(plugin.renderer, str) else plugin.renderer.__module__
    return target.startswith("dvr_gl.")


def _renderer_tables() -> list[str]:
    plugins = {n: p for n, p in registry.plugins().items() if _builtin(p)}
    out = ["## `[renderer]`", "",
           "`renderer.name` chooses the renderer: "
           + ", ".join(f"`{n}` ({_cell(p.description)})" for n, p in plugins.items())
           + ". The other keys are the settings the registered renderers declare; each renderer reads those "
             "listed as read by it and ignores the others, except that it refuses, with the reason, a model "
             "setting it does not support (`dvr info` lists what each renderer reads). A renderer's own settings "
             "(the tables *read by one renderer only*) may also be written in its own table, e.g. "
             "`[renderer.raycast]` with `tolerance = 0.01`: that spelling is accepted only where `renderer.name` "
             "is that renderer, and refuses a key it does not own. The flat spelling (`renderer.tolerance`) is the "
             "canonical one: the flags set it and `--save-scene` writes it; a key given in both is refused.", ""]
    groups: dict[str, list] = {}
    for s in registry.all_settings():
        if s.group == "model" or any(p.declared(s.name) is not None for p in plugins.values()):
            groups.setdefault(s.group, []).append(s)
    order = [g for g in GROUPS if g in groups] + sorted(g for g in groups if g not in GROUPS)
    for group in order:
        title = GROUPS.get(group, f"Read by `{group}` only")
        out += [f"### {title}", ""]
        if group not in GROUPS:  # a renderer's own settings (dvr_gl.scene.settings.Setting.owner)
            out += [f"Also written `[renderer.{group}]` (`renderer.{group}.{groups[group][0].name}`), where "
                    f"`renderer.name = \"{group}\"`.", ""]
        out += ["| key | type | default | meaning | read by |", "|---|---|---|---|---|"]
        for s in groups[group]:
            readers = [n for n, p in plugins.items() if p.declared(s.name) is not None]
            meaning = s.doc + (f" ({s.units})" if s.units else "")
            if s.choices:
                meaning += f"; one of {', '.join(f'`{c}`' for c in s.choices)}"
            narrowed = [f"{n}: {', '.join(f'`{c}`' for c in p.declared(s.name).choices)}" for n, p in plugins.items()
                        if p.declared(s.name) is not None and p.declared(s.name).choices != s.choices]
            if narrowed:
                meaning += f" (supported: {'; '.join(narrowed)})"
            meaning += _replaces(registry.renderer_spec_class(), s.name, "renderer.")
            read_by = "all" if len(readers) == len(plugins) else ", ".join(readers) or "-"
            out.append(f"| `renderer.{s.name}` | {_type(s.type)} | {_default(s.default_value())} | "
                       f"{_cell(meaning)} | {read_by} |")
        out.append("")
    out += _table("`[renderer.shading]`", ShadingSpec, "renderer.shading.")
    out += _table("`[[renderer.shading.lights]]`", LightSpec, "")
    return out


def reference_text() -> str:
    """The page's Markdown."""
    lines = [INTRO, "## Keys", ""]
    lines += _table(None, VolumeSpec, "volume.")
    lines += _table(None, TransferFunctionSpec, "transfer_function.")
    lines += _table(None, CameraSpec, "camera.", "With `eye` and orbit keys both given, the orbit keys replace "
                                                 "the matching parameters of the eye's orbit.")
    lines += _table("`[[camera.keyframe]]`", KeyframeSpec, "", CAMERA_PATHS.rstrip())
    lines += _table(None, ImageSpec, "image.")
    lines += _renderer_tables()
    lines.append(SAVE_SCENE)
    return "\n".join(lines).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    text = reference_text()
    if argv:
        Path(argv[0]).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

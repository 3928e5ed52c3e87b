"""Render a scene (a TOML file, a volume file, or the built-in demo) to an image.

Flags override the scene's keys; ``--set section.key=value`` reaches any key.  Several volume files (and
``--labels``, ``--rgb``) are fields of one scene, composited per sample; ``--time K`` renders a step of a time
series, ``--animate time`` every step (docs/cli.md).
Output is written to a temporary file and renamed, so a failed render leaves
no partial file; an existing file is replaced only with ``--overwrite``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import logging
import math
import os
import time
import tomllib
import types
import typing
from pathlib import Path

from dvr_gl import progress
from dvr_gl.errors import DvrError
from dvr_gl.image import (
    DEFAULT_FPS,
    FLOAT_FORMATS,
    MOVIE_FORMATS,
    Movie,
    check_movie,
    check_output_path,
    check_writable,
    composite_over,
    encode_8bit,
    write_image,
    write_text,
)
from dvr_gl.phantoms import DEMOS
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.sandbox import Sandbox, active, parse_bytes
from dvr_gl.scene.schema import RendererTable, SceneSpec, renderer_spec_class, type_hints
from dvr_gl.toml_writer import loads_toml
from dvr_gl.transfer_function import PRESETS, is_transfer_function_file

from . import fields as cli_fields
from .animation import Animation, Frames, parse_animate

log = logging.getLogger(__name__)

HELP = "render a scene, a volume file or the demo to an image (.png .exr .tif)"

# The scene key each scene flag sets (flag destination -> key); the flag's type, choices and on/off form are
# the key's own, read from the schema (scene_flag).  The renderer settings' flags come from the registry.
_SCENE_KEYS = {
    "renderer": "renderer.name", "shading": "renderer.shading.enabled",
    "scattering": "renderer.scattering.enabled", "scattering_method": "renderer.scattering.method",
    "azimuth": "camera.azimuth", "elevation": "camera.elevation", "view": "camera.view", "up": "camera.up",
    "distance": "camera.distance", "projection": "camera.projection", "fov": "camera.fov",
    "transfer_function": "transfer_function.preset", "rescale_intercept": "transfer_function.rescale_intercept",
    "volume": "volume.path", "format": "volume.format", "dims": "volume.dims", "dtype": "volume.dtype",
    "endian": "volume.endian", "header_bytes": "volume.header_bytes", "spacing": "volume.spacing",
    "nan_value": "volume.nan_value", "array": "volume.array", "solution": "volume.solution",
    "resample": "volume.resample", "channel": "volume.channel", "time": "volume.time",
}
SETTING_DEST = "setting_"
MAX_FRAMES = 10_000  # a renderer setting's flag stores into setting_<name>


def scene_flag(group, flag: str, **options):
    """Add ``flag``, which sets the scene key :data:`_SCENE_KEYS` names for it, typed as the schema types that
    key: a number, an integer or a name (with its choices), three of them, or true/false as ``--x/--no-x``;
    ``options``: its help, a metavar, or a parser of its own (``--up``), which takes the value whole."""
    kind, allowed = _schema_type(_SCENE_KEYS[flag[2:].replace("-", "_")])
    if kind is bool:
        return group.add_argument(flag, action=argparse.BooleanOptionalAction, default=None, **options)
    if typing.get_origin(kind) is tuple and "type" not in options:
        options = {"nargs": len(typing.get_args(kind)), "type": typing.get_args(kind)[0], **options}
    elif kind in (int, float):
        options = {"type": kind, **options}
    if allowed:
        options = {"choices": allowed, **options}
    return group.add_argument(flag, **options)


def _schema_type(key: str):
    """(the type, the choices) of a dotted scene key, from the schema's tables (Optional stripped)."""
    table = SceneSpec
    *path, name = key.split(".")
    for part in path:
        table = type_hints(table)[part]
        table = renderer_spec_class() if table is RendererTable else table
    kind = type_hints(table)[name]
    inner = [t for t in typing.get_args(kind) if t is not type(None)] if typing.get_origin(kind) in (
        typing.Union, types.UnionType) else [kind]
    field = next(f for f in dataclasses.fields(table) if f.name == name)
    return inner[0], field.metadata.get("choices")


def renderers_epilog() -> str:
    """The registered renderers, one a line, for the end of ``--help`` (the CLI keeps its line breaks)."""
    import textwrap

    width = max(len(name) for name in registry.plugins()) + 4
    lines = ["renderers (--renderer NAME; dvr info lists what each reads and refuses):"]
    for name, plugin in registry.plugins().items():
        lines += textwrap.wrap(plugin.description, 100, initial_indent=f"  {name:<{width - 2}}",
                               subsequent_indent=" " * width)
    return "\n".join(lines)


def add_arguments(p: argparse.ArgumentParser):
    p.epilog = renderers_epilog()
    cli_fields.add_files(
        p, "a scene file (.toml), or a volume, mesh or particle file (any suffix dvr info lists; a folder of "
           "slices); several volume files: one field each, composited per sample (each file's channels: a field "
           "each)")
    p.add_argument("-o", "--output", required=True,
                   help="output image: .png (8-bit sRGB), .exr or .tif (float); an animation (every frame of "
                        "--frames in one file, 8-bit sRGB): .gif, or .mp4, .webm, .webp with the extra 'video'")
    several = cli_fields.add_role_flags(p)
    scene_flag(several, "--channel", metavar="K", help="a file with channels: render channel K alone (0 first; "
                                                         "default: every channel, each a field)")
    scene_flag(several, "--time", metavar="K", help="a time series: render step K (0 first, the default), exactly "
                                                      "as that step alone")
    several.add_argument("--animate", type=parse_animate, metavar="orbit|path|time|time,orbit",
                         help="what --frames animates: orbit (the default), path (the scene's [[camera.keyframe]] "
                              "tables: the default when it has them), time (frame i of N shows step "
                              "floor(i*S/N) of the S steps; without --frames N = S, one frame a step) or time "
                              "with either")
    p.add_argument("--demo", nargs="?", const="shepp-logan", choices=list(DEMOS),
                   help="render a built-in phantom (default shepp-logan)")
    scene_flag(p, "--volume", metavar="FILE", help="volume file (overrides the scene's)")
    p.add_argument("--annotate", type=annotate_flag, metavar="colorbar,scalebar,axes[,caption=TEXT]",
                   help="draw annotations over the 8-bit picture (.png .jpg or an animation; never into the float "
                        "image): colorbar, scalebar, axes, all, unit=TEXT, value_unit=TEXT, caption=TEXT (last: "
                        "the rest of the text); docs/annotations.md")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--depth", action="store_true",
                   help="also write the depth (distance along the view axis, world units; inf where the opacity "
                        "never reaches one half): a Z channel of an .exr output, else NAME.depth.exr beside it; "
                        "docs/picking.md")
    p.add_argument("--save-scene", metavar="FILE", help="also write the effective scene (TOML)")
    p.add_argument("--frames", type=int, metavar="N",
                   help="render an animation of N frames (an orbit; --animate time: the time steps): into one "
                        "animation (.gif .mp4 .webm .webp), or to OUTPUT_0000.ext, OUTPUT_0001.ext, ...")
    p.add_argument("--fps", type=float, default=DEFAULT_FPS,
                   help=f"an animation's frames per second (default {DEFAULT_FPS:g})")
    d = p.add_argument_group("on a Dask cluster, with the extra 'dask' (docs/distributed.md)")
    d.add_argument("--dask", metavar="ADDRESS|local:N",
                   help="render on Dask workers: a scheduler's address, or local:N (a local cluster of N worker "
                        "processes, closed after); one frame: its bricks, composited sort-last; --frames: one "
                        f"frame per task (renderer {' or '.join(registry.renderers_with(lambda q: q.sort_last))})")
    d.add_argument("--compositing-method", choices=("direct_send", "binary_swap"), default="direct_send",
                   help="--dask, one frame: how the workers composite their partial images (binary_swap needs "
                        "a power-of-two number of workers; default direct_send)")
    b = p.add_argument_group("sandbox, for scenes you did not write (docs/robustness.md)")
    b.add_argument("--sandbox", action="append", metavar="ROOT", help="read and write only inside folder ROOT "
                   "(repeatable): the scene, every file it names and the outputs; FIFOs and devices are refused")
    b.add_argument("--max-seconds", type=float, metavar="S", help="stop a render that runs longer (wall clock)")
    b.add_argument("--max-memory", metavar="SIZE", help="memory budget for volumes, tables and images, e.g. 2GiB "
                   "(default: half the physical memory)")
    g = p.add_argument_group("scene overrides")
    g.add_argument("--size", metavar="WxH", help="image size, e.g. 512x512 (or 512)")
    scene_flag(g, "--renderer", metavar="NAME",
               help="renderer: " + "; ".join(f"{n} ({q.description})" for n, q in registry.plugins().items()))
    scene_flag(g, "--shading", help="Blinn-Phong shading from the gradient")
    scene_flag(g, "--scattering", help="single scattering of [renderer.scattering]'s lights, with shadows, instead "
                                       "of gradient shading (docs/scattering.md)")
    scene_flag(g, "--scattering-method",
               help="how the GPU finds the light's transmittance: a shadow ray per sample, or a light volume")
    g.add_argument("--mesh", action="append", default=[], metavar="FILE[:R,G,B]",
                   help="an opaque mesh (OBJ, PLY, STL, VTK) in the volume's world, optionally its linear colour; "
                        "repeatable (docs/geometry.md)")
    scene_flag(g, "--azimuth", help="degrees about the up axis")
    scene_flag(g, "--elevation", help="degrees above the horizontal plane")
    scene_flag(g, "--distance", help="eye to target, world units")
    scene_flag(g, "--projection")
    scene_flag(g, "--fov", help="vertical field of view, degrees")
    scene_flag(g, "--view",
               help="an anatomical view, patient upright (the file's orientation applied; docs/orientation.md)")
    scene_flag(g, "--up", metavar="X,Y,Z|[-]x|y|z", type=parse_up,
               help="the up direction (world; default +z, superior): an axis, e.g. -z, or 0,0,-1")
    scene_flag(g, "--transfer-function", metavar="NAME|FILE", action="append",
               help="repeatable: the k-th for the k-th volume file (one given: the first field's); a preset, any "
                    f"case ({', '.join(list(PRESETS)[:5])}, 3D Slicer's: CT-AAA, CT-Bone, "
                    f"MR-Default, ...), a matplotlib colour map (inferno, ...), or a Slicer .vp/.xml or ParaView "
                    f".json file (docs/transfer-functions.md)")
    scene_flag(g, "--rescale-intercept", help="CT presets: HU = data + intercept")
    g.add_argument("--background", metavar="R,G,B[,A]", help="background colour, linear, 0..1")
    g.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="set any scene key, e.g. renderer.shading.shininess=20 (value in TOML syntax)")
    add_setting_arguments(p.add_argument_group("renderer settings (docs/scene-files.md; which renderer reads "
                                               "which: dvr info)"))
    v = p.add_argument_group("volume file options (raw files need --dims and --dtype)")
    scene_flag(v, "--format", help="reader (default: by suffix)")
    scene_flag(v, "--dims", metavar=("NX", "NY", "NZ"))
    scene_flag(v, "--dtype", help="raw sample type: uint8, int16, uint16, float32, ...")
    scene_flag(v, "--endian")
    scene_flag(v, "--header-bytes")
    scene_flag(v, "--spacing", metavar=("SX", "SY", "SZ"))
    scene_flag(v, "--nan-value", help="replace NaN/Inf in the data by this value")
    scene_flag(v, "--array", metavar="NAME", help="meshes: the scalar array to render")
    scene_flag(v, "--solution", metavar="FILE", help="PLOT3D grids: the q (solution) file")
    scene_flag(v, "--resample", metavar="N", help="meshes: resample onto a grid of N points along the longest "
                                                   "axis, for the grid renderers")


def add_setting_arguments(g):
    """A flag per renderer setting that asks for one (:attr:`dvr_gl.scene.settings.Setting.flag`), from the
    registry: ``--name-with-dashes``; booleans as ``--x/--no-x``; choices and types as declared."""
    for setting in registry.all_settings():
        if not setting.flag:
            continue
        flag = "--" + setting.name.replace("_", "-")
        text = setting.doc + (f" ({setting.units})" if setting.units else "")
        dest = SETTING_DEST + setting.name
        kind = next(t for t in (typing.get_args(setting.type) or (setting.type,)) if t is not type(None))
        if kind is bool:
            g.add_argument(flag, dest=dest, action=argparse.BooleanOptionalAction, default=None, help=text)
        elif setting.choices:
            g.add_argument(flag, dest=dest, type=kind, choices=setting.choices, help=text)
        else:
            g.add_argument(flag, dest=dest, type=kind, metavar=kind.__name__.upper(), help=text)


def annotate_flag(text: str):
    """``--annotate``: :func:`dvr_gl.annotations.parse_annotate`, refused as argparse refuses a bad value."""
    from dvr_gl.annotations import parse_annotate

    try:
        return parse_annotate(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--annotate ")) from None


def parse_up(text: str) -> list[float]:
    """``--up``: an axis (``z``, ``-y``, ``+x``) or three numbers ``X,Y,Z``."""
    axes = {"x": [1.0, 0.0, 0.0], "y": [0.0, 1.0, 0.0], "z": [0.0, 0.0, 1.0]}
    t = text.strip().lower()
    if t.lstrip("+-") in axes and len(t) <= 2:
        return [-c for c in axes[t[-1]]] if t.startswith("-") else axes[t[-1]]
    try:
        values = [float(x) for x in t.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(map(math.isfinite, values)) or not any(values):
        raise argparse.ArgumentTypeError(f"{text!r}: give an axis (x, -y, +z) or three numbers X,Y,Z, not all 0")
    return values


def positional_volume(args):
    """The files given where the scene file goes: one volume file (``dvr render head.nhdr``) is read as
    ``--volume``; several, or ``--labels``/``--rgb``, are fields of one scene (:func:`.fields.sort_files`)."""
    cli_fields.sort_files(args)


def parse_size(text: str) -> tuple[int, int]:
    try:
        parts = [int(x) for x in text.lower().split("x")]
    except ValueError:
        parts = []
    if len(parts) == 1:
        parts *= 2
    if len(parts) != 2:
        raise DvrError(f"--size {text!r}: use WIDTHxHEIGHT, e.g. 512x384, or one number for a square")
    return parts[0], parts[1]


def parse_value(text: str):
    """A --set value in TOML syntax; a bare word is a string."""
    try:
        return loads_toml(f"v = {text}", f"--set value {text[:40]!r}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def overrides_from(args) -> dict:
    out = {}
    for dest, key in _SCENE_KEYS.items():
        value = getattr(args, dest, None)
        if dest == "transfer_function" and value:  # repeatable: the first field's (source_of: the others')
            value = value[0]
        if value is not None:
            out[key] = list(value) if isinstance(value, tuple | list) else value
    for setting in registry.all_settings():  # each flag stored its value under its setting's name
        value = getattr(args, SETTING_DEST + setting.name, None)
        if value is not None:
            out[setting.key] = value
    if is_transfer_function_file(out.get("transfer_function.preset")):
        # absolute, relative to where dvr runs (links are followed when it is read: a link loop is one line there)
        out["transfer_function.file"] = os.path.abspath(os.path.expanduser(out.pop("transfer_function.preset")))
    if getattr(args, "scattering", None) and getattr(args, "shading", None) is None:
        out["renderer.shading.enabled"] = False  # scattering lights the samples instead (--shading: refused)
    if args.demo:
        out["volume.demo"] = args.demo
    if args.size:
        out["image.width"], out["image.height"] = parse_size(args.size)
    if args.background:
        try:
            bg = [float(x) for x in args.background.split(",")]
        except ValueError:
            bg = []
        if len(bg) not in (3, 4):
            raise DvrError(f"--background {args.background!r}: use R,G,B or R,G,B,A numbers in 0..1")
        out["image.background"] = bg + [1.0] * (4 - len(bg))
    if getattr(args, "mesh", None):
        out["renderer.geometry"] = [mesh_table(item) for item in args.mesh]
    out.update(set_overrides(args.set))
    return out


def mesh_table(item: str) -> dict:
    """``--mesh FILE[:R,G,B]`` as a ``[[renderer.geometry]]`` table (the path made absolute: relative to
    where dvr runs, not to a scene file)."""
    head, sep, tail = item.rpartition(":")
    if not sep or "/" in tail or "\\" in tail or os.path.exists(item):  # no colour (or a drive's colon)
        path, sep, colour = item, "", ""
    else:
        path, colour = head, tail
    table = {"path": os.path.abspath(os.path.expanduser(path))}
    if sep:
        try:
            rgb = [float(x) for x in colour.split(",")]
        except ValueError:
            rgb = []
        if len(rgb) != 3:
            raise DvrError(f"--mesh {item!r}: give FILE or FILE:R,G,B with three numbers in 0..1")
        table["color"] = rgb
    return table


def set_overrides(items: list[str]) -> dict:
    """``--set KEY=VALUE`` items as scene overrides (values in TOML syntax)."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise DvrError(f"--set {item!r}: use KEY=VALUE, e.g. renderer.filter=nearest")
        out[key.strip()] = parse_value(value.strip())
    return out


def frame_paths(output: Path, frames: int | None) -> list[Path]:
    """The files the frames go to: one (a single image, or an animation of every frame), or one per frame."""
    if frames is None:
        return [output]
    if not 1 <= frames <= MAX_FRAMES:
        raise DvrError(f"--frames must be in [1, {MAX_FRAMES}] (the images of the animation, numbered with 4 "
                       f"digits), got {frames}")
    if output.suffix.lower() in MOVIE_FORMATS:
        return [output]
    return [output.with_name(f"{output.stem}_{i:04d}{output.suffix}") for i in range(frames)]


def _staged_name(path: Path) -> Path:
    """A hidden temporary name beside ``path`` for a frame of a sequence, with its suffix (the format)."""
    return path.with_name(f".{path.stem}.{os.getpid()}.partial{path.suffix}")


def sandbox_of(args) -> Sandbox:
    """The limits the sandbox flags ask for (none given: the unbounded default)."""
    memory = parse_bytes(args.max_memory) if args.max_memory is not None else None
    return Sandbox(tuple(args.sandbox or ()), memory, args.max_seconds)


def check_data_given(args, verb: str = "render"):
    """One scene: a scene file, volume files or the demo (the files sorted: :func:`positional_volume`)."""
    if not args.scene and not args.demo and not args.volume and not args.field_files:
        raise DvrError(f"nothing to {verb}: give a scene file, --volume FILE or --demo")
    if args.demo and args.volume:
        raise DvrError("give --demo or --volume, not both")


def source_of(args, verb: str = "render") -> cli_fields.Source:
    """What the command line's scene is made of (:class:`.fields.Source`), its files sorted
    (:func:`positional_volume`, called first) and checked."""
    check_data_given(args, verb)
    return cli_fields.source_of(args, overrides_from(args), args.transfer_function or [])


def animation_of(args, source: cli_fields.Source, scene) -> Animation | None:
    """The animation ``--frames`` and ``--animate`` ask for (None: one image); a time animation finds its files'
    steps (:func:`.fields.timed_files`)."""
    path = scene.camera_path()
    kinds = args.animate or (frozenset({"path" if path else "orbit"}) if args.frames is not None else frozenset())
    if not kinds:
        return None
    if "path" in kinds and path is None:
        raise DvrError("--animate path: the scene has no [[camera.keyframe]] tables (docs/scene-files.md)")
    if "path" in kinds and path.steps is not None:
        kinds = kinds | {"time"}  # the keyframes' steps walk the time series
    steps = 1
    if "time" in kinds:
        if args.time is not None:
            raise DvrError(f"--time {args.time} renders one step; --animate time renders every step: give one")
        if getattr(args, "dask", None):
            raise DvrError("--animate time with --dask: the steps are read one at a time in this process; "
                           "render a time animation without --dask")
        steps, _ = cli_fields.timed_files(source, scene)
    frames = args.frames if args.frames is not None else steps
    if "time" not in kinds and args.frames is None:
        raise DvrError(f"--animate {'path' if 'path' in kinds else 'orbit'} needs --frames N (the frames of the "
                       f"{'path' if 'path' in kinds else 'turn'})")
    if not 1 <= frames <= MAX_FRAMES:
        raise DvrError(f"--frames must be in [1, {MAX_FRAMES}] (the images of the animation, numbered with 4 "
                       f"digits), got {frames}")
    if "path" in kinds and path.steps is not None and max(path.steps) >= steps:
        raise DvrError(f"camera.keyframe: step {max(path.steps)} is beyond the time series' {steps} steps "
                       f"(0 .. {steps - 1})")
    return Animation(frames, "orbit" in kinds, steps, path if "path" in kinds else None)


def check_depth(args, scene, outputs: list[Path]):
    """``--depth``: refuse, in one line before any work, what cannot give or hold a depth image (the renderer asked
    through its declared trait, ``RendererPlugin.depth_output``; the outputs through :mod:`dvr_gl.depth_image`)."""
    from dvr_gl import depth_image

    problem = registry.depth_refusal(scene)
    if problem:
        raise DvrError(f"--depth: {problem}")
    if getattr(args, "dask", None):
        raise DvrError("--depth: depth images are drawn on one machine, not on Dask workers; leave out --dask")
    for path in outputs:
        depth_image.check_output(path, args.overwrite, sequence=len(outputs) > 1)


def write_frame(path: Path, image, depth, overwrite: bool):
    """One image file, with its depth where one was drawn (:func:`dvr_gl.depth_image.write`)."""
    if depth is None:
        write_image(path, image, overwrite)
        return
    from dvr_gl import depth_image

    depth_image.write(path, image, depth, overwrite)


def run(args) -> int:
    with active(sandbox_of(args)):
        return render(args)


def render(args) -> int:
    positional_volume(args)
    source = source_of(args)
    begun = time.perf_counter()
    scene = source.load()
    log.debug("scene loaded and resolved in %.2f s", time.perf_counter() - begun)
    animation = animation_of(args, source, scene)
    outputs = frame_paths(Path(args.output), animation.frames if animation else None)
    count = animation.frames if animation else 1
    frame_scene = Frames(scene, animation or Animation(1, False), lambda k: source.load(k, scene.renderer).field)
    for path in outputs:  # before rendering: fail fast, and never half-overwrite a sequence
        check_output_path(path, args.overwrite)
    movie = outputs[0].suffix.lower() in MOVIE_FORMATS
    annotations = getattr(args, "annotate", None)
    if annotations and outputs[0].suffix.lower() in FLOAT_FORMATS:
        raise DvrError(f"--annotate draws on the 8-bit picture: write .png, .jpg or an animation, not "
                       f"{outputs[0].suffix} (the float image is never annotated)")
    if annotations:
        from dvr_gl.annotations import layout

        layout(scene, annotations)  # an image too small for them: refused before rendering
    if movie:
        check_movie(outputs[0], scene.image.width, scene.image.height, args.fps, scene.image.background)
    depth = getattr(args, "depth", False)
    if depth:
        check_depth(args, scene, outputs)
    if args.save_scene:
        check_writable(Path(args.save_scene), args.overwrite)
    registry.check(scene)  # before rendering: the renderer's one-line refusal, if any
    if scene.tolerance_choice is not None and not args.quiet:  # a result (the settings chosen): stdout
        given = getattr(args, SETTING_DEST + "tolerance", None)
        print(f"tolerance {given if given is not None else 'from the scene'}: "
              f"{scene.tolerance_choice.describe(scene.field.sample_spacing)}")
    if getattr(args, "dask", None):
        from dvr_gl.distributed.session import check_request

        check_request(scene, args.compositing_method)  # one line before a cluster starts
        if args.sandbox or args.max_seconds is not None or args.max_memory is not None:
            raise DvrError("--dask with the sandbox's flags: the limits hold in this process, not in the Dask "
                           "workers; render scenes you did not write without --dask")
    renderer = create_renderer(scene.renderer.name)
    renderer.want_depth = depth
    start = time.perf_counter()
    staged = []  # a sequence's frames under temporary names, renamed into place once every frame is drawn
    try:
        with contextlib.ExitStack() as stack:
            sink = stack.enter_context(Movie(outputs[0], count, args.fps, args.overwrite)) if movie else None
            remote = None
            if getattr(args, "dask", None):  # the same frames, drawn by Dask workers
                from dvr_gl.distributed.session import frames_on

                remote = stack.enter_context(frames_on(args.dask, [frame_scene(i) for i in range(count)],
                                                       args.compositing_method, renderer))
            if animation is not None:  # a bar over the frames, at once: an animation is long work by request
                step = stack.enter_context(progress.task("frames", count, "frame", delay=0.0, leave=True))
            elif remote is None:  # a long frame's steps (the CPU references'), shown after progress.DELAY seconds
                renderer.progress = stack.enter_context(progress.task("rendering"))  # (Dask's workers report none)
            for i in range(count):
                frame = frame_scene(i)
                begun = time.perf_counter()
                image = composite_over(next(remote) if remote is not None else renderer.render(frame),
                                       scene.image.background)
                if annotations:
                    from dvr_gl.annotations import annotate

                    image = annotate(encode_8bit(image), frame, annotations)
                log.debug("frame %d rendered in %.2f s%s", i, time.perf_counter() - begun,
                          " (compiling the shaders included)" if i == 0 and registry.plugin(
                              scene.renderer.name).needs_gl else "")
                if sink is not None:
                    sink.add(image)
                elif len(outputs) > 1:  # a run stopped at frame k (the time limit, Ctrl-C) leaves no frames
                    staged.append((_staged_name(outputs[i]), outputs[i]))
                    write_frame(staged[-1][0], image, renderer.depth, True)
                else:
                    write_frame(outputs[i], image, renderer.depth, args.overwrite)
                if renderer.stats.get("converged") is False:
                    log.warning("%s did not reach renderer.converged_tolerance %g in every pixel",
                                f"frame {i}" if movie else outputs[i], scene.renderer.converged_tolerance)
                if animation is not None:
                    step(i + 1)
        for temporary, final in staged:
            os.replace(temporary, final)
        staged.clear()
    finally:
        renderer.close()  # also on Ctrl-C (exit 130): the GL context is released, nothing was written
        for temporary, _ in staged:
            with contextlib.suppress(OSError):
                temporary.unlink()
    rendered = time.perf_counter() - start
    if args.save_scene:
        scene_path = Path(args.save_scene)
        # where the file will be: the rename that writes it replaces a link there (abspath, not resolve: a link
        # loop at that name raised RuntimeError)
        write_text(scene_path, scene.to_toml(relative_to=Path(os.path.abspath(scene_path)).parent), args.overwrite)
    if not args.quiet:
        if movie:
            what = f"{outputs[0]} ({count} frame{'s' * (count > 1)} at {args.fps:g} fps, "
        elif animation is not None:
            what = f"{count} frames to {outputs[0]} .. {outputs[-1].name} ("
        else:
            what = f"{outputs[0]} ("
        # render: the frames (compiling included); total: what the user waited, from the process's start
        total = time.perf_counter() - getattr(args, "started", start)
        print(f"wrote {what}{scene.image.width}x{scene.image.height}, {scene.renderer.name}; "
              f"render {rendered:.2f} s, total {total:.2f} s)")
    return 0

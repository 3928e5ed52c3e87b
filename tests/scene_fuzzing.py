"""Hypothesis strategies and outcome checks for fuzzing scenes and the command line (issue 14, item 5).

Shared by ``tests/scene/test_fuzz_scenes.py`` (a bounded number of examples in CI) and
``benchmarks/fuzz_scenes.py`` (a longer run).  Scenes are built from the real schema: every table of
:class:`dvr_gl.scene.schema.SceneSpec`, every ``[renderer]`` key the registry declares, the shading table
and its lights; each key is absent, a value of its own type, or a wild one (another type, NaN,
infinities, huge or negative numbers, random strings, lists, tables), and tables may be missing,
replaced by a scalar or joined by unknown ones.

An outcome is ``"user error"`` (a :class:`~dvr_gl.errors.DvrError`), ``"loaded"`` (or ``"rendered"``),
or ``"other"`` with the exception: the bug these tests look for.

What the other parts of issue 14 bound (table sizes against GL limits, the demo's size, the image size
against the framebuffer, unbounded work from tiny sample distances or tolerances) is drawn from small
ranges here (:data:`BOUNDED`), so that an example never allocates gigabytes or runs for minutes.
"""

from __future__ import annotations

import dataclasses
import io
import math
import random
import typing
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
from hypothesis import strategies as st

from dvr_gl.errors import DvrError
from dvr_gl.scene.model import ClippingSpec, GeometrySpec, ScatteringSpec, ShadingSpec
from dvr_gl.scene.resolve import _FILE_KEYS as _SCENE_FILE_KEYS
from dvr_gl.scene.schema import CameraSpec, ImageSpec, TransferFunctionSpec, VolumeSpec, renderer_spec_class
from judges import DISCRETE

#: Numbers for keys whose large values are the resource bounds' business (another part of issue 14).
BOUNDED = {
    "volume.size": st.one_of(st.integers(2, 20), st.integers(2, 20), st.integers(-3, 1)),
    "image.width": st.integers(-3, 24), "image.height": st.integers(-3, 24),
    "renderer.lut_size": st.integers(-3, 4096), "renderer.preintegration_size": st.integers(-3, 64),
    "renderer.converged_tolerance": st.floats(1e-3, 1.0), "renderer.texture_budget_mb": st.floats(-1, 4096),
    "renderer.sample_distance_voxels": st.one_of(st.floats(0.2, 10), st.sampled_from([0.0, -1.0])),
    "renderer.sample_distance": st.one_of(st.floats(0.2, 10), st.sampled_from([0.0, -1.0])),
    "renderer.iso_refinement": st.integers(-3, 70),
    "renderer.extremum_refinement": st.integers(-3, 12),
    "renderer.extremum_brackets": st.integers(-1, 4),
}

WILD_NUMBERS = st.one_of(
    st.sampled_from([0, -1, 1, 2**63 - 1, -(2**63), 2**64, 0.0, -0.0, 1e-300, -1e-300, 1e300, -1e300,
                     math.nan, math.inf, -math.inf, 0.5, 1.5]),
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-(2**70), 2**70))
WILD_SCALARS = st.one_of(WILD_NUMBERS, st.booleans(), st.text(max_size=12))
WILD = st.one_of(WILD_SCALARS, st.lists(WILD_SCALARS, max_size=5),
                 st.dictionaries(st.text(max_size=6), WILD_SCALARS, max_size=3))
#: Wild values for the keys in BOUNDED: no numbers (a huge one is the resource bounds' case).
WILD_NOT_NUMBERS = st.one_of(st.booleans(), st.text(max_size=12), st.lists(WILD_SCALARS, max_size=5),
                             st.dictionaries(st.text(max_size=6), WILD_SCALARS, max_size=3))


def _valid(tp, key: str, choices: tuple):
    """Values of the key's own type, mostly in a plausible range (the checks decide what is valid)."""
    if key in BOUNDED:
        return BOUNDED[key]
    if choices:
        return st.sampled_from(choices)
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin is typing.Union or (origin is not None and type(None) in args):
        return _valid(next(a for a in args if a is not type(None)), key, choices)
    if tp is float:
        return st.one_of(st.floats(1e-3, 1.0), st.floats(1e-3, 1.0), st.floats(-2, 400, allow_nan=False),
                         st.sampled_from([0.0, -1.0, 1e-300, -1e-300, 1e-30, 1e30, 1e300, -1e300, 180.0]))
    if tp is int:
        return st.integers(-3, 64)
    if tp is bool:
        return st.booleans()
    if tp is str:
        return st.text(max_size=12)
    if origin is tuple:
        return st.tuples(*(_valid(a, key, ()) for a in args)).map(list)
    if origin is list and args[0] in (int, float):  # ranges and sizes (2D transfer functions)
        return st.lists(_valid(args[0], key, ()), max_size=3)
    if origin is list and typing.get_origin(typing.get_args(args[0])[0] if typing.get_args(args[0]) else None) is list:
        node = st.lists(st.one_of(st.floats(0, 1), st.floats(-0.5, 1.5)), min_size=3, max_size=5)
        return st.lists(st.lists(node, max_size=3), max_size=3)  # a 2D table's nodes: value x gradient x rgba
    if origin is list and typing.get_origin(args[0]) is list:  # control points
        colour = st.one_of(st.floats(0, 1), st.floats(0, 1), st.floats(0, 1), st.floats(-0.5, 1.5))
        point = st.one_of(st.lists(colour, min_size=4, max_size=4), st.lists(colour, max_size=6))
        return st.lists(point, max_size=5).map(lambda rows: [[i / 4.0] + r for i, r in enumerate(rows)])
    if origin is list and typing.get_origin(args[0]) is tuple:  # clipping planes
        return st.lists(_valid(args[0], key, ()), max_size=3)
    if origin is list and dataclasses.is_dataclass(args[0]):  # lights, meshes
        return st.lists(table(args[0], f"{key}[]", wildness=0.0), max_size=3)
    if dataclasses.is_dataclass(tp):
        return table(tp, key, wildness=0.0)
    raise TypeError(f"no strategy for {key}: {tp}")


#: How wild a whole example is: the chance that a present key gets a value of another kind.
WILDNESS = (0.0, 0.0, 0.02, 0.1, 0.5)
#: Keys that only volume files read (a demo refuses them: the scene's list, and the raw reader's own), and
#: volume.out_of_core (a demo is made in memory: true is refused).
FILE_KEYS = tuple(dict.fromkeys(_SCENE_FILE_KEYS + ("header_bytes", "endian", "format", "out_of_core")))


def _accepted(cls, name: str, value) -> bool:
    """Whether the parser (and, for a renderer setting, its declared check) accepts ``value`` for key ``name``."""
    from dvr_gl.renderers import registry
    from dvr_gl.scene.schema import parse_table

    try:
        parsed = getattr(parse_table(cls, {name: value}, ""), name)
        for setting in registry.all_settings():
            if cls is renderer_spec_class() and setting.name == name:
                setting.validate(parsed)
    except DvrError:
        return False
    return True


def _coin(draw) -> random.Random:
    """A fair coin seeded by hypothesis: its own draws (``st.floats``, ``st.randoms``) favour the ends of
    their range, which would make every key wild or none; the values themselves keep that bias."""
    return random.Random(draw(st.integers(0, 2**32 - 1)))


@st.composite
def table(draw, cls, where: str, rnd=None, wildness: float = 0.1, present: float = 0.3):
    """A TOML table for dataclass ``cls``: each key absent or present (chance ``present``), of its own type
    or, with chance ``wildness``, wild; sometimes an unknown key.  ``rnd``: the example's coin."""
    rnd = rnd or _coin(draw)
    hints = typing.get_type_hints(cls)
    out = {}
    for f in dataclasses.fields(cls):
        if rnd.random() >= present:
            continue
        key = f"{where}.{f.name}"
        own = _valid(hints[f.name], key, f.metadata.get("choices", ()))
        coin = rnd.random()
        if coin < wildness:
            out[f.name] = draw(WILD_NOT_NUMBERS if key in BOUNDED else WILD)
        elif coin < 2 * wildness:  # its own type, any value: out of range too
            out[f.name] = draw(own)
        else:  # a value the key accepts by itself (combinations may still conflict)
            out[f.name] = draw(own.filter(lambda v, name=f.name: _accepted(cls, name, v)))
    if rnd.random() < wildness:
        out["bogus_key"] = draw(WILD)
    return out


@st.composite
def _volume(draw, files: dict[str, Path], rnd, wildness: float):
    """A demo (mostly) or one of ``files`` by name (a small volume, a folder, a missing or empty file; not
    the transfer-function files and meshes, which :func:`scene_dicts` gives to their own keys)."""
    volume = draw(table(VolumeSpec, "volume", rnd, wildness, present=0.15))
    kind = rnd.random()
    if kind < 0.7:
        volume["demo"] = draw(st.sampled_from(["shepp-logan", "marschner-lobb"]))
        volume.setdefault("size", 12)  # not the default 64: its phantom takes a third of a second
        volume.pop("path", None)
        if rnd.random() >= wildness:  # keys a demo refuses, unless wild
            for key in FILE_KEYS:
                volume.pop(key, None)
    elif kind < 0.9:
        volumes = sorted(k for k in files if not k.startswith(("tf", "mesh")))  # those are the other keys' files
        volume["path"] = str(files[draw(st.sampled_from(volumes))])
        volume.pop("demo", None)
    else:
        volume["demo"] = draw(WILD)
    return volume


@st.composite
def scene_dicts(draw, files: dict[str, Path]):
    """Whole scene dicts built from the schema: each table present, absent or (when wild) a wild value,
    the renderer's with its shading, scattering and clipping tables; sometimes an unknown table.  Files
    named ``tf...`` and ``mesh...`` in ``files`` are given as ``transfer_function.file`` and as
    ``[[renderer.geometry]]`` paths."""
    rnd = _coin(draw)
    wildness = rnd.choice(WILDNESS)

    def maybe(strategy):
        if rnd.random() < wildness / 4:
            return draw(WILD_SCALARS)
        return draw(strategy) if rnd.random() < 0.6 else None

    renderer = maybe(table(renderer_spec_class(), "renderer", rnd, wildness, present=0.1))
    if isinstance(renderer, dict) and rnd.random() < 0.3:
        renderer["shading"] = draw(table(ShadingSpec, "renderer.shading", rnd, wildness))
    if isinstance(renderer, dict) and rnd.random() < 0.2:
        renderer["scattering"] = draw(table(ScatteringSpec, "renderer.scattering", rnd, wildness, present=0.6))
    if isinstance(renderer, dict) and rnd.random() < 0.2:  # its planes and box, wild as any table
        renderer["clipping"] = draw(table(ClippingSpec, "renderer.clipping", rnd, wildness, present=0.6))
    meshes = [str(p) for k, p in sorted(files.items()) if k.startswith("mesh")]
    if isinstance(renderer, dict) and meshes and rnd.random() < 0.15:  # real meshes (and wild tables)
        renderer["geometry"] = [{**draw(table(GeometrySpec, "renderer.geometry[]", rnd, wildness, present=0.5)),
                                 "path": draw(st.sampled_from(meshes))} for _ in range(rnd.randint(1, 2))]
    scene = {
        "volume": maybe(_volume(files, rnd, wildness)) if wildness else draw(_volume(files, rnd, 0.0)),
        "transfer_function": maybe(table(TransferFunctionSpec, "transfer_function", rnd, wildness)),
        "camera": maybe(table(CameraSpec, "camera", rnd, wildness)),
        "image": maybe(table(ImageSpec, "image", rnd, wildness)),
        "renderer": renderer,
        "extra": draw(WILD) if rnd.random() < wildness / 4 else None,
    }
    tf_files = [str(p) for k, p in sorted(files.items()) if k.startswith("tf")]
    if isinstance(scene.get("transfer_function"), dict) and tf_files and rnd.random() < 0.3:
        tf = scene["transfer_function"]  # a real file (its keys drawn above may conflict: a user error)
        tf["file"] = draw(st.sampled_from(tf_files))
        if rnd.random() >= wildness:
            tf.pop("preset", None)
            tf.pop("points", None)
    return {k: v for k, v in scene.items() if v is not None}


# --- outcomes ----------------------------------------------------------------------------------

def scene_outcome(raw: dict, render: bool | str = False) -> tuple[str, BaseException | None]:
    """Load ``raw`` as a scene (and, if asked, render it at 16x16 on the CPU reference, or with
    ``render="own"`` on the scene's own renderer, GL ones included); a warning on the way is a finding too."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outcome = _scene_outcome(raw, render)
    leaked = [w for w in caught if issubclass(w.category, (RuntimeWarning, UserWarning))]
    if leaked and outcome[0] != "other":  # the CLI hides warnings, but their sources are bugs to fix
        return "other", RuntimeWarning(f"{leaked[0].message} ({Path(leaked[0].filename).name}:{leaked[0].lineno})")
    return outcome


def _scene_outcome(raw: dict, render: bool):
    from dvr_gl.renderers import create_renderer, registry
    from dvr_gl.scene.resolve import load_scene

    try:
        scene = load_scene(None, base=raw)
        if not render:
            return "loaded", None
        scene = scene.replace(image=ImageSpec(16, 16, scene.image.background))
        if render != "own":
            scene = scene.with_renderer(name=DISCRETE)
        registry.check(scene)
        with create_renderer(scene.renderer.name) as renderer:
            rgba = renderer.render(scene)
        # lights brighter than 1 scatter more than the colours, and an opaque mesh's Blinn-Phong reaches past 1
        # (0.8 x (0.2 + 0.7) + 0.3 with the default coefficients): high dynamic range, by design
        hdr = scene.renderer.scattering.enabled or bool(getattr(scene.renderer, "geometry", None))
        bright = rgba[..., :3].max() if not hdr else 0.0
        if not (np.isfinite(rgba).all() and rgba.min() >= 0 and max(rgba[..., 3].max(), bright) <= 1 + 1e-6):
            return "other", AssertionError(f"pixels out of [0, 1] or not finite: {rgba.min()}..{rgba.max()}")
        return "rendered", None
    except DvrError:
        return "user error", None
    except Exception as exc:  # the bug looked for
        return "other", exc


# --- the command line --------------------------------------------------------------------------

def _flag_values(action) -> st.SearchStrategy:
    dest = action.dest
    numbers = ["0", "-1", "nan", "inf", "-inf", "1e308", "1e-300", "abc", "", "0.5", "1", "30", "2.5", "-0"]
    if action.nargs == 0:
        return st.just([])
    if action.choices:
        return st.one_of(st.sampled_from(list(action.choices)), st.text(max_size=6)).map(lambda v: [str(v)])
    if dest in ("size",):
        return st.sampled_from(["8", "8x6", "0", "-3x4", "1.5", "x", "8x8x8", "", "16x"]).map(lambda v: [v])
    if dest in ("frames",):
        return st.sampled_from(["0", "-1", "2", "x", "100000", "1.5"]).map(lambda v: [v])
    if dest in ("setting_sample_distance", "setting_sample_distance_voxels", "setting_converged_tolerance"):
        return st.sampled_from(["0", "-1", "nan", "inf", "abc", "0.5", "1", "1e308"]).map(lambda v: [v])
    if dest in ("setting_lut_size",):
        return st.sampled_from(["0", "1", "2", "-5", "x", "4096", "1.5"]).map(lambda v: [v])
    if dest in ("annotate",):  # issue 43: the overlay's items (a float output with it: a user error)
        return st.sampled_from(["all", "axes", "colorbar,scalebar", "scalebar,unit=mm", "caption=a, b", "bogus", "",
                                "axes,", "caption=", "unit=", "axes=1", "colorbar,value_unit=HU"]).map(lambda v: [v])
    if dest in ("animate",):  # path: the scene's keyframes (the demo has none: a user error)
        return st.sampled_from(["orbit", "path", "time", "time,path", "orbit,path", "x", ""]).map(lambda v: [v])
    if dest in ("max_seconds",):
        return st.sampled_from(["0", "-1", "nan", "inf", "x", "60"]).map(lambda v: [v])
    if dest in ("max_memory",):
        return st.sampled_from(["0", "x", "1", "2GiB", "1e99", "12 parsecs"]).map(lambda v: [v])
    if dest in ("sandbox",):
        return st.sampled_from(["/", "/nonexistent", ".", "/dev/null"]).map(lambda v: [v])
    if dest in ("set",):
        keys = st.sampled_from(["renderer.filter", "camera.fov", "volume.size", "image.width", "renderer.shading",
                                "transfer_function.points", "nosection", "a.b.c", "renderer.shading.lights"])
        values = st.sampled_from(["nearest", "0", "[]", "nan", "{x=1}", "'s'", "-1", "[[0,1,1,1,1]]", "8", ""])
        return st.tuples(keys, values).map(lambda kv: [f"{kv[0]}={kv[1]}"])
    if dest in ("output", "save_scene", "volume", "scene"):
        return st.none()  # paths are the tests' own cases
    count = action.nargs if isinstance(action.nargs, int) else 1
    return st.lists(st.sampled_from(numbers), min_size=count, max_size=count)


def cli_argvs(parser) -> st.SearchStrategy:
    """``dvr render`` flag lists (``-o`` and the demo added by the caller), from the parser itself."""
    render = parser._subparsers._group_actions[0].choices["render"]
    options = []
    for action in render._actions:
        if not action.option_strings or action.dest in ("help", "debug"):
            continue
        values = _flag_values(action)
        options.append(values.map(lambda v, flag=action.option_strings[-1]: None if v is None else [flag, *v]))
    one = st.one_of(options)
    return st.lists(one, max_size=6).map(lambda items: [a for item in items if item for a in item])


def cli_outcome(argv: list[str]) -> tuple[str, str]:
    """Run ``dvr render`` in-process: ``("ok" | "user error" | "other", stderr)``; "other" unless the exit
    status is 0 (no Python warning or traceback) or 1 with one ``dvr render: error:`` line."""
    from dvr_gl.apps.cli import main

    err = io.StringIO()
    with redirect_stderr(err), redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's own (one line, exit 1)
            code = exc.code
    text = err.getvalue()
    lines = text.strip().splitlines()
    if "--verbose" in argv or "-v" in argv:  # the log's own lines ("scene loaded and resolved in ...") come first
        lines = [line for line in lines if line.startswith("dvr ") or "Traceback" in line or "Error" in line]
    if code == 0:  # stderr may hold the progress bar and dvr's own warnings, never Python's or a traceback
        leaked = any(word in text for word in ("Warning:", "Traceback", "error"))
        return ("other" if leaked else "ok"), text
    if code == 1 and len(lines) == 1 and ": error: " in lines[0] and "internal error" not in lines[0]:
        return "user error", text
    return "other", f"exit {code}: {text}"

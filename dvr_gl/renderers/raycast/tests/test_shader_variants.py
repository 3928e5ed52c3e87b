"""Every program the ray caster can ask for compiles: ``raycast.frag`` under a covering set of its defines,
the bricked passes' ``resolve.frag`` and the ray bounds' ``ray_bounds.vert``/``.frag``.

The defines are the renderer's own: each case is a scene whose ``[renderer]`` values come from the
raycast plugin's declared settings (every choice of every setting with choices, both values of every
boolean one, the shading, scattering, clipping and geometry tables at the values their fields declare,
each projection the plugin renders), turned into defines by :func:`shader_features` as a frame does,
then crossed with what a frame decides at render time (sample counting, bricked passes, the
skipping decision of ``decide_skipping`` -- block skipping, ray bounds, both -- and every pyramid depth
``NUM_LEVELS`` up to :data:`.acceleration.MAX_LEVELS`).

Why a covering set, and why it covers: the full cross product is 6.6 x 10^9 cases (22 axes of 2 to
13 values), far beyond what llvmpipe compiles in seconds (0.1 to 0.3 s a program here).  The cases
cover every *pair* of values of any two axes (a greedy pairwise covering array, generated below from
the axes, not written out): a define that breaks the program alone, or only together with one other
feature's, is compiled at least once in a failing combination.  Pairs the scene loader refuses
(scattering with a projection mode, with shading or with clipping, ...) are found by loading the
scenes, not listed here: a refused case is shrunk to the values that make it refused, which are then
never combined again.  A last check ties the cases to the shader: every preprocessor name the ray
caster's own GLSL tests is defined in some compiled case, so a new define no case reaches fails here.

Measured on llvmpipe (Mesa 22.3, LLVM 15; 2 cores shared with other jobs): 66 cases, about
930 scenes loaded (most to shrink the refused cases), 16 s of CPU time, 31 s wall clock under a load of 12.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pytest

from dvr_gl.errors import SceneError, ShaderError
from dvr_gl.gl.context import make_current
from dvr_gl.gl.shaders import create_program
from dvr_gl.renderers import registry
from dvr_gl.renderers.raycast.acceleration import MAX_LEVELS
from dvr_gl.renderers.raycast.fields import frame_features
from dvr_gl.renderers.raycast.renderer import BLOCK_SKIPPING_DEFINES, SHADERS, SKIPPING_DEFINES, shader_features
from dvr_gl.scene.model import PHASE_FUNCTIONS, SCATTERING_METHODS
from dvr_gl.scene.resolve import load_scene

# Names the shaders define for themselves, or read only from the library's snippets' own logic.
SELF_DEFINED = {"NEEDS_GRADIENT", "STEP", "SKIPPABLE", "RUN_DENSE", "block_voxel", "u_slab_length",
                "AFFINE_FETCH"}


def setting_axes() -> dict[str, tuple]:
    """The raycast plugin's settings as axes: each a tuple of scene overrides (dicts of dotted keys)."""
    plugin = registry.plugin("raycast")
    axes = {}
    for setting in plugin.settings:
        if setting.choices:
            axes[setting.name] = tuple({setting.key: c} for c in setting.choices)
        elif setting.type is bool:
            axes[setting.name] = ({setting.key: False}, {setting.key: True})
    axes["ert_threshold"] = ({"renderer.ert_threshold": 1.0}, {"renderer.ert_threshold": 0.9})
    # MIP and MinIP refine one or two brackets (the defaults choose either; SECOND_BRACKET where two)
    axes["extremum_brackets"] = ({}, {"renderer.extremum_brackets": 1}, {"renderer.extremum_brackets": 2})
    axes["shading"] = ({"renderer.shading.enabled": False},
                       {"renderer.shading.enabled": True, "renderer.shading.two_sided": False},
                       {"renderer.shading.enabled": True, "renderer.shading.lights": [{}, {}]})
    axes["scattering"] = ({"renderer.scattering.enabled": False},) + tuple(
        {"renderer.scattering.enabled": True, "renderer.scattering.method": method, "renderer.scattering.phase": phase,
         "renderer.scattering.lights": [{}] * lights}
        for method, phase, lights in itertools.product(SCATTERING_METHODS, PHASE_FUNCTIONS, (1, 2)))
    axes["clipping"] = ({}, {"renderer.clipping.planes": [[1.0, 0.0, 0.0, -1.0]]},
                        {"renderer.clipping.box": [[0.5, 0.5, 0.5], [6.0, 6.0, 6.0]]},
                        {"renderer.clipping.planes": [[1.0, 0.0, 0.0, -1.0], [0.0, 1.0, 0.0, -1.0]],
                         "renderer.clipping.box": [[0.5, 0.5, 0.5], [6.0, 6.0, 6.0]]})
    axes["projection"] = tuple({"camera.projection": p} for p in plugin.projections)
    return axes


# What a frame decides after shader_features (RayCastRenderer.decide_skipping, _render_bricks).
FRAME_AXES = {"count_samples": (False, True), "bricked": (False, True), "depth": (False, True),
              "skipping": ("blocks", "blocks and bounds", "bounds only"), "levels": tuple(range(1, MAX_LEVELS + 1))}


# The axis of several fields (dvr_gl/renderers/raycast/fields.py): none, two channels on one grid, a scalar, a
# label map and a colour volume, two channels one of them with a 2D transfer function, a label map beside a
# turned copy of it (its own direction matrix: FIELDS_ORIENTED); their frames are never bricked, count nothing
# and bound their rays or not.
FIELDS = "several fields"


def field_tables(folder: Path, which: str | None) -> list:
    """The [[volume]] tables of a case of several fields (none: one field)."""
    if which is None:
        return []
    if which == "two channels":
        return [{"path": str(folder / "volume.npy")}, {"path": str(folder / "volume.npy")}]
    if which == "a turned member":
        return [{"path": str(folder / "volume.npy")}, {"path": str(folder / "turned.mha"), "role": "label"}]
    if which == "a 2d member":
        return [{"path": str(folder / "volume.npy"),
                 "transfer_function": {"boxes_2d": [[0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5]]}},
                {"path": str(folder / "volume.npy")}]
    return [{"path": str(folder / "volume.npy")}, {"path": str(folder / "labels.npy"), "role": "label"},
            {"path": str(folder / "colour.npy"), "role": "rgb"}]


def frame_defines(scene, count_samples: bool, bricked: bool, depth: bool, skipping: str, levels: int) -> dict:
    """The defines of a frame of ``scene`` that decided so (a define it cannot add is left out: a depth image
    in bricked passes)."""
    if scene.field.kind == "fields":
        return frame_features(scene, shader_features, skipping != "blocks")
    defines = shader_features(scene, count_samples, bricked, depth=depth and not bricked)
    if "ACCELERATE" in defines:
        defines["NUM_LEVELS"] = levels
        if skipping != "blocks" and "COMPOSITE_EMISSION" in defines:  # ray bounds: emission-absorption only
            defines["RAY_BOUNDS"] = True
            if skipping == "bounds only":  # "auto" found block skipping not worth it within the bounds
                defines = {k: v for k, v in defines.items() if k not in BLOCK_SKIPPING_DEFINES}
    return defines


def _pair(a: int, i: int, b: int, j: int) -> tuple:
    return (a, i, b, j) if a < b else (b, j, a, i)


def _holds(case: dict, core: dict) -> bool:
    """Whether ``case`` (axis index to value index) has every value of ``core``."""
    return all(case.get(a) == i for a, i in core.items())


class Cases:
    """A pairwise covering array over ``axes`` (name: values), built greedily one case at a time: each case
    starts from the first pair not yet covered and gives every other axis the value covering the most new
    pairs.  ``refused(case)`` (a case: axis index to value index, the others at their first value) says
    whether a case is impossible; a refused case is shrunk to a core of values refused by itself, which no
    later case contains (pairs holding a core are dropped; a pair that cannot be completed too)."""

    def __init__(self, axes: dict, refused):
        self.names, self.values, self.refused = list(axes), list(axes.values()), refused
        self.forbidden: list[dict] = []
        self.uncovered = {(a, i, b, j) for a, b in itertools.combinations(range(len(self.names)), 2)
                          for i in range(len(self.values[a])) for j in range(len(self.values[b]))}

    def _allowed(self, case: dict) -> bool:
        return not any(_holds(case, core) for core in self.forbidden)

    def _gain(self, case: dict, axis: int, value: int) -> int:
        return sum(_pair(a, i, axis, value) in self.uncovered for a, i in case.items())

    def _fill(self, a: int, i: int, b: int, j: int) -> dict:
        case = {a: i, b: j}
        for axis in range(len(self.names)):
            if axis not in case:
                order = sorted(range(len(self.values[axis])), key=lambda v: -self._gain(case, axis, v))
                case[axis] = next((v for v in order if self._allowed({**case, axis: v})), order[0])
        return case

    def _forbid(self, case: dict):
        """Shrink a refused case to a refused core (values put back to their axis's first one while the case
        stays refused) and forbid it."""
        core = {k: v for k, v in case.items() if v != 0}
        for axis in list(core):
            trial = {k: v for k, v in core.items() if k != axis}
            if self.refused(trial):
                core = trial
        self.forbidden.append(core)  # the pairs left already pass the earlier cores: only the new one to check
        self.uncovered = {p for p in self.uncovered if not _holds({p[0]: p[1], p[2]: p[3]}, core)}

    def __iter__(self):
        while self.uncovered:
            first = min(self.uncovered)
            case = self._fill(*first)
            if not self._allowed(case):  # the greedy fill found no way round a core: give the pair up
                self.uncovered.discard(first)
                continue
            if self.refused(case):
                self._forbid(case)
                continue
            self.uncovered -= {_pair(a, case[a], b, case[b]) for a, b in itertools.combinations(case, 2)}
            yield {name: self.values[k][case[k]] for k, name in enumerate(self.names)}


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """An 8^3 volume (saved once: no phantom to build per case), a label map and a colour volume beside it,
    and a one-triangle mesh."""
    folder = tmp_path_factory.mktemp("variants")
    rng = np.random.default_rng(1)
    np.save(folder / "volume.npy", rng.random((8, 8, 8), dtype=np.float32))
    np.save(folder / "labels.npy", (rng.random((8, 8, 8)) * 3).astype(np.uint8))
    np.save(folder / "colour.npy", rng.random((8, 8, 8, 4), dtype=np.float32))
    (folder / "triangle.obj").write_text("v 1 1 1\nv 6 1 1\nv 1 6 6\nf 1 2 3\n")
    header = ("ObjectType = Image\nNDims = 3\nDimSize = 8 8 8\nElementType = MET_UCHAR\n"
              "TransformMatrix = 0 1 0 -1 0 0 0 0 1\nElementDataFile = LOCAL\n")  # a quarter turn about z
    (folder / "turned.mha").write_bytes(header.encode() + (rng.random(512) * 3).astype(np.uint8).tobytes())
    return folder


def compile_all(ctx, defines: dict) -> list[str]:
    """Compile the programs a frame with these defines uses; the failures, each with its defines."""
    programs = [("fullscreen.vert", "raycast.frag", defines)]
    if "BRICKED" in defines:  # RayCastRenderer._resolve
        programs.append(("fullscreen.vert", "resolve.frag",
                         {k: v for k, v in defines.items() if k not in SKIPPING_DEFINES}))
    if "RAY_BOUNDS" in defines:  # RayCastRenderer.draw_ray_bounds
        programs.append(("ray_bounds.vert", "ray_bounds.frag",
                         {"CAMERA_ORTHOGRAPHIC": "CAMERA_ORTHOGRAPHIC" in defines}))
    failures = []
    for vertex, fragment, program_defines in programs:
        try:
            create_program(ctx, vertex, fragment, program_defines, roots=SHADERS)
        except ShaderError as exc:
            failures.append(f"{fragment} {sorted(program_defines.items())}: {exc}")
    return failures


def names_the_shaders_test() -> set[str]:
    """The preprocessor names the ray caster's own GLSL tests (#ifdef, #if, defined())."""
    names = set()
    for path in Path(SHADERS[0]).iterdir():
        text = path.read_text(encoding="utf-8")
        names |= set(re.findall(r"#\s*if(?:n?def)?\s+!?\s*([A-Z_][A-Z0-9_]*)", text))
        names |= set(re.findall(r"defined\(([A-Z_][A-Z0-9_]*)\)", text))
    return names - {"defined"}


def test_every_define_combination_compiles(shared_gl_context, folder):
    make_current(shared_gl_context)
    axes = {**setting_axes(), "geometry": ({}, {"renderer.geometry": [{"path": str(folder / "triangle.obj")}]}),
            "transfer function 2d": ({}, {"transfer_function.boxes_2d": [[0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5]]}),
            "fields": ({}, {FIELDS: "two channels"}, {FIELDS: "three roles"}, {FIELDS: "a 2d member"},
                       {FIELDS: "a turned member"})}
    every = {**axes, **FRAME_AXES}
    scenes = {}

    def scene(case: dict):
        """The scene of a case (axis index to value index; the others at their first value), or None where
        the loader or the plugin refuses it."""
        key = tuple(case.get(k, 0) for k in range(len(axes)))
        if key not in scenes:
            overrides = {"volume.path": str(folder / "volume.npy"), "image.width": 8, "image.height": 8}
            for values, v in zip(axes.values(), key):
                overrides.update(values[v])
            tables = field_tables(folder, overrides.pop(FIELDS, None))
            if tables:
                del overrides["volume.path"]
            try:
                scenes[key] = load_scene(None, overrides, base={"volume": tables} if tables else None)
                registry.check(scenes[key], "raycast")  # its settings, traits and own check
            except SceneError:
                scenes[key] = None
        return scenes[key]

    failures, compiled = [], []
    for values in Cases(every, lambda case: scene(case) is None):
        key = {k: axes[name].index(values[name]) for k, name in enumerate(axes)}
        defines = frame_defines(scene(key), *(values[name] for name in FRAME_AXES))
        failures += compile_all(shared_gl_context, defines)
        compiled.append(defines)
    assert not failures, "\n".join(failures)
    unreached = names_the_shaders_test() - SELF_DEFINED - set().union(*compiled)
    assert not unreached, f"the ray caster's GLSL tests {sorted(unreached)}, which no case defines"
    assert len(compiled) >= 24  # at least the 6 x 4 pairs of compositing and filter

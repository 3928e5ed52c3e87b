"""GL limits checked before drawing, resource bounds, progress and Ctrl-C (dvr_gl.limits, issue 14).

Limits are read from the real context where that is cheap (one past GL_MAX_TEXTURE_SIZE), and
faked smaller (monkeypatching :func:`dvr_gl.limits.gl_limits`) to exercise each refusal and the
bricking that handles a volume over a texture limit.  The renderers are picked by what they declare
(``tests/judges.py``); one renderer's own limits are tested in its folder (``test_limits_NAME.py``).
"""

from __future__ import annotations

import dataclasses
import re
import time

import numpy as np
import pytest

from conftest import array_scene, assert_close, small_scene
from dvr_gl import limits
from dvr_gl.apps import cli
from dvr_gl.errors import DvrError
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.sandbox import Sandbox, SandboxError, active
from judges import CONVERGED, DISCRETE
from judges import renderers as declaring

#: the GL renderers that sample the grid kit's bricks (they declare a texture budget): a volume over a
#: texture limit is bricked, and their tables are textures
GL_RENDERERS = tuple(declaring("texture_budget_mb", gl=True))
#: the GL renderers with a sample distance (a work estimate in GPU samples)
SAMPLING = tuple(declaring("sample_distance", gl=True))
#: the renderer a grid scene gets when it names none (the scene's default in small_scene)
DEFAULT = registry.default_for("grid")


@pytest.fixture(scope="module")
def renderers(shared_gl_context):
    made = {name: create_renderer(name, ctx=shared_gl_context) for name in (*GL_RENDERERS, *SAMPLING, DEFAULT)}
    yield made
    for r in made.values():
        r.close()


def fake(monkeypatch, ctx, **smaller):
    """Pretend this GL has the given (smaller) limits."""
    real = limits.gl_limits(ctx)
    monkeypatch.setattr(limits, "gl_limits", lambda _ctx: dataclasses.replace(real, **smaller))


def one_line(exc) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


def test_limits_are_read_once_per_context(gl_context):
    first = limits.gl_limits(gl_context)
    assert first is limits.gl_limits(gl_context)
    info = gl_context.info
    assert first.texture_size == info["GL_MAX_TEXTURE_SIZE"] >= 1024
    assert first.texture_3d_size == info["GL_MAX_3D_TEXTURE_SIZE"]
    assert first.array_layers == info["GL_MAX_ARRAY_TEXTURE_LAYERS"]


@pytest.mark.parametrize("name", GL_RENDERERS)
def test_lut_one_past_the_real_texture_limit_is_refused_not_black(renderers, gl_context, name):
    # the worst known bug: a 16385-entry table on llvmpipe (limit 16384) gave an all-zero image, exit 0
    largest = limits.gl_limits(gl_context).texture_size
    scene = small_scene({"renderer.name": name, "renderer.lut_size": largest + 1, "volume.size": 16,
                         "image.width": 8, "image.height": 8})
    with pytest.raises(DvrError) as exc:
        renderers[name].render(scene)
    assert f"renderer.lut_size = {largest + 1} exceeds GL_MAX_TEXTURE_SIZE {largest}" in one_line(exc)
    assert f"use at most {largest}" in str(exc.value)


@pytest.mark.parametrize("name", GL_RENDERERS)
def test_lut_at_a_faked_limit_renders_and_one_more_is_refused(renderers, gl_context, monkeypatch, name):
    fake(monkeypatch, gl_context, texture_size=64)
    renderer = renderers[name]
    at = small_scene({"renderer.name": name, "renderer.lut_size": 64, "volume.size": 16,
                      "image.width": 16, "image.height": 16})
    assert renderer.render(at)[..., 3].max() > 0.1  # a real picture, not zeros
    with pytest.raises(DvrError, match="renderer.lut_size = 65 exceeds GL_MAX_TEXTURE_SIZE 64 .* at most 64"):
        renderer.render(at.with_renderer(lut_size=65))


@pytest.mark.parametrize("name", GL_RENDERERS)
def test_image_over_the_render_target_limit(renderers, gl_context, monkeypatch, name):
    fake(monkeypatch, gl_context, renderbuffer_size=24)
    scene = small_scene({"renderer.name": name, "volume.size": 16, "image.width": 25, "image.height": 8})
    with pytest.raises(DvrError) as exc:
        renderers[name].render(scene)
    assert "image 25x8 exceeds GL_MAX_RENDERBUFFER_SIZE 24" in one_line(exc) and "at most 24 a side" in str(exc.value)


def test_preintegration_table_over_the_texture_limit(renderers, gl_context, monkeypatch):
    fake(monkeypatch, gl_context, texture_size=100)
    scene = small_scene({"renderer.name": DEFAULT, "renderer.classification": "preintegrated",
                         "renderer.preintegration_size": 101, "renderer.lut_size": 64, "volume.size": 16,
                         "image.width": 8, "image.height": 8})
    with pytest.raises(DvrError, match="renderer.preintegration_size = 101 exceeds GL_MAX_TEXTURE_SIZE 100"):
        renderers[DEFAULT].render(scene)


def brick_limits():
    """Each bricking renderer with each texture limit its volume is held under: one 3D texture, or
    (a renderer drawing fixed planes, the voxel planes) an array of 2D layers, each a 2D texture."""
    for name in GL_RENDERERS:
        if registry.plugin(name).fixed_planes:
            yield name, {"array_layers": 20}
            yield name, {"texture_size": 20}
        else:
            yield name, {"texture_3d_size": 20}


@pytest.mark.parametrize("name, limit", list(brick_limits()))
def test_volume_over_a_texture_limit_is_bricked(renderers, gl_context, monkeypatch, name, limit):
    # image and table within the faked texture side, so only the volume exceeds a limit
    scene = small_scene({"renderer.name": name, "image.width": 16, "image.height": 16, "renderer.lut_size": 16})
    whole = renderers[name].render(scene)
    fake(monkeypatch, gl_context, **limit)
    bricked = renderers[name].render(scene)
    assert renderers[name].stats["bricks"] > 1
    # the same samples from other textures: float32 rounding of the compositing order only
    # (dvr_gl/renderers/raycast/tests/test_bricking_raycast.py measures bricked against the reference at the same
    # tolerance)
    assert_close(bricked, whole.astype(np.float64))


# --- resource bounds: each absurd case refused at once, in one line ---------------------------

ABSURD = [
    *[(name, {"renderer.sample_distance_voxels": 1e-7}, f"{name} would take .* gpu samples .*sample_distance")
      for name in SAMPLING],
    (DISCRETE, {"renderer.sample_distance_voxels": 1e-7}, f"{DISCRETE} would take .* cpu samples"),
    (CONVERGED, {"renderer.converged_tolerance": 1e-300},
     "renderer.converged_tolerance = 1e-300 is below .* at least 1e-12"),
    (DISCRETE, {"renderer.lut_size": 1_000_000_000}, "renderer.lut_size = 1000000000 .* over the memory budget"),
    (DISCRETE, {"renderer.classification": "preintegrated", "renderer.preintegration_size": 100_000},
     "renderer.preintegration_size = 100000 .* over the memory budget"),
    (GL_RENDERERS[0], {"renderer.lut_size": 1_000_000_000},
     "renderer.lut_size = 1000000000 exceeds GL_MAX_TEXTURE_SIZE"),
]


@pytest.mark.parametrize("name, overrides, message", ABSURD)
def test_absurd_work_or_memory_is_refused_at_once(renderers, name, overrides, message):
    # the 256x256 frame (at 32x32, 1e-7 voxels is 2.7e11 samples: inside the GPU bound, ~15 min)
    scene = small_scene({"renderer.name": name, "volume.size": 16, "image.width": 256, "image.height": 256,
                         **overrides})
    renderer = renderers.get(name) or create_renderer(name)
    start = time.perf_counter()
    with pytest.raises(DvrError, match=message) as exc:
        renderer.render(scene)
    one_line(exc)
    assert time.perf_counter() - start < 5.0  # refused before any work (typically milliseconds)


def test_demo_volume_size_is_checked_before_generation():
    with pytest.raises(SandboxError, match=r"volume.size = 3000: 3000\^3 voxels.* lower volume.size"):
        small_scene({"volume.size": 3000})


def test_tiny_spacing_is_refused_by_the_work_estimate(renderers, tmp_path):
    # spacings 1e-300 1 1 made a 0.5e-300 default sample distance: 7 GB of segment windows before failing.
    # The scene now refuses voxels below 1e-18 (float32's safe range); within it, a tiny voxel beside
    # unit ones still means absurd work, which the estimate refuses
    from conftest import array_scene

    scene = array_scene(tmp_path, np.zeros((8, 8, 8), np.float32), {"image.width": 8, "image.height": 8},
                        spacing=(1e-15, 1.0, 1.0))
    # the ray caster's default distance is chosen by the scene (issue 44: 2.75 voxels for this empty one)
    with pytest.raises(DvrError, match=r"[0-9.]+ voxels of the smallest spacing, 1e-15"):
        renderers[DEFAULT].render(scene)


def test_a_sandbox_time_budget_lowers_the_work_bound(renderers):
    # 128^2 rays x about 2600 samples: 4e7, under the bound of an hour, over a tenth of a second's 3e7
    scene = small_scene({"volume.size": 16, "image.width": 128, "image.height": 128,
                         "renderer.sample_distance_voxels": 0.01})
    renderers[DEFAULT].check_resources(scene)  # fine without a budget
    with active(Sandbox(max_seconds=0.1)), pytest.raises(DvrError, match="over the bound of 3e\\+07"):
        renderers[DEFAULT].render(scene)


def test_a_sandbox_time_budget_stops_a_cpu_reference_mid_render(monkeypatch):
    """Between steps the renderer checks the time itself, with the timer's message: here the sandbox's
    timer is switched off, so that the renderer's own check is what stops it."""
    import contextlib

    from dvr_gl import sandbox
    from dvr_gl.reference import discrete

    monkeypatch.setattr(sandbox, "_time_limit", lambda seconds: contextlib.nullcontext())
    monkeypatch.setattr(discrete, "SAMPLES_PER_CHUNK", 64)  # several steps
    scene = small_scene({"renderer.name": DISCRETE, "volume.size": 16, "image.width": 16, "image.height": 16})
    renderer = create_renderer(DISCRETE)
    renderer.progress = lambda done, total: time.sleep(0.05)  # a slow step
    with pytest.raises(SandboxError, match=rf"time limit of 0.01 s \(--max-seconds\) in {DISCRETE}") as caught:
        with active(Sandbox(max_seconds=0.01)):
            renderer.render(scene)
    done, total = map(int, re.search(r"(\d+) of (\d+) steps done", str(caught.value)).groups())
    assert done < total  # stopped mid-render, at the first step past the limit


# --- progress and Ctrl-C -----------------------------------------------------------------------

@pytest.mark.parametrize("name", [DISCRETE, CONVERGED])
def test_cpu_references_report_progress(name, monkeypatch):
    from dvr_gl.reference import converged, discrete

    monkeypatch.setattr(discrete, "SAMPLES_PER_CHUNK", 4096)  # several steps of a small render
    monkeypatch.setattr(converged, "RAYS_PER_BATCH", 256)
    scene = small_scene({"renderer.name": name, "volume.size": 16, "image.width": 48, "image.height": 48})
    renderer = create_renderer(name)
    seen = []
    renderer.progress = lambda done, total: seen.append((done, total))
    renderer.render(scene)
    assert len(seen) >= 2 and seen[-1][0] == seen[-1][1] > 0
    assert all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))


def cli_args(tmp_path, name=DISCRETE, extra=()):
    return ["render", "--demo", "--set", "volume.size=16", "--size", "48", "--renderer", name,
            "-o", str(tmp_path / "out.exr"), *extra]


def test_cli_shows_a_progress_bar_for_long_work(tmp_path, monkeypatch, capsys):
    from dvr_gl import progress
    from dvr_gl.reference import discrete

    monkeypatch.setattr(progress, "DELAY", 0.0)  # force it: this render is short
    monkeypatch.setattr(discrete, "SAMPLES_PER_CHUNK", 4096)
    assert cli.main(cli_args(tmp_path)) == 0
    err = capsys.readouterr().err
    # tqdm's bar, drawn as soon as the task starts (DELAY 0): "rendering: 0step [00:00, ?step/s]", then
    # redrawn at most every 0.1 s, which this short render may not reach
    assert "\rrendering: " in err and "step" in err


def interrupting_task(monkeypatch, interrupt):
    """Replace the "rendering" task's reporter (dvr_gl.progress.task) by ``interrupt(done, total)``, which
    may raise KeyboardInterrupt as Ctrl-C would between two steps of a frame."""
    import contextlib

    from dvr_gl import progress

    real = progress.task

    @contextlib.contextmanager
    def task(label, *args, **kwargs):
        if label != "rendering":
            with real(label, *args, **kwargs) as step:
                yield step
            return
        yield interrupt

    monkeypatch.setattr(progress, "task", task)


def test_ctrl_c_mid_render_exits_130_and_writes_nothing(tmp_path, monkeypatch, capsys):
    def interrupt(done, total=None):
        raise KeyboardInterrupt  # as Ctrl-C would, between two steps of the render

    interrupting_task(monkeypatch, interrupt)
    assert cli.main(cli_args(tmp_path)) == 130
    err = capsys.readouterr().err.strip()
    assert err == "dvr render: interrupted"
    assert not list(tmp_path.iterdir())


def test_ctrl_c_between_bricked_gl_passes(tmp_path, monkeypatch, capsys):
    real = limits.gl_limits

    def small(ctx):  # bricks of at most 10 voxels: several passes of the ray caster
        return dataclasses.replace(real(ctx), texture_3d_size=10)

    passes = []

    def interrupt(done, total=None):
        passes.append(done)
        if done == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(limits, "gl_limits", small)
    interrupting_task(monkeypatch, interrupt)
    assert cli.main(cli_args(tmp_path, DEFAULT)) == 130
    assert passes == [1, 2]
    assert capsys.readouterr().err.strip() == "dvr render: interrupted"
    assert not list(tmp_path.iterdir())


def test_cli_refuses_a_frame_larger_than_the_gl_in_one_line(tmp_path, capsys):
    assert cli.main(["render", "--demo", "--set", "volume.size=16", "--size", "20000x16",
                     "-o", str(tmp_path / "e.exr")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("dvr render: error: image 20000x16 exceeds GL_MAX_") and "\n" not in err
    assert not list(tmp_path.iterdir())


def test_cli_lut_over_the_limit_on_a_real_volume(shared_data, tmp_path, capsys):
    status = cli.main(["render", "--volume", str(shared_data / "regular" / "bucky.nhdr"), "--size", "16",
                       "--set", "renderer.lut_size=16385", "-o", str(tmp_path / "e.exr")])
    err = capsys.readouterr().err
    # llvmpipe's limit is 16384: refused; a GL with a larger limit renders (checked against the
    # reference by the lut-size sweep tests), never an all-zero image
    if status == 1:
        assert "renderer.lut_size = 16385 exceeds GL_MAX_TEXTURE_SIZE" in err
        assert not list(tmp_path.iterdir())
    else:
        assert status == 0



@pytest.mark.parametrize("keys", [{"volume.origin": [1e6, 1e6, 1e6]},
                                  {"camera.projection": "orthographic", "camera.distance": 1e7}, {"camera.fov": 0.002}],
                         ids=["far-origin", "far-orthographic-eye", "tiny-fov"])
def test_a_frame_too_far_from_the_origin_for_float32_is_refused(renderers, tmp_path, keys):
    """Found by the fuzz campaign of 2026-11-29: the GPU's float32 world coordinates blanked the picture of a volume
    or an eye far from the origin (black at 1e8), unrefused.  Beyond limits.FAR_FROM_ORIGIN (1e4) box diagonals
    each GL renderer refuses in one line; the same volume 100 diagonals out renders, and the float64 reference takes
    the far one."""
    data = np.random.default_rng(5).random((8, 8, 8)).astype(np.float32)
    base = {"image.width": 8, "image.height": 8}
    origin = keys.get("volume.origin", (0.0, 0.0, 0.0))
    for name in GL_RENDERERS:
        far = array_scene(tmp_path, data, {**base, **{k: v for k, v in keys.items() if k != "volume.origin"},
                                           "renderer.name": name}, origin=origin)
        with pytest.raises(DvrError) as exc:
            renderers[name].render(far)
        assert "computes in float32" in one_line(exc) and "move volume.origin nearer 0" in str(exc.value)
        near = array_scene(tmp_path, data, {**base, "renderer.name": name}, origin=(700.0, 700.0, 700.0))
        assert renderers[name].render(near)[..., 3].max() > 0
    far = array_scene(tmp_path, data, {**base, **{k: v for k, v in keys.items() if k != "volume.origin"},
                                       "renderer.name": DISCRETE}, origin=origin)
    assert create_renderer(DISCRETE).render(far).shape == (8, 8, 4)

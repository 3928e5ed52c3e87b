"""The ray caster's bricked passes: equal to one pass (images and sample counts), and empty-space skipping
in bricked passes and in long rays' windows."""

import dataclasses

import numpy as np
import pytest

from conftest import array_scene, small_scene
from dvr_gl.gl.context import make_current
from dvr_gl.renderers.raycast.renderer import RayCastRenderer


@pytest.fixture(autouse=True)
def current_context(gl_context):
    """The session's context current for every test (a renderer released elsewhere leaves none)."""
    return gl_context


TINY = 1 / 16  # MB: bricks of at most 16 voxels per axis (ghosts included) for the 32^3 phantom


@pytest.fixture(scope="module")
def gpu(shared_gl_context):
    renderer = RayCastRenderer(ctx=make_current(shared_gl_context))
    yield renderer
    renderer.close()


CASES = [
    {}, {"renderer.order": "back_to_front"}, {"renderer.classification": "pre"},
    {"renderer.classification": "preintegrated"}, {"renderer.shading.enabled": True, "renderer.gradient": "texture"},
    {"renderer.ert_threshold": 0.9}, {"renderer.jitter": True}, {"camera.projection": "orthographic"},
    {"camera.eye": [2.0, -3.0, 1.0], "camera.target": [0.0, 10.0, 0.0]},  # inside the volume
    {"renderer.compositing": "mip"},
    {"renderer.compositing": "average", "transfer_function.points": [[0.0, 0, 0, 0, 0.0], [0.2, 1, 1, 1, 0.9]]},
    {"renderer.compositing": "minip", "transfer_function.points": [[0.0, 1, 1, 1, 0.8], [0.3, 0, 0, 0, 0.0]]},
    {"renderer.compositing": "isosurface", "renderer.shading.enabled": True},
    {"renderer.compositing": "isosurface", "camera.projection": "orthographic", "camera.azimuth": 0.0,
     "camera.elevation": 0.0},   # samples on brick faces: each still has one owner
    {"renderer.compositing": "isosurface", "renderer.sample_distance_voxels": 4.0},  # brackets across bricks
    {"renderer.compositing": "isosurface", "camera.eye": [2.0, -3.0, 1.0], "camera.target": [0.0, 10.0, 0.0]},
    {"renderer.classification": "preintegrated", "renderer.sample_distance_voxels": 7.0},  # ends 3.5 voxels out
]




def _case_id(extra: dict) -> str:
    return "-".join(f"{k.split('.')[-1]}={v}" for k, v in extra.items()) or "default"


def _samples_differently(extra: dict) -> bool:
    """Whether a case changes what a sample reads (classification, gradients, the isosurface's bisection, the
    sample distance) rather than only how the same samples are composited (order, early termination, jitter,
    projection, where rays start, MIP/MinIP/average)."""
    return not extra or any(k.split(".")[-1] in ("classification", "enabled", "sample_distance_voxels")
                            or v == "isosurface" for k, v in extra.items())


# The filter decides what a sample reads at a brick's face (the ghost voxels its support needs); the rest of a
# case decides how the passes composite the samples and carry their state.  So every case runs with the linear
# filter, and Catmull-Rom's wider support with the cases that change what a sample reads: a compositing case
# composites the same samples whichever filter read them (the default case checks Catmull-Rom's samples at
# every brick face its rays cross).  (The full cross product: 34 cases; this covering set: 26.)
BRICKED_CASES = ([pytest.param(e, "linear", id=f"linear-{_case_id(e)}") for e in CASES]
                 + [pytest.param(e, "catmull_rom", id=f"catmull_rom-{_case_id(e)}") for e in CASES
                    if _samples_differently(e)])


@pytest.mark.parametrize("extra, filter_kind", BRICKED_CASES)
def test_bricked_equals_unbricked(gpu, extra, filter_kind):
    """Each brick pass composites exactly its own samples, continuing the state of the passes before:
    the same image to float32 rounding (measured <= 1.1e-6 over these cases; asserted 2e-6).  The
    shaded isosurface is lit at a point bisected from values the bricks fetch at their own texture
    coordinates (float32 rounding apart): measured 2.1e-6, asserted 1e-5."""
    scene = small_scene({"renderer.ert_threshold": 1.0, "renderer.filter": filter_kind, **extra})
    whole = gpu.render(scene)
    assert gpu.stats["bricks"] == 1
    bricked = gpu.render(scene.with_renderer(texture_budget_mb=TINY))
    assert gpu.stats["bricks"] >= 8
    assert whole[..., 3].max() > 0.05
    tolerance = 1e-5 if extra.get("renderer.compositing") == "isosurface" else 2e-6
    assert np.abs(bricked - whole).max() <= tolerance, np.abs(bricked - whole).max()


def test_bricked_passes_count_what_one_pass_counts(gl_context):
    """COUNT_SAMPLES in bricked passes: the counts carry from pass to pass, and a ray's samples over
    all of them are its samples in one pass (each sample has one owner), pixel by pixel."""
    renderer = RayCastRenderer(count_samples=True, ctx=gl_context)
    try:
        for extra in ({}, {"renderer.order": "back_to_front"}, {"renderer.compositing": "mip"}):
            scene = small_scene({"renderer.ert_threshold": 1.0, "renderer.acceleration": "off", **extra})
            renderer.render(scene)
            one = renderer.counts.copy()
            renderer.render(scene.with_renderer(texture_budget_mb=TINY))
            assert renderer.stats["bricks"] >= 8 and renderer.stats["samples_per_ray"] > 10
            np.testing.assert_array_equal(renderer.counts, one)
    finally:
        renderer.close()


# --- empty-space skipping in bricked passes ---------------------------------------------------

# Cores of the 36 x 32 x 40 volume below under TINY: 12 to 27 bricks (more ghost voxels, smaller
# cores), split at voxels such as 18, 16 and 13 along x, y and z: jumps must stop at core faces
# inside blocks as well as on their faces.


def _straddling_scene(tmp_path, extra):
    """Empty space around a constant slab (a non-zero constant colour and extinction: jumped in
    closed form) around a structured core, all of them across the brick boundaries, with single
    voxels on core faces (x = 18 and y = 16 with one ghost voxel)."""
    data = np.zeros((40, 32, 36), np.float32)   # z, y, x
    data[4:25, 3:29, 5:31] = 0.8   # empty beyond z = 25: 8-voxel blocks too
    data[13:27, 9:23, 11:25] = np.random.default_rng(8).uniform(0.3, 1.0, (14, 14, 14))
    for z, y, x in [(20, 16, 18), (20, 6, 30), (33, 16, 8), (10, 25, 18), (2, 2, 2)]:
        data[z, y, x] = 1.0
    points = [[0.0, 0, 0, 0, 0], [0.5, 0.2, 0.4, 1, 0.0], [0.7, 0.3, 0.6, 1, 0.06], [0.9, 0.3, 0.6, 1, 0.06],
              [0.95, 1, 0.3, 0.1, 0.9], [1.0, 1, 0.3, 0.1, 0.9]]
    return array_scene(tmp_path, data, {"transfer_function.points": points, "image.width": 33, "image.height": 33,
                                        "renderer.ert_threshold": 1.0, "renderer.iso_value": 0.75, **extra})


def _views(corner):
    """Views: an orbit; two orthographic ones along axes (y, z) whose centre pixel's ray (33 x 33)
    lies in two core faces at once, through ``corner``, a corner eight cores share (others along
    brick faces); and two along diagonals through ``corner``, perspective and orthographic."""
    c = np.asarray(corner, float)
    ortho = {"camera.projection": "orthographic", "camera.view_height": 40.0, "camera.target": list(c)}
    return {
        "orbit": {},
        "axis-y": {**ortho, "camera.eye": list(c - [0.0, 60.0, 0.0])},
        "axis-z": {**ortho, "camera.eye": list(c + [0.0, 0.0, 60.0]), "camera.up": [0.0, 1.0, 0.0]},
        "corner": {"camera.eye": list(c - 50.0), "camera.target": list(c)},
        "corner-ortho": {**ortho, "camera.eye": list(c + [40.0, -40.0, 40.0]), "camera.view_height": 50.0},
    }


def _inner_corner(gpu, scene) -> tuple:
    """A corner eight brick cores share, in world (= voxel) coordinates, under TINY."""
    from dvr_gl.renderers.raycast.renderer import shader_features

    scene = scene.with_renderer(texture_budget_mb=TINY)
    views = gpu.grid_views(scene, shader_features(scene))
    return next(v.brick.core_lo for v in views if min(v.brick.core_lo) > 0)


MODES = {
    "ftb": {}, "btf": {"renderer.order": "back_to_front"},
    "preint": {"renderer.classification": "preintegrated"},
    "preint-btf": {"renderer.classification": "preintegrated", "renderer.order": "back_to_front"},
    "ert": {"renderer.ert_threshold": 0.5},  # stops inside the slab, in jumps and samples
    # one bracket refined: with two, bricked passes refine more candidates than one pass (never worse, not the
    # same; test_extremum_refinement.py), and skipping's equality is checked there
    "mip": {"renderer.compositing": "mip", "renderer.extremum_brackets": 1},
    "minip": {"renderer.compositing": "minip", "renderer.extremum_brackets": 1,
              "transfer_function.points": [[0.0, 1, 1, 1, 0.8], [0.5, 0, 0, 0, 0.0], [1.0, 0, 0, 0, 0.0]]},
    "iso": {"renderer.compositing": "isosurface", "renderer.shading.enabled": True},
}


@pytest.fixture(scope="module")
def counting(shared_gl_context):
    renderer = RayCastRenderer(count_samples=True, ctx=make_current(shared_gl_context))
    yield renderer
    renderer.close()


@pytest.fixture(scope="module")
def unaccelerated():
    """The passes without skipping, per scene (but its block size) and view: (one pass, bricked
    passes).  Without skipping no block is looked up (no ACCELERATE define, no ray bounds), so both
    images are the same for every block size and are rendered once for all of them."""
    return {}


def _unaccelerated(gpu, scene, cache, key):
    """One unaccelerated pass and bricked unaccelerated passes of ``scene`` (from ``cache`` under
    ``key`` where another block size rendered them)."""
    if key not in cache:
        plain = gpu.render(scene.with_renderer(acceleration="off"))
        assert gpu.stats["bricks"] == 1 and plain[..., 3].max() > 0.05
        stepped = gpu.render(scene.with_renderer(acceleration="off", texture_budget_mb=TINY))
        assert gpu.stats["bricks"] >= 12 and not gpu.stats["accelerated"]
        cache[key] = plain, stepped
    return cache[key]


def _compare_bricked_skipping(gpu, tmp_path, extra, views, cache, tolerance=None):
    """Per view: one pass unaccelerated, bricked unaccelerated and bricked accelerated; the largest
    differences of the last from the other two (at most 3e-6, skipping's rounding, from the second;
    ``tolerance`` from the first, or where None 3e-6 more than the second's own difference).  Every
    ray must composite exactly the segments it composites in one unaccelerated pass, each once
    (sampled or jumped, counted per pixel) within its ray bounds (those of one accelerated pass).
    The unaccelerated images come from ``cache`` (the fixture ``unaccelerated``)."""
    worst, jumps = np.zeros(3), 0.0
    same = repr(sorted((k, v) for k, v in extra.items() if k != "renderer.block_size"))
    minip = extra.get("renderer.compositing") == "minip"
    shared = {}  # one volume and transfer function object for every view: the renderer's caches (by identity)
    for view, camera in views.items():  # keep its textures, pyramid and tables from view to view
        scene = _straddling_scene(tmp_path, {**extra, **camera})
        if not shared:
            shared["tf"] = scene.transfer_function
            shared["field"] = (type(scene.volume)(1.0 - scene.volume.data, scene.volume.spacing) if minip
                               else scene.field)
        if minip:  # low values inside: the inverted volume
            scene = scene.replace(volume=shared["field"], transfer_function=shared["tf"])
        else:      # the same values as its own
            scene = dataclasses.replace(scene, field=shared["field"], transfer_function=shared["tf"])
        gpu.render(scene.with_renderer(acceleration="on"))
        assert gpu.stats["bricks"] == 1
        segments = gpu.counts[..., 0] + gpu.counts[..., 3]
        plain, stepped = _unaccelerated(gpu, scene, cache, (same, view))
        bricked = gpu.render(scene.with_renderer(acceleration="on", texture_budget_mb=TINY))
        assert gpu.stats["bricks"] >= 12 and gpu.stats["accelerated"]
        jumps += gpu.stats["jumps_per_ray"]
        errors = np.array([np.abs(bricked - stepped).max(), np.abs(bricked - plain).max(),
                           np.abs(stepped - plain).max()])
        bound = tolerance if tolerance is not None else errors[2] + 3e-6
        assert errors[0] <= 3e-6 and errors[1] <= bound, (view, errors)
        np.testing.assert_array_equal(gpu.counts[..., 0] + gpu.counts[..., 3], segments, err_msg=view)
        worst = np.maximum(worst, errors)
    assert jumps > 0.0  # the passes did skip
    return worst


# Every mode with 4-voxel blocks; 8-voxel blocks (another pyramid, other blocks straddling the core faces) with
# each kind of jump once: front to back, back to front and pre-integrated (preint-btf: the back-to-front walk
# and pre-integration's empty-only jumps together), early termination, the extremum bound (mip: minip is the
# same bound on the inverted volume) and the isosurface's.  (The cross product: 16 cases; this covering set: 13.)
BLOCK_CASES = ([pytest.param(m, 4, id=f"{m}-4") for m in MODES]
               + [pytest.param(m, 8, id=f"{m}-8") for m in MODES if m not in ("btf", "preint", "minip")])


@pytest.mark.parametrize("mode, block_size", BLOCK_CASES)
def test_bricked_and_accelerated_equals_unbricked_unaccelerated(tmp_path, counting, unaccelerated, mode, block_size):
    """Bricked passes jump blocks too, each only the segments its core owns.  Filtered in the shader,
    bricking alone changes nothing here (measured: identical), so against one unaccelerated pass
    only skipping's rounding remains (closed-form jumps round unlike stepping: measured 2.03e-6 at
    most, the same as without bricks, on the 32-voxel-deep slab seen along z; asserted 3e-6), and
    the same against bricked passes without skipping."""
    extra = {**MODES[mode], "renderer.block_size": block_size, "renderer.filtering": "shader"}
    views = _views(_inner_corner(counting, _straddling_scene(tmp_path, extra)))
    worst = _compare_bricked_skipping(counting, tmp_path, extra, views, unaccelerated, 3e-6)
    print(f"{mode} block {block_size}: max |diff| {worst[0]:.3g} from bricked unaccelerated, "
          f"{worst[1]:.3g} from unbricked unaccelerated")


@pytest.mark.parametrize("mode, filter_kind", [("ftb", "linear"), ("preint-btf", "linear"), ("iso", "linear"),
                                               ("btf", "catmull_rom"), ("mip", "catmull_rom")])
def test_bricked_skipping_with_hardware_filtering(tmp_path, counting, unaccelerated, mode, filter_kind):
    """The texture unit's filtering: bricks sample at their own texture coordinates, which round
    unlike the whole volume's (bricked without skipping differs from one pass by up to 7.3e-6 with
    the linear filter, 2.2e-5 with Catmull-Rom, on this volume's random values seen through a steep
    transfer function), and skipping adds no more than its own rounding to that."""
    extra = {**MODES[mode], "renderer.block_size": 4, "renderer.filter": filter_kind}
    worst = _compare_bricked_skipping(counting, tmp_path, extra,
                                      _views(_inner_corner(counting, _straddling_scene(tmp_path, extra))),
                                      unaccelerated)
    print(f"{mode} {filter_kind}: max |diff| {worst[0]:.3g} from bricked unaccelerated, "
          f"{worst[1]:.3g} from unbricked unaccelerated (bricked unaccelerated: {worst[2]:.3g})")


def test_bricked_passes_skip(tmp_path, counting):
    """Skipping happens in bricked passes: counted over all passes, most of the samples become jumps,
    as without bricks."""
    scene = _straddling_scene(tmp_path, {"renderer.block_size": 4})
    counting.render(scene.with_renderer(acceleration="off", texture_budget_mb=TINY))
    assert counting.stats["bricks"] >= 8 and counting.stats["jumps_per_ray"] == 0.0
    stepped = counting.stats["samples_per_ray"]
    counting.render(scene.with_renderer(acceleration="on"))
    unbricked = counting.stats["samples_per_ray"]
    counting.render(scene.with_renderer(acceleration="on", texture_budget_mb=TINY))
    assert counting.stats["bricks"] >= 8 and counting.stats["jumps_per_ray"] > 1.0
    bricked = counting.stats["samples_per_ray"]
    # jumps stop at core faces (and a margin before them): a few samples more than one pass takes
    assert bricked < 0.6 * stepped and bricked <= unbricked + 1.0, (stepped, unbricked, bricked)


@pytest.mark.parametrize("extra", [{}, {"renderer.order": "back_to_front"},
                                   {"renderer.classification": "preintegrated"}, {"renderer.compositing": "mip"},
                                   {"renderer.compositing": "isosurface"}, {"renderer.ert_threshold": 0.9},
                                   {"renderer.texture_budget_mb": TINY}],
                         ids=["ftb", "btf", "preint", "mip", "iso", "ert", "bricks"])
def test_long_ray_windows_skip_within_their_window(tmp_path, counting, monkeypatch, extra):
    """The passes over segment windows (forced to 20 segments) jump too, never past their window's
    end: the one-pass unaccelerated image, every segment within the ray bounds once (as one
    accelerated pass counts them)."""
    from dvr_gl.renderers.raycast import renderer as raycast

    scene = _straddling_scene(tmp_path, {"renderer.block_size": 4, **extra})
    counting.render(scene.with_renderer(acceleration="on", texture_budget_mb=256))
    segments = counting.counts[..., 0] + counting.counts[..., 3]
    whole = counting.render(scene.with_renderer(acceleration="off", texture_budget_mb=256))
    monkeypatch.setattr(raycast, "PASS_SEGMENTS", 20 * raycast.ACCELERATED_COST + scene.renderer.iso_refinement)
    windowed = counting.render(scene.with_renderer(acceleration="on"))
    # pre-integration jumps only empty blocks, which the ray bounds leave few of (0.2 a ray here)
    least = 0.1 if extra.get("renderer.classification") == "preintegrated" else 1.0
    assert counting.stats["passes"] > 4 * counting.stats["bricks"] and counting.stats["jumps_per_ray"] > least
    tolerance = 1e-5 if extra.get("renderer.compositing") == "isosurface" else 2e-6
    assert np.abs(windowed - whole).max() <= tolerance, np.abs(windowed - whole).max()
    if "renderer.ert_threshold" not in extra:
        np.testing.assert_array_equal(counting.counts[..., 0] + counting.counts[..., 3], segments)


def test_accelerated_windows_hold_a_third_of_the_segments():
    """llvmpipe's loop cap counts the outer loop's lookups and the inner loop's entries too: an
    accelerated pass takes at most a third of PASS_SEGMENTS segments."""
    from dvr_gl.renderers.raycast.renderer import ACCELERATED_COST, PASS_SEGMENTS, segment_windows

    scene = small_scene({"renderer.sample_distance": 32 * np.sqrt(3) / 40000})  # 40000 segments
    assert len(segment_windows(scene)) == 1
    windows = segment_windows(scene, accelerated=True)
    assert len(windows) == 2
    assert all(b - a <= (PASS_SEGMENTS - scene.renderer.iso_refinement) // ACCELERATED_COST for a, b in windows)

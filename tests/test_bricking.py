"""Bricks: planning, visibility order, and bricked rendering equal to unbricked."""

import numpy as np
import pytest

from dvr_gl.renderers.grid.bricking import plan_bricks, visibility_order
from dvr_gl.camera import Camera
from dvr_gl.renderers.raycast.renderer import RayCastRenderer

from conftest import small_scene

TINY = 1 / 16  # MB: bricks of at most 16 voxels per axis (ghosts included) for the 32^3 phantom


@pytest.mark.parametrize("dims, edge", [((32, 32, 32), 16), ((100, 40, 1), 32), ((9, 17, 30), 12)])
def test_brick_cores_tile_the_grid_and_textures_hold_the_ghosts(dims, edge):
    bricks = plan_bricks(dims, edge)
    for axis in range(3):
        edges = sorted({(b.core_lo[axis], b.core_hi[axis]) for b in bricks})
        assert edges[0][0] == 0 and edges[-1][1] == max(dims[axis] - 1, 0)
        assert all(a[1] == b[0] for a, b in zip(edges, edges[1:]))  # consecutive cores share a voxel
    for b in bricks:
        assert max(b.tex_dims) <= edge
        for axis in range(3):
            assert b.tex_lo[axis] <= max(b.core_lo[axis] - 3, 0)
            assert b.tex_lo[axis] + b.tex_dims[axis] - 1 >= min(b.core_hi[axis] + 3, dims[axis] - 1)


@pytest.mark.parametrize("eye", [(-50, 10, 10), (10, 12, 70), (15, 15, 15), (90, -40, 33)])
def test_visibility_order_is_front_to_back_along_every_ray(eye):
    """Along rays from the eye, the bricks crossed come in the order's order."""
    class V:  # a unit-spaced volume
        origin, spacing = (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)
    bricks = plan_bricks((32, 32, 32), 16)
    camera = Camera(eye, (16, 16, 16))
    order = visibility_order(bricks, V, camera)
    lo = np.array([b.core_lo for b in order], float)
    hi = np.array([b.core_hi for b in order], float)
    rng = np.random.default_rng(0)
    for target in rng.uniform(0, 31, (100, 3)):
        points = np.asarray(eye, float) + np.linspace(0, 1.5, 3000)[:, None] * (target - np.asarray(eye, float))
        points = points[np.all((points >= 0) & (points <= 31), axis=1)]
        inside = np.all((points[:, None] >= lo[None]) & (points[:, None] <= hi[None]), axis=2)
        crossed = np.argmax(inside, axis=1)  # the first brick (in the order) holding each point
        assert np.all(np.diff(crossed) >= 0)  # never back to an earlier brick


@pytest.fixture(scope="module")
def gpu():
    renderer = RayCastRenderer()
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


@pytest.mark.parametrize("extra", CASES, ids=lambda e: "-".join(f"{k.split('.')[-1]}={v}" for k, v in e.items())
                         or "default")
@pytest.mark.parametrize("filter_kind", ["linear", "catmull_rom"])
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


def test_bricked_passes_count_what_one_pass_counts():
    """COUNT_SAMPLES in bricked passes: the counts carry from pass to pass, and a ray's samples over
    all of them are its samples in one pass (each sample has one owner), pixel by pixel."""
    renderer = RayCastRenderer(count_samples=True)
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


def test_ghosts_grow_with_what_a_brick_reads_beyond_its_core():
    from dvr_gl.renderers.grid.bricking import ghost_width

    assert ghost_width("linear", False) == 1 and ghost_width("catmull_rom", True) == 3
    assert ghost_width("linear", True, reach=0.25) == 3 and ghost_width("cubic_bspline", False, reach=3.5) == 6


def test_accelerated_windows_hold_a_third_of_the_segments():
    """llvmpipe's loop cap counts the outer loop's lookups and the inner loop's entries too: an
    accelerated pass takes at most a third of PASS_SEGMENTS segments."""
    from dvr_gl.renderers.raycast.renderer import ACCELERATED_COST, PASS_SEGMENTS, segment_windows

    scene = small_scene({"renderer.sample_distance": 32 * np.sqrt(3) / 40000})  # 40000 segments
    assert len(segment_windows(scene)) == 1
    windows = segment_windows(scene, accelerated=True)
    assert len(windows) == 2
    assert all(b - a <= (PASS_SEGMENTS - scene.renderer.iso_refinement) // ACCELERATED_COST for a, b in windows)

"""Ray bounds: the faces of the non-empty blocks, drawn per frame, bound each ray's segments
(dvr_gl/renderers/raycast/ray_bounds.py, shaders/ray_bounds.*; docs/acceleration.md)."""

import numpy as np
import pytest

from conftest import array_scene
from dvr_gl.gl.context import make_current
from dvr_gl.rays import intersect_box
from dvr_gl.renderers.raycast import acceleration as accel
from dvr_gl.renderers.raycast import ray_bounds
from dvr_gl.renderers.raycast import renderer as raycast
from dvr_gl.renderers.raycast.renderer import RayCastRenderer


@pytest.fixture(scope="module")
def gpu(shared_gl_context):
    """A counting ray caster on the session's context (borrowed: its programs stay compiled for the other
    modules of the run, which compile many of the same)."""
    renderer = RayCastRenderer(count_samples=True, ctx=make_current(shared_gl_context))
    yield renderer
    renderer.close()


@pytest.fixture
def bounds_only(monkeypatch):
    """auto draws the ray bounds whenever there are faces, and never skips blocks in the loop."""
    monkeypatch.setattr(raycast, "AUTO_BOUNDS_COST", 0.0)
    monkeypatch.setattr(raycast, "worth_skipping", lambda estimate, sample_distance: False)


def test_faces_separate_empty_from_non_empty_blocks():
    """Every face lies between a non-empty block and an empty one (or the outside), once, and every
    such pair of neighbours has its face: the faces close the non-empty blocks' union."""
    occ = np.random.default_rng(1).uniform(size=(4, 5, 6)) < 0.4
    dims, block = (43, 37, 29), 8  # x, y, z: the last blocks are partial
    rows = ray_bounds.boundary_faces(occ, block, dims, (1.0, 2.0, 0.5), (3.0, -1.0, 0.0)).reshape(-1, 6, 5)
    padded = np.pad(occ, 1)
    expected = set()
    for axis, step in ((0, (0, 0, 1)), (1, (0, 1, 0)), (2, (1, 0, 0))):  # x, y, z; steps in (z, y, x)
        for z, y, x in np.ndindex(padded.shape):
            w = (z + step[0], y + step[1], x + step[2])
            if all(c < s for c, s in zip(w, padded.shape)) and padded[z, y, x] != padded[w]:
                if all(0 < c < s - 1 for c, s, st in zip((z, y, x), padded.shape, step) if not st):
                    expected.add((axis, z, y, x))
    assert len(rows) == len(expected) and len(rows) > 50
    # each face's plane and extent: axis-aligned, on a block boundary of its axis
    spacing, origin = np.array([1.0, 2.0, 0.5]), np.array([3.0, -1.0, 0.0])
    for face in rows:
        axis = int(face[0, 3])
        voxel = (face[:, :3] - origin) / spacing
        assert np.ptp(voxel[:, axis]) == 0.0 and face[0, 4] == face[0, axis]
        edge = voxel[0, axis]
        assert edge % block == 0 or edge == dims[axis] - 1


def _sparse_volume(seed, shape=(40, 36, 44)):
    """Random boxes of material in an empty volume (z, y, x)."""
    rng = np.random.default_rng(seed)
    data = np.zeros(shape, np.float32)
    for _ in range(4):
        lo = rng.integers(0, np.array(shape) - 6)
        size = rng.integers(2, 10, 3)
        data[tuple(slice(a, a + s) for a, s in zip(lo, size))] = rng.uniform(0.5, 1.0)
    return data


VIEWS = {"orbit": {"camera.azimuth": 30.0, "camera.elevation": 20.0},
         "axis": {"camera.azimuth": 0.0, "camera.elevation": 0.0},
         "close": {"camera.azimuth": -50.0, "camera.elevation": -35.0, "camera.distance": 60.0},
         "orthographic": {"camera.azimuth": 120.0, "camera.elevation": 40.0, "camera.projection": "orthographic"}}


@pytest.mark.parametrize("view", list(VIEWS))
def test_bounds_are_the_first_entry_and_last_exit(gpu, tmp_path, bounds_only, view):
    """Per pixel, the drawn bounds equal the first entry into and last exit from the non-empty
    blocks, as the slab method finds them in float64 for every block (to 1e-4 of the ray's length:
    float32 positions and planes); rays that miss them all have none.  Rays that only graze a
    block's edge (a crossing under 1e-3 long) may fall either way."""
    scene = array_scene(tmp_path, _sparse_volume(3), {"image.width": 40, "image.height": 36,
                                                       "renderer.block_size": 4, **VIEWS[view]})
    gpu.render(scene)
    assert gpu.stats["ray_bounds"]
    (texture,), _ = gpu._targets["ray bounds"]
    drawn = np.frombuffer(texture.read(), np.float32).reshape(36, 40, 2)[::-1].reshape(-1, 2).astype(np.float64)
    level0 = accel.table_classes(accel.MinMaxPyramid.build(scene.volume.data, 4, (0, 1)),
                                 scene.transfer_function.tabulate(scene.renderer.lut_size), "linear",
                                 scene.volume.spacing)[0]
    occ = ray_bounds.occupied(level0)
    z, y, x = np.nonzero(occ)
    edges = [ray_bounds.block_edges(n, nb, 4) for n, nb in zip(scene.volume.dims, occ.shape[::-1])]
    lo = np.stack([edges[0][x], edges[1][y], edges[2][z]], 1) * scene.volume.spacing + scene.volume.origin
    hi = np.stack([edges[0][x + 1], edges[1][y + 1], edges[2][z + 1]], 1) * scene.volume.spacing + scene.volume.origin
    origins, directions = scene.camera.pixel_rays(40, 36)
    entry, exit_ = np.full(len(origins), np.inf), np.full(len(origins), -np.inf)
    graze = np.zeros(len(origins), bool)
    for a, b in zip(lo, hi):
        t0, t1 = intersect_box(origins, directions, a, b)
        hit = t1 >= t0
        entry[hit] = np.minimum(entry[hit], t0[hit])
        exit_[hit] = np.maximum(exit_[hit], t1[hit])
        graze |= hit & (t1 - t0 < 1e-3)
    length = np.linalg.norm(np.asarray(scene.volume.box[1]) - scene.volume.box[0])
    missed = ~np.isfinite(entry)
    assert missed.sum() > 50 and (~missed).sum() > 50, view
    ok = ~graze
    cleared = float(np.float32(3.0e38))
    assert np.all(drawn[missed & ok] == cleared)
    hit = ~missed & ok
    assert np.abs(drawn[hit, 0] - entry[hit]).max() <= 1e-4 * length
    assert np.abs(-drawn[hit, 1] - exit_[hit]).max() <= 1e-4 * length


CASES = {"front to back": {}, "back to front": {"renderer.order": "back_to_front"},
         "pre-integrated": {"renderer.classification": "preintegrated"},
         "pre-classified": {"renderer.classification": "pre"},
         "shaded, gradient opacity": {"renderer.shading.enabled": True, "renderer.gradient_opacity": True},
         "jittered": {"renderer.jitter": True}, "orthographic": {"camera.projection": "orthographic"},
         "early termination": {"renderer.ert_threshold": 0.9},
         "bricked": {"renderer.texture_budget_mb": 1 / 64}}


@pytest.mark.parametrize("case", list(CASES))
def test_bounds_leave_the_image_unchanged(gpu, tmp_path, bounds_only, case):
    """The segments the bounds leave out lie in empty blocks: the image is the unbounded one exactly,
    with fewer samples (emission-absorption in every classification, order and option)."""
    scene = array_scene(tmp_path, _sparse_volume(4), {"image.width": 32, "image.height": 32,
                                                       "renderer.block_size": 4, "camera.azimuth": 25.0,
                                                       "camera.elevation": 15.0, **CASES[case]})
    off = gpu.render(scene.with_renderer(acceleration="off"))
    samples = gpu.stats["samples"]
    bounded = gpu.render(scene)
    assert gpu.stats["ray_bounds"] and not gpu.stats["accelerated"]
    assert gpu.stats["samples"] < 0.6 * samples and off[..., 3].max() > 0.1
    np.testing.assert_array_equal(bounded, off)


def test_no_bounds_where_the_eye_is_next_to_material(gpu, tmp_path, bounds_only):
    """A non-empty block at the near plane (the eye inside the volume, beside material): its entry
    face may lie behind the eye, so the rays are not bounded; the image is the unbounded one."""
    data = _sparse_volume(5)
    data[18:22, 16:20, 20:24] = 0.9  # material around the eye
    scene = array_scene(tmp_path, data, {"image.width": 24, "image.height": 24, "renderer.block_size": 4,
                                         "camera.distance": 1.0, "camera.fov": 90.0})
    off = gpu.render(scene.with_renderer(acceleration="off"))
    inside = gpu.render(scene)
    assert not gpu.stats["ray_bounds"] and off[..., 3].max() > 0.1
    np.testing.assert_array_equal(inside, off)
    far = scene.replace(camera=scene.camera.orbited(distance=200.0))
    gpu.render(far)
    assert gpu.stats["ray_bounds"]


@pytest.mark.parametrize("mode", ["mip", "minip", "average", "isosurface"])
def test_other_modes_are_not_bounded(gpu, tmp_path, mode):
    """Only emission-absorption leaves out empty blocks' samples: MIP's maximum, MinIP's minimum and
    the average count every sample, and the isosurface brackets its crossing between samples."""
    scene = array_scene(tmp_path, _sparse_volume(6), {"image.width": 16, "image.height": 16,
                                                       "renderer.compositing": mode, "renderer.iso_value": 0.6})
    gpu.render(scene.with_renderer(acceleration="on"))
    assert not gpu.stats["ray_bounds"] and "RAY_BOUNDS" not in gpu.stats["defines"]

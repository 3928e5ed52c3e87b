"""Acceleration structures and accelerated ray casting: same image, fewer samples."""

import numpy as np
import pytest

from conftest import array_scene, small_scene
from dvr_gl.fields.reconstruction import SampledField
from dvr_gl.gl.context import make_current
from dvr_gl.renderers.raycast import acceleration as accel
from dvr_gl.renderers.raycast.renderer import RayCastRenderer
from dvr_gl.transfer_function import TransferFunction

FILTERS = ["nearest", "linear", "cubic_bspline", "catmull_rom"]


@pytest.mark.parametrize("shape", [(37, 29, 45), (16, 8, 24), (3, 1, 9)])
@pytest.mark.parametrize("block, filter_kind",
                         [(8, "linear"), (8, "catmull_rom"), (16, "nearest"), (4, "cubic_bspline")])
def test_pyramid_matches_brute_force(shape, block, filter_kind):
    rng = np.random.default_rng(sum(shape) + block)
    data = rng.integers(-500, 1000, shape).astype(np.int16)
    lo, hi = accel.SUPPORT[filter_kind]
    pyramid = accel.MinMaxPyramid.build(data, block, (lo, hi))
    assert len(pyramid.levels) == accel.level_count(shape, block)
    for level, (mins, maxs) in enumerate(pyramid.levels):
        size = block << level
        for idx in np.ndindex(mins.shape):
            window = tuple(slice(max(b * size - lo, 0), min((b + 1) * size - 1 + hi, n - 1) + 1)
                           for b, n in zip(idx, shape))
            assert mins[idx] == data[window].min() and maxs[idx] == data[window].max(), (level, idx)


def test_sparse_table_range_queries():
    rng = np.random.default_rng(3)
    table = rng.standard_normal((100, 4))
    st = accel.SparseTable(table)
    i0 = rng.integers(0, 100, 500)
    i1 = np.minimum(i0 + rng.integers(0, 100, 500), 99)
    lo, hi = st.query(i0, i1)
    for a, b, mn, mx in zip(i0, i1, lo, hi):
        np.testing.assert_array_equal(mn, table[a:b + 1].min(axis=0))
        np.testing.assert_array_equal(mx, table[a:b + 1].max(axis=0))


@pytest.mark.parametrize("filter_kind", FILTERS)
def test_block_classes_bound_every_sample(filter_kind):
    """Property: at random points of every block, the filtered value looked up in the table gives
    exactly the class's (colour, sigma) in constant blocks and sigma = 0 in empty ones."""
    rng = np.random.default_rng(7)
    data = np.zeros((32, 32, 32), np.float32)
    data[2:18, 2:18, 2:18] = 0.7                       # a homogeneous region
    data[rng.integers(0, 32, 30), rng.integers(0, 32, 30), rng.integers(0, 32, 30)] = 1.0  # isolated voxels
    tf = TransferFunction(np.array([[0.0, 0, 0, 0, 0], [0.3, 0.2, 0.5, 1, 0], [0.6, 1, 0.5, 0.1, 0.4],
                                    [0.9, 1, 0.5, 0.1, 0.4], [0.95, 1, 1, 1, 0.9], [1.0, 1, 1, 1, 0.9]]))
    lut = tf.tabulate(256)
    pyramid = accel.MinMaxPyramid.build(data, 4, accel.SUPPORT[filter_kind])
    classes = accel.table_classes(pyramid, lut, filter_kind, (1.0, 1.0, 1.0))
    field = SampledField(data, (1, 1, 1), (0, 0, 0), filter_kind)
    top = np.array(data.shape[::-1]) - 1
    seen = {"empty": 0, "constant": 0}
    for level, blocks in enumerate(classes):
        size = 4 << level
        for idx in np.ndindex(blocks.shape[:3]):
            cls = blocks[idx]
            if cls[3] < 0:
                continue
            corner = np.array(idx[::-1]) * size  # x, y, z
            points = corner + rng.uniform(0, size, (40, 3))
            points = points[np.all(points <= top, axis=1)]  # inside the volume's box
            colour, sigma = lut.lookup(field.sample(points))
            if cls[3] == 0:
                assert np.all(sigma == 0), (level, idx)
                seen["empty"] += 1
            else:
                np.testing.assert_allclose(sigma, cls[3], rtol=1e-6)
                np.testing.assert_allclose(colour, np.broadcast_to(cls[:3], colour.shape), rtol=1e-6)
                seen["constant"] += 1
    assert seen["empty"] > 0 and seen["constant"] > 0


@pytest.fixture(scope="module")
def gpu(shared_gl_context):
    """A counting ray caster on the session's context (borrowed: closing it releases its own objects,
    not the context, whose cache keeps the programs compiled here for the rest of the run)."""
    renderer = RayCastRenderer(count_samples=True, ctx=make_current(shared_gl_context))
    yield renderer
    renderer.close()


def _compare(gpu, scene, tolerance=2e-6):
    """Accelerated against unaccelerated: the same image within float32 rounding, fewer samples."""
    plain = gpu.render(scene.with_renderer(acceleration=False))
    samples = gpu.stats["samples_per_ray"]
    fast = gpu.render(scene.with_renderer(acceleration=True))
    assert plain[..., 3].max() > 0.05
    assert np.abs(fast - plain).max() <= tolerance, np.abs(fast - plain).max()
    return samples, gpu.stats["samples_per_ray"]


def _slab_scene(tmp_path, extra):
    """A volume whose interior is a large homogeneous region at a value where the transfer function
    is constant and non-zero (jumped in closed form), around a structured core, with single voxels on
    block boundaries (the filter's support must reach across them)."""
    data = np.zeros((40, 40, 40), np.float32)
    data[6:34, 6:34, 6:34] = 0.8
    data[15:25, 15:25, 15:25] = np.random.default_rng(1).uniform(0.3, 1.0, (10, 10, 10))
    for z, y, x in [(7, 7, 8), (31, 16, 24), (16, 31, 31), (1, 1, 1), (38, 38, 38)]:
        data[z, y, x] = 1.0
    points = [[0.0, 0, 0, 0, 0], [0.5, 0.2, 0.4, 1, 0.0], [0.7, 0.3, 0.6, 1, 0.06], [0.9, 0.3, 0.6, 1, 0.06],
              [0.95, 1, 0.3, 0.1, 0.9], [1.0, 1, 0.3, 0.1, 0.9]]
    return array_scene(tmp_path, data, {"transfer_function.points": points, "image.width": 40, "image.height": 40,
                                        "renderer.ert_threshold": 1.0, "renderer.iso_value": 0.75,
                                        "renderer.block_size": 4, **extra})


# Cases that change what the blocks are classified from or what a sample reads (the filter's support decides
# both): each with every filter.
READING = {"ftb": {}, "pre": {"renderer.classification": "pre"}, "shaded": {"renderer.shading.enabled": True},
           "block8": {"renderer.block_size": 8}, "preint": {"renderer.classification": "preintegrated"},
           "preint-btf": {"renderer.classification": "preintegrated", "renderer.order": "back_to_front"}}
# Cases that change only how the same jumps and samples are composited: a jump is composited alike whichever
# filter's support classed its block, so each runs with one filter, the four filters in turn (each filter
# meets one of them).  (The full cross product: 40 cases; this covering set: 28.)
COMPOSITING = {"btf": ({"renderer.order": "back_to_front"}, "catmull_rom"),
               "ert": ({"renderer.ert_threshold": 0.9}, "nearest"),
               "jitter": ({"renderer.jitter": True}, "cubic_bspline"),
               "ortho": ({"camera.projection": "orthographic"}, "linear")}
EA_CASES = ([pytest.param(f, e, id=f"{name}-{f}") for name, e in READING.items() for f in FILTERS]
            + [pytest.param(f, e, id=f"{name}-{f}") for name, (e, f) in COMPOSITING.items()])


@pytest.mark.parametrize("filter_kind, extra", EA_CASES)
def test_emission_absorption_unchanged(tmp_path, gpu, filter_kind, extra):
    """Closed-form jumps over constant blocks equal stepping to float32 rounding (measured <= 6e-8;
    asserted 2e-6), with early termination inside a block stopping where stepping does."""
    scene = _slab_scene(tmp_path, {**extra, "renderer.filter": filter_kind})
    before, after = _compare(gpu, scene)
    assert after < before if scene.renderer.block_size == 4 else after <= before  # 8^3 blocks: few fit here


@pytest.mark.parametrize("filter_kind", FILTERS)
@pytest.mark.parametrize("mode", ["isosurface", "mip", "minip"])
def test_other_modes_unchanged(tmp_path, gpu, filter_kind, mode):
    extra = {"renderer.compositing": mode, "renderer.filter": filter_kind,
             "renderer.shading.enabled": mode == "isosurface"}
    scene = _slab_scene(tmp_path, extra)
    if mode == "minip":  # low values inside: invert, and let the transfer function show them
        scene = scene.replace(volume=type(scene.volume)(1.0 - scene.volume.data, scene.volume.spacing))
    before, after = _compare(gpu, scene)
    assert after <= before


def test_narrow_spike_inside_a_block(tmp_path, gpu):
    """A transfer function that is zero but for a spike 1/1000 of the range wide, inside the value
    range of blocks whose voxels never take that value: the blocks must not be jumped."""
    ramp = np.broadcast_to(np.linspace(0, 1, 32, dtype=np.float32), (32, 32, 32)).copy()
    spike = [[0.0, 1, 1, 1, 0], [0.5004, 1, 1, 1, 0], [0.5005, 1, 0.2, 0.1, 1.0], [0.5006, 1, 1, 1, 0], [1, 1, 1, 1, 0]]
    # the step given: the defaults take one voxel here (the spike is out of reach of the display target), whose
    # samples sit at half voxels along this axis-aligned ramp and all miss a spike 0.006 voxel wide
    scene = array_scene(tmp_path, ramp, {"transfer_function.points": spike, "renderer.lut_size": 1 << 14,
                                         "image.width": 32, "image.height": 32, "renderer.ert_threshold": 1.0,
                                         "renderer.sample_distance_voxels": 0.75})
    _compare(gpu, scene)


def test_transfer_function_edits_reclassify(tmp_path, gpu):
    # the step fixed: an empty transfer function is chosen again (defaults.py) and would take the longest step,
    # where the ray bounds are not worth drawing; this test is about the blocks' classification
    scene = small_scene({"renderer.ert_threshold": 1.0, "renderer.sample_distance_voxels": 0.5})
    gpu.render(scene)
    empty = scene.replace(transfer_function=TransferFunction(np.array([[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 0.0]])))
    image = gpu.render(empty)
    # no block is left that is not empty: the ray bounds leave every ray without a segment
    assert image.max() == 0 and gpu.stats["ray_bounds"] and gpu.stats["samples"] == 0


def test_homogeneity_tolerance_bounds_the_error(tmp_path, gpu):
    """Nearly constant blocks jumped with the midpoint of their range: the error grows with the
    tolerance and stays within the documented bound (number of jumped blocks x tolerance / 2)."""
    data = np.zeros((40, 40, 40), np.float32)
    data[4:36, 4:36, 4:36] = np.random.default_rng(2).uniform(0.7, 0.72, (32, 32, 32))
    points = [[0.0, 0, 0, 0, 0], [0.5, 0.2, 0.4, 1, 0.0], [0.9, 1, 0.6, 0.2, 0.2]]
    scene = array_scene(tmp_path, data, {"transfer_function.points": points, "image.width": 32, "image.height": 32,
                                         "renderer.ert_threshold": 1.0, "renderer.block_size": 4})
    exact = gpu.render(scene.with_renderer(acceleration=False))
    exact_samples = gpu.stats["samples_per_ray"]
    errors = []
    for tolerance in (0.1, 0.3):  # sigma varies by ~0.012 per unit over a block's range, x diagonal 6.9
        image = gpu.render(scene.with_renderer(homogeneity_tolerance=tolerance, acceleration="on"))
        jumps = gpu.stats["jumps_per_ray"]
        assert gpu.stats["samples_per_ray"] < exact_samples / 2
        errors.append(np.abs(image - exact).max())
        assert errors[-1] <= (jumps + 1) * tolerance / 2
    assert 0 < errors[0] <= errors[1]

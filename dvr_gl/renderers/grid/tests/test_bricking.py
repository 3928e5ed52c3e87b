"""Bricks: planning, visibility order and ghost widths (the grid kit); a renderer's bricked rendering equal
to unbricked is tested in its folder (``test_bricking_NAME.py``)."""

import numpy as np
import pytest

from dvr_gl.camera import Camera
from dvr_gl.renderers.grid.bricking import plan_bricks, visibility_order


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


def test_ghosts_grow_with_what_a_brick_reads_beyond_its_core():
    from dvr_gl.renderers.grid.bricking import ghost_width

    assert ghost_width("linear", False) == 1 and ghost_width("catmull_rom", True) == 3
    assert ghost_width("linear", True, reach=0.25) == 3 and ghost_width("cubic_bspline", False, reach=3.5) == 6

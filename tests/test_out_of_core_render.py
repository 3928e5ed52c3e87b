"""The ray caster's side of issue 22: bricks read apart (out of core, coarser levels).

The texture LRU, the acceleration pyramid built from block ranges, the transparency test that
leaves empty bricks out, and images: a volume read out of core renders as the same volume in
memory, a coarse level of a linear field renders as the fine one.
"""

from __future__ import annotations

import types

import numpy as np
import pytest

from dvr_gl.renderers.grid.gl_base import TextureLRU
from dvr_gl.renderers.raycast import acceleration as accel
from dvr_gl.renderers.raycast.out_of_core import transparent
from dvr_gl.transfer_function import TransferFunction


class FakeTexture:
    def __init__(self, log, name):
        self.log, self.name = log, name

    def release(self):
        self.log.append(self.name)


def test_texture_lru_keeps_the_most_recent_within_its_budget():
    released = []
    lru = TextureLRU(budget=30)

    def make(name, size):
        return lambda: ({"u_volume": FakeTexture(released, name)}, size)

    lru.get("a", make("a", 10))
    lru.get("b", make("b", 10))
    lru.get("a", make("a", 10))   # a hit: "a" is now the most recent
    lru.get("c", make("c", 10))
    assert released == [] and lru.used == 30
    lru.get("d", make("d", 10))   # over the budget: the least recently used ("b") goes
    assert released == ["b"]
    assert (lru.hits, lru.misses, lru.uploaded) == (1, 4, 40)
    lru.get("e", make("e", 100))  # alone over the budget: kept (a pass needs its brick), the rest go
    assert sorted(released) == ["a", "b", "c", "d"] and lru.used == 100
    lru.release()
    assert released[-1] == "e" and lru.used == 0


def block_ranges(data, block):
    """Each block's own voxels' minimum and maximum, by brute force."""
    nz, ny, nx = data.shape
    shape = tuple(-(-n // block) for n in data.shape)
    mins, maxs = np.empty(shape), np.empty(shape)
    for k in range(shape[0]):
        for j in range(shape[1]):
            for i in range(shape[2]):
                part = data[k * block:(k + 1) * block, j * block:(j + 1) * block, i * block:(i + 1) * block]
                mins[k, j, i], maxs[k, j, i] = part.min(), part.max()
    return types.SimpleNamespace(mins=mins, maxs=maxs, block_size=block)


@pytest.mark.parametrize("support", [(0, 1), (1, 2)])
def test_pyramid_from_block_ranges_holds_the_exact_one(support):
    """The pyramid from plain block ranges (no pass over the voxels) contains, at every level and
    block, the range the exact pyramid computes from the voxels: skipping by it stays exact."""
    rng = np.random.default_rng(3)
    data = rng.random((40, 37, 70)).astype(np.float32)
    data[:, :, 35:] *= 0.1  # different ranges in different blocks
    exact = accel.MinMaxPyramid.build(data, 8, support)
    wide = accel.MinMaxPyramid.from_ranges(block_ranges(data, 8), support)
    assert len(wide.levels) == len(exact.levels)
    for (emin, emax), (wmin, wmax) in zip(exact.levels, wide.levels):
        assert wmin.shape == emin.shape
        assert (wmin <= emin).all() and (wmax >= emax).all()
    # and it is not the whole volume's range everywhere: blocks far apart keep their own
    assert wide.levels[0][1][:, :, 0].max() > 0.9 and wide.levels[0][1][:, :, -1].max() < 0.11


def test_transparent_finds_every_opaque_value_of_the_range():
    """A range is transparent only where the exact transfer function and the table nodes around it
    are all zero: a narrow spike inside the range is found, one beyond the nodes' reach is not."""
    tf = TransferFunction(np.array([[0, 0, 0, 0, 0.0], [50, 1, 1, 1, 0.0], [50.5, 1, 1, 1, 0.8],
                                    [51, 1, 1, 1, 0.0], [100, 1, 1, 1, 0.0]]))
    grid = [((0.0, 100.0), 101)]  # table nodes at every integer value
    assert transparent(tf, 0, 49, grid)
    assert not transparent(tf, 50.2, 50.7, grid)   # inside the spike
    assert transparent(tf, 49.5, 49.9, grid)       # widened to the nodes 49 .. 50: the spike starts at 50
    assert not transparent(tf, 49.5, 50.1, grid)   # widened to 49 .. 51: the spike is in
    assert transparent(tf, 52.0, 100.0, grid)
    assert not transparent(tf, 51.2, 52.0, [((0.0, 100.0), 11)])  # coarse nodes 50 .. 60 take the spike in

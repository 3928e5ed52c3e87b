"""Groups of items laid end to end (each group's length in ``counts``), handled without a Python loop:
the vectorized pair lists of the mesh's bins and rays, the knots along rays, the sort's successors."""

from __future__ import annotations

import numpy as np


def ranks(counts) -> np.ndarray:
    """Each item's position in its group: ``0 .. counts[i] - 1`` for every group, concatenated."""
    counts = np.asarray(counts)
    return np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)


def joined_knots(rays: list, ts: list) -> tuple[np.ndarray, np.ndarray]:
    """``(ray, t)`` lists of arrays, gathered batch by batch, as two arrays (empty ones if none)."""
    if not rays:
        return np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(rays), np.concatenate(ts)


def ranges(starts, counts) -> np.ndarray:
    """The indices ``starts[i] .. starts[i] + counts[i] - 1`` of every group, concatenated."""
    return np.repeat(starts, counts) + ranks(counts)

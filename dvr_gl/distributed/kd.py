"""The bricks split among workers: a kd tree of the brick grid.

The brick grid (brick indices, x, y, z) is halved recursively along its longest axis (in bricks),
the workers of a node split between its two children in proportion to their bricks, so that
every worker's bricks form a box of the grid and any two sibling groups lie on either side of a
plane of brick boundaries.  For a point of view the sibling on the eye's side of that plane comes
first along every ray that crosses both (perspective: the side the eye is on; orthographic: the
side the view direction leaves), which orders the workers' partial images for compositing.
Workers are numbered in the tree's left-to-right order, the left child holding the lower numbers;
with a power-of-two count every split halves the workers, so the workers ``i`` and
``i ^ 2**r`` are siblings at level ``r`` from the bottom: binary swap's partners.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Node:
    """Workers ``lo .. hi - 1`` and their box of bricks (brick indices ``box_lo .. box_hi - 1``).
    An inner node splits along ``axis`` at brick index ``cut`` (the left child: indices below it)
    and voxel coordinate ``plane`` (the first core voxel of the bricks at ``cut``)."""

    lo: int
    hi: int
    box_lo: tuple
    box_hi: tuple
    axis: int = -1
    cut: int = -1
    plane: float = 0.0
    left: "Node | None" = None
    right: "Node | None" = None

    def left_first(self, eye_voxel, view_direction, orthographic: bool) -> bool:
        """Is the left child in front for this view (eye and direction in voxel coordinates)?"""
        if orthographic:
            return view_direction[self.axis] >= 0.0
        return eye_voxel[self.axis] < self.plane

    def leaves(self):
        if self.left is None:
            yield self
        else:
            yield from self.left.leaves()
            yield from self.right.leaves()


def split(bricks: list, workers: int) -> tuple[Node, list[list]]:
    """The kd tree of ``bricks`` (:class:`dvr_gl.renderers.grid.bricking.Brick`, a full grid) for
    ``workers`` workers, and each worker's bricks (a worker may get none where the grid has fewer
    bricks along the split than workers)."""
    if workers < 1:
        raise ValueError("at least one worker")
    index = np.array([b.index for b in bricks])
    lo_voxel = {}  # first core voxel of brick index i along each axis
    for b in bricks:
        for axis in range(3):
            lo_voxel[axis, b.index[axis]] = b.core_lo[axis]
    assigned: list[list] = [[] for _ in range(workers)]

    def build(lo, hi, box_lo, box_hi):
        extent = np.asarray(box_hi) - np.asarray(box_lo)
        n = hi - lo
        if n == 1 or extent.max() <= 1:
            inside = np.all((index >= box_lo) & (index < box_hi), axis=1)
            assigned[lo].extend(b for b, keep in zip(bricks, inside) if keep)
            return Node(lo, hi, tuple(box_lo), tuple(box_hi))
        axis = int(np.argmax(extent))
        left_workers = n // 2
        cut = box_lo[axis] + min(max(round(extent[axis] * left_workers / n), 1), extent[axis] - 1)
        left_hi, right_lo = list(box_hi), list(box_lo)
        left_hi[axis], right_lo[axis] = cut, cut
        return Node(lo, hi, tuple(box_lo), tuple(box_hi), axis, cut, float(lo_voxel[axis, cut]),
                    build(lo, lo + left_workers, box_lo, left_hi), build(lo + left_workers, hi, right_lo, box_hi))

    root = build(0, workers, [0, 0, 0], list(index.max(axis=0) + 1))
    return root, assigned


def front_to_back(root: Node, eye_voxel, view_direction, orthographic: bool) -> list[int]:
    """The workers in visibility order (front first) for a view."""
    def walk(node):
        if node.left is None:
            return list(range(node.lo, node.hi))  # a leaf holds one worker (or an unsplittable box's)
        first, second = (node.left, node.right) if node.left_first(eye_voxel, view_direction, orthographic) \
            else (node.right, node.left)
        return walk(first) + walk(second)
    return walk(root)


def sibling_node(root: Node, lo: int, hi: int) -> Node:
    """The inner node whose children are the worker ranges ``[lo, mid)`` and ``[mid, hi)``."""
    node = root
    while (node.lo, node.hi) != (lo, hi) and node.left is not None:  # a leaf: one box, any order
        node = node.left if hi <= node.left.hi else node.right
    return node

"""Bricks: a volume split into sub-volumes that each fit one texture.

Brick cores tile the volume's voxel grid and share their boundary voxel (the
core of brick ``b`` along an axis is voxels ``[lo, hi]`` and the next brick's
starts at ``hi``), so together they cover the box without gaps; each brick's
texture adds ``ghost`` voxels on every side (clamped to the volume), so that a
filter (cubic: one below, two above), central differences (one more) and
samples a renderer takes beyond the core for what the core owns (see
:func:`ghost_width`) read the same voxels as in the whole volume.  A sample belongs to the brick whose
half-open core ``[lo, hi)`` holds its voxel coordinate (the last brick along an
axis closes at the volume's end), so every sample is composited exactly once.

For a point of view, :func:`visibility_order` sorts bricks so that along every
ray the bricks come front to back: along each axis a ray moves away from the
eye's brick index, so the sum over axes of the index distance never decreases.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

GHOST = 3  # cubic support (2) + central differences (1): enough for point samples in the core
FILTER_SUPPORT = {"nearest": 1, "linear": 1, "cubic_bspline": 2, "catmull_rom": 2}  # voxels read beyond a point


@dataclass(frozen=True)
class Brick:
    index: tuple[int, int, int]   # brick grid position (x, y, z)
    core_lo: tuple[int, int, int]  # first and last core voxel (x, y, z), inclusive
    core_hi: tuple[int, int, int]
    tex_lo: tuple[int, int, int]   # first texture voxel and texture size (x, y, z), ghosts included
    tex_dims: tuple[int, int, int]
    last: tuple[bool, bool, bool]  # is it the last brick along x, y, z (its core closes at the end)

    def data(self, array: np.ndarray) -> np.ndarray:
        """This brick's texture voxels of a ``[z, y, x, ...]`` array."""
        (x0, y0, z0), (nx, ny, nz) = self.tex_lo, self.tex_dims
        return np.ascontiguousarray(array[z0:z0 + nz, y0:y0 + ny, x0:x0 + nx])

    def world_box(self, volume) -> tuple[np.ndarray, np.ndarray]:
        o, s = np.asarray(volume.origin), np.asarray(volume.spacing)
        lo, hi = o + np.asarray(self.core_lo) * s, o + np.asarray(self.core_hi) * s
        vlo, vhi = volume.box  # single-sample axes: the volume's slab
        single = np.asarray(volume.dims) == 1
        return np.where(single, vlo, lo), np.where(single, vhi, hi)


def plan_bricks(dims, max_texture: int, ghost: int = GHOST) -> list[Brick]:
    """Bricks whose textures are at most ``max_texture`` voxels along every axis."""
    core = max_texture - 2 * ghost - 1          # voxel intervals a core may span
    if core < 1:
        raise ValueError(f"bricks of {max_texture} voxels leave no core beside {ghost} ghost voxels")
    per_axis = []
    for n in dims:
        count = max(1, -(-(n - 1) // core))
        edges = np.linspace(0, n - 1, count + 1).round().astype(int) if n > 1 else np.array([0, 0])
        per_axis.append([(int(a), int(b), last) for a, b, last in
                         zip(edges[:-1], edges[1:], [False] * (len(edges) - 2) + [True])])
    bricks = []
    for (bx, ax), (by, ay), (bz, az) in itertools.product(*(list(enumerate(a)) for a in per_axis)):
        lo = (ax[0], ay[0], az[0])
        hi = (ax[1], ay[1], az[1])
        tex_lo = tuple(max(low - ghost, 0) for low in lo)
        tex_hi = tuple(min(h + ghost, n - 1) for h, n in zip(hi, dims))
        bricks.append(Brick((bx, by, bz), lo, hi, tex_lo, tuple(int(b - a + 1) for a, b in zip(tex_lo, tex_hi)),
                            (ax[2], ay[2], az[2])))
    return bricks


def ghost_width(filter_name: str, central_differences: bool, reach: float = 0.0) -> int:
    """Ghost voxels a brick needs on each side: the filter's support, one more where gradients are
    central differences, and ``reach``: how far (voxels, along any axis) beyond its core a renderer
    samples for what the brick owns (the ends of a pre-integrated segment, an isosurface's bracket)."""
    return FILTER_SUPPORT[filter_name] + int(central_differences) + math.ceil(reach - 1e-9)


def brick_size_for(volume, bytes_per_voxel: int, budget_bytes: int, max_size: int, ghost: int = GHOST) -> int:
    """The largest brick edge (voxels, ghosts included) whose texture fits the budget and the GL limit."""
    edge = min(max_size, max(volume.dims) + 2 * ghost + 1)
    while edge > 2 * ghost + 2 and edge ** 3 * bytes_per_voxel > budget_bytes:
        edge = int(edge * 0.8)
    return edge


def visibility_order(bricks: list[Brick], volume, camera, front_to_back: bool = True) -> list[Brick]:
    """Bricks in an order valid for every ray of the camera (see the module doc)."""
    if not bricks:  # every brick of the frame empty
        return []
    f, _, _ = camera.basis()
    index = np.array([b.index for b in bricks])
    if camera.projection == "orthographic":  # parallel rays: along each axis the index moves one way
        key = index @ np.sign(f)
    else:
        eye = (np.asarray(camera.eye) - np.asarray(volume.origin)) / np.asarray(volume.spacing)
        lo, hi = np.array([b.core_lo for b in bricks]), np.array([b.core_hi for b in bricks])
        eye_index = np.empty(3)
        for axis in range(3):  # the eye's brick index along each axis (-1 or the count if outside)
            inside = (lo[:, axis] <= eye[axis]) & (eye[axis] < hi[:, axis])
            if inside.any():
                eye_index[axis] = index[inside, axis][0]
            else:
                eye_index[axis] = -1 if eye[axis] < lo[:, axis].min() else index[:, axis].max() + 1
        key = np.abs(index - eye_index).sum(axis=1)
    order = np.argsort(key if front_to_back else -key, kind="stable")
    return [bricks[i] for i in order]

"""Grid views: the part of a voxel grid one pass samples, the whole volume or one brick of it (first
voxel and size, :mod:`.bricking`), so bricked and unbricked rendering share every shader and uniform;
a brick may be drawn from a coarser level of the volume (:func:`level_view`).

:func:`plan_views` chooses the views of a frame, :func:`grid_uniforms` maps world coordinates to a
view's texels.  Used by the grid renderers (:mod:`.sampling`).
"""

from __future__ import annotations

import numpy as np

from ...errors import DvrError
from .bricking import brick_size_for, ghost_width, plan_bricks

# A volume read out of core is drawn in bricks of at most 1 / OUT_OF_CORE_BRICKS of its host-memory budget.
OUT_OF_CORE_BRICKS = 8


class GridView:
    """The part of the voxel grid a pass samples: ``tex_lo`` (x, y, z) and ``dims`` of its texture, in
    the voxels of ``grid``: the scene's volume (None), or its coarser level ``level``."""

    def __init__(self, tex_lo=(0, 0, 0), dims=None, brick=None, level: int = 0, grid=None):
        self.tex_lo, self.dims, self.brick = tuple(tex_lo), tuple(dims), brick
        self.level, self.grid = level, grid


def plan_views(scene, defines: dict, per_voxel: int, limit: int, reach: float) -> list[GridView]:
    """The whole volume if its textures (``per_voxel`` bytes a voxel) fit the GL limit ``limit`` (voxels
    along an edge) and the budget, else bricks that do; a volume read out of core
    (:mod:`dvr_gl.out_of_core`) always in bricks, each at most an eighth of
    ``renderer.memory_budget_mb`` (its host copy is read while the last one's texture lives);
    ``reach``: how far (voxels) beyond a brick's core the renderer samples (:func:`.bricking.ghost_width`)."""
    r, volume = scene.renderer, scene.volume
    budget = r.texture_budget_mb * 2 ** 20
    whole = max(volume.dims) <= limit and np.prod(volume.dims) * per_voxel <= budget
    if whole and not volume.out_of_core and not volume.levels:
        return [GridView((0, 0, 0), volume.dims)]
    central = ("SHADING" in defines or "GRADIENT_OPACITY" in defines) and "GRADIENT_TEXTURE" not in defines
    ghost = ghost_width(r.filter, central, reach)
    brick_budget = budget
    if volume.out_of_core:
        brick_budget = min(budget, getattr(r, "memory_budget_mb", 4096.0) * 2 ** 20 / OUT_OF_CORE_BRICKS)
    edge = brick_size_for(volume, per_voxel, brick_budget, limit, ghost)
    if edge ** 3 * per_voxel > brick_budget or edge <= 2 * ghost + 1:
        raise DvrError(f"renderer.texture_budget_mb = {r.texture_budget_mb} cannot hold even a "
                       f"{2 * ghost + 2}^3 brick of {volume.name} ({ghost} ghost voxel{'s' * (ghost > 1)} a side); "
                       f"raise it")
    return [GridView(b.tex_lo, b.tex_dims, b) for b in plan_bricks(volume.dims, edge, ghost)]


def level_view(scene, view: GridView, level: int) -> GridView:
    """``view``'s brick drawn from the volume's coarser level ``level`` (1: ``volume.levels[0]``): the
    level's voxels over the brick's texture box, with as many ghost voxels of the level as the
    brick has of level 0 (ownership stays level 0's: the shader's global coordinates)."""
    if level == 0 or view.brick is None:
        return view
    volume, b = scene.volume, view.brick
    grid = volume.levels[level - 1]
    o0, s0 = np.asarray(volume.origin), np.asarray(volume.spacing)
    ok, sk = np.asarray(grid.origin), np.asarray(grid.spacing)
    lo0 = o0 + np.asarray(b.core_lo) * s0
    hi0 = o0 + np.asarray(b.core_hi) * s0
    tex_hi = np.asarray(b.tex_lo) + np.asarray(b.tex_dims) - 1
    ghost = int(max(1, *(np.asarray(b.core_lo) - b.tex_lo), *(tex_hi - b.core_hi)))  # its widest side
    dims = np.asarray(grid.dims)
    lo = np.clip(np.floor((lo0 - ok) / sk).astype(int) - ghost, 0, dims - 1)
    hi = np.clip(np.ceil((hi0 - ok) / sk).astype(int) + ghost, 0, dims - 1)
    return GridView(tuple(int(v) for v in lo), tuple(int(v) for v in hi - lo + 1), view.brick, level, grid)


def grid_uniforms(scene, view: GridView) -> dict:
    """World coordinates to ``view``'s texture voxels (``voxel = world * scale + offset``), its voxel
    spacing (world units) and size."""
    vol = view.grid or scene.volume
    spacing = np.array(vol.spacing)
    return {"u_world_to_voxel_scale": 1.0 / spacing,
            "u_world_to_voxel_offset": -np.array(vol.origin) / spacing - np.array(view.tex_lo),
            "u_voxel_spacing": spacing, "u_dims": view.dims}

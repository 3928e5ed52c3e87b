"""Acceleration structures for ray casting: a min-max pyramid and per-transfer-function block classes.

**Blocks.** Level-0 blocks are ``B^3`` voxels (``block_size``, 8 or 16); level
``l`` blocks are ``(B 2^l)^3``.  A ray sample at voxel coordinate ``u`` lies in
block ``floor(u / S)`` of size ``S``, whose own voxels are ``[b S, (b + 1) S - 1]``;
the filter reads beyond them (trilinear: ``floor(u) + 1``, up to ``(b + 1) S``;
cubics: ``floor(u) - 1 .. floor(u) + 2``), so each block's value range covers the
voxels ``[b S - lo, (b + 1) S - 1 + hi]`` with ``(lo, hi)`` = (0, 1) for nearest and
trilinear and (1, 2) for the cubics, clamped to the volume.  The pyramid holds the minimum
and maximum of those voxels per block and level, built once per volume.

**Classes** (recomputed in milliseconds when the transfer function changes):
a block is *constant* when colour and extinction are constant (within
``tolerance``) for every value the filter can produce in it: for the table the
GPU uses, every value between the block's minimum and maximum interpolates
table nodes ``floor(x(min)) .. ceil(x(max))``, so the range minimum and maximum
of those nodes (sparse tables, O(1) per query) bound it.  Catmull-Rom's
negative lobes can leave ``[min, max]`` by up to 0.477 of its width (the sum of
the negative tensor weights), so its ranges are widened by that.  A constant
block is stored as ``(colour, sigma)``, an empty one as ``(0, 0, 0, 0)``, any
other as ``sigma = -1``.  With ``tolerance = 0`` only exactly constant blocks
qualify, and rendering is unchanged: a run of segments whose samples all see
the same ``(c, sigma)`` composites to ``c (1 - exp(-sigma m d))`` however it is
stepped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import rays as rays_mod

# Voxels a filter reads beyond a block's own: (below, above).
SUPPORT = {"nearest": (0, 1), "linear": (0, 1), "cubic_bspline": (1, 2), "catmull_rom": (1, 2)}
# How far a filter's output can leave the range of its taps, as a fraction of that range.
OVERSHOOT = {"nearest": 0.0, "linear": 0.0, "cubic_bspline": 0.0, "catmull_rom": (1.25 ** 3 - 1.0) / 2.0}
MAX_LEVELS = 4


def level_count(dims, block_size: int, max_levels: int = MAX_LEVELS) -> int:
    """Levels of the pyramid: halving the block grid until one block or ``max_levels``."""
    nb = max(-(-n // block_size) for n in dims)
    levels = 1
    while levels < max_levels and nb > 1:
        nb = -(-nb // 2)
        levels += 1
    return levels


def _window_reduce(a: np.ndarray, axis: int, block: int, lo: int, hi: int, op) -> np.ndarray:
    """Reduce ``a`` along ``axis`` over windows ``[b B - lo, (b + 1) B - 1 + hi]`` (clamped to the array),
    one per block ``b < ceil(n / B)``.  Views and a gather of the boundary voxels: no copy of ``a``."""
    moved = np.moveaxis(a, axis, -1)
    n = moved.shape[-1]
    full, rest = divmod(n, block)
    parts = []
    if full:
        parts.append(op.reduce(moved[..., :full * block].reshape(moved.shape[:-1] + (full, block)), axis=-1))
    if rest:
        parts.append(op.reduce(moved[..., full * block:], axis=-1, keepdims=True))
    out = np.concatenate(parts, axis=-1) if len(parts) > 1 else parts[0]
    starts = np.arange(out.shape[-1]) * block
    for j in range(1, lo + 1):  # voxels below each block
        out = op(out, moved[..., np.maximum(starts - j, 0)])
    for j in range(hi):  # voxels above each block
        out = op(out, moved[..., np.minimum(starts + block + j, n - 1)])
    return np.moveaxis(out, -1, axis)


def _z_reduce(data: np.ndarray, block: int, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
    """Minimum and maximum over each block's window of z slices (as ``_window_reduce`` along axis 0),
    one slab at a time: the slab's slices stay in cache for both reductions (the CT bunny's 190 MB:
    70 ms against 140-250 for two whole-volume passes)."""
    n = data.shape[0]
    nb = -(-n // block)
    mins = np.empty((nb,) + data.shape[1:], data.dtype)
    maxs = np.empty_like(mins)
    for b in range(nb):
        slab = data[max(b * block - lo, 0):min((b + 1) * block + hi, n)]
        np.minimum.reduce(slab, axis=0, out=mins[b])
        np.maximum.reduce(slab, axis=0, out=maxs[b])
    return mins, maxs


@dataclass(frozen=True, eq=False)
class MinMaxPyramid:
    """Per-block minimum and maximum of a volume's values, for ``MAX_LEVELS`` levels.

    ``levels[l]`` is ``(min, max)``, each ``(nbz, nby, nbx)`` float32; level 0 has
    ``ceil(n / B)`` blocks per axis, each level half the previous (rounded up).
    """

    block_size: int
    support: tuple[int, int]
    levels: tuple

    @classmethod
    def build(cls, data: np.ndarray, block_size: int = 8, support=(0, 1), max_levels: int = MAX_LEVELS):
        lo, hi = support
        mins, maxs = _z_reduce(data, block_size, lo, hi)
        for axis in (1, 2):
            mins = _window_reduce(mins, axis, block_size, lo, hi, np.minimum)
            maxs = _window_reduce(maxs, axis, block_size, lo, hi, np.maximum)
        levels = [(mins.astype(np.float32), maxs.astype(np.float32))]
        for _ in range(1, level_count(data.shape, block_size, max_levels)):
            levels.append(tuple(_coarsen(a, op) for a, op in zip(levels[-1], (np.minimum, np.maximum))))
        return cls(block_size, tuple(support), tuple(levels))

    @classmethod
    def from_ranges(cls, ranges, support=(0, 1), max_levels: int = MAX_LEVELS):
        """The pyramid of a volume read out of core, from its blocks' plain ranges
        (:class:`dvr_gl.out_of_core.BlockRanges`: each block's own voxels), without reading a voxel: each
        block's window also takes its neighbours' ranges on the sides the filter reaches into (a
        superset of the voxels :meth:`build` takes: only wider, so skipping stays exact)."""
        lo, hi = support
        mins, maxs = (np.asarray(a, dtype=np.float32) for a in (ranges.mins, ranges.maxs))
        for axis in range(3):
            for reach, shift in ((lo, 1), (hi, -1)):
                if reach and mins.shape[axis] > 1:
                    mins = np.minimum(mins, _shifted(mins, axis, shift))
                    maxs = np.maximum(maxs, _shifted(maxs, axis, shift))
        levels = [(mins, maxs)]
        dims = tuple(n * ranges.block_size for n in mins.shape)
        for _ in range(1, level_count(dims, ranges.block_size, max_levels)):
            levels.append(tuple(_coarsen(a, op) for a, op in zip(levels[-1], (np.minimum, np.maximum))))
        return cls(ranges.block_size, tuple(support), tuple(levels))

    def block_voxels(self, level: int) -> int:
        return self.block_size << level


def _shifted(a: np.ndarray, axis: int, shift: int) -> np.ndarray:
    """``a`` moved by one along ``axis`` (1: each entry takes its lower neighbour's), edges repeated."""
    n = a.shape[axis]
    index = np.clip(np.arange(n) - shift, 0, n - 1)
    return np.take(a, index, axis=axis)


def _coarsen(a: np.ndarray, op) -> np.ndarray:
    """Combine 2x2x2 children (odd counts padded by repeating the edge)."""
    pad = [(0, s % 2) for s in a.shape]
    a = np.pad(a, pad, mode="edge")
    z, y, x = (s // 2 for s in a.shape)
    return op.reduce(op.reduce(op.reduce(a.reshape(z, 2, y, 2, x, 2), axis=5), axis=3), axis=1)


class SparseTable:
    """Range minimum and maximum over the rows of a table, O(1) per query (vectorized)."""

    def __init__(self, table: np.ndarray):
        self.mins, self.maxs = [table], [table]
        span = 1
        while 2 * span <= len(table):
            self.mins.append(np.minimum(self.mins[-1][:-span], self.mins[-1][span:]))
            self.maxs.append(np.maximum(self.maxs[-1][:-span], self.maxs[-1][span:]))
            span *= 2

    def query(self, i0: np.ndarray, i1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Column-wise min and max of rows ``i0 .. i1`` (inclusive, ``i0 <= i1``)."""
        k = np.floor(np.log2(i1 - i0 + 1)).astype(np.int64)
        k = np.minimum(k, len(self.mins) - 1)
        out_min = np.empty(i0.shape + self.mins[0].shape[1:])
        out_max = np.empty_like(out_min)
        for level in range(len(self.mins)):  # not np.unique: its first call imports numpy.ma (20-30 ms)
            sel = k == level
            if not sel.any():
                continue
            a, b = i0[sel], i1[sel] - (1 << level) + 1
            out_min[sel] = np.minimum(self.mins[level][a], self.mins[level][b])
            out_max[sel] = np.maximum(self.maxs[level][a], self.maxs[level][b])
        return out_min, out_max


def _distinct(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted distinct values of ``codes`` and, per element, the index of its value among them
    (``np.unique(..., return_inverse=True)`` without its import of numpy.ma on the first frame)."""
    order = np.argsort(codes, kind="stable")
    ranked = codes[order]
    first = np.empty(len(ranked), bool)
    first[:1] = True
    np.not_equal(ranked[1:], ranked[:-1], out=first[1:])
    inverse = np.empty(len(codes), np.int64)
    inverse[order] = np.cumsum(first) - 1
    return ranked[first], inverse


def widened(lo: np.ndarray, hi: np.ndarray, filter_kind: str) -> tuple[np.ndarray, np.ndarray]:
    """The values a filter can produce from taps in ``[lo, hi]``."""
    over = OVERSHOOT[filter_kind] * (hi - lo)
    return lo - over, hi + over


def constant_blocks(colour_min, colour_max, sigma_min, sigma_max, block_world: float,
                    tolerance: float, constant_allowed: bool) -> np.ndarray:
    """Block classes ``(..., 4)``: ``(colour, sigma)`` where constant within the tolerance, ``(0, 0, 0, 0)``
    where empty, ``sigma = -1`` elsewhere.  ``constant_allowed = False`` (shading) keeps only empty blocks:
    a constant colour would be shaded differently at every sample."""
    out = np.concatenate([(colour_min + colour_max) / 2.0, ((sigma_min + sigma_max) / 2.0)[..., None]], axis=-1)
    empty = sigma_max <= 0.0
    constant = ((sigma_max - sigma_min) * block_world <= tolerance) & \
        (np.max(colour_max - colour_min, axis=-1) <= tolerance)
    keep = empty | (constant if constant_allowed else False)
    out[empty] = 0.0
    out[~keep, 3] = -1.0
    return out.astype(np.float32)


def snapped(vmin: np.ndarray, vmax: np.ndarray, domain, nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Value ranges widened outward to a grid of ``nodes`` over ``domain``: a pre-integration table
    interpolates its entries from the nodes around the segment's end values."""
    lo, hi = domain
    scale = (nodes - 1) / (hi - lo)
    x0 = np.clip(np.floor((vmin - lo) * scale), 0, nodes - 1)
    x1 = np.clip(np.ceil((vmax - lo) * scale), 0, nodes - 1)
    return lo + x0 / scale, lo + x1 / scale


def table_classes(pyramid: MinMaxPyramid, lut, filter_kind: str, spacing, tolerance: float = 0.0,
                  constant_allowed: bool = True, snap=None) -> list[np.ndarray]:
    """Post-classification block classes, one ``(nbz, nby, nbx, 4)`` array per level.
    ``snap = (domain, nodes)``: pre-integrated classification, ranges widened to its nodes."""
    table = SparseTable(np.asarray(lut.table, dtype=np.float64))
    out = []
    for level, (mins, maxs) in enumerate(pyramid.levels):
        vmin, vmax = widened(mins.astype(np.float64), maxs.astype(np.float64), filter_kind)
        if snap is not None:
            vmin, vmax = snapped(vmin, vmax, *snap)
        i0 = np.floor(lut.node_coordinate(vmin)).astype(np.int64)
        i1 = np.minimum(np.ceil(lut.node_coordinate(vmax)).astype(np.int64), lut.size - 1)
        # blocks share few distinct ranges (air, soft tissue, ...): query each once
        pairs, inverse = _distinct(i0.ravel() * lut.size + i1.ravel())
        tmin, tmax = table.query(pairs // lut.size, pairs % lut.size)
        tmin, tmax = tmin[inverse], tmax[inverse]
        shape = mins.shape
        block_world = np.linalg.norm(np.asarray(spacing) * pyramid.block_voxels(level))
        out.append(constant_blocks(tmin[:, :3].reshape(shape + (3,)), tmax[:, :3].reshape(shape + (3,)),
                                   tmin[:, 3].reshape(shape), tmax[:, 3].reshape(shape), block_world,
                                   tolerance, constant_allowed))
    return out


def classified_classes(channel_pyramids: list[MinMaxPyramid], associated: bool, filter_kind: str, spacing,
                       tolerance: float = 0.0, constant_allowed: bool = True) -> list[np.ndarray]:
    """Pre-classification block classes from pyramids of the classified channels (q_r, q_g, q_b, sigma)
    or (c_r, c_g, c_b, sigma)."""
    out = []
    for level in range(len(channel_pyramids[0].levels)):
        lows, highs = zip(*(widened(p.levels[level][0].astype(np.float64), p.levels[level][1].astype(np.float64),
                                    filter_kind) for p in channel_pyramids))
        lo, hi = np.stack(lows, axis=-1), np.stack(highs, axis=-1)
        lo[..., 3], hi[..., 3] = np.maximum(lo[..., 3], 0.0), np.maximum(hi[..., 3], 0.0)  # clamped as sampled
        block_world = np.linalg.norm(np.asarray(spacing) * channel_pyramids[0].block_voxels(level))
        classes = constant_blocks(lo[..., :3], hi[..., :3], lo[..., 3], hi[..., 3], block_world,
                                  tolerance, constant_allowed)
        if associated:  # constant (sigma c, sigma): store the colour c
            sig = classes[..., 3:4]
            with np.errstate(invalid="ignore", divide="ignore"):
                classes[..., :3] = np.where(sig > 0, classes[..., :3] / sig, 0.0)
        out.append(classes)
    return out


def minmax_textures(pyramid: MinMaxPyramid, filter_kind: str) -> list[np.ndarray]:
    """Per level ``(nbz, nby, nbx, 2)`` float32: the values the filter can produce in each block."""
    return [np.stack(widened(mins, maxs, filter_kind), axis=-1).astype(np.float32) for mins, maxs in pyramid.levels]


# Neighbourhood radii of the runs texture, in level-0 blocks (shaders/blocks.glsl's dense_reach).
RUN_RADII = (1, 2, 4, 8)


def neighbourhood_reduce(key: np.ndarray, reach: int, op) -> np.ndarray:
    """``op`` of ``key`` over the blocks within Chebyshev distance ``reach`` (clipped to the grid):
    separable, one shifted view per offset and axis."""
    out = key
    for axis in range(3):
        acc = out.copy()
        n = out.shape[axis]
        for shift in range(1, min(reach, n - 1) + 1):
            lo = [slice(None)] * 3
            hi = [slice(None)] * 3
            lo[axis], hi[axis] = slice(0, n - shift), slice(shift, n)
            acc[tuple(lo)] = op(acc[tuple(lo)], out[tuple(hi)])   # the neighbour above
            acc[tuple(hi)] = op(acc[tuple(hi)], out[tuple(lo)])   # the neighbour below
        out = acc
    return out


def run_keys(level0: np.ndarray, mode: str) -> np.ndarray:
    """The runs texture ``(nbz, nby, nbx, 4)`` float32 from a mode's level-0 blocks (the classes for
    emission-absorption, the (min, max) texture otherwise): channel ``i`` reduces the mode's key over
    the blocks within ``RUN_RADII[i] - 1``.  Keys: emission, 1 where a block is not skippable (least
    around: 1 only if none is); MIP and isosurface, the block maximum (least around: no block below
    it); MinIP, the block minimum (largest around)."""
    if mode == "emission":
        key, op = (level0[..., 3] < 0.0).astype(np.float32), np.minimum
    elif mode == "minip":
        key, op = level0[..., 0], np.maximum
    else:
        key, op = level0[..., 1], np.minimum
    return np.stack([neighbourhood_reduce(key, r - 1, op) for r in RUN_RADII], axis=-1).astype(np.float32)


@dataclass(frozen=True)
class SkipEstimate:
    """What skipping would do to a frame, per ray through the volume: ``fraction`` of the samples
    saved, ``lookups`` of blocks (one per skippable block crossed, one per run of blocks sampled),
    over rays ``length`` world units long on average, in ``mode`` (as :func:`skip_estimate`'s)."""

    fraction: float
    lookups: float
    length: float
    mode: str = "emission"
    outside: float = 0.0  # bounded: the fraction of all samples outside the ray bounds
    bounded: bool = False  # over the points within the ray bounds only
    ray_length: float = 0.0  # the rays' mean length in the box (bounded or not), world units


def skippable_fraction(level0: np.ndarray, mode: str, block_size: int, volume, camera, aspect: float = 1.0,
                       iso_value: float = 0.0, rays: int = 24, steps_per_block: int = 2) -> float:
    """:func:`skip_estimate`'s fraction of samples saved."""
    return skip_estimate(level0, mode, block_size, volume, camera, aspect, iso_value, rays,
                         steps_per_block).fraction


def skip_estimate(level0: np.ndarray, mode: str, block_size: int, volume, camera, aspect: float = 1.0,
                  iso_value: float = 0.0, rays: int = 24, steps_per_block: int = 2,
                  bounded: bool = False) -> SkipEstimate:
    """An estimate of the fraction of a frame's samples that block skipping saves and of the block
    lookups it costs, from the level-0 blocks alone, for ``RayCastRenderer.decide_skipping``
    (``renderer.acceleration = "auto"``).

    About ``rays x rays`` pixel rays of ``camera`` (the image's ``aspect``, width / height) are walked
    through the block grid at ``steps_per_block`` points per block width.  A point is skippable where
    its block is: emission, a constant or empty block (``level0`` the classes); MIP (MinIP), a block
    whose maximum is at most (minimum at least) the largest minimum (smallest maximum) of the blocks
    met before, a bound the true running maximum (minimum) can only exceed; isosurface, a block
    whose maximum is below iso, counting each ray only up to the end of its first block that is not.
    Lookups: one per skippable block a ray enters, at the coarsest level whose block around the point
    is skippable (as the shader jumps), and one per run of points that are not skippable (a run in the
    shader ends at its dense neighbourhood's edge, at most ``2 * RUN_RADII[-1] - 1`` blocks on). Early
    termination is ignored: the estimate is over the whole ray.  ``bounded``: the rays start one step
    before their first non-empty block and end one step after their last (emission-absorption's ray
    bounds, :mod:`.ray_bounds`), and ``outside`` is the fraction of all points left out so."""
    nx = rays if aspect >= 1.0 else max(1, round(rays * aspect))
    ny = rays if aspect <= 1.0 else max(1, round(rays / aspect))
    origins, dirs = camera.pixel_rays(nx, ny)
    lo, hi = volume.box
    t0, t1 = rays_mod.intersect_box(origins, dirs, lo, hi)
    t0 = np.maximum(t0, camera.near_distance(dirs))
    hit = t1 > t0
    if not hit.any():
        return SkipEstimate(0.0, 0.0, 0.0, mode)
    origins, dirs, t0, t1 = origins[hit], dirs[hit], t0[hit], t1[hit]
    spacing, origin = np.asarray(volume.spacing, float), np.asarray(volume.origin, float)
    step = block_size * float(spacing.min()) / steps_per_block
    count = np.ceil((t1 - t0) / step).astype(np.int64)
    k = np.arange(int(count.max()))
    t = t0[:, None] + (k[None, :] + 0.5) * step
    valid = k[None, :] < count[:, None]
    voxel = (origins[:, None, :] + t[..., None] * dirs[:, None, :] - origin) / spacing   # (x, y, z)
    grid = level0.shape[:3]
    b = np.clip(np.floor(voxel / block_size).astype(np.int64), 0, np.array(grid[::-1]) - 1)
    # the key whose block value decides skipping, per level (coarser: the 2x2x2 children combined)
    if mode == "emission":
        key, op = level0[..., 3] >= 0.0, np.logical_and
    elif mode == "minip":
        key, op = -level0[..., 0], np.maximum
    else:
        key, op = level0[..., 1], np.maximum
    keys = [key]
    for _ in range(1, level_count(volume.dims, block_size)):
        keys.append(_coarsen(keys[-1], op))
    values = [kl[b[..., 2] >> lv, b[..., 1] >> lv, b[..., 0] >> lv] for lv, kl in enumerate(keys)]
    outside = 0.0
    if bounded:
        occupied = (level0[..., 3][b[..., 2], b[..., 1], b[..., 0]] != 0.0) & valid  # not empty
        reached = occupied.any(axis=1)
        first = np.where(reached, np.argmax(occupied, axis=1) - 1, count)
        last = np.where(reached, k.size - np.argmax(occupied[:, ::-1], axis=1) + 1, 0)
        inside = valid & (k[None, :] >= first[:, None]) & (k[None, :] < last[:, None])
        outside = 1.0 - inside.sum() / max(valid.sum(), 1)
        valid = inside
    if mode == "emission":
        skips = values
    elif mode == "isosurface":
        skips = [v < iso_value for v in values]
        first = np.argmax(~skips[0] & valid, axis=1)  # the first block that may hold the surface
        reached = (~skips[0] & valid).any(axis=1)
        last = np.where(reached, first + steps_per_block, count)
        valid &= k[None, :] < last[:, None]
    else:
        low = level0[..., 0][b[..., 2], b[..., 1], b[..., 0]] if mode == "max" else \
            -level0[..., 1][b[..., 2], b[..., 1], b[..., 0]]
        low = np.where(valid, low, -np.inf)
        bound = np.maximum.accumulate(np.concatenate([np.full((len(t), 1), -np.inf), low[:, :-1]], axis=1), axis=1)
        skips = [v <= bound for v in values]
    skip = skips[0] & valid
    # a lookup jumps the coarsest skippable block around its point: one per such block entered
    jumped = np.full(skip.shape, -1, np.int64)
    for lv in reversed(range(len(skips))):
        flat = ((b[..., 2] >> lv) * (grid[1] + 1) + (b[..., 1] >> lv)) * (grid[2] + 1) + (b[..., 0] >> lv)
        take = skips[lv] & skip & (jumped < 0)
        jumped[take] = (flat[take] << 2) + lv
    entered = np.ones_like(valid)
    entered[:, 1:] = jumped[:, 1:] != jumped[:, :-1]
    # a run samples on to the edge of its block's widest dense neighbourhood (radius R blocks, about
    # R blocks along the ray): each sampled point is 1 / (R steps_per_block) of a lookup, and a run
    # that starts inside a block half a lookup more on average
    sampled = valid & ~skip
    run_start = sampled.copy()
    run_start[:, 1:] &= ~sampled[:, :-1]
    dense = run_keys(level0, "emission" if mode == "emission" else "minip" if mode == "minip" else "max")
    dense = dense[b[..., 2], b[..., 1], b[..., 0]]
    if mode == "emission":
        dense = dense > 0.5
    elif mode == "isosurface":
        dense = dense >= iso_value
    else:
        dense = (-dense if mode == "minip" else dense) > bound[..., None]
    radius = np.ones(skip.shape)
    for i, r in enumerate(RUN_RADII):
        radius = np.where(dense[..., i], float(r), radius)
    lookups = (skip & entered).sum() + (sampled / (radius * steps_per_block)).sum() + 0.5 * run_start.sum()
    rays_hit = len(t)
    length = float(valid.sum() * step / rays_hit) if bounded else float(np.sum(t1 - t0) / rays_hit)
    return SkipEstimate(float(skip.sum() / max(valid.sum(), 1)), float(lookups / rays_hit), length, mode,
                        float(outside), bounded, float(np.sum(t1 - t0) / rays_hit))


def classes_with_runs(level0: np.ndarray) -> np.ndarray:
    """Emission-absorption's level-0 classes with the runs folded in (blocks.glsl, RUNS_IN_CLASSES):
    a block that cannot be skipped (sigma < 0) holds ``-R``, ``R`` the largest of :data:`RUN_RADII`
    whose neighbourhood has no skippable block (at least 1: the block itself)."""
    keys = run_keys(level0, "emission")
    radius = np.zeros(level0.shape[:3], np.float32)
    for i, r in enumerate(RUN_RADII):
        radius = np.where(keys[..., i] > 0.5, np.float32(r), radius)
    out = level0.copy()
    out[..., 3] = np.where(level0[..., 3] < 0.0, -radius, level0[..., 3])
    return out

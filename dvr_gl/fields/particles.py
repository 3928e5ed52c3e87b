"""SPH particles as a field (data kind ``"particles"``): :class:`ParticleSet`.

Each particle ``j`` has a position ``x_j``, a smoothing length ``h_j`` (support ``2 h_j``), a mass
``m_j``, a density ``rho_j`` and a quantity ``A_j``; the field is the SPH interpolant

    A(x) = sum_j (m_j / rho_j) A_j W(|x - x_j|, h_j)

with the M4 cubic spline ``W`` (:mod:`.sph`; the scatter form: each particle's own ``h``), zero
beyond every support.  Without a quantity the field is the density itself (``A_j = rho_j``: ``sum_j
m_j W``), whose X-ray is the column density.

* ``bounds``: the box of the supports; ``sample_spacing`` ("one voxel"): the median ``h``;
* ``value_range``: zero (outside every support) to the interpolant's largest value at the
  particles (where it peaks for smooth data; an interpolant may exceed it slightly between them);
  above :data:`RANGE_SAMPLED_ABOVE` particles, at those of the largest quantities;
* the reconstruction's ``knots`` along a ray are where it enters and leaves each particle's support
  (where the kernel's third derivative jumps from zero, and where a small particle could fall between
  samples): between knots the field is smooth (the kernel is C2 at ``r = h``), and the converged
  reference fits the polynomial of :data:`SPH_DEGREE` to a piece as for the Gaussian.  Cutting also at
  ``r = h`` and at the nearest approach doubled the converged reference's time (the Plummer demo of
  4096 particles at 32x32: 14.8 s against 7.4 s) for the same image (to 4e-9);
* ``samples`` and ``reconstruct_values``: the quantities at the particles and other values at them
  interpolated alike (pre-classification classifies the particles).

Points are sampled through sparse grids of cells (:class:`CellIndex`, a level per size of particle),
each cell listing the particles whose support reaches into it; the knots of a batch of rays come from
every particle whose support the ray meets, found by the distance of its centre to the line
(chunks of rays by particles).
"""

from __future__ import annotations

import contextlib
import functools
import math

import numpy as np

from .. import progress
from ..checks import WORLD_RANGE
from ..errors import SceneError, VolumeError
from ..sandbox import check_bytes
from . import particle_scatter, sph
from .ragged import joined_knots, ranges, ranks

#: The degree of the polynomial the converged reference fits to a piece between knots (as
#: :data:`~dvr_gl.fields.reconstruction.GAUSSIAN_DEGREE`): the kernel is a polynomial in ``r``, not in
#: the ray parameter, but smooth between the knots.
SPH_DEGREE = 9
FILTER = "m4"
POINTS_PER_BATCH = 8192  # points sampled at once (their pairs with the particles in their cells)
PAIRS_PER_CHUNK = 4_000_000  # (ray, particle) pairs tested at once for knots
#: Above this many particles the value range is the interpolant's extremes at the particles of the
#: :data:`RANGE_SAMPLES` largest (and smallest) quantities, not at every particle (ParticleSet.value_range):
#: the sum at every one of a million Plummer particles took 2.4 s of a 5.5 s first picture on an idle machine.
RANGE_SAMPLED_ABOVE = 1 << 18
RANGE_SAMPLES = 4096


class ParticleSet:
    """SPH particles with a quantity; a :class:`~dvr_gl.fields.Field` of kind ``"particles"``."""

    kind = "particles"
    default_filter = FILTER  # what a scene's default filter (linear) stands for here: the SPH kernel

    def __init__(self, positions, smoothing_lengths, masses, densities, values=None, name: str = "particles",
                 array: str = "density", source: str = ""):
        self.name, self.array, self.source = name, array, source
        positions = np.asarray(positions, dtype=np.float64)
        if positions.ndim != 2 or positions.shape[1] != 3 or not len(positions):
            raise VolumeError(f"{name}: expected positions (N, 3) of at least one particle, got shape "
                              f"{positions.shape}")
        n = len(positions)
        columns = {"smoothing lengths": smoothing_lengths, "masses": masses, "densities": densities}
        if values is not None:
            columns[f"quantity {array!r}"] = values
        arrays = {}
        for label, column in columns.items():
            column = np.asarray(column, dtype=np.float64)
            if column.ndim == 0:
                column = np.full(n, float(column))
            column = column.reshape(-1)
            if len(column) != n:
                raise VolumeError(f"{name}: {len(column)} {label} for {n} particles")
            arrays[label] = column
        for label, column in (("positions", positions), *arrays.items()):
            bad = ~np.isfinite(column.reshape(n, -1)).all(axis=1)
            if bad.any():
                raise VolumeError(f"{name}: {int(bad.sum())} {label} are NaN or Inf, the first at particle "
                                  f"{int(np.argmax(bad)) + 1}; fix the file or choose another array (volume.array)")
        h, m, rho = arrays["smoothing lengths"], arrays["masses"], arrays["densities"]
        _refuse(name, ~(h > 0), "a smoothing length <= 0; every particle needs a positive one")
        _refuse(name, ~(m >= 0), "a negative mass")
        _refuse(name, ~(rho > 0), "a density <= 0 (m / rho is each particle's volume)")
        # GL draws in float32 relative to the box's centre, whose squares leave its range beyond these
        lo, hi = WORLD_RANGE
        _refuse(name, np.abs(positions).max(axis=1) > hi, f"a position beyond {hi:g} of the origin (float32 "
                f"coordinates); shift or scale the particles")
        _refuse(name, (h < lo / sph.SUPPORT) | (h > hi / sph.SUPPORT), f"a smoothing length outside "
                f"[{lo / sph.SUPPORT:g}, {hi / sph.SUPPORT:g}] world units (float32 coordinates); scale the particles")
        self.positions, self.smoothing_lengths, self.masses, self.densities = positions, h, m, rho
        self.values = arrays.get(f"quantity {array!r}", rho)
        self.weights = m / rho  # each particle's volume
        reach = sph.SUPPORT * h[:, None]
        self._bounds = ((positions - reach).min(axis=0), (positions + reach).max(axis=0))
        self.sample_spacing = float(np.median(h))

    def __len__(self) -> int:
        return len(self.positions)

    @property
    def bounds(self):
        """The box of the particles' supports (world units)."""
        return self._bounds

    @functools.cached_property
    def value_range(self) -> tuple[float, float]:
        """Zero to the interpolant's largest value at the particles (its smallest where some quantity is
        negative); above :data:`RANGE_SAMPLED_ABOVE` particles, where the sum at every particle costs seconds,
        its largest (smallest) at the :data:`RANGE_SAMPLES` particles of the largest (smallest) quantity
        (:meth:`_range_at_extremes`)."""
        if len(self) > RANGE_SAMPLED_ABOVE:
            extremes = self._range_at_extremes()
            if extremes is not None:
                return extremes
        at = self._reconstruction.sample(self.positions, progress=f"{self.name}: the value range")
        return (min(0.0, float(at.min())), max(0.0, float(at.max())))

    def _range_at_extremes(self) -> tuple[float, float] | None:
        """The value range from the interpolant at the particles of the most extreme quantities only: the
        interpolant is a weighted sum of its neighbours' quantities, so it peaks where they do (on a million
        Plummer particles the same maximum as at every particle, to the last bit, in a seventh of the time).
        A lower bound of the full range's ends: a quantity above the estimate is classified as its top.  Its
        sign needs no sum (the weights ``m / rho`` and the kernel are not negative).  None where numba or a
        grid of the chosen points does not serve (the caller sums at every particle)."""
        values, k = self.values, RANGE_SAMPLES
        chosen = [np.argpartition(-values, k)[:k]] if values.max() > 0 else []
        if values.min() < 0:
            chosen.append(np.argpartition(values, k)[:k])
        if not chosen:
            return 0.0, 0.0
        points = self.positions[np.concatenate(chosen)]
        reach = sph.SUPPORT * self.smoothing_lengths
        lo, hi = points.min(axis=0), points.max(axis=0)
        near = np.all((self.positions > lo - reach[:, None]) & (self.positions < hi + reach[:, None]), axis=1)
        levels = particle_scatter.plan(points, self.positions[near], reach[near])
        if levels is None or particle_scatter.compiled() is None:
            return None
        at = particle_scatter.scatter_sum(levels, points, self.positions[near], self.smoothing_lengths[near],
                                          self._reconstruction.carried[near])[:, 0]
        return min(0.0, float(at.min())), max(0.0, float(at.max()))

    @property
    def samples(self) -> np.ndarray:
        """The quantity at the particles (pre-classification classifies these)."""
        return self.values

    def describe(self) -> str:
        lo, hi = self.value_range
        h = self.smoothing_lengths
        return (f"{self.name}: {len(self)} SPH particles, h {h.min():.3g}..{h.max():.3g} (median "
                f"{self.sample_spacing:.3g}), {self.array} interpolated {lo:g}..{hi:g}")

    def __repr__(self) -> str:
        return f"ParticleSet({self.describe()})"

    def reconstruct(self, filter: str = FILTER, kernel_width=None, kernel_radius=None) -> "SPHInterpolant":
        if filter != FILTER:
            raise SceneError(f"{self.name}: SPH particles are interpolated with their cubic-spline kernel; set "
                             f"renderer.filter = \"{FILTER}\" (got {filter!r})")
        return self._reconstruction

    def reconstruct_values(self, values: np.ndarray, filter: str = FILTER, **_) -> "SPHInterpolant":
        """Other values at the particles ``(N,)`` or ``(N, C)`` interpolated as the quantity is."""
        self.reconstruct(filter)
        return SPHInterpolant(self, np.asarray(values, dtype=np.float64))

    @functools.cached_property
    def _reconstruction(self) -> "SPHInterpolant":
        return SPHInterpolant(self, self.values)

    @functools.cached_property
    def columns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The positions' x, y and z, each contiguous."""
        return tuple(np.ascontiguousarray(self.positions[:, a]) for a in range(3))

    @functools.cached_property
    def index(self) -> "CellIndex":
        return CellIndex(self.positions, sph.SUPPORT * self.smoothing_lengths, self.bounds)


def _refuse(name: str, bad: np.ndarray, what: str):
    """Refuse the particles flagged in ``bad``, naming how many have ``what`` and the first of them."""
    if bad.any():
        count = int(bad.sum())
        raise VolumeError(f"{name}: {count} particle{'s' if count > 1 else ''} (the first: particle "
                          f"{int(np.argmax(bad)) + 1}) {'have' if count > 1 else 'has'} {what}")


class CellIndex:
    """Cells listing the particles whose support (a sphere of ``radius``) reaches into them, in levels:
    each particle in the level whose cells are at least half its support's radius and less than its
    radius wide (cubes ``size * 2^level`` from the box's corner), so that it lists in at most 4-5 cells a
    side and a point meets about 3.4-8 times the particles whose support holds it, whatever the spread of
    the smoothing lengths (a single grid fine enough for the small ones lists a large particle in
    thousands of cells).  Only occupied cells are kept (:class:`_SparseCells`), so a particle far away
    (1e17 from the rest) costs its own cells, not a grid across the gap."""

    def __init__(self, centres: np.ndarray, radius: np.ndarray, bounds):
        lo, hi = (np.asarray(b, dtype=np.float64) for b in bounds)
        extent = float(np.max(hi - lo))
        # level 0: cells as wide as the smallest support's radius (cells of half the median radius made the
        # converged reference 4x faster than cells a support across); at most 2^40 a side, so that cell
        # coordinates are exact integers
        size = max(float(radius.min()), extent / 2.0 ** 40, 1e-300)
        level = np.floor(np.log2(np.maximum(radius / size, 1.0))).astype(np.int64)  # radius / 2^level in [1, 2)
        self.levels = []
        for k in np.unique(level):
            owner = np.nonzero(level == k)[0]
            cells = _SparseCells(lo, size * 2.0 ** int(k), centres[owner], radius[owner], owner)
            self.levels.append(cells)
        self.entries = sum(c.entries for c in self.levels)

    def pairs(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(point, particle)``: each point with every particle listed in its cell of each level."""
        found = [c.pairs(points) for c in self.levels]
        return np.concatenate([f[0] for f in found]), np.concatenate([f[1] for f in found])


class _SparseCells:
    """One level of :class:`CellIndex`: cubes of ``size`` from ``lo``, the occupied ones only, as sorted
    integer keys with their members.  A key is the cell's index in the box of occupied cells where that
    box has under 2^62 cells; else (particles far apart) the cells' coordinates ranked axis by axis:
    exact either way, never hashed."""

    def __init__(self, lo: np.ndarray, size: float, centres: np.ndarray, radius: np.ndarray, owner: np.ndarray):
        self.lo, self.size = lo, size
        first = self._cell(centres - radius[:, None])
        span = self._cell(centres + radius[:, None]) - first + 1
        count = span.prod(axis=1)
        self.entries = int(count.sum())
        check_bytes(self.entries * 64.0, "the particles' cell index", "use fewer particles")
        who = np.repeat(np.arange(len(centres)), count)
        k = ranks(count)  # each cell's rank inside its particle's block
        sx, sy = span[who, 0], span[who, 1]
        cell = (first[who, 0] + k % sx, first[who, 1] + (k // sx) % sy, first[who, 2] + k // (sx * sy))
        del k, sx, sy
        self.low = first.min(axis=0)
        self.extent = (first + span).max(axis=0) - self.low
        self.ranked = float(np.prod(self.extent.astype(np.float64))) >= 2.0 ** 62
        if self.ranked:
            self.axes = [np.unique(c) for c in cell]
            self.xy = np.unique(np.searchsorted(self.axes[0], cell[0]) * len(self.axes[1])
                                + np.searchsorted(self.axes[1], cell[1]))
            key, _ = self._keys(np.stack(cell, axis=1))
        else:  # every cell lies in the box of occupied cells
            key = ((cell[2] - self.low[2]) * self.extent[1] + (cell[1] - self.low[1])) * self.extent[0] \
                + (cell[0] - self.low[0])
        del cell
        order = np.argsort(key)  # a cell's members in any order
        self.members = owner[who[order]]
        key = key[order]
        self.start = np.flatnonzero(np.r_[True, key[1:] != key[:-1], True]).astype(np.int64)
        self.keys = key[self.start[:-1]]

    def _cell(self, points: np.ndarray) -> np.ndarray:
        return np.floor((points - self.lo) / self.size).astype(np.int64)

    @staticmethod
    def _find(sorted_values: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each value's place in ``sorted_values`` and whether it is there."""
        at = np.minimum(np.searchsorted(sorted_values, values), len(sorted_values) - 1)
        return at, sorted_values[at] == values

    def _keys(self, cell: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The keys of cells ``(n, 3)`` and whether each can be occupied."""
        if not self.ranked:
            rel = cell - self.low
            valid = ((rel >= 0) & (rel < self.extent)).all(axis=1)
            rel = np.where(valid[:, None], rel, 0)
            return (rel[:, 2] * self.extent[1] + rel[:, 1]) * self.extent[0] + rel[:, 0], valid
        (x, hx), (y, hy), (z, hz) = (self._find(self.axes[a], cell[:, a]) for a in range(3))
        xy, hxy = self._find(self.xy, x * len(self.axes[1]) + y)
        return xy * len(self.axes[2]) + z, hx & hy & hz & hxy

    def pairs(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        u = np.floor((points - self.lo) / self.size)
        inside = (np.abs(u) < 2.0 ** 62).all(axis=1)  # beyond: no cell (and no int64 overflow)
        key, valid = self._keys(np.where(inside[:, None], u, 0.0).astype(np.int64))
        at, hit = self._find(self.keys, key)
        hit &= inside & valid
        count = np.where(hit, self.start[at + 1] - self.start[at], 0)
        point = np.repeat(np.arange(len(points)), count)
        slot = ranges(self.start[at].astype(np.float64), count).astype(np.int64)
        return point, self.members[slot]


class SPHInterpolant:
    """The interpolant of ``values`` (``(N,)`` or ``(N, C)``) at the particles of ``particles``."""

    degree = SPH_DEGREE

    def __init__(self, particles: ParticleSet, values: np.ndarray):
        self.particles = particles
        self.channels = values.shape[1] if values.ndim == 2 else 0
        self.carried = (particles.weights[:, None] * values.reshape(len(particles), -1))  # (m / rho) A

    def _sum(self, points: np.ndarray, gradient: bool = False, label: str | None = None) -> np.ndarray:
        """The sum (or its gradient) at ``points``, in batches; ``label``: long sums report progress
        under it (:mod:`dvr_gl.progress`)."""
        points = np.asarray(points, dtype=np.float64)
        width = 3 if gradient else self.carried.shape[1]
        out = np.zeros((len(points), width))
        with progress.task(label or "", len(points), "point") if label else contextlib.nullcontext() as step:
            if not gradient and self._scatter(points, out):
                if step is not None:
                    step(len(points))
                return out
            compiled = None if gradient else _compiled_pair_sum()
            for i in range(0, len(points), POINTS_PER_BATCH):
                if compiled is not None:
                    self._batch_compiled(points, i, out, compiled)
                else:
                    self._batch(points, i, gradient, out)
                if step is not None:
                    step(min(i + POINTS_PER_BATCH, len(points)))
        return out

    def _scatter(self, points: np.ndarray, out: np.ndarray) -> bool:
        """The sum at ``points`` into ``out`` scattered from the particles through a grid of the points
        (:mod:`.particle_scatter`: compiled, no index of the particles) where there are as many points as
        particles or more (the value range, a reader's density) and the grid suits them; False otherwise."""
        p = self.particles
        if len(points) < len(p) or particle_scatter.compiled() is None or not np.isfinite(points).all():
            return False
        levels = particle_scatter.plan(points, p.positions, sph.SUPPORT * p.smoothing_lengths)
        if levels is None:
            return False
        out[:] = particle_scatter.scatter_sum(levels, points, p.positions, p.smoothing_lengths, self.carried)
        return True

    def _batch(self, points: np.ndarray, i: int, gradient: bool, out: np.ndarray):
        """The batch of ``points`` from ``i`` into ``out``."""
        p, width = self.particles, out.shape[1]
        batch = points[i:i + POINTS_PER_BATCH]
        point, j = p.index.pairs(batch)
        # an axis at a time (gathers of one column are faster than of rows)
        d = [batch[:, a][point] - p.columns[a][j] for a in range(3)]
        r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        h = p.smoothing_lengths[j]
        inside = r2 < (sph.SUPPORT * h) ** 2  # a cell's candidates: about a fifth are within reach
        point, j, r2, h = point[inside], j[inside], r2[inside], h[inside]
        d = np.stack([c[inside] for c in d], axis=1) if gradient else None
        if gradient:  # grad W = w'(q) / (pi h^4) d / r
            r = np.sqrt(r2)
            scale = sph.dw(r / h) / (math.pi * h ** 4) / np.where(r > 0, r, 1.0) * self.carried[j, 0]
            for axis in range(3):
                out[i:i + len(batch), axis] = np.bincount(point, scale * d[:, axis], minlength=len(batch))
        else:
            wk = sph.kernel(r2, h)
            for c in range(width):
                out[i:i + len(batch), c] = np.bincount(point, wk * self.carried[j, c], minlength=len(batch))

    def _batch_compiled(self, points: np.ndarray, i: int, out: np.ndarray, compiled) -> None:
        """:meth:`_batch`'s values with the compiled pair sum ``compiled`` (:func:`_pair_sum`)."""
        p = self.particles
        batch = np.ascontiguousarray(points[i:i + POINTS_PER_BATCH])
        point, j = p.index.pairs(batch)
        compiled(batch, point.astype(np.int64), j.astype(np.int64), *p.columns, p.smoothing_lengths,
                 self.carried, out[i:i + len(batch)])

    def sample(self, points: np.ndarray, progress: str | None = None) -> np.ndarray:
        """The interpolant at ``points``; ``progress``: a label under which a long sum reports its batches."""
        out = self._sum(points, label=progress)
        return out if self.channels else out[:, 0]

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """The interpolant's exact gradient (the kernel's), value units per world unit."""
        return self._sum(points, gradient=True)

    def knots(self, origins, directions, t0, t1):
        """``(ray, t)``: where a ray enters and leaves each particle's support, inside ``(t0, t1)``."""
        p = self.particles
        origins, directions = np.asarray(origins, np.float64), np.asarray(directions, np.float64)
        a = np.einsum("ni,ni->n", directions, directions)
        step = max(1, PAIRS_PER_CHUNK // max(len(origins), 1))
        rays, ts = [], []
        for s in range(0, len(p), step):
            c = p.positions[s:s + step]
            h = p.smoothing_lengths[s:s + step]
            rel = c[None, :, :] - origins[:, None, :]                       # (R, P, 3)
            tc = np.einsum("rpi,ri->rp", rel, directions) / a[:, None]      # nearest approach
            rho2 = np.einsum("rpi,rpi->rp", rel, rel) - tc * tc * a[:, None]
            ray, j = np.nonzero(rho2 < (sph.SUPPORT * h[None, :]) ** 2)
            if not len(ray):
                continue
            near, r2 = tc[ray, j], rho2[ray, j]
            half = np.sqrt(np.maximum((sph.SUPPORT * h[j]) ** 2 - r2, 0.0) / a[ray])
            t = np.concatenate([near - half, near + half])
            owner = np.concatenate([ray, ray])
            keep = (t > t0[owner]) & (t < t1[owner])
            rays.append(owner[keep])
            ts.append(t[keep])
        return joined_knots(rays, ts)


def _pair_sum(points, point, j, x, y, z, h, carried, out):
    """Adds ``W(|points[point] - x_j|, h_j) carried[j]`` into ``out[point]`` for each candidate pair
    (``point[k]``, ``j[k]``), the M4 kernel of :func:`.sph.kernel` (zero at and beyond ``2 h``): the SPH
    sum of :meth:`SPHInterpolant._batch` in one loop (compiled by :func:`_compiled_pair_sum`)."""
    for k in range(len(point)):
        a, b = point[k], j[k]
        dx, dy, dz = points[a, 0] - x[b], points[a, 1] - y[b], points[a, 2] - z[b]
        r2, hb = dx * dx + dy * dy + dz * dz, h[b]
        if r2 >= (sph.SUPPORT * hb) ** 2:
            continue
        q = math.sqrt(r2) / hb
        wq = 1.0 - 1.5 * q * q + 0.75 * q ** 3 if q < 1.0 else 0.25 * (2.0 - q) ** 3
        wk = wq / (math.pi * hb ** 3)
        for c in range(carried.shape[1]):
            out[a, c] += wk * carried[b, c]


@functools.cache
def _compiled_pair_sum():
    """:func:`_pair_sum` compiled with numba, or ``None`` without numba (the numpy path then sums)."""
    try:
        import numba
    except ImportError:
        return None
    return numba.njit(cache=True)(_pair_sum)


def plummer_sphere(count: int, scale: float = 1.0, cut: float = 4.0, seed: int = 0, eta: float = 1.2,
                   total_mass: float = 1.0, name: str = "plummer") -> ParticleSet:
    """A Plummer sphere of ``count`` equal-mass particles (``total_mass`` within the cut, scale radius
    ``scale``), cut at ``cut`` scale radii, drawn with ``seed``: density
    ``rho(r) = 3 M / (4 pi a^3) (1 + r^2 / a^2)^(-5/2)``, radii by inverting the enclosed mass
    ``M(r) = r^3 / (r^2 + a^2)^(3/2)``; each particle's density is the exact one at its radius and its
    smoothing length ``eta (m / rho)^(1/3)`` (about 58 neighbours in its support at ``eta = 1.2``, as SPH
    codes choose)."""
    if count < 1:
        raise SceneError(f"a Plummer sphere needs at least one particle, got {count}")
    rng = np.random.default_rng(seed)
    inside = cut ** 3 / (cut ** 2 + 1.0) ** 1.5  # the mass fraction within the cut
    u = rng.uniform(0.0, inside, count)
    u = np.maximum(u, 1e-300)
    r = scale / np.sqrt(u ** (-2.0 / 3.0) - 1.0)
    direction = rng.normal(size=(count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    positions = direction * r[:, None]
    mass = np.full(count, total_mass / count)
    # the density of the uncut sphere whose cut holds total_mass
    density = 3.0 * total_mass / inside / (4.0 * math.pi * scale ** 3) * (1.0 + (r / scale) ** 2) ** -2.5
    h = eta * (mass / density) ** (1.0 / 3.0)
    return ParticleSet(positions, h, mass, density, name=name, source="generated")

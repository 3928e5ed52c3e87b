"""The same-discretization reference: samples exactly where a renderer places them.

For each pixel's ray (:class:`~dvr_gl.rays.RayBatch`), the samples come from a
plan (:mod:`.plans`): by default the ray caster's, where segment ``k`` of
length ``d`` starts at ``t0 + k d`` (the last one shortened to end at ``t1``)
and is sampled at its midpoint or jittered offset; or the crossings with the
slice planes of a slicing renderer.  Everything is float64 and
vectorized over rays; segments are processed in chunks of several steps at a
time, so rays of thousands of steps stay fast.

Compositing modes:

* ``emission_absorption`` with pre-integrated classification: the scalar at both
  ends of a segment indexes the pre-integration table (colour, optical depth);
  the shortened last segment is corrected for its length; shading and
  gradient opacity apply at the segment's midpoint.
* ``emission_absorption``, front to back: accumulated optical depth ``tau``,
  transmittance ``exp(-tau)``; a segment of extinction ``sigma`` and length
  ``l`` has opacity ``1 - exp(-sigma l)`` and colour ``c`` times that.  Early
  ray termination skips every segment after accumulated opacity reaches
  ``ert_threshold``.  Back to front: the over operator from the last segment
  to the first (no early termination possible).
* ``isosurface``: the first point with value >= iso among ``t0`` and the
  samples; bisection between the bracketing positions, then one linear
  interpolation; colour from the transfer function at iso, shaded, opaque.
* ``xray``: each segment's optical depth ``sigma l`` and emission ``sigma c l`` summed, with no
  attenuation between segments: alpha ``1 - exp(-tau)``, colour alpha times the sum of ``sigma c l``
  over ``tau``.
* ``average`` (length-weighted mean of the samples), ``mip`` and ``minip``
  (maximum and minimum sample): the value is classified once, with the
  opacity of one ``unit_distance``.

Several fields (a :class:`~dvr_gl.fields.layers.FieldSet`): the segments span the union of the fields' boxes;
each sample mixes the fields' own models (:mod:`.fields`: extinctions and emissions add, pre-integrated
segments by the mixture rule); the projections and the isosurface are per field (:func:`.fields.project`,
:func:`.fields.first_hit`).  A single field never takes that path.

Rays that miss the volume are transparent black.  A mesh's scalar is NaN outside its cells
(:mod:`dvr_gl.fields.mesh`): samples there emit and absorb nothing, add nothing to an average
(whose length is still the ray's in the box) and are no extremum; a ray with no sample inside
the mesh is transparent.
"""

from __future__ import annotations

import numpy as np

from ..clipping import ClipRegion
from ..geometry import over_surface, surface_rgba
from ..rays import RayBatch
from ..transfer_function import xray_rgba
from . import fields
from .model import OpticalModel
from .plans import RaySegments, SegmentGrid

SAMPLES_PER_CHUNK = 1 << 21


def _chunks(n_seg: np.ndarray, active: np.ndarray, descending: bool = False):
    """Yield ``(rows, k, m)``: segments ``k .. k + m - 1`` of the active rays that have them,
    about :data:`SAMPLES_PER_CHUNK` samples at a time, in ray order or (``descending``) reversed."""
    kmax = int(n_seg.max()) if len(n_seg) else 0
    if not descending:
        k = 0
        while k < kmax:
            rows = np.nonzero(active & (n_seg > k))[0]
            if rows.size == 0:
                return
            m = max(1, min(SAMPLES_PER_CHUNK // rows.size, kmax - k))
            yield rows, k, m
            k += m
        return
    end = kmax
    while end > 0:
        longest = np.count_nonzero(active & (n_seg >= end))
        m = max(1, min(SAMPLES_PER_CHUNK // max(longest, 1), end))
        rows = np.nonzero(active & (n_seg > end - m))[0]
        if rows.size:
            yield rows, end - m, m
        end -= m


#: The golden section's smaller part: where a refinement step probes when the parabola gives no point inside.
GOLDEN = 0.3819660112501051


def refine_extremum(value_at, t, f, lo, hi, step: float, steps: int) -> np.ndarray:
    """The largest value found by ``steps`` safeguarded parabolic steps around each ray's largest sample
    (``renderer.extremum_refinement``; MinIP passes the negated field), as the ray caster's GLSL does
    (shaders/projection.glsl, ``refine_extremum``).

    ``value_at(t)``: the (signed) field at parameters ``t`` (world units along each ray); ``t``, ``f``: the
    largest sample's parameter and value; ``[lo, hi]``: the ray's kept part.  The bracket is the sample and
    the points one ``step`` before and after it (clamped to the kept part); each step evaluates the field
    at the vertex of the parabola through the bracket's three points, or, where that parabola has no
    maximum strictly inside, at the golden-section point of the longer side, and keeps the best point in
    the middle.  Returns the largest value evaluated (at least ``f``): between the largest sample and the
    trilinear field's maximum near it."""
    a, b = np.maximum(t - step, lo), np.minimum(t + step, hi)
    m, fm = np.asarray(t, dtype=np.float64), np.asarray(f, dtype=np.float64)
    fa, fb = value_at(a), value_at(b)
    for _ in range(steps):
        q, r = (m - a) * (fm - fb), (m - b) * (fm - fa)
        den = 2.0 * (q - r)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = m - ((m - a) * q - (m - b) * r) / den
        golden = np.where(m - a > b - m, m - GOLDEN * (m - a), m + GOLDEN * (b - m))
        u = np.where((den > 0.0) & (u > a) & (u < b) & (u != m), u, golden)
        fu = value_at(u)
        better, left = fu > fm, u < m
        a, fa = np.where(better & ~left, m, np.where(~better & left, u, a)), \
            np.where(better & ~left, fm, np.where(~better & left, fu, fa))
        b, fb = np.where(better & left, m, np.where(~better & ~left, u, b)), \
            np.where(better & left, fm, np.where(~better & ~left, fu, fb))
        m, fm = np.where(better, u, m), np.where(better, fu, fm)
    return np.fmax(fm, np.fmax(fa, fb))  # fmax: a mesh's field is NaN outside its cells


class SecondCandidates:
    """Each ray's extreme sample and its second candidate, the best peak of the samples other than the extreme
    one and not next to it (``renderer.extremum_brackets`` 2: both brackets are refined), tracked sample by
    sample as the ray caster's GLSL does (shaders/projection.glsl, ``track_second``).  Values are ``sign`` times
    the field (MinIP: -1); ``-inf``: none (a missing sample: beside a gap, a ray's end or another brick's
    sample).  A peak is a sample at least as large as the samples beside it (a missing one counts as ``-inf``).
    Over a ray's samples ``s_0, s_1, ...`` (segment indices) the result is: the first sample holding the
    largest value, at ``i`` (a peak), and the first peak holding the largest value of the peaks at least two
    segments from ``i``.  A sample is known to be a peak when the next one comes (or none does: :meth:`finish`);
    of the peaks, the best so far and the best at least two segments from it are kept (peaks next to each
    other are equal, so a new best is never next to the old one, which becomes the second)."""

    def __init__(self, n: int):
        none = np.full(n, -np.inf)
        self.best, self.at, self.k = none.copy(), np.zeros(n), np.zeros(n, np.int64)  # the best peak
        self.second, self.second_at = none.copy(), np.zeros(n)
        self.last_k, self.last, self.last_at = np.full(n, -2, np.int64), none.copy(), np.zeros(n)  # undecided
        self.rises = np.ones(n, bool)  # the undecided sample is at least the one before it

    NAMES = ("best", "at", "k", "second", "second_at", "last_k", "last", "last_at", "rises")

    def take(self, rows, k: int, v: np.ndarray, t: np.ndarray):
        """Samples ``v`` (``(rows, m)``, signed; ``-inf``: none) at parameters ``t`` of segments ``k ..
        k + m - 1`` of rays ``rows``, in order."""
        st = {name: getattr(self, name)[rows] for name in self.NAMES}
        for c in range(v.shape[1]):
            self._step(st, k + c, v[:, c], t[:, c])
        for name in self.NAMES:
            getattr(self, name)[rows] = st[name]

    def finish(self):
        """After the last samples: each ray's undecided sample has no next one."""
        st = {name: getattr(self, name) for name in self.NAMES}
        self._offer(st, (st["last_k"] >= 0) & st["rises"], st["last"], st["last_k"], st["last_at"])
        for name in ("best", "at", "k", "second", "second_at"):
            setattr(self, name, st[name])
        self.last_k[:] = -2

    @staticmethod
    def _offer(st: dict, peak, c, k, t):
        """Peaks ``c`` (where ``peak``) of segments ``k`` at parameters ``t``: the best, or the second."""
        higher = peak & (c > st["best"])
        second = peak & ~higher & (c > st["second"]) & (k - st["k"] >= 2)
        st["second"] = np.select([higher, second], [st["best"], c], st["second"])
        st["second_at"] = np.select([higher, second], [st["at"], t], st["second_at"])
        st["best"], st["at"], st["k"] = (np.where(higher, c, st["best"]), np.where(higher, t, st["at"]),
                                         np.where(higher, k, st["k"]))

    @classmethod
    def _step(cls, st: dict, k: int, s: np.ndarray, t: np.ndarray):
        took = s > -np.inf
        follows = took & (st["last_k"] == k - 1)
        # a sample not followed by this one (a gap) is decided as soon as this one comes, as the GLSL's gap does
        decided = took & (st["last_k"] >= 0) & st["rises"] & (~follows | (st["last"] >= s))
        cls._offer(st, decided, st["last"], st["last_k"], st["last_at"])
        st["rises"] = np.where(took, ~follows | (s >= st["last"]), st["rises"])
        st["last_k"], st["last"], st["last_at"] = (np.where(took, k, st["last_k"]), np.where(took, s, st["last"]),
                                                   np.where(took, t, st["last_at"]))


class DiscreteReference:
    """Render a resolved scene with the same discretization as the GPU renderers."""

    def __init__(self, scene, plan=None, rays: RayBatch | None = None):
        """``plan``: where to sample, a function of the rays (see :mod:`.plans`); default: the ray
        caster's segments.  ``rays``: other rays than the camera's pixels' (shear-warp's
        intermediate image)."""
        self.scene = scene
        r = scene.renderer
        self.rays = rays if rays is not None else RayBatch.for_camera(
            scene.camera, scene.image.width, scene.image.height, scene.field.bounds,
            r.jitter_seed if r.jitter else None, ClipRegion.of(r))
        self.surface = surface_rgba(scene, self.rays)  # opaque meshes end the rays (and show behind)
        self.plan = plan(self.rays) if plan is not None else RaySegments(self.rays, r.sample_distance)
        # several fields: the members' models mixed per sample (.fields); one field: its own model
        model = fields.Mixture if fields.several(scene) else OpticalModel
        self.model = model(scene, exact=False, segment_length=self.plan.slab_length)
        self.n_seg = self.plan.count
        self.samples = 0
        self.progress = None  # progress(done, total) per chunk: segments done of the longest ray's

    def _steps(self, active: np.ndarray, descending: bool = False):
        """:func:`_chunks` of the active rays, reporting each to :attr:`progress`."""
        total = int(self.n_seg.max()) if len(self.n_seg) else 0
        for rows, k, m in _chunks(self.n_seg, active, descending):
            yield rows, k, m
            if self.progress is not None:
                self.progress(total - k if descending else k + m, total)

    @property
    def stats(self) -> dict:
        """``samples``: segments sampled (after early termination) in the last render."""
        return {"samples": self.samples}

    def render(self) -> np.ndarray:
        """Premultiplied linear RGBA ``(H, W, 4)`` float32."""
        return self.render_float64().astype(np.float32)

    def render_float64(self, shape: tuple[int, int] | None = None) -> np.ndarray:
        """The image before rounding to float32 (for closed-form checks); ``shape``: (rows, columns)
        of the rays, if not the scene's image."""
        r = self.scene.renderer
        mode = r.compositing
        if mode == "emission_absorption":
            rgba = self._back_to_front() if r.order == "back_to_front" else self._front_to_back()
        elif mode == "isosurface":
            rgba = fields.first_hit(self) if fields.several(self.scene) else self._isosurface()
        elif mode == "xray":
            rgba = self._xray()
        else:
            rgba = fields.project(self, mode) if fields.several(self.scene) else self._projection(mode)
        rows, cols = shape or (self.scene.image.height, self.scene.image.width)
        return over_surface(rgba, self.surface).reshape(rows, cols, 4)

    def _segments(self, grid: SegmentGrid):
        """Associated colour and optical depth of each segment, ``(rows, m, 3)`` and ``(rows, m)``."""
        length = grid.length[grid.valid]
        if self.model.preintegration is not None:
            premult, tau = self.model.preintegrated(*grid.ends(), grid.points, grid.dirs,
                                                    length / self.plan.slab_length)
            return grid.scatter(premult), grid.scatter(tau)
        colour, sigma = self.model.emission(grid.points, grid.dirs)
        tau = sigma * length
        premult = colour * (-np.expm1(-tau))[:, None]
        return grid.scatter(premult), grid.scatter(tau)

    def _front_to_back(self) -> np.ndarray:
        n = len(self.rays)
        colour = np.zeros((n, 3))
        tau_acc = np.zeros(n)
        active = self.n_seg > 0
        threshold = self.scene.renderer.ert_threshold if self.plan.terminates else 1.0
        for rows, k, m in self._steps(active):
            grid = self.plan.grid(rows, k, m)
            premult, tau = self._segments(grid)
            tau_before = tau_acc[rows, None] + np.cumsum(tau, axis=1) - tau
            include = grid.valid & (-np.expm1(-tau_before) < threshold)
            transmittance = np.exp(-tau_before)
            colour[rows] += np.sum(np.where(include[..., None], transmittance[..., None] * premult, 0.0), axis=1)
            tau_acc[rows] += np.sum(np.where(include, tau, 0.0), axis=1)
            active[rows] &= -np.expm1(-tau_acc[rows]) < threshold
            self.samples += int(include.sum())
        return np.concatenate([colour, -np.expm1(-tau_acc)[:, None]], axis=1)

    def _xray(self) -> np.ndarray:
        """Absorption only: the segments' optical depths and ``sigma c`` lengths summed (no attenuation
        between them); alpha ``1 - exp(-tau)``, colour alpha times the extinction-weighted mean."""
        n = len(self.rays)
        emitted = np.zeros((n, 3))
        tau_acc = np.zeros(n)
        for rows, k, m in self._steps(self.n_seg > 0):
            grid = self.plan.grid(rows, k, m)
            colour, sigma = self.model.emission(grid.points, grid.dirs)
            tau = sigma * grid.length[grid.valid]
            emitted[rows] += np.sum(grid.scatter(colour * tau[:, None]), axis=1)
            tau_acc[rows] += np.sum(grid.scatter(tau), axis=1)
            self.samples += int(grid.valid.sum())
        return xray_rgba(emitted, tau_acc)

    def _back_to_front(self) -> np.ndarray:
        n = len(self.rays)
        rgba = np.zeros((n, 4))
        active = self.n_seg > 0
        for rows, k, m in self._steps(active, descending=True):
            grid = self.plan.grid(rows, k, m)
            premult, tau = self._segments(grid)
            alpha = -np.expm1(-tau)
            acc = rgba[rows]
            for j in range(m - 1, -1, -1):
                seg = np.concatenate([premult[:, j], alpha[:, j, None]], axis=1)
                over = seg + (1.0 - alpha[:, j, None]) * acc
                acc = np.where(grid.valid[:, j, None], over, acc)
            rgba[rows] = acc
            self.samples += int(grid.valid.sum())
        return rgba

    def _isosurface(self) -> np.ndarray:
        rows, t = self.iso_hits()
        points = self.rays.points(rows, t[:, None])
        colour, _ = self.model.classify_value(np.full(len(rows), self.scene.renderer.iso_value))
        if self.model.shading is not None:
            colour = self.model.shade(colour, points, self.rays.directions[rows])
        rgba = np.zeros((len(self.rays), 4))
        rgba[rows, :3] = colour
        rgba[rows, 3] = 1.0
        return rgba

    def iso_hits(self) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, t)``: the rays that meet the isosurface and the ray parameter of each hit (world units)."""
        r = self.scene.renderer
        iso = r.iso_value
        n = len(self.rays)
        scalar = self.model.scalar
        has = self.n_seg > 0
        entry = self.rays.points(np.arange(n), self.rays.t0[:, None])
        prev_s = scalar.sample(entry)
        prev_t = self.rays.t0.copy()
        hit = has & (prev_s >= iso)
        bracket = np.zeros((n, 4))  # t_a, s_a, t_b, s_b with s_a < iso <= s_b
        bracket[hit] = np.stack([prev_t[hit], prev_s[hit], prev_t[hit], prev_s[hit]], axis=1)
        active = has & ~hit
        for rows, k, m in self._steps(active):
            grid = self.plan.grid(rows, k, m)
            s = grid.scatter(scalar.sample(grid.points), fill=-np.inf)
            above = grid.valid & (s >= iso)
            found = above.any(axis=1)
            j = np.argmax(above, axis=1)
            self.samples += int(np.where(found, j + 1, grid.valid.sum(axis=1)).sum())
            fr = rows[found]
            jf = j[found]
            t_b, s_b = grid.t[found, jf], s[found, jf]
            t_a = np.where(jf > 0, grid.t[found, jf - 1], prev_t[fr])
            s_a = np.where(jf > 0, s[found, np.maximum(jf - 1, 0)], prev_s[fr])
            bracket[fr] = np.stack([t_a, s_a, t_b, s_b], axis=1)
            hit[fr] = True
            active[fr] = False
            last = np.maximum(grid.valid.sum(axis=1) - 1, 0)
            prev_t[rows] = grid.t[np.arange(len(rows)), last]
            prev_s[rows] = s[np.arange(len(rows)), last]
        rows = np.nonzero(hit)[0]
        return rows, self._refine(rows, bracket[rows], iso, r.iso_refinement)

    def _refine(self, rows, bracket, iso, steps: int) -> np.ndarray:
        """Bisection on ``[t_a, t_b]`` keeping ``s(t_a) < iso <= s(t_b)``, then linear interpolation."""
        t_a, s_a, t_b, s_b = bracket.T.copy()
        scalar = self.model.scalar
        for _ in range(steps):
            t_m = 0.5 * (t_a + t_b)
            s_m = scalar.sample(self.rays.points(rows, t_m[:, None]))
            up = s_m >= iso
            t_b, s_b = np.where(up, t_m, t_b), np.where(up, s_m, s_b)
            t_a, s_a = np.where(up, t_a, t_m), np.where(up, s_a, s_m)
        span = s_b - s_a
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(span > 0, (iso - s_a) / span, 1.0)
        return t_a + np.clip(w, 0.0, 1.0) * (t_b - t_a)

    def _projection(self, mode: str) -> np.ndarray:
        """Average, MIP or MinIP of each ray's samples, classified once.  The extrema are kept as the
        maximum of ``sign`` times the samples (MinIP: -1), with the parameter of the first sample holding
        it, which ``renderer.extremum_refinement`` refines around (:func:`refine_extremum`); with
        ``renderer.extremum_brackets`` 2 also around the :class:`SecondCandidates`' second, keeping the better."""
        n = len(self.rays)
        sign = -1.0 if mode == "minip" else 1.0
        acc = np.zeros(n) if mode == "average" else np.full(n, -np.inf)
        at = np.zeros(n)  # the parameter of the extreme sample
        length = np.zeros(n)
        active = self.n_seg > 0
        seen = np.zeros(n, bool)
        r = self.scene.renderer
        second = SecondCandidates(n) if (mode != "average" and r.extremum_refinement and hasattr(self.plan, "d")
                                         and getattr(r, "extremum_brackets", None) == 2) else None
        for rows, k, m in self._steps(active):
            grid = self.plan.grid(rows, k, m)
            s = self.model.scalar.sample(grid.points)
            inside = ~np.isnan(s)
            seen[rows] |= grid.scatter(inside, False).any(axis=1)
            if mode == "average":
                s = np.where(inside, s, 0.0)
                acc[rows] += np.sum(grid.scatter(s) * grid.length, axis=1)
                length[rows] += grid.length.sum(axis=1)
            else:
                v = grid.scatter(np.where(inside, sign * s, -np.inf), -np.inf)
                j = np.argmax(v, axis=1)  # the first holding the chunk's extremum
                best = v[np.arange(len(rows)), j]
                raised = best > acc[rows]
                acc[rows[raised]] = best[raised]
                at[rows[raised]] = grid.t[raised, j[raised]]
                if second is not None:
                    second.take(rows, k, v, grid.t)
            self.samples += int(grid.valid.sum())
        if second is not None:
            second.finish()
        has = (self.n_seg > 0) & seen
        if mode != "average" and self.scene.renderer.extremum_refinement and hasattr(self.plan, "d"):
            acc[has] = self._refined_extremum(np.nonzero(has)[0], at[has], acc[has], sign)
            if second is not None:  # the better of the two brackets refined
                two = has & (second.second > -np.inf)
                acc[two] = np.fmax(acc[two], self._refined_extremum(np.nonzero(two)[0], second.second_at[two],
                                                                     second.second[two], sign))
        value = np.where(has, sign * acc, 0.0)
        if mode == "average":
            value = np.where(has, acc / np.where(length > 0, length, 1.0), 0.0)
        colour, alpha = self.model.classify_value(value[has])
        rgba = np.zeros((n, 4))
        rgba[has, :3] = colour * alpha[:, None]
        rgba[has, 3] = alpha
        return rgba

    def _refined_extremum(self, rows, t, value, sign: float) -> np.ndarray:
        """:func:`refine_extremum` of rays ``rows`` around their extreme samples (at ``t``, ``sign`` times
        the field ``value``), within each ray's kept part, one segment each side."""
        def value_at(tq):
            return sign * self.model.scalar.sample(self.rays.points(rows, tq[:, None]))

        return refine_extremum(value_at, t, value, self.rays.t0[rows], self.rays.t1[rows], self.plan.d,
                               self.scene.renderer.extremum_refinement or 0)


def same_discretization(scene) -> np.ndarray:
    """The float64 image ``(H, W, 4)`` of the conventions' segments: the oracle of a renderer that samples
    where the conventions put the samples (a plugin may declare it as it is)."""
    return DiscreteReference(scene).render_float64()

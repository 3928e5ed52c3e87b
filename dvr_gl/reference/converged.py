"""The converged reference: the rendering integral of the continuous model, to a tolerance.

The model is the scene's: its reconstruction filter, classification and
shading, with the transfer function evaluated exactly (no table) and no
sampling grid, jitter or early termination.  Along each ray the field is
smooth between the filter's knots (see :mod:`.reconstruction`), so rays are
cut there first; then

* ``emission_absorption``: each piece is integrated by ``n``-point
  Gauss-Legendre collocation (optical depth at the nodes by the spectral
  integration matrix, so ``tau`` and the emission integral are both
  high-order).  A piece's error is estimated by comparing it with its two
  halves; pieces are bisected until each ray's summed error estimate (colour
  and optical depth, which bound the error of the composited pixel to first
  order) is at most ``tolerance``.
* ``xray``: as emission-absorption, with nothing attenuated: each piece's optical depth and
  emission ``sigma c`` are integrated alike and summed along the ray (alpha ``1 - exp(-tau)``,
  colour alpha times their ratio).
* ``average``: Gauss-Legendre on each piece (exact: the pieces are polynomials; for the Gaussian,
  exact for the polynomial of its ``degree`` that stands for it).
* ``isosurface``, ``mip``, ``minip``: the field along each piece is a
  polynomial of the filter's degree (3 for trilinear, 9 for the cubics, 0 for
  nearest), fitted exactly from that many samples (the Gaussian is not a polynomial: its
  interpolant of degree 9 stands for it, see :mod:`dvr_gl.fields.reconstruction`); its extremum (golden-section
  search) or first crossing of the iso-value (bisection) is found on a grid of
  64 points per piece and then to float64 resolution.  Only features narrower
  than 1/64 of a voxel along a ray could be missed.

Several fields (a :class:`~dvr_gl.fields.layers.FieldSet`): the exact mixture of the fields' own models
(:mod:`.fields`), rays cut at every field's knots and breakpoints inside its box, at its box's faces and where a
label map's label changes; MIP, MinIP, average and isosurface per field, each over its chord of its box.  A
single field never takes that path.

Rays are processed in batches, pieces as flat arrays; per-ray compositing
uses row-wise cumulative sums, so no optical depth is accumulated across rays.
"""

from __future__ import annotations

import numpy as np

from ..clipping import ClipRegion
from ..fields.reconstruction import smooth_pieces
from ..geometry import over_surface, surface_rgba
from ..rays import RayBatch
from ..sandbox import check_bytes
from ..transfer_function import xray_rgba
from . import fields
from .model import OpticalModel

RAYS_PER_BATCH = 2048
MAX_ROUNDS = 60
GRID_PER_PIECE = 64
GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
BYTES_PER_PIECE = 256  # a live piece's estimates (11 float64 columns) and their refined halves


def collocation(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1] and the spectral integration matrix
    ``S[i, j] = integral_{-1}^{x_i} l_j(x) dx`` of the Lagrange basis through the nodes."""
    x, w = np.polynomial.legendre.leggauss(n)
    k = np.arange(n)
    vander = x[:, None] ** k[None, :]
    integral = (x[:, None] ** (k + 1) - (-1.0) ** (k + 1)) / (k + 1)
    return x, w, integral @ np.linalg.inv(vander)


def _pad_rows(ray: np.ndarray, *columns: np.ndarray):
    """Group flat values (sorted by ray) into zero-padded rows ``(rays, width, ...)``."""
    uniq, start, count = np.unique(ray, return_index=True, return_counts=True)
    width = int(count.max()) if len(count) else 0
    pos = np.arange(len(ray)) - np.repeat(start, count)
    slot = np.searchsorted(uniq, ray)
    out = []
    for c in columns:
        grid = np.zeros((len(uniq), width) + c.shape[1:])
        grid[slot, pos] = c
        out.append(grid)
    return uniq, out


class ConvergedReference:
    def __init__(self, scene, nodes: int = 4):
        """``scene``: any field (:mod:`dvr_gl.fields`) with the scene's filter; ``nodes``: Gauss-Legendre
        points per piece."""
        self.scene = scene
        self.several = fields.several(scene)  # several fields: the members' models mixed (.fields)
        self.model = fields.Mixture(scene, exact=True) if self.several else OpticalModel(scene, exact=True)
        self.rays = RayBatch.for_camera(scene.camera, scene.image.width, scene.image.height,
                                        scene.field.bounds, clip=ClipRegion.of(scene.renderer))
        self.surface = surface_rgba(scene, self.rays)  # opaque meshes end the rays (and show behind)
        self.tol = scene.renderer.converged_tolerance
        self.by_cell = hasattr(getattr(self.model, "scalar", None), "pieces")  # a mesh: pieces know their cells
        self.x, self.w, self.S = collocation(nodes)
        self.stats = {"pieces": 0, "evaluations": 0, "converged": True}
        # emission-absorption attenuates within and between pieces; the X-ray only sums
        self.attenuate = scene.renderer.compositing != "xray"
        self.progress = None  # progress(done, total) per batch of rays
        self.hit_t = np.full(len(self.rays), np.inf)  # the isosurface's first hit per ray (inf: none)

    def render(self) -> np.ndarray:
        """Premultiplied linear RGBA ``(H, W, 4)`` float32."""
        return self.render_float64().astype(np.float32)

    def render_float64(self) -> np.ndarray:
        """The image before rounding to float32 (for closed-form checks)."""
        rgba = self.volume_rgba()
        return over_surface(rgba, self.surface).reshape(self.scene.image.height, self.scene.image.width, 4)

    def volume_rgba(self) -> np.ndarray:
        """The volume's premultiplied ``(N, 4)`` per ray, before the surfaces behind it."""
        mode = self.scene.renderer.compositing
        if self.several and mode not in ("emission_absorption", "xray"):
            return fields.per_channel(self)
        hit = np.nonzero(self.rays.t1 > self.rays.t0)[0]
        rgba = np.zeros((len(self.rays), 4))
        method = {"emission_absorption": self._emission_absorption, "xray": self._emission_absorption,
                  "average": self._average,
                  "isosurface": self._first_hit, "mip": lambda rows: self._extremum(rows, 1.0),
                  "minip": lambda rows: self._extremum(rows, -1.0)}[mode]
        for i in range(0, len(hit), RAYS_PER_BATCH):
            rows = hit[i:i + RAYS_PER_BATCH]
            rgba[rows] = method(rows)
            if self.progress is not None:
                self.progress(min(i + RAYS_PER_BATCH, len(hit)), len(hit))
        return rgba

    # --- pieces ------------------------------------------------------------------------------

    def _pieces(self, rows: np.ndarray):
        """Smooth pieces ``(ray, a, b, cell)`` of rays ``rows``, sorted along each ray: a mesh's pieces
        in its cells (``cell``: the cell, the field is linear there); a grid's rays cut at the
        filter's knots (``cell`` 0, unused)."""
        r = self.rays
        if self.several:
            return fields.mixture_pieces(self.model, r, rows)
        if self.by_cell:
            ray, a, b, cell = self.model.scalar.pieces(r.origins[rows], r.directions[rows], r.t0[rows], r.t1[rows])
            return rows[ray], a, b, cell
        local, a, b = smooth_pieces(self.model.scalar, r.origins[rows], r.directions[rows], r.t0[rows], r.t1[rows])
        return rows[local], a, b, np.zeros(len(local), np.int64)

    @staticmethod
    def _split(ray, a, b, cell, piece, t):
        """Pieces cut at ``t`` inside pieces ``piece`` (still sorted along rays; each part keeps its cell)."""
        idx = np.concatenate([np.arange(len(a)), np.arange(len(a)), piece])
        at = np.concatenate([a, b, t])
        order = np.lexsort((at, idx))
        idx, at = idx[order], at[order]
        keep = (idx[1:] == idx[:-1]) & (at[1:] > at[:-1])
        p = idx[:-1][keep]
        return ray[p], at[:-1][keep], at[1:][keep], cell[p]

    def _breakpoint_cuts(self, ray, a, b, cell, model=None):
        """Where the field crosses a transfer-function breakpoint inside a piece, as ``(piece, t)``:
        kinks in colour or extinction there would make quadrature converge erratically (and its
        error estimate unreliable), so pieces are cut at them.  Found on each piece's exact
        polynomial: sign changes on a 64-point grid, then bisection to float64 resolution.  ``model``: the
        single-field model whose field and transfer function are meant (default: the scene's; several fields
        cut at each member's, :func:`.fields.mixture_cuts`)."""
        if self.several and model is None:
            return fields.mixture_cuts(self, ray, a, b, cell)
        model = model or self.model
        breaks = model.breakpoints()
        if not len(breaks) or model.scalar.degree == 0:  # constant pieces cross nothing
            return None
        coeffs = self._fit(ray, a, b, cell, model)
        grid = np.linspace(-1.0, 1.0, GRID_PER_PIECE + 1)
        values = self._horner(coeffs, np.broadcast_to(grid, (len(ray), len(grid))))
        lo, hi = values.min(axis=1), values.max(axis=1)
        cut_ray, cut_t = [], []
        for v in breaks:
            cand = np.nonzero((lo < v) & (hi > v))[0]
            if not len(cand):
                continue
            above = values[cand] >= v
            piece, j = np.nonzero(above[:, 1:] != above[:, :-1])
            piece = cand[piece]
            x_lo, x_hi = grid[j], grid[j + 1]
            up = self._horner(coeffs[piece], x_hi) >= v
            for _ in range(60):
                m = 0.5 * (x_lo + x_hi)
                same = (self._horner(coeffs[piece], m) >= v) == up
                x_lo, x_hi = np.where(same, x_lo, m), np.where(same, m, x_hi)
            cut_ray.append(piece)
            cut_t.append(a[piece] + 0.5 * (b[piece] - a[piece]) * (0.5 * (x_lo + x_hi) + 1.0))
        if not cut_ray:
            return None
        return np.concatenate(cut_ray), np.concatenate(cut_t)

    def _points(self, ray, t, cell):
        """World points, ray directions and cells (None for a grid) at parameters ``t`` ``(N, k)``
        along rays ``ray`` in pieces of cells ``cell``."""
        r = self.rays
        pts = r.origins[ray, None, :] + t[..., None] * r.directions[ray, None, :]
        dirs = np.broadcast_to(r.directions[ray, None, :], pts.shape)
        cells = np.repeat(cell, t.shape[1]) if self.by_cell else None
        return pts.reshape(-1, 3), dirs.reshape(-1, 3), cells

    # --- emission-absorption -------------------------------------------------------------------

    def _gauss(self, ray, a, b, cell):
        """Optical depth and emitted colour (attenuated within the piece) of pieces ``[a, b]``."""
        half = 0.5 * (b - a)
        t = a[:, None] + half[:, None] * (self.x[None, :] + 1.0)
        n = len(self.x)
        if not self.attenuate:  # the X-ray: the emission sigma c (shaded, depth-cued) and sigma, summed
            emitted, sigma = self.model.xray_emission(*self._points(ray, t, cell))
            sigma = sigma.reshape(-1, n)
            self.stats["evaluations"] += sigma.size
            weight = half[:, None] * self.w[None, :]
            return half * (sigma @ self.w), np.einsum("pn,pnc->pc", weight, emitted.reshape(-1, n, 3))
        colour, sigma = self.model.emission(*self._points(ray, t, cell))
        sigma = sigma.reshape(-1, n)
        colour = colour.reshape(-1, n, 3)
        self.stats["evaluations"] += sigma.size
        tau_nodes = half[:, None] * (sigma @ self.S.T)
        tau = half * (sigma @ self.w)
        weight = half[:, None] * self.w[None, :] * sigma * np.exp(-tau_nodes)
        return tau, np.einsum("pn,pnc->pc", weight, colour)

    def _estimate(self, ray, a, b, cell, coarse_tau, coarse_col):
        """Pieces with the estimates of their halves (``lt, lc, rt, rc``), the refined estimate
        (halves composited: ``tau``, ``col``) and its error against the coarse one (``err``)."""
        m = 0.5 * (a + b)
        lt, lc = self._gauss(ray, a, m, cell)
        rt, rc = self._gauss(ray, m, b, cell)
        tau = lt + rt
        col = lc + (np.exp(-lt)[:, None] if self.attenuate else 1.0) * rc
        err = np.maximum(np.abs(col - coarse_col).max(axis=1), np.abs(tau - coarse_tau))
        return {"ray": ray, "a": a, "b": b, "cell": cell, "lt": lt, "lc": lc, "rt": rt, "rc": rc,
                "tau": tau, "col": col, "err": err}

    def _emission_absorption(self, rows):
        """Adaptive integration with one error budget per ray: while a ray's summed error
        estimate exceeds the tolerance, bisect its pieces whose error exceeds their equal
        share of it.  (A piece holding a jump, say where a normal flips, then converges
        like its width instead of never meeting a width-proportional tolerance.)"""
        take = lambda p, idx: {k: v[idx] for k, v in p.items()}  # noqa: E731
        ray, a, b, cell = self._pieces(rows)
        cuts = self._breakpoint_cuts(ray, a, b, cell)
        if cuts is not None:
            ray, a, b, cell = self._split(ray, a, b, cell, *cuts)
        live = self._estimate(ray, a, b, cell, *self._gauss(ray, a, b, cell))
        done = []
        for step in range(MAX_ROUNDS + 1):
            slot = np.searchsorted(rows, live["ray"])
            total = np.bincount(slot, live["err"], minlength=len(rows))
            count = np.bincount(slot, minlength=len(rows))
            finished = total[slot] <= self.tol
            if step == MAX_ROUNDS:
                self.stats["converged"] &= bool(finished.all())
                finished[:] = True
            split = ~finished & (live["err"] > self.tol / np.maximum(count[slot], 1))
            done.append(take(live, finished))
            if finished.all():
                break
            p = take(live, split)
            # refinement doubles what it splits: stop before memory runs out, not after
            check_bytes((len(live["ray"]) + len(p["ray"])) * BYTES_PER_PIECE * 2.0, "the converged reference's "
                        "pieces", "raise renderer.converged_tolerance or lower --size")
            m = 0.5 * (p["a"] + p["b"])
            parts = [take(live, ~finished & ~split), self._estimate(p["ray"], p["a"], m, p["cell"], p["lt"], p["lc"]),
                     self._estimate(p["ray"], m, p["b"], p["cell"], p["rt"], p["rc"])]
            live = {k: np.concatenate([q[k] for q in parts]) for k in live}
        ray, a, tau, col = (np.concatenate([d[k] for d in done]) for k in ("ray", "a", "tau", "col"))
        self.stats["pieces"] += len(ray)
        order = np.lexsort((a, ray))
        uniq, (tau_g, col_g) = _pad_rows(ray[order], tau[order], col[order])
        out = np.zeros((len(rows), 4))
        slot = np.searchsorted(rows, uniq)
        if not self.attenuate:  # the X-ray: sums
            out[slot] = xray_rgba(col_g.sum(axis=1), tau_g.sum(axis=1))
            return out
        tau_before = np.cumsum(tau_g, axis=1) - tau_g
        colour = np.sum(np.exp(-tau_before)[..., None] * col_g, axis=1)
        out[slot, :3] = colour
        out[slot, 3] = -np.expm1(-tau_g.sum(axis=1))
        return out

    # --- average -------------------------------------------------------------------------------

    def _average(self, rows):
        ray, a, b, cell = self._pieces(rows)
        # exact for the degree <= 9 pieces of every filter, and 10 with the depth cue's linear weight
        x, w = np.polynomial.legendre.leggauss(6)
        half = 0.5 * (b - a)
        t = a[:, None] + half[:, None] * (x[None, :] + 1.0)
        pts, _, cells = self._points(ray, t, cell)
        s = self.model.projected_values(pts, cells).reshape(-1, len(x))
        integral = np.bincount(np.searchsorted(rows, ray), half * (s @ w), minlength=len(rows))
        length = self.rays.t1[rows] - self.rays.t0[rows]
        return self._classified(integral / length, self._has_pieces(rows, ray))

    @staticmethod
    def _has_pieces(rows, ray):
        """Which of ``rows`` have a piece (all rays into a grid's box; a mesh's box holds gaps)."""
        has = np.zeros(len(rows), bool)
        has[np.searchsorted(rows, ray)] = True
        return has

    def _classified(self, values, has):
        """Projected values classified once; transparent where a ray met no data (``has`` False)."""
        out = np.zeros((len(values), 4))
        colour, alpha = self.model.classify_value(values[has])
        out[has] = np.concatenate([colour * alpha[:, None], alpha[:, None]], axis=1)
        return out

    # --- exact extrema and first hits on the pieces' polynomials ------------------------------

    def _fit(self, ray, a, b, cell, model=None):
        """Monomial coefficients ``(N, D + 1)`` of the field along pieces ``[a, b]``, in the variable
        ``x`` in [-1, 1] across each (the field is a polynomial of degree D between knots, so D + 1
        samples determine it exactly).  ``model``: as :meth:`_breakpoint_cuts`'s."""
        model = model or self.model
        degree = model.scalar.degree
        nodes = np.cos(np.pi * (np.arange(degree + 1) + 0.5) / (degree + 1))  # Chebyshev points
        half = 0.5 * (b - a)
        t = a[:, None] + half[:, None] * (nodes[None, :] + 1.0)
        pts, _, cells = self._points(ray, t, cell)
        values = model.values(pts, cells).reshape(len(ray), degree + 1)
        self.stats["evaluations"] += values.size
        return values @ np.linalg.inv(nodes[:, None] ** np.arange(degree + 1)[None, :]).T

    def _polynomials(self, rows):
        """Pieces ``(ray, a, b, cell)`` and their polynomials (see :meth:`_fit`)."""
        ray, a, b, cell = self._pieces(rows)
        return ray, a, b, cell, self._fit(ray, a, b, cell)

    @staticmethod
    def _horner(coeffs, x):
        out = np.zeros_like(x)
        for k in range(coeffs.shape[1] - 1, -1, -1):
            out = out * x + (coeffs[:, k, None] if x.ndim == 2 else coeffs[:, k])
        return out

    def _extremum(self, rows, sign):
        """Maximum of ``sign * field`` along each ray: a dense grid on each piece's polynomial,
        then golden-section search around the best grid point (both on the polynomial)."""
        ray, a, b, _, coeffs = self._polynomials(rows)
        grid = np.linspace(-1.0, 1.0, GRID_PER_PIECE + 1)
        values = sign * self._horner(coeffs, np.broadcast_to(grid, (len(ray), len(grid))))
        j = np.argmax(values, axis=1)
        lo = grid[np.maximum(j - 1, 0)]
        hi = grid[np.minimum(j + 1, GRID_PER_PIECE)]
        best = values[np.arange(len(ray)), j]

        def f(x):
            return sign * self._horner(coeffs, x)

        c, d = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
        fc, fd = f(c), f(d)
        for _ in range(60):  # the bracket shrinks by 0.618 per step: to float64 resolution
            left = fc > fd  # the maximum lies in [lo, d]
            hi, lo = np.where(left, d, hi), np.where(left, lo, c)
            x = np.where(left, hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo))
            fx = f(x)
            c, d, fc, fd = (np.where(left, x, d), np.where(left, c, x),
                            np.where(left, fx, fd), np.where(left, fc, fx))
            best = np.maximum(best, fx)
        per_ray = np.full(len(rows), -np.inf)
        np.maximum.at(per_ray, np.searchsorted(rows, ray), best)
        return self._classified(sign * per_ray, self._has_pieces(rows, ray))

    def _first_hit(self, rows):
        """The first point with value >= iso: the first piece whose polynomial reaches iso on a
        dense grid, then bisection on that polynomial."""
        iso = self.scene.renderer.iso_value
        ray, a, b, cell, coeffs = self._polynomials(rows)
        grid = np.linspace(-1.0, 1.0, GRID_PER_PIECE + 1)
        above = self._horner(coeffs, np.broadcast_to(grid, (len(ray), len(grid)))) >= iso
        has = above.any(axis=1)
        slot = np.searchsorted(rows, ray)
        first_piece = np.full(len(rows), len(ray))
        np.minimum.at(first_piece, slot[has], np.nonzero(has)[0])  # pieces are sorted along rays
        hit = first_piece < len(ray)
        p = first_piece[hit]
        j = np.argmax(above[p], axis=1)
        x_hi = grid[j]
        x_lo = np.where(j > 0, grid[np.maximum(j - 1, 0)], x_hi)
        cp = coeffs[p]
        for _ in range(64):
            m = 0.5 * (x_lo + x_hi)
            up = self._horner(cp, m) >= iso
            x_lo, x_hi = np.where(up, x_lo, m), np.where(up, m, x_hi)
        x = 0.5 * (x_lo + x_hi)
        t = a[p] + 0.5 * (b[p] - a[p]) * (x + 1.0)
        self.hit_t[rows[hit]] = t
        out = np.zeros((len(rows), 4))
        colour, _ = self.model.classify_value(np.full(len(p), iso))
        if self.model.shading is not None:
            pts, dirs, cells = self._points(rows[hit], t[:, None], cell[p])
            colour = self.model.shade(colour, pts, dirs, cells)
        out[hit, :3] = colour
        out[hit, 3] = 1.0
        return out

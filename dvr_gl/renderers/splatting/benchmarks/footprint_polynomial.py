"""A study: the SPH cubic spline's footprint without a table, as three polynomials (issue 44; not used by the
renderer, see the measurements below).

    python dvr_gl/renderers/splatting/benchmarks/footprint_polynomial.py [--degree 14]

``f(q) = h^2 F`` (the kernel's integral along a line at ``q = rho^2 / R^2`` from its centre, support ``R =
2h``; :func:`dvr_gl.fields.sph.footprint` in float64, the judge) has no short closed form, and its closed
form with logarithms has three places where one polynomial cannot follow it:

* at the centre, ``q^2 log q``: along a chord through the inner sphere the cubic's ``r^3`` integrates to
  ``3/8 b^4 log(1 / b)`` plus smooth terms (``b = rho / h``), so ``f = P_core(q) + KAPPA q^2 log q`` with
  ``KAPPA = -9 / (2 pi)`` and ``P_core`` smooth on ``q < 1/16``;
* at ``q = 1/4`` (``rho = h``: the chord stops crossing the inner sphere) the third derivative's jump leaves
  ``(1/4 - q)^(7/2)`` on the inner side: the middle piece ``P_middle(q)`` on ``[1/16, 1/4)`` ends there;
* at the rim the chord closes as ``(2 - r)^3`` along it: ``f = (1 - q)^(7/2) P_outer(q)`` on ``[1/4, 1]``.

Each ``P`` interpolates its smooth part at the Chebyshev points of its piece, in ``x`` in [-1, 1] across the
piece, in powers of ``x`` (the sums of the coefficients' magnitudes under 1: Horner's rule loses nothing).
Measured at 400001 values of ``q`` (degree 14 each): at most 1.24e-9 of ``f(0) = 3 / (2 pi)`` (the middle
piece's, next to ``q = 1/4``; the core's 1.2e-14, the outer's 7e-10), against 7e-8 for GL's table of 16384
entries read linearly; degree 12: 8.1e-9.

Why the host's deposit loops keep the table (2026-11-28, AVX2, one thread's CPU time on the 10^6-particle
column of ``dvr bench splatting --peers``, a machine shared with other work): the loop with only ``q``
(no footprint) 0.46 s, the table 1.1-1.3 s, one degree-14 polynomial over each whole row (vectorised, fused
multiply-adds) 0.8 s, the outer piece's with its square root 0.9-1.2 s; but the three pieces need either
each row split in runs (five per row, mostly too short for the vector loop: 1.7-2.1 s) or two polynomials
per pixel and a select (1.6 s).  (docs/particles.md, the column density against sarracen.)
"""

from __future__ import annotations

import argparse
import math

import numpy as np

#: The pieces' ends in ``q``: the core below ``CORE_END``, the middle below ``MIDDLE_END`` (``rho = h``).
CORE_END, MIDDLE_END = 1.0 / 16.0, 0.25
#: The coefficient of ``q^2 log q`` in ``f`` at the centre.
KAPPA = -9.0 / (2.0 * math.pi)


def footprint(q) -> np.ndarray:
    """The judge: ``f(q)`` from the float64 integral."""
    from dvr_gl.fields import sph

    return sph.footprint(sph.SUPPORT * np.sqrt(np.asarray(q, dtype=np.float64)))


def _across(q, lo: float, hi: float):
    """``x`` in [-1, 1] across the piece ``[lo, hi]``."""
    return (q - lo) * (2.0 / (hi - lo)) - 1.0


def horner(coefficients, x):
    """The polynomial with ``coefficients`` (highest power first) at ``x``."""
    y = 0.0 * x
    for a in coefficients:
        y = y * x + a
    return y


def fit(degree: int = 14) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The three polynomials (core, middle, outer; highest power first), fitted from the float64 integral."""
    cheb = np.polynomial.chebyshev
    nodes = np.cos(np.pi * (np.arange(degree + 1) + 0.5) / (degree + 1))
    smooth = (
        (0.0, CORE_END, lambda q: footprint(q) - KAPPA * q * q * np.log(q)),
        (CORE_END, MIDDLE_END, footprint),
        (MIDDLE_END, 1.0, lambda q: footprint(q) / (1.0 - q) ** 3.5),
    )
    out = []
    for lo, hi, part in smooth:
        q = lo + 0.5 * (nodes + 1.0) * (hi - lo)  # the nodes exclude the ends: no 0 log 0 or 0 / 0
        out.append(cheb.cheb2poly(cheb.chebfit(nodes, part(q), degree))[::-1])
    return tuple(out)


def evaluate(q, pieces) -> np.ndarray:
    """``f(q)`` from the three polynomials ``pieces`` (:func:`fit`), float64; 0 at ``q >= 1``."""
    core, middle, outer = pieces
    q = np.minimum(np.asarray(q, dtype=np.float64), 1.0)  # f(1) = 0 beyond the rim
    rest = 1.0 - q
    inner = horner(core, _across(q, 0.0, CORE_END)) + KAPPA * q * q * np.log(np.maximum(q, 1e-300))
    between = horner(middle, _across(q, CORE_END, MIDDLE_END))
    rim = horner(outer, _across(q, MIDDLE_END, 1.0)) * (rest * rest * rest * np.sqrt(rest))
    return np.where(q < CORE_END, inner, np.where(q < MIDDLE_END, between, rim))


def errors(pieces, samples: int = 400001) -> dict[str, float]:
    """The largest error of :func:`evaluate` over ``f(0)``, per piece."""
    q = np.linspace(0.0, 1.0, samples)
    e = np.abs(evaluate(q, pieces) - footprint(q)) / footprint(0.0)
    return {"core": float(e[q < CORE_END].max()), "middle": float(e[(q >= CORE_END) & (q < MIDDLE_END)].max()),
            "outer": float(e[q >= MIDDLE_END].max())}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--degree", type=int, default=14)
    pieces = fit(parser.parse_args().degree)
    for name, e in errors(pieces).items():
        print(f"{name}: {e:.2e} of f(0)")

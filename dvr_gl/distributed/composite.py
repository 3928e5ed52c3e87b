"""Compositing partial images (the compositing states of a renderer that composites sort-last) in numpy.

A state is what a sort-last renderer's ``render_state`` returns for a subset of the bricks
(``RendererPlugin.sort_last``; the ray caster's is its fragment loop's BRICKED output): a
``(height, width, 4)`` float32 array per pixel.  Two states of
bricks that follow each other along every ray (``front``, then ``back``) combine into the state
of both, per compositing mode:

* emission-absorption, front to back: (colour reaching the eye, optical depth tau); the over
  operator in optical-depth form: ``C = C_front + exp(-tau_front) C_back``, ``tau = tau_front +
  tau_back`` (exactly what the renderer's next pass would do, starting from the front's state);
* back-to-front emission and the isosurface: a premultiplied RGBA image, the over operator
  ``C = C_front + (1 - alpha_front) C_back`` for all four channels;
* MIP and MinIP: the running maximum (minimum) in x, and in z the extremum refined between the
  samples (``renderer.extremum_refinement``) around it: the whole state of the one whose x wins, the
  front's on a tie (the first sample holding the extremum is the one refined around); with two brackets
  refined (``renderer.extremum_brackets`` 2, operators ``max2`` and ``min2``: y the second candidate, z the
  best of every pass's refinements, w the extreme sample's segment), z is the better of the two states' (each
  refinement is a value of the field on the ray: the composite is never worse than either), y the best of
  the seconds and the losing extremum;
* average (x: sum of value x length, y: length) and xray (rgb: sum of sigma c l, a: sum of sigma l):
  sums.

Each operator is associative, so states may be combined in any grouping that keeps the visibility
order (direct send's sequence, binary swap's tree).  The arithmetic runs in float64 and the result
is float32, as the GPU's state texture is.
"""

from __future__ import annotations

import numpy as np

EMPTY = {"mip": -3.0e38, "minip": 3.0e38}  # the x channel of a ray before any sample, as the GPU's state starts


def operator_of(compositing: str, order: str = "front_to_back", brackets: int = 1) -> str:
    """The operator that combines two states of this compositing mode and order (MIP and MinIP: with
    ``brackets`` refined, ``renderer.extremum_brackets``)."""
    if compositing == "emission_absorption":
        return "over_rgba" if order == "back_to_front" else "over_depth"
    extremum = {"mip": "max", "minip": "min"}.get(compositing)
    if extremum is not None:
        return extremum + ("2" if brackets == 2 else "")
    return {"isosurface": "over_rgba", "average": "sum", "xray": "sum"}[compositing]


def empty_state(operator: str, height: int, width: int) -> np.ndarray:
    """The state of rays that met no brick (the identity of ``operator``)."""
    state = np.zeros((height, width, 4), np.float32)
    empty = {"max": EMPTY["mip"], "min": EMPTY["minip"]}.get(operator.rstrip("2"), 0.0)
    state[..., :3 if operator in ("max2", "min2") else 1] = empty  # two brackets: no second, nothing refined
    return state


def combine(operator: str, front: np.ndarray, back: np.ndarray) -> np.ndarray:
    """The state of ``front``'s bricks followed by ``back``'s (same shape), float32."""
    f, b = np.asarray(front, np.float64), np.asarray(back, np.float64)
    if operator == "over_depth":
        out = np.empty_like(f)
        out[..., :3] = f[..., :3] + np.exp(-f[..., 3:4]) * b[..., :3]
        out[..., 3] = f[..., 3] + b[..., 3]
    elif operator == "over_rgba":
        out = f + (1.0 - f[..., 3:4]) * b
    elif operator in ("max", "min"):
        sign = 1.0 if operator == "max" else -1.0
        out = np.where((sign * b[..., 0] > sign * f[..., 0])[..., None], b, f)
    elif operator in ("max2", "min2"):
        sign = 1.0 if operator == "max2" else -1.0
        back_wins = (sign * b[..., 0] > sign * f[..., 0])[..., None]
        out = np.where(back_wins, b, f)
        losing = sign * np.where(back_wins[..., 0], f[..., 0], b[..., 0])
        out[..., 1] = sign * np.maximum(np.maximum(sign * f[..., 1], sign * b[..., 1]), losing)
        out[..., 2] = sign * np.maximum(sign * f[..., 2], sign * b[..., 2])
    elif operator == "sum":
        out = f + b
    else:
        raise ValueError(f"unknown compositing operator {operator!r}")
    return out.astype(np.float32)


def combine_all(operator: str, states: list) -> np.ndarray:
    """States in visibility order (front first) combined into one."""
    out = states[0]
    for state in states[1:]:
        out = combine(operator, out, state)
    return np.asarray(out, np.float32)

"""Sampling a label map without inventing a label: the float64 rule the references call
(``dvr_gl/gl/shaders/common/labels.glsl`` is the same rule on the GPU).

Voxel coordinate ``u = (p - origin) / spacing`` (sample ``i`` at ``u = i``), taps clamped to the edge as the
``linear`` filter's (:mod:`dvr_gl.fields.reconstruction`):

* ``linear`` (every filter but ``nearest``): the trilinear weights ``w_j`` of the 8 surrounding voxels give
  each label ``L`` its indicator ``I_L(p) = sum of w_j over the taps labelled L``; the sample's label is
  ``argmax_L I_L(p)``, ties to the smaller label.  Only a tap's label can win, so 3 beside 5 never reads 4,
  and the boundary between two labels is the 0.5 level of their indicator: smooth, where the nearest voxel's
  is a staircase.
* ``nearest``: the label of the voxel at ``floor(u + 0.5)``.

The indicator's gradient (the trilinear indicator of the chosen label, differentiated analytically; zero
along an axis where ``u`` is outside ``[0, n - 1]``, where the clamp holds it constant) points into the
label: shading's normal is minus it.
"""

from __future__ import annotations

import numpy as np

#: Points sampled at a time: the working arrays stay a few MiB whatever the number of points.
CHUNK = 1 << 16


def _axis(u: np.ndarray, n: int, spacing: float):
    """Tap indices ``(2, N)``, weights ``(2, N)`` and their derivatives per world unit ``(2, N)`` along one axis."""
    uc = np.clip(u, 0.0, n - 1)
    i0 = np.clip(np.floor(uc), 0, max(n - 2, 0)).astype(np.int64)
    f = uc - i0
    inside = ((u >= 0.0) & (u <= n - 1)).astype(np.float64) / spacing
    return np.stack([i0, np.minimum(i0 + 1, n - 1)]), np.stack([1.0 - f, f]), np.stack([-inside, inside])


def _taps(volume, points: np.ndarray):
    """The 8 taps' labels ``(8, N)`` and weights ``(8, N)``, in the order x fastest, and the axes' tap
    weights and derivatives (for :func:`_gradient`)."""
    u = volume.world_to_index(points)
    axes = [_axis(u[:, a], volume.dims[a], volume.spacing[a]) for a in range(3)]
    (ix, wx, _), (iy, wy, _), (iz, wz, _) = axes
    labels = np.empty((8, len(points)), np.int64)
    weights = np.empty((8, len(points)))
    for j, (a, b, c) in enumerate(_CORNERS):
        labels[j] = volume.data[iz[c], iy[b], ix[a]]
        weights[j] = wx[a] * wy[b] * wz[c]
    return labels, weights, axes


_CORNERS = [(a, b, c) for c in range(2) for b in range(2) for a in range(2)]


def _gradient(axes, labels: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """The gradient ``(N, 3)`` per world unit of the trilinear indicator of ``chosen`` (a label per point)."""
    (_, wx, dx), (_, wy, dy), (_, wz, dz) = axes
    out = np.zeros((labels.shape[1], 3))
    for j, (a, b, c) in enumerate(_CORNERS):
        mine = labels[j] == chosen
        out[:, 0] += np.where(mine, dx[a] * wy[b] * wz[c], 0.0)
        out[:, 1] += np.where(mine, wx[a] * dy[b] * wz[c], 0.0)
        out[:, 2] += np.where(mine, wx[a] * wy[b] * dz[c], 0.0)
    return out


def _nearest(volume, points: np.ndarray) -> np.ndarray:
    u = volume.world_to_index(points)
    i = [np.clip(np.floor(u[:, a] + 0.5), 0, volume.dims[a] - 1).astype(np.int64) for a in range(3)]
    return volume.data[i[2], i[1], i[0]].astype(np.int64)


def _argmax_indicator(labels: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``argmax_L I_L`` over the taps' labels, ties to the smaller label; each ``I_L`` summed over the taps
    in their order (as the GLSL does).  Where the 8 taps agree (inside a region: most samples) that label."""
    chosen = labels[0].copy()
    mixed = np.nonzero(np.any(labels != labels[0], axis=0))[0]
    if mixed.size:
        chosen[mixed] = _argmax_mixed(labels[:, mixed], weights[:, mixed])
    return chosen


def _argmax_mixed(labels: np.ndarray, weights: np.ndarray) -> np.ndarray:
    best_label = labels[0]
    best = np.full(labels.shape[1], -1.0)
    for j in range(8):
        indicator = np.zeros(labels.shape[1])
        for k in range(8):
            indicator += np.where(labels[k] == labels[j], weights[k], 0.0)
        better = (indicator > best) | ((indicator == best) & (labels[j] < best_label))
        best = np.where(better, indicator, best)
        best_label = np.where(better, labels[j], best_label)
    return best_label


def label_sample(volume, points, filter: str = "linear") -> tuple[np.ndarray, np.ndarray]:
    """The label at world points ``(N, 3)`` (the volume's own frame) and the gradient of its trilinear
    indicator ``(N, 3)`` per world unit (see the module doc): ``(labels (N,) int64, gradient (N, 3) float64)``.
    ``filter``: ``nearest``, or any other (the indicator rule)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out_labels = np.empty(len(points), np.int64)
    out_grad = np.empty((len(points), 3))
    for start in range(0, len(points), CHUNK):
        chunk = points[start:start + CHUNK]
        labels, weights, axes = _taps(volume, chunk)
        chosen = _nearest(volume, chunk) if filter == "nearest" else _argmax_indicator(labels, weights)
        out_labels[start:start + len(chunk)] = chosen
        # where the 8 taps agree the indicator is 1 around the point: no gradient (most samples)
        mixed = np.nonzero(np.any(labels != labels[0], axis=0))[0]
        grad = np.zeros((len(chunk), 3))
        grad[mixed] = _gradient([(i[:, mixed], w[:, mixed], d[:, mixed]) for i, w, d in axes], labels[:, mixed],
                                chosen[mixed])
        out_grad[start:start + len(chunk)] = grad
    return out_labels, out_grad


def indicator(volume, points, label: int) -> np.ndarray:
    """The trilinear indicator ``I_label`` at world points ``(N,)``: the share of the 8 taps' weight that
    holds ``label`` (the boundary's 0.5 level; for tests and docs)."""
    labels, weights, _ = _taps(volume, np.asarray(points, dtype=np.float64).reshape(-1, 3))
    return np.where(labels == label, weights, 0.0).sum(axis=0)

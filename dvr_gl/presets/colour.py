"""Colour encodings and the colour spaces VTK interpolates colour maps in.

Colour maps are published sRGB-encoded; the renderer's colours are linear (conventions).  VTK's
colour transfer functions interpolate the sRGB numbers in RGB, CIE Lab (D65 white, as vtkMath), HSV
(hue the short way round) or Moreland's diverging space ("Diverging Color Maps for Scientific
Visualization", 2009: Lab in polar form, through white between two saturated hues far apart).
"""

from __future__ import annotations

import numpy as np

SPACES = ("rgb", "lab", "hsv", "diverging")

_WHITE = np.array([0.9505, 1.0, 1.089])  # D65, the reference white vtkMath's Lab uses
_RGB_TO_XYZ = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
_XYZ_TO_RGB = np.linalg.inv(_RGB_TO_XYZ)


def srgb_to_linear(c):
    """sRGB-encoded colour (colour maps are published that way) to linear."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c):
    """Linear colour in [0, 1] (clipped) to sRGB-encoded, as displays show it."""
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def srgb_to_lab(c) -> np.ndarray:
    """sRGB-encoded ``(..., 3)`` to CIE L*a*b* (L in 0..100)."""
    xyz = srgb_to_linear(c) @ _RGB_TO_XYZ.T / _WHITE
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16 / 116)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], axis=-1)


def lab_to_srgb(lab) -> np.ndarray:
    """CIE L*a*b* ``(..., 3)`` to sRGB-encoded, clipped to [0, 1]."""
    lab = np.asarray(lab, dtype=np.float64)
    fy = (lab[..., 0] + 16) / 116
    f = np.stack([fy + lab[..., 1] / 500, fy, fy - lab[..., 2] / 200], axis=-1)
    xyz = np.where(f ** 3 > 0.008856, f ** 3, (f - 16 / 116) / 7.787) * _WHITE
    return linear_to_srgb(xyz @ _XYZ_TO_RGB.T)


def _rgb_to_hsv(c: np.ndarray) -> np.ndarray:
    mx, mn = c.max(axis=-1), c.min(axis=-1)
    d = mx - mn
    with np.errstate(invalid="ignore", divide="ignore"):
        h = np.select([d == 0, mx == c[..., 0], mx == c[..., 1]],
                      [0.0, ((c[..., 1] - c[..., 2]) / d) % 6, (c[..., 2] - c[..., 0]) / d + 2],
                      (c[..., 0] - c[..., 1]) / d + 4) / 6
        s = np.where(mx > 0, d / mx, 0.0)
    return np.stack([h, s, mx], axis=-1)


def _hsv_to_rgb(hsv: np.ndarray) -> np.ndarray:
    h, s, v = (hsv[..., i] for i in range(3))
    k = (np.array([5.0, 3.0, 1.0]) + (h[..., None] % 1.0) * 6) % 6
    return v[..., None] - v[..., None] * s[..., None] * np.clip(np.minimum(k, 4 - k), 0, 1)


def _msh(c: np.ndarray) -> np.ndarray:
    lab = srgb_to_lab(c)
    m = np.linalg.norm(lab, axis=-1)
    s = np.arccos(np.clip(lab[..., 0] / np.where(m > 0, m, 1.0), -1, 1))
    return np.stack([m, s, np.arctan2(lab[..., 2], lab[..., 1])], axis=-1)


def _msh_to_srgb(msh: np.ndarray) -> np.ndarray:
    m, s, h = (msh[..., i] for i in range(3))
    return lab_to_srgb(np.stack([m * np.cos(s), m * np.sin(s) * np.cos(h), m * np.sin(s) * np.sin(h)], axis=-1))


def _adjust_hue(m_sat, s_sat, h_sat, m_unsat):
    """Moreland's hue for an unsaturated end, turned from the saturated one's (arrays, element by element)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        spin = s_sat * np.sqrt(np.maximum(m_unsat ** 2 - m_sat ** 2, 0.0)) / (m_sat * np.sin(s_sat))
    return np.where(m_sat >= m_unsat, h_sat, np.where(h_sat > -np.pi / 3, h_sat + spin, h_sat - spin))


def _diverging(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Moreland's diverging interpolation from Msh colours ``a`` to ``b`` (``(P, 3)``, each point its own
    segment's ends) at fractions ``t`` ``(P,)``: sRGB ``(P, 3)``.  Two saturated ends of hues far apart
    pass through white (an Msh of their largest M, at least 88) half way."""
    far = (a[:, 1] > 0.05) & (b[:, 1] > 0.05) & (np.abs(np.angle(np.exp(1j * (a[:, 2] - b[:, 2])))) > np.pi / 3)
    mid = np.zeros_like(a)
    mid[:, 0] = np.maximum(np.maximum(a[:, 0], b[:, 0]), 88.0)
    first, second = far & (t < 0.5), far & ~(t < 0.5)
    start = np.where(second[:, None], mid, a)
    end = np.where(first[:, None], mid, b)
    u = np.where(first, np.clip(2 * t, 0, 1), np.where(second, np.clip(2 * t - 1, 0, 1), t))
    return _diverging_msh(start, end, u)


def _diverging_msh(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Linear in Msh from ``a`` to ``b`` (``(P, 3)``) at ``t``, an unsaturated end's hue turned first."""
    a, b = a.copy(), b.copy()
    turn_a = (a[:, 1] < 0.05) & (b[:, 1] >= 0.05)
    turn_b = (b[:, 1] < 0.05) & (a[:, 1] >= 0.05)
    a[:, 2] = np.where(turn_a, _adjust_hue(b[:, 0], b[:, 1], b[:, 2], a[:, 0]), a[:, 2])
    b[:, 2] = np.where(turn_b, _adjust_hue(a[:, 0], a[:, 1], a[:, 2], b[:, 0]), b[:, 2])
    return _msh_to_srgb(a + (b - a) * t[..., None])


def interpolate(colours: np.ndarray, x, space: str = "rgb") -> np.ndarray:
    """sRGB colour ``(N, 3)`` of the map ``colours`` (``(K, 4)`` rows ``(value, r, g, b)``, values
    increasing) at values ``x``, interpolated in ``space``; constant beyond the ends (VTK's clamping)."""
    x = np.atleast_1d(np.asarray(x, dtype=np.float64))
    v, rgb = colours[:, 0], colours[:, 1:4]
    if space == "rgb" or len(v) == 1:
        return np.stack([np.interp(x, v, rgb[:, c]) for c in range(3)], axis=-1)
    if space == "lab":
        lab = srgb_to_lab(rgb)
        return lab_to_srgb(np.stack([np.interp(x, v, lab[:, c]) for c in range(3)], axis=-1))
    i = np.clip(np.searchsorted(v, x, side="right") - 1, 0, len(v) - 2)
    t = np.clip((x - v[i]) / (v[i + 1] - v[i]), 0.0, 1.0)
    if space == "hsv":
        hsv = _rgb_to_hsv(rgb)
        h0, h1 = hsv[i, 0], hsv[i + 1, 0]
        h1 = np.where(h1 - h0 > 0.5, h1 - 1, np.where(h0 - h1 > 0.5, h1 + 1, h1))  # the short way round
        out = np.stack([h0 + (h1 - h0) * t, *(hsv[i, c] + (hsv[i + 1, c] - hsv[i, c]) * t for c in (1, 2))], axis=-1)
        return _hsv_to_rgb(out)
    if space == "diverging":  # every point at once, with its segment's ends (many segments are no loop)
        msh = _msh(rgb)
        return np.clip(_diverging(msh[i], msh[i + 1], t), 0.0, 1.0)
    raise ValueError(f"unknown colour space {space!r}")

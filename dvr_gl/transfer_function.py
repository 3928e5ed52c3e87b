"""Transfer functions: piecewise-linear control points in data units.

A control point is ``(value, r, g, b, opacity)``; the function is linear
between points and constant beyond the first and last (conventions).
Colour is linear and non-associated.  ``opacity`` means, by ``opacity_model``:

* ``alpha`` (default, as VTK): the opacity of a layer of constant material
  ``unit_distance`` thick.  Alpha is what is interpolated linearly; extinction
  is ``sigma = -ln(1 - alpha) / unit_distance``.  Alpha = 1 is clamped to
  :data:`ALPHA_MAX`, the largest float32 below 1, so the largest extinction is
  :data:`MAX_OPTICAL_DEPTH` / unit_distance (16.64 per unit distance).
* ``extinction``: the extinction coefficient sigma itself (per world unit),
  interpolated linearly (physical units, and closed forms for linear ramps).

Emission is ``q = sigma * c``; a segment of length ``d`` at constant value has
opacity ``1 - exp(-sigma d)`` and associated colour ``c (1 - exp(-sigma d))``.

An optional sixth column is the single-scattering albedo (in [0, 1], linear between points): what a
scene's ``renderer.scattering.albedo = "transfer_function"`` reads (docs/scattering.md); every other
use of the function ignores it.
"""

from __future__ import annotations

import dataclasses
import difflib
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import SceneError, install_hint
from .presets import colormaps, paraview, slicer
from .presets.colour import linear_to_srgb, srgb_to_linear  # noqa: F401  (the names other modules import)
from .presets.property import gradient_opacity_is_constant

ALPHA_MAX = 1.0 - 2.0 ** -24
MAX_OPTICAL_DEPTH = -np.log1p(-ALPHA_MAX)  # = 24 ln 2 = 16.6355...
OPACITY_MODELS = ("alpha", "extinction")


def extinction_from_alpha(alpha, unit_distance: float):
    """``sigma = -ln(1 - alpha) / unit_distance`` in the stable form, alpha clamped to [0, ALPHA_MAX]."""
    a = np.clip(np.asarray(alpha, dtype=np.float64), 0.0, ALPHA_MAX)
    return -np.log1p(-a) / unit_distance


def segment_opacity(sigma, length):
    """Opacity ``1 - exp(-sigma * length)`` of a segment, stable for tiny optical depth."""
    return -np.expm1(-np.asarray(sigma) * np.asarray(length))


def xray_rgba(emitted, tau: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Premultiplied RGBA ``(..., 4)`` float64 of a radiograph: ``emitted`` the integral of ``sigma c``, an
    array ``(..., 3)`` or three arrays ``(...)``, ``tau`` that of ``sigma`` ``(...)``: alpha ``1 - exp(-tau)``,
    colour alpha times ``emitted / tau`` (zero where ``tau`` is).  Written channel by channel into ``out``
    (made if not given): no stacked, divided or concatenated copies (for a 512x512 image they took 34 ms)."""
    tau = np.asarray(tau)
    if out is None:
        out = np.empty(tau.shape + (4,))
    alpha = np.negative(np.expm1(np.negative(tau)), out=out[..., 3])
    # emitted / tau where tau > 0, and 0 elsewhere as emitted / inf: plain divisions (a masked one took 2 ms
    # more a 512x512 image)
    divisor = np.where(tau > 0, tau, np.inf)
    for c in range(3):
        channel = emitted[c] if isinstance(emitted, (list, tuple)) else emitted[..., c]
        np.multiply(np.divide(channel, divisor, out=out[..., c]), alpha, out=out[..., c])
    return out


def projected_rgba(tf: "TransferFunction", values: np.ndarray) -> np.ndarray:
    """Premultiplied RGBA ``(N, 4)`` of projected values (average, MIP, MinIP): each classified once,
    exactly, with the opacity of one ``unit_distance`` (conventions); written in place (the stacked and
    concatenated copies were about half its time at 512x512)."""
    values = np.asarray(values, dtype=np.float64)
    out = np.empty(values.shape + (4,))  # written channel by channel: no stacked colour, no concatenated copy
    alpha = out[..., 3]
    alpha[...] = segment_opacity(tf.extinction(values), tf.unit_distance)
    for c in range(3):
        np.multiply(tf._interp(values, c + 1), alpha, out=out[..., c])
    return out


def _narrow_integers(values: np.ndarray):
    """For integer data of a narrow range (a CT's 16 bits; more than 65,536 voxels and at most a quarter as
    many values as voxels), classified once a value and looked up: ``(nodes, index)``, every value from the
    least to the greatest in float64 (as each voxel's would be) and each voxel's offset from the least (in
    int64 for signed data, in the data's own type for unsigned: uint64's values above int64's; no overflow,
    every voxel is the least or above).  ``None`` for other data."""
    if values.dtype.kind not in "iu" or values.size <= 1 << 16:
        return None
    lo, hi = int(values.min()), int(values.max())
    if hi - lo >= values.size // 4:
        return None
    kind = np.int64 if values.dtype.kind == "i" else values.dtype.type
    nodes = (kind(lo) + np.arange(hi - lo + 1).astype(kind)).astype(np.float64)
    return nodes, values.astype(kind, copy=False) - kind(lo)


@dataclass(frozen=True, eq=False, repr=False)
class TransferFunction:
    """Piecewise-linear transfer function (see module doc).

    Attributes:
        points: ``(K, 5)`` float64 rows ``(value, r, g, b, opacity)``, values strictly increasing.
        unit_distance: world length to which ``alpha`` refers (> 0).
        opacity_model: ``alpha`` or ``extinction``.
    """

    points: np.ndarray
    unit_distance: float = 1.0
    opacity_model: str = "alpha"

    def __post_init__(self):
        try:
            pts = np.array(self.points, dtype=np.float64)
        except (ValueError, TypeError):  # ragged rows or non-numbers
            pts = np.empty((0, 0))
        if pts.ndim != 2 or pts.shape[1] not in (5, 6) or len(pts) < 1:
            raise SceneError("transfer_function.points must be a non-empty list of [value, r, g, b, opacity] "
                             "rows, or [value, r, g, b, opacity, albedo] (or give transfer_function.preset)")
        with np.errstate(over="ignore", invalid="ignore"):  # infinite steps are refused below
            steps = np.diff(pts[:, 0])
        if not (np.isfinite(pts).all() and np.isfinite(steps).all()):
            raise SceneError("transfer_function.points must be finite numbers (no NaN or Inf, values at most "
                             "1e308 apart)")
        bad = np.nonzero(steps <= 0)[0]
        if bad.size:
            i = int(bad[0])
            raise SceneError(f"transfer_function.points: values must increase strictly, but point {i + 1} "
                             f"({pts[i + 1, 0]:g}) follows {pts[i, 0]:g}; sort the points")
        if self.opacity_model not in OPACITY_MODELS:
            raise SceneError(f"transfer_function.opacity_model {self.opacity_model!r} is not one of "
                             f"{', '.join(OPACITY_MODELS)}")
        _check_range(pts[:, 1:4], 0.0, 1.0, "colour (r, g, b)")
        hi = 1.0 if self.opacity_model == "alpha" else np.inf
        _check_range(pts[:, 4:5], 0.0, hi, "alpha" if self.opacity_model == "alpha" else "extinction")
        _check_range(pts[:, 5:6], 0.0, 1.0, "albedo")
        u = float(self.unit_distance)
        if not np.isfinite(u) or u <= 0:
            raise SceneError(f"transfer_function.unit_distance must be a positive number, got {u}")
        pts.setflags(write=False)
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "unit_distance", u)

    @property
    def domain(self) -> tuple[float, float]:
        """Value range spanned by the control points."""
        return float(self.points[0, 0]), float(self.points[-1, 0])

    def _interp(self, values, column: int) -> np.ndarray:
        v = np.asarray(values, dtype=np.float64)
        return np.interp(v, self.points[:, 0], self.points[:, column])

    def color(self, values) -> np.ndarray:
        """Non-associated linear colour ``(..., 3)`` at data values."""
        return np.stack([self._interp(values, c) for c in (1, 2, 3)], axis=-1)

    @property
    def has_albedo(self) -> bool:
        """Whether the points carry the albedo column (the sixth)."""
        return self.points.shape[1] == 6

    def albedo(self, values) -> np.ndarray:
        """The single-scattering albedo at data values (the sixth column, linear between points)."""
        if not self.has_albedo:
            raise SceneError("the transfer function has no albedo column: give its points as [value, r, g, b, "
                             "opacity, albedo], or renderer.scattering.albedo as a number")
        return self._interp(values, 5)

    def opacity(self, values) -> np.ndarray:
        """The interpolated opacity column (alpha or sigma, by ``opacity_model``)."""
        return self._interp(values, 4)

    def extinction(self, values) -> np.ndarray:
        """Extinction coefficient sigma (per world unit) at data values."""
        o = self.opacity(values)
        if self.opacity_model == "alpha":
            return extinction_from_alpha(o, self.unit_distance)
        return o

    def evaluate(self, values) -> tuple[np.ndarray, np.ndarray]:
        """``(colour (..., 3), sigma (...))`` at data values, exactly (no table)."""
        return self.color(values), self.extinction(values)

    def opaque_somewhere(self, lo, hi, margin: float = 0.0) -> np.ndarray:
        """Whether the transfer function holds some opacity on each value range ``[lo - margin, hi +
        margin]`` (arrays): the opacity column is linear between control points and never negative,
        so it is zero over a range exactly when it is zero at both ends and at every control value
        between them.  ``margin``: widens the ranges (a table's spacing, where a table classifies)."""
        lo = np.asarray(lo, dtype=np.float64) - margin
        hi = np.asarray(hi, dtype=np.float64) + margin
        values, column = self.points[:, 0], self.points[:, 4]
        nonzero = np.r_[0, np.cumsum(column > 0)]  # control points with opacity, up to each index
        inner = nonzero[np.searchsorted(values, hi, "left")] - nonzero[np.searchsorted(values, lo, "right")]
        ends = (np.interp(lo, values, column) > 0) | (np.interp(hi, values, column) > 0)
        return ends | (inner > 0)

    def breakpoints(self) -> np.ndarray:
        """Data values where colour or extinction is not smooth: the control values and,
        in the alpha model, where alpha reaches ALPHA_MAX inside a segment (the clamp)."""
        v, a = self.points[:, 0], self.points[:, 4]
        extra = []
        if self.opacity_model == "alpha":
            for i in range(len(v) - 1):
                a0, a1 = a[i], a[i + 1]
                if (a0 - ALPHA_MAX) * (a1 - ALPHA_MAX) < 0:
                    extra.append(v[i] + (ALPHA_MAX - a0) / (a1 - a0) * (v[i + 1] - v[i]))
        return np.unique(np.concatenate([v, np.array(extra)]))

    def transparent_below(self, value: float, above: float) -> "TransferFunction":
        """The same from ``above`` up, falling linearly to transparent at ``value`` (below ``above``) and
        transparent below it: where data holds ``value`` there is no material (a mesh resampled onto a
        grid, outside its cells; ``above``: the lowest value of the material)."""
        if not value < above:
            raise ValueError(f"transparent_below: {value} is not below {above}")
        row = np.array([self._interp([above], c)[0] for c in range(self.points.shape[1])])
        row[0] = above
        start = row.copy()
        start[0], start[4] = value, 0.0
        kept = self.points[self.points[:, 0] > above]
        points = np.concatenate([[start, row], kept])
        return TransferFunction(points, self.unit_distance, self.opacity_model)

    def tabulate(self, size: int = 4096) -> "TransferFunctionLUT":
        """Sample colour and extinction at ``size`` evenly spaced values over the domain (a LUT)."""
        if int(size) < 2:
            raise SceneError(f"lut_size must be at least 2, got {size}")
        lo, hi = self.domain
        if hi <= lo:  # a single control point: a constant function
            hi = lo + 1.0
        nodes = np.linspace(lo, hi, int(size))
        table = np.concatenate([self.color(nodes), self.extinction(nodes)[:, None]], axis=1)
        return TransferFunctionLUT(table, (lo, hi), self.albedo(nodes) if self.has_albedo else None)

    def classify_voxels(self, data: np.ndarray, associated: bool = True, dtype=np.float64) -> np.ndarray:
        """Pre-classification: ``(..., 4)`` per voxel, ``(sigma c, sigma)`` (associated: emission and
        extinction, so transparent voxels carry no colour) or ``(c, sigma)``.  Integer data of a narrow range
        (a CT's 16 bits) are classified once a value and looked up: the same numbers.  ``dtype`` float32: the
        segments evaluated in float32 (:meth:`_classify_float32`), each channel contiguous (a ``(4, ...)`` array
        seen channel-last): for what is rounded to float32 anyway (Fourier's spectrum)."""
        if np.dtype(dtype) == np.float32:
            return self._classify_float32(np.asarray(data), associated)
        values = np.asarray(data)
        narrow = _narrow_integers(values)
        if narrow is not None:
            nodes, index = narrow
            return self.classify_voxels(nodes, associated)[index]
        values = np.asarray(values, dtype=np.float64)
        out = np.empty(values.shape + (4,))  # written in place: no stacked colour, no concatenated copy
        out[..., 3] = self.extinction(values)
        for k in range(3):
            out[..., k] = self._interp(values, k + 1)
            if associated:
                out[..., k] *= out[..., 3]
        return out

    def _classify_float32(self, values: np.ndarray, associated: bool) -> np.ndarray:
        """:meth:`classify_voxels` in float32, ``(..., 4)`` over a ``(4, ...)`` array (each channel
        contiguous).  Integer data of a narrow range: the float64 table (once a value) looked up.  Otherwise the
        segments in float32: 256^3 float voxels in 0.3 s where float64 and channel-last took 3.3 s (its log1p
        alone 7x float32's); within a few float32 roundings of float64 (measured 1.8e-7 of the largest value on
        the blobs, 1.1e-7 on random data through a four-point transfer function with alpha up to 1).  Where
        alpha exceeds 1/2, whose ``-log(1 - alpha)`` float32 would amplify (its condition number is
        ``1 / (1 - alpha)``), those voxels' extinction again in float64."""
        out = np.empty((4,) + values.shape, np.float32)
        narrow = _narrow_integers(values)
        if narrow is not None:
            nodes, index = narrow
            table = self.classify_voxels(nodes, associated)
            for c in range(4):
                np.take(table[:, c].astype(np.float32), index, out=out[c])
            return np.moveaxis(out, 0, -1)
        points = self.points
        v = np.clip(values.astype(np.float32), np.float32(points[0, 0]), np.float32(points[-1, 0]))
        # each voxel's segment of the piecewise-linear columns (value, r, g, b, opacity): np.interp's, in float32
        segment = np.searchsorted(points[1:-1, 0].astype(np.float32), v, side="right") if len(points) > 2 else 0
        x0 = points[:-1, 0].astype(np.float32)
        np.subtract(v, x0[segment], out=v)  # the offset into the segment

        def column(k, into):
            f = points[:, k]
            slope = (np.diff(f) / np.diff(points[:, 0])).astype(np.float32)  # the values increase strictly
            np.multiply(v, slope[segment], out=into)
            into += f[:-1].astype(np.float32)[segment]
            return into

        sigma = column(4, out[3])
        if self.opacity_model == "alpha":  # -ln(1 - alpha) / unit distance, alpha clamped (extinction_from_alpha)
            steep = np.flatnonzero(sigma.ravel() > 0.5)
            np.clip(sigma, 0.0, np.float32(ALPHA_MAX), out=sigma)
            np.negative(sigma, out=sigma)
            np.log1p(sigma, out=sigma)
            sigma *= np.float32(-1.0 / self.unit_distance)
            if steep.size:
                sigma.ravel()[steep] = self.extinction(values.ravel()[steep])
        for k in range(3):
            column(k + 1, out[k])
            if associated:
                out[k] *= sigma
        return np.moveaxis(out, 0, -1)

    def __repr__(self) -> str:
        lo, hi = self.domain
        return (f"TransferFunction({len(self.points)} points over {lo:g}..{hi:g}, {self.opacity_model} "
                f"per {self.unit_distance:g} unit{'s' * (self.unit_distance != 1)})")

    def to_dict(self) -> dict:
        return {"points": self.points.tolist(), "unit_distance": self.unit_distance,
                "opacity_model": self.opacity_model}


def _check_range(cols: np.ndarray, lo: float, hi: float, what: str):
    bad = np.nonzero(((cols < lo) | (cols > hi)).any(axis=1))[0]
    if bad.size:
        i = int(bad[0])
        raise SceneError(f"transfer_function.points[{i}] has {what} {cols[i].tolist()} outside "
                         f"[{lo:g}, {hi:g}]")


@dataclass(frozen=True, eq=False)
class TransferFunctionLUT:
    """A transfer function tabulated at evenly spaced values (the GPU's lookup texture).

    ``table[i] = (r, g, b, sigma)`` at value ``domain[0] + i * (domain[1] - domain[0]) / (N - 1)``
    (and ``albedo_table[i]``, the albedo column there, where the function has one):
    node-centred in value, so texture coordinate ``(x + 0.5) / N`` with ``x`` the
    fractional node index reproduces :meth:`lookup` under linear filtering.

    Extinction (computed in float64 from the model) is what is interpolated
    between nodes, not alpha: shaders then need no ``log(1 - alpha)``, which
    float32 computes poorly for small alpha, and a steep ramp to alpha = 1 inside
    one interval keeps most of its optical depth (the model is convex in alpha).
    Between nodes this differs from the model at second order in the node spacing.
    """

    table: np.ndarray
    domain: tuple[float, float]
    albedo_table: np.ndarray | None = None

    @property
    def size(self) -> int:
        return len(self.table)

    def node_coordinate(self, values) -> np.ndarray:
        """Fractional node index of data values, clamped to ``[0, N - 1]``."""
        lo, hi = self.domain
        x = (np.asarray(values, dtype=np.float64) - lo) * ((self.size - 1) / (hi - lo))
        return np.clip(x, 0.0, self.size - 1)

    def lookup(self, values) -> tuple[np.ndarray, np.ndarray]:
        """``(colour (..., 3), sigma (...))`` by linear interpolation of the table."""
        row = self._interpolate(self.table, values)
        return row[..., :3], row[..., 3]

    def albedo(self, values) -> np.ndarray:
        """The albedo column by linear interpolation of its table (as :meth:`lookup`)."""
        if self.albedo_table is None:
            raise SceneError("the transfer function has no albedo column")
        return self._interpolate(self.albedo_table[:, None], values)[..., 0]

    def _interpolate(self, table, values) -> np.ndarray:
        """Rows of ``table`` (``(size, C)``, at the nodes) linearly interpolated at data values."""
        x = self.node_coordinate(values)
        i0 = np.minimum(np.floor(x).astype(np.int64), self.size - 2)
        f = (x - i0)[..., None]
        return table[i0] * (1.0 - f) + table[i0 + 1] * f


# --- presets -------------------------------------------------------------------------------------
#
# A preset is found by name (docs/transfer-functions.md): one of dvr-gl's own (PRESETS' first five),
# one of 3D Slicer's volume-rendering presets (shipped as Slicer's own XML), or a matplotlib colour
# map; or read from a file (Slicer .vp or presets XML, ParaView colour-map JSON).  Names match without
# regard to case, and no two names differ only by case (tests/scene/test_presets.py): dvr-gl's bone
# preset, once `ct-bone` beside Slicer's `CT-Bone`, is `ct-bone-ivory`; `ct-bone` is now Slicer's.


def _grayscale(lo, hi, intercept):
    return [[lo, 0, 0, 0, 0], [hi, 1, 1, 1, 0.1]]


def _viridis(lo, hi, intercept):
    """matplotlib's 256-entry viridis (shipped, CC0) over the value range, opacity 0 to 0.1."""
    return colormaps.from_table("viridis", colormaps.viridis_table()).points((lo, hi))


def _ct_bone(lo, hi, intercept):
    """Bone from about +200 HU, opaque and ivory above +700 HU (opacity per mm)."""
    hu = [(-1024, (0, 0, 0), 0), (150, (0.55, 0.25, 0.15), 0), (300, (0.85, 0.7, 0.55), 0.25),
          (700, (0.95, 0.9, 0.8), 0.8), (3000, (1, 1, 0.95), 0.95)]
    return [[h - intercept, *c, a] for h, c, a in hu]


def _ct_skin(lo, hi, intercept):
    """Skin and soft tissue around -500..+100 HU, with faint bone (opacity per mm)."""
    hu = [(-1024, (0, 0, 0), 0), (-600, (0.7, 0.4, 0.3), 0), (-400, (0.9, 0.6, 0.5), 0.15),
          (100, (0.9, 0.65, 0.55), 0.2), (300, (1, 0.95, 0.9), 0.3), (3000, (1, 1, 1), 0.6)]
    return [[h - intercept, *c, a] for h, c, a in hu]


def _shepp_logan(lo, hi, intercept):
    """For the built-in Shepp-Logan phantom (values 0..1): faint blue brain,
    orange lesions, a thin translucent white skull."""
    return [[0.0, 0, 0, 0, 0], [0.12, 0.1, 0.2, 0.6, 0], [0.18, 0.15, 0.3, 0.8, 0.005],
            [0.24, 0.15, 0.3, 0.8, 0.005], [0.27, 0.3, 0.4, 0.9, 0.0], [0.31, 1.0, 0.3, 0.05, 0.08],
            [0.41, 1.0, 0.75, 0.1, 0.12], [0.45, 0.9, 0.9, 0.85, 0.0], [0.85, 0.9, 0.9, 0.85, 0.0],
            [1.0, 1.0, 1.0, 0.95, 0.03]]


def _slicer(name):
    return lambda lo, hi, intercept: slicer.read_presets()[name].points((lo, hi), intercept)


PRESETS = {
    "grayscale": (_grayscale, "grey ramp over the volume's value range"),
    "viridis": (_viridis, "matplotlib's viridis over the value range, opacity ramp 0 to 0.1"),
    "ct-bone-ivory": (_ct_bone, "CT bone, ivory (Hounsfield units, see rescale_intercept)"),
    "ct-skin": (_ct_skin, "CT skin and soft tissue (Hounsfield units, see rescale_intercept)"),
    "shepp-logan": (_shepp_logan, "the built-in Shepp-Logan phantom"),
    **{n: (_slicer(n), "3D Slicer's preset (data units: Hounsfield units for CT, see rescale_intercept)")
       for n in slicer.read_presets()},
}


def find_preset(name: str) -> str:
    """The preset's name as :data:`PRESETS` or matplotlib spells it, found in any case (no two
    names differ only by case); an unknown name is one line with the close matches."""
    if name in PRESETS:
        return name
    folded = {n.lower(): n for n in PRESETS}
    key = str(name).lower()
    if len(key) > 200:  # no name is that long: no close matches to look for (difflib is quadratic in it)
        key = key[:200]
    if key in folded:
        return folded[key]
    mpl = colormaps.matplotlib_names()
    if mpl is not None and key in mpl:
        return mpl[key]
    known = list(folded) + list(mpl or {})
    close = difflib.get_close_matches(key, known, n=4, cutoff=0.6)
    hint = f"did you mean {', '.join(folded.get(c) or mpl[c] for c in close)}? " if close else ""
    extra = ("" if mpl is not None else "; matplotlib colour maps by name (inferno, magma, ...) need matplotlib: "
             f"{install_hint('plot')}")
    text = str(name)
    shown = repr(text) if len(text) <= 80 else f"{text[:60]!r} (and {len(text) - 60} more characters)"
    raise SceneError(f"unknown transfer function preset {shown}: {hint}give a preset ({', '.join(list(PRESETS)[:5])}, "
                     f"3D Slicer's such as CT-AAA), a matplotlib colour map, or a .vp/.json/.xml file "
                     f"(docs/transfer-functions.md){extra}")


def preset_property(name: str):
    """The :class:`~dvr_gl.presets.property.VolumeProperty` behind a named preset (Slicer's, a colour
    map), or None for dvr-gl's own."""
    found = find_preset(name)
    if found in slicer.read_presets():
        return slicer.read_presets()[found]
    if found in PRESETS:
        return None
    return colormaps.matplotlib_map(found)


#: The colours a scene's channels get by default, in order (after napari's and ImageJ's composite
#: palettes: magenta and green read apart for most people with a colour-vision deficiency).
CHANNEL_COLORS = ((1.0, 0.0, 1.0), (0.0, 1.0, 0.0), (0.0, 1.0, 1.0), (1.0, 1.0, 0.0), (1.0, 0.0, 0.0),
                  (0.0, 0.0, 1.0))


def channel_transfer_function(k: int, value_range: tuple[float, float], unit_distance: float = 1.0):
    """The default transfer function of channel ``k`` of several: black to :data:`CHANNEL_COLORS` ``[k]``
    (cycling) over ``value_range``, opacity 0 to 0.1 per ``unit_distance`` as the ``grayscale`` preset's."""
    lo, hi = value_range
    hi = hi if hi > lo else lo + 1.0
    r, g, b = CHANNEL_COLORS[k % len(CHANNEL_COLORS)]
    return TransferFunction(np.array([[lo, 0, 0, 0, 0], [hi, r, g, b, 0.1]], dtype=np.float64),
                            unit_distance=unit_distance)


def preset(name: str, value_range: tuple[float, float], rescale_intercept: float = 0.0,
           unit_distance: float = 1.0) -> TransferFunction:
    """A named preset as a :class:`TransferFunction` in data units (names: :func:`find_preset`).

    Generic presets and colour maps span ``value_range``; CT presets (dvr-gl's and Slicer's) are
    written in Hounsfield units and placed with ``HU = data + rescale_intercept`` (DICOM's meaning:
    -1024 for CT data stored as HU + 1024, such as CThead and the CT bunny).  ``unit_distance``: the
    world length alpha refers to (Slicer's presets: 1, a millimetre, as VTK's default).
    """
    found = find_preset(name)
    check_rescale_intercept(rescale_intercept)
    lo, hi = value_range
    if hi <= lo:
        hi = lo + 1.0
    if found in PRESETS:
        points = PRESETS[found][0](lo, hi, rescale_intercept)
        prop = slicer.read_presets().get(found)
        if prop is not None:
            _warn_unmodelled(prop)
    else:
        points = colormaps.matplotlib_map(found).points((lo, hi))
    return TransferFunction(np.array(points, dtype=np.float64), unit_distance=unit_distance)


def from_property(prop, value_range, rescale_intercept: float = 0.0, unit_distance: float = 1.0) -> TransferFunction:
    """A :class:`~dvr_gl.presets.property.VolumeProperty` (read from a file) as a TransferFunction;
    what we do not model (a varying gradient opacity, nearest interpolation) is warned about."""
    check_rescale_intercept(rescale_intercept)
    _warn_unmodelled(prop)
    return TransferFunction(prop.points(value_range, rescale_intercept), unit_distance=unit_distance)


#: The largest rescale intercept (in magnitude): values are shifted by it in float64, where 1e12 keeps steps
#: of 1e-4 apart (a preset's 0.01 HU); DICOM's intercepts are about 1e3 to 1e5.
MAX_RESCALE_INTERCEPT = 1e12


def check_rescale_intercept(value) -> float:
    """``value`` if it is a usable rescale intercept: a finite number within :data:`MAX_RESCALE_INTERCEPT`
    (beyond that, the points ``HU - intercept`` of a preset collapse onto one value in float64, and the message
    would blame points the user never gave)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not abs(v) <= MAX_RESCALE_INTERCEPT:  # NaN too
        raise SceneError(f"transfer_function.rescale_intercept (--rescale-intercept) {value!r}: give a finite number "
                         f"within +-{MAX_RESCALE_INTERCEPT:g} (HU = data + intercept: -1024 for CT stored as "
                         f"HU + 1024)")
    return v


def read_transfer_function_file(path, name: str | None = None, stretch: bool | None = None):
    """A transfer-function file as a VolumeProperty, by its suffix: Slicer's ``.vp``, Slicer's presets
    or MRML XML (``.xml``, ``.mrml``: ``name`` picks one), ParaView's colour-map JSON (``.json``:
    ``name`` picks one of several).  ``stretch``: see :class:`TransferFunctionSpec`."""
    from .sandbox import check_input_path

    path = check_input_path(Path(os.path.expanduser(str(path))), "transfer function file")
    suffix = path.suffix.lower()
    if suffix == ".vp":
        prop = slicer.read_vp(path)
    elif suffix in (".xml", ".mrml"):
        props = slicer.read_presets(path.resolve())
        if name is None and len(props) > 1:
            raise SceneError(f"{path}: holds {len(props)} volume properties ({', '.join(list(props)[:5])}, ...); "
                             f"name one with transfer_function.name")
        matches = [p for n, p in props.items() if name is None or n.lower() == name.lower()]
        if not matches:
            raise SceneError(f"{path}: no volume property named {name!r}; it holds {', '.join(list(props)[:8])}")
        prop = matches[0]
    elif suffix == ".json":
        prop = paraview.to_property(paraview.choose(paraview.read_maps(path), name, path), path.name, stretch)
    else:
        raise SceneError(f"{path}: cannot tell the transfer function format from the suffix {suffix or '(none)'!r}; "
                         f"give a Slicer .vp or .xml file or a ParaView colour-map .json")
    if stretch is not None and suffix != ".json":
        prop = dataclasses.replace(prop, stretch=bool(stretch))
    return prop


FILE_SUFFIXES = (".vp", ".xml", ".mrml", ".json", ".pvsm")  # .pvsm: a 2D transfer function (transfer_function_2d)


def is_transfer_function_file(name) -> bool:
    """Whether a ``--transfer-function`` argument names a file (by its suffix) rather than a preset."""
    return isinstance(name, str) and Path(name).suffix.lower() in FILE_SUFFIXES


def _warn_unmodelled(prop) -> None:
    if not gradient_opacity_is_constant(prop):
        warnings.warn(f"{prop.source}: its gradient opacity is not modelled and is dropped (the image shows "
                      f"more of the flat regions than in Slicer; a 2D transfer function models it: "
                      f"TransferFunction2D.from_gradient_factor, docs/transfer-functions.md)", stacklevel=3)
    if prop.interpolation == 0:
        warnings.warn(f"{prop.source}: nearest-neighbour interpolation is not applied from the file; set "
                      f"renderer.filter = \"nearest\" for it", stacklevel=3)

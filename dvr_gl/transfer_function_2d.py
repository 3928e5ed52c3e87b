"""Two-dimensional transfer functions: colour and opacity over (value, gradient magnitude).

After Kniss, Kindlmann and Hansen (2002): a sample is classified by its value ``v`` and by ``g = |grad v|``, so
that boundaries between materials (where ``g`` is large) can be shown apart from the materials themselves.

The function is a table of nodes, ``(r, g, b, opacity)`` at ``NV x NG`` evenly spaced points of
``value_range x gradient_range``, bilinear between them (value first, then gradient magnitude: the order
the shader mixes in) and constant beyond the ranges, as a 1D transfer function is beyond its points.
``opacity`` means alpha per ``unit_distance`` or extinction, by ``opacity_model``, exactly as in
:mod:`dvr_gl.transfer_function`.  ``g`` is the gradient the ray caster shades with: central differences of
the reconstructed field one voxel apart along each axis, in value units per world unit.

Widgets are rasterized onto the table when it is made (:meth:`TransferFunction2D.from_boxes`): ParaView's
boxes (``[value, gradient, width, height, r, g, b, alpha]``: a rectangle whose alpha is a Gaussian about its
centre, standard deviation 0.3 of its width and height, zero outside), composited over in order.  The table
is the definition: the converged reference evaluates it exactly (opacity interpolated, then turned into
extinction); the GPU and the discrete reference look up its extinction at the nodes (:meth:`tabulate_2d`),
which differ at second order in the node spacing, as the 1D table does.

Gradient-magnitude opacity (``renderer.gradient_opacity``) is one case:
:meth:`TransferFunction2D.from_gradient_opacity` gives ``sigma(v) min(1, g / reference)`` exactly, with two
gradient nodes, 0 and the reference.

The object is a :class:`~dvr_gl.transfer_function.TransferFunction` whose points are the table's value
marginal (at each value node, the most opaque node over gradient magnitude): what code that needs one value
axis reads (empty-space skipping, which it keeps conservative; a histogram's display).  A renderer
classifies with the 2D table only where it declares ``transfer_function_2d``; the registry refuses the
others.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import SceneError
from .transfer_function import TransferFunction, extinction_from_alpha

#: ParaView's box: the Gaussian's standard deviation as a fraction of the box's width and height
#: (``vtkPVTransferFunction2DBox::GaussianSigmaFactor`` = 30, per cent)
BOX_SIGMA = 0.3
#: the nodes a box table has by default (value x gradient magnitude)
BOX_TABLE_SIZE = (256, 64)
_MAX_NODES = 1 << 20  # nodes: 16 MiB as RGBA32F, a few times that in float64 while drawing boxes


@dataclass(frozen=True, eq=False, repr=False, init=False)
class TransferFunction2D(TransferFunction):
    """A 2D transfer function (see the module doc).

    Attributes:
        table: ``(NV, NG, 4)`` float64 nodes ``(r, g, b, opacity)``; ``table[i, j]`` at value node ``i`` and
            gradient-magnitude node ``j``.
        value_range, gradient_range: the first and last node of each axis (data units; value units per world
            unit).
        unit_distance, opacity_model: as :class:`~dvr_gl.transfer_function.TransferFunction`'s.
        points: the value marginal (module doc).
    """

    table: np.ndarray = None
    value_range: tuple = (0.0, 1.0)
    gradient_range: tuple = (0.0, 1.0)

    def __init__(self, table, value_range, gradient_range, unit_distance: float = 1.0, opacity_model: str = "alpha"):
        t = _checked_table(table, opacity_model)
        object.__setattr__(self, "table", t)
        object.__setattr__(self, "value_range", _checked_range(value_range, "value_range_2d", 0))
        object.__setattr__(self, "gradient_range", _checked_range(gradient_range, "gradient_range_2d", 1))
        object.__setattr__(self, "unit_distance", unit_distance)
        object.__setattr__(self, "opacity_model", opacity_model)
        strongest = np.argmax(t[:, :, 3], axis=1)  # per value node, the most opaque gradient node
        rows = t[np.arange(len(t)), strongest]
        object.__setattr__(self, "points", np.column_stack([self.value_nodes(), rows]))
        self.__post_init__()

    @property
    def is_2d(self) -> bool:
        return True

    @property
    def shape(self) -> tuple[int, int]:
        return self.table.shape[:2]

    def value_nodes(self) -> np.ndarray:
        return np.linspace(*self.value_range, self.table.shape[0])

    def gradient_nodes(self) -> np.ndarray:
        return np.linspace(*self.gradient_range, self.table.shape[1])

    def evaluate_2d(self, values, gradients) -> tuple[np.ndarray, np.ndarray]:
        """``(colour (..., 3), sigma (...))`` at values and gradient magnitudes, exactly: the table's
        colour and opacity interpolated, the opacity then turned into extinction."""
        row = bilinear(self.table, self.value_range, self.gradient_range, values, gradients)
        sigma = row[..., 3]
        if self.opacity_model == "alpha":
            sigma = extinction_from_alpha(sigma, self.unit_distance)
        return row[..., :3], sigma

    def tabulate_2d(self) -> "TransferFunction2DLUT":
        """The GPU's table: colour and extinction at the nodes (RGBA32F, NV x NG)."""
        t = self.table.copy()
        if self.opacity_model == "alpha":
            t[..., 3] = extinction_from_alpha(t[..., 3], self.unit_distance)
        return TransferFunction2DLUT(t, self.value_range, self.gradient_range)

    def classify_voxels(self, data, associated: bool = True):
        raise SceneError("a 2D transfer function classifies with the gradient at each sample, and "
                         "classification = 'pre' classifies the voxels alone: use classification post")

    def to_table(self) -> dict:
        """The scene file's ``[transfer_function]`` table that makes this function again."""
        return {"table_2d": self.table.tolist(), "value_range_2d": list(self.value_range),
                "gradient_range_2d": list(self.gradient_range), "unit_distance": self.unit_distance,
                "opacity_model": self.opacity_model}

    def to_dict(self) -> dict:
        return self.to_table()

    def __repr__(self) -> str:
        (v0, v1), (g0, g1) = self.value_range, self.gradient_range
        return (f"TransferFunction2D({self.shape[0]} x {self.shape[1]} nodes over value {v0:g}..{v1:g}, "
                f"|gradient| {g0:g}..{g1:g}, {self.opacity_model} per {self.unit_distance:g})")

    @classmethod
    def from_boxes(cls, boxes, value_range, gradient_range, size=BOX_TABLE_SIZE, unit_distance: float = 1.0):
        """ParaView's boxes ``[value, gradient, width, height, r, g, b, alpha]`` rasterized onto a table of
        ``size`` nodes over the ranges (module doc); alpha per ``unit_distance``."""
        b = _checked_boxes(boxes)
        nv, ng = _checked_size(size)
        vr = _checked_range(value_range, "value_range_2d", 0)
        gr = _checked_range(gradient_range, "gradient_range_2d", 1)
        v, g = np.meshgrid(np.linspace(*vr, nv), np.linspace(*gr, ng), indexing="ij")
        emitted, alpha = np.zeros((nv, ng, 3)), np.zeros((nv, ng))
        for x, y, w, h, r, gg, bb, a in b:
            with np.errstate(over="ignore"):  # a box far from a node, or thinner than float64 steps: not inside
                u, t = (v - x) / w, (g - y) / h
            inside = (u >= 0) & (u <= 1) & (t >= 0) & (t <= 1)
            u, t = np.where(inside, u, 0.5), np.where(inside, t, 0.5)
            box_alpha = np.where(inside, a * np.exp(-((u - 0.5) ** 2 + (t - 0.5) ** 2) / (2 * BOX_SIGMA ** 2)), 0.0)
            emitted = box_alpha[..., None] * np.array([r, gg, bb]) + (1.0 - box_alpha[..., None]) * emitted
            alpha = box_alpha + (1.0 - box_alpha) * alpha
        with np.errstate(invalid="ignore", divide="ignore"):
            colour = np.where(alpha[..., None] > 0, emitted / alpha[..., None], 0.0)
        return cls(np.concatenate([np.clip(colour, 0.0, 1.0), alpha[..., None]], axis=-1), vr, gr, unit_distance)

    @classmethod
    def from_gradient_opacity(cls, tf: TransferFunction, reference: float, size: int = 4096):
        """``tf``'s colour and extinction scaled by ``min(1, g / reference)``: what ``renderer.gradient_opacity``
        with ``gradient_opacity_reference = reference`` renders, as a table of ``size`` value nodes (the 1D
        table's, at ``lut_size = size``) by two gradient nodes, 0 and ``reference`` (extinction model: the
        product is bilinear, so the table holds it exactly)."""
        lut = tf.tabulate(size)
        ref = float(reference)
        if not (np.isfinite(ref) and ref > 0):
            raise SceneError(f"from_gradient_opacity: the reference |gradient| must be a positive number, got {ref}")
        full = lut.table
        none = np.column_stack([full[:, :3], np.zeros(len(full))])
        return cls(np.stack([none, full], axis=1), lut.domain, (0.0, ref), tf.unit_distance, "extinction")

    @classmethod
    def from_gradient_factor(cls, tf: TransferFunction, factor, size: int = 4096, gradient_nodes: int = 64):
        """VTK's and Slicer's gradient opacity: ``tf``'s alpha times a piecewise-linear factor of ``g``, ``factor``
        rows ``(|gradient|, factor in [0, 1])`` (a Slicer preset's ``gradient_opacity``; constant beyond the
        rows), as a table of ``size`` value nodes (the 1D table's) by ``gradient_nodes`` evenly spaced over the
        rows' span (the factor is exact where its knots fall on nodes, linear between them otherwise).
        ``tf`` in the alpha model: the product is of opacities, as VTK's."""
        f = np.array(factor, np.float64)
        if f.ndim != 2 or f.shape[1] != 2 or len(f) < 1 or not np.isfinite(f).all() or np.any(np.diff(f[:, 0]) < 0) \
                or f[:, 1].min() < 0 or f[:, 1].max() > 1:
            raise SceneError("a gradient opacity must be rows (|gradient|, factor): finite, |gradient| increasing, "
                             "factor in [0, 1]")
        if tf.opacity_model != "alpha":
            raise SceneError("from_gradient_factor multiplies alpha by the factor: give a transfer function in alpha")
        lo, hi = max(float(f[0, 0]), 0.0), float(f[-1, 0])
        hi = hi if hi > lo else lo + 1.0
        g = np.linspace(lo, hi, int(gradient_nodes))
        values = np.linspace(*tf.tabulate(2).domain, int(size))
        alpha = tf.opacity(values)[:, None] * np.interp(g, f[:, 0], f[:, 1])[None, :]
        colour = np.broadcast_to(tf.color(values)[:, None, :], alpha.shape + (3,))
        return cls(np.concatenate([colour, alpha[..., None]], axis=-1), (values[0], values[-1]), (lo, hi),
                   tf.unit_distance, "alpha")


@dataclass(frozen=True, eq=False)
class TransferFunction2DLUT:
    """A 2D transfer function's GPU table: ``table[i, j] = (r, g, b, sigma)`` at value node ``i`` and
    gradient-magnitude node ``j``, looked up as ``common/transfer_function_2d.glsl`` does."""

    table: np.ndarray
    value_range: tuple
    gradient_range: tuple

    def lookup(self, values, gradients) -> tuple[np.ndarray, np.ndarray]:
        row = bilinear(self.table, self.value_range, self.gradient_range, values, gradients)
        return row[..., :3], row[..., 3]

    def uniforms(self) -> dict:
        """The shader's map from (value, |gradient|) to texels."""
        (v0, v1), (g0, g1) = self.value_range, self.gradient_range
        nv, ng = self.table.shape[:2]
        return {"u_tf2d_size": (nv, ng), "u_tf2d_lo": (v0, g0), "u_tf2d_scale": ((nv - 1) / (v1 - v0),
                                                                                 (ng - 1) / (g1 - g0))}

    def texels(self) -> np.ndarray:
        """``(NG, NV, 4)`` float32: rows of gradient magnitude, columns of value (the texture's layout)."""
        return np.ascontiguousarray(self.table.transpose(1, 0, 2), dtype=np.float32)


def bilinear(table, value_range, gradient_range, values, gradients) -> np.ndarray:
    """Rows of ``table`` ``(NV, NG, C)`` at values and gradient magnitudes: interpolated along value, then
    along gradient magnitude, each coordinate clamped to its nodes (the shader's order and clamps)."""
    def coordinate(x, lo_hi, n):
        lo, hi = lo_hi
        c = np.clip((np.asarray(x, np.float64) - lo) * ((n - 1) / (hi - lo)), 0.0, n - 1)
        i0 = np.minimum(np.floor(c).astype(np.int64), n - 2)
        return i0, (c - i0)[..., None]

    nv, ng = table.shape[:2]
    i, fi = coordinate(values, value_range, nv)
    j, fj = coordinate(gradients, gradient_range, ng)
    low = table[i, j] * (1.0 - fi) + table[i + 1, j] * fi
    high = table[i, j + 1] * (1.0 - fi) + table[i + 1, j + 1] * fi
    return low * (1.0 - fj) + high * fj


def voxel_gradient_magnitudes(data, spacing) -> np.ndarray:
    """``|grad|`` at the voxels of ``data[z, y, x]`` (float64): central differences one voxel apart along each
    axis, the taps clamped to the edge, in value units per world unit (``spacing``: x, y, z), which is the
    gradient the renderers classify with, at the voxel centres.  Differences are taken in the samples' own
    float type (integers in float64), squares summed in float64."""
    d = np.asarray(data)
    d = d if np.issubdtype(d.dtype, np.floating) else d.astype(np.float64)
    out = np.zeros(d.shape)
    for axis, h in zip((2, 1, 0), spacing):
        n = d.shape[axis]
        up = np.take(d, np.minimum(np.arange(n) + 1, n - 1), axis=axis)
        down = np.take(d, np.maximum(np.arange(n) - 1, 0), axis=axis)
        out += ((up - down) / (2.0 * h)) ** 2
    return np.sqrt(out)


def histogram_2d(data, spacing, bins=(256, 64), value_range=None, gradient_range=None):
    """The joint histogram of value and gradient magnitude over the voxels (what a 2D transfer function is drawn
    over, as in Kniss et al.): ``(counts (NV, NG), value_range, gradient_range)``; the ranges default to the data's
    (gradient magnitude: 0 to its 99.9th percentile, so that a few steep voxels do not squeeze the rest)."""
    d = np.asarray(data, np.float64)
    g = voxel_gradient_magnitudes(d, spacing)
    vr = _range_or(value_range, (float(d.min()), float(d.max())))
    gr = _range_or(gradient_range, (0.0, float(np.percentile(g, 99.9))), "gradient_range_2d")
    counts, _, _ = np.histogram2d(d.ravel(), g.ravel(), bins=_checked_size(bins), range=(vr, gr))
    return counts, vr, gr


def is_2d(tf) -> bool:
    """Whether a transfer function classifies by value and gradient magnitude."""
    return bool(getattr(tf, "is_2d", False))


#: what a 2D transfer function cannot be rendered with, and why (checked by :func:`check_scene`)
_REFUSED = {
    "classification": ({"pre", "preintegrated"}, "classifies each sample with its own gradient: use "
                       "classification = 'post'"),
    "compositing": ({"mip", "minip", "average", "isosurface"}, "classifies samples along a ray, and a "
                    "projected value or an iso-surface's colour has no gradient magnitude: use "
                    "emission_absorption or xray"),
}


def check_scene(scene) -> None:
    """One line naming what a scene asks for that its 2D transfer function cannot be rendered with."""
    r = scene.renderer
    for key, (values, why) in _REFUSED.items():
        if getattr(r, key) in values:
            raise SceneError(f"renderer.{key} = {getattr(r, key)!r} with a 2D transfer function: it {why}")
    sc = getattr(r, "scattering", None)
    if sc is not None and sc.enabled:
        raise SceneError("renderer.scattering with a 2D transfer function: the shadow rays' extinction would need "
                         "the gradient at every shadow sample, which is not modelled; turn scattering off")
    if getattr(r, "hemispherical_shading", False):
        raise SceneError("renderer.hemispherical_shading with a 2D transfer function is not modelled; turn it off")


# --- scene keys ----------------------------------------------------------------------------------


def from_spec(spec, field, base_dir: Path = Path(".")) -> TransferFunction2D | None:
    """The 2D transfer function a ``[transfer_function]`` table gives (``table_2d``, ``boxes_2d``, or a ParaView
    state ``file`` ``.pvsm``), or None where it gives a 1D one."""
    file = spec.file if isinstance(spec.file, str) and spec.file.lower().endswith(".pvsm") else None
    given = [k for k, v in (("table_2d", spec.table_2d), ("boxes_2d", spec.boxes_2d), ("file", file))
             if v is not None]
    if not given:
        for key in ("value_range_2d", "gradient_range_2d", "size_2d"):
            if getattr(spec, key) is not None:
                raise SceneError(f"transfer_function.{key} applies to a 2D transfer function: give table_2d, "
                                 f"boxes_2d or a ParaView .pvsm file, or remove it")
        return None
    if len(given) > 1 or spec.points is not None or spec.preset is not None:
        others = given[1:] + [k for k in ("points", "preset") if getattr(spec, k) is not None]
        raise SceneError(f"transfer_function: give {given[0]} or {others[0]}, not both")
    if spec.table_2d is not None:
        if spec.size_2d is not None:
            raise SceneError("transfer_function.size_2d sizes the table boxes are drawn on; table_2d gives its own")
        return TransferFunction2D(spec.table_2d, _range_or(spec.value_range_2d, field.value_range),
                                  _range_or(spec.gradient_range_2d, (0.0, 1.0), "gradient_range_2d"),
                                  spec.unit_distance, spec.opacity_model)
    if spec.opacity_model != "alpha":
        raise SceneError("transfer_function: boxes are written in alpha; use opacity_model = 'alpha'")
    if file is not None:
        from .sandbox import check_input_path

        path = Path(os.path.expanduser(file))
        path = check_input_path(path if path.is_absolute() else Path(base_dir) / path, "ParaView state file")
        boxes, ranges = read_paraview_state(path, spec.name)
    else:
        boxes, ranges = spec.boxes_2d, None
    b = _checked_boxes(boxes)
    value_range = spec.value_range_2d or (ranges[:2] if ranges else field.value_range)
    gradient_range = spec.gradient_range_2d or (ranges[2:] if ranges else (0.0, float((b[:, 1] + b[:, 3]).max())))
    return TransferFunction2D.from_boxes(b, _range_or(value_range, field.value_range),
                                         _range_or(gradient_range, (0.0, 1.0), "gradient_range_2d"),
                                         spec.size_2d or BOX_TABLE_SIZE, spec.unit_distance)


def _range_or(given, fallback, key: str = "value_range_2d") -> tuple[float, float]:
    """``given`` (a scene's range), or ``fallback`` widened to a unit where it is one value."""
    if given is not None:
        return _checked_range(given, key, 1 if key.startswith("gradient") else 0)
    lo, hi = float(fallback[0]), float(fallback[1])
    return (lo, hi if hi > lo else lo + 1.0)


# --- ParaView's state files ----------------------------------------------------------------------

_MAX_STATE_BYTES = 256 * 2 ** 20


def read_paraview_state(path, name: str | None = None):
    """The boxes ``(K, 8)`` and ``Range`` ``[value lo, hi, gradient lo, hi]`` (None if unset) of a
    ``TransferFunction2D`` proxy in a ParaView state file (``.pvsm``, ParaView 5.10 on): its ``Boxes``
    property holds ``[x, y, width, height, r, g, b, alpha]`` per box.  ParaView writes 2D transfer functions
    in state files only (its colour-map presets and JSON hold 1D ones); ``name`` picks one of several by its
    name in the state (``ARRAY.TransferFunction2D``, or the array's name)."""
    path = Path(path)
    if os.path.getsize(path) > _MAX_STATE_BYTES:
        raise SceneError(f"{path}: too large for a ParaView state file ({os.path.getsize(path)} bytes)")
    proxies, names = _state_proxies(path.read_bytes(), path)
    if not proxies:
        raise SceneError(f"{path}: holds no 2D transfer function (a TransferFunction2D proxy); save the state "
                         f"from ParaView 5.10 or later with a 2D transfer function in use")
    found = {names.get(pid, pid): p for pid, p in proxies.items()}
    if name is None and len(found) > 1:
        raise SceneError(f"{path}: holds {len(found)} 2D transfer functions ({', '.join(found)}); name one with "
                         f"transfer_function.name")
    if name is not None:
        key = name.lower()
        found = {k: p for k, p in found.items() if key in (k.lower(), k.lower().split(".transferfunction2d")[0])}
        if not found:
            raise SceneError(f"{path}: no 2D transfer function named {name!r}")
    prop = next(iter(found.values()))
    boxes = prop.get("Boxes", [])
    if not boxes or len(boxes) % 8:
        raise SceneError(f"{path}: the 2D transfer function's Boxes hold {len(boxes)} numbers, not a positive "
                         f"multiple of 8 (x, y, width, height, r, g, b, alpha per box)")
    rng = prop.get("Range")
    usable = rng is not None and len(rng) == 4 and rng[0] < rng[1] and rng[2] < rng[3]
    return np.array(boxes, np.float64).reshape(-1, 8), (list(rng) if usable else None)


class _Declaration(Exception):
    """A DOCTYPE or entity declaration in a state file."""


def _state_proxies(data: bytes, path):
    """``({proxy id: {property: [numbers]}}, {proxy id: name})`` of the TransferFunction2D proxies of a ParaView
    state document, read by expat as it streams; a DOCTYPE or entity declaration is refused as it is met
    (entities can expand without bound or name other files; ParaView writes neither)."""
    import xml.parsers.expat

    proxies, names, state = {}, {}, {"proxy": None, "property": None}

    def refuse(*_):
        raise _Declaration()

    def start(tag, a):
        if tag == "Proxy" and a.get("type") == "TransferFunction2D":
            state["proxy"] = proxies.setdefault(a.get("id", str(len(proxies))), {})
        elif tag == "Property" and state["proxy"] is not None:
            state["property"] = state["proxy"].setdefault(a.get("name", ""), [])
        elif tag == "Element" and state["property"] is not None:
            state["property"].append(_number(a.get("value"), path))
        elif tag == "Item" and a.get("id") is not None and a.get("name"):
            names[a["id"]] = a["name"]

    def end(tag):
        if tag == "Proxy":
            state["proxy"] = None
        if tag in ("Proxy", "Property"):
            state["property"] = None

    parser = xml.parsers.expat.ParserCreate()
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except _Declaration:
        raise SceneError(f"{path}: holds a DOCTYPE or entity declaration, which ParaView state files do not use "
                         f"(entities can expand without bound); remove it") from None
    except (xml.parsers.expat.ExpatError, LookupError, ValueError) as exc:
        raise SceneError(f"{path}: not a valid XML file ({exc})") from None
    return proxies, names


def _number(text, path) -> float:
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise SceneError(f"{path}: a 2D transfer function's property holds {text!r}, not a number") from None
    if not np.isfinite(v):
        raise SceneError(f"{path}: a 2D transfer function's property holds {text!r}; give finite numbers")
    return v


# --- checks --------------------------------------------------------------------------------------


def _checked_table(table, opacity_model: str) -> np.ndarray:
    try:
        t = np.array(table, dtype=np.float64)
    except (ValueError, TypeError):  # ragged or not numbers
        t = np.empty(0)
    if t.ndim != 3 or t.shape[2] != 4 or t.shape[0] < 2 or t.shape[1] < 2:
        raise SceneError("transfer_function.table_2d must be NV x NG nodes of [r, g, b, opacity] (NV, NG at least "
                         "2): rows over value, each a list over gradient magnitude")
    if t.shape[0] * t.shape[1] > _MAX_NODES:
        raise SceneError(f"transfer_function.table_2d has {t.shape[0]} x {t.shape[1]} nodes; at most "
                         f"{_MAX_NODES} in all")
    if not np.isfinite(t).all():
        raise SceneError("transfer_function.table_2d must hold finite numbers (no NaN or Inf)")
    hi = 1.0 if opacity_model == "alpha" else np.inf
    for what, cols, top in (("colour (r, g, b)", t[..., :3], 1.0), ("opacity", t[..., 3:], hi)):
        bad = np.argwhere(((cols < 0) | (cols > top)).any(axis=-1))
        if bad.size:
            i, j = bad[0]
            raise SceneError(f"transfer_function.table_2d[{i}][{j}] has {what} {cols[i, j].tolist()} outside "
                             f"[0, {top:g}]")
    t.setflags(write=False)
    return t


def _checked_range(r, key: str, lowest_floor: int) -> tuple[float, float]:
    """A ``[lo, hi]`` range of finite numbers, ``lo < hi`` (and ``lo >= 0`` for gradient magnitude)."""
    try:
        lo, hi = (float(x) for x in r)
    except (TypeError, ValueError):
        raise SceneError(f"transfer_function.{key} must be [lo, hi], two numbers, got {r!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi and max(abs(lo), abs(hi)) <= 1e38):
        raise SceneError(f"transfer_function.{key} [{lo:g}, {hi:g}]: give finite numbers within +-1e38 (the "
                         f"shader's float32), lo below hi")
    if hi - lo < max(1e-30, 1e-6 * max(abs(lo), abs(hi))):  # the shader maps it to texels in float32
        raise SceneError(f"transfer_function.{key} [{lo:g}, {hi:g}] is too narrow to look up in float32; widen it")
    if lowest_floor and lo < 0:
        raise SceneError(f"transfer_function.{key} starts at {lo:g}; a gradient magnitude is never negative")
    return lo, hi


def _checked_boxes(boxes) -> np.ndarray:
    try:
        b = np.array(boxes, dtype=np.float64)
    except (ValueError, TypeError):
        b = np.empty(0)
    if b.ndim != 2 or b.shape[1] != 8 or len(b) < 1 or len(b) > 4096:
        raise SceneError("transfer_function.boxes_2d must be 1 to 4096 boxes [value, gradient, width, height, r, "
                         "g, b, alpha] (ParaView's)")
    with np.errstate(over="ignore"):
        tops = b[:, 1] + b[:, 3] if b.ndim == 2 and b.shape[1:] == (8,) else b
    if not np.isfinite(b).all() or not np.isfinite(tops).all():
        raise SceneError("transfer_function.boxes_2d must hold finite numbers (each box's top too)")
    bad = np.nonzero((b[:, 2] <= 0) | (b[:, 3] <= 0) | (b[:, 4:] < 0).any(axis=1) | (b[:, 4:] > 1).any(axis=1))[0]
    if bad.size:
        raise SceneError(f"transfer_function.boxes_2d[{bad[0]}] = {b[bad[0]].tolist()}: width and height must be "
                         f"positive, colour and alpha in [0, 1]")
    return b


def _checked_size(size) -> tuple[int, int]:
    try:
        nv, ng = (int(x) for x in size)
    except (TypeError, ValueError):
        raise SceneError(f"transfer_function.size_2d must be [NV, NG], two whole numbers, got {size!r}") from None
    if nv < 2 or ng < 2 or nv * ng > _MAX_NODES:
        raise SceneError(f"transfer_function.size_2d [{nv}, {ng}]: each at least 2, at most {_MAX_NODES} nodes "
                         f"in all")
    return nv, ng

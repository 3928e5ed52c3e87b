"""The categorical transfer function of a label map: :class:`LabelTable`, its default, its GPU form.

A label map holds integers (uint8, uint16 or int16 voxels; float32 voxels that are whole numbers, as an int32
file arrives).  Each label in the table has a colour (linear RGB, non-associated) and an opacity; a label that
is not in the table is transparent, and so is label 0 unless the table lists it.  Opacity follows
:class:`~dvr_gl.transfer_function.TransferFunction`'s models: ``alpha`` (default), the opacity of a layer
``unit_distance`` thick, so ``sigma = -log1p(-alpha) / unit_distance``, with alpha 1 clamped to
:data:`~dvr_gl.transfer_function.ALPHA_MAX` (total opacity stands for the finite extinction
``MAX_OPTICAL_DEPTH / unit_distance``, 16.64 per unit distance, as a transfer function's does); or
``extinction``, sigma itself per world unit.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError, VolumeError
from ..presets.colour import srgb_to_linear
from ..transfer_function import OPACITY_MODELS, extinction_from_alpha

#: Opacity of every label of the default table, alpha per ``unit_distance``: a label region a few unit
#: distances thick hides what lies behind it, a thin one lets it show.
DEFAULT_OPACITY = 0.5
#: The golden angle as a fraction of the hue circle: label ``L``'s default hue is ``L * GOLDEN`` (mod 1), so
#: neighbouring labels are far apart in hue and a label keeps its colour in every scene.
GOLDEN = 0.381966011250105
#: The largest label magnitude of float32 voxels: every integer up to 2^24 is exact in float32.
MAX_FLOAT_LABEL = 2 ** 24
#: Texels per row of the GPU table (:meth:`LabelTable.texture_table`): within every GL's smallest maximum
#: texture width (4096), so a table of 65536 labels is 16 rows.
TABLE_ROW = 4096
#: Voxels counted at a time by :func:`labels_present` (a cache-sized int64 copy: 0.67 s for the frog's 32
#: million voxels where one whole-volume bincount takes 1.5 s and a sort 2.3 s).
COUNT_CHUNK = 1 << 19
#: The widest span of labels a table may list (largest - smallest + 1): its GPU table holds a texel for each
#: (16 MiB at this span), and every 16-bit label map spans at most 98304.
MAX_SPAN = 1 << 20


def default_colors(labels) -> np.ndarray:
    """The default linear colours ``(K, 3)`` of integer labels: hue ``L * GOLDEN`` (mod 1), HSV saturation
    0.75 and value 0.95 and 0.75 alternating with the label (sRGB-encoded, decoded to linear)."""
    out = []
    for label in np.asarray(labels, dtype=np.int64).tolist():
        hue = (label * GOLDEN) % 1.0
        out.append(colorsys.hsv_to_rgb(hue, 0.75, 0.95 if label % 2 else 0.75))
    return srgb_to_linear(np.array(out, dtype=np.float64).reshape(-1, 3))


def check_label_data(data: np.ndarray, name: str = "label map") -> None:
    """Refuse, in one line, voxels that are not labels: float values that are not whole numbers, or beyond
    float32's exact integers."""
    if data.dtype.kind in "iu":
        return
    if data.dtype.kind != "f":
        raise VolumeError(f"{name}: a label map needs integer voxels (uint8, uint16 or int16), got {data.dtype}")
    finite = np.isfinite(data).all()
    if not finite or np.any(np.abs(data) > MAX_FLOAT_LABEL) or np.any(data != np.round(data)):
        raise VolumeError(f"{name}: a label map holds whole numbers, but these float voxels are not (or exceed "
                          f"2^24); give the segmentation's integer file, or render it as a scalar field "
                          f"(volume.role = \"scalar\")")


def labels_present(data: np.ndarray) -> np.ndarray:
    """The distinct labels in ``data``, sorted (int64): counted in one pass for 8- and 16-bit voxels (a sort
    of a large volume costs seconds)."""
    if data.dtype.kind in "iu" and data.dtype.itemsize <= 2:
        info = np.iinfo(data.dtype)
        offset = -int(info.min)
        counts = np.zeros(int(info.max) + offset + 1, np.int64)
        flat = data.ravel()
        for start in range(0, flat.size, COUNT_CHUNK):  # cache-sized: bincount widens each chunk to int64
            chunk = flat[start:start + COUNT_CHUNK]
            counts += np.bincount(chunk.astype(np.int64) + offset if offset else chunk, minlength=len(counts))
        return np.nonzero(counts)[0].astype(np.int64) - offset
    return np.unique(data).astype(np.int64)


@dataclass(frozen=True, eq=False, repr=False)
class LabelTable:
    """Colour and opacity per label (see the module doc).

    Attributes:
        labels: ``(K,)`` int64 label values, strictly increasing.
        colors: ``(K, 3)`` linear RGB in [0, 1].
        opacity: ``(K,)`` alpha per ``unit_distance`` in [0, 1], or sigma per world unit (``opacity_model``).
        unit_distance: world length alpha refers to (> 0).
        opacity_model: ``alpha`` or ``extinction``.
        names: a name per label (from a colour-table file; empty strings where none), for legends.
    """

    labels: np.ndarray
    colors: np.ndarray
    opacity: np.ndarray
    unit_distance: float = 1.0
    opacity_model: str = "alpha"
    names: tuple = ()

    kind = "labels"

    def __post_init__(self):
        labels = np.asarray(self.labels)
        if labels.ndim != 1 or labels.dtype.kind not in "iuf" or not np.all(np.abs(labels) <= MAX_FLOAT_LABEL) \
                or not np.array_equal(labels, np.round(labels)):
            raise SceneError(f"transfer_function.labels: each label must be a whole number within +-2^24 (the "
                             f"labels of a map), got {labels.ravel()[:4].tolist()}")
        labels = labels.astype(np.int64)
        order = np.argsort(labels, kind="stable")
        labels = labels[order]
        if labels.size and np.any(np.diff(labels) == 0):
            dup = int(labels[np.nonzero(np.diff(labels) == 0)[0][0]])
            raise SceneError(f"transfer_function.labels: label {dup} is given twice; keep one row per label")
        colors = np.asarray(self.colors, dtype=np.float64).reshape(-1, 3)
        opacity = np.asarray(self.opacity, dtype=np.float64).reshape(-1)
        if len(colors) != len(labels) or len(opacity) != len(labels):
            raise SceneError(f"transfer_function.labels: {len(labels)} labels, {len(colors)} colours and "
                             f"{len(opacity)} opacities; give one [label, r, g, b, opacity] row per label")
        colors, opacity = colors[order], opacity[order]
        if labels.size and labels[-1] - labels[0] >= MAX_SPAN:
            raise SceneError(f"transfer_function.labels: labels {int(labels[0])} to {int(labels[-1])} span more "
                             f"than {MAX_SPAN} values; list only the labels the map holds")
        if self.opacity_model not in OPACITY_MODELS:
            raise SceneError(f"transfer_function.opacity_model {self.opacity_model!r} is not one of "
                             f"{', '.join(OPACITY_MODELS)}")
        hi = 1.0 if self.opacity_model == "alpha" else np.inf
        _check(colors, 0.0, 1.0, labels, "colour (r, g, b)")
        _check(opacity[:, None], 0.0, hi, labels, "alpha" if self.opacity_model == "alpha" else "extinction")
        u = float(self.unit_distance)
        if not np.isfinite(u) or u <= 0:
            raise SceneError(f"transfer_function.unit_distance must be a positive number, got {u}")
        names = tuple(self.names)[:len(labels)] if self.names else ()
        names = tuple(names[i] for i in order) if len(names) == len(labels) else ()
        for array in (labels, colors, opacity):
            array.setflags(write=False)
        for key, value in (("labels", labels), ("colors", colors), ("opacity", opacity), ("unit_distance", u),
                           ("names", names)):
            object.__setattr__(self, key, value)

    @property
    def extinction(self) -> np.ndarray:
        """sigma per world unit of each listed label ``(K,)``."""
        if self.opacity_model == "alpha":
            return extinction_from_alpha(self.opacity, self.unit_distance)
        return self.opacity.copy()

    def lookup(self, labels) -> tuple[np.ndarray, np.ndarray]:
        """``(colour (..., 3), sigma (...))`` float64 of integer labels; a label not in the table: black and
        transparent."""
        labels = np.asarray(labels, dtype=np.int64)
        k = np.clip(np.searchsorted(self.labels, labels), 0, max(len(self.labels) - 1, 0))
        if not len(self.labels):
            return np.zeros(labels.shape + (3,)), np.zeros(labels.shape)
        found = self.labels[k] == labels
        colour = np.where(found[..., None], self.colors[k], 0.0)
        sigma = np.where(found, self.extinction[k], 0.0)
        return colour, sigma

    def visible(self, labels) -> np.ndarray:
        """Whether each label is in the table with some opacity (where an isosurface of labels is hit)."""
        return self.lookup(labels)[1] > 0

    @property
    def domain(self) -> tuple[float, float]:
        """The smallest and largest listed label (0, 0 for an empty table)."""
        return (float(self.labels[0]), float(self.labels[-1])) if len(self.labels) else (0.0, 0.0)

    def opaque_somewhere(self, lo, hi, margin: float = 0.0) -> np.ndarray:
        """Whether some label with opacity lies in each range ``[lo - margin, hi + margin]`` (arrays), as
        :meth:`TransferFunction.opaque_somewhere <dvr_gl.transfer_function.TransferFunction.opaque_somewhere>`
        answers for values: a sample's label is always one of its 8 taps', so a block whose voxels (with the
        apron its taps reach) hold labels in ``[lo, hi]`` is empty when this is False."""
        shown = self.labels[self.extinction > 0].astype(np.float64)
        lo = np.asarray(lo, dtype=np.float64) - margin
        hi = np.asarray(hi, dtype=np.float64) + margin
        return np.searchsorted(shown, hi, "right") > np.searchsorted(shown, lo, "left")

    # --- the scene table --------------------------------------------------------------------------

    def to_table(self) -> dict:
        """The scene's ``[volume.transfer_function]`` table this resolves from: every label explicit."""
        rows = [[int(k), *map(float, c), float(a)] for k, c, a in zip(self.labels, self.colors, self.opacity)]
        return {"labels": rows, "unit_distance": self.unit_distance, "opacity_model": self.opacity_model}

    to_dict = to_table

    @classmethod
    def from_rows(cls, rows, unit_distance: float = 1.0, opacity_model: str = "alpha") -> "LabelTable":
        """From ``[[label, r, g, b, opacity], ...]`` (the scene key ``transfer_function.labels``, colour linear)."""
        try:
            table = np.array(rows, dtype=np.float64).reshape(len(rows), -1) if len(rows) else np.zeros((0, 5))
        except (TypeError, ValueError, OverflowError):  # not a list, ragged rows, non-numbers
            table = np.empty((0, 0))
        if table.ndim != 2 or table.shape[1] != 5 or not np.isfinite(table).all():
            raise SceneError("transfer_function.labels must be a list of [label, r, g, b, opacity] rows of finite "
                             "numbers (colour linear, 0..1)")
        return cls(table[:, 0], table[:, 1:4], table[:, 4], unit_distance, opacity_model)

    # --- the GPU form -------------------------------------------------------------------------------

    @property
    def first(self) -> int:
        """The label of the GPU table's first texel (the smallest listed label; 0 for an empty table)."""
        return int(self.labels[0]) if len(self.labels) else 0

    @property
    def count(self) -> int:
        """Texels of the GPU table: every label from :attr:`first` to the largest listed (at least 1)."""
        return int(self.labels[-1]) - self.first + 1 if len(self.labels) else 1

    def texture_table(self) -> np.ndarray:
        """The GPU table ``(rows, TABLE_ROW or count, 4)`` float32 of ``(r, g, b, sigma)``: label ``L`` at texel
        ``k = L - first``, row ``k // width``, column ``k % width``; labels the table does not list are zeros."""
        width = min(self.count, TABLE_ROW)
        rows = -(-self.count // width)
        out = np.zeros((rows * width, 4), np.float32)
        if len(self.labels):
            k = self.labels - self.first
            out[k, :3] = self.colors
            out[k, 3] = self.extinction
        return out.reshape(rows, width, 4)

    def uniforms(self, prefix: str = "u_label") -> dict:
        """The uniforms labels.glsl's ``label_class`` reads with the table: ``{prefix}_layout`` = (first label,
        texel count, texels per row)."""
        return {f"{prefix}_layout": (self.first, self.count, min(self.count, TABLE_ROW))}

    def upload(self, ctx):
        """The GPU table as an RGBA32F 2D texture (fetched with texelFetch, never filtered)."""
        import moderngl

        table = self.texture_table()
        tex = ctx.texture((table.shape[1], table.shape[0]), 4, np.ascontiguousarray(table).tobytes(), dtype="f4")
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def __len__(self) -> int:
        return len(self.labels)

    def __repr__(self) -> str:
        shown = ", ".join(str(int(k)) for k in self.labels[:6]) + (", ..." if len(self.labels) > 6 else "")
        return (f"LabelTable({len(self.labels)} labels: {shown}; {self.opacity_model} per "
                f"{self.unit_distance:g} unit{'s' * (self.unit_distance != 1)})")


def _check(cols: np.ndarray, lo: float, hi: float, labels: np.ndarray, what: str) -> None:
    bad = np.nonzero(((cols < lo) | (cols > hi) | ~np.isfinite(cols)).any(axis=1))[0]
    if bad.size:
        i = int(bad[0])
        raise SceneError(f"transfer_function.labels: label {int(labels[i])} has {what} {cols[i].tolist()} outside "
                         f"[{lo:g}, {hi:g}]")


def default_table(data: np.ndarray, unit_distance: float = 1.0, opacity: float = DEFAULT_OPACITY) -> LabelTable:
    """Every label present in ``data`` but 0 with its default colour (:func:`default_colors`) and ``opacity``
    (alpha per ``unit_distance``); label 0, the background, transparent (absent)."""
    present = labels_present(data)
    present = present[present != 0]
    return LabelTable(present, default_colors(present), np.full(len(present), float(opacity)), unit_distance)

"""Colour tables of label maps, read strictly (one line naming the line at fault) and sandboxed.

* 3D Slicer's colour-table file (``.ctbl``, and ``.txt``): lines ``label name R G B A``, each of R, G, B, A an
  integer 0..255, the name without spaces; ``#`` starts a comment.  A procedural (continuous) colour file is
  refused: it colours values, not labels.
* ITK-SNAP's label description file (``.txt``, ``.label``): lines ``IDX R G B A VIS MSH "LABEL"``, R, G, B
  0..255, A the opacity 0..1, VIS 0 hides the label.  A ``.txt`` is told apart from Slicer's by its quoted
  name.
* 3D Slicer's segmentation (``.seg.nrrd``; any ``.nrrd``): the header's segment metadata only,
  ``SegmentN_LabelValue``, ``SegmentN_Color`` (0..1), ``SegmentN_Name``, ``SegmentN_Layer``; segments carry no
  opacity there, so each gets :data:`~dvr_gl.labels.table.DEFAULT_OPACITY`.

Colours in these files are display colours (sRGB-encoded): they are decoded to linear (conventions).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ..errors import SceneError
from ..presets.colour import srgb_to_linear
from ..sandbox import check_input_path
from .table import DEFAULT_OPACITY, MAX_FLOAT_LABEL, LabelTable

#: The largest colour-table file read (bytes): FreeSurfer's and Slicer's largest tables are under 1 MiB.
MAX_TABLE_BYTES = 16 << 20
#: The largest NRRD header read for segment metadata (bytes), as the NRRD reader's.
MAX_HEADER = 1 << 20
SUFFIXES = (".ctbl", ".txt", ".label", ".nrrd")

_SLICER = re.compile(r"^\s*(-?\d+)\s+(\S+)\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)\s*$")
_ITKSNAP = re.compile(r'^\s*(-?\d+)\s+(\d+)\s+(\d+)\s+(\d+)\s+([0-9.eE+-]+)\s+([01])\s+([01])\s+"(.*)"\s*$')


def is_color_table(file) -> bool:
    """Whether ``transfer_function.file`` names a colour table of labels (by its suffix)."""
    return isinstance(file, str) and Path(file).suffix.lower() in SUFFIXES


def read_color_table(path, unit_distance: float = 1.0) -> LabelTable:
    """The colour table in ``path`` (see the module doc) as a :class:`LabelTable`, alpha per ``unit_distance``."""
    path = check_input_path(Path(os.path.expanduser(str(path))), "colour table")
    suffix = path.suffix.lower()
    if suffix == ".nrrd":
        rows = _segment_rows(path)
    elif suffix in (".ctbl", ".txt", ".label"):
        rows = _text_rows(path, suffix)
    else:
        raise SceneError(f"{path}: cannot tell a colour table's format from the suffix {suffix or '(none)'!r}; give "
                         f"a Slicer .ctbl/.txt colour table, an ITK-SNAP label description (.txt, .label) or a "
                         f"Slicer .seg.nrrd")
    if not rows:
        raise SceneError(f"{path}: the colour table lists no label; give a table with at least one")
    labels, colors, opacity, names = zip(*rows)
    if not any(opacity):  # FreeSurfer's LUTs write A = 0 for every label: read as Slicer's, nothing would show
        raise SceneError(f"{path}: every label in the table is transparent (opacity 0), so nothing would show; "
                         f"give the opacities (transfer_function.labels = [[label, r, g, b, opacity], ...])")
    seen = set()
    for label in labels:
        if label in seen:
            raise SceneError(f"{path}: label {label} is listed twice; keep one line per label")
        seen.add(label)
    try:
        return LabelTable(np.array(labels, dtype=np.int64), srgb_to_linear(np.array(colors)), np.array(opacity),
                          unit_distance, names=tuple(names))
    except SceneError as exc:
        raise SceneError(f"{path}: {exc}") from None


def _read_text(path: Path) -> str:
    size = path.stat().st_size
    if size > MAX_TABLE_BYTES:
        raise SceneError(f"{path}: {size} bytes is too large for a colour table (at most {MAX_TABLE_BYTES}); is it "
                         f"the right file?")
    raw = path.read_bytes()
    if b"\0" in raw:
        raise SceneError(f"{path}: a binary file, not a colour table (text lines 'label name R G B A')")
    return raw.decode("utf-8", errors="replace")


def _text_rows(path: Path, suffix: str) -> list:
    """Rows ``(label, srgb (3,), opacity, name)`` of a Slicer or ITK-SNAP text table."""
    text = _read_text(path)
    if text.lstrip().lower().startswith("# color procedural file"):
        raise SceneError(f"{path}: a Slicer procedural colour map colours values, not labels; give a colour table "
                         f"('# Color table file') or use it as a scalar field's transfer function")
    lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1) if line.strip()
             and not line.lstrip().startswith("#")]
    itksnap = suffix == ".label" or "itk-snap" in text[:2000].lower() or any('"' in line for _, line in lines[:1])
    return [_itksnap_row(path, n, line) if itksnap else _slicer_row(path, n, line) for n, line in lines]


def _slicer_row(path: Path, number: int, line: str):
    m = _SLICER.match(line)
    if m is None:
        raise SceneError(f"{path}: line {number} is not 'label name R G B A' (integers, colour and opacity "
                         f"0..255, a name without spaces): {_show(line)}")
    label, name, *rgba = m.groups()
    rgba = [_byte(path, number, v) for v in rgba]
    return _label(path, number, label), [c / 255.0 for c in rgba[:3]], rgba[3] / 255.0, name


def _itksnap_row(path: Path, number: int, line: str):
    m = _ITKSNAP.match(line)
    if m is None:
        raise SceneError(f"{path}: line {number} is not an ITK-SNAP label line 'IDX R G B A VIS MSH \"LABEL\"' "
                         f"(R, G, B 0..255, A 0..1, VIS and MSH 0 or 1): {_show(line)}")
    label, r, g, b, alpha, visible, _mesh, name = m.groups()
    try:
        a = float(alpha)
    except ValueError:
        a = float("nan")
    if not 0.0 <= a <= 1.0:
        raise SceneError(f"{path}: line {number}: the opacity A {alpha!r} is not a number in 0..1")
    rgb = [_byte(path, number, v) / 255.0 for v in (r, g, b)]
    return _label(path, number, label), rgb, a * int(visible), name


def _label(path: Path, number, text: str) -> int:
    """A label value, within what a label map holds (+-2^24: float32's exact integers)."""
    v = int(text)
    if abs(v) > MAX_FLOAT_LABEL:
        raise SceneError(f"{path}: {'line ' if isinstance(number, int) else ''}{number}: label {_show(text)} is "
                         f"beyond +-2^24, more than a label map holds")
    return v


def _byte(path: Path, number: int, value: str) -> int:
    v = int(value)
    if not 0 <= v <= 255:
        raise SceneError(f"{path}: line {number}: colour and opacity are 0..255, got {v}")
    return v


def _show(line: str) -> str:
    return repr(line if len(line) <= 80 else line[:77] + "...")


def _segment_rows(path: Path) -> list:
    """Rows of a Slicer segmentation's segments (``SegmentN_*`` ``key:=value`` header lines)."""
    fields = _key_values(path)
    indices = sorted({int(m.group(1)) for key in fields if (m := re.fullmatch(r"Segment(\d+)_\w+", key))})
    if not indices:
        raise SceneError(f"{path}: its header names no segment (SegmentN_LabelValue, SegmentN_Color); a Slicer "
                         f".seg.nrrd has them: give one, or a .ctbl colour table")
    rows, layers = [], {}
    for i in indices:
        value = fields.get(f"Segment{i}_LabelValue")
        if value is None or not re.fullmatch(r"\s*-?\d+\s*", value):
            raise SceneError(f"{path}: Segment{i}_LabelValue is {'missing' if value is None else _show(value)}; "
                             f"each segment needs an integer label (resave the segmentation with Slicer 4.11 or "
                             f"later)")
        colour = _segment_colour(path, i, fields.get(f"Segment{i}_Color", ""))
        layer = fields.get(f"Segment{i}_Layer", "0").strip()
        layers.setdefault(layer, set()).add(int(value.strip()))
        label = _label(path, f"Segment{i}_LabelValue", value.strip())
        rows.append((label, colour, DEFAULT_OPACITY, fields.get(f"Segment{i}_Name", "").strip()))
    if len(layers) > 1 and len(set.union(*layers.values())) < len(rows):
        raise SceneError(f"{path}: its segments overlap in {len(layers)} layers, which reuse label values; export "
                         f"the segmentation as one label map (Slicer: Export to labelmap) and its colour table")
    return rows


def _segment_colour(path: Path, i: int, text: str) -> list:
    try:
        colour = [float(v) for v in text.split()]
    except ValueError:
        colour = []
    if len(colour) != 3 or not all(0.0 <= c <= 1.0 for c in colour):
        raise SceneError(f"{path}: Segment{i}_Color {_show(text)} is not three numbers in 0..1")
    return colour


def _key_values(path: Path) -> dict:
    """The ``key:=value`` lines of an NRRD header (read up to its blank line, at most :data:`MAX_HEADER`)."""
    with open(path, "rb") as fh:
        head = fh.read(MAX_HEADER)
    if not (head.startswith(b"NRRD000") and head[7:8].isdigit()):
        raise SceneError(f"{path}: not an NRRD file (it must begin NRRD0001 to NRRD0005); give a Slicer .seg.nrrd")
    fields = {}
    for line in head.decode("utf-8", errors="replace").splitlines()[1:]:
        if not line.strip():
            break  # the header ends at its first blank line; the data follow
        key, sep, value = line.partition(":=")
        if sep and not line.startswith("#"):
            if key in fields:
                raise SceneError(f"{path}: header key {key!r} appears twice; keep one")
            fields[key] = value
    return fields

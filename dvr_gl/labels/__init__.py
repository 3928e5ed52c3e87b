"""Label maps (a member of role ``"label"``, :mod:`dvr_gl.fields.layers`): integer voxels classified by a
categorical table, sampled without ever inventing a label (docs/labels.md).

* :class:`~dvr_gl.labels.table.LabelTable`: colour and opacity per label; label 0 and labels it does not list
  are transparent; its GPU form (an RGBA32F table, :meth:`~dvr_gl.labels.table.LabelTable.upload`).
* :func:`~dvr_gl.labels.sampling.label_sample`: the float64 rule (the indicator of each of the 8 taps' labels,
  argmax, ties to the smaller label; or the nearest voxel's) and the indicator's gradient; the GPU's is
  ``dvr_gl/gl/shaders/common/labels.glsl``.
* :func:`~dvr_gl.labels.readers.read_color_table`: Slicer's and ITK-SNAP's colour tables, Slicer's
  ``.seg.nrrd`` segment metadata.
* :func:`label_transfer_function`: a scene's ``[volume.transfer_function]`` of a label map, resolved.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ..errors import SceneError
from .readers import is_color_table, read_color_table
from .sampling import indicator, label_sample
from .table import DEFAULT_OPACITY, LabelTable, check_label_data, default_colors, default_table, labels_present

__all__ = ["DEFAULT_OPACITY", "LabelTable", "check_label_data", "default_colors", "default_table", "indicator",
           "is_color_table", "label_sample", "label_transfer_function", "labels_present", "read_color_table",
           "segment_colours", "as_label_table"]


def label_transfer_function(tf_spec, field, base_dir: Path | str = ".") -> LabelTable:
    """The :class:`LabelTable` of a label map ``field`` (a Volume) from its transfer-function spec: the rows of
    ``labels``, a colour table ``file`` (relative to ``base_dir``), or by default every label present but 0 in
    a colour of its own (:func:`default_table`).  Anything else (points, a preset) is refused in one line."""
    check_label_data(field.data, getattr(field, "name", "label map"))
    for key in ("points", "preset", "name", "stretch"):
        if getattr(tf_spec, key, None) is not None:
            raise SceneError(f"transfer_function.{key} does not apply to a label map ({getattr(field, 'name', '')}, "
                             f"volume.role = \"label\"): give transfer_function.labels = [[label, r, g, b, opacity], "
                             f"...] or a colour table file (.ctbl, ITK-SNAP .txt, .seg.nrrd), or neither for the "
                             f"default colours (docs/labels.md)")
    unit, model = tf_spec.unit_distance, tf_spec.opacity_model
    rows, file = getattr(tf_spec, "labels", None), tf_spec.file
    if rows is not None and file is not None:
        raise SceneError("transfer_function: give labels or file, not both")
    if rows is not None:
        return LabelTable.from_rows(rows, unit, model)
    if model != "alpha":
        raise SceneError("transfer_function.opacity_model = \"extinction\" applies to transfer_function.labels; "
                         "colour tables and the default colours are written in alpha")
    if file is not None:
        path = Path(file).expanduser()
        return read_color_table(path if path.is_absolute() else Path(base_dir) / path, unit)
    return default_table(field.data, unit)


def segment_colours(tf_spec, path):
    """``tf_spec``, or where it names no table and ``path`` is a Slicer segmentation (``.seg.nrrd``), the
    spec of that file's own segment colours (:func:`read_color_table`): a segmentation given as a label map
    brings its colours.  ``path`` as the volume table gives it (relative to the scene file, as a table's file)."""
    if not (isinstance(path, str) and path.lower().endswith(".seg.nrrd")):
        return tf_spec
    if any(getattr(tf_spec, key, None) is not None for key in ("labels", "file", "points", "preset")):
        return tf_spec
    return dataclasses.replace(tf_spec, file=path)


def as_label_table(value, name: str = "label map") -> LabelTable:
    """A label map's table as the Python API takes it: a :class:`LabelTable`, rows ``[[label, r, g, b, opacity],
    ...]`` (colour linear) or a colour table file's path; anything else (a preset's name, a transfer function)
    is refused in one line."""
    if isinstance(value, LabelTable):
        return value
    if isinstance(value, (str, Path)) and (is_color_table(str(value)) or Path(value).expanduser().is_file()):
        return read_color_table(value)
    if isinstance(value, (list, tuple)) or getattr(value, "ndim", None) == 2:
        return LabelTable.from_rows(value)
    raise SceneError(f"{name}: a label map takes a LabelTable, rows [[label, r, g, b, opacity], ...] or a colour "
                     f"table file (.ctbl, ITK-SNAP .txt, .seg.nrrd), not {str(value)[:40]!r} (docs/labels.md)")

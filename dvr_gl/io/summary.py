"""What a loaded field holds, as lines for ``dvr info FILE``: size, type, geometry, orientation, the value
range, a histogram and a transfer function to start from, as a command line to paste."""

from __future__ import annotations

import numpy as np

from ..fields import value_sample

HISTOGRAM_BINS = 8
BAR = 40  # characters of the longest histogram bar
CT_AIR = -900.0  # a minimum below this in an integer volume: Hounsfield units (air is -1000 HU)


def number(value: float, integral: bool) -> str:
    """A value as the data holds it: integers exactly, floats to float32's precision."""
    return str(int(round(value))) if integral else f"{value:.7g}"


def summary_lines(field, source: str) -> list[str]:
    """The lines ``dvr info`` prints for ``field`` (a Volume, a TetMesh or a ParticleSet) read from ``source``."""
    lo, hi = (float(v) for v in field.value_range)
    samples = value_sample(field)  # a mesh: its values; read out of core: an even subsample
    integral = samples.dtype.kind in "iub"
    kind = getattr(field, "kind", "grid")
    lines = [field.describe()]
    if kind == "grid":
        lines += _grid_lines(field)
    else:
        lines.append(f"bounds: {_vec(field.bounds[0])} .. {_vec(field.bounds[1])} (world units)")
    lines.append(f"value range: {number(lo, integral)} .. {number(hi, integral)}"
                 + ("" if kind == "grid" else " (of the interpolated field)" if kind == "particles" else ""))
    if getattr(field, "out_of_core", False):
        lines.append(f"read out of core ({field.nbytes / 2 ** 30:.2f} GiB over renderer.memory_budget_mb = "
                     f"{field.memory_budget_mb:g}): the value range from its block ranges, the histogram and the "
                     f"suggestion from an even subsample of {samples.size} samples")
    lines += histogram_lines(samples, integral)
    lines += suggestion_lines(field, samples, integral, source)
    return lines


def _vec(v) -> str:
    return "(" + ", ".join(f"{float(x):.6g}" for x in v) + ")"


def _grid_lines(v) -> list[str]:
    from ..orientation import axis_letters

    nx, ny, nz = v.dims
    d = np.asarray(v.direction)
    letters = axis_letters(d)
    kind = ("oblique" if letters != letters.upper() else "identity" if np.array_equal(d, np.eye(3))
            else "mirrored" if np.linalg.det(d) < 0 else "turned")
    lines = [f"dims: {nx} x {ny} x {nz} (x, y, z) = {nx * ny * nz} samples",
             f"type: {v.dtype}",
             f"spacing: {_vec(v.spacing)} (world units per sample step, x y z)",
             f"origin: {_vec(v.origin)} (sample (0, 0, 0) in the patient frame, LPS)",
             f"orientation: {letters} ({kind}; the index axes x, y, z point to these patient directions)"]
    for label, row in zip(("direction:", "", ""), d):
        lines.append(f"{label:11s} [{' '.join(f'{x:+.6f}' for x in row)}]")
    lo, hi = v.box
    lines.append(f"box: {_vec(lo)} .. {_vec(hi)} (the volume's own frame)")
    return lines


def histogram_lines(samples: np.ndarray, integral: bool, bins: int = HISTOGRAM_BINS) -> list[str]:
    """A text histogram of the sample values: each bin's range, a bar (linear in the count) and its share."""
    flat = samples.ravel()
    lo, hi = float(flat.min()), float(flat.max())
    if lo == hi:
        return [f"histogram: every sample is {number(lo, integral)}"]
    counts, edges = np.histogram(flat, bins=bins, range=(lo, hi))
    width = max(len(number(e, integral)) for e in edges)
    lines = [f"histogram ({bins} bins of {number((hi - lo) / bins, False)}):"]
    for c, a, b in zip(counts, edges[:-1], edges[1:]):
        bar = "#" * int(round(BAR * c / counts.max()))
        if c and not bar:
            bar = "."
        lines.append(f"  {number(a, integral):>{width}} .. {number(b, integral):>{width}} {bar:<{BAR}} "
                     f"{100.0 * c / flat.size:5.1f}%")
    return lines


def suggestion_lines(field, samples: np.ndarray, integral: bool, source: str) -> list[str]:
    """A transfer function to start from, as a ``dvr render`` command line: a Slicer CT preset when the values
    look like Hounsfield units, else a ramp over the 2nd to 99.8th percentile of the samples above the
    smallest value (the background, usually most of a volume)."""
    lo = float(samples.min())
    command = f"dvr render {source} -o out.png"
    if integral and getattr(field, "kind", "grid") == "grid" and lo <= CT_AIR:
        return ["suggested transfer function (the values look like CT in Hounsfield units; also CT-AAA, "
                "CT-Muscle, CT-Soft-Tissue):",
                f"  {command} --transfer-function CT-Bone"]
    flat = samples.ravel()
    above = flat[flat > lo]
    if above.size == 0:
        above = flat
    a, b = (float(x) for x in np.percentile(above, [2.0, 99.8]))
    if b <= a:
        a, b = float(flat.min()), float(flat.max()) if flat.max() > flat.min() else float(flat.min()) + 1.0
    a, b = number(a, integral), number(b, integral)
    points = f"[[{a}, 0, 0, 0, 0], [{b}, 1, 1, 1, 0.05]]"
    lines = ["suggested transfer function (a grey ramp over the 2nd to 99.8th percentile of the samples above "
             "the minimum; opacity per unit distance, see docs/conventions.md):",
             f"  {command} --set 'transfer_function.points={points}'"]
    if integral and samples.dtype.itemsize == 2 and lo >= 0 and float(samples.max()) > 2000:
        lines.append(f"  or, if it is CT stored as HU + 1024: {command} --transfer-function CT-Bone "
                     f"--rescale-intercept -1024")
    return lines

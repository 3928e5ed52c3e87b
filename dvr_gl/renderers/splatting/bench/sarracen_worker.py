"""sarracen's column density, timed, for ``dvr bench splatting --peers``: run by the peers' interpreter
(``.venv-peers``, where sarracen is installed; it imports nothing of dvr-gl).

It compiles sarracen's numba loops once on 100 particles (not timed: sarracen does not cache them, every
process pays the compile) and checks there that :func:`column` equals ``interpolate_3d_proj``; then it
answers one request a line on stdin, ``{"particles": NPZ, "size": N, "out": NPY}``, with ``{"seconds": S}``
on stdout: the column density of the particles (:func:`column`) over the square window ``x0, y0, width``,
N x N pixels, sarracen's cubic spline (support 2h) sampled at pixel centres; the image, rows from the bottom
(y up), saved to NPY.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np


def column(data, size: int, weight_function, count=None):
    """sarracen's column density: its CPU backend's ``interpolate_3d_projection``, as ``interpolate_3d_proj``
    calls it for the density with ``normalize=False`` (weights ``m``, no minimum h, no rotation), with one
    column-kernel function throughout: ``interpolate_3d_proj`` makes a new numba function per call, which
    recompiles the loop every call."""
    from sarracen.interpolate.cpu_backend import CPUBackend

    x0, y0, width = (float(data[k]) for k in ("x0", "y0", "width"))
    x, y, h, m = (np.ascontiguousarray(data[k][:count], dtype=np.float64) for k in ("x", "y", "h", "m"))
    return CPUBackend.interpolate_3d_projection(x, y, m, h, weight_function, 2.0, size, size, x0, x0 + width,
                                                y0, y0 + width, False)


def as_called(data, size: int, count=None):
    """``interpolate_3d_proj`` itself (to check that :func:`column` computes what it does)."""
    import pandas as pd
    import sarracen

    keys = ("x", "y", "z", "h", "m", "rho")
    frame = sarracen.SarracenDataFrame(pd.DataFrame({k: data[k][:count] for k in keys}), params={})
    x0, y0, width = (float(data[k]) for k in ("x0", "y0", "width"))
    return sarracen.interpolate.interpolate_3d_proj(frame, "rho", x_pixels=size, y_pixels=size, xlim=(x0, x0 + width),
                                                    ylim=(y0, y0 + width), normalize=False, dens_weight=False,
                                                    hmin=False)


def main() -> int:
    import sarracen

    weight_function = sarracen.kernels.CubicSplineKernel().get_column_kernel_func(1000)
    compiled = False
    for line in sys.stdin:
        request = json.loads(line)
        data = np.load(request["particles"])
        if not compiled:
            if not np.allclose(column(data, 16, weight_function, 100), as_called(data, 16, 100), rtol=1e-12, atol=0):
                raise SystemExit("sarracen's backend call differs from interpolate_3d_proj")
            compiled = True
        start = time.perf_counter()
        image = column(data, int(request["size"]), weight_function)
        seconds = time.perf_counter() - start
        np.save(request["out"], image)
        print(json.dumps({"seconds": seconds}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

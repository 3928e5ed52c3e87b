"""The Kaiser-Bessel slice's taps read two by two against one by one, timed interleaved.

    python dvr_gl/renderers/fourier/benchmarks/paired_taps.py [--n 256] [--size 512] [--repeat 5]
        [--interpolation cubic_bspline] [--padding 2] [--modes average xray]

One renderer, the blobs demo at ``N^3`` (the ``dvr bench fourier`` scenes), the average and the
pre-classified X-ray at Fourier's defaults (or the slice and padding given): a view with ``paired_taps``
off (TAPS^3 texel fetches a slice sample), then on ((TAPS / 2)^3 linearly filtered reads), in turn
``repeat`` times after one untimed view each (the spectrum made once); medians of the view's wall time
and of the slice pass (the renderer's ``slice_seconds``: the slice drawn and read back, the shell pass),
and the two images' largest difference.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from dvr_gl.renderers.fourier.bench.measure import scene_for
from dvr_gl.renderers.fourier.renderer import FourierRenderer


def compare(renderer: FourierRenderer, scene, repeat: int) -> dict:
    """Median view and slice seconds of each path, and their images' largest absolute difference."""
    images, views, slices = {}, {False: [], True: []}, {False: [], True: []}
    for paired in (False, True):
        renderer.paired_taps = paired
        images[paired] = renderer.render(scene)
    for _ in range(repeat):
        for paired in (False, True):
            renderer.paired_taps = paired
            start = time.perf_counter()
            renderer.render(scene)
            views[paired].append(time.perf_counter() - start)
            slices[paired].append(renderer.stats["slice_seconds"])
    return {"view": {k: statistics.median(v) for k, v in views.items()},
            "slice": {k: statistics.median(v) for k, v in slices.items()},
            "difference": float(np.abs(images[True].astype(np.float64) - images[False]).max())}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=256)
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--interpolation", help="renderer.slice_interpolation (default: Fourier's)")
    parser.add_argument("--padding", type=float, help="renderer.padding (default: Fourier's)")
    parser.add_argument("--modes", nargs="+", default=["average", "xray"])
    args = parser.parse_args(argv)
    settings = {k: v for k, v in (("slice_interpolation", args.interpolation), ("padding", args.padding)) if v}
    print(f"| {args.n}^3, {args.size}x{args.size} | per tap ms a view | paired ms | ratio | per tap slice ms "
          "| paired slice ms | max difference |\n|---|---:|---:|---:|---:|---:|---:|")
    with FourierRenderer() as renderer:
        for mode in args.modes:
            row = compare(renderer, scene_for(args.n, mode, args.size).with_renderer(**settings), args.repeat)
            view, slice_ = row["view"], row["slice"]
            print(f"| {mode} | {1e3 * view[False]:.0f} | {1e3 * view[True]:.0f} | {view[False] / view[True]:.2f} "
                  f"| {1e3 * slice_[False]:.0f} | {1e3 * slice_[True]:.0f} | {row['difference']:.1e} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

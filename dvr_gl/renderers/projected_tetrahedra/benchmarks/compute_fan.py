"""The Shirley-Tuchman fan built by a compute shader (``pt_fan.comp``) against the geometry shader's.

Issue 44 item 3: ``integration = "shirley-tuchman"`` builds each cell's fan in ``pt.geom``, which llvmpipe
runs on the calling thread; ``ProjectedTetrahedraRenderer.compute_fan = True`` (the default where GL 4.3
has compute shaders) builds the same fan once a frame, after the order, with ``pt_fan.comp`` (llvmpipe's
thread pool) into a vertex buffer drawn in slot order by ``pt_fan.vert``.  This bench times both in one
process, interleaved per frame (compute, geometry, compute, ...; first frames untimed), the exact order,
for each mesh and each of the cells bench's three views at ``--size``:

* ``frame ms`` and ``draw ms`` (``stats``; the draw includes the compute dispatch), medians;
* ``geometry / compute frame``: the ratio of the medians, and the median of the per-frame pairs' ratios;
* the largest difference between the two pictures (any pixel and channel).

    python dvr_gl/renderers/projected_tetrahedra/benchmarks/compute_fan.py --data-dir ../shared/data
        [--meshes comb,bluntfin] [--frames 7] [--size 512]
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

import numpy as np


def measure(pt, scene, frames: int) -> dict:
    """One scene's row: both paths' frame and draw ms (medians), the paired ratio, the largest difference."""
    pictures, times = {}, {True: [], False: []}
    for compute in times:  # programs, adjacency, buffers: untimed
        pt.compute_fan = compute
        pictures[compute] = pt.render(scene)
        if pt.stats["fan"] != ("compute shader" if compute else "geometry shader"):
            raise SystemExit(f"the fan was built by the {pt.stats['fan']}: this context has no compute shaders "
                             "(GL 4.3); nothing to compare")
    for _ in range(frames):
        for compute in times:
            pt.compute_fan = compute
            pt.render(scene)
            times[compute].append((pt.stats["seconds"], pt.stats["draw_seconds"]))
    pt.compute_fan = True
    ms = {k: [1e3 * statistics.median(t[i] for t in v) for i in range(2)] for k, v in times.items()}
    paired = statistics.median(g[0] / c[0] for g, c in zip(times[False], times[True]))
    return {"compute": ms[True], "geometry": ms[False], "paired": paired,
            "diff": float(np.abs(pictures[True] - pictures[False]).max())}


def main(argv=None):
    from dvr_gl.renderers import create_renderer
    from dvr_gl.renderers.projected_tetrahedra.bench.measure import view_scenes

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, required=True, help="the shared data folder")
    parser.add_argument("--meshes", default="comb,bluntfin", help="comma-separated")
    parser.add_argument("--frames", type=int, default=7, help="frames per path (medians)")
    parser.add_argument("--size", type=int, default=512, help="image width and height")
    args = parser.parse_args(argv)
    if args.frames < 1 or args.size < 1:
        raise SystemExit("--frames and --size must be at least 1")
    pt = create_renderer("projected-tetrahedra")
    print("| mesh | view | compute fan frame ms (draw) | geometry shader frame ms (draw) "
          "| geometry / compute frame | median of paired ratios | largest difference |")
    print("|---|---|---:|---:|---:|---:|---:|")
    try:
        for name, az, el, scene in view_scenes(args.meshes.split(","), args.data_dir, args.size):
            r = measure(pt, scene.with_renderer(cell_order="exact", integration="shirley-tuchman"), args.frames)
            c, g = r["compute"], r["geometry"]
            print(f"| {name} | {az:.0f}/{el:.0f} | {c[0]:.0f} ({c[1]:.0f}) | {g[0]:.0f} ({g[1]:.0f}) "
                  f"| {g[0] / c[0]:.2f} | {r['paired']:.2f} | {r['diff']:.1e} |", flush=True)
    finally:
        pt.close()


if __name__ == "__main__":
    main()

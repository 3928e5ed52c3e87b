"""The drawn order grouped by screen tile (``tile_pixels = 64``, the default) against the visibility order as it is.

Issue 44 item 3: llvmpipe bins each triangle into the 64 x 64-pixel tiles it covers and rasterizes a tile's
triangles in the order drawn; in the visibility order consecutive cells lie far apart on screen, so a tile's
triangles are scattered through the binned scene.  ``ProjectedTetrahedraRenderer.tile_pixels`` regroups the
drawn order by tile (:func:`dvr_gl.renderers.projected_tetrahedra.order.tile_coherent`), keeping the order of
the cells that touch any one tile.  This bench times both in one process, interleaved per frame (grouped,
ungrouped, grouped, ...; first frames untimed), the exact order, for each mesh and each of the cells bench's
three views at ``--size``:

* ``frame ms`` (order, draw): medians of ``stats``; the grouping is in the order's time;
* CPU ms of the process a frame (llvmpipe's threads included): medians;
* ``ungrouped / grouped frame``: the ratio of the medians, and the median of the per-frame pairs' ratios;
* the largest difference between the two pictures (any pixel and channel; zero by construction).

    python dvr_gl/renderers/projected_tetrahedra/benchmarks/tile_order.py --data-dir ../shared/data
        [--meshes jaw,post,comb,bluntfin,notch,tetraMesh] [--integration shirley-tuchman] [--frames 7] [--size 512]
        [--tile 64]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

PATHS = [64, 0]  # tile_pixels: grouped (--tile), then as it is


def measure(pt, scene, frames: int) -> dict:
    """One scene's row: both paths' frame, order, draw and CPU ms (medians), the paired ratio, the largest
    difference between the pictures."""
    pictures, times = {}, {tile: [] for tile in PATHS}
    for tile in PATHS:  # programs, adjacency, buffers: untimed
        pt.tile_pixels = tile
        pictures[tile] = pt.render(scene)
        if pt.stats["tiles"] != tile:
            raise SystemExit("the order was not grouped by tile: numba is not installed (the extra 'numba'), or "
                             "the camera reaches the mesh")
    for _ in range(frames):
        for tile in PATHS:
            pt.tile_pixels = tile
            cpu = time.process_time()
            pt.render(scene)
            s = pt.stats
            times[tile].append((s["seconds"], s["order_seconds"], s["draw_seconds"], time.process_time() - cpu))
    pt.tile_pixels = PATHS[0]
    ms = {k: [1e3 * statistics.median(t[i] for t in v) for i in range(4)] for k, v in times.items()}
    paired = statistics.median(u[0] / g[0] for g, u in zip(times[PATHS[0]], times[PATHS[1]]))
    return {"grouped": ms[PATHS[0]], "ungrouped": ms[PATHS[1]], "paired": paired,
            "diff": float(np.abs(pictures[PATHS[0]] - pictures[PATHS[1]]).max())}


def main(argv=None):
    from dvr_gl.renderers import create_renderer
    from dvr_gl.renderers.projected_tetrahedra.bench.measure import view_scenes

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, required=True, help="the shared data folder")
    parser.add_argument("--meshes", default="jaw,post,comb,bluntfin,notch,tetraMesh", help="comma-separated")
    parser.add_argument("--integration", default="shirley-tuchman", choices=("shirley-tuchman", "exact"))
    parser.add_argument("--frames", type=int, default=7, help="frames per path (medians)")
    parser.add_argument("--size", type=int, default=512, help="image width and height")
    parser.add_argument("--tile", type=int, default=64, help="tile_pixels of the grouped order")
    args = parser.parse_args(argv)
    if args.frames < 1 or args.size < 1 or args.tile < 1:
        raise SystemExit("--frames, --size and --tile must be at least 1")
    PATHS[0] = args.tile
    pt = create_renderer("projected-tetrahedra")
    print(f"{args.integration}, {args.size}x{args.size}, tiles of {args.tile} pixels, medians of {args.frames} frames "
          "a path, interleaved\n")
    print("| mesh | view | grouped frame ms (order, draw) | CPU ms | as it is frame ms (order, draw) | CPU ms "
          "| as it is / grouped frame | median of paired ratios | largest difference |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    try:
        for name, az, el, scene in view_scenes(args.meshes.split(","), args.data_dir, args.size):
            r = measure(pt, scene.with_renderer(cell_order="exact", integration=args.integration), args.frames)
            g, u = r["grouped"], r["ungrouped"]
            print(f"| {name} | {az:.0f}/{el:.0f} | {g[0]:.0f} ({g[1]:.0f}, {g[2]:.0f}) | {g[3]:.0f} "
                  f"| {u[0]:.0f} ({u[1]:.0f}, {u[2]:.0f}) | {u[3]:.0f} | {u[0] / g[0]:.2f} | {r['paired']:.2f} "
                  f"| {r['diff']:.1e} |", flush=True)
    finally:
        pt.close()


if __name__ == "__main__":
    main()

"""The Shirley-Tuchman fan built on the host (numba, ``fan.py``) against the geometry shader's (``pt.geom``).

Issue 44 item 3: ``integration = "shirley-tuchman"`` builds each cell's fan (class 1 or 2, the thick
vertex, the exact integral along the thick piece, 3 or 4 triangles) in ``pt.geom``, which llvmpipe
runs on the calling thread; ``ProjectedTetrahedraRenderer.host_fan = True`` builds the same fan in
numba (per cell, in a thread of its own while the order is computed) and draws it with a plain vertex
shader.  This bench times both, interleaved per frame (host, geometry shader, host, ...; medians),
for each shared mesh from the first view of ``dvr bench cells`` at ``--size``:

* ``frame ms`` and ``draw ms`` (``stats``: the draw includes the host fan's wait, indexing and upload);
* ``host wait ms``: what the draw waited for the host fan (its build beyond the order's time, the
  triangles' indices in the order and the uploads);
* ``prebuilt draw ms``: the host fan's draw with the fan already built (what the geometry stage would
  cost with the fan free);
* the largest difference between the two pictures (float32 in ``pt.geom``, float64 on the host).

    python dvr_gl/renderers/projected_tetrahedra/benchmarks/host_fan.py --data-dir ../shared/data
        [--meshes notch,tetraMesh,bluntfin,comb] [--frames 5] [--size 512]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np


def measure(pt, name: str, data_dir: Path, frames: int, size: int) -> dict:
    """One mesh's row: both paths' frame and draw ms (medians), the host fan's wait, the prebuilt draw."""
    from dvr_gl.bench.datasets import shared_mesh
    from dvr_gl.renderers.projected_tetrahedra.fan import HostFan
    from dvr_gl.scene.resolve import load_scene

    keys, mesh = shared_mesh(name, data_dir)
    scene = load_scene(None, {**keys, "camera.azimuth": 30.0, "camera.elevation": 20.0,
                              "renderer.name": "projected-tetrahedra", "image.width": size, "image.height": size})
    scene = scene.with_renderer(cell_order="exact", integration="shirley-tuchman")
    start, finish, waits, prebuilt = HostFan.start, HostFan.finish, [], [None]

    def timed_start(self, *args):  # prebuilt: nothing built, the buffers hold the frame before's fan
        if prebuilt[0] is None:
            start(self, *args)

    def timed_finish(self, order):
        if prebuilt[0] is not None:
            return prebuilt[0]
        begin = time.perf_counter()
        n = finish(self, order)
        waits.append(time.perf_counter() - begin)
        return n

    HostFan.start, HostFan.finish = timed_start, timed_finish
    pt.compute_fan = False  # "gs": the geometry shader's fan (the compute shader's: compute_fan.py)
    try:
        pictures, times = {}, {"host": [], "gs": [], "prebuilt": []}
        for key in times:  # upload, programs, adjacency, numba: untimed
            pt.host_fan = key != "gs"
            pictures[key] = pt.render(scene)
        for _ in range(frames):
            for key in times:
                pt.host_fan = key != "gs"
                prebuilt[0] = 12 * pt.stats["cells_drawn"] if key == "prebuilt" else None
                pt.render(scene)
                times[key].append((pt.stats["seconds"], pt.stats["draw_seconds"]))
    finally:
        HostFan.start, HostFan.finish = start, finish
        pt.host_fan, pt.compute_fan = False, True
    ms = {key: [1e3 * statistics.median(t[i] for t in values) for i in range(2)] for key, values in times.items()}
    return {"mesh": name, "cells": len(mesh.tets), "host": ms["host"], "gs": ms["gs"], "prebuilt": ms["prebuilt"][1],
            "wait": 1e3 * statistics.median(waits), "diff": float(np.abs(pictures["host"] - pictures["gs"]).max())}


def main(argv=None):
    from dvr_gl.renderers import create_renderer

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, required=True, help="the shared data folder")
    parser.add_argument("--meshes", default="notch,tetraMesh,bluntfin,comb", help="comma-separated")
    parser.add_argument("--frames", type=int, default=5, help="frames per path (medians)")
    parser.add_argument("--size", type=int, default=512, help="image width and height")
    args = parser.parse_args(argv)
    pt = create_renderer("projected-tetrahedra")
    print("| mesh | cells | host fan: frame ms (draw) | geometry shader: frame ms (draw) "
          "| geometry shader / host frame | host wait ms | prebuilt draw ms | largest difference |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for name in args.meshes.split(","):
        r = measure(pt, name, args.data_dir, args.frames, args.size)
        host, gs = r["host"], r["gs"]
        print(f"| {name} | {r['cells']} | {host[0]:.0f} ({host[1]:.0f}) | {gs[0]:.0f} ({gs[1]:.0f}) "
              f"| {gs[0] / host[0]:.2f} | {r['wait']:.0f} | {r['prebuilt']:.0f} | {r['diff']:.1e} |", flush=True)


if __name__ == "__main__":
    main()

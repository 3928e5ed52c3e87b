"""The exact visibility order, compiled (numba, ``order_compiled.py``) against numpy (``order.py``).

Issue 44 item 3 asks the compiled order for at least 5x numpy's speed.  For each shared mesh and view
of ``dvr bench cells`` (512x512), the rays the renderer casts (those the GL boundary count picks) are
taken once; then ``VisibilityOrder`` with and without the compiled loops is timed in turn (A B A B
..., CPU seconds of this process, medians), and the two orders are asserted equal cell for cell.

    python dvr_gl/renderers/projected_tetrahedra/benchmarks/order_speed.py --data-dir ../shared/data
        [--meshes comb,post] [--rounds 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

SIZE = 512
VIEWS = ((30.0, 20.0), (120.0, -10.0), (0.0, 90.0))


def _scene(name: str, data_dir: Path, azimuth: float, elevation: float):
    from dvr_gl.bench.datasets import MESHES, mesh_scene_keys
    from dvr_gl.scene.resolve import load_scene

    source, array = MESHES[name]
    path = data_dir / source
    mesh = load_scene(None, {"volume.path": str(path), **({"volume.array": array} if array else {})}).field
    return load_scene(None, {**mesh_scene_keys(path, array, mesh), "camera.azimuth": azimuth,
                             "camera.elevation": elevation, "renderer.name": "projected-tetrahedra",
                             "image.width": SIZE, "image.height": SIZE})


def measure(pt, name: str, data_dir: Path, rounds: int) -> list[dict]:
    """One row a view: rays cast, compiled and numpy CPU ms (medians) and their ratio."""
    from dvr_gl.renderers.projected_tetrahedra.order import VisibilityOrder

    rows, fast, slow = [], None, None
    for azimuth, elevation in VIEWS:
        scene = _scene(name, data_dir, azimuth, elevation)
        pt.render(scene)  # the mesh's textures and adjacency
        textures, orders = pt._mesh_resources(scene.field)
        if fast is None:
            fast, slow = orders, VisibilityOrder(scene.field, compiled_loops=False)
            slow.adjacency = fast.adjacency  # the same faces, computed once
        pixels = pt._gap_pixels(scene, textures, orders)
        img = scene.image
        times = {"compiled": [], "numpy": []}
        results = {}
        for _ in range(rounds):
            for key, order in (("compiled", fast), ("numpy", slow)):
                start = time.process_time()
                results[key] = order(scene.camera, img.width, img.height, "exact", pixels=pixels)
                times[key].append(time.process_time() - start)
        assert np.array_equal(results["compiled"][0], results["numpy"][0]), (name, azimuth, elevation)
        ms = {key: 1e3 * statistics.median(values) for key, values in times.items()}
        rows.append({"mesh": name, "view": f"{azimuth:g}/{elevation:g}", "rays": results["compiled"][1]["rays_cast"],
                     **ms, "ratio": ms["numpy"] / max(ms["compiled"], 1e-9)})
    return rows


def main(argv=None):
    from dvr_gl.renderers import create_renderer

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, required=True, help="the shared data folder")
    parser.add_argument("--meshes", default="bluntfin,comb,post,jaw,notch,tetraMesh", help="comma-separated")
    parser.add_argument("--rounds", type=int, default=5, help="timed calls of each (medians)")
    args = parser.parse_args(argv)
    pt = create_renderer("projected-tetrahedra")
    print("| mesh | view | rays cast | compiled ms | numpy ms | numpy / compiled |")
    print("|---|---|---:|---:|---:|---:|")
    for name in args.meshes.split(","):
        for r in measure(pt, name, args.data_dir, args.rounds):
            print(f"| {r['mesh']} | {r['view']} | {r['rays']} | {r['compiled']:.0f} | {r['numpy']:.0f} | "
                  f"{r['ratio']:.1f} |", flush=True)


if __name__ == "__main__":
    main()

"""The exact visibility order, compiled (numba, ``order_compiled.py``) against numpy (``order.py``).

Issue 44 item 3 asks the compiled order for at least 5x numpy's speed.  For each shared mesh and view
of ``dvr bench cells`` (512x512), the rays the renderer casts (those the GL boundary count picks) are
taken once; then ``VisibilityOrder`` compiled on the cells renumbered for locality, compiled on the
mesh's own numbering and in numpy (on the mesh's numbering) are timed in turn (A B C A B C ..., CPU
seconds of this process, medians), and the orders are asserted equal cell for cell.  The renderer's
default renumbers only a scattered numbering (``order.scattered``): the shared meshes as written run on
their own numbering, the second column; shuffled (``--shuffle``), renumbered, the first.  The
renumbering's cost (once per mesh) is printed after each mesh's rows.  ``--shuffle``: the meshes'
cells shuffled first (a mesh written in a scattered order); ``--frames``: whole frames too, renumbered
and not in turn (wall seconds, medians; the pictures asserted equal).

    python dvr_gl/renderers/projected_tetrahedra/benchmarks/order_speed.py --data-dir ../shared/data
        [--meshes comb,post] [--rounds 5] [--shuffle] [--frames]
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import statistics
import time
from pathlib import Path

import numpy as np

SIZE = 512


def _scene(name: str, data_dir: Path, azimuth: float, elevation: float, shuffle: bool = False):
    from dvr_gl.bench.datasets import shared_mesh
    from dvr_gl.renderers.projected_tetrahedra.bench.measure import view_keys
    from dvr_gl.scene.resolve import load_scene

    keys, _ = shared_mesh(name, data_dir)
    scene = load_scene(None, view_keys(keys, azimuth, elevation, SIZE))
    return dataclasses.replace(scene, field=_shuffled(scene.field)) if shuffle else scene


@functools.lru_cache(maxsize=1)
def _shuffled(mesh):
    """The mesh with its cells in a random order (the same each run), kept for the next view."""
    from dvr_gl.fields.mesh import TetMesh

    cells = np.random.default_rng(0).permutation(len(mesh.tets))
    values = mesh.values[cells] if mesh.association == "cell" else mesh.values
    return TetMesh(mesh.points, mesh.tets[cells], values, mesh.association, mesh.name + " shuffled")


def measure(pt, name: str, data_dir: Path, rounds: int, shuffle: bool = False, frames: bool = False):
    """One row a view: rays cast, compiled (renumbered or not) and numpy CPU ms (medians) and the
    ratios, with ``frames`` the frames' wall ms renumbered and not; and the renumbering's seconds."""
    from dvr_gl.renderers.projected_tetrahedra.bench.measure import VIEWS
    from dvr_gl.renderers.projected_tetrahedra.order import VisibilityOrder

    rows, fast, plain, slow = [], None, None, None
    for azimuth, elevation in VIEWS:
        scene = _scene(name, data_dir, azimuth, elevation, shuffle)
        pt.render(scene)  # the mesh's textures and adjacency
        textures, orders = pt._mesh_resources(scene.field)
        if fast is None:
            fast, plain = orders, VisibilityOrder(scene.field)
            slow = VisibilityOrder(scene.field, compiled_loops=False)
            plain.renumber = slow.renumber = False
            plain.adjacency = slow.adjacency = fast.adjacency  # the same faces, computed once
            fast.renumber = True
            fast.renumbered  # once per mesh: not in the timed calls
        pixels = pt._gap_pixels(scene, textures, orders)
        img = scene.image
        times = {"compiled": [], "plain": [], "numpy": []}
        results = {}
        for _ in range(rounds):
            for key, order in (("compiled", fast), ("plain", plain), ("numpy", slow)):
                start = time.process_time()
                results[key] = order(scene.camera, img.width, img.height, "exact", pixels=pixels)
                times[key].append(time.process_time() - start)
        assert np.array_equal(results["compiled"][0], results["numpy"][0]), (name, azimuth, elevation)
        assert np.array_equal(results["plain"][0], results["numpy"][0]), (name, azimuth, elevation)
        if frames:
            times.update(_frames(pt, scene, fast, rounds))
        ms = {key: 1e3 * statistics.median(values) for key, values in times.items()}
        rows.append({"mesh": name, "view": f"{azimuth:g}/{elevation:g}", "rays": results["compiled"][1]["rays_cast"],
                     **ms, "ratio": ms["numpy"] / max(ms["compiled"], 1e-9),
                     "plain_ratio": ms["numpy"] / max(ms["plain"], 1e-9)})
    return rows, fast.renumbered.seconds


def _frames(pt, scene, orders, rounds: int) -> dict:
    """Whole frames' wall seconds with the order renumbered and not, in turn; the pictures equal."""
    times, pictures = {"frame": [], "frame_plain": []}, {}
    for _ in range(rounds):
        for key, renumber in (("frame", True), ("frame_plain", False)):
            orders.renumber = renumber
            start = time.perf_counter()
            pictures[key] = pt.render(scene)
            times[key].append(time.perf_counter() - start)
    orders.renumber = True
    assert np.array_equal(pictures["frame"], pictures["frame_plain"])
    return times


def main(argv=None):
    from dvr_gl.renderers import create_renderer

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, required=True, help="the shared data folder")
    parser.add_argument("--meshes", default="bluntfin,comb,post,jaw,notch,tetraMesh", help="comma-separated")
    parser.add_argument("--rounds", type=int, default=5, help="timed calls of each (medians)")
    parser.add_argument("--shuffle", action="store_true", help="shuffle the meshes' cells first")
    parser.add_argument("--frames", action="store_true", help="also time whole frames, renumbered and not")
    args = parser.parse_args(argv)
    pt = create_renderer("projected-tetrahedra")
    print("| mesh | view | rays cast | compiled ms, renumbered | compiled ms, mesh's numbering | numpy ms | "
          "numpy / compiled, renumbered | numpy / compiled, mesh's numbering |"
          + (" frame ms, renumbered | frame ms, mesh's numbering |" if args.frames else ""))
    print("|---|---|---:|---:|---:|---:|---:|---:|" + ("---:|---:|" if args.frames else ""))
    for name in args.meshes.split(","):
        rows, seconds = measure(pt, name, args.data_dir, args.rounds, args.shuffle, args.frames)
        for r in rows:
            frames = f" {r['frame']:.0f} | {r['frame_plain']:.0f} |" if args.frames else ""
            print(f"| {r['mesh']}{' shuffled' if args.shuffle else ''} | {r['view']} | {r['rays']} | "
                  f"{r['compiled']:.0f} | {r['plain']:.0f} | {r['numpy']:.0f} | {r['ratio']:.1f} | "
                  f"{r['plain_ratio']:.1f} |{frames}", flush=True)
        print(f"renumbering {name}'s cells (once): {1e3 * seconds:.0f} ms", flush=True)


if __name__ == "__main__":
    main()

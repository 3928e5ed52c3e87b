"""The mesh renderers on a sparse transfer function: opacity only in a narrow band of the scalar
(its 75th to 85th percentile, peaked at the 80th), so that most cells are transparent, beside the
dense one of ``dvr bench cells`` (opacity over the whole range).

    python dvr_gl/renderers/projected_tetrahedra/benchmarks/cells_sparse.py [--data-dir ../shared/data]
        [--meshes bluntfin,comb,post,jaw] [--size 512] [--peers-python PY]

For each mesh, the first view of ``dvr bench cells`` (azimuth 30, elevation 20), one process for
dvr-gl: ``cell-raycast`` and ``projected-tetrahedra`` (exact order; transparent cells ordered but not
drawn) at the median of 3 frames after one untimed, and VTK's projected tetrahedra in the peers'
environment, as the bench runs it; RMS against ``reference-converged`` at half the size.  Prints a
Markdown table (docs/meshes.md, "A sparse transfer function").
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from dvr_gl.bench import datasets, picks
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.projected_tetrahedra.bench import measure as cells
from dvr_gl.scene.resolve import load_scene


def sparse_keys(path: Path, array, mesh) -> dict:
    """The bench's scene keys with the narrow band for a transfer function."""
    keys = datasets.mesh_scene_keys(path, array, mesh)
    lo, mid, hi = (float(q) for q in np.quantile(mesh.values, [0.75, 0.8, 0.85]))
    keys["transfer_function.points"] = [[lo, 0.2, 0.5, 0.9, 0.0], [mid, 0.9, 0.8, 0.3, 0.8], [hi, 0.9, 0.3, 0.2, 0.0]]
    return {**keys, "camera.azimuth": 30.0, "camera.elevation": 20.0}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, default=Path(__file__).resolve().parents[5] / "shared" / "data")
    parser.add_argument("--meshes", default="bluntfin,comb,post,jaw")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--peers-python", default=None, help="the peers' interpreter, for VTK (docs/peers.md)")
    args = parser.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="dvr-cells-sparse-"))
    pt = create_renderer("projected-tetrahedra")
    # the other GL mesh renderer (cell-raycast) on its context, both against the converged reference
    walk = create_renderer(next(n for n in picks.renderers(kind="mesh", gl=True) if n != pt.name), ctx=pt.ctx)
    reference = create_renderer(picks.converged())
    print("| mesh | cells with opacity | `cell-raycast` ms | RMS | `projected-tetrahedra` ms | RMS | VTK ms | VTK RMS |"
          " VTK ms / `cell-raycast` ms |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name in args.meshes.split(","):
        source, array = datasets.MESHES[name]
        path = args.data_dir / source
        if not path.exists():
            print(f"{name}: {path} not found (--data-dir)", file=sys.stderr)
            continue
        mesh = load_scene(None, {"volume.path": str(path), **({"volume.array": array} if array else {})}).field
        keys = sparse_keys(path, array, mesh)
        scene = load_scene(None, {**keys, "image.width": args.size, "image.height": args.size})
        small = load_scene(None, {**keys, "image.width": args.size // 2, "image.height": args.size // 2})
        truth = reference.render(small.with_renderer(name=reference.name)).astype(np.float64)
        measured = {}
        for renderer in (walk, pt):
            timed = cells._timed(renderer, scene.with_renderer(name=renderer.name), 3)
            measured[renderer.name] = (timed["ms"], cells._rms(renderer.render(small.with_renderer(name=renderer.name)),
                                                               truth))
        drawn = pt.stats["cells_drawn"]
        vtk = None
        if args.peers_python:
            vtu = work / f"{name}.vtu"
            cells.write_vtu(mesh, vtu)
            notes = []
            vtk = cells._vtk_row(name, "30/20", mesh, scene, vtu, args.peers_python, args.size, args.size // 2, 3,
                                 truth, work / name, 1800, notes)
            for note in notes:
                print(note, file=sys.stderr)
        (cr_ms, cr_rms), (pt_ms, pt_rms) = measured[walk.name], measured[pt.name]
        vtk_cells = f"{vtk['ms']:.0f} | {vtk['rms']:.1e} | {vtk['ms'] / cr_ms:.2f}" if vtk else "- | - | -"
        print(f"| {name} | {drawn:,} of {len(mesh.tets):,} | {cr_ms:.0f} | {cr_rms:.1e} | {pt_ms:.0f} | {pt_rms:.1e} | "
              f"{vtk_cells} |", flush=True)
    walk.close()
    pt.close()


if __name__ == "__main__":
    main()

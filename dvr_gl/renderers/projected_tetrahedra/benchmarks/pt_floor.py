"""How fast projected tetrahedra could be on this machine: the frame with its fragment work taken away.

Issue 16 asks for as many cells per second as VTK's ``vtkProjectedTetrahedraMapper``.  This bench
renders each shared mesh (first view of ``dvr bench cells``, 512x512) with ``projected-tetrahedra``
as shipped and with two cut-down fragment shaders, each in a process of its own (the program cache
belongs to a context; the cut-down shaders are written to a temporary copy of the renderer's ``shaders/``,
searched before its own):

* ``shipped``: the exact order and the exact transfer-function integral per fragment;
* ``no integral``: the fragment still clips its ray against the cell's planes, and the integral is
  replaced by one exponential (less than any pre-integration table's lookup would cost);
* ``flat``: the fragment shader writes a constant (rasterizing and blending the footprints only);

each with the exact order and with the centroid order (frame, order and draw ms), then VTK's
projected tetrahedra in the same run (``.venv-peers``, as ``dvr bench cells``).  If ``flat`` with the
centroid order is slower than VTK, no change to the fragment work can reach VTK's rate here.

    python dvr_gl/renderers/projected_tetrahedra/benchmarks/pt_floor.py --data-dir ../shared/data
        [--meshes bluntfin,comb,post,jaw]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

VARIANTS = {
    "shipped": None,
    "no integral": ("    frag = transfer_segment(s_front, s_back, len);",
                    "    float a_ = 1.0 - exp(-0.1 * len * (s_front + s_back));\n"
                    "    frag = vec4(0.5 * a_, 0.5 * a_, 0.5 * a_, a_);"),
    "flat": "flat",
}


def _shaders(variant: str, into: Path) -> Path:
    """A copy of projected tetrahedra's own shader folder with ``pt.frag`` cut down to ``variant``."""
    from dvr_gl.renderers.projected_tetrahedra import renderer

    root = into / "shaders"
    shutil.copytree(renderer.SHADERS[0], root)
    change = VARIANTS[variant]
    frag = root / "pt.frag"
    text = frag.read_text()
    if change == "flat":
        text = text[:text.index("void main() {")] + "void main() { frag = vec4(0.01); }\n"
    elif change is not None:
        assert change[0] in text, "pt.frag changed: update the bench's cut"
        text = text.replace(*change)
    frag.write_text(text)
    return root


def _measure(args) -> dict:
    """One variant, one mesh, both orders (run in a child process)."""
    from dvr_gl.bench.datasets import MESHES
    from dvr_gl.bench.datasets import mesh_scene_keys as scene_keys
    from dvr_gl.renderers import create_renderer
    from dvr_gl.renderers.projected_tetrahedra import renderer
    from dvr_gl.renderers.projected_tetrahedra.bench.measure import VIEWS
    from dvr_gl.scene.resolve import load_scene

    work = tempfile.TemporaryDirectory(prefix="dvr-pt-floor-")
    # the cut copy first: the renderer's programs find pt.frag there, the rest in its own roots
    renderer.SHADERS = (_shaders(args.variant, Path(work.name)), *renderer.SHADERS)
    source, array = MESHES[args.mesh]
    path = Path(args.data_dir) / source
    mesh = load_scene(None, {"volume.path": str(path), **({"volume.array": array} if array else {})}).field
    az, el = VIEWS[0]
    keys = {**scene_keys(path, array, mesh), "camera.azimuth": az, "camera.elevation": el,
            "renderer.name": "projected-tetrahedra", "image.width": args.size, "image.height": args.size}
    scene = load_scene(None, keys)
    pt = create_renderer("projected-tetrahedra")
    out = {}
    for order in ("exact", "centroid"):
        s = scene.with_renderer(cell_order=order)
        pt.render(s)
        stats = []
        for _ in range(args.frames):
            pt.render(s)
            stats.append(dict(pt.stats))
        out[order] = {k: 1e3 * statistics.median(x[k] for x in stats)
                      for k in ("seconds", "order_seconds", "draw_seconds")}
    out["cells"] = len(mesh.tets)
    pt.close()
    work.cleanup()
    return out


def _vtk_ms(name, data_dir, size, frames, python) -> float | None:
    from dvr_gl.bench import datasets
    from dvr_gl.renderers.projected_tetrahedra.bench import measure as cells
    from dvr_gl.scene.resolve import load_scene

    source, array = datasets.MESHES[name]
    path = Path(data_dir) / source
    mesh = load_scene(None, {"volume.path": str(path), **({"volume.array": array} if array else {})}).field
    az, el = cells.VIEWS[0]
    keys = datasets.mesh_scene_keys(path, array, mesh)
    scene = load_scene(None, {**keys, "camera.azimuth": az, "camera.elevation": el, "image.width": size,
                              "image.height": size})
    with tempfile.TemporaryDirectory(prefix="dvr-pt-floor-vtk-") as work:
        vtu = Path(work) / f"{name}.vtu"
        cells.write_vtu(mesh, vtu)
        notes = []
        row = cells._vtk_row(name, "", mesh, scene, vtu, python, size, 16, frames, np.zeros((16, 16, 4)),
                             Path(work) / "vtk", 1800.0, notes)
    if row is None:
        print("vtk:", "; ".join(notes), file=sys.stderr)
        return None
    return row["ms"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", default="../shared/data")
    parser.add_argument("--meshes", default="bluntfin,comb,post,jaw")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--frames", type=int, default=3)
    parser.add_argument("--peers-python", default=".venv-peers/bin/python")
    parser.add_argument("--variant", help=argparse.SUPPRESS)
    parser.add_argument("--mesh", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.variant:
        print(json.dumps(_measure(args)))
        return
    print("| mesh | cells | variant | exact: frame ms (order, draw) | centroid: frame ms (order, draw) | VTK ms |")
    print("|---|---:|---|---:|---:|---:|")
    for name in args.meshes.split(","):
        vtk = _vtk_ms(name, args.data_dir, args.size, args.frames, args.peers_python)
        for variant in VARIANTS:
            cmd = [sys.executable, __file__, "--variant", variant, "--mesh", name, "--data-dir", args.data_dir,
                   "--size", str(args.size), "--frames", str(args.frames)]
            res = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.splitlines()[-1])
            cell = lambda o: (f"{res[o]['seconds']:.0f} ({res[o]['order_seconds']:.0f}, "  # noqa: E731
                              f"{res[o]['draw_seconds']:.0f})")
            print(f"| {name} | {res['cells']:,} | {variant} | {cell('exact')} | {cell('centroid')} | "
                  f"{'' if vtk is None else f'{vtk:.0f}'} |", flush=True)


if __name__ == "__main__":
    main()

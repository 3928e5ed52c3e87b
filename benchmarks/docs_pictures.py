"""Pictures of clipping and of opaque meshes in a volume for the docs (a renderer's own pictures are made
by a script in its folder's benchmarks/, listed in benchmarks/README.md).

    python benchmarks/docs_pictures.py [--size 256] [--data-dir ../shared/data] [--out docs/images]

* ``clipping.png``: CThead (the skin preset, shaded; from the shared data when present, else the
  Marschner-Lobb demo) cut by a plane facing the default eye through the centre and cropped by a box
  below its top fifth, left to right: every GL renderer of grids that declares clipping and interpolates the
  voxels (trilinearly), in the registry's order (today the ray caster, slicing3d, slicing2d and shear-warp).
* ``geometry.png``: CThead with the bone preset and two opaque meshes (``[[renderer.geometry]]``): a
  sphere through the skull and a plate beyond it, by the default grid renderer (the ray caster) and the
  renderer of view-aligned slices (slicing3d).

The frame times are printed: one frame each on this machine, after a first one that makes the
encodings, normals and textures.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from dvr_gl.bench import picks
from dvr_gl.bench.pictures import head, timed
from dvr_gl.geometry import icosphere
from dvr_gl.image import side_by_side, write_image
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.scene.model import GeometrySpec

REPO = Path(__file__).resolve().parent.parent


def clipping(size: int, data_dir: Path) -> np.ndarray:
    base, label = head(size, data_dir, "ct-skin")
    forward = np.asarray(base.camera.basis()[0])
    lo, hi = (np.asarray(b, dtype=np.float64) for b in base.field.bounds)
    centre = (lo + hi) / 2.0
    # a plane facing the eye through the centre (the near half cut away), and a box cropping the top
    plane = (*(float(x) for x in forward), -float(forward @ centre))
    box = (tuple(float(x) for x in lo - 1.0),
           tuple(float(x) for x in np.where([0, 0, 1], lo + 0.8 * (hi - lo), hi + 1.0)))
    scene = base.with_renderer(clipping=type(base.renderer.clipping)(planes=[plane], box=box))
    print(f"clipping ({label}):")
    top = []
    # the GL renderers of grids that clip and interpolate the voxels (a kernel splatter of CThead at this size
    # takes many minutes a frame)
    interpolating = set(picks.renderers("filter", "linear", kind="grid", gl=True))
    for name in (n for n in picks.renderers("clipping", kind="grid", gl=True) if n in interpolating):
        with create_renderer(name) as renderer:
            top.append(timed(renderer, scene.with_renderer(name=name), name))
    return side_by_side(top)


def geometry(size: int, data_dir: Path, folder: Path) -> np.ndarray:
    """A sphere through the skull and a floor below it, with the default grid renderer and the renderer of
    view-aligned slices."""
    import meshio

    scene, label = head(size, data_dir, "ct-bone-ivory")
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.field.bounds)
    centre, span = (lo + hi) / 2.0, hi - lo
    points, faces = icosphere(centre + [0.25 * span[0], 0.0, 0.0], 0.3 * span.min())
    meshio.write_points_cells(str(folder / "sphere.obj"), points, [("triangle", faces)])
    z = hi[2] + 0.02 * span[2]  # beyond the head: CThead's up is -z, and the default eye above it
    plate = np.array([[lo[0] - span[0], lo[1] - span[1], z], [hi[0] + span[0], lo[1] - span[1], z],
                      [hi[0] + span[0], hi[1] + span[1], z], [lo[0] - span[0], hi[1] + span[1], z]])
    meshio.write_points_cells(str(folder / "plate.obj"), plate, [("triangle", np.array([[0, 1, 2], [0, 2, 3]],
                                                                                        dtype=np.int32))])
    meshes = [GeometrySpec(path=str(folder / "sphere.obj"), color=(0.2, 0.5, 0.9)),
              GeometrySpec(path=str(folder / "plate.obj"), color=(0.6, 0.6, 0.55))]
    scene = scene.with_renderer(geometry=meshes)
    print(f"geometry ({label}):")
    pictures = []
    sliced = [n for n, p in registry.plugins().items() if p.view_aligned_slices]
    for name in (picks.baseline(), *sliced[:1]):
        with create_renderer(name) as renderer:
            pictures.append(timed(renderer, scene.with_renderer(name=name), name))
    return side_by_side(pictures)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--data-dir", default=str(REPO.parent / "shared" / "data"))
    p.add_argument("--out", default=str(REPO / "docs" / "images"))
    args = p.parse_args(argv)
    out = Path(args.out)
    write_image(out / "clipping.png", clipping(args.size, Path(args.data_dir)), overwrite=True)
    with tempfile.TemporaryDirectory() as folder:
        write_image(out / "geometry.png", geometry(args.size, Path(args.data_dir), Path(folder)), overwrite=True)
    print(f"wrote clipping.png and geometry.png in {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

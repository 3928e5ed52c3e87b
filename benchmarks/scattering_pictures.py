"""Pictures of single scattering for the docs.

    python benchmarks/scattering_pictures.py [--size 320] [--reference-size 96] [--out docs/images]

* ``scattering-shadow.png``: the shadow demo (a ball above a floor, lit from above beside the eye) at
  ``--size``, left to right: the ray caster with the light volume at the demo's 128 nodes, with a
  light volume of 32 nodes (the nodes show on the shadow's edge), and with shadow rays (0.25 voxel,
  as the demo's view rays).
* ``scattering-methods.png``: the same scene at ``--reference-size``, left to right:
  reference-converged (tolerance ``--tolerance``), shadow rays, the light volume (128 nodes) and
  slicing3d's half-angle slicing (256 pixels), each at the demo's 0.25 voxel; below each method, 10x
  its absolute difference from the reference (summed over RGBA, grey).

The timings and RMS errors printed are one frame each on this machine, a light volume's making
included.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from dvr_gl.bench.scattering import measuring
from dvr_gl.image import side_by_side, write_image
from dvr_gl.phantoms import demo_scene
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.renderers import create_renderer
from dvr_gl.scene.resolve import load_scene

REPO = Path(__file__).resolve().parent.parent
DEMO_ROW = ({}, {"renderer.scattering.light_volume_size": 32}, {"renderer.scattering.method": "shadow_rays"})
# each method on the renderer dvr bench scattering measures it with (the ray caster's shadow rays and light
# volume, the demo's method, and 3D slicing's half-angle slicing)
METHODS = (("shadow_rays", {"renderer.scattering.method": "shadow_rays"}),
           ("light_volume", {}),
           ("half_angle", {"renderer.scattering.method": "half_angle", "renderer.scattering.light_buffer_size": 256}))


def _scene(size: int, extra: dict):
    return load_scene(None, {"image.width": size, "image.height": size, **extra}, demo_scene("shadow"))


def _timed(renderer, scene) -> np.ndarray:
    start = time.perf_counter()
    image = renderer.render(scene)
    print(f"  {scene.renderer.name} {scene.renderer.scattering.method}: {time.perf_counter() - start:.2f} s")
    return image


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=320)
    p.add_argument("--reference-size", type=int, default=96)
    p.add_argument("--tolerance", type=float, default=1e-3)
    p.add_argument("--out", default=str(REPO / "docs" / "images"))
    args = p.parse_args(argv)
    out = Path(args.out)
    print("the shadow demo:")
    with create_renderer(measuring("light_volume")) as raycast:
        pictures = [_timed(raycast, _scene(args.size, extra)) for extra in DEMO_ROW]
    write_image(out / "scattering-shadow.png", side_by_side(pictures), overwrite=True)
    print("the methods beside reference-converged:")
    start = time.perf_counter()
    truth = ConvergedReference(_scene(args.reference_size, {"renderer.converged_tolerance": args.tolerance})).render()
    print(f"  reference-converged: {time.perf_counter() - start:.0f} s")
    top, bottom = [truth], [np.zeros_like(truth)]
    for method, extra in METHODS:
        name = measuring(method)
        with create_renderer(name) as renderer:
            image = _timed(renderer, _scene(args.reference_size, {"renderer.name": name, **extra}))
        print(f"    RMS against the reference {np.sqrt(np.mean((image - truth) ** 2)):.2e}")
        top.append(image)
        difference = np.minimum(10.0 * np.abs(image - truth).sum(axis=-1), 1.0)
        bottom.append(np.stack([difference, difference, difference, np.ones_like(difference)], axis=-1))
    figure = side_by_side([side_by_side(top), side_by_side(bottom)], axis=0)
    write_image(out / "scattering-methods.png", figure, overwrite=True)
    print(f"wrote {out / 'scattering-shadow.png'} and {out / 'scattering-methods.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

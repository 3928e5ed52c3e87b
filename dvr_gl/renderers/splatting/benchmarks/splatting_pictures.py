"""Pictures of splatting's schemes for the docs (docs/images/splatting-schemes.png, splatting-particles.png).

    python dvr_gl/renderers/splatting/benchmarks/splatting_pictures.py [--size 192] [--out docs/images]

Row 1, the 64^3 Shepp-Logan phantom under its preset (azimuth 40, elevation 20, perspective, no
shading): image-aligned sheets post-classified, pre-classified, axis-aligned sheets, every splat
alone (``none``, pre-classified), and the CPU reference of the same Gaussian at a tenth of a voxel,
post-classified.  Row 2, a Plummer sphere of 4096 SPH particles splatted (image-aligned,
post-classified), its X-ray (pre-classified), and the CPU reference of the same interpolant.
Each picture over black, side by side; the timings printed are one frame each on this machine.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[4]  # the repository

from dvr_gl.bench import picks  # noqa: E402
from dvr_gl.image import side_by_side, write_image  # noqa: E402
from dvr_gl.phantoms import demo_scene  # noqa: E402
from dvr_gl.renderers import create_renderer  # noqa: E402
from dvr_gl.scene.resolve import load_scene  # noqa: E402

SCHEMES = [("image_aligned", "post"), ("image_aligned", "pre"), ("axis_aligned", "post"), ("none", "pre")]


def grid_row(size: int) -> list[np.ndarray]:
    base = {"volume.demo": "shepp-logan", "volume.size": 64, "image.width": size, "image.height": size,
            "camera.azimuth": 40.0, "camera.elevation": 20.0, "camera.distance": 105.0,
            "renderer.shading.enabled": False, "transfer_function.preset": "shepp-logan", "renderer.name": "splatting",
            "renderer.filter": "gaussian"}
    pictures = []
    with create_renderer("splatting") as splatting:
        for scheme, classification in SCHEMES:
            scene = load_scene(None, {**base, "renderer.sheet_buffer": scheme,
                                      "renderer.classification": classification})
            t = time.perf_counter()
            pictures.append(splatting.render(scene))
            print(f"phantom {scheme} {classification}: {time.perf_counter() - t:.1f} s", flush=True)
    pictures.append(_reference(base, "phantom"))
    return pictures


def particle_row(size: int) -> list[np.ndarray]:
    demo = demo_scene("plummer")
    base = {"volume.demo": "plummer", "volume.size": 32, "image.width": size, "image.height": size,
            "camera.distance": 60.0,
            "renderer.shading.enabled": False, "transfer_function.points": demo["transfer_function"]["points"]}
    pictures = []
    with create_renderer("splatting") as splatting:
        for extra in ({}, {"renderer.compositing": "xray", "renderer.classification": "pre"}):
            t = time.perf_counter()
            pictures.append(splatting.render(load_scene(None, {**base, "renderer.name": "splatting", **extra})))
            print(f"plummer splatting {extra}: {time.perf_counter() - t:.1f} s", flush=True)
    pictures.append(_reference(base, "plummer"))
    return pictures


def _reference(base: dict, name: str) -> np.ndarray:
    """The CPU reference of the same kernel sampled every tenth of a voxel (the converged one took over
    20 minutes on the phantom under its preset, whose narrow peaks it cuts at)."""
    t = time.perf_counter()
    with create_renderer(picks.discrete()) as reference:
        image = reference.render(load_scene(None, {**base, "renderer.name": reference.name,
                                                   "renderer.sample_distance_voxels": 0.1}))
    print(f"{name} reference: {time.perf_counter() - t:.1f} s", flush=True)
    return image


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=192)
    parser.add_argument("--out", default=str(REPO / "docs" / "images"))
    args = parser.parse_args(argv)
    out = Path(args.out)
    write_image(out / "splatting-schemes.png", side_by_side(grid_row(args.size)), overwrite=True)
    write_image(out / "splatting-particles.png", side_by_side(particle_row(args.size)), overwrite=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

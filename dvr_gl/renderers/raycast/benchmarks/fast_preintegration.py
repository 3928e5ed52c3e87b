"""The fast pre-integration table on optically thick segments: CThead bone at 1 voxel.

    python dvr_gl/renderers/raycast/benchmarks/fast_preintegration.py [--data ../shared/data] [--size 128]

Renders the ray caster with the exact and the fast table at a sample distance of
one voxel and prints each one's RMS error against the converged reference (the
comparison of ``dvr bench tradeoff``) and the largest colour in the image, which
an unnormalized fast table pushed to 1.96 (docs/preintegration.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from dvr_gl.bench.datasets import STUDIES as DATASETS
from dvr_gl.bench.tradeoff import converged_truth
from dvr_gl.image import compare_images
from dvr_gl.renderers import create_renderer
from dvr_gl.scene.resolve import load_scene


def cthead_bone(data: Path, size: int):
    name, path, overrides = next(d for d in DATASETS if d[0] == "CThead, bone")
    return load_scene(None, {"volume.path": str(data / path), "image.width": size, "image.height": size,
                             **overrides})


def measure(scene, truth) -> dict:
    """table method -> (RMS against ``truth``, largest colour) at one voxel."""
    out = {}
    with create_renderer("raycast") as renderer:
        for method in ("exact", "fast"):
            image = renderer.render(scene.with_renderer(classification="preintegrated", preintegration=method,
                                                        sample_distance=scene.field.sample_spacing))
            out[method] = (compare_images(image, truth)["rms"], float(image[..., :3].max()))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[5] / "shared" / "data")
    parser.add_argument("--size", type=int, default=128, help="square image size (default 128)")
    args = parser.parse_args()
    scene = cthead_bone(args.data, args.size)
    for method, (rms, brightest) in measure(scene, converged_truth(scene)).items():
        print(f"{method}: RMS {rms:.3e}, largest colour {brightest:.3f}")


if __name__ == "__main__":
    main()

"""The data behind the ray caster's defaults (docs/tradeoff.md, "Why these defaults"): error against
the converged reference and frame time over a grid of sample distance x early-termination threshold,
on the shared datasets and the peers' phantoms.

    python dvr_gl/renderers/raycast/benchmarks/defaults.py [--data-dir ../shared/data] [--cache DIR] [--size 512]
        [--error-size 128]

Error: RMS and PSNR of a ``--error-size`` image against ``reference-converged`` of the same scene
(cached in ``--cache`` by scene, since it takes minutes).  Time: the draw of a ``--size`` image
(median of 3 after a warm-up, acceleration auto as by default), the grid's cases interleaved in
rounds so that the machine's drift hits them alike; ``rel`` is the time over the current default's
(0.5 voxel, 0.99) in the same round.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import statistics
import sys
from pathlib import Path

import numpy as np

from dvr_gl.bench.datasets import STUDIES as DATASETS
from dvr_gl.bench.tradeoff import converged_truth
from dvr_gl.image import compare_images
from dvr_gl.renderers.raycast.renderer import RayCastRenderer
from dvr_gl.scene.resolve import load_scene

DISTANCES = (0.25, 0.5, 1.0, 2.0)           # voxels
THRESHOLDS = (0.99, 1.0 - 1.0 / 255.0, 0.999, 1.0)
PHANTOMS = [(f"{demo} 256^3, viridis", {"volume.demo": demo, "volume.size": 256, "transfer_function.preset": "viridis"})
            for demo in ("marschner-lobb", "blobs")]


def scenes(data_dir: Path):
    out = list(PHANTOMS)
    for name, path, overrides in DATASETS:
        if "bunny" not in name and (data_dir / path).exists():
            out.append((name, {"volume.path": str(data_dir / path), **overrides}))
    return out


def truth(scene, cache: Path, name: str) -> np.ndarray:
    key = hashlib.sha1(json.dumps([name, scene.to_dict() if hasattr(scene, "to_dict") else repr(scene)],
                                  sort_keys=True, default=str).encode()).hexdigest()[:16]
    path = cache / f"converged-{key}.npy"
    if path.exists():
        return np.load(path)
    image = converged_truth(scene)
    cache.mkdir(parents=True, exist_ok=True)
    np.save(path, image)
    return image


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data-dir", default=str(Path(__file__).resolve().parents[5] / "shared" / "data"))
    p.add_argument("--cache", default=str(Path.home() / ".cache" / "dvr-gl" / "converged"))
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--error-size", type=int, default=128)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--only", default=None)
    args = p.parse_args(argv)
    renderer = RayCastRenderer()
    print("scene | voxels | ERT | RMS | PSNR dB | ms | rel. to 0.5/0.99")
    for name, overrides in scenes(Path(args.data_dir)):
        if args.only and args.only.lower() not in name.lower():
            continue
        small = load_scene(None, {**overrides, "image.width": args.error_size, "image.height": args.error_size})
        ref = truth(small, Path(args.cache), name)
        big = load_scene(None, {**overrides, "image.width": args.size, "image.height": args.size}).volume
        grid = [(d, e) for d in DISTANCES for e in THRESHOLDS]
        errors, times = {}, {case: [] for case in grid}
        for d, e in grid:
            case = {"renderer.sample_distance_voxels": d, "renderer.ert_threshold": e}
            image = renderer.render(load_scene(None, {**overrides, **case, "image.width": args.error_size,
                                                      "image.height": args.error_size}).replace(volume=small.volume))
            errors[(d, e)] = compare_images(image, ref)
        for _ in range(args.rounds):
            for d, e in grid:
                scene = load_scene(None, {**overrides, "renderer.sample_distance_voxels": d,
                                          "renderer.ert_threshold": e,
                                          "image.width": args.size, "image.height": args.size}).replace(volume=big)
                renderer.render(scene)
                renderer.render(scene)
                times[(d, e)].append(renderer.stats["gpu_seconds"])
        base = statistics.median(times[(0.5, 0.99)])
        for d, e in grid:
            t = statistics.median(times[(d, e)])
            err = errors[(d, e)]
            print(f"{name} | {d:g} | {e:.4f} | {err['rms']:.2e} | {err['psnr']:.1f} | {1e3 * t:.1f} | {t / base:.2f}",
                  flush=True)
    renderer.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""``--tolerance E`` on narrow transfer-function features of real data: measured RMS / E and cost.

    python dvr_gl/renderers/raycast/benchmarks/tolerance_narrow.py [--data ../shared/data] [--size 64]

For each dataset (a tent of alpha 0.6 over 0.5-5 % of the value range) and
E = 1e-2, 3e-3, 1e-3: the a-priori model's choice alone and with the
a-posteriori check (dvr_gl/renderers/raycast/tolerance.py), each one's RMS error against the
converged reference (computed once per dataset) divided by E; the seconds the
check took; and the cost: the checked choice's frame time against the fastest
sample distance (halving from 2 voxels, same classification and filtering)
that meets E, which needs the reference to find.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from dvr_gl.bench import format_table, median_seconds
from dvr_gl.bench.tradeoff import converged_truth
from dvr_gl.image import compare_images
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.raycast import tolerance
from dvr_gl.scene.resolve import load_scene


def tent(lo: float, hi: float, centre: float, width: float) -> list:
    c, w = lo + centre * (hi - lo), width * (hi - lo)
    return [[lo, 0, 0, 0, 0], [c - w / 2, 0.9, 0.5, 0.2, 0], [c, 1, 0.8, 0.5, 0.6], [c + w / 2, 0.9, 0.5, 0.2, 0],
            [hi, 0, 0, 0, 0]]


DATASETS = [  # name, file, transfer function (value range of the file's type)
    ("lobster, 8-bit, 5 % tent", "regular/lobster.nhdr", tent(0, 255, 0.45, 0.05)),
    ("hydrogen, 8-bit, 2 % tent", "regular/hydrogen_atom.nhdr", tent(0, 255, 0.25, 0.02)),
    ("CThead, 16-bit, 2 % tent", "regular/cthead.nhdr", tent(0, 3272, 0.4, 0.02)),
    ("headsq, 16-bit, 0.5 % tent", "regular/headsq_quarter.nhdr", tent(0, 4095, 0.3, 0.005)),
]
TOLERANCES = (1e-2, 3e-3, 1e-3)
COLUMNS = [("dataset", "dataset", ""), ("tolerance", "E", "g"), ("model", "model alone: RMS / E", ".2f"),
           ("checked", "checked: RMS / E", ".2f"), ("choice", "checked choice", ""), ("check_s", "check s", ".1f"),
           ("cost", "time / fastest meeting E", ".2f")]


def fastest_meeting(renderer, scene, truth, e: float):
    """Frame seconds of the largest sample distance (2 voxels, halved) whose RMS is <= ``e``."""
    voxel = scene.field.sample_spacing
    d = 2.0 * voxel
    while d > voxel / 128:
        case = scene.with_renderer(sample_distance=d)
        if compare_images(renderer.render(case), truth)["rms"] <= e:
            return median_seconds(renderer, case, 3)
        d /= 2.0
    return None


def run(data: Path, size: int):
    rows = []
    with create_renderer("raycast") as renderer:
        for name, path, points in DATASETS:
            if not (data / path).exists():
                print(f"{name}: {data / path} not found, skipped")
                continue
            scene = load_scene(None, {"volume.path": str(data / path), "image.width": size, "image.height": size,
                                      "transfer_function.points": points, "renderer.shading.enabled": False})
            truth = converged_truth(scene)
            for e in TOLERANCES:
                alone, _ = tolerance.apply(scene, e, verify=False)
                start = time.perf_counter()
                checked, choice = tolerance.apply(scene, e)
                seconds = time.perf_counter() - start
                best = fastest_meeting(renderer, checked, truth, e)
                rows.append({"dataset": name, "tolerance": e, "check_s": seconds,
                             "model": compare_images(renderer.render(alone), truth)["rms"] / e,
                             "checked": compare_images(renderer.render(checked), truth)["rms"] / e,
                             "choice": f"{choice.classification} {choice.filtering} "
                                       f"{choice.sample_distance / scene.field.sample_spacing:.3g} vox",
                             "cost": median_seconds(renderer, checked, 3) / best if best else None})
                print(rows[-1], flush=True)
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[5] / "shared" / "data")
    parser.add_argument("--size", type=int, default=64, help="square image size (default 64)")
    args = parser.parse_args()
    print(format_table(run(args.data, args.size), COLUMNS))


if __name__ == "__main__":
    main()

"""``dvr bench accel``: what early termination, empty-space skipping and homogeneity jumps save.

For each dataset and transfer function, the same view is rendered with each
acceleration off and on: samples per ray (counted by the shader), block jumps
per ray, frame time (median of ``repeat`` frames after a warm-up, draw to
``glFinish``, counting off), the speed-up and sample reduction against no
acceleration, and the largest pixel difference from the unaccelerated image
(early termination may change it by up to ``1 - 0.99``; skipping must not).
Also the time to build the min-max pyramid (once per volume) and to classify
its blocks (once per transfer function edit).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ....bench import median_seconds, tick
from ....bench.datasets import STUDIES
from ....scene.resolve import load_scene
from .. import acceleration as accel
from ..renderer import RayCastRenderer

DATASETS = STUDIES  # the shared datasets it measures, each with a transfer function
CONFIGS = [  # label, overrides
    ("none", {"renderer.ert_threshold": 1.0, "renderer.acceleration": "off"}),
    ("early termination", {"renderer.ert_threshold": 0.99, "renderer.acceleration": "off"}),
    ("empty-space skipping (bounds and blocks)", {"renderer.ert_threshold": 1.0, "renderer.acceleration": "on"}),
    ("both (default, auto)", {"renderer.ert_threshold": 0.99, "renderer.acceleration": "auto"}),
    ("both + homogeneity 0.3", {"renderer.ert_threshold": 0.99, "renderer.acceleration": "on",
                                "renderer.homogeneity_tolerance": 0.3}),
]
COLUMNS = [("dataset", "dataset", ""), ("config", "acceleration", ""), ("samples_per_ray", "samples/ray", ".1f"),
           ("jumps_per_ray", "jumps/ray", ".1f"), ("ms", "frame ms", ".1f"), ("speedup", "speed-up", ".2f"),
           ("fewer_samples", "fewer samples", ".2f"), ("max_error", "max |diff|", ".1e")]


def run(data_dir: Path, size: int = 512, repeat: int = 5, datasets=DATASETS, configs=CONFIGS):
    """Rows for the table, and notes (build times, skipped datasets)."""
    rows, notes = [], []
    renderer = RayCastRenderer()
    try:
        for name, path, overrides in datasets:
            if not (data_dir / path).exists() and not list((data_dir / path).parent.glob((data_dir / path).name + "*")):
                notes.append(f"{name}: {data_dir / path} not found, skipped")
                continue
            base = {"volume.path": str(data_dir / path), "image.width": size, "image.height": size, **overrides}
            scene0 = load_scene(None, base)
            start = time.perf_counter()
            pyramid = accel.MinMaxPyramid.build(scene0.volume.data, 8, accel.SUPPORT["linear"])
            built = time.perf_counter() - start
            start = time.perf_counter()
            accel.table_classes(pyramid, scene0.transfer_function.tabulate(4096), "linear", scene0.volume.spacing)
            classified = time.perf_counter() - start
            nx, ny, nz = scene0.volume.dims
            notes.append(f"{name} ({nx}x{ny}x{nz}): min-max pyramid {1e3 * built:.0f} ms, "
                         f"block classes {1e3 * classified:.1f} ms")
            reference = None
            for label, config in configs:
                scene = load_scene(None, {**base, **config}).replace(volume=scene0.volume)
                renderer.count_samples = True
                image = renderer.render(scene)  # warm-up, and the sample count
                stats = dict(renderer.stats)
                renderer.count_samples = False
                renderer.render(scene)
                seconds = median_seconds(renderer, scene, repeat, "gpu_seconds", warm_up=False)
                if reference is None:
                    reference = (image, seconds, stats["samples_per_ray"])
                rows.append({"dataset": name, "config": label, "samples_per_ray": stats["samples_per_ray"],
                             "jumps_per_ray": stats["jumps_per_ray"], "ms": 1e3 * seconds,
                             "speedup": reference[1] / seconds,
                             "fewer_samples": reference[2] / max(stats["samples_per_ray"], 1e-9),
                             "max_error": float(np.abs(image - reference[0]).max())})
    finally:
        renderer.close()
    return rows, notes


# Dense scenes, where no block (or a few) can be skipped: what acceleration may cost there.
def dense_scenes(volume_size: int = 256) -> list[tuple[str, dict]]:
    """(name, overrides): the two phantoms of the peers' benchmark, composite (the viridis preset: an
    opacity ramp over the value range, so that no block is empty) and MIP, and the demo."""
    out = []
    for demo in ("marschner-lobb", "blobs"):
        base = {"volume.demo": demo, "volume.size": volume_size, "renderer.sample_distance_voxels": 1.0}
        out.append((f"{demo} {volume_size}^3, composite", {**base, "transfer_function.preset": "viridis"}))
        out.append((f"{demo} {volume_size}^3, MIP", {**base, "renderer.compositing": "mip"}))
    out.append(("demo (shepp-logan 96^3, shaded)", {"volume.demo": "shepp-logan", "volume.size": 96,
                                                    "renderer.sample_distance_voxels": 0.25,
                                                    "renderer.shading.enabled": True}))
    return out


OVERHEAD_COLUMNS = [("dataset", "scene", ""), ("outside", "outside bounds (estimate)", ".2f"),
                    ("skippable", "skippable (estimate)", ".2f"),
                    ("saved", "samples saved", ".2f"), ("off_ms", "off ms", ".1f"), ("on_ms", "on ms", ".1f"),
                    ("auto_ms", "auto ms", ".1f"), ("on_ratio", "on/off", ".2f"), ("on_worst", "worst", ".2f"),
                    ("auto_ratio", "auto/off", ".2f"), ("auto_worst", "worst", ".2f")]


def overhead(scenes: list[tuple[str, dict]], size: int = 512, views: int = 6, repeat: int = 2) -> list[dict]:
    """Acceleration on and auto against off, in one process: for each of ``views`` azimuths the three
    settings alternate (``repeat`` rounds, the fastest frame of each), and the ratios to off are
    taken per view; the table gives their median and worst.  Also auto's estimates of the fraction
    of samples outside the ray bounds and of the skippable fraction inside them, and the samples on
    saves (counted by the shader), as medians over the views."""
    import statistics

    rows = []
    renderer = RayCastRenderer()
    try:
        for name, overrides in scenes:
            base = {"image.width": size, "image.height": size, "camera.elevation": 20.0, **overrides}
            volume = load_scene(None, base).volume
            ratios = {"on": [], "auto": []}
            ms = {"on": [], "off": [], "auto": []}
            estimates, outside, saved = [], [], []
            for view in range(views):
                azimuth = 30.0 + 360.0 * view / views
                scenes_ = {mode: load_scene(None, {**base, "camera.azimuth": azimuth,
                                                   "renderer.acceleration": mode}).replace(volume=volume)
                           for mode in ("off", "on", "auto")}
                renderer.count_samples = True
                counted = {}
                for mode in ("off", "on", "auto"):  # warm-up: programs, textures, block classes
                    renderer.render(scenes_[mode])
                    counted[mode] = renderer.stats
                renderer.count_samples = False
                estimates.append(counted["auto"]["skippable_estimate"] or 0.0)
                outside.append(counted["auto"]["outside_bounds_estimate"] or 0.0)
                saved.append(1.0 - counted["on"]["samples_per_ray"] / max(counted["off"]["samples_per_ray"], 1e-9))
                best = {mode: float("inf") for mode in scenes_}
                for _ in range(repeat):
                    for mode, scene in scenes_.items():
                        renderer.render(scene)
                        best[mode] = min(best[mode], renderer.stats["gpu_seconds"])
                        tick()
                for mode in ms:
                    ms[mode].append(1e3 * best[mode])
                for mode in ratios:
                    ratios[mode].append(best[mode] / best["off"])
            rows.append({"dataset": name, "outside": statistics.median(outside),
                         "skippable": statistics.median(estimates),
                         "saved": statistics.median(saved),
                         **{f"{m}_ms": statistics.median(v) for m, v in ms.items()},
                         **{f"{m}_ratio": statistics.median(v) for m, v in ratios.items()},
                         **{f"{m}_worst": max(v) for m, v in ratios.items()}})
    finally:
        renderer.close()
    return rows

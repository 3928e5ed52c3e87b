"""``dvr bench quality``: error against the converged reference versus samples, for a narrow spike.

The classic claim for pre-integrated classification: a transfer function with a
narrow feature needs far fewer samples (or slices) than post-classification for
the same quality, because the table integrates the feature exactly between two
samples while point samples must land on it.  Measured here on the
Marschner-Lobb signal (41^3, the classic filter test) with an extinction spike
(a tent 2 % or 0.5 % of the value range wide at its base): for the ray caster
and 3D slicing, post-classified and pre-integrated (exact and fast tables), at
sample spacings from 4 voxels down to 1/32, the RMS error against the converged
reference; then, for each error level, the sample spacing each method needs
(interpolated log-log between the measured spacings) and their ratio.

The pre-integration table is sized so that the spike spans at least 5 of its
nodes (256 for 2 %, 1024 for 0.5 %): a coarser table smears the spike and its
error, not the sampling's, sets the floor.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..image import compare_images
from ..preintegration import preintegrate
from ..reference.converged import ConvergedReference
from ..renderers import create_renderer, registry
from ..scene.resolve import load_scene
from . import converged, picks, tick

WIDTHS = (0.02, 0.005)
SPACINGS = (4.0, 2.0, 1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125)
LEVELS = (3e-2, 1e-2, 3e-3)
COLUMNS = [("renderer", "renderer", ""), ("classification", "classification", ""),
           ("spacing", "spacing (voxels)", "g"), ("rms", "RMS error", ".2e"), ("psnr", "PSNR dB", ".1f"),
           ("ms", "GPU ms", ".1f")]


def spike(width: float, peak: float = 2.0) -> list:
    """Transfer function points: dim orange, extinction 0 except a tent of ``peak`` (per world unit)
    centred on 0.5 and ``width`` wide at its base (the signal's range is [0, 1])."""
    return [[0.0, 1.0, 0.5, 0.2, 0.0], [0.5 - width / 2, 1.0, 0.5, 0.2, 0.0], [0.5, 1.0, 0.6, 0.3, peak],
            [0.5 + width / 2, 1.0, 0.5, 0.2, 0.0], [1.0, 1.0, 0.5, 0.2, 0.0]]


def table_size(width: float) -> int:
    """The smallest power of two, at least 256, whose node spacing puts 5 nodes across the spike."""
    return max(256, 2 ** math.ceil(math.log2(5.0 / width)))


def base_scene(size: int, volume_size: int, width: float = WIDTHS[0]) -> dict:
    # peak 0.04 / width: the area under the tent (extinction times value) is the same for every width
    return {"volume.demo": "marschner-lobb", "volume.size": volume_size, "image.width": size,
            "image.height": size, "transfer_function.points": spike(width, 0.04 / width),
            "transfer_function.opacity_model": "extinction", "renderer.ert_threshold": 1.0,
            "renderer.acceleration": False, "renderer.lut_size": 4097,
            "renderer.preintegration_size": table_size(width), "camera.azimuth": 30.0, "camera.elevation": 25.0}


def methods() -> list[tuple[str, str]]:
    """(renderer, classification): the GPU grid renderers with a sample distance and pre-integration (the ray
    caster, 3D slicing), post-classified and pre-integrated; the baseline also with the fast table."""
    out = []
    for name in picks.renderers("sample_distance", kind="grid", gl=True):
        if "preintegrated" in registry.plugin(name).choices("classification"):
            fast = [(name, "preintegrated fast")] if name == picks.baseline() else []
            out += [(name, "post"), (name, "preintegrated"), *fast]
    return out


def run(size: int = 128, volume_size: int = 41, width: float = WIDTHS[0], spacings=SPACINGS, methods=methods,
        tolerance: float = 1e-5):
    """Rows of the table, the summary lines and the table build times for one spike width (``methods``: the
    (renderer, classification) pairs, or a function giving them)."""
    base = base_scene(size, volume_size, width)
    truth = ConvergedReference(load_scene(None, {**base, "renderer.converged_tolerance": tolerance}))
    truth = converged(truth, float64=True).astype(np.float32)
    rows = []
    renderers = {}
    try:
        for name, classification in (methods() if callable(methods) else methods):
            if name not in renderers:
                renderers[name] = create_renderer(name)
            fast = classification.endswith("fast")
            for d in spacings:
                scene = load_scene(None, {**base, "renderer.sample_distance_voxels": d,
                                          "renderer.classification": classification.split()[0],
                                          "renderer.preintegration": "fast" if fast else "exact"})
                r = renderers[name]
                r.render(scene)                      # builds tables and programs
                image = r.render(scene)              # timed
                tick()
                err = compare_images(image, truth)
                rows.append({"renderer": name, "classification": classification, "spacing": d,
                             "rms": err["rms"], "psnr": err["psnr"], "ms": 1e3 * r.stats["gpu_seconds"]})
    finally:
        for r in renderers.values():
            r.close()
    return rows, summary(rows), build_times(base)


def build_times(base: dict) -> dict:
    """Seconds to build each kind of pre-integration table for this scene (one segment length)."""
    scene = load_scene(None, base)
    n = scene.renderer.preintegration_size
    out = {}
    for method in ("exact", "fast"):
        start = time.perf_counter()
        preintegrate(scene.transfer_function, scene.renderer.sample_distance, n, method, scene.renderer.lut_size,
                     reuse=False)  # the build, not a table kept from the renders before
        out[method] = time.perf_counter() - start
    return out


def spacing_for(rows, renderer: str, classification: str, level: float) -> float | None:
    """The largest spacing at which the error reaches ``level``: the first crossing from coarse to
    fine, interpolated linearly in log(spacing) and log(error); None if it is never reached."""
    curve = sorted(((r["spacing"], r["rms"]) for r in rows
                    if r["renderer"] == renderer and r["classification"] == classification), reverse=True)
    for i, (d, e) in enumerate(curve):
        if e > level:
            continue
        if i == 0:
            return d
        d0, e0 = curve[i - 1]
        t = math.log(e0 / level) / math.log(e0 / e)
        return math.exp(math.log(d0) + t * (math.log(d) - math.log(d0)))
    return None


def summary(rows) -> list[str]:
    """For each error level and renderer: the spacing each classification needs and the ratio."""
    lines = []
    finest = min(r["spacing"] for r in rows)
    for level in LEVELS:
        for name in sorted({r["renderer"] for r in rows}):
            post = spacing_for(rows, name, "post", level)
            pre = spacing_for(rows, name, "preintegrated", level)
            if pre is None:
                lines.append(f"RMS <= {level:g}, {name}: neither reaches it by {finest:g} voxel"
                             if post is None else f"RMS <= {level:g}, {name}: post-classified at {post:.3g} voxel; "
                             f"pre-integrated not by {finest:g} voxel")
            elif post is None:
                lines.append(f"RMS <= {level:g}, {name}: pre-integrated at {pre:.3g} voxel; post-classified "
                             f"not by {finest:g} voxel: more than {pre / finest:.3g}x fewer samples")
            else:
                verdict = f"{pre / post:.3g}x fewer samples" if pre >= post else f"{post / pre:.3g}x more samples"
                lines.append(f"RMS <= {level:g}, {name}: pre-integrated at {pre:.3g} voxel, post-classified at "
                             f"{post:.3g} voxel: {verdict}")
    return lines

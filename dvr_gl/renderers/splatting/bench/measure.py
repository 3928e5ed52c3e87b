"""``dvr bench splatting``: the splatting renderer's schemes on the demo or the shared datasets.

Per dataset (and an SPH particle set: a Plummer sphere, its own cubic-spline kernels, no axis-aligned
sheets and no ray caster beside it) and scheme (sheet buffer and classification, and image-aligned post-classified
sheets shaded by the scene's lights): the frame time (median after a
warm-up), the splats drawn (instances over all sheets), culled, skipped behind opaque pixels (early
termination) and the sheets; the error against
its same-slabs reference (the oracle: float32 and the tables) and the RMS against the converged
reference of the same kernel and classification (what the scheme's discretization costs); and
beside them the ray caster (trilinear, against its own converged reference) at the largest sample
distance that is at least as accurate as image-aligned sheets post-classified, the two then timed
again frame by frame in turn (under the same load) and the ratio of their medians.  Then the
45-degree study: the largest change of each image between azimuth 45 - 0.01 and 45 + 0.01 (where
axis-aligned sheets switch axes) and 30 +- 0.01 (no switch), beside the converged image's own.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ....bench import converged, median_seconds
from ....bench.picks import baseline
from ....image import compare_images
from ....reference.converged import ConvergedReference
from ....scene.resolve import load_scene
from ... import create_renderer, registry
from ..oracle import oracle as same_slabs

BASELINE = baseline()  # the renderer set beside at equal error (the ray caster): the default renderer of grids
SCHEMES = [("image_aligned", "post"), ("image_aligned", "pre"), ("axis_aligned", "post"), ("none", "pre"),
           ("image_aligned", "post-shaded")]  # shaded: the default lights, screen-space gradients of the slab means
RAYCAST_DISTANCES = (4.0, 2.0, 1.0, 0.5, 0.25, 0.125)
STUDY_ANGLES = (30.0, 45.0)
STUDY_STEP = 0.01
COLUMNS = [("dataset", "dataset", ""), ("scheme", "sheet buffer", ""), ("classification", "classification", ""),
           ("ms", "frame ms", ".0f"), ("drawn", "splats drawn", ",d"), ("culled", "culled", ",d"),
           ("skipped", "skipped", ",d"),
           ("sheets", "sheets", "d"), ("oracle", "max vs oracle", ".1e"), ("rms", "RMS vs converged", ".2e"),
           ("baseline", f"{BASELINE} at equal RMS", ""), ("ratio", f"x {BASELINE}", ".0f")]
STUDY_COLUMNS = [("angle", "azimuth", "g"), ("image_aligned", "image-aligned change", ".2e"),
                 ("axis_aligned", "axis-aligned change", ".2e"), ("converged", "converged change", ".2e")]


def base_overrides(size: int) -> dict:
    return {"renderer.name": "splatting", "renderer.filter": "gaussian", "renderer.shading.enabled": False,
            "image.width": size, "image.height": size}


def run(scenes, size: int = 128, repeat: int = 3, progress=None, shaded: bool = True):
    """Rows of the schemes' table for ``scenes`` (``(name, overrides)``); ``shaded=False`` leaves out the
    shaded scheme, whose converged reference is the slowest by far."""
    rows = []
    splatting, raycast = create_renderer("splatting"), create_renderer(BASELINE)
    try:
        for name, overrides in scenes:
            base = load_scene(None, {**base_overrides(size), **overrides})
            particles = base.field.kind == "particles"
            if particles:  # their own kernel; no voxel planes to stack, no ray caster to compare with
                base = base.with_renderer(filter="m4")
            truth = {}
            for scheme, label in SCHEMES:
                if (particles and scheme == "axis_aligned") or (not shaded and label.endswith("shaded")):
                    continue
                classification = label.split("-")[0]
                scene = base.with_renderer(sheet_buffer=scheme, classification=classification)
                if label.endswith("shaded"):
                    scene = scene.with_renderer(shading=dataclasses.replace(scene.renderer.shading, enabled=True))
                if label not in truth:
                    truth[label] = converged(ConvergedReference(scene.with_renderer(converged_tolerance=1e-4)))
                ms = 1e3 * median_seconds(splatting, scene, repeat)
                image = splatting.render(scene)
                stats = splatting.stats
                row = {"dataset": name, "scheme": scheme, "classification": label, "ms": ms,
                       "drawn": stats.get("splats_drawn", stats["splats"]), "culled": stats["culled"],
                       "skipped": stats.get("skipped", 0), "sheets": stats.get("sheets", 0),
                       "oracle": float(np.abs(_unterminated(splatting, scene) - same_slabs(scene)).max()),
                       "rms": compare_images(image, truth[label])["rms"]}
                if (scheme, label) == ("image_aligned", "post"):
                    row["baseline"] = "-" if particles else _raycast_at(raycast, base, row["rms"], repeat)
                    if isinstance(row["baseline"], tuple):  # both timed again, frame by frame in turn
                        case, distance = row["baseline"]
                        row["ms"], ms = interleaved(splatting, scene, raycast, case, repeat)
                        row["baseline"], row["ratio"] = f"{ms:.0f} ms at {distance:g} voxel", row["ms"] / ms
                rows.append(row)
                if progress:
                    progress(row)
    finally:
        splatting.close()
        raycast.close()
    return rows


def _unterminated(splatting, scene) -> np.ndarray:
    """The image without early termination (the oracle terminates nothing)."""
    if scene.renderer.ert_threshold >= 1.0 or scene.renderer.compositing != "emission_absorption":
        return splatting.render(scene)
    image = splatting.render(scene.with_renderer(ert_threshold=1.0))
    return image


def interleaved(first, a, second, b, repeat: int) -> tuple[float, float]:
    """Median frame times (ms) of ``first`` rendering ``a`` and ``second`` rendering ``b``, one frame of each
    in turn (after a warm-up of each): both under the same load."""
    first.render(a)
    second.render(b)
    times = []
    for _ in range(repeat):
        first.render(a)
        second.render(b)
        times.append((first.stats["seconds"], second.stats["seconds"]))
    return tuple(1e3 * float(np.median(t)) for t in zip(*times))


def _raycast_at(raycast, scene, rms: float, repeat: int):
    """The ray caster's scene ``(case, distance)`` at the largest sample distance whose RMS against its own
    (trilinear) converged reference is at most ``rms``; a note where there is none."""
    linear = scene.with_renderer(name=BASELINE, filter="linear")
    truth = converged(ConvergedReference(linear.with_renderer(converged_tolerance=1e-4)))
    for d in RAYCAST_DISTANCES:
        case = linear.with_renderer(sample_distance_voxels=d)
        if registry.refusal(case, BASELINE):
            return "-"
        if compare_images(raycast.render(case), truth)["rms"] <= rms:
            return case, d
    return f"not reached at {RAYCAST_DISTANCES[-1]:g} voxel"


def study(overrides: dict, size: int = 48):
    """Rows of the 45-degree study (elevation 0, post-classified)."""
    base = {**base_overrides(size), **overrides, "camera.elevation": 0.0, "renderer.converged_tolerance": 1e-5}
    rows = []
    with create_renderer("splatting") as splatting:
        for angle in STUDY_ANGLES:
            views = [{"camera.azimuth": angle + s} for s in (-STUDY_STEP, STUDY_STEP)]
            row = {"angle": angle}
            for scheme in ("image_aligned", "axis_aligned"):
                a, b = (splatting.render(load_scene(None, {**base, **v, "renderer.sheet_buffer": scheme}))
                        for v in views)
                row[scheme] = float(np.abs(a - b).max())
            a, b = (converged(ConvergedReference(load_scene(None, {**base, **v})), float64=True) for v in views)
            row["converged"] = float(np.abs(a - b).max())
            rows.append(row)
    return rows


def plummer_scene(particles: int) -> tuple[str, dict]:
    """The Plummer demo of about ``particles`` particles, with its transfer function."""
    from ....phantoms import demo_scene

    size = max(2, 2 * round(particles ** (1.0 / 3.0)))
    demo = demo_scene("plummer")
    return (f"Plummer, {(size // 2) ** 3} SPH particles",
            {"volume.demo": "plummer", "volume.size": size,
             "transfer_function.points": demo["transfer_function"]["points"]})

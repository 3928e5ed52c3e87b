"""``dvr bench fourier``: Fourier volume rendering against the ray caster, per view and per volume.

Per volume size ``N`` (the blobs demo, ``N^3``: dense, every value positive) and mode (the average and the
pre-classified X-ray), orthographic: the pre-processing (the channels, ghost layers, pre-multiplication,
padding and the 3D transform, once) and its spectrum's size; the time per view (the slice in GL, the
inverse 2D transform and the classification on the host: median after a warm-up) at the image size;
the ray caster at its defaults at the same size; and at a smaller image, the RMS of both against
reference-converged, and the ray caster's time at the largest sample distance as accurate as Fourier
rendering.
"""

from __future__ import annotations

import statistics

from ....bench import converged, median_seconds
from ....bench.picks import baseline
from ....image import compare_images
from ....reference.converged import ConvergedReference
from ....scene.resolve import load_scene
from ... import create_renderer

DISTANCES = (2.0, 1.0, 0.5, 0.25, 0.125)
BASELINE = baseline()  # the renderer set beside (the ray caster): the default renderer of grids
COLUMNS = [("n", "N", "d"), ("mode", "mode", ""), ("pre_s", "pre-processing s", ".2f"),
           ("spectrum_mb", "spectrum MB", ".0f"), ("fft", "transform", ""), ("view_ms", "fourier ms/view", ".1f"),
           ("raycast_ms", f"{BASELINE} ms (defaults)", ".1f"), ("speedup", "speed-up", ".1f"),
           ("rms", "fourier RMS", ".2e"), ("raycast_rms", f"{BASELINE} RMS (defaults)", ".2e"),
           ("equal", f"{BASELINE} at fourier's RMS", "")]


def scene_for(n: int, mode: str, size: int):
    return load_scene(None, {"volume.demo": "blobs", "volume.size": n, "renderer.name": "fourier",
                             "renderer.compositing": mode, "renderer.classification": "pre",
                             "renderer.shading.enabled": False, "camera.projection": "orthographic",
                             "image.width": size, "image.height": size})


def run(sizes, size: int = 512, error_size: int = 128, repeat: int = 3, progress=None) -> list[dict]:
    rows = []
    fourier, raycast = create_renderer("fourier"), create_renderer(BASELINE)
    try:
        for n in sizes:
            for mode in ("average", "xray"):
                scene = scene_for(n, mode, size)
                fourier.render(scene)  # pre-processing
                row = {"n": n, "mode": mode, "pre_s": fourier.stats["preprocess_seconds"],
                       "spectrum_mb": fourier.stats["spectrum_bytes"] / 2 ** 20, "fft": fourier.stats["fft"]}
                fourier.render(scene)  # a warm-up view (the program, the targets)
                views = []
                for _ in range(repeat):
                    fourier.render(scene)
                    views.append(fourier.stats["view_seconds"])
                row["view_ms"] = 1e3 * statistics.median(views)
                ray = scene.with_renderer(name=BASELINE)
                row["raycast_ms"] = 1e3 * median_seconds(raycast, ray, repeat)
                row["speedup"] = row["raycast_ms"] / row["view_ms"]
                small = scene_for(n, mode, error_size)
                truth = converged(ConvergedReference(small.with_renderer(converged_tolerance=1e-4)))
                row["rms"] = compare_images(fourier.render(small), truth)["rms"]
                row["raycast_rms"] = compare_images(raycast.render(small.with_renderer(name=BASELINE)), truth)["rms"]
                row["equal"] = _raycast_at(raycast, ray, small.with_renderer(name=BASELINE), truth, row["rms"], repeat)
                rows.append(row)
                if progress:
                    progress(row)
    finally:
        fourier.close()
        raycast.close()
    return rows


SHARED_COLUMNS = [("dataset", "dataset", ""), ("mode", "mode", ""), ("pre_s", "pre-processing s", ".2f"),
                  ("view_ms", "ms/view", ".1f"), ("rms_rel", "RMS / image max", ".2e"), ("max", "max", ".2e"),
                  ("silhouette", "max off the silhouette", ".2e"), ("rms_wide", "RMS, 6 taps, bandwidth 2", ".2e")]


def shared(scenes, size: int = 128, progress=None) -> list[dict]:
    """The accuracy study: each shared dataset (``(name, overrides)``) in both modes at its defaults
    (the trilinear field, the plugin's slice settings), against reference-converged of the same
    scene: RMS over the image's maximum, the largest error, the largest error two pixels or more inside
    the box's silhouette, and the RMS of the accurate settings: the slice's frequencies reaching twice the
    voxels' Nyquist limit, the Kaiser-Bessel kernel six taps a side."""
    import numpy as np

    from ....rays import RayBatch

    rows = []
    with create_renderer("fourier") as fourier:
        for name, overrides in scenes:
            for mode in ("average", "xray"):
                scene = load_scene(None, {**overrides, "renderer.name": "fourier", "renderer.compositing": mode,
                                          "renderer.classification": "pre", "renderer.shading.enabled": False,
                                          "camera.projection": "orthographic", "image.width": size,
                                          "image.height": size})
                image = fourier.render(scene).astype(np.float64)
                pre = fourier.stats["preprocess_seconds"]
                fourier.render(scene)
                truth = converged(ConvergedReference(scene.with_renderer(converged_tolerance=1e-4)), float64=True)
                error = np.abs(image - truth)
                rays = RayBatch.for_camera(scene.camera, size, size, scene.volume.bounds)
                inside = (rays.t1 > rays.t0).reshape(size, size)
                for axis in (0, 1):  # two pixels in from the silhouette
                    for step in (1, 2):
                        inside &= np.roll(inside, step, axis) & np.roll(inside, -step, axis)
                view_ms = 1e3 * fourier.stats["view_seconds"]
                wide = fourier.render(scene.with_renderer(slice_bandwidth=2.0, slice_taps=6)).astype(np.float64)
                peak = max(truth.max(), 1e-300)
                rows.append({"dataset": name, "mode": mode, "pre_s": pre, "view_ms": view_ms,
                             "rms_rel": float(np.sqrt(np.mean(error ** 2)) / peak),
                             "max": float(error.max()),
                             "silhouette": float(error[inside].max()) if inside.any() else 0.0,
                             "rms_wide": float(np.sqrt(np.mean((wide - truth) ** 2)) / peak)})
                if progress:
                    progress(rows[-1])
    return rows


def _raycast_at(raycast, timed, small, truth, rms: float, repeat: int) -> str:
    """The ray caster's time (at the timed image size) at the largest sample distance whose RMS (at the
    small size) is at most ``rms``."""
    for d in DISTANCES:
        if compare_images(raycast.render(small.with_renderer(sample_distance_voxels=d)), truth)["rms"] <= rms:
            ms = 1e3 * median_seconds(raycast, timed.with_renderer(sample_distance_voxels=d), repeat)
            return f"{ms:.0f} ms at {d:g} voxel"
    return f"not reached at {DISTANCES[-1]:g} voxel"

"""``dvr bench fourier``: Fourier volume rendering against the ray caster, per view and per volume.

Per volume size ``N`` (the blobs demo, ``N^3``: dense, every value positive) and mode (the average and the
pre-classified X-ray), orthographic: the spectrum's preparation, once (the channels: the X-ray's
classification, ghost layers; the transform: pre-multiplication, padding and the 3D transform; ready:
those and the textures' upload) and the first frame (its wall and CPU time: the second is the work, the
first also the machine's load); the time per view at the
image size, Fourier at its defaults and the ray caster at its defaults in one interleaved run (F, R, F,
R, ...; medians after a warm-up), and their ratio; the RMS of both against reference-converged at a
smaller image of the same framing.  Then, at the largest ``N``, each mode's error-vs-time points of
both (Fourier's settings, the ray caster's sample distances), all timed in one interleaved run, and
whether Fourier's front lies below the ray caster's at every error between 1e-4
and 1e-2 RMS.
"""

from __future__ import annotations

import math
import statistics
import time

from ....bench import converged
from ....bench.picks import baseline
from ....image import compare_images
from ....reference.converged import ConvergedReference
from ....scene.resolve import load_scene
from ... import create_renderer

BASELINE = baseline()  # the renderer set beside (the ray caster): the default renderer of grids
#: The ray caster's sample distances (voxels) on its error-vs-time front, beside its defaults: from 64 voxels,
#: whose error on the blobs' X-ray reaches the band's top, to 0.5.
DISTANCES = (64.0, 32.0, 16.0, 8.0, 4.0, 2.0, 1.0, 0.5)
#: Fourier's settings on its front, beside its defaults (six taps at padding 1.25, the exact clip): the box
#: clipped by the ghost layer (no shell pass), the slice cut to its low frequencies (``slice_cutoff``, in
#: multiples of the voxels' Nyquist limit), fewer taps, and the cubic B-spline slice at padding 2 (where its
#: replicas are small).
FOURIER_SETTINGS = (("ghost layer", {"box_clip": "ghost_layer"}),
                    ("ghost layer, cutoff 0.5", {"box_clip": "ghost_layer", "slice_cutoff": 0.5}),
                    ("ghost layer, cutoff 0.25", {"box_clip": "ghost_layer", "slice_cutoff": 0.25}),
                    ("ghost layer, cutoff 0.15", {"box_clip": "ghost_layer", "slice_cutoff": 0.15}),
                    ("cutoff 0.5", {"slice_cutoff": 0.5}),
                    ("4 taps, padding 1.5", {"slice_taps": 4, "padding": 1.5}),
                    ("cubic B-spline slice, padding 2", {"slice_interpolation": "cubic_bspline", "padding": 2.0}))
#: The error band where Fourier's front is to lie below the ray caster's.
BAND = (1e-4, 1e-2)
COLUMNS = [("n", "N", "d"), ("mode", "mode", ""), ("channels_s", "channels s", ".3f"),
           ("transform_s", "transform s", ".3f"), ("spectrum_s", "spectrum ready s", ".3f"),
           ("first_s", "first frame s", ".2f"), ("spectrum_mb", "spectrum MB", ".0f"),
           ("view_ms", "fourier ms/view", ".1f"), ("raycast_ms", f"{BASELINE} ms (defaults)", ".1f"),
           ("speedup", "ratio", ".2f"), ("rms", "fourier RMS", ".2e"), ("raycast_rms", f"{BASELINE} RMS", ".2e"),
           ("first_cpu_s", "first frame CPU s", ".2f")]
FRONT_COLUMNS = [("mode", "mode", ""), ("renderer", "renderer", ""), ("setting", "setting", ""),
                 ("rms", "RMS", ".2e"), ("ms", "ms/view", ".1f"), ("front", "on its front", "")]


def scene_for(n: int, mode: str, size: int):
    return load_scene(None, {"volume.demo": "blobs", "volume.size": n, "renderer.name": "fourier",
                             "renderer.compositing": mode, "renderer.classification": "pre",
                             "renderer.shading.enabled": False, "camera.projection": "orthographic",
                             "image.width": size, "image.height": size})


def interleaved(cases, repeat: int) -> list[float]:
    """Median seconds of each ``(renderer, scene)`` of ``cases``, rendered in turn ``repeat`` times after one
    untimed round (wall time of ``render``: what a user waits for a view), every other round in the reverse
    order (so that no case always follows the same one)."""
    for renderer, scene in cases:
        renderer.render(scene)
    times = [[] for _ in cases]
    order = list(range(len(cases)))
    for round_ in range(repeat):
        for k in (order if round_ % 2 == 0 else order[::-1]):
            renderer, scene = cases[k]
            start = time.perf_counter()
            renderer.render(scene)
            times[k].append(time.perf_counter() - start)
    return [statistics.median(t) for t in times]


def run(sizes, size: int = 512, error_size: int = 128, repeat: int = 3, progress=None,
        front: bool = True) -> tuple[list[dict], list[dict], list[str]]:
    """The per-size rows, the error-vs-time points at the largest size (``front``) and one verdict a mode."""
    rows, points, verdicts = [], [], []
    fourier, raycast = create_renderer("fourier"), create_renderer(BASELINE)
    try:
        for n in sizes:
            for mode in ("average", "xray"):
                scene = scene_for(n, mode, size)
                start, cpu = time.perf_counter(), time.process_time()
                fourier.render(scene)  # the spectrum, then the first view
                # the process's CPU time (every thread's): the work, where the wall time also counts the load
                first_cpu = time.process_time() - cpu
                stats = fourier.stats
                row = {"n": n, "mode": mode, "channels_s": stats["channels_seconds"],
                       "transform_s": stats["transform_seconds"], "spectrum_s": stats["preprocess_seconds"],
                       "first_s": time.perf_counter() - start, "first_cpu_s": first_cpu,
                       "spectrum_mb": fourier.stats["spectrum_bytes"] / 2 ** 20}
                ray = scene.with_renderer(name=BASELINE)
                f_s, r_s = interleaved([(fourier, scene), (raycast, ray)], repeat)
                row.update(view_ms=1e3 * f_s, raycast_ms=1e3 * r_s, speedup=r_s / f_s)
                small = scene_for(n, mode, error_size)
                truth = converged(ConvergedReference(small.with_renderer(converged_tolerance=1e-4)))
                row["rms"] = compare_images(fourier.render(small), truth)["rms"]
                row["raycast_rms"] = compare_images(raycast.render(small.with_renderer(name=BASELINE)), truth)["rms"]
                rows.append(row)
                if progress:
                    progress(row)
                if front and n == max(sizes):
                    found = _front(fourier, raycast, scene, small, truth, repeat)
                    points += [{"mode": mode, **p} for p in found]
                    verdicts.append(f"{mode}: {dominance(found)}")
    finally:
        fourier.close()
        raycast.close()
    return rows, points, verdicts


def _front(fourier, raycast, scene, small, truth, repeat: int) -> list[dict]:
    """Both renderers' error-vs-time points, every one timed in one interleaved run (each point rendered in
    turn, medians of ``repeat`` rounds: the load's drift shared by all): the ray caster's defaults and sample
    distances, Fourier's defaults and :data:`FOURIER_SETTINGS`.  Fourier's settings with the same spectrum
    (those that only cut the slice) share a renderer; the others each have their own, which keeps its
    spectrum between the rounds (``fourier``, the defaults', is one of them)."""
    ray, small_ray = scene.with_renderer(name=BASELINE), small.with_renderer(name=BASELINE)
    points = [(BASELINE, "defaults", raycast, ray, small_ray)]
    points += [(BASELINE, f"{d:g} voxels", raycast, ray.with_renderer(sample_distance_voxels=d),
                small_ray.with_renderer(sample_distance_voxels=d)) for d in DISTANCES]
    spectra = {}  # the settings a spectrum depends on -> its renderer
    made = []
    try:
        for name, changes in (("defaults", {}),) + FOURIER_SETTINGS:
            timed = scene.with_renderer(**changes)
            r = timed.renderer
            key = (r.slice_interpolation, r.padding, r.slice_taps, r.box_clip)
            if not spectra:
                spectra[key] = fourier
            elif key not in spectra:
                spectra[key] = create_renderer("fourier")
                made.append(spectra[key])
            points.append(("fourier", name, spectra[key], timed, small.with_renderer(**changes)))
        times = interleaved([(renderer, timed) for _, _, renderer, timed, _ in points], repeat)
        out = [{"renderer": family, "setting": name, "ms": 1e3 * seconds,
                "rms": compare_images(renderer.render(err), truth)["rms"]}
               for (family, name, renderer, _, err), seconds in zip(points, times)]
    finally:
        for renderer in made:
            renderer.close()
    for p in out:
        p["front"] = "yes" if _on_front(p, [q for q in out if q["renderer"] == p["renderer"]]) else ""
    return out


def _on_front(p, family) -> bool:
    return not any(q is not p and q["rms"] <= p["rms"] and q["ms"] < p["ms"] for q in family)


def cheapest(points, error: float) -> float:
    """The least time of ``points`` at an RMS of at most ``error`` (infinite where none reaches it)."""
    return min((p["ms"] for p in points if p["rms"] <= error), default=math.inf)


def dominance(points, band=BAND) -> str:
    """Whether Fourier's front lies below the ray caster's at every error of ``band`` ("dominates"), at or
    above it at every one ("dominated"), or below at some ("crossing"): compared at each point's error in
    the band and at both its ends (both fronts are step functions of the error: the least time at an RMS of
    at most that error; from the band's lower end to the first point in it, each front is its cheapest point
    below the band)."""
    fourier = [p for p in points if p["renderer"] == "fourier"]
    rays = [p for p in points if p["renderer"] != "fourier"]
    levels = sorted({p["rms"] for p in points if band[0] <= p["rms"] <= band[1]} | set(band))
    wins = [e for e in levels if cheapest(fourier, e) < cheapest(rays, e)]
    losses = [(e, cheapest(fourier, e), cheapest(rays, e)) for e in levels if e not in wins]
    if not losses:
        return (f"dominates: fourier's front is below the ray caster's at every error from {band[0]:g} to "
                f"{band[1]:g} RMS")
    e, f, r = losses[0]
    at = (f"at RMS {e:.2e} the ray caster takes {r:.0f} ms, fourier "
          f"{'never reaches it' if math.isinf(f) else f'{f:.0f} ms'}")
    if not wins:
        return f"dominated: fourier is nowhere faster from {band[0]:g} to {band[1]:g} RMS ({at})"
    return f"crossing: fourier faster at {len(wins)} of {len(levels)} error levels ({at})"


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

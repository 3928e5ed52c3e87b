"""``dvr bench scattering``: single scattering's methods in the ray caster, error against time.

Per scene (the ``shadow`` demo, a ball's hard shadow on a floor; with ``--shared`` the small shared
datasets, lit by the default light): shadow rays at several sample distances (the shadow rays take the
view rays' step), and the light volume at several sizes and view-ray sample distances.  Each row: the
frame time at the timing size (median after a warm-up: the light volume is made once per light and
transfer function, so it is kept between frames), the light volume's making apart, and the RMS against
reference-converged at the error size.  Then per scene the speed-up at equal error: for each
shadow-ray setting, the fastest light-volume setting at most as far from the reference.  Last, what
single scattering leaves out (:func:`multiple`): the Monte Carlo reference with every order of
scattering against reference-converged's single scattering, beside the Monte Carlo noise.
"""

from __future__ import annotations

import numpy as np

from ..image import compare_images
from ..phantoms import demo_scene
from ..reference.converged import ConvergedReference
from ..renderers import create_renderer, registry
from ..scene.resolve import load_scene
from . import converged, median_seconds, picks

# Steps a factor of 4/3 apart below one voxel: with a factor of two, "the fastest setting as accurate"
# often had to take the next finer step at twice the cost (the hard shadow: the light volume at 0.5 voxel
# was 2 % short of the shadow rays' error at 0.5 voxel, so the comparison took 0.25 voxel)
SHADOW_RAY_DISTANCES = (2.0, 1.0, 0.75, 0.5, 0.375, 0.25)
LIGHT_VOLUME_SIZES = (32, 64, 128, 256)
LIGHT_VOLUME_DISTANCES = (2.0, 1.0, 0.75, 0.5, 0.375, 0.25)
LIGHT_BUFFER_SIZES = (128, 256, 512)
COLUMNS = [("scene", "scene", ""), ("renderer", "renderer", ""), ("method", "method", ""), ("setting", "setting", ""),
           ("ms", "frame ms", ".0f"), ("volume_ms", "light volume ms", ".0f"), ("rms", "RMS vs converged", ".2e")]
EQUAL_COLUMNS = [("scene", "scene", ""), ("rays", "shadow rays", ""), ("rays_rms", "RMS", ".2e"),
                 ("rays_ms", "ms", ".0f"), ("volume", "fastest other method as accurate", ""),
                 ("volume_rms", "RMS", ".2e"), ("volume_ms", "ms", ".0f"), ("speedup", "speed-up", ".1f")]
DEFAULT_LIGHT = {"enabled": True, "albedo": 0.9, "lights": [{"direction": [0.4, 0.6, -1.0], "intensity": 1.5}]}


def shadow_demo(size: int = 64) -> tuple[str, dict]:
    """The shadow demo's scene as overrides (its own transfer function, light and camera), ``size^3``."""
    scene = demo_scene("shadow")
    overrides = {"volume.demo": "shadow", "volume.size": size,
                 "transfer_function.points": scene["transfer_function"]["points"],
                 "renderer.scattering": {k: v for k, v in scene["renderer"]["scattering"].items()
                                         if k not in ("method", "light_volume_size")}}
    camera = {f"camera.{k}": v for k, v in scene["camera"].items() if k != "distance"}  # framed at any size
    return "shadow demo", {**overrides, **camera}


def measuring(method: str) -> str:
    """The renderer whose ``method`` the bench measures: the first GL grid renderer (in the registry's order)
    that finds scattering's transmittance that way (it refuses no scene for it: the ray caster's shadow rays
    and light volume, 3D slicing's half-angle slicing)."""
    probe = _scene(shadow_demo(4)[1], 8, {"renderer.scattering.method": method})
    found = [n for n in picks.renderers("scattering", kind="grid", gl=True) if registry.refusal(probe, n) is None]
    if not found:
        raise LookupError(f"no GL grid renderer finds scattering by {method}")
    return found[0]


def settings(light_volume_sizes=LIGHT_VOLUME_SIZES,
             shadow_ray_distances=SHADOW_RAY_DISTANCES) -> list[tuple[str, str, str, dict]]:
    """(renderer, method, setting's label, renderer overrides) of the rows."""
    rays, volume, half_angle = (measuring(m) for m in ("shadow_rays", "light_volume", "half_angle"))
    out = [(rays, "shadow_rays", f"{d:g} voxel", {"renderer.scattering.method": "shadow_rays",
                                                       "renderer.sample_distance_voxels": d})
           for d in shadow_ray_distances]
    out += [(volume, "light_volume", f"{n} nodes, {d:g} voxel", {"renderer.scattering.method": "light_volume",
                                                                    "renderer.scattering.light_volume_size": n,
                                                                    "renderer.sample_distance_voxels": d})
            for n in light_volume_sizes for d in LIGHT_VOLUME_DISTANCES]
    out += [(half_angle, "half_angle", f"{n} pixels, {d:g} voxel", {"renderer.scattering.method": "half_angle",
                                                                     "renderer.scattering.light_buffer_size": n,
                                                                     "renderer.sample_distance_voxels": d})
            for n in LIGHT_BUFFER_SIZES for d in LIGHT_VOLUME_DISTANCES]
    return out


def _scene(overrides: dict, size: int, extra: dict):
    base = {"renderer.name": picks.baseline(), "renderer.shading.enabled": False, "image.width": size,
            "image.height": size}
    if "renderer.scattering" not in overrides:
        base["renderer.scattering"] = DEFAULT_LIGHT
    return load_scene(None, {**base, **overrides, **extra})


def run(scenes, size: int = 256, error_size: int = 64, repeat: int = 3, tolerance: float = 1e-4,
        progress=None, light_volume_sizes=LIGHT_VOLUME_SIZES,
        shadow_ray_distances=SHADOW_RAY_DISTANCES) -> list[dict]:
    """Rows of the methods' table for ``scenes`` (``(name, overrides)``)."""
    rows = []
    rows_settings = settings(light_volume_sizes, shadow_ray_distances)
    renderers = {name: create_renderer(name) for name in dict.fromkeys(r for r, *_ in rows_settings)}
    try:
        for name, overrides in scenes:
            truth = converged(ConvergedReference(_scene(overrides, error_size, {
                "renderer.converged_tolerance": tolerance, "renderer.name": picks.converged()})))
            for renderer_name, method, label, extra in rows_settings:
                renderer = renderers[renderer_name]
                extra = {**extra, "renderer.name": renderer_name}
                scene = _scene(overrides, size, extra)
                renderer.render(scene)  # the light volume, if any, made here
                made = renderer.stats.get("light_volume_seconds", 0.0)
                ms = 1e3 * median_seconds(renderer, scene, repeat, warm_up=False)
                image = renderer.render(_scene(overrides, error_size, extra))
                row = {"scene": name, "renderer": renderer_name, "method": method, "setting": label, "ms": ms,
                       "volume_ms": 1e3 * made if method == "light_volume" else None,
                       "rms": compare_images(image, truth)["rms"]}
                rows.append(row)
                if progress:
                    progress(row)
    finally:
        for renderer in renderers.values():
            renderer.close()
    return rows


def equal_error(rows: list[dict]) -> list[dict]:
    """Per scene and shadow-ray row: the fastest light-volume or half-angle row at most as far from the
    reference."""
    out = []
    for ray in (r for r in rows if r["method"] == "shadow_rays"):
        candidates = [r for r in rows if r["scene"] == ray["scene"] and r["method"] != "shadow_rays"
                      and r["rms"] <= ray["rms"]]
        best = min(candidates, key=lambda r: r["ms"], default=None)
        out.append({"scene": ray["scene"], "rays": ray["setting"], "rays_rms": ray["rms"], "rays_ms": ray["ms"],
                    "volume": f"{best['method']} {best['setting']}" if best else "none as accurate",
                    "volume_rms": best and best["rms"], "volume_ms": best and best["ms"],
                    "speedup": best and ray["ms"] / best["ms"]})
    return out


MULTIPLE_COLUMNS = [("scene", "scene", ""), ("paths", "paths per pixel", "d"),
                    ("single", "single scattering: mean RGB", ".4f"),
                    ("full", "all orders (Monte Carlo): mean RGB", ".4f"),
                    ("rms", "RMS of the difference", ".2e"), ("noise", "Monte Carlo's RMS standard error", ".2e"),
                    ("largest", "largest difference", ".2e"), ("seconds", "Monte Carlo s", ".0f")]


def multiple(scenes, size: int = 32, paths: int = 64, tolerance: float = 1e-4, progress=None) -> list[dict]:
    """Per scene: reference-converged (single scattering) against the Monte Carlo reference (all orders)
    at ``size``: the means, the RMS and largest difference, and the Monte Carlo standard error's RMS
    (the difference's noise floor)."""
    import time

    from ..reference.monte_carlo import MonteCarloReference

    rows = []
    for name, overrides in scenes:
        scene = _scene(overrides, size, {"renderer.converged_tolerance": tolerance,
                                         "renderer.name": picks.converged()})
        single = converged(ConvergedReference(scene), float64=True)
        start = time.perf_counter()
        full, error = MonteCarloReference(scene, paths=paths, seed=0).render()
        diff = (full - single)[..., :3]
        rows.append({"scene": name, "paths": paths, "single": float(single[..., :3].mean()),
                     "full": float(full[..., :3].mean()), "rms": float(np.sqrt(np.mean(diff ** 2))),
                     "noise": float(np.sqrt(np.mean(error[..., :3] ** 2))), "largest": float(np.abs(diff).max()),
                     "seconds": time.perf_counter() - start})
        if progress:
            progress(rows[-1])
    return rows

"""``dvr bench raycast``: frame time and samples of the GPU ray caster.

Every case renders the same view; the frame time is the median of ``repeat``
frames after one warm-up frame, measured from the draw call to ``glFinish``
(textures already uploaded, read-back excluded).  Samples are counted by the
shader itself in the warm-up frame (``COUNT_SAMPLES``, a define only benchmarks
set); the timed frames run the program without it.
"""

from __future__ import annotations

import statistics

from ....bench import tick
from ....scene.resolve import load_scene
from ..renderer import RayCastRenderer

CASES = [  # (label, overrides, fragment shader)
    ("emission, early termination off", {"renderer.ert_threshold": 1.0}, "raycast.frag"),
    ("emission, early termination 0.99", {"renderer.ert_threshold": 0.99}, "raycast.frag"),
    ("  same, minimal hand-written shader", {"renderer.ert_threshold": 1.0}, "minimal_raycast.frag"),
    ("emission, cubic B-spline (8 fetches)", {"renderer.filter": "cubic_bspline"}, "raycast.frag"),
    ("emission, cubic B-spline in shader (64)", {"renderer.filter": "cubic_bspline",
                                                 "renderer.filtering": "shader"}, "raycast.frag"),
    ("emission + shading, central differences", {"renderer.shading.enabled": True}, "raycast.frag"),
    ("emission + shading, gradient texture", {"renderer.shading.enabled": True,
                                              "renderer.gradient": "texture"}, "raycast.frag"),
    ("isosurface + shading", {"renderer.compositing": "isosurface", "renderer.shading.enabled": True},
     "raycast.frag"),
    ("maximum intensity projection", {"renderer.compositing": "mip"}, "raycast.frag"),
    # Every compositing mode and classification without shading, early termination off: their
    # samples per second against the minimal loop's (the last column).
    ("emission, back to front", {"renderer.ert_threshold": 1.0, "renderer.order": "back_to_front"},
     "raycast.frag"),
    ("emission, pre-classified", {"renderer.ert_threshold": 1.0, "renderer.classification": "pre"},
     "raycast.frag"),
    ("emission, pre-integrated", {"renderer.ert_threshold": 1.0, "renderer.classification": "preintegrated"},
     "raycast.frag"),
    ("minimum intensity projection", {"renderer.compositing": "minip"}, "raycast.frag"),
    ("average (X-ray)", {"renderer.compositing": "average"}, "raycast.frag"),
    ("isosurface, unshaded", {"renderer.compositing": "isosurface"}, "raycast.frag"),
]
MINIMAL = "  same, minimal hand-written shader"
MINIMAL_OF = "emission, early termination off"  # the minimal loop takes this case's samples

COLUMNS = [("case", "case", ""), ("volume", "volume", ""), ("image", "image", ""),
           ("samples_per_ray", "samples/ray", ".1f"), ("ms", "frame ms (median)", ".1f"),
           ("msamples_per_s", "Msamples/s", ".1f"), ("of_minimal", "of the minimal loop", ".0%")]


def run(base: dict, repeat: int = 5, cases=CASES) -> list[dict]:
    """Render each case ``repeat`` times (after a warm-up) over the scene ``base`` (dotted keys)."""
    renderers: dict[str, RayCastRenderer] = {}
    rows = []
    try:
        scene0 = load_scene(None, base)
        for label, overrides, shader in cases:
            scene = load_scene(None, {**base, **overrides}) if overrides else scene0
            scene = scene.replace(volume=scene0.volume)  # one volume, uploaded once
            if shader not in renderers:
                ctx = next(iter(renderers.values())).ctx if renderers else None
                renderers[shader] = RayCastRenderer(ctx=ctx, fragment_shader=shader)
            r = renderers[shader]
            r.count_samples = shader == "raycast.frag"
            r.render(scene)  # warm-up: compile, upload, count the samples
            samples = r.stats.get("samples")
            per_ray = r.stats.get("samples_per_ray")
            r.count_samples = False
            r.render(scene)  # compile the program the timed frames use
            times = []
            for _ in range(repeat):
                r.render(scene)
                times.append(r.stats["gpu_seconds"])
                tick()
            t = statistics.median(times)
            nx, ny, nz = scene.volume.dims
            rows.append({"case": label, "volume": f"{nx}x{ny}x{nz}",
                         "image": f"{scene.image.width}x{scene.image.height}", "ms": 1e3 * t,
                         "samples_per_ray": per_ray if shader == "raycast.frag" else None,
                         "msamples_per_s": samples / t / 1e6 if samples and shader == "raycast.frag" else None})
    finally:
        for r in reversed(list(renderers.values())):
            r.close()
    by_label = {row["case"]: row for row in rows}
    if MINIMAL in by_label and by_label.get(MINIMAL_OF, {}).get("msamples_per_s"):
        minimal = by_label[MINIMAL]
        reference = by_label[MINIMAL_OF]
        minimal["msamples_per_s"] = reference["msamples_per_s"] * reference["ms"] / minimal["ms"]
        for row in rows:
            if row.get("msamples_per_s"):
                row["of_minimal"] = row["msamples_per_s"] / minimal["msamples_per_s"]
    return rows

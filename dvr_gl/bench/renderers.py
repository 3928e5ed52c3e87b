"""``dvr bench renderers``: frame time of the GPU renderers side by side, whole and bricked.

The ray caster, 3D view-aligned slicing and 2D texture stacks render one view,
post-classified and pre-integrated, first from one texture and then from bricks
under a small texture budget.  "draw": the median over ``repeat`` frames (after a
warm-up) of the draw calls to ``glFinish``, as in ``dvr bench raycast``; "frame":
the whole ``render()``, with texture uploads (bricks that do not all fit the
budget are uploaded again every frame), slice geometry and read-back.  Early termination
and acceleration are off so that every renderer does the whole integral (the
slicers never terminate early); 2D stacks always sample the voxel planes, one
per voxel, the others at the scene's sample distance.
"""

from __future__ import annotations

import statistics

from ..renderers import create_renderer
from ..scene.resolve import load_scene
from . import picks, tick

CLASSIFICATIONS = ("post", "preintegrated")
COLUMNS = [("renderer", "renderer", ""), ("classification", "classification", ""), ("bricks", "bricks", "d"),
           ("ms", "draw ms", ".1f"), ("frame_ms", "frame ms", ".1f")]


def measured() -> list[str]:
    """The GPU grid renderers that brick under a texture budget and pre-integrate (the ray caster, both
    slicers), in the registry's order."""
    bricked = set(picks.renderers("texture_budget_mb"))
    return [n for n in picks.renderers("classification", "preintegrated", kind="grid", gl=True) if n in bricked]


def run(base: dict, repeat: int = 5, budget_mb: float = 48.0) -> list[dict]:
    """Rows for each renderer x classification x (one texture, bricks under ``budget_mb``)."""
    base = {**base, "renderer.acceleration": False, "renderer.ert_threshold": 1.0}
    volume = load_scene(None, base).volume
    rows = []
    for name in measured():
        with create_renderer(name) as r:
            for classification in CLASSIFICATIONS:
                for budget in (None, budget_mb):
                    overrides = {"renderer.classification": classification}
                    if budget is not None:
                        overrides["renderer.texture_budget_mb"] = budget
                    scene = load_scene(None, {**base, **overrides}).replace(volume=volume)
                    r.render(scene)                                   # compile, upload, build tables
                    draws, frames = [], []
                    for _ in range(repeat):
                        r.render(scene)
                        draws.append(r.stats["gpu_seconds"])
                        tick()
                        frames.append(r.stats["seconds"])
                    rows.append({"renderer": name, "classification": classification,
                                 "bricks": r.stats.get("bricks", 1), "ms": 1e3 * statistics.median(draws),
                                 "frame_ms": 1e3 * statistics.median(frames)})
    return rows

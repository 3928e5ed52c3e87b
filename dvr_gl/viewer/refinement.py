"""Progressive refinement, "the illusion of interaction" (pure; no window, no GL).

While the user drags, frames are rendered at a reduced :class:`Level` (fewer pixels, longer
sample distance) chosen to hold a frame-time budget; once the input stops, the view is refined
to full quality, and for jittered rendering passes with different jitter seeds are averaged.

The cost model: a level's render time grows with its *work*, ``1 / (block^2 * factor)`` of a
full-quality frame (``block`` x ``block`` pixels per rendered pixel, sample distance times
``factor``), plus fixed costs (set-up, read-back).  The controller keeps, per level, an
exponential average of the measured render times, and of the time a frame spends outside the
renderer (display, GUI).  A level not measured yet is predicted by linear interpolation in work
between the measured levels around it, which captures the fixed costs, or, beyond them,
proportionally from the nearest one (over-estimating toward full quality, where the fixed costs
weigh less).  An interactive frame gets the best level whose predicted total fits the budget.

Idle refinement goes straight to full quality when that is predicted to take at most
:attr:`RefinementController.idle_step` seconds (every GPU renderer on the sizes tested); slower
renderers (the CPU references) step up one level per frame, so the picture improves while the
window stays responsive between steps.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Level:
    """A rendering quality: ``block`` window pixels per rendered pixel along each axis, and the
    scene's sample distance times ``distance_factor``."""

    block: int
    distance_factor: float

    @property
    def work(self) -> float:
        """Fraction of a full-quality frame's samples."""
        return 1.0 / (self.block ** 2 * self.distance_factor)

    @property
    def full(self) -> bool:
        return self.block == 1 and self.distance_factor == 1.0

    def image_size(self, width: int, height: int) -> tuple[int, int]:
        """The rendered image's size for a ``width`` x ``height`` window area (at least 1 x 1)."""
        return max(1, math.ceil(width / self.block)), max(1, math.ceil(height / self.block))


FULL = Level(1, 1.0)
# Best first; each step cuts the work by 1.8x to 2.25x.  Resolution falls before sampling does, up to
# 2x2 blocks, because a longer sample distance changes the picture (opacity correction keeps the
# overall opacity, not thin features) where a lower resolution only blurs it.
LADDER = (FULL, Level(1, 2.0), Level(2, 1.0), Level(2, 2.0), Level(3, 2.0), Level(4, 2.0),
          Level(6, 2.0), Level(8, 2.0), Level(8, 4.0), Level(12, 4.0), Level(16, 4.0))
# Without a measurement yet (a new renderer or setting), interaction starts here.
FIRST_GUESS = Level(4, 2.0)


@dataclass(frozen=True)
class FramePlan:
    """What to render next: the level, and the jitter pass (0: the scene's own seed)."""

    level: Level
    jitter_pass: int = 0
    interactive: bool = False


class RefinementController:
    """Chooses what each frame renders (see the module doc).

    Args:
        budget: frame-time budget while interacting, seconds (all of a frame: render, display, GUI).
        passes: jittered passes to average when idle (1 without jitter).
        idle_step: longest predicted render an idle refinement step may take before going
            to full quality in one step, seconds.
        smoothing: weight of the newest measurement in the running estimates.
    """

    def __init__(self, budget: float = 0.1, passes: int = 1, idle_step: float = 1.5, smoothing: float = 0.5):
        if not budget > 0:
            raise ValueError(f"budget must be positive, got {budget}")
        self.budget = budget
        self.passes = max(1, int(passes))
        self.idle_step = idle_step
        self.smoothing = smoothing
        self.times: dict[Level, float] = {}      # running mean render time of each level measured, seconds
        self.overhead: float = 0.0               # running mean time of a frame outside the renderer
        self._interacting = False
        self._dirty = True
        self._last: Level | None = None          # level of the last image shown since the last change
        self._passes_done = 0                    # full-quality passes accumulated since the last change

    # --- inputs ---

    def changed(self, interactive: bool):
        """The view or the scene changed; ``interactive``: as part of a continuing gesture (drag,
        wheel), so the next frames should hold the budget."""
        self._interacting = interactive
        self._dirty = True
        self._last = None
        self._passes_done = 0

    def idle(self):
        """The gesture ended: refine from now on."""
        self._interacting = False

    def forget_costs(self):
        """Costs changed (renderer, settings, image size): measure again."""
        self.times.clear()

    def set_passes(self, passes: int):
        """Jittered passes to average (1: no accumulation)."""
        self.passes = max(1, int(passes))

    def measured(self, plan: FramePlan, render_seconds: float, other_seconds: float = 0.0):
        """Record the time a frame took: in the renderer, and outside it (display, GUI)."""
        a, level = self.smoothing, plan.level
        old = self.times.get(level)
        self.times[level] = render_seconds if old is None else (1 - a) * old + a * render_seconds
        self.overhead = (1 - a) * self.overhead + a * other_seconds

    def shown(self, plan: FramePlan):
        """The frame of ``plan`` was rendered and is on screen."""
        self._last = plan.level
        self._dirty = False
        if plan.level.full:
            self._passes_done = max(self._passes_done, plan.jitter_pass + 1)

    # --- decisions ---

    def predict_render(self, level: Level) -> float | None:
        """Predicted render time at ``level``, seconds (None before any measurement)."""
        if level in self.times:
            return self.times[level]
        if not self.times:
            return None
        w = level.work
        below = max(((lv.work, t) for lv, t in self.times.items() if lv.work < w), default=None)
        above = min(((lv.work, t) for lv, t in self.times.items() if lv.work > w), default=None)
        if below and above:
            (w0, t0), (w1, t1) = below, above
            return t0 + (t1 - t0) * (w - w0) / (w1 - w0)
        w0, t0 = below or above
        return t0 * w / w0

    def predict(self, level: Level) -> float | None:
        """Predicted frame time at ``level``: render and the rest, seconds (None before any measurement)."""
        render = self.predict_render(level)
        return None if render is None else self.overhead + render

    @property
    def full_seconds(self) -> float | None:
        """Predicted render time of a full-quality frame."""
        return self.predict_render(FULL)

    def interactive_level(self) -> Level:
        """The best level whose predicted frame time fits the budget (the cheapest if none does)."""
        if not self.times:
            return FIRST_GUESS
        return next((level for level in LADDER if self.predict(level) <= self.budget), LADDER[-1])

    def _idle_level(self) -> Level:
        """Full quality when it takes at most ``idle_step``; else one level better than the last
        shown (at least the best level within ``idle_step``)."""
        if not self.times:
            return FIRST_GUESS
        if self.full_seconds <= self.idle_step:
            return FULL
        within = next((i for i, lv in enumerate(LADDER) if self.predict_render(lv) <= self.idle_step),
                      len(LADDER) - 1)
        if self._last is None:
            return LADDER[within]
        rank = LADDER.index(self._last) if self._last in LADDER else len(LADDER)
        return LADDER[max(0, min(rank - 1, within))]

    def next_frame(self) -> FramePlan | None:
        """What to render now, or None when the picture on screen is final until the next change."""
        if self._interacting:
            return FramePlan(self.interactive_level(), 0, interactive=True) if self._dirty else None
        if self._last is not None and self._last.full:
            if self._passes_done >= self.passes:
                return None
            return FramePlan(FULL, self._passes_done)
        return FramePlan(self._idle_level(), 0)

    @property
    def state(self) -> str:
        """``interactive``, ``refining``, ``accumulating`` or ``full``."""
        if self._interacting:
            return "interactive"
        if self._last is None or not self._last.full:
            return "refining"
        if self._passes_done < self.passes:
            return "accumulating"
        return "full"

    @property
    def passes_done(self) -> int:
        return self._passes_done


def plan_scene(scene, plan: FramePlan):
    """The scene a frame of ``plan`` renders: fewer pixels, a longer sample distance, another jitter seed (the
    viewer's and the notebook widget's frames alike)."""
    from ..scene.settings import with_sample_distance

    level = plan.level
    width, height = level.image_size(scene.image.width, scene.image.height)
    renderer = scene.renderer
    if level.distance_factor != 1.0:
        renderer = with_sample_distance(renderer, scene.field, factor=level.distance_factor)
    if plan.jitter_pass:
        renderer = dataclasses.replace(renderer, jitter_seed=scene.renderer.jitter_seed + plan.jitter_pass)
    return scene.replace(image=dataclasses.replace(scene.image, width=width, height=height), renderer=renderer)

"""What the HUD (the status bar) shows: frame and render times, samples per second, renderer and
settings (pure; no window)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..orientation import volume_frame_scene
from ..rays import intersect_box
from .settings import describe


def nominal_samples(scene, grid: int = 32) -> float:
    """Samples a full frame of ``scene`` takes before any skipping or early termination: the
    length of every pixel's ray inside the field's box (from the near plane on) over the sample
    distance, summed, estimated from the rays of an image at most ``grid`` pixels wide and high."""
    img, cam = scene.image, volume_frame_scene(scene)[0].camera  # the rays in the field's own frame
    scale = min(1.0, grid / max(img.width, img.height))   # a coarser image of the same aspect
    w, h = max(1, round(img.width * scale)), max(1, round(img.height * scale))
    origins, dirs = cam.pixel_rays(w, h)
    t0, t1 = intersect_box(origins, dirs, *scene.field.bounds)
    t0 = np.maximum(t0, cam.near_distance(dirs))
    length = np.clip(t1 - t0, 0.0, None)
    return float(length.sum() / scene.renderer.sample_distance * (img.width * img.height) / (w * h))


@dataclass(frozen=True)
class FrameStats:
    """One presented frame, complete (the HUD shows the last one; it never mixes two frames).

    render_seconds: the renderer's ``render`` of the frame, its image read back to the host (so
        a GPU renderer has finished).
    frame_seconds: the whole loop iteration that made the frame, from its start (after waiting
        for input) to the buffer swap that presented it: render, upload, panel, swap.  Both are
        measured with one clock (:class:`FrameClock`) and the render lies inside the frame, so
        ``render_seconds <= frame_seconds``.
    samples: the frame's samples (the renderer's count, or :func:`nominal_samples`).
    size: the rendered image's size, pixels; state, level_text: the refinement's.
    """

    render_seconds: float = 0.0
    frame_seconds: float = 0.0
    samples: float = 0.0
    measured_samples: bool = False
    size: tuple[int, int] = (0, 0)
    state: str = "refining"
    level_text: str = ""

    @property
    def samples_per_second(self) -> float:
        return self.samples / self.render_seconds if self.render_seconds > 0 else 0.0

    @property
    def other_seconds(self) -> float:
        """The frame outside the renderer: upload, panel, swap."""
        return max(0.0, self.frame_seconds - self.render_seconds)


class FrameClock:
    """Times one frame at a time in one clock: :meth:`begin` when the loop iteration starts,
    :meth:`render` around the renderer, :meth:`end` after the swap; seconds of ``clock``
    (default :func:`time.perf_counter`)."""

    def __init__(self, clock=time.perf_counter):
        self.clock = clock
        self.started = clock()
        self.render_seconds: float | None = None

    def begin(self):
        self.started, self.render_seconds = self.clock(), None

    def render(self, draw):
        """``draw()``, timed as the frame's render; its result."""
        start = self.clock()
        try:
            return draw()
        finally:
            self.render_seconds = self.clock() - start

    def end(self) -> tuple[float, float]:
        """``(render, frame)`` seconds of the frame just presented."""
        frame = self.clock() - self.started
        return (self.render_seconds or 0.0), frame


def hud_lines(scene, stats: FrameStats, message: str | None = None, status: str = "") -> list[str]:
    """The status bar's two lines: the settings and ``status`` (the time step, the field edited; or, while there
    is one, the last message), then the refinement state, the image's size and level, the last frame's times
    and samples per second."""
    sps = stats.samples_per_second
    kind = "" if stats.measured_samples else " (nominal)"
    level = f" {stats.level_text}" if stats.level_text else ""
    return [
        message if message else describe(scene) + (f" | {status}" if status else ""),
        (f"{stats.state} | {stats.size[0]}x{stats.size[1]}{level} | frame {stats.frame_seconds * 1e3:.1f} ms = "
         f"render {stats.render_seconds * 1e3:.1f} + display {stats.other_seconds * 1e3:.1f} ms | "
         f"{sps / 1e6:.1f} M samples/s{kind} | F1: help"),
    ]

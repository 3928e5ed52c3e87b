"""What the HUD shows: frame time, samples per second, renderer and settings (pure; no window)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rays import intersect_box
from .settings import describe


def nominal_samples(scene, grid: int = 32) -> float:
    """Samples a full frame of ``scene`` takes before any skipping or early termination: the
    length of every pixel's ray inside the field's box (from the near plane on) over the sample
    distance, summed, estimated from the rays of an image at most ``grid`` pixels wide and high."""
    img, cam = scene.image, scene.camera
    scale = min(1.0, grid / max(img.width, img.height))   # a coarser image of the same aspect
    w, h = max(1, round(img.width * scale)), max(1, round(img.height * scale))
    origins, dirs = cam.pixel_rays(w, h)
    t0, t1 = intersect_box(origins, dirs, *scene.field.bounds)
    t0 = np.maximum(t0, cam.near_distance(dirs))
    length = np.clip(t1 - t0, 0.0, None)
    return float(length.sum() / scene.renderer.sample_distance * (img.width * img.height) / (w * h))


@dataclass
class FrameStats:
    """The last rendered frame: seconds in the renderer and for the whole frame, samples, size."""

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


def hud_lines(scene, stats: FrameStats) -> list[str]:
    """The HUD's lines: settings (two lines), then timing, then the refinement state."""
    sps = stats.samples_per_second
    kind = "" if stats.measured_samples else " (nominal)"
    parts = describe(scene).split(" | ")
    return [
        " | ".join(parts[:4]),
        " | ".join(parts[4:]),
        f"frame {stats.frame_seconds * 1e3:.1f} ms (render {stats.render_seconds * 1e3:.1f} ms) | "
        f"{sps / 1e6:.1f} M samples/s{kind}",
        f"{stats.size[0]}x{stats.size[1]} {stats.level_text} | {stats.state}",
    ]

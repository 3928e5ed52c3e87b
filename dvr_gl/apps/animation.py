"""What frame ``i`` of ``dvr render --frames N --animate orbit|time|time,orbit`` shows (docs/cli.md).

* ``orbit`` (the default of ``--frames``): the camera turns 360 degrees about the up axis over the N frames;
  frame 0 is the scene's own camera.
* ``time``: frame ``i`` of N shows step ``floor(i S / N)`` of the S steps: N = S (the default when ``--frames``
  is not given) is one frame per step; more frames hold each step N/S frames; fewer skip steps evenly, always
  starting at step 0.  Steps are read one at a time, when a frame first needs one, so a series larger than memory
  animates within the memory budget.  Every frame keeps the first step's transfer functions, camera and
  sampling, so that a colour means the same value in every frame (a frame of step k is the image of ``--time
  k`` wherever the transfer functions are given in data units, as points or a file: a preset stretched over the
  data's range is stretched over step 0's).
* ``time,orbit``: both at once.
* ``path`` (the default of ``--frames`` when the scene has ``[[camera.keyframe]]`` tables): the camera follows
  the keyframes' path (:class:`dvr_gl.camera_path.CameraPath`), frame ``i`` of N at time
  ``start + i (end - start) / (N - 1)``: the first and last keyframes are the first and last frames.
  ``time,path``: with the time steps too; keyframes that give a ``step`` choose each frame's step
  (:meth:`dvr_gl.camera_path.CameraPath.step_at`), and ``path`` then walks the time series by itself.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from typing import Callable

ANIMATIONS = ("orbit", "time", "path")


def parse_animate(text: str) -> frozenset:
    """``--animate``: ``orbit``, ``time`` or both, comma-separated."""
    parts = frozenset(p.strip().lower() for p in text.split(",") if p.strip())
    if not parts or not parts <= set(ANIMATIONS) or {"orbit", "path"} <= parts:
        raise argparse.ArgumentTypeError(f"{text!r}: give orbit, time, or time,orbit; or path or time,path (the "
                                         f"scene's [[camera.keyframe]] tables)")
    return parts


def orbit_scene(scene, i: int, count: int):
    """Frame ``i`` of an orbit of ``count`` frames (frame 0: the scene's own camera)."""
    if not i:
        return scene
    az0 = scene.camera.orbited().orbit[0]
    return scene.replace(camera=scene.camera.orbited(azimuth=az0 + 360.0 * i / count))


@dataclass(frozen=True)
class Animation:
    """``frames`` frames; the camera orbits if ``orbit``; ``steps`` > 1: the time steps walked."""

    frames: int
    orbit: bool = True
    steps: int = 1
    path: object = None  # a CameraPath the camera follows (instead of an orbit)

    def step(self, i: int) -> int:
        """The time step frame ``i`` shows: the path's keyframes' steps where they give them
        (:meth:`dvr_gl.camera_path.CameraPath.step_at`), else ``floor(i steps / frames)``, exact in integers."""
        if self.path is not None and self.path.steps is not None:
            return self.path.step_at(self.path.frame_times(self.frames)[i])
        return i * self.steps // self.frames


class Frames:
    """The scene of each frame of ``animation``, from ``scene`` (step 0's); ``read_step(k)`` gives the data at
    step ``k`` (:meth:`dvr_gl.apps.fields.Source.load`'s field), called once per step shown, in order."""

    def __init__(self, scene, animation: Animation, read_step: Callable[[int], object] | None = None):
        self.scene, self.animation, self.read_step = scene, animation, read_step
        self.shown, self.field = 0, scene.field

    def __call__(self, i: int):
        scene = self.scene
        if self.animation.steps > 1:
            k = self.animation.step(i)
            if k != self.shown:  # the previous step's data is dropped here: one step in memory at a time
                self.field = None
                self.field = self.read_step(k)
                self.shown = k
            scene = self._at_step(scene)
        if self.animation.path is not None:
            return scene.replace(camera=self.animation.path.camera_at(self.times[i]))
        return orbit_scene(scene, i, self.animation.frames) if self.animation.orbit else scene

    def _at_step(self, scene):
        """``scene`` with the shown step's field.  One grid is resolved again for it (the camera and the
        volume's source kept), so that what the renderer chose from the data (the ray caster's defaults
        are chosen by the scene) is what ``--time k`` chooses: frame i is that step's image alone."""
        if getattr(self.field, "kind", None) == "grid" and scene.spec is not None:
            return scene.replace(field=self.field, camera=scene.camera, volume_source=scene.volume_source)
        return dataclasses.replace(scene, field=self.field)

    @property
    def times(self):
        """The path's time at each frame (seconds)."""
        return self.animation.path.frame_times(self.animation.frames)

"""The viewer's time and fields (pure; no window): playing, pausing and stepping through a time series, and which
field of several the transfer-function editor edits.

A series is read one step at a time: ``read_step(k)`` gives the scene at step ``k`` (the command line's scene
loaded with ``volume.time = k``: :meth:`dvr_gl.apps.fields.Source.load`); the viewer keeps its own camera,
renderer settings and transfer functions and takes the step's data and sources (:func:`at_step`), so a
screenshot's scene names the step it shows.  Playing advances one step every :attr:`Player.seconds_per_step`,
but never past a step that has not been presented yet (a slow step is shown, not skipped).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

from ..transfer_function import TransferFunction

STEPS_PER_SECOND = 4.0  # the pace of playing: a series is read and drawn one step at a time


def at_step(scene, stepped):
    """``scene`` (its camera, settings, transfer functions) with the data and sources of ``stepped``, the same
    scene loaded at another time step."""
    return dataclasses.replace(scene, field=stepped.field, volume_source=stepped.volume_source,
                               sources=stepped.sources)


@dataclass
class Player:
    """The time step shown (``step`` of ``steps``), playing or paused."""

    steps: int
    read_step: Callable[[int], object]
    step: int = 0
    playing: bool = False
    seconds_per_step: float = 1.0 / STEPS_PER_SECOND
    due: float = 0.0      # when playing may show the next step (seconds of the viewer's clock)
    presented: bool = True  # the current step has been drawn at least once

    def toggle(self, now: float) -> bool:
        """Play or pause; whether it plays now."""
        self.playing = not self.playing and self.steps > 1
        self.due = now + self.seconds_per_step
        return self.playing

    def go(self, delta: int) -> int:
        """Step by ``delta`` (wrapping around the ends); the new step."""
        self.step = (self.step + delta) % self.steps
        self.presented = False
        return self.step

    def tick(self, now: float) -> bool:
        """Whether playing moves on now: the next step is due and the current one has been presented (the
        caller then shows the next: :meth:`go`)."""
        if not (self.playing and self.presented and now >= self.due):
            return False
        self.due = max(self.due + self.seconds_per_step, now)  # a steady pace; no catching up after a slow step
        return True

    def describe(self) -> str:
        return f"time {self.step}/{self.steps - 1} {'playing' if self.playing else 'paused'}"


def editable(layers) -> list[int]:
    """The fields whose transfer function the editor edits (control points over values: scalar and rgb fields;
    a label map's colour table is not a curve)."""
    return [i for i, layer in enumerate(layers)
            if layer.role != "label" and isinstance(layer.transfer_function, TransferFunction)]


def next_editable(layers, current: int) -> int:
    """The next field after ``current`` the editor can edit (``current`` itself if no other)."""
    fields = editable(layers)
    later = [i for i in fields if i > current]
    return later[0] if later else (fields[0] if fields else current)


def with_transfer_function(scene, index: int, tf, choose_again: bool = True):
    """``scene`` with field ``index``'s transfer function replaced (a scene of one field: its own);
    ``choose_again``: the renderer's settings chosen by the scene are chosen for ``tf`` (Scene.replace)."""
    if not scene.transfer_functions:
        return scene.replace(transfer_function=tf, choose_again=choose_again)
    tfs = list(scene.transfer_functions)
    tfs[index] = tf
    return dataclasses.replace(scene, transfer_functions=tuple(tfs), transfer_function=tfs[0])

"""Picking under the cursor, annotations over the displayed picture, and camera-path recording (pure; no
window).

* **Picking** (I): once the cursor has rested :data:`PICK_REST_SECONDS` on the image (never while dragging),
  :func:`dvr_gl.pick` traces the one ray of the full-size scene's pixel under it (:func:`cursor_pixel`: the
  image rectangle on screen spans the full scene whatever resolution the frame shown has) and the status bar
  shows :func:`pick_text`.
* **Annotations** (A): :mod:`dvr_gl.annotations`' colour bar, scale bar and axes drawn on the 8-bit
  encoding of the displayed picture (:func:`annotated_display`) and of 8-bit screenshots; never into the
  float image (an EXR or TIFF screenshot is not annotated).
* **Camera path** (shift+K adds the current camera, Backspace clears): keyframe ``k`` (from 0) is at time
  ``k`` seconds, so a path's segments take equal shares of an animation's frames (``dvr render saved.toml
  --frames N``; edit the ``time`` of a ``[[camera.keyframe]]`` to pace it otherwise).
"""

from __future__ import annotations

import math

import numpy as np

from ..annotations import Annotations, annotate
from ..camera_path import CameraPath
from ..image import encode_8bit

PICK_REST_SECONDS = 0.2   # the cursor rests this long on the image before a pick (so moving never pays for one)
VIEWER_ANNOTATIONS = Annotations(colorbar=True, scalebar=True, axes=True)


def cursor_pixel(cursor: tuple[float, float], image_rect, scene_size: tuple[int, int]) -> tuple[float, float] | None:
    """The full-size scene's pixel coordinates ``(x, y)`` (column from the left, row from the top; what
    :func:`dvr_gl.pick` takes) under a window point ``cursor``; ``image_rect``: where the image is drawn
    ``(x, y, width, height)``, window pixels (:class:`.layout.Layout`'s ``image``); ``scene_size``: the
    scene's full image size, pixels.  A reduced-resolution frame is stretched over the same rectangle, so the
    mapping does not depend on it.  None off the image."""
    ix, iy, iw, ih = image_rect
    if iw <= 0 or ih <= 0 or not (ix <= cursor[0] < ix + iw and iy <= cursor[1] < iy + ih):
        return None
    w, h = scene_size
    return (min((cursor[0] - ix) / iw * w, w - 1e-6), min((cursor[1] - iy) / ih * h, h - 1e-6))


def pick_text(p) -> str:
    """The status bar's words for a :class:`dvr_gl.Pick`: the value, the voxel ``(z, y, x)`` and the world
    position (world units), or why there is none."""
    if not p.hit:
        return f"pixel ({p.x}, {p.y}): nothing (the ray's opacity never reaches one half)"
    if p.values:
        value = f"{p.field} {p.values[p.field]:.6g}" if p.field in p.values else "-"
    else:
        value = f"value {p.value:.6g}" if p.value is not None else "value -"
    voxel = f" voxel (z, y, x) {tuple(int(i) for i in p.index)}" if p.index is not None else ""
    x, y, z = p.position
    return f"{value}{voxel} at ({x:.4g}, {y:.4g}, {z:.4g}) depth {p.depth:.4g}"


class PickProbe:
    """When to pick: on (I toggles), after the cursor rests, once per cursor position and scene version."""

    def __init__(self, rest: float = PICK_REST_SECONDS):
        self.enabled, self.rest = True, rest
        self.moved_at = -math.inf
        self.done: tuple | None = None     # (pixel, version) of the text shown
        self.text = ""

    def moved(self, now: float):
        self.moved_at = now

    def due(self, now: float, pixel, version: int, dragging: bool) -> bool:
        """Whether to pick ``pixel`` (None: off the image; the text is cleared) of scene ``version`` now."""
        if not self.enabled or pixel is None:
            self.text, self.done = "", None
            return False
        key = (tuple(int(math.floor(c)) for c in pixel), version)
        return not dragging and now - self.moved_at >= self.rest and key != self.done

    def show(self, pixel, version: int, text: str):
        self.done, self.text = (tuple(int(math.floor(c)) for c in pixel), version), text


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """8-bit sRGB codes to linear values (IEC 61966-2-1), float32."""
    c = np.asarray(c, np.float32) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def annotated_display(shown: np.ndarray, scene, annotations: Annotations = VIEWER_ANNOTATIONS) -> np.ndarray:
    """The displayed picture ``shown`` (linear RGBA, background composited, ``scene``'s size) with the
    annotations drawn on its 8-bit encoding: only the annotations' pixels change, to the linear values of
    their 8-bit codes (the display encodes them back to the same codes)."""
    pixels = encode_8bit(shown)
    drawn = annotate(pixels, scene, annotations)
    changed = np.any(drawn[..., :3] != pixels[..., :3], axis=-1)
    out = np.array(shown, dtype=np.float32, copy=True)
    out[changed, :3] = srgb_to_linear(drawn[changed, :3])
    return out


class KeyframeRecorder:
    """Cameras recorded as a :class:`~dvr_gl.camera_path.CameraPath`: keyframe ``k`` at ``k`` seconds; with a
    time series, each keyframe's step too."""

    def __init__(self):
        self.cameras: list = []
        self.steps: list = []

    def add(self, camera, step: int | None = None) -> str:
        """Add ``camera``; the status line's words.  A camera equal to the last keyframe's is not added."""
        if self.cameras and camera == self.cameras[-1] and (step is None or step == self.steps[-1]):
            return f"camera path: the view is keyframe {len(self.cameras)}'s; turn or move it first"
        self.cameras.append(camera)
        self.steps.append(step)
        n = len(self.cameras)
        more = "; saved with S (the .toml plays it: dvr render FILE.toml --frames N)" if n > 1 else \
            "; add another view (shift+K)"
        return f"camera path: keyframe {n} at {n - 1} s{more}"

    def clear(self) -> str:
        n, self.cameras, self.steps = len(self.cameras), [], []
        return f"camera path: {n} keyframes cleared"

    def path(self) -> CameraPath | None:
        """The recorded path (None with fewer than two keyframes)."""
        if len(self.cameras) < 2:
            return None
        steps = tuple(self.steps) if all(s is not None for s in self.steps) else None
        return CameraPath(tuple(self.cameras), tuple(float(k) for k in range(len(self.cameras))), steps)

    def describe(self) -> str:
        return f"path: {len(self.cameras)} keyframes" if self.cameras else ""

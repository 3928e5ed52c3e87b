"""``dvr bench slicing``: 2D texture stacks against view-aligned 3D slicing, across view angles.

An object-aligned stack samples each ray where it crosses the voxel planes, so
along a ray turned by ``theta`` from the stack axis the samples lie
``1 / cos(theta)`` voxels apart (up to sqrt(2) at 45 degrees in a plane) and the
slices show as stripes; at 45 degrees the renderer switches to the other stack
and every sample moves at once: the image jumps.  View-aligned slices keep one
spacing at every angle.  This sweeps the azimuth (elevation 0, so the x and y
stacks compete and switch at 45 degrees) and reports, per angle, the RMS error
against the converged reference of ``slicing2d`` (post-classified and
pre-integrated) and ``slicing3d`` at one slice per voxel; then the jump: how
much the image changes between ``angle - step`` and ``angle + step`` at 45
degrees (a switch) and at 30 degrees (none), next to the converged reference's
own change (what the rotation alone accounts for).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ....bench import converged, tick
from ....image import check_writable, compare_images, composite_over, write_image
from ....reference.converged import ConvergedReference
from ....reference.plans import stack_axis
from ....scene.resolve import load_scene
from ... import create_renderer, registry

AZIMUTHS = (0.0, 15.0, 30.0, 40.0, 44.0, 46.0, 50.0, 60.0, 75.0, 90.0)
JUMP_ANGLES = (30.0, 45.0)
JUMP_STEP = 0.01   # degrees: so small that the rotation itself barely changes the image
# the stacks are set beside view-aligned slices: the renderer that declares them (3D slicing)
VIEW_ALIGNED = next(iter(registry.renderers_with(lambda p: p.view_aligned_slices and not p.reference)))
METHODS = (("slicing2d", "post"), ("slicing2d", "preintegrated"), (VIEW_ALIGNED, "post"))
COLUMNS = [("azimuth", "azimuth", "g"), ("stack", "stack", ""), ("spacing", "2D spacing (voxels)", ".3f"),
           ("slicing2d post", "slicing2d RMS", ".2e"), ("slicing2d preintegrated", "slicing2d pre-int. RMS", ".2e"),
           (f"{VIEW_ALIGNED} post", f"{VIEW_ALIGNED} RMS", ".2e")]
JUMP_COLUMNS = [("angle", "at azimuth", "g"), ("slicing2d post", "slicing2d change", ".2e"),
                ("slicing2d preintegrated", "slicing2d pre-int. change", ".2e"),
                (f"{VIEW_ALIGNED} post", f"{VIEW_ALIGNED} change", ".2e"), ("converged", "converged change", ".2e")]
BLACK = (0.0, 0.0, 0.0, 1.0)
ERROR_GAIN = 2.0   # the error pictures show |image - converged| times this


def base_scene(volume_size: int, size: int, volume: str | None = None) -> dict:
    base = {"image.width": size, "image.height": size, "camera.elevation": 0.0,
            "renderer.sample_distance_voxels": 1.0, "renderer.acceleration": False}
    if volume:
        base["volume.path"] = volume
    else:
        base.update({"volume.demo": "shepp-logan", "volume.size": volume_size})
    return base


class _Sweep:
    """Renders one base scene at given azimuths with each method and the converged reference."""

    ZOOM = 0.65   # of the default distance (which fits the box's bounding sphere): the object fills the frame

    def __init__(self, base: dict):
        first = load_scene(None, base)
        self.base = {**base, "camera.distance": self.ZOOM * first.camera.orbit[2]}
        self.volume = first.volume                          # one volume object: textures upload once
        self.renderers = {}

    def scene(self, azimuth: float, classification: str = "post"):
        scene = load_scene(None, {**self.base, "camera.azimuth": azimuth, "renderer.classification": classification})
        return scene.replace(volume=self.volume)

    def render(self, name: str, classification: str, azimuth: float) -> np.ndarray:
        if name not in self.renderers:
            self.renderers[name] = create_renderer(name)
        image = self.renderers[name].render(self.scene(azimuth, classification))
        tick()
        return image

    def converged(self, azimuth: float) -> np.ndarray:
        return converged(ConvergedReference(self.scene(azimuth)), float64=True).astype(np.float32)

    def close(self):
        for r in self.renderers.values():
            r.close()


def run(base: dict, azimuths=AZIMUTHS, pictures: Path | None = None, overwrite: bool = False):
    """Rows of the angle table, rows of the jump table, and the pictures written."""
    sweep = _Sweep(base)
    rows, jumps, sheet = [], [], []
    try:
        for azimuth in azimuths:
            scene = sweep.scene(azimuth)
            axis = stack_axis(scene.camera)
            forward = scene.camera.basis()[0]
            truth = sweep.converged(azimuth)
            row = {"azimuth": azimuth, "stack": "xyz"[axis],
                   "spacing": scene.volume.spacing[axis] / abs(forward[axis]) / min(scene.volume.spacing)}
            images = {}
            for name, classification in METHODS:
                images[(name, classification)] = sweep.render(name, classification, azimuth)
                row[f"{name} {classification}"] = compare_images(images[(name, classification)], truth)["rms"]
            rows.append(row)
            sheet.append(_sheet_row(truth, images[("slicing2d", "post")], images[(VIEW_ALIGNED, "post")]))
        for angle in JUMP_ANGLES:
            jump = {"angle": angle}
            views = (angle - JUMP_STEP, angle + JUMP_STEP)
            for name, classification in METHODS:
                a, b = (sweep.render(name, classification, v) for v in views)
                jump[f"{name} {classification}"] = compare_images(a, b)["rms"]
            before, after = (sweep.converged(v) for v in views)
            jump["converged"] = compare_images(before, after)["rms"]
            jumps.append(jump)
            if angle == 45.0:
                a, b = (sweep.render("slicing2d", "post", v) for v in views)
                jump_sheet = [_opaque(a), _opaque(b), _error(a, b)]
    finally:
        sweep.close()
    written = []
    if pictures is not None:
        for name, picture in (("slicing_sweep.png", np.concatenate(sheet, axis=0)),
                              ("slicing_jump.png", np.concatenate(jump_sheet, axis=1))):
            write_image(Path(pictures) / name, picture, overwrite)
            written.append(Path(pictures) / name)
    return rows, jumps, written


def check_pictures(folder: Path, overwrite: bool = False):
    """Fail before any work if the pictures cannot be written."""
    for name in ("slicing_sweep.png", "slicing_jump.png"):
        check_writable(Path(folder) / name, overwrite)


def _opaque(rgba: np.ndarray) -> np.ndarray:
    return composite_over(rgba, BLACK)


def _error(image: np.ndarray, truth: np.ndarray) -> np.ndarray:
    diff = np.abs(_opaque(image) - _opaque(truth)) * ERROR_GAIN
    diff[..., 3] = 1.0
    return np.clip(diff, 0.0, 1.0)


def _sheet_row(truth, stack, view_aligned) -> np.ndarray:
    """One row of the sweep picture: converged | slicing2d | slicing3d | slicing2d error | slicing3d error."""
    return np.concatenate([_opaque(truth), _opaque(stack), _opaque(view_aligned), _error(stack, truth),
                           _error(view_aligned, truth)], axis=1)

"""Orientation: the patient frame of a volume whose header states one, and the anatomical views.

A file's header may say how its index axes lie in the patient (NRRD ``space directions``, NIfTI's
sform or qform, DICOM's ImageOrientationPatient, MetaImage's ``TransformMatrix``); the readers keep
that as :attr:`dvr_gl.Volume.direction`, the columns being the x, y and z index axes in the **LPS**
frame (x toward the patient's left, y toward posterior, z toward superior: DICOM's and ITK's
convention; NIfTI's RAS is converted on reading).  Sample ``(i, j, k)`` lies at
``origin + direction @ (i*sx, j*sy, k*sz)`` in that frame.

The voxels are never reordered.  The renderers work in the volume's own frame (sample ``(i, j, k)``
at ``origin + (i*sx, j*sy, k*sz)``), and the camera, which the scene states in the patient frame,
is turned into that frame just before a frame is drawn (:func:`volume_frame_scene`, called by
:meth:`dvr_gl.renderers.Renderer.render`).  A direction matrix with determinant -1 (one axis stored
mirrored, common in radiological files) turns a right-handed camera into a left-handed one, which no
renderer draws; so the renderer draws the mirrored view, and the image's columns are flipped back.

What stays in the volume's own frame: clipping regions, opaque meshes and the lights' directions and
positions (``renderer.clipping``, ``renderer.geometry``, ``renderer.shading.lights``,
``renderer.scattering.lights``) are given in the data's axes, as before; with an identity direction
(every file that states none, and every array) the two frames are one.

The anatomical views (:data:`ANATOMICAL_VIEWS`) orbit the camera about the volume's centre with
superior up, each from the side its name gives: ``anterior`` looks at the face (the patient's left
on the image's right), ``superior`` down on the head with anterior at the top, ``inferior`` up from
the feet with anterior at the top (the radiological axial view).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .errors import SceneError
from .fields.grid import IDENTITY

#: view name -> (azimuth, elevation) in degrees about ``up = +z`` (superior), see :mod:`dvr_gl.camera`'s orbit
#: frame: azimuth 0 puts the eye on the -y side, which is anterior in LPS; azimuth 90 on +x, the left.
ANATOMICAL_VIEWS = {
    "anterior": (0.0, 0.0), "posterior": (180.0, 0.0), "left": (90.0, 0.0), "right": (-90.0, 0.0),
    "superior": (180.0, 90.0), "inferior": (0.0, -90.0),
}

_LETTERS = (("L", "R"), ("P", "A"), ("S", "I"))  # LPS axes: + letter, - letter


def view_orbit(view: str, azimuth=None, elevation=None) -> tuple[float, float]:
    """``(azimuth, elevation)`` of an anatomical view; refused in one line when the view is unknown or an
    azimuth or elevation is given with it (the view sets both)."""
    if view not in ANATOMICAL_VIEWS:
        raise SceneError(f"camera.view {view!r} is not one of {', '.join(ANATOMICAL_VIEWS)}")
    if azimuth is not None or elevation is not None:
        raise SceneError(f"camera: view = {view!r} sets azimuth and elevation; give one or the other")
    return ANATOMICAL_VIEWS[view]


def direction_of(field) -> np.ndarray:
    """The field's direction matrix (identity for fields that state none: meshes, particles, spheres)."""
    return np.asarray(getattr(field, "direction", IDENTITY), dtype=np.float64)


def is_oriented(field) -> bool:
    return tuple(map(tuple, direction_of(field))) != IDENTITY


def axis_letters(direction) -> str:
    """The patient direction each index axis points to most, e.g. ``LPS`` or ``RAS``; a lower-case letter
    marks an oblique axis (less than 0.9 of it along that patient axis)."""
    m = np.asarray(direction, dtype=np.float64)
    letters = []
    for column in m.T:
        axis = int(np.argmax(np.abs(column)))
        letter = _LETTERS[axis][0 if column[axis] > 0 else 1]
        letters.append(letter if abs(column[axis]) >= 0.9 else letter.lower())
    return "".join(letters)


def to_volume_frame(field, points) -> np.ndarray:
    """Patient-frame points ``(..., 3)`` in the volume's own frame: ``origin + D^T (p - origin)``."""
    d, o = direction_of(field), np.asarray(getattr(field, "origin", (0.0, 0.0, 0.0)), dtype=np.float64)
    return o + (np.asarray(points, dtype=np.float64) - o) @ d


def to_patient_frame(field, points) -> np.ndarray:
    """Volume-frame points ``(..., 3)`` in the patient frame: ``origin + D (p - origin)``."""
    d, o = direction_of(field), np.asarray(getattr(field, "origin", (0.0, 0.0, 0.0)), dtype=np.float64)
    return o + (np.asarray(points, dtype=np.float64) - o) @ d.T


def volume_frame_scene(scene):
    """``(scene, mirrored)``: the scene with its camera turned from the patient frame into the volume's
    own frame, and whether the drawn image must be flipped left to right (a direction matrix with
    determinant -1).  The scene itself when its field has no orientation."""
    field = scene.field
    if not is_oriented(field):
        return scene, False
    d = direction_of(field)
    cam = scene.camera
    f, r, u = cam.basis()  # the patient-frame basis, poles included (the orbit's azimuth sets it there)
    eye = to_volume_frame(field, cam.eye)
    distance = float(np.linalg.norm(np.subtract(cam.target, cam.eye)))
    f_v, u_v = f @ d, u @ d  # D^T f, D^T u
    mirrored = bool(np.linalg.det(d) < 0)
    local = dataclasses.replace(cam, eye=tuple(eye), target=tuple(eye + distance * f_v), up=tuple(u_v),
                                orbit=None)
    return dataclasses.replace(scene, camera=local), mirrored

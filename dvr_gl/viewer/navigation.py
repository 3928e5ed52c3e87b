"""Navigation: mouse motion in window pixels to camera changes (pure; no window).

Conventions (:mod:`dvr_gl.camera`): angles in degrees, world units, image y down.  Dragging
*grabs* the volume: the point under the cursor follows it.

* **Orbit** (left drag): ``dx`` pixels right turns the volume right, i.e. the eye's azimuth
  decreases by ``dx * ORBIT_DEGREES_PER_PIXEL``; ``dy`` pixels down turns its top toward the
  viewer, i.e. the elevation increases.  Elevation stays within +-:data:`MAX_ELEVATION`, short of
  the poles where the up vector and the view direction would coincide.
* **Pan** (middle or shift-left drag): the target moves in the image plane so that the plane
  through the target follows the cursor exactly (world units per pixel from the field of view and
  distance, or the orthographic view height).
* **Zoom** (wheel): each wheel step multiplies the distance (perspective) or the view height
  (orthographic) by :data:`ZOOM_PER_STEP` (steps away from the viewer zoom in).
* **Projection toggle** keeps the size of the plane through the target: view height
  ``= 2 d tan(fov / 2)`` and back.
"""

from __future__ import annotations

import numpy as np

from ..camera import Camera

ORBIT_DEGREES_PER_PIXEL = 0.4
MAX_ELEVATION = 89.0
ZOOM_PER_STEP = 0.9
MIN_DISTANCE = 1e-6


def orbit(camera: Camera, dx: float, dy: float) -> Camera:
    """The camera after a drag of ``(dx, dy)`` window pixels (x right, y down) that turns the volume."""
    az, el, dist = camera.orbit or camera.orbited().orbit
    el = min(MAX_ELEVATION, max(-MAX_ELEVATION, el + dy * ORBIT_DEGREES_PER_PIXEL))
    return camera.orbited(azimuth=az - dx * ORBIT_DEGREES_PER_PIXEL, elevation=el)


def world_per_pixel(camera: Camera, image_height: int) -> float:
    """World length of one pixel on the plane through the target, perpendicular to the view."""
    _, half_h = camera.half_extent(1.0)
    if camera.projection == "orthographic":
        return 2.0 * half_h / image_height
    dist = float(np.linalg.norm(np.subtract(camera.eye, camera.target)))
    return 2.0 * dist * half_h / image_height


def pan(camera: Camera, dx: float, dy: float, image_height: int) -> Camera:
    """The camera moved in its image plane so the target plane follows a drag of ``(dx, dy)`` pixels."""
    _, right, up = camera.basis()
    step = world_per_pixel(camera, image_height)
    shift = (-dx * right + dy * up) * step
    az, el, dist = camera.orbit or camera.orbited().orbit
    target = tuple(np.asarray(camera.target) + shift)
    return Camera.from_orbit(target, camera.up, az, el, dist, projection=camera.projection, fov=camera.fov,
                             view_height=camera.view_height, near=camera.near)


def zoom(camera: Camera, steps: float) -> Camera:
    """The camera after ``steps`` wheel steps (positive: toward the target)."""
    factor = ZOOM_PER_STEP ** steps
    if camera.projection == "orthographic":
        return camera.with_(view_height=camera.view_height * factor)
    _, _, dist = camera.orbit or camera.orbited().orbit
    return camera.orbited(distance=max(MIN_DISTANCE, dist * factor))


def toggle_projection(camera: Camera) -> Camera:
    """Perspective to orthographic or back, keeping the size of the plane through the target."""
    _, _, dist = camera.orbit or camera.orbited().orbit
    _, half = camera.with_(projection="perspective").half_extent(1.0)
    if camera.projection == "perspective":
        return camera.with_(projection="orthographic", view_height=2.0 * dist * half)
    distance = camera.view_height / (2.0 * half)
    return camera.with_(projection="perspective").orbited(distance=distance)

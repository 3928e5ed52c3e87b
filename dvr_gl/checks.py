"""Checks of one value, shared by the scene file's keys, the renderer settings and the Python constructors.

A check takes a value and returns what is wrong with it, as a phrase completing "<key> ..." (``"must be
positive"``), or None; the caller raises :class:`dvr_gl.errors.SceneError` naming its key, so a scene file and a
Camera or a field built in Python are refused with the same words.  This module sits at the bottom of the
package (it imports nothing of it): the camera and the fields check world lengths here, below the scene
contract (:mod:`dvr_gl.scene.settings`, :mod:`dvr_gl.scene.schema`) that declares its keys with the same checks.
"""

from __future__ import annotations

from typing import Optional


def positive(value) -> Optional[str]:
    return None if value > 0 else "must be positive"


def at_least(n):
    return lambda value: None if value >= n else f"must be at least {n}"


#: World lengths (voxel spacing, box extent, coordinates, camera distances) must lie in this range: GL
#: shaders work in float32, whose squared lengths leave the normal range (1.2e-38 .. 3.4e38) beyond it.
WORLD_RANGE = (1e-18, 1e18)


def world_coordinates(values) -> Optional[str]:
    """A point (world units) within :data:`WORLD_RANGE` of the origin."""
    return None if all(abs(v) <= WORLD_RANGE[1] for v in values) else f"must be within {WORLD_RANGE[1]:g} of the origin"


def world_length(value) -> Optional[str]:
    """A length (world units) in :data:`WORLD_RANGE`."""
    lo, hi = WORLD_RANGE
    return None if lo <= value <= hi else f"must be in [{lo:g}, {hi:g}] world units"


def between(lo, hi, open_lo=False, open_hi=False, what=""):
    """A number in ``[lo, hi]`` (``open_lo``, ``open_hi``: the end left out); ``what`` ends the phrase (units)."""
    text = f"must be in {'(' if open_lo else '['}{lo:g}, {hi:g}{')' if open_hi else ']'}{what}"

    def check(value):
        ok_lo = value > lo if open_lo else value >= lo
        ok_hi = value < hi if open_hi else value <= hi
        return None if ok_lo and ok_hi else text
    return check

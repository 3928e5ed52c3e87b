"""Colour maps by name: viridis from its shipped table (with or without matplotlib) and any
matplotlib colour map when matplotlib is installed (the ``plot`` extra).

A colour map becomes a stretched :class:`~dvr_gl.presets.property.VolumeProperty`: its 256 entries
(sRGB-encoded, as matplotlib's) evenly over the data's value range, with the opacity ramp
:data:`~dvr_gl.presets.property.RAMP_ALPHA` (0 at the low end to 0.1 per unit distance at the high end).
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from .property import RAMP_ALPHA, VolumeProperty

VIRIDIS_FILE = Path(__file__).with_name("viridis.csv")
ENTRIES = 256


@functools.lru_cache(maxsize=1)
def viridis_table() -> np.ndarray:
    """matplotlib's viridis, ``(256, 3)`` sRGB-encoded (CC0; LICENSE-viridis.txt)."""
    return np.loadtxt(VIRIDIS_FILE, delimiter=",", comments="#")


def from_table(name: str, srgb: np.ndarray) -> VolumeProperty:
    """A colour map's table ``(N, 3)`` (sRGB) as a stretched property over ``0..1``."""
    x = np.linspace(0.0, 1.0, len(srgb))
    colours = np.column_stack([x, srgb])
    return VolumeProperty(name, np.array([[0.0, 0.0], [1.0, RAMP_ALPHA]]), colours, "rgb", True,
                          source=f"colour map {name}")


def matplotlib_names() -> dict[str, str] | None:
    """matplotlib's colour-map names by their lower case, or None without matplotlib."""
    try:
        import matplotlib
    except ImportError:
        return None
    return {n.lower(): n for n in matplotlib.colormaps}


def matplotlib_map(name: str) -> VolumeProperty:
    """matplotlib's colour map ``name`` (its exact spelling) sampled at 256 entries."""
    import matplotlib

    cmap = matplotlib.colormaps[name]
    return from_table(name, cmap(np.linspace(0.0, 1.0, ENTRIES))[:, :3])

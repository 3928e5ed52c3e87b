"""What a format reader returns, and how readers find their optional library."""

from __future__ import annotations

import importlib
from dataclasses import dataclass

import numpy as np

from ..errors import VolumeError


@dataclass
class RawArray:
    """A reader's result: ``data[z, y, x]`` plus the geometry the file states (None: not stated)."""

    data: np.ndarray
    spacing: tuple[float, float, float] | None = None
    origin: tuple[float, float, float] | None = None


def require(module: str, package: str, extra: str):
    """Import an optional reader library, or say which extra installs it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise VolumeError(f"reading this format needs the {package} package: "
                          f"pip install 'dvr-gl[{extra}]' (or pip install {package})") from exc

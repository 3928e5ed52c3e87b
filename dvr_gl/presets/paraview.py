"""ParaView's colour-map presets in JSON (what "Export" in ParaView's preset dialog writes): a list
of objects (or one object) with ``Name``, ``ColorSpace`` and ``RGBPoints`` (flat ``x, r, g, b, ...``,
sRGB-encoded), optionally ``Points`` (opacity: flat ``x, alpha, midpoint, sharpness, ...``).

ParaView stretches a preset onto the data's range when it applies one, so these are stretched too
(the colour points' range onto the volume's value range) unless the scene says
``transfer_function.stretch = false`` (values as written, data units).  A map without ``Points`` gets
the ramp of :data:`~dvr_gl.presets.property.RAMP_ALPHA`.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..errors import SceneError
from ..sandbox import check_bytes
from .property import RAMP_ALPHA, VolumeProperty, flat_rows, unique_values

_SPACES = {"rgb": "rgb", "lab": "lab", "cielab": "lab", "hsv": "hsv", "diverging": "diverging"}
_MAX_BYTES = 64 * 2 ** 20
# Python objects per byte of JSON at most: a number in two bytes ("0,") is a 24-32 byte object and a
# list's 8-byte pointer to it.
_OBJECT_BYTES = 20


def read_maps(path: Path) -> list[dict]:
    """The JSON objects of a ParaView preset file, each with ``Name``."""
    path = Path(path)
    size = os.path.getsize(path)
    if size > _MAX_BYTES:
        raise SceneError(f"{path}: too large for a colour-map file ({size} bytes)")
    check_bytes(_OBJECT_BYTES * size, f"{path}: reading the colour-map file", "give a smaller file or allow more "
                "memory (--max-memory)")
    try:
        data = json.loads(path.read_bytes())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: not valid JSON ({exc}); give a ParaView colour-map export") from None
    except RecursionError:  # the decoder's own guard against deep nesting ([[[[...]]]]), before the C stack's
        raise SceneError(f"{path}: JSON nested too deeply for a colour-map file (a ParaView export is three "
                         f"levels deep); give a ParaView colour-map export") from None
    maps = data if isinstance(data, list) else [data]
    if not maps or not all(isinstance(m, dict) for m in maps):
        raise SceneError(f"{path}: not a ParaView colour-map file (a JSON object or list of objects with "
                         f"RGBPoints)")
    return maps


def choose(maps: list[dict], name: str | None, path: Path) -> dict:
    """The map called ``name`` (any case), or the only one."""
    names = [str(m.get("Name", f"map {i + 1}")) for i, m in enumerate(maps)]
    if name is None:
        if len(maps) > 1:
            shown = ", ".join(names[:5]) + (", ..." if len(names) > 5 else "")
            raise SceneError(f"{path}: holds {len(maps)} colour maps ({shown}); name one with "
                             f"transfer_function.name in the scene file")
        return maps[0]
    for n, m in zip(names, maps):
        if n.lower() == name.lower():
            return m
    raise SceneError(f"{path}: no colour map named {name!r}; it holds {', '.join(names[:8])}")


def to_property(m: dict, where: str, stretch: bool | None) -> VolumeProperty:
    """One map as a :class:`VolumeProperty`."""
    name = str(m.get("Name", Path(where).stem))
    where = f"{where}, {name}"
    if "RGBPoints" not in m:
        extra = " (an indexed/categorical map)" if "IndexedColors" in m else ""
        raise SceneError(f"{where}: no RGBPoints{extra}; give a continuous colour map")
    space_name = str(m.get("ColorSpace", "RGB"))
    space = _SPACES.get(space_name.lower())
    if space is None:
        raise SceneError(f"{where}: ColorSpace {space_name!r} is not supported; use RGB, Lab, HSV or Diverging")
    colours = flat_rows(m["RGBPoints"], 4, f"{where}: RGBPoints")
    colours = colours[np.argsort(colours[:, 0], kind="stable")]
    colours[:, 0] = unique_values(colours[:, 0])
    if not ((colours[:, 1:] >= 0) & (colours[:, 1:] <= 1)).all():
        raise SceneError(f"{where}: RGBPoints colours outside [0, 1]")
    if "Points" in m:
        opacity = _opacity(flat_rows(m["Points"], 4, f"{where}: Points"), where)
    else:
        opacity = np.array([[colours[0, 0], 0.0], [colours[-1, 0], RAMP_ALPHA]])
        if len(colours) == 1 or colours[-1, 0] == colours[0, 0]:
            opacity = np.array([[colours[0, 0], RAMP_ALPHA]])
    return VolumeProperty(name, opacity, colours, space, True if stretch is None else bool(stretch), None, None, 1,
                          where)


def _opacity(rows: np.ndarray, where: str) -> np.ndarray:
    """``(value, alpha)`` rows of ParaView's ``x, alpha, midpoint, sharpness`` points: a midpoint other
    than 0.5 with sharpness 0 is still piecewise linear (half the step at the midpoint); a sharpness
    above 0 is a curve we do not model, refused."""
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    if not ((rows[:, 1] >= 0) & (rows[:, 1] <= 1)).all():
        raise SceneError(f"{where}: Points opacity outside [0, 1]")
    if (rows[:-1, 3] != 0).any():
        raise SceneError(f"{where}: Points with sharpness above 0 (curved opacity) are not supported; set "
                         f"sharpness to 0 in ParaView's opacity editor")
    if ((rows[:-1, 2] <= 0) | (rows[:-1, 2] >= 1)).any():
        raise SceneError(f"{where}: Points midpoints must lie strictly between 0 and 1")
    out = []
    for (x0, a0, mid, _), (x1, a1, _, _) in zip(rows[:-1], rows[1:]):
        out.append((x0, a0))
        if mid != 0.5 and x1 > x0:
            out.append((x0 + mid * (x1 - x0), (a0 + a1) / 2))
    out.append(tuple(rows[-1, :2]))
    out = np.array(out)
    out[:, 0] = unique_values(out[:, 0])
    return out

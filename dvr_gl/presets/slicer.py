"""3D Slicer's volume properties: the presets (an MRML scene of ``VolumeProperty`` elements, as in
``slicer_presets.xml``) and the ``.vp`` text file Slicer saves a volume property to.

A ``.vp`` file is nine lines (vtkMRMLVolumePropertyStorageNode): interpolation (0 nearest, 1 linear),
shade (0/1), diffuse, ambient, specular, specular power, then three functions written as a count
followed by that many numbers: scalar opacity ``(value, alpha)`` pairs, gradient opacity
``(|gradient|, factor)`` pairs, colour ``(value, r, g, b)`` quadruples.  The XML attributes hold the
same (``scalarOpacity``, ``gradientOpacity``, ``colorTransfer``, ``shade``, ...).  Values are in the
data's units (Hounsfield units for CT); alpha is per unit distance (VTK's ScalarOpacityUnitDistance,
1 world unit, a millimetre in Slicer).
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

from ..errors import SceneError
from .property import VolumeProperty, flat_rows, unique_values

PRESETS_FILE = Path(__file__).with_name("slicer_presets.xml")
_MAX_BYTES = 16 * 2 ** 20  # volume properties are a few kB


def _function(text: str, width: int, what: str) -> np.ndarray:
    """Slicer's ``"count n1 n2 ..."`` string as ``(count / width, width)`` rows, values made unique."""
    try:
        numbers = [float(t) for t in str(text).split()]
    except ValueError:
        raise SceneError(f"{what}: not a list of numbers ({str(text)[:40]!r})") from None
    if not numbers or numbers[0] != len(numbers) - 1:
        raise SceneError(f"{what}: the count {numbers[0] if numbers else 'missing'} does not match the "
                         f"{max(len(numbers) - 1, 0)} numbers that follow")
    rows = flat_rows(numbers[1:], width, what)
    rows[:, 0] = unique_values(rows[:, 0])
    return rows


def _number(text, what: str) -> float:
    try:
        value = float(str(text).split()[0])
    except (ValueError, IndexError):
        raise SceneError(f"{what}: not a number ({str(text)[:40]!r})") from None
    if not np.isfinite(value):
        raise SceneError(f"{what}: not a finite number")
    return value


def _property(name: str, fields: dict, where: str) -> VolumeProperty:
    """A property from its nine fields (strings, named as in the XML)."""
    opacity = _function(fields["scalarOpacity"], 2, f"{where}: scalar opacity")
    colours = _function(fields["colorTransfer"], 4, f"{where}: colour transfer function")
    gradient = _function(fields["gradientOpacity"], 2, f"{where}: gradient opacity") \
        if str(fields.get("gradientOpacity", "")).strip() else None
    if not ((opacity[:, 1] >= 0) & (opacity[:, 1] <= 1)).all():
        raise SceneError(f"{where}: scalar opacity outside [0, 1]")
    if not ((colours[:, 1:] >= 0) & (colours[:, 1:] <= 1)).all():
        raise SceneError(f"{where}: colour outside [0, 1]")
    shading = {"enabled": bool(_number(fields["shade"], f"{where}: shade")),
               "ambient": _number(fields["ambient"], f"{where}: ambient"),
               "diffuse": _number(fields["diffuse"], f"{where}: diffuse"),
               "specular": _number(fields["specular"], f"{where}: specular"),
               "shininess": _number(fields["specularPower"], f"{where}: specular power")}
    if min(shading[k] for k in ("ambient", "diffuse", "specular", "shininess")) < 0:
        raise SceneError(f"{where}: a negative shading coefficient")
    interpolation = int(_number(fields["interpolation"], f"{where}: interpolation"))
    return VolumeProperty(name, opacity, colours, "rgb", False, shading, gradient, interpolation, where)


def read_presets(path: Path = PRESETS_FILE) -> dict[str, VolumeProperty]:
    """The ``VolumeProperty`` elements of a Slicer MRML/XML file by name, in file order (read again
    when the file changes)."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    if st.st_size > _MAX_BYTES:
        raise SceneError(f"{path}: too large for a volume property file ({st.st_size} bytes)")
    return _read_presets(str(path), st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=8)
def _read_presets(path: str, mtime_ns: int, size: int) -> dict[str, VolumeProperty]:
    where = Path(path).name
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    elements = _volume_properties(data, path)
    out = {}
    for a in elements:
        name = a.get("name", f"property {len(out) + 1}")
        missing = [k for k in ("scalarOpacity", "colorTransfer", "shade", "ambient", "diffuse", "specular",
                               "specularPower", "interpolation") if k not in a]
        if missing:
            raise SceneError(f"{where}: VolumeProperty {name!r} lacks {', '.join(missing)}")
        out[name] = _property(name, a, f"{where}, {name}")
    if not out:
        raise SceneError(f"{path}: no VolumeProperty elements; give a Slicer presets/MRML file")
    return out


class _Declaration(Exception):
    """A DOCTYPE or entity declaration met by :func:`_volume_properties`."""


def _volume_properties(data: bytes, path) -> list[dict]:
    """The attributes of each ``VolumeProperty`` element of an XML document, in order: read by expat as
    it streams (no tree: memory as the attributes, however deep the nesting).  A DOCTYPE (and so any entity
    declaration) is refused as it is met, before anything is expanded: entities that expand into each
    other (the "billion laughs") or name other files are XML's ways to make a small file huge or to read
    outside the sandbox, and Slicer writes neither."""
    import xml.parsers.expat

    found = []

    def refuse(*_):
        raise _Declaration()

    def start(name, attributes):
        if name == "VolumeProperty":
            found.append(attributes)

    parser = xml.parsers.expat.ParserCreate()
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    parser.StartElementHandler = start
    try:
        parser.Parse(data, True)
    except _Declaration:
        raise SceneError(f"{path}: holds a DOCTYPE or entity declaration, which volume property files do not "
                         f"use (entities can expand without bound); remove it") from None
    except (xml.parsers.expat.ExpatError, LookupError, ValueError) as exc:  # LookupError: an unknown encoding
        raise SceneError(f"{path}: not a valid XML file ({exc})") from None
    return found


def read_vp(path: Path) -> VolumeProperty:
    """A Slicer ``.vp`` file (see the module doc)."""
    path = Path(path)
    if os.path.getsize(path) > _MAX_BYTES:
        raise SceneError(f"{path}: too large for a volume property file ({os.path.getsize(path)} bytes)")
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError:
        raise SceneError(f"{path}: not a text file; a Slicer .vp file is nine lines of numbers") from None
    lines = [ln.strip() for ln in lines]
    while lines and not lines[-1]:
        lines.pop()
    if len(lines) != 9:
        raise SceneError(f"{path}: {len(lines)} lines, but a Slicer .vp file has nine (interpolation, shade, "
                         f"diffuse, ambient, specular, specular power, scalar opacity, gradient opacity, colour)")
    keys = ("interpolation", "shade", "diffuse", "ambient", "specular", "specularPower", "scalarOpacity",
            "gradientOpacity", "colorTransfer")
    return _property(path.stem, dict(zip(keys, lines)), path.name)

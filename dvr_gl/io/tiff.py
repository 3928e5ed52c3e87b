"""TIFF stacks through OpenImageIO: a multi-page TIFF, a folder of slices, or a glob; ImageJ and OME-TIFF
hyperstacks of several channels and time points.

A plain stack: each page (or file, in natural sort order) is one z slice; all must have the same size and
one sample per pixel, or with ``volume.role = "rgb"`` 3 or 4 (r, g, b and alpha; a colour volume,
:mod:`dvr_gl.fields.color`, its codes sRGB-decoded there).

A hyperstack is one file whose description says how its pages are laid out:

* ImageJ (``ImageJ=`` descriptions): ``channels=C``, ``slices=Z``, ``frames=T``, ``images=C*Z*T`` pages
  in ImageJ's order, channels fastest, then slices, then frames (page ``c + C (z + Z t)``); the voxel size
  from its calibration where it names a ``unit``: x and y the inverse of the XResolution and YResolution
  tags (pixels per unit), z its ``spacing``; the seconds between frames its ``finterval`` (in ``tunit``,
  default seconds).  ImageJ names no channel: they are ``channel k``.
* OME-TIFF (an OME-XML description of one image): ``SizeZ``, ``SizeC``, ``SizeT`` planes in the order
  ``DimensionOrder`` gives (``XYZCT``: z fastest), or as its ``TiffData`` elements map planes to pages
  (``IFD``, ``PlaneCount``, ``FirstZ``/``FirstC``/``FirstT``); the voxel size from ``PhysicalSizeX/Y/Z``
  (in micrometres where their units differ), the interval from ``TimeIncrement``; channel names from its
  ``Channel`` elements.

``volume.channel`` and ``volume.time`` (:mod:`.channels`) choose; only the pages of the chosen time step
(and channel) are read.  A file is checked against what it says of itself before its pages are trusted,
since OpenImageIO stops at the first page it cannot reach without a word (a 30-page stack cut at 30 % read
as 9 slices):

* its chain of pages (IFDs) is walked here: every page and every strip or tile of its pixels must lie
  inside the file (a cut file is refused, naming the first page past its end);
* an ImageJ description's ``images=`` (else ``channels x slices x frames``), or an OME-XML description's
  ``SizeZ x SizeC x SizeT``, must equal the pages found; a count of zero, below zero, not a number, or one
  that does not match the others is refused in one line.  Every file is checked (a FIFO named ``x.tif``
  is refused)
and each page's size counts against the memory budget before it is read.  A plain TIFF's resolution tags
rarely hold the voxel spacing, so without an ImageJ or OME calibration spacing defaults to 1 and is set in
the scene (``volume.spacing``).
"""

from __future__ import annotations

import math
import os
import re
import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import progress
from ..errors import VolumeError
from ..sandbox import check_bytes, check_input_path
from .channels import MAX_COUNT, Axes, RawChannels, channel_names, pick_channel, pick_step, seconds
from .common import RawArray, show
from .series import is_pattern, natural_key

# tag -> what it holds: the pixels' offsets and byte counts, in strips or tiles; the resolution (pixels per unit)
STRIP_OFFSETS, STRIP_COUNTS, TILE_OFFSETS, TILE_COUNTS, DESCRIPTION = 273, 279, 324, 325, 270
X_RESOLUTION, Y_RESOLUTION = 282, 283
# TIFF field type -> (struct code, bytes): BYTE, ASCII, SHORT, LONG, RATIONAL (two LONGs), LONG8
FIELD_TYPES = {1: ("B", 1), 2: ("B", 1), 3: ("H", 2), 4: ("I", 4), 5: ("I", 4), 16: ("Q", 8)}
MAX_DESCRIPTION = 16 << 20  # bytes of ImageDescription read: a longer one is not checked
#: OME's length units in micrometres (where PhysicalSizeX, Y and Z state different units).
MICROMETRES = {"m": 1e6, "cm": 1e4, "mm": 1e3, "µm": 1.0, "um": 1.0, "nm": 1e-3, "Å": 1e-4, "pm": 1e-6}


class _Chain:
    """The chain of pages (IFDs) of a classic or Big TIFF, read with seeks (not the whole file)."""

    def __init__(self, fh, path: Path):
        self.fh, self.path = fh, path
        self.size = os.fstat(fh.fileno()).st_size
        head = fh.read(16)
        order = {b"II": "<", b"MM": ">"}.get(head[:2])
        magic = struct.unpack(order + "H", head[2:4])[0] if order and len(head) >= 8 else None
        if magic not in (42, 43):
            raise VolumeError(f"{path}: not a TIFF file (no II*/MM* header); give TIFF slices")
        self.order, self.big = order, magic == 43
        self.word = "Q" if self.big else "I"
        if self.big and len(head) < 16:
            raise VolumeError(f"{path}: its BigTIFF header is cut short; the file is truncated")
        self.first = struct.unpack(order + self.word, head[8:16] if self.big else head[4:8])[0]

    def read(self, at: int, n: int) -> bytes:
        if at < 0 or n < 0 or at + n > self.size:
            raise _Cut(at + n)
        self.fh.seek(at)
        return self.fh.read(n)

    def pages(self):
        """Each page's ``(its offset, {tag: (type, count, value bytes or their offset)})``."""
        at, seen = self.first, set()
        entry, count_code = (20, "Q") if self.big else (12, "H")
        while at:
            if at in seen:
                raise VolumeError(f"{self.path}: its chain of pages loops back to page {len(seen)}'s "
                                  f"predecessor; the file is damaged")
            seen.add(at)
            count_size = struct.calcsize(count_code)
            n = struct.unpack(self.order + count_code, self.read(at, count_size))[0]
            body = self.read(at + count_size, n * entry + struct.calcsize(self.word))
            tags = {}
            for i in range(n):
                if self.big:
                    tag, kind, count, value = struct.unpack(self.order + "HHQ8s", body[i * 20:i * 20 + 20])
                else:
                    tag, kind, count, value = struct.unpack(self.order + "HHI4s", body[i * 12:i * 12 + 12])
                tags[tag] = (kind, count, value)
            yield at, tags
            at = struct.unpack(self.order + self.word, body[n * entry:])[0]

    def read_field(self, field) -> bytes:
        """A field's bytes (inline, or where its offset points); b"" for a type not of bytes or over
        :data:`MAX_DESCRIPTION`."""
        kind, count, value = field
        if kind not in (1, 2) or count > MAX_DESCRIPTION:
            return b""
        if count <= len(value):
            return value[:count]
        return self.read(struct.unpack(self.order + ("Q" if self.big else "I"), value)[0], count)

    def values(self, field) -> list[int]:
        """A field's numbers (inline, or where its offset points); a RATIONAL's as numerator, denominator."""
        kind, count, value = field
        if kind not in FIELD_TYPES:
            return []
        code, size = FIELD_TYPES[kind]
        count *= 2 if kind == 5 else 1
        inline = len(value)
        blob = value[:count * size] if count * size <= inline else \
            self.read(struct.unpack(self.order + ("Q" if self.big else "I"), value)[0], count * size)
        return list(struct.unpack(f"{self.order}{count}{code}", blob))


class _Cut(Exception):
    """Something the chain points at lies past the end of the file."""

    def __init__(self, end):
        self.end = end


class _Cut(Exception):
    """Something the chain points at lies past the end of the file."""

    def __init__(self, end):
        self.end = end


@dataclass
class _Pages:
    """What the chain of pages holds: the page count, the first page's description and resolution
    (pixels per unit, x and y; None where not stated)."""

    count: int
    description: str | None = None
    resolution: tuple | None = None


def check_pages(path: Path) -> _Pages:
    """The pages of the TIFF at ``path`` (its chain walked, every page's pixels inside the file), the first
    page's ImageDescription and resolution; a cut or damaged file is refused in one line."""
    with open(path, "rb") as fh:
        chain = _Chain(fh, path)
        found = _Pages(0)
        try:
            for at, tags in chain.pages():
                if found.count == 0:
                    _first_page(chain, tags, found)
                offsets = chain.values(tags.get(STRIP_OFFSETS) or tags.get(TILE_OFFSETS) or (0, 0, b""))
                counts = chain.values(tags.get(STRIP_COUNTS) or tags.get(TILE_COUNTS) or (0, 0, b""))
                if len(offsets) != len(counts) or not offsets:
                    raise VolumeError(f"{path}: page {found.count} gives {len(offsets)} strip or tile offsets and "
                                      f"{len(counts)} byte counts; the file is damaged")
                end = max(o + c for o, c in zip(offsets, counts))
                if end > chain.size:
                    raise _Cut(end)
                found.count += 1
        except _Cut as cut:
            raise VolumeError(f"{path}: page {found.count} reaches past the end of the file (to byte {cut.end} of "
                              f"{chain.size}); the file is truncated: copy or write it again") from None
        except struct.error:
            raise VolumeError(f"{path}: page {found.count}'s header is damaged; the file is corrupt") from None
    return found


def _first_page(chain: _Chain, tags: dict, found: _Pages) -> None:
    if DESCRIPTION in tags:
        found.description = chain.read_field(tags[DESCRIPTION]).split(b"\0")[0].decode("latin-1")
    ratios = []
    for tag in (X_RESOLUTION, Y_RESOLUTION):
        pair = chain.values(tags[tag]) if tag in tags and tags[tag][0] == 5 and tags[tag][1] == 1 else []
        ratios.append(pair[0] / pair[1] if len(pair) == 2 and pair[0] > 0 and pair[1] > 0 else None)
    if ratios[0] is not None:
        found.resolution = (ratios[0], ratios[1] or ratios[0])


def stack_files(path: Path) -> list[Path]:
    """The slice files that ``path`` names: itself, the TIFFs in a folder, or a glob's matches."""
    import glob

    text = str(path)
    if is_pattern(text):
        files = [Path(p) for p in glob.glob(text)]
    elif path.is_dir():
        files = [p for p in path.iterdir() if p.suffix.lower() in (".tif", ".tiff")]
    else:
        files = [path]
    if not files:
        raise VolumeError(f"{path}: no TIFF files found (nor DICOM files, which are found by content)")
    return [check_input_path(f, "TIFF file") for f in sorted(files, key=natural_key)]


# --- the layout a description states ---------------------------------------------------------------

@dataclass
class Layout:
    """How a file's pages make a volume: ``pages[t, c, z]`` the page of each plane; ``channels`` 0 for a
    plain stack (no channel axis); names, spacing (x, y, z) and interval (seconds) where stated."""

    pages: np.ndarray
    channels: int = 0
    names: tuple = ()
    spacing: tuple | None = None
    interval: float | None = None

    @property
    def axes(self) -> Axes:
        return Axes(self.channels, self.names, self.pages.shape[0], self.interval)


def plain(count: int) -> Layout:
    """A stack of ``count`` z slices, one time point, no channel axis."""
    return Layout(np.arange(count).reshape(1, 1, count))


def layout(found: _Pages, path: Path) -> Layout:
    """The layout the first page's description states (a plain stack where it says nothing), checked
    against the pages found."""
    text = found.description
    if text and text.startswith("ImageJ="):
        return _imagej(text, found, path)
    if text and "<OME" in text[:4096]:
        return _ome(text, found, path)
    return plain(found.count)


def _count(fields: dict, key: str, path, what: str, default=None):
    if key not in fields:
        return default
    text = fields[key].strip()
    if not re.fullmatch(r"\d{1,9}", text) or not 1 <= int(text) <= MAX_COUNT:
        raise VolumeError(f"{path}: its {what} has {key}={show(fields[key])}; it must be a count from 1 to "
                          f"{MAX_COUNT}: fix the description")
    return int(text)


def _promised(path, kind: str, found: int, promised: int) -> VolumeError:
    contiguous = " (ImageJ writes a stack over 4 GiB as one page with the others' pixels after it, which is " \
        "not read: save it as a folder of slices)" if found == 1 and kind == "ImageJ" else ""
    return VolumeError(f"{path}: holds {found} pages, its {kind} description promises {promised}{contiguous}; the "
                       f"file is truncated or its description is wrong")


def _imagej(text: str, found: _Pages, path: Path) -> Layout:
    fields = dict(line.partition("=")[::2] for line in text.splitlines())
    what = "ImageJ description"
    images = _count(fields, "images", path, what)
    c, t = _count(fields, "channels", path, what, 1), _count(fields, "frames", path, what, 1)
    z = _count(fields, "slices", path, what)
    if z is None:
        z = (images if images is not None else found.count) // (c * t) or 1
    if images is None:
        images = c * z * t
    if c * z * t != images:
        raise VolumeError(f"{path}: its ImageJ description has images={images} but channels={c} x slices={z} x "
                          f"frames={t} = {c * z * t}; fix the description")
    if images != found.count:
        raise _promised(path, "ImageJ", found.count, images)
    pages = np.arange(images).reshape(t, z, c).transpose(0, 2, 1)  # channels fastest, then slices, then frames
    spacing = None
    unit = fields.get("unit", "").strip().lower()
    if unit and unit not in ("pixel", "pixels") and found.resolution is not None:
        spacing = (1 / found.resolution[0], 1 / found.resolution[1], _number(fields.get("spacing"), 1.0))
    interval = seconds(fields.get("finterval"), fields.get("tunit", "s")) if t > 1 else None
    return Layout(pages, c if "channels" in fields else 0, (), _finite(spacing), interval)


def _number(text, default: float) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        return default
    return value if math.isfinite(value) and value > 0 else default


def _finite(spacing):
    return spacing if spacing is not None and all(math.isfinite(v) and v > 0 for v in spacing) else None


def _ome(text: str, found: _Pages, path: Path) -> Layout:
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise VolumeError(f"{path}: its OME-XML description is not valid XML ({exc}); fix it") from None
    if any(_tag(e) == "UUID" for e in root.iter()):
        return plain(found.count)  # a multi-file OME-TIFF: its pages lie in several files, read as slices
    pixels = [e for e in root.iter() if _tag(e) == "Pixels"]
    if len(pixels) != 1:
        raise VolumeError(f"{path}: its OME-XML describes {len(pixels)} images; a volume is one: save one "
                          f"image (series) per file")
    px = pixels[0]
    sizes = {k: _count(px.attrib, f"Size{k}", path, "OME-XML", 1) for k in "ZCT"}
    channels = [c for c in px if _tag(c) == "Channel"]
    samples = [int(c.get("SamplesPerPixel", "1")) if re.fullmatch(r"\d{1,2}", c.get("SamplesPerPixel", "1").strip())
               else 1 for c in channels]
    if channels and max(samples) > 1 and sum(samples) == sizes["C"]:  # RGB: SizeC counts samples, a page holds 3
        sizes["C"] = len(channels)
    if sizes["Z"] * sizes["C"] * sizes["T"] > found.count:
        raise _promised(path, "OME-XML", found.count, sizes["Z"] * sizes["C"] * sizes["T"])
    order = px.get("DimensionOrder", "XYZCT")
    if sorted(order) != sorted("XYZCT") or not order.startswith("XY"):
        raise VolumeError(f"{path}: its OME-XML DimensionOrder={show(order)} is not XY followed by Z, C and T in "
                          f"some order; fix it")
    pages = _ome_pages(px, order[2:], sizes, found.count, path)
    names = [c.get("Name", "") for c in channels]
    return Layout(pages, sizes["C"], tuple(channel_names(names, sizes["C"])), _ome_spacing(px),
                  seconds(px.get("TimeIncrement"), px.get("TimeIncrementUnit", "s")) if sizes["T"] > 1 else None)


def _tag(element) -> str:
    return element.tag.rpartition("}")[2]


def _ome_pages(px, order: str, sizes: dict, count: int, path: Path) -> np.ndarray:
    """``pages[t, c, z]``: the planes in ``order`` (fastest first) from page 0, or as the TiffData map them."""
    total = sizes["Z"] * sizes["C"] * sizes["T"]
    strides, step = {}, 1
    for axis in order:
        strides[axis], step = step, step * sizes[axis]
    planes = np.full(total, -1, dtype=np.int64)
    mappings = [e for e in px if _tag(e) == "TiffData"]
    if not mappings:
        if total != count:
            raise _promised(path, "OME-XML", count, total)
        planes[:] = np.arange(total)
    for m in mappings:
        first = sum(_attr(m, f"First{a}", 0, sizes[a] - 1, path) * strides[a] for a in "ZCT")
        ifd = _attr(m, "IFD", 0, count - 1, path)
        n = _attr(m, "PlaneCount", 1, total, path) if "PlaneCount" in m.attrib or len(mappings) > 1 \
            else min(total - first, count - ifd)
        if first + n > total or ifd + n > count:
            raise VolumeError(f"{path}: an OME-XML TiffData maps {n} planes from IFD {ifd}, past the {count} pages "
                              f"or {total} planes; fix the description")
        planes[first:first + n] = np.arange(ifd, ifd + n)
    if (planes < 0).any():
        raise VolumeError(f"{path}: its OME-XML TiffData map {int((planes >= 0).sum())} of its {total} planes to "
                          f"pages; fix the description")
    index = np.arange(total)
    t, c, z = (index // strides[a] % sizes[a] for a in "TCZ")
    pages = np.empty((sizes["T"], sizes["C"], sizes["Z"]), dtype=np.int64)
    pages[t, c, z] = planes
    return pages


def _attr(element, key: str, low: int, high: int, path) -> int:
    text = element.get(key, str(low))
    if not re.fullmatch(r"\d{1,9}", text.strip()) or not low <= int(text) <= high:
        raise VolumeError(f"{path}: an OME-XML TiffData has {key}={show(text)}; it must be an integer from {low} to "
                          f"{high}: fix the description")
    return int(text)


def _ome_spacing(px):
    """PhysicalSizeX/Y/Z (Y defaults to X, Z to 1): as stated where their units agree, else in micrometres."""
    if "PhysicalSizeX" not in px.attrib:
        return None
    keys = ("PhysicalSizeX", "PhysicalSizeY", "PhysicalSizeZ")
    values = [_number(px.get(keys[0]), 1.0), _number(px.get(keys[1], px.get(keys[0])), 1.0),
              _number(px.get(keys[2]), 1.0)]
    units = [px.get(k + "Unit", "µm") for k in keys]
    if len(set(units)) > 1 and all(u in MICROMETRES for u in units):
        values = [v * MICROMETRES[u] for v, u in zip(values, units)]
    return _finite(tuple(values))


# --- reading -------------------------------------------------------------------------------------------

def tiff_axes(path: Path) -> Axes:
    """A file's channels and time steps as its description states them (a folder or glob of slices: none)."""
    files = stack_files(Path(path))
    if len(files) != 1:
        return Axes()
    return layout(check_pages(files[0]), files[0]).axes


def read_tiff_stack(path: Path, channel: int | None = None, time: int | None = None, color: bool = False):
    """The stack, or the chosen step (and channel) of a hyperstack; ``color``: pages of 3 or 4 samples, the
    data ``[z, y, x, 3|4]``."""
    path = Path(path)
    files = stack_files(path)
    if len(files) == 1:
        return _read_file(files[0], channel, time, bool(color))
    slices: list[np.ndarray] = []
    budget = [0]
    pick_channel(channel, Axes(), str(path))
    pick_step(time, Axes(), str(path))
    with progress.task("reading TIFF slices", len(files), "file") as step:
        for number, f in enumerate(files, 1):
            found = check_pages(f)
            pages = layout(found, f)
            if pages.pages.shape[:2] != (1, 1):
                raise VolumeError(f"{f}: a hyperstack of {pages.pages.shape[1]} channels and {pages.pages.shape[0]} "
                                  f"time points in a folder or glob of slices; read the file alone")
            slices.extend(_read_pages(f, list(pages.pages.ravel()), budget, bool(color)))
            step(number)
    return RawArray(_stack(slices, path))


def _read_file(path: Path, channel, time, color: bool):
    """One file: a plain stack, or the chosen step (and channel) of a hyperstack."""
    pages = layout(check_pages(path), path)
    axes = pages.axes
    chosen, step = pick_channel(channel, axes, str(path)), pick_step(time, axes, str(path))
    wanted = range(pages.pages.shape[1]) if chosen is None else [chosen]
    if color and len(wanted) > 1:
        raise VolumeError(f"{path}: volume.role = rgb: the hyperstack has {len(wanted)} channels; a colour volume is "
                          f"one: choose it (volume.channel)")
    budget = [0]
    volumes = [_stack(_read_pages(path, list(pages.pages[step, c]), budget, color), path) for c in wanted]
    arrays = [RawArray(v, pages.spacing) for v in volumes]
    if chosen is not None or pages.channels == 0 or color:
        return arrays[0]
    return RawChannels(arrays, channel_names(pages.names, len(arrays)))


def _stack(slices: list[np.ndarray], path: Path) -> np.ndarray:
    shapes = {s.shape for s in slices}
    if len(shapes) != 1:
        raise VolumeError(f"{path}: slices differ in size {sorted(shapes)}; all slices must match")
    types = {s.dtype for s in slices}
    if len(types) != 1:
        raise VolumeError(f"{path}: slices differ in pixel type {sorted(map(str, types))}")
    return np.stack(slices, axis=0)


def _read_pages(path: Path, wanted: list[int], budget: list[int], color: bool = False) -> list[np.ndarray]:
    """The pages ``wanted`` of one file, in that order; ``budget[0]`` counts the bytes of all pages read so far;
    ``color``: pages of 3 or 4 samples, each ``[y, x, 3|4]``."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise VolumeError(f"{path}: cannot open as TIFF ({oiio.geterror().strip()})")
    pages = []
    try:
        for sub in wanted:
            sub = int(sub)
            if not inp.seek_subimage(sub, 0):
                raise VolumeError(f"{path}: OpenImageIO cannot reach page {sub}, which the file's chain of pages "
                                  f"holds; the file is damaged")
            spec = inp.spec()
            if color and spec.nchannels not in (3, 4):
                raise VolumeError(f"{path}: volume.role = rgb: page {sub} has {spec.nchannels} samples per pixel; a "
                                  f"colour volume's pages have 3 (r, g, b) or 4 (and alpha): give it the role scalar")
            if not color and spec.nchannels != 1:
                colour = " (set volume.role = rgb to read colour pages as a colour volume)" \
                    if spec.nchannels in (3, 4) else ""
                raise VolumeError(f"{path}: page {sub} has {spec.nchannels} samples per pixel; a volume slice needs "
                                  f"1 (grey){colour}")
            budget[0] += spec.image_bytes()
            check_bytes(budget[0], f"{path}: the TIFF pages up to page {sub}",
                        "read fewer slices, or raise the memory budget")
            pixels = inp.read_image(sub, 0, 0, spec.nchannels if color else 1, oiio.UNKNOWN)
            if pixels is None:
                raise VolumeError(f"{path}: page {sub} is truncated or corrupt ({inp.geterror().strip()})")
            shape = (spec.height, spec.width) + ((spec.nchannels,) if color else ())
            pages.append(np.asarray(pixels).reshape(shape))
    finally:
        inp.close()
    return pages

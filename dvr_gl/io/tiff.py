"""TIFF stacks through OpenImageIO: a multi-page TIFF, a folder of slices, or a glob.

Each page (or file, in natural sort order) is one z slice; all must have the
same size and one channel.

A file is checked against what it says of itself before its pages are trusted, since OpenImageIO stops
at the first page it cannot reach without a word (a 30-page stack cut at 30 % read as 9 slices):

* its chain of pages (IFDs) is walked here: every page and every strip or tile of its pixels must lie
  inside the file (a cut file is refused, naming the first page past its end), and OpenImageIO must
  find as many pages as the chain holds;
* an ImageJ description's ``images=`` (else ``slices=``), or an OME-XML description's
  ``SizeZ x SizeC x SizeT``, must equal the pages found; an ImageJ hyperstack of several channels or
  time points (``channels=``, ``frames=``), or OME ``SizeC``/``SizeT`` above 1, is refused, as its
  pages are not one z stack.  Every file is checked (a FIFO named ``x.tif`` is refused)
and each page's size counts against the memory budget before it is read.  TIFF resolution tags rarely hold the voxel
spacing, so spacing defaults to 1 and is set in the scene (``volume.spacing``).
"""

from __future__ import annotations

import glob
import os
import re
import struct
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .. import progress
from ..errors import VolumeError
from ..sandbox import check_bytes, check_input_path
from .common import RawArray, show

# tag -> what it holds: the pixels' offsets and byte counts, in strips or tiles
STRIP_OFFSETS, STRIP_COUNTS, TILE_OFFSETS, TILE_COUNTS, DESCRIPTION = 273, 279, 324, 325, 270
# TIFF field type -> (struct code, bytes): BYTE, ASCII, SHORT, LONG, LONG8 (the ones these tags use)
FIELD_TYPES = {1: ("B", 1), 2: ("B", 1), 3: ("H", 2), 4: ("I", 4), 16: ("Q", 8)}
MAX_DESCRIPTION = 16 << 20  # bytes of ImageDescription read: a longer one is not checked


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
        """A field's numbers (inline, or where its offset points)."""
        kind, count, value = field
        if kind not in FIELD_TYPES:
            return []
        code, size = FIELD_TYPES[kind]
        inline = len(value)
        blob = value[:count * size] if count * size <= inline else \
            self.read(struct.unpack(self.order + ("Q" if self.big else "I"), value)[0], count * size)
        return list(struct.unpack(f"{self.order}{count}{code}", blob))


class _Cut(Exception):
    """Something the chain points at lies past the end of the file."""

    def __init__(self, end):
        self.end = end


def check_pages(path: Path) -> tuple[int, str | None]:
    """The pages of the TIFF at ``path`` (its chain walked, every page's pixels inside the file) and the
    first page's ImageDescription; a cut or damaged file is refused in one line."""
    with open(path, "rb") as fh:
        chain = _Chain(fh, path)
        pages, description = 0, None
        try:
            for at, tags in chain.pages():
                if pages == 0 and DESCRIPTION in tags:
                    description = chain.read_field(tags[DESCRIPTION]).split(b"\0")[0].decode("latin-1")
                offsets = chain.values(tags.get(STRIP_OFFSETS) or tags.get(TILE_OFFSETS) or (0, 0, b""))
                counts = chain.values(tags.get(STRIP_COUNTS) or tags.get(TILE_COUNTS) or (0, 0, b""))
                if len(offsets) != len(counts) or not offsets:
                    raise VolumeError(f"{path}: page {pages} gives {len(offsets)} strip or tile offsets and "
                                      f"{len(counts)} byte counts; the file is damaged")
                end = max(o + c for o, c in zip(offsets, counts))
                if end > chain.size:
                    raise _Cut(end)
                pages += 1
        except _Cut as cut:
            raise VolumeError(f"{path}: page {pages} reaches past the end of the file (to byte {cut.end} of "
                              f"{chain.size}); the file is truncated: copy or write it again") from None
        except struct.error:
            raise VolumeError(f"{path}: page {pages}'s header is damaged; the file is corrupt") from None
    return pages, description


def _natural_key(p: Path):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]


def stack_files(path: Path) -> list[Path]:
    """The slice files that ``path`` names: itself, the TIFFs in a folder, or a glob's matches."""
    text = str(path)
    if any(c in text for c in "*?["):
        files = [Path(p) for p in glob.glob(text)]
    elif path.is_dir():
        files = [p for p in path.iterdir() if p.suffix.lower() in (".tif", ".tiff")]
    else:
        files = [path]
    if not files:
        raise VolumeError(f"{path}: no TIFF files found (nor DICOM files, which are found by content)")
    return [check_input_path(f, "TIFF file") for f in sorted(files, key=_natural_key)]


def promised_pages(description: str | None, path: Path) -> int | None:
    """The pages an ImageJ or OME-XML ImageDescription promises (None: it says nothing), refusing the
    stacks whose pages are not one z stack (several channels, time points or images)."""
    if not description:
        return None
    if description.startswith("ImageJ="):
        fields = dict(line.partition("=")[::2] for line in description.splitlines())
        numbers = {}
        for key in ("images", "slices", "channels", "frames"):
            if key in fields:
                if not re.fullmatch(r"\d{1,9}", fields[key].strip()) or int(fields[key]) < 1:
                    raise VolumeError(f"{path}: its ImageJ description has {key}={show(fields[key])}; "
                                      f"it must be a count >= 1: fix the description")
                numbers[key] = int(fields[key])
        _one_stack(path, "ImageJ hyperstack", numbers.get("channels", 1), numbers.get("frames", 1))
        return numbers.get("images", numbers.get("slices"))
    if "<OME" not in description[:4096]:
        return None
    try:
        root = ET.fromstring(description)
    except ET.ParseError as exc:
        raise VolumeError(f"{path}: its OME-XML description is not valid XML ({exc}); fix it") from None
    if any(e.tag.endswith("}UUID") or e.tag == "UUID" for e in root.iter()):
        return None  # a multi-file OME-TIFF: its pages lie in several files
    pixels = [e for e in root.iter() if e.tag.rpartition("}")[2] == "Pixels"]
    if len(pixels) != 1:
        raise VolumeError(f"{path}: its OME-XML describes {len(pixels)} images; a volume is one: save one "
                          f"image (series) per file")
    sizes = {}
    for key in ("SizeZ", "SizeC", "SizeT"):
        text = pixels[0].get(key, "1")
        if not re.fullmatch(r"\d{1,9}", text.strip()) or int(text) < 1:
            raise VolumeError(f"{path}: its OME-XML {key}={show(text)} must be a count >= 1; fix it")
        sizes[key] = int(text)
    _one_stack(path, "OME-TIFF", sizes["SizeC"], sizes["SizeT"])
    return sizes["SizeZ"]


def _one_stack(path, what, channels, frames) -> None:
    if channels > 1 or frames > 1:
        raise VolumeError(f"{path}: an {what} of {channels} channel{'s' * (channels != 1)} and {frames} time "
                          f"point{'s' * (frames != 1)}; a volume is one "
                          f"channel at one time: save that z stack alone (e.g. ImageJ's Image > Hyperstacks > "
                          f"Reduce Dimensionality)")


def _read_pages(path: Path, budget: list[int]) -> list[np.ndarray]:
    """The pages of one file; ``budget[0]`` counts the bytes of all pages read so far."""
    import OpenImageIO as oiio

    found, description = check_pages(path)
    promised = promised_pages(description, path)
    if promised is not None and promised != found:
        kind = "ImageJ" if description.startswith("ImageJ") else "OME-XML"
        contiguous = " (ImageJ writes a stack over 4 GiB as one page with the others' pixels after it, which is " \
            "not read: save it as a folder of slices)" if found == 1 and kind == "ImageJ" else ""
        raise VolumeError(f"{path}: holds {found} pages, its {kind} description promises {promised}{contiguous}; the "
                          f"file is truncated or its description is wrong")
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise VolumeError(f"{path}: cannot open as TIFF ({oiio.geterror().strip()})")
    pages = []
    try:
        sub = 0
        while inp.seek_subimage(sub, 0):
            spec = inp.spec()
            if spec.nchannels != 1:
                raise VolumeError(f"{path}: page {sub} has {spec.nchannels} channels; "
                                  f"a volume slice needs 1 (grey)")
            budget[0] += spec.image_bytes()
            check_bytes(budget[0], f"{path}: the TIFF pages up to page {sub}",
                        "read fewer slices, or raise the memory budget")
            pixels = inp.read_image(sub, 0, 0, 1, oiio.UNKNOWN)
            if pixels is None:
                raise VolumeError(f"{path}: page {sub} is truncated or corrupt ({inp.geterror().strip()})")
            pages.append(np.asarray(pixels).reshape(spec.height, spec.width))
            sub += 1
    finally:
        inp.close()
    if len(pages) != found:
        raise VolumeError(f"{path}: OpenImageIO reads {len(pages)} pages, the file's chain of pages holds {found}; "
                          f"the file is damaged")
    return pages


def read_tiff_stack(path: Path) -> RawArray:
    path = Path(path)
    slices: list[np.ndarray] = []
    budget = [0]
    files = stack_files(path)
    with progress.task("reading TIFF slices", len(files), "file") as step:
        for number, f in enumerate(files, 1):
            slices.extend(_read_pages(f, budget))
            step(number)
    shapes = {s.shape for s in slices}
    if len(shapes) != 1:
        raise VolumeError(f"{path}: slices differ in size {sorted(shapes)}; all slices must match")
    types = {s.dtype for s in slices}
    if len(types) != 1:
        raise VolumeError(f"{path}: slices differ in pixel type {sorted(map(str, types))}")
    return RawArray(np.stack(slices, axis=0))

"""Reading bytes: gzip/bzip2 by file suffix, and files split into numbered parts.

A data file too large for its host is sometimes split into ``name.part1``,
``name.part2``, ... which together form the original byte stream (the CT
bunny in ``shared/data/large`` is one bzip2 stream split in two).  When
``name`` does not exist but ``name.part1`` does, the parts are joined.
"""

from __future__ import annotations

import bz2
import gzip
import os
import re
import zlib
from pathlib import Path

from ..errors import VolumeError


def split_parts(path: Path) -> list[Path]:
    """The parts ``path.part1, path.part2, ...`` in order, or [] when there are none."""
    parts = []
    pattern = re.compile(re.escape(path.name) + r"\.part(\d+)$")
    if not path.parent.is_dir():
        return parts
    for entry in path.parent.iterdir():
        m = pattern.match(entry.name)
        if m:
            parts.append((int(m.group(1)), entry))
    parts.sort()
    numbers = [n for n, _ in parts]
    if parts and numbers != list(range(1, len(parts) + 1)):
        raise VolumeError(f"{path}: split parts are not numbered 1..{len(parts)} (found {numbers}); "
                          f"a part is missing")
    return [p for _, p in parts]


def exists_or_split(path: Path) -> bool:
    return path.is_file() or bool(split_parts(path))


def read_stored_bytes(path: Path) -> bytes:
    """The bytes of ``path`` as stored (joined from its parts if it is split)."""
    path = Path(path)
    if path.is_file():
        return path.read_bytes()
    parts = split_parts(path)
    if not parts:
        raise VolumeError(f"{path}: file not found")
    return b"".join(p.read_bytes() for p in parts)


def decompress(blob: bytes, encoding: str, name: str) -> bytes:
    """Decompress ``blob`` (encoding ``raw``, ``gzip``, ``bzip2`` or ``zlib``), or explain why not."""
    try:
        if encoding == "raw":
            return blob
        if encoding == "gzip":
            return gzip.decompress(blob)
        if encoding == "bzip2":
            return bz2.decompress(blob)
        if encoding == "zlib":
            d = zlib.decompressobj()
            out = d.decompress(blob)
            if not d.eof:
                raise EOFError("zlib stream ended early")
            return out
    except (EOFError, OSError, zlib.error, ValueError) as exc:
        raise VolumeError(f"{name}: {encoding} data is truncated or corrupt ({exc}); "
                          f"download or copy the file again") from exc
    raise VolumeError(f"{name}: unknown encoding {encoding!r}; use raw, gzip, bzip2 or zlib")


def encoding_from_suffix(path: Path) -> str:
    name = path.name.lower()
    if name.endswith((".gz", ".gzip")):
        return "gzip"
    if name.endswith((".bz2", ".bzip2")):
        return "bzip2"
    if name.endswith((".zraw", ".zlib")):
        return "zlib"
    return "raw"


def read_bytes(path: Path, encoding: str | None = None) -> bytes:
    """The decoded bytes of ``path``; the encoding defaults to the one the suffix names."""
    path = Path(path)
    return decompress(read_stored_bytes(path), encoding or encoding_from_suffix(path), os.fspath(path))

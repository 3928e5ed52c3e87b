"""Reading a header's data bytes, bounded by what the header promises.

Every reader gets its voxel bytes from :func:`read_data`: it checks each file with
:func:`dvr_gl.sandbox.check_input_path` (a FIFO or device would block), checks the
promised byte count against the memory budget before anything is allocated, and
for raw data against the file's size before anything is read.  Compressed data
(gzip, bzip2, zlib) is decoded piece by piece and stops one byte past the promised
size, so a small header over a huge stream (a "zip bomb") fails at once.

A data file too large for its host is sometimes split into ``name.part1``,
``name.part2``, ... which together form the original byte stream (the CT bunny
in ``shared/data/large`` is one bzip2 stream split in two).  When ``name`` does
not exist but ``name.part1`` does, the parts are joined.
"""

from __future__ import annotations

import bz2
import os
import re
import zlib
from pathlib import Path

from .. import progress
from ..errors import VolumeError
from ..sandbox import check_bytes, check_input_path, current

ENCODINGS = ("raw", "gzip", "bzip2", "zlib")
CHUNK = 1 << 20  # bytes read from a file at a time


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
    return os.path.lexists(path) or bool(split_parts(path))


def stored_files(path: Path, what: str, name: str) -> list[Path]:
    """The files holding ``path``'s bytes (itself, or its parts), each one allowed to be read."""
    path = Path(path)
    if not current().allows(path):  # before its folder is listed for parts: refused whether or not it exists
        check_input_path(path, what)
    files = [path] if os.path.lexists(path) else split_parts(path)
    if not files:
        raise VolumeError(f"{name}: its {what} {path} was not found; put it next to the header or fix its name")
    return [check_input_path(f, what) for f in files]


def encoding_from_suffix(path: Path) -> str:
    name = path.name.lower()
    if name.endswith((".gz", ".gzip")):
        return "gzip"
    if name.endswith((".bz2", ".bzip2")):
        return "bzip2"
    if name.endswith((".zraw", ".zlib")):
        return "zlib"
    return "raw"


def _pieces(files: list[Path], start: int, line_skip: int, name: str):
    """The stored bytes from ``start`` (bytes into the joined files) after ``line_skip`` lines."""
    lines_left = line_skip
    for f in files:
        with open(f, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if start >= size:
                start -= size
                continue
            fh.seek(start)
            start = 0
            while piece := fh.read(CHUNK):
                at = 0  # an offset, not slices: a chunk of short lines is not copied once a line
                while lines_left and at < len(piece):
                    newline = piece.find(b"\n", at)
                    at = newline + 1 if newline >= 0 else len(piece)
                    lines_left -= newline >= 0
                if at < len(piece):
                    yield piece[at:] if at else piece
    if lines_left:
        raise VolumeError(f"{name}: line skip {line_skip} goes past the end of the data file "
                          f"({line_skip - lines_left} lines); fix the line skip")


def after_lines(path: Path, start: int, lines: int, name: str) -> int:
    """The offset in ``path`` just after ``lines`` lines from byte ``start``: the file is read in chunks and
    its newlines counted, so the work is bounded by the file's size, whatever the count (``line skip:
    100000000`` on a 32 KB file once read a line at a time, for minutes); a count past the end is refused."""
    left, at = lines, start
    with open(path, "rb") as fh:
        fh.seek(start)
        while left and (piece := fh.read(CHUNK)):
            found = piece.count(b"\n")
            if found < left:
                left, at = left - found, at + len(piece)
                continue
            end = -1
            for _ in range(left):
                end = piece.find(b"\n", end + 1)
            return at + end + 1
    if left:
        raise VolumeError(f"{name}: line skip {lines} goes past the end of the data file "
                          f"({lines - left} lines); fix the line skip")
    return at


def _decoder(encoding: str):
    if encoding == "bzip2":
        return bz2.BZ2Decompressor()
    return zlib.decompressobj(zlib.MAX_WBITS | (16 if encoding == "gzip" else 0))


def _decode(pieces, encoding: str, limit: int, step=lambda done: None) -> bytearray:
    """At most ``limit + 1`` decoded bytes: one more than ``limit`` says the stream holds more;
    ``step(done)`` is told the bytes decoded so far (a progress bar: the CT bunny takes 20 s).

    gzip members and bzip2 streams may follow each other (as ``gzip -c a b`` writes); bytes
    after a zlib stream are ignored, as MetaImage writers sometimes pad the file."""
    out = bytearray()
    decoder = _decoder(encoding)
    for data in pieces:
        while True:
            if decoder.eof:
                data = decoder.unused_data + data
                if encoding == "zlib" or not data:
                    break
                decoder = _decoder(encoding)
            if not data:
                break
            out += decoder.decompress(data, limit + 1 - len(out))
            step(min(len(out), limit))
            if len(out) > limit:
                return out
            data = getattr(decoder, "unconsumed_tail", b"")
        if decoder.eof and encoding == "zlib":
            break
    if not decoder.eof:
        raise EOFError("the compressed stream ends early")
    return out


def read_data(path: Path, nbytes: int, *, name: str, encoding: str = "raw", start: int = 0,
              line_skip: int = 0, skip: int = 0, what: str = "data file", promise: str = "the header",
              exact: bool = True) -> bytes:
    """Exactly the ``nbytes`` bytes the header promises, or a :class:`VolumeError`.

    Args:
        path: the data file (or the header itself for attached data); may be split into parts.
        nbytes: the bytes the header promises (dims x sample size).
        name: the header, to name in messages.
        encoding: ``raw``, ``gzip``, ``bzip2`` or ``zlib``.
        start: bytes of the stored file before the data (an attached header's length).
        line_skip: lines of the stored file to skip after ``start``.
        skip: bytes to skip in the decoded data; -1 (raw only): the data is the file's last bytes.
        what, promise: how messages name the data file and what promised its size.
        exact: raw data must end where the promised bytes end (False: later bytes are ignored).
    Decoded (compressed) data must hold exactly ``skip + nbytes`` bytes, whatever ``exact`` says:
    more is how a decompression bomb shows itself.
    """
    if encoding not in ENCODINGS:
        raise VolumeError(f"{name}: unknown encoding {encoding!r}; use raw, gzip, bzip2 or zlib")
    files = stored_files(path, what, name)
    # decoded skipped bytes are held too (a raw skip is seeked over unless lines are skipped first)
    held = nbytes + (max(skip, 0) if encoding != "raw" or line_skip else 0)
    check_bytes(held, f"{name}: the {nbytes}-byte volume {promise} promises"
                + (f" (and {skip} bytes to skip)" if held > nbytes else ""),
                "check the sizes and skips in the header, or raise the memory budget")
    stored = sum(f.stat().st_size for f in files) - start
    if encoding == "raw":
        return _read_raw(files, nbytes, name, start, line_skip, skip, stored, promise, exact, what)
    if skip < 0:
        raise VolumeError(f"{name}: a skip of -1 (data at the end of the file) is valid only for raw "
                          f"data, not {encoding}; give the byte count to skip")
    try:
        with progress.task(f"decompressing {Path(name).name}", skip + nbytes, "B") as step:
            out = _decode(_pieces(files, start, line_skip, name), encoding, skip + nbytes, step)
    except (EOFError, OSError, zlib.error, ValueError) as exc:
        raise VolumeError(f"{name}: {encoding} data is truncated or corrupt ({exc}); "
                          f"download or copy the file again") from None
    if len(out) != skip + nbytes:
        size = f"more than {skip + nbytes}" if len(out) > skip + nbytes else len(out)
        raise VolumeError(f"{name}: the {encoding} data decodes to {size} bytes, but {promise} "
                          f"needs {_bytes(skip, nbytes)}; the header or the data file is wrong")
    return bytes(memoryview(out)[skip:])


def _bytes(skip: int, nbytes: int) -> str:
    return f"{nbytes} bytes" if skip == 0 else f"{skip} bytes to skip and {nbytes} of data"


def _read_raw(files, nbytes, name, start, line_skip, skip, stored, promise, exact, what) -> bytes:
    if skip < 0:  # the data is the last nbytes of the file, wherever the lines end
        skip, line_skip = stored - nbytes, 0
        if skip < 0:
            raise VolumeError(f"{name}: the {what} holds {stored} bytes, but {promise} needs {nbytes}; "
                              f"the data file is truncated or the header is wrong")
    elif line_skip == 0 and (stored < skip + nbytes or exact and stored != skip + nbytes):
        raise VolumeError(f"{name}: the {what} holds {stored} bytes{' after the header' if start else ''}, "
                          f"but {promise} needs {_bytes(skip, nbytes)}; the data file is truncated or "
                          f"the header is wrong")
    if line_skip == 0:  # seek over the skip instead of reading it
        start, skip = start + skip, 0
    out = bytearray()
    for piece in _pieces(files, start, line_skip, name):
        out += piece
        if len(out) > skip + nbytes:
            break
    if len(out) < skip + nbytes or exact and len(out) != skip + nbytes:
        raise VolumeError(f"{name}: the {what} holds {len(out)} bytes after the line skip, but {promise} "
                          f"needs {_bytes(skip, nbytes)}; fix the skips or the sizes")
    return bytes(memoryview(out)[skip:skip + nbytes])


def read_text(path: Path, name: str, start: int, line_skip: int, count: int, what: str = "data file") -> bytes:
    """The stored bytes of an ASCII data section (after ``start`` bytes and ``line_skip`` lines),
    checked against the memory budget: the text, and ``count`` parsed values."""
    files = stored_files(path, what, name)
    stored = max(sum(f.stat().st_size for f in files) - start, 0)
    # the text, its tokens (about 50 bytes each as Python objects, at most one per 2 bytes)
    # and the values as float64
    need = stored + 50 * min(count, stored // 2 + 1) + 8 * count
    check_bytes(need, f"{name}: the ASCII data ({count} values)", "check the sizes in the header")
    return b"".join(_pieces(files, start, line_skip, name))

"""Blosc-compressed zarr chunks checked before numcodecs decodes them.

numcodecs hands a chunk to c-blosc 1's ``blosc_decompress``, which is given no length for its input: it trusts
the 16-byte header.  A chunk whose header lies (a compressed size over the chunk's length, an uncompressed size
of 2 GB) makes it read past the chunk: a segfault, or heap memory decoded as samples (a wrong image).  So the
header is checked against the chunk and the array's metadata first (:func:`check_frame`); c-blosc checks the
rest within the compressed size it is then given truthfully.

The header (blosc format 1 and 2): version, versionlz, flags, typesize (one byte each), then little-endian
uint32 nbytes (uncompressed), blocksize and cbytes (compressed, header included).
"""

from __future__ import annotations

import json
import math
import os
import struct
from dataclasses import dataclass

import numpy as np

from ..errors import VolumeError
from ..sandbox import check_bytes

HEADER = 16
#: flags bit: the data is stored uncompressed after the header (cbytes is nbytes + 16)
MEMCPYED = 0x2
#: the codec names a zarr v3 array's blosc goes by, and the byte codecs that keep the blosc frame as it is
#: but for a trailing checksum (its length)
V3_NAMES = ("blosc", "numcodecs.blosc")
TRAILERS = {"crc32c": 4}
#: array-to-array codecs that keep the chunk's byte count (so the uncompressed size is known)
SAME_SIZE = ("transpose",)


@dataclass(frozen=True)
class Expect:
    """What a blosc chunk of an array holds: ``nbytes`` uncompressed (None where filters change it), and
    ``trailer`` bytes after the frame (a checksum)."""

    nbytes: int | None
    trailer: int = 0


@dataclass(frozen=True)
class Shard:
    """A zarr v3 shard of blosc chunks: ``count`` inner chunks, each an ``inner`` :class:`Expect`, found by an
    index of ``index`` bytes (an offset and a length, uint64, per chunk, then checksums) at its start or end."""

    count: int
    index: int
    at_start: bool
    inner: Expect


def layout(metadata: dict) -> Expect | Shard | None:
    """The :class:`Expect` of an array's metadata (``.zarray`` or a v3 ``zarr.json``), or None where its
    chunks are not blosc frames (another or no compressor, sharded, a group, metadata zarr would refuse)."""
    if not isinstance(metadata, dict):
        return None
    if metadata.get("zarr_format") == 3 or "node_type" in metadata:
        return _v3(metadata)
    compressor = metadata.get("compressor")
    if not isinstance(compressor, dict) or compressor.get("id") != "blosc":
        return None
    nbytes = _chunk_bytes(metadata.get("chunks"), metadata.get("dtype"))
    return Expect(None if metadata.get("filters") else nbytes)


def _v3(metadata: dict) -> Expect | Shard | None:
    """A zarr v3 array's blosc chunks: blosc the last byte codec (but for a checksum after it), or sharded
    (:func:`_shard`)."""
    if metadata.get("node_type") != "array":
        return None
    grid = metadata.get("chunk_grid")
    shape = grid.get("configuration", {}).get("chunk_shape") if isinstance(grid, dict) else None
    return _codecs(metadata.get("codecs"), shape, metadata.get("data_type"))


def _codecs(codecs, shape, dtype) -> Expect | Shard | None:
    """The :class:`Expect` (or :class:`Shard`) of chunks of ``shape`` encoded by v3 ``codecs``."""
    if not isinstance(codecs, list) or not codecs:
        return None
    names = [c.get("name") if isinstance(c, dict) else c for c in codecs]
    if names[-1] == "sharding_indexed":
        return _shard(codecs[-1], shape, dtype)
    trailer = 0
    while names and names[-1] in TRAILERS:
        trailer += TRAILERS[names.pop()]
    if not names or names[-1] not in V3_NAMES:
        return None
    others = [n for n in names[:-1] if n != "bytes"]
    nbytes = _chunk_bytes(shape, dtype)
    return Expect(nbytes if all(n in SAME_SIZE for n in others) else None, trailer)


def _shard(codec: dict, shape, dtype) -> Shard | None:
    """A sharded array's :class:`Shard`, where its inner chunks are blosc frames (not sharded again) and its
    index is plain (uint64 pairs, then crc32c checksums); None otherwise."""
    config = codec.get("configuration") if isinstance(codec, dict) else None
    if not isinstance(config, dict):
        return None
    inner_shape = config.get("chunk_shape")
    inner = _codecs(config.get("codecs"), inner_shape, dtype)
    index_codecs = [c.get("name") if isinstance(c, dict) else c for c in config.get("index_codecs") or
                    [{"name": "bytes"}, {"name": "crc32c"}]]
    if not isinstance(inner, Expect) or not isinstance(shape, list) or not isinstance(inner_shape, list) or \
            len(shape) != len(inner_shape) or not all(isinstance(n, int) and n > 0 for n in shape + inner_shape) \
            or any(n not in ("bytes", "crc32c") for n in index_codecs):
        return None
    count = math.prod(-(-n // c) for n, c in zip(shape, inner_shape))
    return Shard(count, 16 * count + 4 * index_codecs.count("crc32c"), config.get("index_location") == "start",
                 inner)


def check_read(data, expect: Expect | Shard, part: tuple[str, int], where: str) -> None:
    """Check what the store read of a chunk before it is decoded: ``part`` is ``("whole", 0)`` (the file),
    ``("range", start)`` (a shard's inner chunk read alone, or its index where that starts the shard at 0) or
    ``("other", 0)`` (a shard's index at its end: nothing to check)."""
    kind, start = part
    if isinstance(expect, Expect):
        if kind == "whole":
            check_frame(data, expect, where)
        return
    if kind == "range" and not (expect.at_start and start == 0):
        check_frame(data, expect.inner, f"{where} (a chunk inside the shard, at byte {start})")
    elif kind == "whole":
        _check_shard(memoryview(data).cast("B"), expect, where)


def _check_shard(data, shard: Shard, where: str) -> None:
    """Each inner chunk the shard's index locates, checked (one the index puts past the shard's end is cut
    short there, as zarr cuts it, and so refused); an index that does not fit is zarr's to refuse."""
    if len(data) < shard.index:
        return
    index = data[:shard.index] if shard.at_start else data[len(data) - shard.index:]
    pairs = np.frombuffer(index, "<u8", 2 * shard.count).reshape(-1, 2)
    for k, (offset, length) in enumerate(pairs.tolist()):
        if offset == length == 2 ** 64 - 1:  # an empty chunk: the fill value
            continue
        check_frame(data[offset:offset + length], shard.inner, f"{where} (chunk {k} inside the shard)")


def _chunk_bytes(shape, dtype) -> int | None:
    """A chunk's bytes: its shape's samples times the dtype's size; None where either is not plain."""
    try:
        if not isinstance(shape, list) or not all(isinstance(n, int) and n >= 0 for n in shape):
            return None
        return math.prod(shape) * np.dtype(dtype).itemsize
    except (TypeError, ValueError):
        return None


def check_frame(data, expect: Expect, where: str) -> None:
    """Refuse (one :class:`VolumeError` line naming ``where``) a blosc chunk whose header does not fit it: a
    compressed size other than the chunk's length, an uncompressed size other than the array's chunk, a block
    size of 0 or over the data, a type size of 0, a stored (uncompressed) chunk of the wrong length."""
    data = memoryview(data).cast("B")
    frame = len(data) - expect.trailer
    if frame < HEADER:
        raise _damaged(where, f"{len(data)} bytes, shorter than blosc's {HEADER}-byte header")
    _, _, flags, typesize = data[0], data[1], data[2], data[3]
    nbytes, blocksize, cbytes = struct.unpack_from("<III", data, 4)
    problem = None
    if cbytes != frame:
        problem = f"its header gives {cbytes} compressed bytes, the chunk holds {frame}"
    elif expect.nbytes is not None and nbytes != expect.nbytes:
        problem = f"its header gives {nbytes} bytes uncompressed, the array's chunk holds {expect.nbytes}"
    elif typesize == 0:
        problem = "its header gives a type size of 0"
    elif nbytes and not 0 < blocksize <= nbytes:
        problem = f"its header gives blocks of {blocksize} bytes for {nbytes} bytes"
    elif flags & MEMCPYED and cbytes != nbytes + HEADER:
        problem = f"it is stored uncompressed, {cbytes - HEADER} bytes for {nbytes}"
    if problem:
        raise _damaged(where, problem)
    if expect.nbytes is None:  # filters: the size is unknown, but must fit in memory
        check_bytes(nbytes, f"{where}: a blosc chunk of {nbytes} bytes uncompressed",
                    "the store is damaged or not meant for this: rewrite it, or raise the memory budget")


def _damaged(where: str, problem: str) -> VolumeError:
    return VolumeError(f"{where}: the blosc chunk is damaged ({problem}); rewrite the store")


def read_metadata(path: str) -> dict | None:
    """A metadata file's JSON (its size already checked by the store), None where absent or not JSON."""
    try:
        with open(path, "rb") as f:
            found = json.loads(f.read())
    except (OSError, ValueError, RecursionError):
        return None
    return found if isinstance(found, dict) else None


def find_layout(root: str, key: str, cache: dict, check) -> Expect | Shard | None:
    """The :class:`Expect` of the array a chunk ``key`` of the store at ``root`` belongs to: the nearest folder
    above it with a ``.zarray`` or ``zarr.json`` (a consolidated entry at the root first, as zarr reads that),
    each folder looked up once (``cache``); ``check(key)`` checks a metadata file before it is read."""
    folder = key.rpartition("/")[0]
    while True:
        if folder not in cache:
            cache[folder] = _folder_layout(root, folder, cache, check)
        found = cache[folder]
        if found is not False or not folder:
            return found or None
        folder = folder.rpartition("/")[0]


def _folder_layout(root: str, folder: str, cache: dict, check):
    """The folder's array :class:`Expect` (None: not blosc), or False where the folder holds no metadata."""
    consolidated = _consolidated(root, cache, check)
    if folder in consolidated:
        return layout(consolidated[folder])
    for name in (".zarray", "zarr.json", ".zgroup"):
        key = f"{folder}/{name}" if folder else name
        if os.path.isfile(os.path.join(root, key)):
            check(key)
            return layout(read_metadata(os.path.join(root, key)))
    return False


def _consolidated(root: str, cache: dict, check) -> dict:
    """The root's consolidated metadata, by array path (v2 ``.zmetadata``, v3 ``consolidated_metadata``)."""
    if "\0consolidated" not in cache:
        found = {}
        for key in (".zmetadata", "zarr.json"):
            if os.path.isfile(os.path.join(root, key)):
                check(key)
                found.update(_entries(read_metadata(os.path.join(root, key))))
        cache["\0consolidated"] = found
    return cache["\0consolidated"]


def _entries(metadata: dict | None) -> dict:
    if not metadata:
        return {}
    v2 = metadata.get("metadata") if "zarr_consolidated_format" in metadata else None
    if isinstance(v2, dict):
        return {k[:-len("/.zarray")] if k != ".zarray" else "": v for k, v in v2.items() if k.endswith(".zarray")}
    v3 = metadata.get("consolidated_metadata")
    v3 = v3.get("metadata") if isinstance(v3, dict) else None
    return {k: v for k, v in v3.items()} if isinstance(v3, dict) else {}

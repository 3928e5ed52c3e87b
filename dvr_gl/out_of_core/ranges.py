"""The minimum and maximum of every block of voxels, computed once and kept beside the data.

A renderer asks :meth:`BlockRanges.range_of` whether a brick holds any value its transfer function
makes visible before it reads the brick: an empty brick is never read.

Blocks are ``B^3`` voxels, ``B = 32`` by default: bricks are multiples of it (32 to 256 voxels a side,
so that a brick's range is the union of whole blocks and never wider than its own), and the table
stays small: 2 values per 32 KiB of uint8 voxels, about 1 MB for a 16 GB volume, which pickles to Dask
workers and loads in milliseconds; smaller blocks would skip a little more empty space at 8 times
the table per halving.

The pass streams the source in tiles of at most :data:`SLAB_BYTES` bytes (whole blocks: ``B`` planes,
as many rows and columns as fit), so its memory does not grow with the volume.  It also counts the
non-finite values (NaN, +-Inf) of float data: a volume holding some is refused, as
:class:`~dvr_gl.fields.grid.Volume` refuses it, unless the source replaces them (``nan_value``).

The table is saved to a sidecar file ``<data file>.dvr-ranges.npz`` (for a zarr store
``<store>.dvr-ranges.npz``, or ``<store>.<array path>.dvr-ranges.npz``), keyed by what makes it valid
(the file's size and modification time, dims, type, offset, block size, ``nan_value``), and computed
again when the key differs.  Where the data's folder is not writable the sidecar goes to the user's
cache folder (``$XDG_CACHE_HOME/dvr-gl/ranges``, default ``~/.cache/dvr-gl/ranges``).

A sidecar is never trusted: one that cannot be read or does not agree with itself (cut, garbage, other
members, shapes or types, NaN) is computed again with a one-line warning (logger ``dvr_gl``), and
rewritten.  Inside a sandbox with roots, a sidecar outside them (the cache folder, a link out) is
neither read nor written.
"""

from __future__ import annotations

import json
import logging
import math
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from .. import progress
from ..errors import VolumeError
from ..sandbox import check_bytes, current
from .sources import check_box, fingerprint

BLOCK = 32
SLAB_BYTES = 32 << 20  # bytes of voxels the pass reads at a time (one tile)
VERSION = 1  # of the sidecar's layout: a sidecar of another version is computed again
SUFFIX = ".dvr-ranges.npz"

log = logging.getLogger(__name__)


class BlockRanges:
    """Per-block minima and maxima: ``mins[kz, ky, kx]`` over voxels ``[kz*B, (kz+1)*B)`` etc. (the
    last block along an axis may be shorter), in the volume's scalar type.

    Attributes:
        mins, maxs: ``(nbz, nby, nbx)`` arrays.
        block_size: ``B``, voxels per block side.
        dims: the volume's ``(nx, ny, nz)``.
        non_finite: NaN and +-Inf values counted by the pass (0 unless the source leaves them).
        sidecar: the file the table was read from or written to (None: memory only).
    """

    def __init__(self, mins: np.ndarray, maxs: np.ndarray, block: int, dims, non_finite: int = 0,
                 sidecar: Path | None = None):
        self.mins, self.maxs = mins, maxs
        self.block_size = int(block)
        self.dims = tuple(int(d) for d in dims)
        self.non_finite = int(non_finite)
        self.sidecar = sidecar
        expected = tuple(-(-n // self.block_size) for n in reversed(self.dims))
        if mins.shape != expected or maxs.shape != expected:
            raise VolumeError(f"block ranges of shape {mins.shape} for dims {self.dims} and block {block}; "
                              f"expected {expected}")

    @property
    def shape(self) -> tuple[int, int, int]:
        """Blocks along z, y, x."""
        return self.mins.shape

    @property
    def value_range(self) -> tuple[float, float]:
        """The volume's smallest and largest value."""
        return float(self.mins.min()), float(self.maxs.max())

    def range_of(self, lo, dims) -> tuple[float, float]:
        """The smallest and largest value of voxels ``lo .. lo + dims - 1`` (x, y, z), conservatively:
        over the whole blocks the box overlaps (a box of whole blocks gets its exact range)."""
        lo, dims = check_box(lo, dims, self.dims, "block ranges")
        b = self.block_size
        sel = tuple(slice(lo[a] // b, (lo[a] + dims[a] - 1) // b + 1) for a in (2, 1, 0))
        return float(self.mins[sel].min()), float(self.maxs[sel].max())

    def __getstate__(self):
        state = dict(self.__dict__)
        state["sidecar"] = None if self.sidecar is None else str(self.sidecar)
        return state

    def __repr__(self) -> str:
        lo, hi = self.value_range
        blocks = "x".join(map(str, reversed(self.shape)))
        return f"BlockRanges({self.block_size}^3 blocks, {blocks}, values {lo:g}..{hi:g})"

    # --- computing ---------------------------------------------------------------------------------

    @classmethod
    def compute(cls, source, block: int = BLOCK, slab_bytes: int = SLAB_BYTES) -> "BlockRanges":
        """Stream ``source`` once in tiles of at most ``slab_bytes`` bytes (but at least one block)."""
        block = int(block)
        if block < 1:
            raise VolumeError(f"{source.name}: the block size must be at least 1 voxel, got {block}")
        nx, ny, nz = source.dims
        item = source.dtype.itemsize
        shape = tuple(-(-n // block) for n in (nz, ny, nx))
        check_bytes(2 * math.prod(shape) * item, f"{source.name}: the block ranges ({'x'.join(map(str, shape[::-1]))} "
                    f"blocks of {block}^3)", "use larger blocks, or raise the memory budget")
        mins = np.empty(shape, dtype=source.dtype)
        maxs = np.empty(shape, dtype=source.dtype)
        # a tile: B planes, whole rows where they fit (x first, then y), in whole blocks
        tile_x = min(nx, max(block, slab_bytes // (item * block * block) // block * block))
        tile_y = min(ny, max(block, slab_bytes // (item * block * tile_x) // block * block))
        bad = 0
        with progress.task(f"block ranges of {source.name}", source.nbytes, "B") as step:
            done = 0
            for z0 in range(0, nz, block):
                for y0 in range(0, ny, tile_y):
                    for x0 in range(0, nx, tile_x):
                        n = (min(tile_x, nx - x0), min(tile_y, ny - y0), min(block, nz - z0))
                        tile = source.read((x0, y0, z0), n)
                        lo, hi = _block_extremes(tile, block)
                        at = (z0 // block, slice(y0 // block, y0 // block + lo.shape[1]),
                              slice(x0 // block, x0 // block + lo.shape[2]))
                        mins[at], maxs[at] = lo[0], hi[0]
                        if tile.dtype.kind == "f" and not (np.isfinite(lo).all() and np.isfinite(hi).all()):
                            bad += int(np.count_nonzero(~np.isfinite(tile)))
                        done += tile.nbytes
                        step(done)
                        del tile
        return cls(mins, maxs, block, source.dims, bad)

    @classmethod
    def of(cls, source, block: int = BLOCK, sidecar: bool = True, slab_bytes: int = SLAB_BYTES) -> "BlockRanges":
        """The source's block ranges: from its sidecar when one is valid, else computed (and saved, with
        ``sidecar``); a source holding non-finite values is refused in one line."""
        key = source.validity() if sidecar else None
        if key is not None:
            key = {**key, "block": int(block), "nan_value": source.nan_value, "version": VERSION}
        ranges = _load(source, key) if key is not None else None
        if ranges is None:
            ranges = cls.compute(source, block, slab_bytes)
            if key is not None:
                ranges.sidecar = _save(source, key, ranges)
        if ranges.non_finite and source.nan_value is None:
            raise VolumeError(f"{source.name}: {ranges.non_finite} NaN or Inf values; choose a replacement value "
                              f"(scene key volume.nan_value, or --nan-value)")
        return ranges


def _block_extremes(tile: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-block mins and maxs of a ``[z, y, x]`` tile whose origin is on the block grid."""
    out = []
    for reduce in (np.minimum, np.maximum):
        a = tile
        for axis in (2, 1, 0):  # the fastest axis first: each step shrinks what the next one reads
            a = reduce.reduceat(a, np.arange(0, a.shape[axis], block), axis=axis)
        out.append(a)
    return out[0], out[1]


# --- the sidecar --------------------------------------------------------------------------------------

def cache_folder() -> Path:
    """Where sidecars go when the data's folder is not writable."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "dvr-gl" / "ranges"


def sidecar_paths(source, key: dict) -> list[Path]:
    """Where the source's sidecar may be: beside the data, then in the cache folder (named by the data's
    absolute path, so that two files of one name do not share one)."""
    base = source.sidecar_base()
    beside = base.with_name(base.name + SUFFIX)
    cached = cache_folder() / f"{base.name}.{fingerprint({'path': str(base.resolve())})}{SUFFIX}"
    return [beside, cached]


def _load(source, key: dict) -> BlockRanges | None:
    """The ranges from the first sidecar whose key is ``key``; one that cannot be read or does not agree
    with itself (cut, garbage, other members, shapes or types, NaN) is not used: a one-line warning, and
    the ranges are computed again (and the sidecar rewritten).  Inside a sandbox with roots, a sidecar
    outside them once links are followed (the cache folder, a link) is not read."""
    box = current()
    for path in sidecar_paths(source, key):
        if not path.is_file() or not box.allows(path):  # FIFOs, devices and folders are not files
            continue
        try:
            ranges = _read_sidecar(path, source, key)
        except Exception as exc:  # a damaged file: zipfile, numpy and json raise many kinds  # noqa: BLE001
            text = str(exc).splitlines()[0] if str(exc) else ""
            log.warning("%s: the block-ranges sidecar is damaged (%s); computing the ranges again", path,
                        f"{type(exc).__name__}: {text}" if text else type(exc).__name__)
            continue
        if ranges is not None:
            return ranges
    return None


#: The members of a sidecar, and the most bytes each but the ranges may hold.
MEMBERS = {"mins.npy": None, "maxs.npy": None, "key.npy": 1 << 20, "non_finite.npy": 1 << 10}


def _read_sidecar(path: Path, source, key: dict) -> BlockRanges | None:
    """The ranges a sidecar holds, None where its key is another (stale: the data changed), or an exception
    where it does not agree with itself.  Its members' sizes are checked before any is read, so that a
    forged header cannot make numpy allocate more than the ranges of this volume."""
    block = key["block"]
    shape = tuple(-(-n // block) for n in reversed(source.dims))
    limit = {m: n or math.prod(shape) * source.dtype.itemsize + 1024 for m, n in MEMBERS.items()}
    with zipfile.ZipFile(path) as archive:
        sizes = {info.filename: info.file_size for info in archive.infolist()}
    if set(sizes) != set(MEMBERS) or any(sizes[m] > limit[m] for m in MEMBERS):
        raise ValueError(f"members {sorted(sizes)} of {sizes}; expected {sorted(MEMBERS)} in at most {limit} bytes")
    with np.load(path, allow_pickle=False) as z:
        if json.loads(str(z["key"][()])) != json.loads(json.dumps(key)):
            return None
        mins, maxs, non_finite = z["mins"], z["maxs"], z["non_finite"]
    if mins.dtype != source.dtype or maxs.dtype != source.dtype or mins.shape != shape or maxs.shape != shape:
        raise ValueError(f"ranges of {mins.dtype}/{maxs.dtype} {mins.shape}/{maxs.shape}; expected {source.dtype} "
                         f"{shape}")
    if non_finite.shape != () or non_finite.dtype.kind not in "iu" or int(non_finite) < 0:
        raise ValueError(f"non_finite {non_finite!r}")
    if int(non_finite) == 0 and mins.dtype.kind == "f" and not (np.isfinite(mins).all() and np.isfinite(maxs).all()):
        raise ValueError("NaN or Inf in the ranges of finite data")
    if (mins > maxs).any():
        raise ValueError("a block's minimum above its maximum")
    return BlockRanges(mins, maxs, block, source.dims, int(non_finite), path)


def _save(source, key: dict, ranges: BlockRanges) -> Path | None:
    """Write the sidecar (beside the data, else in the cache folder) under a temporary name renamed into
    place, so a reader never sees half a file; None when neither place is writable."""
    for path in sidecar_paths(source, key):
        if not current().allows(path):  # the cache folder or a link outside the sandbox's roots
            continue
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, temporary = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
            try:
                with os.fdopen(fd, "wb") as fh:
                    np.savez(fh, mins=ranges.mins, maxs=ranges.maxs, key=np.array(json.dumps(key)),
                             non_finite=np.array(ranges.non_finite))
                os.replace(temporary, path)
            except BaseException:
                os.unlink(temporary)
                raise
            return path
        except OSError:
            continue
    return None

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

Nor is a sidecar dvr-gl did not write for this user: each is signed (HMAC-SHA256 over its key and the
exact bytes of its ranges and non-finite count) with a secret key of :data:`KEY_BYTES` random bytes kept
in the cache folder (:func:`key_path`, mode 0600, created on first use).  One forged with the data's
real key and false ranges (every block empty: every brick skipped, a wrong picture), unsigned or signed
with another key, is computed again with a one-line warning and rewritten signed.  Where the key cannot
be created or read, no sidecar is trusted or written: the ranges are computed each time (one warning).
The key is dvr-gl's own state, not input a scene names, so a sandbox reads it outside its roots; it
only creates it inside them.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import logging
import math
import os
import stat
import struct
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
VERSION = 2  # of the sidecar's layout (2: signed): a sidecar of another version is computed again, silently
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
    """Where sidecars go when the data's folder is not writable, and the key that signs them."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "dvr-gl" / "ranges"


def sidecar_paths(source, key: dict) -> list[Path]:
    """Where the source's sidecar may be: beside the data, then in the cache folder (named by the data's
    absolute path, so that two files of one name do not share one)."""
    base = source.sidecar_base()
    beside = base.with_name(base.name + SUFFIX)
    cached = cache_folder() / f"{base.name}.{fingerprint({'path': str(base.resolve())})}{SUFFIX}"
    return [beside, cached]


# --- the key that signs sidecars ----------------------------------------------------------------------

KEY_BYTES = 32  # of the secret: HMAC-SHA256's block is 64 bytes, its output 32
KEY_NAME = "sidecar-signing.key"
_KEY_WARNED: set[str] = set()  # key files already warned about: one warning per process


def key_path() -> Path:
    """The secret key that signs this user's sidecars, in the cache folder."""
    return cache_folder() / KEY_NAME


def signing_key() -> bytes | None:
    """This user's secret key, created on first use (:data:`KEY_BYTES` from :func:`os.urandom`, mode 0600,
    never replacing one another process made first); None where it cannot be created or read (a read-only
    home; then no sidecar is trusted or written, with one warning per process), or does not exist yet
    under a sandbox whose roots exclude it: the key is read outside the roots (dvr-gl's own state, not
    input: a scene neither names nor supplies it) but never written there."""
    path = key_path()
    try:
        return _read_key(path)
    except FileNotFoundError:
        pass
    except OSError as exc:
        return _key_unusable(path, exc)
    if not current().allows(path):
        return None
    try:
        _create_key(path)
        return _read_key(path)
    except OSError as exc:
        return _key_unusable(path, exc)


_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


def _read_key(path: Path) -> bytes:
    """The key in ``path``: a regular file (never a FIFO: opened without blocking) of exactly
    :data:`KEY_BYTES` bytes, this user's, that no one else may read or write."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | _NOFOLLOW)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_size != KEY_BYTES:
            raise OSError(f"not a file of {KEY_BYTES} bytes")
        if hasattr(os, "getuid") and (st.st_uid != os.getuid() or st.st_mode & 0o077):
            raise OSError(f"owned by user {st.st_uid} with mode {stat.S_IMODE(st.st_mode):o}; expected this "
                          f"user's, mode 600")
        secret = os.read(fd, KEY_BYTES + 1)
    finally:
        os.close(fd)
    if len(secret) != KEY_BYTES:
        raise OSError(f"{len(secret)} bytes read; expected {KEY_BYTES}")
    return secret


def _create_key(path: Path) -> None:
    """Write a new key to a temporary file (``O_CREAT | O_EXCL``, mode 0600) and link it at ``path``: a
    reader never sees part of a key, and the first of two processes creating one at once wins."""
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f"{path.name}.{os.getpid()}.{os.urandom(4).hex()}.tmp")
    fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o600)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(os.urandom(KEY_BYTES))
        try:
            os.link(temporary, path)
        except FileExistsError:
            pass  # another process made one first: use it
        except OSError:  # a file system without hard links: create it in place
            if not path.exists():
                os.replace(temporary, path)
    finally:
        if os.path.lexists(temporary):
            os.unlink(temporary)


def _key_unusable(path: Path, exc: OSError) -> None:
    """None, with one warning line per key file and process."""
    if str(path) not in _KEY_WARNED:
        _KEY_WARNED.add(str(path))
        reason = exc.strerror or str(exc)
        log.warning("%s: the key that signs block-ranges sidecars cannot be used (%s); no sidecar is trusted: "
                    "the ranges are computed each time", path, reason)
    return None


def _signature(secret: bytes, key: dict, mins: np.ndarray, maxs: np.ndarray, non_finite: int) -> bytes:
    """HMAC-SHA256 over the sidecar's key, its ranges' types, shapes and exact bytes, and its non-finite
    count, each part prefixed with its length (no two contents give one message)."""
    mac = hmac.new(secret, digestmod=hashlib.sha256)

    def part(data) -> None:
        data = memoryview(data).cast("B")
        mac.update(struct.pack("<Q", data.nbytes))
        mac.update(data)

    part(b"dvr-gl block ranges sidecar")
    part(json.dumps(key, sort_keys=True).encode())
    for a in (mins, maxs):
        part(json.dumps([a.dtype.str, list(a.shape)]).encode())
        part(np.ascontiguousarray(a))
    part(str(int(non_finite)).encode())
    return mac.digest()


class _NotOurs(Exception):
    """A sidecar that agrees with itself but was not signed with this user's key."""


def _load(source, key: dict) -> BlockRanges | None:
    """The ranges from the first sidecar whose key is ``key``; one that cannot be read or does not agree
    with itself (cut, garbage, other members, shapes or types, NaN) or whose signature is missing or
    wrong is not used: a one-line warning, and the ranges are computed again (and the sidecar rewritten).
    Inside a sandbox with roots, a sidecar outside them once links are followed (the cache folder, a
    link) is not read.  Without a key nothing is read."""
    box = current()
    secret = None
    for path in sidecar_paths(source, key):
        if not path.is_file() or not box.allows(path):  # FIFOs, devices and folders are not files
            continue
        secret = secret or signing_key()
        if secret is None:
            return None
        try:
            ranges = _read_sidecar(path, source, key, secret)
        except _NotOurs as exc:
            log.warning("%s: the block-ranges sidecar was not written by dvr-gl for this user (%s); computing "
                        "the ranges again", path, exc)
            continue
        except Exception as exc:  # a damaged file: zipfile, numpy and json raise many kinds  # noqa: BLE001
            text = str(exc).splitlines()[0] if str(exc) else ""
            log.warning("%s: the block-ranges sidecar is damaged (%s); computing the ranges again", path,
                        f"{type(exc).__name__}: {text}" if text else type(exc).__name__)
            continue
        if ranges is not None:
            return ranges
    return None


#: The members of a sidecar, and the most bytes each but the ranges may hold (``signature.npy`` may be
#: missing: an unsigned sidecar is refused as not ours, not as damaged).
MEMBERS = {"mins.npy": None, "maxs.npy": None, "key.npy": 1 << 20, "non_finite.npy": 1 << 10,
           "signature.npy": 1 << 10}


def _read_sidecar(path: Path, source, key: dict, secret: bytes) -> BlockRanges | None:
    """The ranges a sidecar holds, None where its key is another (stale: the data changed), or an exception
    where it does not agree with itself (:class:`_NotOurs` where it does but its signature is missing or
    wrong).  Its members' sizes are checked before any is read, so that a forged header cannot make numpy
    allocate more than the ranges of this volume."""
    block = key["block"]
    shape = tuple(-(-n // block) for n in reversed(source.dims))
    limit = {m: n or math.prod(shape) * source.dtype.itemsize + 1024 for m, n in MEMBERS.items()}
    with zipfile.ZipFile(path) as archive:
        sizes = {info.filename: info.file_size for info in archive.infolist()}
    if set(sizes) not in (set(MEMBERS), set(MEMBERS) - {"signature.npy"}) or any(sizes[m] > limit[m] for m in sizes):
        raise ValueError(f"members {sorted(sizes)} of {sizes}; expected {sorted(MEMBERS)} in at most {limit} bytes")
    with np.load(path, allow_pickle=False) as z:
        if json.loads(str(z["key"][()])) != json.loads(json.dumps(key)):
            return None
        mins, maxs, non_finite = z["mins"], z["maxs"], z["non_finite"]
        signature = z["signature"] if "signature" in z.files else None
    if mins.dtype != source.dtype or maxs.dtype != source.dtype or mins.shape != shape or maxs.shape != shape:
        raise ValueError(f"ranges of {mins.dtype}/{maxs.dtype} {mins.shape}/{maxs.shape}; expected {source.dtype} "
                         f"{shape}")
    if non_finite.shape != () or non_finite.dtype.kind not in "iu" or int(non_finite) < 0:
        raise ValueError(f"non_finite {non_finite!r}")
    if int(non_finite) == 0 and mins.dtype.kind == "f" and not (np.isfinite(mins).all() and np.isfinite(maxs).all()):
        raise ValueError("NaN or Inf in the ranges of finite data")
    if (mins > maxs).any():
        raise ValueError("a block's minimum above its maximum")
    if signature is None:
        raise _NotOurs("no signature")
    if (signature.dtype != np.uint8 or signature.shape != (32,)
            or not hmac.compare_digest(signature.tobytes(), _signature(secret, key, mins, maxs, int(non_finite)))):
        raise _NotOurs("a wrong signature")
    return BlockRanges(mins, maxs, block, source.dims, int(non_finite), path)


def _save(source, key: dict, ranges: BlockRanges) -> Path | None:
    """Write the sidecar, signed (beside the data, else in the cache folder) under a temporary name
    renamed into place, so a reader never sees half a file; None when neither place is writable or there
    is no key to sign it with (an unsigned sidecar would never be read)."""
    secret = None
    for path in sidecar_paths(source, key):
        if not current().allows(path):  # the cache folder or a link outside the sandbox's roots
            continue
        secret = secret or signing_key()
        if secret is None:
            return None
        signature = np.frombuffer(_signature(secret, key, ranges.mins, ranges.maxs, ranges.non_finite), np.uint8)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, temporary = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
            try:
                with os.fdopen(fd, "wb") as fh:
                    np.savez(fh, mins=ranges.mins, maxs=ranges.maxs, key=np.array(json.dumps(key)),
                             non_finite=np.array(ranges.non_finite), signature=signature)
                os.replace(temporary, path)
            except BaseException:
                os.unlink(temporary)
                raise
            return path
        except OSError:
            continue
    return None

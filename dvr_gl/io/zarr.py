"""zarr arrays and OME-Zarr images through the zarr package (extra ``zarr``).

* A zarr array of three dimensions (leading axes of size 1 are dropped): ``[z, y, x]``, spacing 1.
* A group holding one array (or the one ``volume.array`` names, by its path in the group).
* An OME-Zarr image (NGFF 0.4, ``multiscales`` in the group's attributes, or 0.5, under ``ome``): the
  level ``volume.level`` chooses (0, the default, is the full resolution); its ``axes`` name the z, y
  and x axes (in any order: the array is transposed by name, never guessed); the ``coordinateTransformations``,
  the dataset's then the multiscale's, give the spacing (``scale``) and origin (``translation``) in the axes'
  units.  The channel axis (type ``channel``, else named ``c``) gives every channel, each a field
  (:mod:`.channels`; names from the ``omero`` metadata's channel ``label``), or ``volume.channel``'s alone;
  the time axis (type ``time``, else named ``t``) gives step ``volume.time`` (default 0), its chunks alone
  read, the seconds between steps from its scale and unit; another axis of size 1 is dropped and a longer one
  refused.  Out of core (:func:`zarr_layout`) reads one channel of one step: with several channels, name one.

What is checked, before any voxel is read (each a one-line :class:`VolumeError`):

* the OME metadata, against the NGFF 0.4/0.5 schema's rules, before any array is opened
  (:func:`ome_image`): ``multiscales`` a list of objects, ``datasets`` a non-empty list of at most
  :data:`MAX_LEVELS` objects with a relative ``path`` (no ``..``, ``.`` or leading ``/``), ``axes`` a
  list of unique names (objects with a string ``name``), transforms of a known ``type`` with one finite
  number per axis, a known ``version``;
* the chosen array (and out of core its coarser levels, :func:`check_array`): a scalar type, chunks of
  at least one sample, a chunk within the memory budget (zarr decodes whole chunks), at most
  :data:`MAX_CHUNKS` chunks; read whole, its bytes within the budget;
* every file the store reads (metadata and chunks, :func:`open_store`): inside the store, a regular
  file, read whole only within the memory budget, and under a sandbox with roots inside them once
  links are followed (a chunk linked to a file elsewhere is refused, not read);
* a blosc chunk (a shard's inner chunks too) whose header does not fit it or the array is refused before
  numcodecs decodes it (:mod:`.blosc`: c-blosc trusts the header, and reads past the chunk);
* a chunk that does not decode (corrupt, cut, of another size) is refused in one line, and the zarr
  reads still under way are let finish first, so that nothing else is printed.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import json
import logging
import math
import os
import stat
from pathlib import Path

import numpy as np

from .. import progress
from ..errors import DvrError, VolumeError
from ..sandbox import SandboxError, check_bytes, current
from . import blosc
from .channels import Axes, RawChannels, channel_names, check_count, pick_channel, pick_step, seconds
from .common import RawArray, check_sample_type, check_spacing, require, show

SPATIAL = ("z", "y", "x")
#: The most chunks an array may have: zarr reads 1.5k (stored) to 15k (missing) chunks a second on two
#: cores, so this is 20 minutes to 3 hours of reading; a store in smaller chunks is refused (rechunk it).
MAX_CHUNKS = 1 << 24
CHUNK_RATE = 1500  # stored chunks a second read on two cores (small chunks; 0.7 ms each)
#: Chunks one zarr call reads at most when an array is read whole: zarr lists every chunk of a call
#: first, so this bounds that list, and each call is a step of the progress bar.
SLAB_CHUNKS = 4096
#: OME-Zarr versions read (0.1 to 0.3 have the same multiscales, 0.3's axes are plain names).
VERSIONS = ("0.1", "0.2", "0.3", "0.4", "0.5")
#: The most levels an OME-Zarr image may have (each coarser one is opened to read it out of core).
MAX_LEVELS = 64
#: The files that hold a store's metadata (JSON), and the memory parsing one takes, in times its size.
METADATA_FILES = (".zarray", ".zattrs", ".zgroup", ".zmetadata", "zarr.json")
JSON_FACTOR = 16
#: Seconds to let the zarr reads still under way finish after one failed (see :func:`reading`); those
#: still running then are cancelled.
SETTLE_SECONDS = 10.0

log = logging.getLogger(__name__)


def read_zarr(path: Path, array: str | None = None, level: int | None = None, channel: int | None = None,
              time: int | None = None):
    """The chosen array's volume; an OME-Zarr image of several channels with none chosen, a
    :class:`.channels.RawChannels` of them all; of a time series, step ``time`` alone."""
    target, axes, transforms, name, attrs, _ = _open(path, array, level)
    info = _image_axes(target.shape, axes, transforms, attrs, name)
    axes = chosen_axes(axes, info, channel, time, name)
    index, order, spacing, origin = zarr_plan(target.shape, axes, transforms, name, keep_channels=True)
    kept = [n for n, i in zip(target.shape, index) if isinstance(i, slice)]
    several = "several channels: pick one (volume.channel) to read it out of core, " if len(kept) > 3 else ""
    check_bytes(math.prod(kept) * np.dtype(target.dtype).itemsize,
                f"{name}: the zarr array of shape {tuple(kept)}" + (f" read from {tuple(target.shape)}" if
                                                                    len(kept) < len(target.shape) else ""),
                f"choose a coarser level (volume.level), {several}read it out of core (volume.out_of_core), or "
                f"raise the memory budget")
    check_array(target, name)
    data = read_all(target, name, index)
    if len(kept) == 3:
        return RawArray(np.ascontiguousarray(np.transpose(data, order)), spacing, origin)
    at = [k for k, i in zip(range(len(index)), index) if isinstance(i, slice)].index(_channel_axis(axes))
    arrays = [RawArray(np.ascontiguousarray(np.transpose(np.take(data, c, axis=at), order)), spacing, origin)
              for c in range(data.shape[at])]
    return RawChannels(arrays, list(info.names))


def read_all(target, name: str, index: tuple | None = None) -> np.ndarray:
    """The array's samples that ``index`` selects (default all; a slice or an integer per axis), read
    ``SLAB_CHUNKS`` chunks at a time along the first axis it slices (a progress step each): the chunks outside
    the selection (another time step's) are never read."""
    shape, chunks = tuple(target.shape), tuple(target.chunks)
    if not shape:
        return np.asarray(target[...])
    index = tuple(index) if index is not None else (slice(None),) * len(shape)
    kept = [k for k, i in enumerate(index) if isinstance(i, slice)]
    out = np.empty([shape[k] for k in kept], dtype=target.dtype)
    first = kept[0]
    per_layer = math.prod(-(-shape[k] // chunks[k]) for k in kept[1:])
    step_rows = chunks[first] * max(1, SLAB_CHUNKS // max(per_layer, 1))
    with progress.task(f"reading {Path(name).name}", out.nbytes, "B") as step, reading(name, CHUNK):
        for start in range(0, shape[first], step_rows):
            selection = list(index)
            selection[first] = slice(start, start + step_rows)
            out[start:start + step_rows] = target[tuple(selection)]
            step(out[:start + step_rows].nbytes)
    return out


def zarr_axes(path: Path, array: str | None = None, level: int | None = None) -> Axes:
    """The channels and time steps of the chosen array (:class:`.channels.Axes`), nothing read but metadata."""
    target, axes, transforms, name, attrs, _ = _open(path, array, level)
    return _image_axes(target.shape, axes, transforms, attrs, name)


def _kind_of(axis) -> str | None:
    """``"channel"``, ``"time"`` or None for an axis ``(name, type[, pick])``: by its type, else its name."""
    name, kind = axis[0].lower(), axis[1]
    if kind in ("channel", "time"):
        return kind
    return {"c": "channel", "t": "time"}.get(name) if kind in (None, "") else None


def _channel_axis(axes) -> int | None:
    found = [k for k, a in enumerate(axes or ()) if _kind_of(a) == "channel" and a[0].lower() not in SPATIAL]
    return found[0] if found else None


def _image_axes(shape, axes, transforms, attrs: dict, name: str) -> Axes:
    """What an OME-Zarr image holds beyond space: its channel axis (with the omero labels), its time axis
    (with the seconds between steps, from the axis' scale and unit); a bare array: none."""
    if axes is None or len(axes) != len(shape):
        return Axes()
    kinds = [_kind_of(a) if a[0].lower() not in SPATIAL else None for a in axes]
    for kind in ("channel", "time"):
        if kinds.count(kind) > 1:
            raise VolumeError(f"{name}: the axes name {kinds.count(kind)} {kind} axes; an image has at most one: fix "
                              f"the metadata")
    channels, names, steps, interval = 0, (), 1, None
    if "channel" in kinds:
        channels = check_count(shape[kinds.index("channel")], name, "channels")
        names = tuple(channel_names(_omero_labels(attrs), channels))
    if "time" in kinds:
        at = kinds.index("time")
        steps = check_count(shape[at], name, "time steps")
        scale = np.ones(len(axes))
        for kind, values in _as_pairs(transforms, len(axes), name):
            scale = scale * values if kind == "scale" else scale
        interval = seconds(scale[at], attrs.get("_units", {}).get(axes[at][0]) or "") if steps > 1 else None
    return Axes(channels, names, steps, interval)


def _omero_labels(attrs: dict) -> list:
    """The omero metadata's channel labels (0.4 at the top, 0.5 under ``ome``); [] where absent or malformed."""
    omero = attrs.get("omero", (attrs.get("ome") or {}).get("omero") if isinstance(attrs.get("ome"), dict) else None)
    channels = omero.get("channels") if isinstance(omero, dict) else None
    if not isinstance(channels, list):
        return []
    return [c.get("label") if isinstance(c, dict) and isinstance(c.get("label"), str) else "" for c in channels]


def chosen_axes(axes, info: Axes, channel, time, name: str):
    """``axes`` with the chosen entries picked, ``(name, type, index)``: the time axis' step (default 0), the
    channel axis' channel where one is chosen (every channel otherwise); each checked against the file."""
    chosen = pick_channel(channel, info, name)
    step = pick_step(time, info, name)
    if axes is None:
        return None
    picked = []
    for axis in axes:
        kind = _kind_of(axis) if axis[0].lower() not in SPATIAL else None
        pick = step if kind == "time" else chosen if kind == "channel" else None
        picked.append((axis[0], axis[1], pick) if pick is not None else tuple(axis[:2]))
    return picked


def open_zarr(path: Path, array: str | None = None, level: int | None = None, with_levels: bool = False):
    """The zarr array chosen (see the module doc) without reading it: ``(array, axes, transforms, name)``;
    ``axes`` is None for an array without OME metadata.  ``with_levels``: a fifth item, the
    ``(array, transforms)`` of each coarser OME-Zarr level after the chosen one, fine to coarse."""
    found = _open(path, array, level, with_levels)
    return found[:4] + ((found[5],) if with_levels else ())


def _open(path: Path, array: str | None = None, level: int | None = None, with_levels: bool = False):
    """:func:`open_zarr`'s four items, the group's attributes (with ``_units``: each axis' unit) and the
    coarser levels."""
    zarr = require("zarr", "zarr", "zarr")
    path = Path(path)
    if not current().allows(path):
        roots = ", ".join(str(r) for r in current().roots)
        raise SandboxError(f"{path}: the zarr store lies outside the allowed folders ({roots}); move it into one "
                           f"of them")
    name = str(path)
    with reading(name, "not a zarr store, or its metadata is not valid ({}); check the path, or fix the store"):
        node = zarr.open(store=open_store(path), mode="r")
    axes, transforms, coarser, attrs = None, [], [], {}
    if isinstance(node, zarr.Array):
        if array is not None or level is not None:
            raise VolumeError(f"{name}: a single zarr array; volume.array and volume.level apply to groups: "
                              f"remove them")
        target = node
    else:
        attrs = dict(node.attrs)
        image = ome_image(attrs, name)
        if image is not None:
            attrs["_units"] = _units(attrs)
            datasets, axes, common = image
            chosen = _level_index(level, len(datasets), name)
            target, transforms = _dataset(node, datasets[chosen], name), datasets[chosen][1] + common
            coarser = [(_dataset(node, d, name), d[1] + common) for d in datasets[chosen + 1:]] \
                if with_levels else []
        else:
            if level is not None:
                raise VolumeError(f"{name}: volume.level applies to OME-Zarr multiscale images; this group has no "
                                  f"multiscales metadata")
            target = _member(node, array, name)
    return target, axes, transforms, name, attrs, coarser


def _units(attrs: dict) -> dict:
    """Each named axis' unit (a string) in the first multiscale image (checked already by :func:`ome_image`)."""
    ome = attrs.get("ome") if isinstance(attrs.get("ome"), dict) else attrs
    axes = ome["multiscales"][0].get("axes") or []
    return {a["name"]: a["unit"] for a in axes if isinstance(a, dict) and isinstance(a.get("unit"), str)}


class ZarrLayout(tuple):
    """:func:`zarr_layout`'s ``(array, axes, transforms, name, coarser)``; ``refusal`` says why it cannot be read
    in part (several channels, none chosen), None where it can."""

    refusal = None


def zarr_layout(path: Path, array: str | None = None, level: int | None = None, channel: int | None = None,
                time: int | None = None) -> ZarrLayout:
    """The chosen array and its coarser levels, unread (:func:`open_zarr` ``with_levels``), for reading in part
    (each checked by :func:`check_array`); the axes carry the chosen channel and step (:func:`chosen_axes`), so
    that only their chunks are read.  Several channels with none chosen: its ``refusal`` says to choose one."""
    target, axes, transforms, name, attrs, coarser = _open(path, array, level, with_levels=True)
    info = _image_axes(target.shape, axes, transforms, attrs, name)
    found = ZarrLayout((target, chosen_axes(axes, info, channel, time, name), transforms, name, coarser))
    if channel is None and info.channels > 1:
        found.refusal = (f"{name}: {info.channels} channels; out of core reads one channel at a time: choose it "
                         f"(volume.channel, one [[volume]] table a channel) or read it in memory")
        return found
    for target in [found[0], *(a for a, _ in found[4])]:
        check_array(target, found[3])
    return found


def check_array(target, name: str) -> None:
    """Refuse, before any chunk is read, an array a volume cannot come from or that reading would not
    survive: not a scalar type, chunks of no sample, a chunk over the memory budget (zarr decodes whole
    chunks), more than :data:`MAX_CHUNKS` chunks (the whole array's bytes are checked where it is read
    whole, :func:`read_zarr`)."""
    what = f"{name}: the zarr array {show(getattr(target, 'path', '') or '/')}"
    dtype = np.dtype(target.dtype)
    check_sample_type(dtype, name, "the zarr array's dtype", str(dtype))
    shape, chunks = tuple(int(n) for n in target.shape), tuple(int(c) for c in target.chunks)
    if len(chunks) != len(shape) or min(chunks, default=1) < 1 or min(shape, default=0) < 0:
        raise VolumeError(f"{what} has shape {list(shape)} in chunks {list(chunks)}; chunks need one positive "
                          f"size per axis: fix or rewrite the store")
    check_bytes(math.prod(chunks) * dtype.itemsize, f"{what}: one chunk of {list(chunks)}",
                "rewrite the store in smaller chunks (e.g. 64^3), or raise the memory budget")
    count = math.prod(-(-n // c) for n, c in zip(shape, chunks))
    if count > MAX_CHUNKS:
        raise VolumeError(f"{what} has {count:.3g} chunks of {list(chunks)}, over {MAX_CHUNKS} (about "
                          f"{_duration(count / CHUNK_RATE)} of reading at the {CHUNK_RATE} chunks a second measured "
                          f"on two cores); rewrite the store in larger chunks (e.g. 64^3)")


def zarr_plan(shape, axes, transforms, name, keep_channels: bool = False):
    """How to turn an array of ``shape`` into the volume ``[z, y, x]``: ``(index, order, spacing, origin)``:
    ``array[index]`` drops the axes of size 1 that are not spatial and takes the entry an axis
    ``(name, type, index)`` picks (:func:`chosen_axes`), ``np.transpose(_, order)`` orders the spatial ones
    z, y, x; spacing and origin (x first) come from the OME transforms (None without ``axes``: a bare array's
    leading axes of size 1 are dropped, nothing is transposed).  ``keep_channels``: the channel axis, unpicked,
    is kept (a slice; ``order`` then orders the spatial axes of one channel taken from it)."""
    if axes is None:
        drop = 0
        while len(shape) - drop > 3 and shape[drop] == 1:
            drop += 1
        if len(shape) - drop != 3:
            raise VolumeError(f"{name}: the array has shape {tuple(shape)}; a volume needs 3 dimensions (z, y, x)")
        return (0,) * drop + (slice(None),) * 3, (0, 1, 2), None, None
    return _by_axes(shape, axes, transforms, name, keep_channels)


# --- the store: every file checked before it is opened --------------------------------------------

def open_store(path) -> "object":
    """A read-only zarr store on the folder ``path`` whose every read is checked (:func:`check_key`)."""
    return _checked_store_class()(Path(path), read_only=True)


def is_checked(store) -> bool:
    """Whether ``store`` is one :func:`open_store` made."""
    return store is not None and isinstance(store, _checked_store_class())


@functools.cache
def _checked_store_class():
    from zarr.storage import LocalStore

    class CheckedStore(LocalStore):
        """zarr's LocalStore, each key's file checked by :func:`check_key` before it is opened."""

        def __init__(self, root, *, read_only: bool = False):
            super().__init__(root, read_only=read_only)
            self.folders = {}  # resolved folders (check_key)
            self.layouts = {}  # each folder's blosc chunks (blosc.find_layout)

        def check(self, key, whole: bool = False):
            check_key(self.root, key, self.folders, whole)

        async def get(self, key, prototype=None, byte_range=None):
            # checked and read in a worker thread, as LocalStore reads: the loop's thread, which starts
            # every chunk's read, is not held up by the check's system calls
            return await asyncio.to_thread(self.get_sync, key, prototype=prototype, byte_range=byte_range)

        async def get_partial_values(self, prototype, key_ranges):
            key_ranges = list(key_ranges)
            for key, _ in key_ranges:
                self.check(key)
            return await super().get_partial_values(prototype, key_ranges)

        def get_sync(self, key, *, prototype=None, byte_range=None):
            self.check(key, whole=byte_range is None)
            found = super().get_sync(key, prototype=prototype, byte_range=byte_range)
            if found is not None:
                self.check_chunk(key, found, byte_range)
            return found

        def check_chunk(self, key, found, byte_range=None):
            """A blosc chunk's header checked against it before numcodecs decodes it (:mod:`.blosc`: c-blosc
            trusts the header, and reads past a chunk whose header lies); a shard's, each inner chunk's."""
            if key.rpartition("/")[2] in METADATA_FILES:
                return
            expect = blosc.find_layout(str(self.root), key, self.layouts, lambda k: self.check(k, whole=True))
            if expect is not None:
                blosc.check_read(found.as_numpy_array(), expect, _part(byte_range),
                                 f"{self.root}: chunk {show(key)}")

        async def list_dir(self, prefix):
            self.check(prefix)
            async for key in super().list_dir(prefix):
                yield key

    return CheckedStore


def _part(byte_range) -> tuple[str, int]:
    """What a read of ``byte_range`` is (:func:`.blosc.check_read`): ``("whole", 0)``, ``("range", start)``
    (bytes ``start`` on: a shard's inner chunk, or its index at the start) or ``("other", 0)`` (a suffix: the
    index at a shard's end)."""
    from zarr.abc.store import RangeByteRequest

    if byte_range is None:
        return "whole", 0
    if isinstance(byte_range, RangeByteRequest):
        return "range", int(byte_range.start)
    return "other", 0


def check_key(root: Path, key: str, folders: dict | None = None, whole: bool = False) -> None:
    """Refuse to read the store's ``key``: a key outside the store (``..``, absolute), a file that is not
    regular (a FIFO would block), inside a sandbox with roots a file outside them once links are
    followed, and a file read ``whole`` larger than the memory budget (metadata: :data:`JSON_FACTOR`
    times its size, what parsing it takes).  A missing file passes (zarr reads a missing chunk as the fill
    value).

    ``folders`` (the store's own) keeps each folder's resolved path, so that a chunk costs one ``lstat``
    more than none (its folder resolved once; the chunk itself followed only where it is a link):
    ``os.path.realpath`` of every chunk cost 50 us, a tenth of reading a small chunk."""
    parts = key.replace("\\", "/").split("/")
    if key.startswith(("/", "\\")) or ".." in parts:
        raise VolumeError(f"{root}: the store names {show(key)}, outside itself; fix the metadata (paths are "
                          f"relative, without '..')")
    path = os.path.join(root, key)
    roots = current().roots
    try:
        if roots:
            allowed = _resolved(roots)
            folder, _, leaf = key.rpartition("/")
            folders = {} if folders is None else folders
            where = folders.get((folder, roots))
            if where is None:
                where = _inside(os.path.join(root, folder), allowed, roots)
                folders[(folder, roots)] = where
            found = os.lstat(os.path.join(where, leaf))
            if stat.S_ISLNK(found.st_mode):
                found = os.stat(_inside(path, allowed, roots))
        else:
            found = os.stat(path)
    except OSError:
        return
    if not (stat.S_ISREG(found.st_mode) or stat.S_ISDIR(found.st_mode)):
        raise SandboxError(f"{path}: the zarr store's file is not a regular file (a FIFO, device or socket could "
                           f"block); fix the store")
    if whole and stat.S_ISDIR(found.st_mode):  # zarr would read it as a missing chunk: its fill value
        raise VolumeError(f"{path}: a folder where the store has a file (a chunk or metadata); the store is "
                          f"damaged: rewrite it")
    if whole and stat.S_ISREG(found.st_mode):
        metadata = parts[-1] in METADATA_FILES
        check_bytes(found.st_size * (JSON_FACTOR if metadata else 1),
                    f"{path}: reading this {'metadata' if metadata else 'chunk'} file of {found.st_size} bytes",
                    "the store is damaged or not meant for this: rewrite it, or raise the memory budget")


def _inside(path: str, allowed: tuple[str, ...], roots) -> str:
    """``path`` resolved (links followed) if it lies under one of the ``allowed`` (resolved) roots."""
    resolved = os.path.realpath(path)
    if not any(resolved == r or resolved.startswith(r.rstrip(os.sep) + os.sep) for r in allowed):
        raise SandboxError(f"{path}: the zarr store's file lies outside the allowed folders "
                           f"({', '.join(map(str, roots))}) once links are followed; move it into one of them")
    return resolved


def _duration(seconds: float) -> str:
    for unit, size in (("hours", 3600.0), ("minutes", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


@functools.lru_cache(maxsize=16)
def _resolved(roots: tuple) -> tuple[str, ...]:
    """The roots with links followed, once per set of roots (not once per chunk)."""
    return tuple(os.path.realpath(r) for r in roots)


# --- reading: one line for whatever zarr raises, nothing else printed ------------------------------

#: What :func:`reading` says of a chunk that does not decode.
CHUNK = "a chunk of the zarr array cannot be read ({}); the store is damaged: rewrite it"
#: ... and of an array's metadata zarr refuses (after ``what``, the array's name).
METADATA = "metadata is not valid ({}); fix or rewrite the store"


@contextlib.contextmanager
def reading(name: str, says: str = METADATA, what: str = ""):
    """Turn what zarr raises while opening or reading (a corrupt chunk, broken JSON, metadata zarr
    refuses) into one :class:`VolumeError` line, ``f"{name}: {what}{says}"`` with the cause in ``says``'
    ``{}``; our own errors (a file outside the sandbox) pass as they are.

    zarr reads a call's chunks as concurrent tasks on its own event loop: when one fails the others
    are still under way, and at exit Python would print each as "Task was destroyed but it is
    pending!" with tracebacks.  They are let finish first (:func:`_settle`)."""
    try:
        yield
    except DvrError:
        _settle()
        raise
    except Exception as exc:  # zarr, numcodecs and json raise many kinds  # noqa: BLE001
        _settle()
        text = str(exc).splitlines()[0] if str(exc) else ""
        raise VolumeError(f"{name}: {what}" + says.format(f"{type(exc).__name__}: {text}" if text else
                                                           type(exc).__name__)) from None
    except BaseException:  # the sandbox's timer, ^C: what is under way is dropped
        _settle(cancel=True)
        raise


def _settle(cancel: bool = False):
    """Wait (at most :data:`SETTLE_SECONDS`) for the tasks still on zarr's event loop, or cancel them,
    and send what the loop reports of them to the debug log rather than stderr.  Waiting, not cancelling,
    after an error: the loop is the process's, and another thread's reads (a Dask worker's) go on."""
    try:
        from zarr.core import sync
    except ImportError:
        return
    loop = sync.loop[0]
    if loop is None or loop.is_closed():
        return
    loop.set_exception_handler(_quiet)

    async def rest():
        me = asyncio.current_task()
        tasks = [t for t in asyncio.all_tasks() if t is not me]
        for t in tasks if cancel else ():
            t.cancel()
        if tasks:
            _, late = await asyncio.wait(tasks, timeout=SETTLE_SECONDS)
            for t in late:  # still reading after all that time: dropped
                t.cancel()
            if late:
                await asyncio.wait(late, timeout=1.0)
        for t in tasks:  # retrieved: no "exception was never retrieved"
            if t.done() and not t.cancelled():
                t.exception()

    with contextlib.suppress(Exception):
        sync.sync(rest(), loop=loop)


def _quiet(loop, context):
    log.debug("zarr's event loop: %s", context.get("message"))


# --- OME-Zarr metadata --------------------------------------------------------------------------------

def ome_image(attrs: dict, name: str):
    """The first multiscale image of a group's attributes, checked against the NGFF 0.4/0.5 schema's rules
    (the module doc), or None where the group has no ``multiscales``: ``(datasets, axes, transforms)``
    with ``datasets`` ``[(path, transforms), ...]`` fine to coarse, ``axes`` ``[(name, type), ...]`` and
    ``transforms`` the multiscale's own (each a list of ``("scale" | "translation", values)``)."""
    version = None
    if "ome" in attrs:  # 0.5
        ome = attrs["ome"]
        if not isinstance(ome, dict):
            raise VolumeError(f"{name}: the 'ome' attribute is {_kind(ome)}, not an object; fix the metadata "
                              f"(OME-Zarr 0.5)")
        if "multiscales" not in ome:
            return None
        multiscales, version = ome["multiscales"], ome.get("version")
    elif "multiscales" in attrs:
        multiscales = attrs["multiscales"]
    else:
        return None
    if not isinstance(multiscales, list) or not multiscales:
        raise VolumeError(f"{name}: 'multiscales' is {_kind(multiscales)}; OME-Zarr wants a list of images "
                          f"(objects with 'axes' and 'datasets'): fix the metadata")
    image = multiscales[0]
    if not isinstance(image, dict):
        raise VolumeError(f"{name}: the first multiscales entry is {_kind(image)}, not an object with 'axes' and "
                          f"'datasets'; fix the metadata")
    version = image.get("version", version)
    if version is not None and version not in VERSIONS:
        raise VolumeError(f"{name}: OME-Zarr version {show(version)} is not one this reader knows "
                          f"({', '.join(VERSIONS)}); convert the image (e.g. with ome-zarr-py) or read its arrays "
                          f"as plain zarr (volume.array)")
    axes = _axes(image.get("axes"), name)
    datasets = image.get("datasets")
    if not isinstance(datasets, list) or not datasets:
        raise VolumeError(f"{name}: the multiscales 'datasets' is {_kind(datasets)}; OME-Zarr wants a list of "
                          f"levels, each {{'path': ..., 'coordinateTransformations': [...]}}: fix the metadata")
    if len(datasets) > MAX_LEVELS:
        raise VolumeError(f"{name}: the image has {len(datasets)} levels, over {MAX_LEVELS} (each halves the last: "
                          f"no image needs more); fix the metadata")
    levels = []
    for k, dataset in enumerate(datasets):
        where = f"dataset {k}"
        if not isinstance(dataset, dict) or "path" not in dataset:
            raise VolumeError(f"{name}: {where} ({_kind(dataset)}) has no 'path'; each level is "
                              f"{{'path': ..., 'coordinateTransformations': [...]}}: fix the metadata")
        levels.append((_path(dataset["path"], name, where),
                       _transforms(dataset.get("coordinateTransformations"), len(axes), name, where)))
    return levels, axes, _transforms(image.get("coordinateTransformations"), len(axes), name, "the multiscale")


def _kind(value) -> str:
    """What a field holds, in a few words, for a message."""
    if value is None:
        return "missing"
    if isinstance(value, dict):
        return "an object" if value else "an empty object"
    if isinstance(value, list) and not value:
        return "an empty list"
    if isinstance(value, str):
        return show(value)
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _axes(axes, name: str) -> list[tuple[str, str | None]]:
    if not isinstance(axes, list) or not axes:
        raise VolumeError(f"{name}: the multiscales 'axes' is {_kind(axes)}; OME-Zarr 0.4 and later want a list "
                          f"such as [{{'name': 'z', 'type': 'space'}}, ...]: fix the metadata")
    found = []
    for k, axis in enumerate(axes):
        if isinstance(axis, str):  # OME-Zarr 0.3: plain names
            axis = {"name": axis}
        if not isinstance(axis, dict) or not isinstance(axis.get("name"), str) or not axis["name"]:
            what = f"has name {_kind(axis.get('name'))}" if isinstance(axis, dict) else f"is {_kind(axis)}"
            raise VolumeError(f"{name}: axis {k} {what}; each axis is {{'name': 'z', 'type': 'space'}} (a name "
                              f"is a string): fix the metadata")
        kind = axis.get("type")
        if kind is not None and not isinstance(kind, str):
            raise VolumeError(f"{name}: axis {show(axis['name'])} has type {_kind(kind)}; a type is 'space', "
                              f"'time' or 'channel': fix the metadata")
        found.append((axis["name"], kind))
    names = [n.lower() for n, _ in found]
    if len(set(names)) != len(names):
        raise VolumeError(f"{name}: the axes {names} repeat a name; each axis needs its own: fix the metadata")
    return found


def _path(path, name: str, where: str) -> str:
    """A dataset's path: relative, inside the group (no ``..``, ``.`` or leading ``/``)."""
    if not isinstance(path, str) or not path.strip("/"):
        raise VolumeError(f"{name}: {where} has path {_kind(path)}; a path is the array's name in the group "
                          f"(a string, e.g. '0'): fix the metadata")
    parts = path.replace("\\", "/").split("/")
    if path.startswith(("/", "\\")) or any(p in ("", ".", "..") for p in parts) or ":" in parts[0]:
        raise VolumeError(f"{name}: {where} has path {show(path)}, which leaves the image or is not plain; a path "
                          f"is relative, inside the group, without '..': fix the metadata")
    return path


def _transforms(transforms, n: int, name: str, where: str) -> list[tuple[str, np.ndarray]]:
    """A ``coordinateTransformations`` list checked: ``[(type, values), ...]``, identities left out."""
    if transforms is None:
        return []
    if not isinstance(transforms, list):
        raise VolumeError(f"{name}: {where}'s coordinateTransformations is {_kind(transforms)}, not a list; "
                          f"fix the metadata")
    found = []
    for t in transforms:
        if not isinstance(t, dict):
            raise VolumeError(f"{name}: {where}'s coordinateTransformations hold {_kind(t)}, not an object such as "
                              f"{{'type': 'scale', 'scale': [...]}}: fix the metadata")
        kind = t.get("type")
        if kind == "identity":
            continue
        if kind not in ("scale", "translation"):
            raise VolumeError(f"{name}: {where} has a coordinateTransformation of type {_kind(kind)}; OME-Zarr "
                              f"images have 'scale' and 'translation' (and 'identity'): fix the metadata")
        values = t.get(kind)
        if values is None and "path" in t:
            raise VolumeError(f"{name}: {where}'s {kind} is stored in a file ({show(t['path'])}); this reader takes "
                              f"the values in the metadata: write them there")
        if not isinstance(values, list) or len(values) != n or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values):
            raise VolumeError(f"{name}: {where}'s {kind} is {_kind(values)}; it needs {n} finite numbers, one per "
                              f"axis: fix the metadata")
        found.append((kind, np.asarray(values, dtype=np.float64)))
    return found


def _level_index(level, count: int, name: str) -> int:
    try:
        level = 0 if level is None else int(level)
    except (TypeError, ValueError):
        raise VolumeError(f"{name}: volume.level must be an integer, got {level!r}") from None
    if not 0 <= level < count:
        raise VolumeError(f"{name}: volume.level {level} is out of range; the image has {count} levels "
                          f"(0 is the full resolution, {count - 1} the coarsest)")
    return level


def _dataset(group, dataset, name):
    """The array at a dataset's path (opened, not read)."""
    path = dataset[0]
    with reading(name, what=f"the zarr array {show(path)}'s "):
        try:
            found = group[path]
        except KeyError:
            found = None
    if found is None or not hasattr(found, "dtype"):
        raise VolumeError(f"{name}: the OME-Zarr dataset path {show(path)} names "
                          f"{'no array' if found is None else 'a group, not an array'} in the store; fix the "
                          f"metadata or the store")
    return found


def _member(group, array, name):
    with reading(name, what="an array's "):
        arrays = dict(sorted(group.arrays()))
    if array is not None:
        _path(array, name, "volume.array")
        with reading(name, what=f"the zarr array {show(array)}'s "):
            try:
                found = group[array]
            except KeyError:
                found = None
        if found is None or not hasattr(found, "dtype"):
            raise VolumeError(f"{name}: no array {array!r} in the group; it has "
                              f"{', '.join(map(repr, arrays)) or 'none'}")
        return found
    if len(arrays) != 1:
        raise VolumeError(f"{name}: the group holds {len(arrays)} arrays ({', '.join(map(repr, arrays)) or 'none'}); "
                          f"name one with volume.array")
    return next(iter(arrays.values()))


def _by_axes(shape, axes, transforms, name, keep_channels=False):
    if len(axes) != len(shape):
        raise VolumeError(f"{name}: {len(axes)} axes for an array of {len(shape)} dimensions; fix the metadata")
    names = [a[0].lower() for a in axes]
    missing = [a for a in SPATIAL if a not in names]
    if missing:
        raise VolumeError(f"{name}: the axes are named {', '.join(a[0] for a in axes)}; a volume needs axes named "
                          f"z, y and x (type 'space', in any order; others, such as t and c, of size 1): rename the "
                          f"axes in the multiscales metadata")
    scale, shift = np.ones(len(axes)), np.zeros(len(axes))
    # applied in turn: a later scale scales an earlier translation too
    for kind, values in _as_pairs(transforms, len(axes), name):
        if kind == "scale":
            scale, shift = scale * values, shift * values
        else:
            shift = shift + values
    index = []
    for entry, size in zip(axes, shape):
        axis, kind = entry[0], entry[1]
        pick = entry[2] if len(entry) > 2 else None
        if axis.lower() in SPATIAL:
            index.append(slice(None))
        elif pick is not None and 0 <= int(pick) < size:
            index.append(int(pick))
        elif size == 1:
            index.append(0)
        elif keep_channels and _kind_of(entry) == "channel":
            index.append(slice(None))
        else:
            what = _kind_of(entry) or kind or "other"
            key = {"channel": " (volume.channel)", "time": " (volume.time)"}.get(what, "")
            raise VolumeError(f"{name}: the {what} axis {axis!r} has {size} entries; a volume is one scalar field: "
                              f"choose one{key}, or write one {what} to its own array (e.g. with zarr) and read "
                              f"that")
    kept = [n for n in names if n in SPATIAL]
    order = tuple(kept.index(a) for a in SPATIAL)  # by name: [z, y, x]
    at = {n: i for i, n in enumerate(names)}
    spacing = check_spacing([scale[at[a]] for a in ("x", "y", "z")], name, "the scale coordinateTransformation")
    origin = tuple(float(shift[at[a]]) for a in ("x", "y", "z"))
    if not all(math.isfinite(o) for o in origin):
        raise VolumeError(f"{name}: the translation coordinateTransformation gives the origin {origin}; it needs "
                          f"finite numbers: fix the metadata or set volume.origin")
    return tuple(index), order, spacing, origin


def _as_pairs(transforms, n: int, name: str):
    """Transforms as ``(kind, values)``: :func:`_transforms`' pairs, or raw NGFF objects (the Python API's
    :class:`~dvr_gl.out_of_core.ZarrSource`) checked by it."""
    transforms = list(transforms)
    if all(isinstance(t, tuple) for t in transforms):
        return transforms
    return _transforms(transforms, n, name, "the transforms")

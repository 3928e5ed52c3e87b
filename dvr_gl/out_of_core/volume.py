"""A regular grid read out of core: :class:`OutOfCoreVolume`, and :func:`open_volume` to open a file as one.

The volume has :class:`~dvr_gl.fields.grid.Volume`'s interface (its geometry, ``dtype``, ``nbytes``,
``read(lo, dims)``, ``levels``, ``value_range``) without its voxels: ``read`` fetches a box from the
source through a host-memory LRU cache (:class:`.cache.ByteLRU`), and ``ranges`` (:class:`.BlockRanges`)
tells a renderer which boxes are empty before it reads them.  ``data`` is refused in one line: only
renderers that read bricks (the ray caster) render it.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import SceneError, VolumeError
from ..fields.grid import IDENTITY, Volume, check_direction
from .cache import ByteLRU
from .ranges import BLOCK, BlockRanges
from .sources import RawSource, ZarrSource

#: renderer.memory_budget_mb's default (MB): the host memory allowed for a volume's resident voxels (the scene
#: contract's setting reads it here, where the budget is spent).
MEMORY_BUDGET_MB = 4096.0
#: The share of the budget the cache of read boxes may hold; the rest is for what is read at the moment
#: (a brick, a mapped window, the block-range pass's tile) and for the renderer's staging.
CACHE_SHARE = 0.5
MB = 2 ** 20


class OutOfCoreVolume:
    """A regular grid whose voxels stay in their file (a :class:`~dvr_gl.fields.Field` of kind ``"grid"``).

    Args:
        source: a :class:`.RawSource`, :class:`.ZarrSource` or :class:`.ArraySource` (``read(lo, dims)``).
        spacing, origin, name, direction: as :class:`~dvr_gl.fields.grid.Volume`'s (name: the source's).
        memory_budget_mb: host memory for the cache of read boxes (:data:`CACHE_SHARE` of it).
        block_size: the block ranges' block side (voxels).
        ranges: the block ranges if known; else computed (or read from the sidecar) now, or on first use
            with ``lazy``.
        levels: coarser levels (each an :class:`OutOfCoreVolume` of the same box), fine to coarse.
        sidecar: keep the block ranges in a sidecar file (:mod:`.ranges`).
        lazy: compute the ranges on first use rather than now (coarser levels).
        cache: a :class:`.ByteLRU` to share (levels share their finest level's).
    """

    kind = "grid"
    out_of_core = True

    def __init__(self, source, spacing=None, origin=None, name: str | None = None, direction=None, *,
                 memory_budget_mb: float = MEMORY_BUDGET_MB, block_size: int = BLOCK, ranges: BlockRanges | None = None,
                 levels=(), sidecar: bool = True, lazy: bool = False, cache: ByteLRU | None = None):
        self.source = source
        self.name = name or source.name
        spacing = tuple(float(s) for s in (spacing if spacing is not None else (1.0, 1.0, 1.0)))
        origin = tuple(float(o) for o in (origin if origin is not None else (0.0, 0.0, 0.0)))
        if len(spacing) != 3 or not all(np.isfinite(spacing)) or min(spacing) <= 0:
            raise VolumeError(f"{self.name}: spacing must be three positive numbers, got {spacing}")
        if len(origin) != 3 or not all(np.isfinite(origin)):
            raise VolumeError(f"{self.name}: origin must be three finite numbers, got {origin}")
        if not memory_budget_mb > 0:
            raise VolumeError(f"{self.name}: renderer.memory_budget_mb must be > 0, got {memory_budget_mb}")
        self.spacing, self.origin = spacing, origin
        self.direction = check_direction(direction, self.name)
        self.memory_budget_mb = float(memory_budget_mb)
        self.block_size = int(block_size)
        self.sidecar = bool(sidecar)
        self._ranges = ranges
        self._levels = tuple(levels)
        self.cache = cache if cache is not None else ByteLRU(int(self.memory_budget_mb * MB * CACHE_SHARE))
        for level in self._levels:
            level.cache = self.cache
        if not lazy:
            self.ranges  # noqa: B018 (computed now: a volume of NaN is refused when it is opened)

    # --- what Volume has ---------------------------------------------------------------------------

    @property
    def dims(self) -> tuple[int, int, int]:
        """Number of samples along x, y, z."""
        return self.source.dims

    @property
    def dtype(self) -> np.dtype:
        """The scalar type :meth:`read` returns (uint8, uint16, int16 or float32)."""
        return self.source.dtype

    @property
    def nbytes(self) -> int:
        """The voxels' size in bytes (none of them resident)."""
        return self.source.nbytes

    @property
    def ranges(self) -> BlockRanges:
        """Per-block minima and maxima (:class:`.BlockRanges`), computed once (see :mod:`.ranges`)."""
        if self._ranges is None:
            self._ranges = BlockRanges.of(self.source, self.block_size, self.sidecar,
                                          slab_bytes=min(32 * MB, int(self.memory_budget_mb * MB / 4)))
        return self._ranges

    @property
    def value_range(self) -> tuple[float, float]:
        """The smallest and largest value (from the block ranges)."""
        return self.ranges.value_range

    @property
    def levels(self) -> tuple:
        """Coarser levels (OME-Zarr's, opened lazily too), fine to coarse; empty for a single level."""
        return self._levels

    def read(self, lo, dims) -> np.ndarray:
        """Voxels ``lo .. lo + dims - 1`` (x, y, z) as a C-contiguous ``[z, y, x]`` array of :attr:`dtype`,
        through the cache: read-only, as the cache keeps it (copy it to change it)."""
        key = (id(self), tuple(int(v) for v in lo), tuple(int(v) for v in dims))
        found = self.cache.get(key)
        if found is not None:
            return found
        data = self.source.read(lo, dims)
        data.setflags(write=False)
        self.cache.put(key, data)
        return data

    def subsample(self, max_values: int = 1 << 22) -> np.ndarray:
        """An even subsample of the voxels, ``[z, y, x]``, at most ``max_values`` of them: every ``s``-th
        voxel along each axis (the same stride on all three), read a plane at a time (one plane of the
        volume resident at most), for histograms and suggestions (``dvr info``, the viewer's panel)."""
        nx, ny, nz = self.dims
        stride = max(1, int(np.ceil((nx * ny * nz / max_values) ** (1 / 3))))
        planes = [self.source.read((0, 0, z), (nx, ny, 1))[0, ::stride, ::stride] for z in range(0, nz, stride)]
        return np.stack(planes)

    @property
    def data(self):
        raise SceneError(f"{self.name}: the volume ({_size(self.nbytes)}) is read out of core and only the raycast "
                         f"renderer renders it: use renderer.name = 'raycast', or load it whole (volume.out_of_core = "
                         f"false, or raise renderer.memory_budget_mb = {self.memory_budget_mb:g} above its size with "
                         f"out_of_core = 'auto')")

    samples = data

    def reconstruct(self, *args, **kwargs):
        return self.data  # the CPU references sample the voxels in memory: the same one-line refusal

    reconstruct_values = reconstruct

    # the geometry is Volume's own: it reads only dims, spacing and origin
    box = Volume.box
    bounds = Volume.bounds
    sample_spacing = Volume.sample_spacing
    world_to_index = Volume.world_to_index
    world_to_texture = Volume.world_to_texture
    voxels_to_world = Volume.voxels_to_world

    def describe(self) -> str:
        nx, ny, nz = self.dims
        lo, hi = self.value_range
        turned = "" if self.direction == IDENTITY else f", direction {[list(r) for r in self.direction]}"
        levels = f", {len(self.levels)} coarser levels" if self.levels else ""
        return (f"{self.name}: {nx}x{ny}x{nz} {self.dtype}, spacing {self.spacing}, origin {self.origin}{turned}, "
                f"values {lo:g}..{hi:g}, read out of core ({_size(self.nbytes)}{levels})")

    def __repr__(self) -> str:
        nx, ny, nz = self.dims
        return (f"OutOfCoreVolume({self.name!r}, {nx}x{ny}x{nz} {self.dtype}, spacing={self.spacing}, "
                f"origin={self.origin}, {self.source!r})")

    # --- pickling: small, no voxels, no open files ---------------------------------------------------

    def __getstate__(self):
        state = dict(self.__dict__)
        state["cache"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self.cache = ByteLRU(int(self.memory_budget_mb * MB * CACHE_SHARE))
        for level in self._levels:
            level.cache = self.cache


def _size(nbytes: int) -> str:
    return f"{nbytes / 2 ** 30:.3g} GiB" if nbytes >= 2 ** 30 else f"{nbytes / MB:.3g} MiB"


# --- opening ---------------------------------------------------------------------------------------

def open_volume(path, out_of_core=True, memory_budget_mb: float = MEMORY_BUDGET_MB, format: str = "auto", *,
                dims=None, dtype=None, endian: str = "little", header_bytes: int = 0, spacing=None, origin=None,
                nan_value: float | None = None, array: str | None = None, level: int | None = None,
                channel: int | None = None, time: int | None = None,
                block_size: int = BLOCK, sidecar: bool = True):
    """Open a volume file, out of core or in memory.

    Args:
        path: a raw file, NRRD (``.nrrd``/``.nhdr``), MetaImage (``.mhd``/``.mha``), a zarr store; any other
            format :func:`dvr_gl.io.load_volume` reads (in memory only).
        out_of_core: True: out of core (refused in one line for a format or encoding that cannot be read in
            part); ``"auto"``: out of core when the voxels exceed ``memory_budget_mb`` and the file can be
            read in part, else in memory; False: in memory (a :class:`~dvr_gl.fields.grid.Volume`).
        memory_budget_mb: renderer.memory_budget_mb (MB).
        format, dims, dtype, endian, header_bytes, spacing, origin, nan_value, array, level, channel, time: as
            :func:`dvr_gl.io.load_volume` takes them.
        block_size, sidecar: the block ranges' block side and whether they are kept in a sidecar file.
    """
    from ..io import detect_format, load_volume

    if out_of_core not in (True, False, "auto"):
        raise VolumeError(f"volume.out_of_core must be auto, true or false, got {out_of_core!r}")
    options = {"dims": dims, "dtype": dtype, "endian": endian, "header_bytes": header_bytes, "spacing": spacing,
               "origin": origin, "nan_value": nan_value, "array": array, "level": level, "channel": channel,
               "time": time}
    path = Path(os.path.expanduser(str(path)))
    if out_of_core is not False:
        opened = _open_in_part(path, format if format != "auto" else detect_format(path), options,
                               memory_budget_mb, block_size, sidecar, required=out_of_core is True)
        if opened is not None:
            return opened
    return load_volume(path, format, **options)


def _open_in_part(path: Path, fmt: str, options: dict, budget_mb: float, block_size: int, sidecar: bool,
                  required: bool):
    """The volume out of core, or None where it should be loaded whole (``required`` False: the voxels fit
    the budget, or the format cannot be read in part)."""
    from ..io import PARTIAL_FORMATS, voxel_layout
    from ..io.common import check_spacing
    from ..io.raw import RawLayout
    from ..io.series import VOLUME_FORMATS, is_pattern, step_file
    from ..sandbox import check_input_path

    if is_pattern(path) and fmt in VOLUME_FORMATS:  # a time series of files: the chosen step's file, read in part
        path, options = step_file(path, options.get("time")), {**options, "time": None}

    if fmt not in PARTIAL_FORMATS and not required:
        return None
    if fmt != "zarr" and os.path.lexists(path):
        check_input_path(path, "volume file")
    raw_options = {k: options[k] for k in ("dims", "dtype", "endian", "header_bytes", "array", "level")}
    if fmt != "raw":
        raw_options = {k: v for k, v in raw_options.items() if k not in ("endian", "header_bytes")}
    # the channel and time step a file's reader picks (dvr_gl.io.channels): zarr reads only their chunks
    raw_options.update({k: options[k] for k in ("channel", "time") if options.get(k) is not None})
    found = voxel_layout(path, fmt, raw_options)
    nan_value = options["nan_value"]
    if getattr(found, "refusal", None):  # a raw encoding not read in part; a zarr image of channels, none chosen
        if required:
            raise VolumeError(found.refusal)
        return None
    if isinstance(found, RawLayout):
        endian = "big" if found.dtype.byteorder == ">" else "little"
        source = RawSource(found.path, found.dims, found.dtype, found.offset, endian, nan_value, name=path.name)
        geometry, coarser = (found.spacing, found.origin, found.direction), []
    else:
        target, axes, transforms, name, coarser = found
        source = ZarrSource(target, axes, transforms, path.name, nan_value, store=path)
        geometry = (source.spacing, source.origin, None)
    if not required and source.nbytes <= budget_mb * MB:
        return None
    spacing = options["spacing"]
    spacing = check_spacing(spacing, str(path), "spacing (volume.spacing)") if spacing is not None else geometry[0]
    origin = options["origin"] if options["origin"] is not None else geometry[1]
    levels = []
    for level_array, level_transforms in coarser:  # OME-Zarr's coarser levels, in its own geometry
        level_source = ZarrSource(level_array, axes, level_transforms, f"{path.name} ({level_array.path})", nan_value,
                                  store=path)
        levels.append(OutOfCoreVolume(level_source, level_source.spacing, level_source.origin, direction=geometry[2],
                                      memory_budget_mb=budget_mb, block_size=block_size, sidecar=sidecar, lazy=True))
    return OutOfCoreVolume(source, spacing, origin, path.name, geometry[2], memory_budget_mb=budget_mb,
                           block_size=block_size, levels=levels, sidecar=sidecar)


def open_for_scene(path: Path, spec, memory_budget_mb: float):
    """The scene's volume out of core (``volume.out_of_core``: ``"auto"``, True, False; see
    :func:`open_volume`), or None where :func:`dvr_gl.io.load_field` loads it (in memory, a mesh, particles)."""
    from ..io import GRID_FORMATS, PARTIAL_FORMATS, detect_format

    choice = getattr(spec, "out_of_core", "auto")
    if choice is False:
        return None
    try:
        fmt = detect_format(path) if spec.format == "auto" else spec.format
    except VolumeError:
        if choice is True:
            raise
        return None  # load_field says what is wrong
    if fmt not in GRID_FORMATS or spec.series is not None or spec.resample is not None:
        if choice is True:
            raise VolumeError(f"{path}: volume.out_of_core = true applies to regular grids read in part "
                              f"({', '.join(PARTIAL_FORMATS)}); this is {fmt}: set volume.out_of_core = 'auto'")
        return None
    options = {"dims": spec.dims, "dtype": spec.dtype, "endian": spec.endian, "header_bytes": spec.header_bytes,
               "spacing": spec.spacing, "origin": spec.origin, "nan_value": spec.nan_value, "array": spec.array,
               "level": spec.level, "channel": getattr(spec, "channel", None), "time": getattr(spec, "time", None)}
    return _open_in_part(path, fmt, options, memory_budget_mb, BLOCK, True, required=choice is True)

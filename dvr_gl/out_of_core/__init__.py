"""Volumes larger than memory: read in part, box by box, never loaded whole (docs/out-of-core.md).

* :mod:`.sources`: :class:`RawSource` (raw files, NRRD raw encoding, uncompressed MetaImage),
  :class:`ZarrSource` (zarr v2/v3, OME-Zarr), :class:`ArraySource` (in memory); ``read(lo, dims)``;
* :mod:`.ranges`: :class:`BlockRanges`, every block's minimum and maximum, computed once and kept in a
  sidecar file, so that empty bricks are never read;
* :mod:`.cache`: :class:`ByteLRU`, the host-memory cache of read boxes, bounded in bytes;
* :mod:`.volume`: :class:`OutOfCoreVolume` (the :class:`~dvr_gl.fields.grid.Volume` interface without
  the voxels) and :func:`open_volume`;
* :mod:`.synthetic`: :func:`write_synthetic_raw`, large test volumes written in slabs.
"""

from .cache import ByteLRU
from .ranges import BLOCK, BlockRanges
from .sources import ArraySource, RawSource, Source, ZarrSource
from .synthetic import write_synthetic_raw
from .volume import MEMORY_BUDGET_MB, OutOfCoreVolume, open_for_scene, open_volume

__all__ = ["BLOCK", "MEMORY_BUDGET_MB", "ArraySource", "BlockRanges", "ByteLRU", "OutOfCoreVolume", "RawSource",
           "Source", "ZarrSource", "open_for_scene", "open_volume", "write_synthetic_raw"]

"""Where an out-of-core volume's voxels come from: sources that read a box of voxels and nothing more.

A source has ``dims = (nx, ny, nz)``, ``dtype`` (the scalar type the renderers get: uint8, uint16,
int16 or float32, native byte order, as :func:`dvr_gl.fields.grid.to_scalar_type` turns the stored
type into one), ``nbytes`` (``nx * ny * nz`` samples of ``dtype``) and ``read(lo, dims)``: the voxels
``lo .. lo + dims - 1`` (x, y, z order) as a C-contiguous ``[z, y, x]`` array the caller owns.  With
``nan_value`` given, NaN and +-Inf are replaced by it as they are read.

* :class:`RawSource`: uncompressed voxels at an offset in one file (raw files, NRRD raw encoding,
  uncompressed MetaImage), mapped a window at a time (see :meth:`RawSource._read` for why);
* :class:`ZarrSource`: a zarr array (v2 or v3, OME-Zarr axes by name), only the chunks a box touches;
* :class:`ArraySource`: an array in memory (tests, the Python API).

Sources pickle without their open files or arrays (a Dask worker reopens the file by its path).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import mmap
import os
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..fields.grid import to_scalar_type

#: The most bytes of a file mapped at once by :meth:`RawSource.read` (see there): what reading adds to the
#: resident memory beyond the box it returns.
MAP_WINDOW = 16 << 20


def scalar_type(stored: np.dtype, name: str = "volume") -> np.dtype:
    """The scalar type :func:`~dvr_gl.fields.grid.to_scalar_type` makes of ``stored`` (native order)."""
    return to_scalar_type(np.zeros(0, dtype=stored), name).dtype


def check_box(lo, dims, volume_dims, name: str) -> tuple[tuple[int, int, int], tuple[int, int, int]]:
    """``lo`` and ``dims`` (x, y, z) as integers, the box inside the volume, or a one-line error."""
    try:
        lo = tuple(int(v) for v in lo)
        dims = tuple(int(v) for v in dims)
    except (TypeError, ValueError):
        raise VolumeError(f"{name}: a box is lo = (x, y, z) and dims = (nx, ny, nz) in voxels, got {lo!r}, "
                          f"{dims!r}") from None
    if len(lo) != 3 or len(dims) != 3 or min(lo) < 0 or min(dims) < 1 or \
            any(a + n > v for a, n, v in zip(lo, dims, volume_dims)):
        raise VolumeError(f"{name}: the box lo {list(lo)} dims {list(dims)} is not inside the volume's "
                          f"{list(volume_dims)} voxels")
    return lo, dims


class Source:
    """What every source shares (see the module doc); subclasses implement :meth:`_read`."""

    name: str
    dims: tuple[int, int, int]
    stored: np.dtype  # as stored (byte order included)
    nan_value: float | None = None

    @property
    def dtype(self) -> np.dtype:
        """The scalar type :meth:`read` returns: uint8, uint16, int16 or float32, native byte order."""
        return scalar_type(self.stored, self.name)

    @property
    def nbytes(self) -> int:
        """Bytes of the whole volume in :attr:`dtype` (Python integers: no overflow)."""
        nx, ny, nz = self.dims
        return nx * ny * nz * self.dtype.itemsize

    def read(self, lo, dims) -> np.ndarray:
        """Voxels ``lo .. lo + dims - 1`` (x, y, z) as a new C-contiguous ``[z, y, x]`` array of :attr:`dtype`."""
        lo, dims = check_box(lo, dims, self.dims, self.name)
        data = self._read(lo, dims)
        data = np.ascontiguousarray(to_scalar_type(data, self.name))
        if self.nan_value is not None and data.dtype.kind == "f":
            data[~np.isfinite(data)] = self.nan_value  # the array is ours: replaced in place
        return data

    def _read(self, lo, dims) -> np.ndarray:
        raise NotImplementedError

    def confined(self):
        """Where no sandbox is in force (a Dask worker that unpickled the source), the roots of the one it
        was opened under, so that what it reads there is checked as it was here."""
        from ..sandbox import Sandbox, active, current

        box = current()
        roots = getattr(self, "roots", ())
        if box.roots or not roots:
            return contextlib.nullcontext()
        return active(Sandbox(roots=roots, max_bytes=box.max_bytes))

    def validity(self) -> dict | None:
        """What makes block ranges computed from this source valid (file size, mtime, layout), for the
        sidecar; None: nothing on disk to key them by (not cached)."""
        return None

    def sidecar_base(self) -> Path | None:
        """The path the ranges' sidecar is named after (``<base>.dvr-ranges.npz``); None: no sidecar."""
        return None


class RawSource(Source):
    """Uncompressed voxels, x fastest, after ``offset`` bytes of one file.

    Args:
        path: the file.
        dims: ``(nx, ny, nz)``.
        dtype: the stored sample type (a name such as ``"uint16"`` or a numpy dtype; one with an explicit
            byte order keeps it, otherwise ``byteorder`` says it).
        offset: bytes before the first voxel (a header).
        byteorder: ``"little"`` or ``"big"``.
        nan_value: replace NaN and +-Inf by this value as they are read (None: leave them).
        name: for messages (default the file's name).
    The file must hold at least ``offset`` plus the voxels' bytes.
    """

    def __init__(self, path, dims, dtype, offset: int = 0, byteorder: str = "little",
                 nan_value: float | None = None, name: str | None = None):
        self.path = Path(path)
        self.name = name or self.path.name
        dt = np.dtype(dtype)
        if byteorder not in ("little", "big"):
            raise VolumeError(f"{self.name}: byte order {byteorder!r}; use 'little' or 'big'")
        if dt.byteorder in "=|" and dt.itemsize > 1:
            dt = dt.newbyteorder("<" if byteorder == "little" else ">")
        if dt.kind not in "biuf":
            raise VolumeError(f"{self.name}: sample type {dt} is not a scalar type; use integers or floats")
        self.stored = dt
        self.dims = tuple(int(d) for d in dims)
        if len(self.dims) != 3 or min(self.dims) < 1:
            raise VolumeError(f"{self.name}: dims must be three integers >= 1 (nx, ny, nz), got {list(dims)}")
        self.offset = int(offset)
        self.nan_value = None if nan_value is None else float(nan_value)
        need = self.offset + int(np.prod(self.dims, dtype=object)) * dt.itemsize
        size = self.path.stat().st_size if self.path.is_file() else -1
        if size < need:
            raise VolumeError(f"{self.name}: the file holds {max(size, 0)} bytes, but {self.offset} bytes of header "
                              f"and {'x'.join(map(str, self.dims))} samples of {dt.name} need {need}; "
                              f"check dims, dtype and offset")
        self._fd = None
        self.roots = _roots()

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_fd"] = None  # a descriptor is this process's; the path reopens it
        return state

    def __del__(self):
        if getattr(self, "_fd", None) is not None:
            os.close(self._fd)

    def _file(self) -> int:
        if self._fd is None:
            from ..sandbox import check_input_path

            with self.confined():  # checked again where it is opened (a Dask worker, or a link swapped since)
                check_input_path(self.path, "volume file")
            self._fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_BINARY", 0))
        return self._fd

    def _read(self, lo, dims) -> np.ndarray:
        # Mapped, a window of at most MAP_WINDOW bytes at a time, unmapped right after its rows are copied.
        # /usr/bin/time -v counts a mapped file's touched pages (and the cached neighbours the kernel maps
        # with them, "fault-around") as resident until they are unmapped: so resident memory grows by at
        # most one window, whatever the box.  Measured on a page-cached 1 GiB uint8 file (1024^3), 40
        # random boxes each, on this project's 2-core machine: 32^3 boxes 0.08 ms mapped vs 1.3 ms with
        # explicit reads (os.preadv, one call per plane, the rows' gaps read into a scratch buffer); 64^3
        # 0.18 vs 5.3 ms; 128^3 0.56 vs 19 ms.  Mapping copies only the box (the kernel maps the pages in
        # between without copying them), explicit reads copy the gaps too and build a buffer per row.
        x0, y0, z0 = lo
        bx, by, bz = dims
        nx, ny, _ = self.dims
        item = self.stored.itemsize
        row, plane = nx * item, nx * ny * item
        out = np.empty((bz, by, bx), dtype=self.stored)
        span = by * row  # one plane's rows of the box, whole
        if span <= MAP_WINDOW:  # several planes per window
            planes, rows = 1 + (MAP_WINDOW - span) // plane, by
        else:  # a plane's rows over several windows
            planes, rows = 1, max(1, MAP_WINDOW // row)
        fd = self._file()
        for k in range(0, bz, planes):
            g = min(planes, bz - k)
            for j in range(0, by, rows):
                r = min(rows, by - j)
                start = self.offset + (z0 + k) * plane + (y0 + j) * row
                length = (g - 1) * plane + r * row
                aligned = start - start % mmap.ALLOCATIONGRANULARITY
                with mmap.mmap(fd, length + start - aligned, access=mmap.ACCESS_READ, offset=aligned) as window:
                    view = np.ndarray((g, r, nx), dtype=self.stored, buffer=window, offset=start - aligned,
                                      strides=(plane, row, item))
                    out[k:k + g, j:j + r] = view[:, :, x0:x0 + bx]
                    del view  # the map closes only when no array holds it
        return out

    def validity(self) -> dict:
        st = self.path.stat()
        return {"file": self.path.name, "size": st.st_size, "mtime_ns": st.st_mtime_ns, "dims": list(self.dims),
                "dtype": self.stored.str, "offset": self.offset}

    def sidecar_base(self) -> Path:
        return self.path

    def __repr__(self) -> str:
        return f"RawSource({str(self.path)!r}, dims={self.dims}, dtype={self.stored.str!r}, offset={self.offset})"


class ZarrSource(Source):
    """A zarr array (v2 or v3): only the chunks a box touches are read and decoded.

    Args:
        array: the zarr array.
        axes: OME-Zarr ``[(name, type), ...]`` naming each of its axes (z, y, x in any order; others of
            size 1 are dropped), as :func:`dvr_gl.io.zarr.open_zarr` gives them; None: the array is
            ``[..., z, y, x]`` with leading axes of size 1.
        transforms: OME-Zarr ``coordinateTransformations`` (dataset's then multiscale's), for
            :attr:`spacing` and :attr:`origin`.
        name: for messages; nan_value: as :class:`RawSource`'s.
        store: the store's folder, to reopen the array after pickling (default: the array's own store
            root when it is a local folder).
    """

    def __init__(self, array, axes=None, transforms=(), name: str | None = None, nan_value: float | None = None,
                 store: str | os.PathLike | None = None):
        from ..io.zarr import check_array, is_checked, zarr_plan

        self.name = name or str(getattr(array, "path", "") or "zarr array")
        check_array(array, self.name)
        self._array = array
        self.array_path = str(getattr(array, "path", "") or "")
        root = getattr(getattr(array, "store", None), "root", None)
        self.store = Path(store) if store is not None else (Path(root) if root is not None else None)
        self.index, self.order, self.spacing, self.origin = zarr_plan(array.shape, axes, list(transforms), self.name)
        # the entries a channel or time axis picks (dvr_gl.io.channels): each pick is its own field, with its own
        # block ranges and sidecar (axes of one entry, dropped, are not picks)
        self.picks = [[k, int(i)] for k, (i, n) in enumerate(zip(self.index, array.shape))
                      if not isinstance(i, slice) and n > 1]
        kept = [n for n, i in zip(array.shape, self.index) if isinstance(i, slice)]
        nz, ny, nx = (kept[o] for o in self.order)
        self.dims = (int(nx), int(ny), int(nz))
        if min(self.dims) < 1:  # refused here, as a whole load refuses it: the block ranges would step by 0
            raise VolumeError(f"{self.name}: zero-sized dimension in shape (z, y, x) = {(nz, ny, nx)}; a volume "
                              f"needs at least one sample along each axis: fix or rewrite the store")
        self.stored = np.dtype(array.dtype)
        if self.stored.kind not in "biuf":
            raise VolumeError(f"{self.name}: dtype {self.stored} is not a scalar type a volume can hold")
        self.chunks = tuple(int(c) for c in getattr(array, "chunks", array.shape))
        self.nan_value = None if nan_value is None else float(nan_value)
        if self.store is not None and not is_checked(getattr(array, "store", None)):
            self._array = None  # reopened through the checked store (every file against the sandbox)
        self.roots = _roots()

    @property
    def array(self):
        if self._array is None:
            import zarr

            from ..io.zarr import open_store, reading

            with self.confined(), reading(self.name, "the zarr array cannot be opened again ({}); was the store "
                                                     "changed?"):
                # the store's every file checked against the sandbox, as when it was opened first
                self._array = zarr.open_array(store=open_store(self.store), path=self.array_path or None, mode="r")
        return self._array

    def __getstate__(self):
        state = dict(self.__dict__)
        if self.store is not None:
            state["_array"] = None  # reopened from the store's folder
        return state

    def _read(self, lo, dims) -> np.ndarray:
        from ..io.zarr import CHUNK, reading

        box = [slice(lo[2 - j], lo[2 - j] + dims[2 - j]) for j in range(3)]  # z, y, x
        selection, spatial = [], 0
        inverse = {k: j for j, k in enumerate(self.order)}  # the j-th kept axis is spatial axis inverse[j]
        for i in self.index:
            if isinstance(i, slice):
                selection.append(box[inverse[spatial]])
                spatial += 1
            else:
                selection.append(i)
        array = self.array
        with self.confined(), reading(self.name, CHUNK):  # a corrupt chunk: one line, nothing else printed
            data = np.asarray(array[tuple(selection)])
        return np.transpose(data, self.order)

    def _metadata(self) -> Path | None:
        if self.store is None:
            return None
        folder = self.store / self.array_path if self.array_path else self.store
        return next((folder / m for m in ("zarr.json", ".zarray") if (folder / m).is_file()), None)

    def validity(self) -> dict | None:
        meta = self._metadata()
        if meta is None:
            return None
        st = meta.stat()
        # rewriting chunks in place changes neither: delete the sidecar then (docs/out-of-core.md)
        key = {"array": self.array_path, "metadata_size": st.st_size, "metadata_mtime_ns": st.st_mtime_ns,
               "folder_mtime_ns": meta.parent.stat().st_mtime_ns, "dims": list(self.dims),
               "dtype": self.stored.str, "chunks": list(self.chunks)}
        return {**key, "picks": self.picks} if getattr(self, "picks", None) else key

    def sidecar_base(self) -> Path | None:
        if self._metadata() is None:
            return None
        base = self.store if not self.array_path else \
            self.store.with_name(f"{self.store.name}.{self.array_path.replace('/', '_')}")
        picks = getattr(self, "picks", None)  # a channel's or step's own: axis-entry pairs
        return base.with_name(f"{base.name}.pick{'_'.join(f'{k}-{i}' for k, i in picks)}") if picks else base

    def __repr__(self) -> str:
        return f"ZarrSource({self.name!r}, dims={self.dims}, dtype={self.stored.str!r}, chunks={self.chunks})"


class ArraySource(Source):
    """An array in memory, ``data[z, y, x]`` (tests, the Python API); ranges are not cached on disk."""

    def __init__(self, data, name: str = "array", nan_value: float | None = None):
        data = np.asarray(data)
        if data.ndim != 3 or min(data.shape) < 1:
            raise VolumeError(f"{name}: expected a 3D array (z, y, x), got shape {data.shape}")
        self.data = data
        self.name = name
        nz, ny, nx = data.shape
        self.dims = (nx, ny, nz)
        self.stored = data.dtype
        self.nan_value = None if nan_value is None else float(nan_value)

    def _read(self, lo, dims) -> np.ndarray:
        (x0, y0, z0), (bx, by, bz) = lo, dims
        return np.array(self.data[z0:z0 + bz, y0:y0 + by, x0:x0 + bx])

    def __repr__(self) -> str:
        return f"ArraySource({self.name!r}, dims={self.dims}, dtype={self.stored.str!r})"


def _roots() -> tuple:
    """The roots of the sandbox in force, kept by a source (:meth:`Source.confined`)."""
    from ..sandbox import current

    return tuple(current().roots)


def fingerprint(key: dict) -> str:
    """A short stable digest of a validity key (for the cache folder's file names)."""
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]

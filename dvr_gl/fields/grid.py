"""The regular grid (data kind ``"grid"``): a node-centred grid of scalars, :class:`Volume`.

Conventions (``docs/conventions.md``):

* ``data[z, y, x]``, C order, x fastest, as raw files store it;
* ``spacing = (sx, sy, sz)`` and ``origin = (ox, oy, oz)`` in world units, x first;
* sample ``(i, j, k)`` sits at ``origin + (i*sx, j*sy, k*sz)``; the box is the
  hull of the samples, ``[origin, origin + (n - 1) * spacing]``;
* an axis with a single sample would give a box of zero thickness, so such an
  axis gets a slab one spacing thick centred on the sample (a project
  extension of the conventions: a single slice must be visible);
* scalar types are uint8, uint16, int16 and float32.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, VolumeError

SCALAR_TYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.int16), np.dtype(np.float32))


#: The narrowest value range of float data the GPU renderers classify right: their shaders map a value into the
#: transfer function by ``1 / range`` in float32 (at most 3.4e38), and their products of such values leave float32's
#: normal numbers (from 1.2e-38).  Measured on a Gaussian blob: spanning 9.7e-35 it renders as the unscaled blob
#: (ray caster and 3D slicing, within 1.5e-7), spanning 9.7e-36 off by 0.79 of opacity (subnormal values: black);
#: shear-warp and the references, in float64 on the host, either way.  Two decades of margin.
NARROWEST_FLOAT_RANGE = 1e-33


def _numbers(values, what: str, name: str) -> tuple:
    """``values`` as a tuple of floats, or one line naming the volume and what they are."""
    try:
        return tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise VolumeError(f"{name}: {what} must be three numbers (x, y, z), got {values!r}") from None


def check_float32_range(value_range: tuple[float, float], dtype, name: str) -> None:
    """Refuse float data whose values span less than :data:`NARROWEST_FLOAT_RANGE` (but differ), in one line."""
    lo, hi = value_range
    if np.dtype(dtype).kind == "f" and 0.0 < hi - lo < NARROWEST_FLOAT_RANGE:
        raise VolumeError(f"{name}: the values span only {hi - lo:.3g} (from {lo:.3g} to {hi:.3g}), too narrow for "
                          f"float32 arithmetic on the GPU (at least {NARROWEST_FLOAT_RANGE:g}); scale the data "
                          f"(multiply it by 1e30, say) before loading")


def to_scalar_type(data: np.ndarray, name: str = "volume") -> np.ndarray:
    """Convert ``data`` to one of the four scalar types, native byte order.

    Lossless where possible: int8 -> int16, bool -> uint8; wider integers and
    float64 become float32, which must hold the values (else an error).
    """
    dt = data.dtype
    if dt.kind == "b":
        return data.astype(np.uint8)
    native = dt.newbyteorder("=")
    if native in SCALAR_TYPES:
        return data.astype(native, copy=False)
    if dt.kind == "i" and dt.itemsize == 1:
        return data.astype(np.int16)
    if dt.kind in "iuf":
        if dt.kind == "f" and data.size:
            finite = data[np.isfinite(data)]
            if finite.size and np.abs(finite).max() > np.finfo(np.float32).max:
                raise VolumeError(f"{name}: values exceed the float32 range; rescale the data before loading")
        return data.astype(np.float32)
    raise VolumeError(f"{name}: unsupported scalar type {dt}; use uint8, uint16, int16 or float32 data")


@dataclass(frozen=True, eq=False, repr=False)
class Volume:
    """A regular grid of scalar samples in world space; a :class:`~dvr_gl.fields.Field` of kind ``"grid"``.

    Attributes:
        data: ``(nz, ny, nx)`` array of uint8, uint16, int16 or float32, read-only.
        spacing: distance between samples along x, y, z (world units, > 0).
        origin: world position of sample ``(0, 0, 0)``.
        name: a label for messages (file name or demo name).
        direction: ``3x3`` orthonormal matrix whose columns are the directions of the x, y and z index
            axes in the patient (LPS) frame, as the file's header states it (NRRD ``space directions``,
            NIfTI's sform/qform, DICOM's ImageOrientationPatient, MetaImage's ``TransformMatrix``);
            identity when the file states none.  The voxels are never reordered: the renderers work in
            the volume's own frame (sample ``(i, j, k)`` at ``origin + (i*sx, j*sy, k*sz)``) and the
            camera, given in the patient frame, is turned into it (:mod:`dvr_gl.orientation`).
    """

    data: np.ndarray
    spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = "volume"
    direction: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    value_range: tuple[float, float] = field(init=False)

    kind = "grid"
    #: The voxels are in memory (``data``); a volume read out of core (:mod:`dvr_gl.out_of_core`) says True.
    out_of_core = False

    def __post_init__(self):
        from ..io.labelled import is_data_array

        if is_data_array(self.data):  # xarray: its dims name the axes, its coordinates give the geometry
            from ..io.labelled import unpack

            defaults = {"spacing": (1.0, 1.0, 1.0), "origin": (0.0, 0.0, 0.0), "name": "volume"}
            for key, value in unpack(self.data, self.spacing, self.origin, self.name, defaults).items():
                object.__setattr__(self, key, value)
        data = np.asarray(self.data)
        if data.ndim != 3:
            raise VolumeError(f"{self.name}: expected a 3D array (z, y, x), got shape {data.shape}")
        if min(data.shape) < 1:
            raise VolumeError(f"{self.name}: zero-sized dimension in shape (z, y, x) = {data.shape}")
        data = np.ascontiguousarray(to_scalar_type(data, self.name))
        if data.dtype.kind == "f" and not np.isfinite(data).all():
            bad = int(np.count_nonzero(~np.isfinite(data)))
            raise VolumeError(f"{self.name}: {bad} NaN or Inf values; choose a replacement value "
                              f"(scene key volume.nan_value, or --nan-value)")
        data.setflags(write=False)
        spacing = _numbers(self.spacing, "spacing", self.name)
        origin = _numbers(self.origin, "origin", self.name)
        if len(spacing) != 3 or not all(np.isfinite(spacing)) or min(spacing) <= 0:
            raise VolumeError(f"{self.name}: spacing must be three positive numbers, got {self.spacing}")
        if len(origin) != 3 or not all(np.isfinite(origin)):
            raise VolumeError(f"{self.name}: origin must be three finite numbers, got {self.origin}")
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "direction", check_direction(self.direction, self.name))
        object.__setattr__(self, "spacing", spacing)
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "value_range", (float(data.min()), float(data.max())))
        check_float32_range(self.value_range, data.dtype, self.name)

    @classmethod
    def from_xarray(cls, data_array, **kwargs) -> "Volume":
        """A volume from an xarray ``DataArray`` (dims ``z``, ``y``, ``x`` in any order; coordinates as
        spacing and origin): :mod:`dvr_gl.io.labelled`.  ``Volume(data_array)`` does the same."""
        return cls(data_array, **kwargs)

    @property
    def dtype(self) -> np.dtype:
        """The scalar type of the samples."""
        return self.data.dtype

    @property
    def nbytes(self) -> int:
        """The samples' size in bytes."""
        return self.data.nbytes

    @property
    def levels(self) -> tuple:
        """Coarser levels of a multi-resolution pyramid, fine to coarse (:mod:`dvr_gl.multires`); none
        unless given (:meth:`with_levels`)."""
        return self.__dict__.get("_levels", ())

    def with_levels(self, levels) -> "Volume":
        """This volume with ``levels`` (coarser grids of the same box, fine to coarse) attached."""
        out = Volume.__new__(Volume)
        out.__dict__.update(self.__dict__)
        out.__dict__["_levels"] = tuple(levels)
        return out

    def read(self, lo, dims) -> np.ndarray:
        """The samples of the voxel box ``lo .. lo + dims - 1`` (x, y, z order) as a ``[z, y, x]``
        C-contiguous array the caller owns: what a brick's texture holds (the same call reads a volume
        out of core)."""
        (x0, y0, z0), (nx, ny, nz) = lo, dims
        return np.array(self.data[z0:z0 + nz, y0:y0 + ny, x0:x0 + nx], order="C")

    @property
    def dims(self) -> tuple[int, int, int]:
        """Number of samples along x, y, z."""
        nz, ny, nx = self.data.shape
        return (nx, ny, nz)

    @property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """The world-space box ``(lo, hi)``: the hull of the samples (see module doc)."""
        n = np.array(self.dims, dtype=np.float64)
        s = np.array(self.spacing)
        o = np.array(self.origin)
        lo = o.copy()
        hi = o + (n - 1) * s
        single = n == 1
        lo[single] -= 0.5 * s[single]
        hi[single] += 0.5 * s[single]
        return lo, hi

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The field's bounding box (:class:`~dvr_gl.fields.Field`): :attr:`box`."""
        return self.box

    @property
    def sample_spacing(self) -> float:
        """One voxel: the smallest spacing (world units), the unit of distances in voxels."""
        return min(self.spacing)

    @property
    def samples(self) -> np.ndarray:
        """The sample values, ``data``."""
        return self.data

    def reconstruct(self, filter: str = "linear", kernel_width: float | None = None,
                    kernel_radius: float | None = None):
        """The continuous field under a reconstruction filter (:mod:`.reconstruction`); ``kernel_width``:
        the Gaussian's standard deviation in voxels, ``kernel_radius`` where it is cut (standard deviations)."""
        from .reconstruction import SampledField

        _check_grid_filter(filter)
        return SampledField(self.data, self.spacing, self.origin, filter, kernel_width, kernel_radius)

    def reconstruct_values(self, values: np.ndarray, filter: str = "linear", kernel_width: float | None = None,
                           kernel_radius: float | None = None):
        """Other values at this grid's samples (``(nz, ny, nx[, C])``), reconstructed alike."""
        from .reconstruction import SampledField

        _check_grid_filter(filter)
        return SampledField(values, self.spacing, self.origin, filter, kernel_width, kernel_radius)

    def world_to_index(self, points: np.ndarray) -> np.ndarray:
        """Continuous voxel coordinates ``(i, j, k)`` (x, y, z order) of world points ``(..., 3)``."""
        return (np.asarray(points, dtype=np.float64) - np.array(self.origin)) / np.array(self.spacing)

    def world_to_texture(self, points: np.ndarray) -> np.ndarray:
        """Texture coordinates in [0, 1]^3: sample ``i`` of ``n`` maps to ``(i + 0.5) / n``."""
        return (self.world_to_index(points) + 0.5) / np.array(self.dims, dtype=np.float64)

    def voxels_to_world(self, distance_in_voxels: float) -> float:
        """A distance in voxels (of the smallest spacing) in world units."""
        return float(distance_in_voxels) * self.sample_spacing

    def describe(self) -> str:
        nx, ny, nz = self.dims
        lo, hi = self.value_range
        turned = "" if self.direction == IDENTITY else f", direction {[list(r) for r in self.direction]}"
        return (f"{self.name}: {nx}x{ny}x{nz} {self.data.dtype}, spacing {self.spacing}, "
                f"origin {self.origin}{turned}, values {lo:g}..{hi:g}")

    def __repr__(self) -> str:
        nx, ny, nz = self.dims
        lo, hi = self.value_range
        return (f"Volume({self.name!r}, {nx}x{ny}x{nz} {self.data.dtype}, spacing={_short(self.spacing)}, "
                f"origin={_short(self.origin)}, values {lo:g}..{hi:g})")


def _short(v) -> str:
    return "(" + ", ".join(f"{x:g}" for x in v) + ")"


IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def check_direction(direction, name: str = "volume") -> tuple:
    """A direction matrix as a tuple of three rows, checked: finite, ``3x3``, columns of unit length and
    mutually orthogonal (within 1e-4, what headers written in float32 reach); the columns are
    re-orthonormalized so that the renderers' frame change is exact."""
    if direction is None:
        return IDENTITY
    try:
        m = np.asarray(direction, dtype=np.float64)
    except (TypeError, ValueError):
        raise VolumeError(f"{name}: direction must be a 3x3 matrix of numbers, got {direction!r}") from None
    if m.shape != (3, 3) or not np.isfinite(m).all():
        raise VolumeError(f"{name}: direction must be a finite 3x3 matrix, got shape {m.shape}")
    if np.abs(m.T @ m - np.eye(3)).max() > 1e-4:
        raise VolumeError(f"{name}: the direction matrix's columns (the index axes in the patient frame) must be "
                          f"orthonormal; shear or scaling belongs in the spacing; fix the header")
    u, _, vt = np.linalg.svd(m)  # the nearest orthogonal matrix
    m = u @ vt
    m[np.abs(m) < 1e-12] = 0.0
    return tuple(tuple(float(x) for x in row) for row in m)


def replace_non_finite(data: np.ndarray, value: float) -> np.ndarray:
    """Replace NaN and +-Inf by ``value`` (the user's explicit choice)."""
    if data.dtype.kind != "f":
        return data
    out = np.array(data, copy=True)
    out[~np.isfinite(out)] = value
    return out


def _check_grid_filter(filter: str):
    if filter == "m4":
        raise SceneError("renderer.filter = m4 is the SPH kernel of particle sets; a regular grid takes nearest, "
                         "linear, cubic_bspline, catmull_rom or gaussian")

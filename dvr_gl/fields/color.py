"""Colour volumes (a field of role ``"rgb"``): a cryosection, rendered colour data; :class:`ColorVolume`.

A colour volume is a regular grid (the conventions of :mod:`dvr_gl.fields.grid`: ``data[z, y, x]``, node-centred
samples, spacing and origin x first, a direction matrix) whose voxels hold four float32 components
``(r, g, b, x)``:

* ``r, g, b``: *linear* colour in [0, 1].  Integer files store colour sRGB-encoded, as every image does: an
  8- or 16-bit code ``k`` of ``n`` bits is decoded with the exact sRGB transfer function (IEC 61966-2-1)
  of ``v = k / (2^n - 1)``: ``v / 12.92`` for ``v <= 0.04045``, else ``((v + 0.055) / 1.055)^2.4`` (not a
  gamma of 2.2).  Float data is taken as linear (:meth:`ColorVolume.from_linear`) unless said otherwise
  (:meth:`ColorVolume.from_srgb` takes sRGB-encoded floats in [0, 1] too).
* ``x``: what the member's opacity is a function of (:attr:`ColorVolume.opacity_source`): the *luminance*
  ``Y = 0.2126 r + 0.7152 g + 0.0722 b`` of the linear colour (Rec. 709 / sRGB primaries), or the file's
  *alpha* (straight, not premultiplied; stored linearly, never sRGB-encoded: ``k / (2^n - 1)``).

All four components are reconstructed alike, by the scene's filter (:meth:`ColorVolume.reconstruct`: ``(N, 4)``
float64 samples).  Luminance is linear in the colour, so the filtered ``x`` is the luminance of the filtered
colour.  A sample's classification (docs/several-fields.md): colour ``(r, g, b)`` from the data, extinction
``sigma`` from the member's transfer function of ``x`` (:func:`rgb_transfer_function`; its colour columns are
not used); gradient opacity and shading use the gradient of ``x``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SceneError, VolumeError
from ..presets.colour import srgb_to_linear
from .grid import IDENTITY, Volume, _check_grid_filter, _short
from .reconstruction import SampledField

#: Rec. 709 (sRGB) luminance weights of linear r, g, b: the Y row of the RGB -> XYZ matrix.
LUMINANCE_WEIGHTS = (0.2126, 0.7152, 0.0722)
#: What the fourth component ``x`` is: the colour's luminance, or the file's alpha.
OPACITY_SOURCES = ("luminance", "alpha")
#: The default transfer function of luminance: opacity 0 at the smallest luminance to this at the largest,
#: per ``unit_distance`` (the ``grayscale`` preset's and a channel's default maximum).
DEFAULT_OPACITY = 0.1
#: The colour columns of a colour volume's transfer functions: not used (the colour is the data's).
UNUSED_COLOUR = (1.0, 1.0, 1.0)
CODE_BITS = {np.dtype(np.uint8): 8, np.dtype(np.uint16): 16}
SLAB_VOXELS = 1 << 20  # voxels decoded at a time (their float64 copy: 32 MiB)


def srgb_decode(codes: np.ndarray) -> np.ndarray:
    """Linear float64 values of sRGB-encoded ``codes``: uint8 or uint16 codes through an exact table of every
    code (``k / (2^n - 1)`` decoded), floats in [0, 1] decoded as they are."""
    codes = np.asarray(codes)
    bits = CODE_BITS.get(codes.dtype.newbyteorder("="))
    if bits is None:
        return srgb_to_linear(codes)
    table = srgb_to_linear(np.arange(2 ** bits, dtype=np.float64) / (2 ** bits - 1))
    return np.take(table, codes)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """``Y = 0.2126 r + 0.7152 g + 0.0722 b`` of linear colour ``(..., 3)`` (float64)."""
    rgb = np.asarray(rgb, dtype=np.float64)
    wr, wg, wb = LUMINANCE_WEIGHTS
    return wr * rgb[..., 0] + wg * rgb[..., 1] + wb * rgb[..., 2]


@dataclass(frozen=True, eq=False, repr=False)
class ColorVolume:
    """A regular grid of linear colour ``(nz, ny, nx, 4)`` float32: ``r, g, b`` and ``x`` (see the module doc).

    Attributes:
        data: the components, read-only, each in [0, 1].
        spacing, origin, name, direction: as :class:`~dvr_gl.fields.grid.Volume`'s.
        opacity_source: ``"luminance"`` (``x`` is the colour's luminance) or ``"alpha"`` (the file's).
        encoding: how the colour was stored (``"sRGB 8-bit"``, ``"sRGB 16-bit"``, ``"sRGB float"`` or
            ``"linear"``), for messages.
    Use the constructors (:meth:`from_srgb`, :meth:`from_linear`, :meth:`from_stored`); the class itself takes
    the four components as they are.  It is a member of a scene in the role ``"rgb"``
    (:class:`~dvr_gl.fields.layers.Member`).
    """

    data: np.ndarray
    spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = "rgb"
    direction: tuple = IDENTITY
    opacity_source: str = "luminance"
    encoding: str = "linear"
    value_range: tuple[float, float] = field(init=False)

    kind = "grid"
    role = "rgb"  # the role it plays in a scene: its data is colour (a scalar role would misread it)
    out_of_core = False
    levels = ()  # no coarser levels (a multi-resolution pyramid is built of scalar grids)

    def __post_init__(self):
        data = np.asarray(self.data)
        if data.ndim != 4 or data.shape[3] != 4:
            raise VolumeError(f"{self.name}: a colour volume holds (z, y, x, 4) components r, g, b, x; got shape "
                              f"{data.shape} (use ColorVolume.from_srgb or from_linear for (z, y, x, 3|4) colour)")
        if self.opacity_source not in OPACITY_SOURCES:
            raise VolumeError(f"{self.name}: opacity_source must be one of {', '.join(OPACITY_SOURCES)}, got "
                              f"{self.opacity_source!r}")
        # The grid's checks, once: a one-voxel Volume checks and normalizes the geometry as every grid's.
        grid = Volume(np.zeros((1, 1, 1), np.uint8), self.spacing, self.origin, self.name, self.direction)
        data = np.ascontiguousarray(_unit_range(data, self.name, "components"), dtype=np.float32)
        data.setflags(write=False)
        object.__setattr__(self, "data", data)
        for key in ("spacing", "origin", "direction"):
            object.__setattr__(self, key, getattr(grid, key))
        if data.shape[0] * data.shape[1] * data.shape[2] == 0:
            raise VolumeError(f"{self.name}: zero-sized dimension in shape (z, y, x) = {data.shape[:3]}")
        x = data[..., 3]
        object.__setattr__(self, "value_range", (float(x.min()), float(x.max())))

    # --- constructors ---------------------------------------------------------------------------------------

    @classmethod
    def from_srgb(cls, array, *, alpha=None, **geometry) -> "ColorVolume":
        """A colour volume from sRGB-encoded colour ``(z, y, x, 3|4)``: uint8 (0..255), uint16 (0..65535), or
        floats in [0, 1]; decoded exactly (module doc).  ``alpha``: None (the array's fourth component when it
        has one, else the luminance), False (the luminance, a fourth component ignored), or an array
        ``(z, y, x)`` of straight alpha in the colour's scale.  ``geometry``: ``spacing``, ``origin``, ``name``,
        ``direction`` as a :class:`~dvr_gl.fields.grid.Volume`'s."""
        array, name = _components(array, geometry.get("name", "rgb"))
        if array.dtype.kind == "f":
            _unit_range(array, name, "sRGB-encoded colour")
        elif array.dtype.newbyteorder("=") not in CODE_BITS:
            raise VolumeError(f"{name}: sRGB colour must be uint8, uint16 or floats in [0, 1]; got {array.dtype}: "
                              f"convert it (e.g. array.astype(numpy.uint8)) or give linear floats (from_linear)")
        bits = CODE_BITS.get(array.dtype.newbyteorder("="))
        encoding = f"sRGB {bits}-bit" if bits else "sRGB float"
        return cls._assemble(array, srgb_decode, _alpha(array, alpha, name, bits), encoding, geometry)

    @classmethod
    def from_linear(cls, array, *, alpha=None, **geometry) -> "ColorVolume":
        """A colour volume from linear colour ``(z, y, x, 3|4)`` in [0, 1] (floats; a fourth component is
        alpha); ``alpha`` and ``geometry`` as :meth:`from_srgb`'s."""
        array, name = _components(array, geometry.get("name", "rgb"))
        if array.dtype.kind != "f":
            raise VolumeError(f"{name}: linear colour must be floats in [0, 1]; got {array.dtype} (integer colour "
                              f"is sRGB-encoded: use ColorVolume.from_srgb)")
        _unit_range(array[..., :3], name, "linear colour")
        linear = lambda slab: slab.astype(np.float64)  # noqa: E731
        return cls._assemble(array, linear, _alpha(array, alpha, name, None), "linear", geometry)

    @classmethod
    def from_stored(cls, array, *, alpha=None, **geometry) -> "ColorVolume":
        """A colour volume from a file's components ``(z, y, x, 3|4)``: integer codes are sRGB-encoded, floats
        linear (what image files and renderers write); the readers' constructor."""
        array = np.asarray(array)
        make = cls.from_linear if array.dtype.kind == "f" else cls.from_srgb
        return make(array, alpha=alpha, **geometry)

    @classmethod
    def _assemble(cls, array: np.ndarray, decode, alpha, encoding: str, geometry: dict) -> "ColorVolume":
        """The components from colour ``array`` ``(z, y, x, 3|4)``: ``decode`` turns its ``(..., 3)`` into linear
        float64, ``alpha`` is ``(alpha, its largest value)`` or None (the luminance); a slab of z at a time, so
        that no float64 copy of the whole volume is ever made."""
        data = np.empty(array.shape[:3] + (4,), np.float32)
        step = max(1, SLAB_VOXELS // max(1, array.shape[1] * array.shape[2]))
        for z in range(0, array.shape[0], step):
            rgb = decode(array[z:z + step, ..., :3])
            data[z:z + step, ..., :3] = rgb
            data[z:z + step, ..., 3] = luminance(rgb) if alpha is None else alpha[0][z:z + step] / alpha[1]
        source = "luminance" if alpha is None else "alpha"
        return cls(data, opacity_source=source, encoding=encoding, **geometry)

    # --- the grid ---------------------------------------------------------------------------------------------

    box = Volume.box
    bounds = Volume.bounds
    sample_spacing = Volume.sample_spacing
    world_to_index = Volume.world_to_index
    world_to_texture = Volume.world_to_texture
    voxels_to_world = Volume.voxels_to_world
    reconstruct_values = Volume.reconstruct_values
    read = Volume.read  # the voxel box as a [z, y, x, 4] array: the slice keeps the components' axis

    @property
    def dims(self) -> tuple[int, int, int]:
        """Number of samples along x, y, z."""
        nz, ny, nx = self.data.shape[:3]
        return (nx, ny, nz)

    @property
    def dtype(self) -> np.dtype:
        """The components' type: float32."""
        return self.data.dtype

    @property
    def nbytes(self) -> int:
        return self.data.nbytes

    @property
    def colour(self) -> np.ndarray:
        """The linear colour ``(nz, ny, nx, 3)`` (a read-only view)."""
        return self.data[..., :3]

    @property
    def samples(self) -> np.ndarray:
        """``x`` ``(nz, ny, nx)``: the value the transfer function reads (histograms, suggested opacities)."""
        return self.data[..., 3]

    def reconstruct(self, filter: str = "linear", kernel_width: float | None = None,
                    kernel_radius: float | None = None) -> "ColorReconstruction":
        """The four components under a reconstruction filter, filtered alike: ``sample`` gives ``(N, 4)``,
        ``gradient`` the gradient of ``x`` (:class:`ColorReconstruction`)."""
        _check_grid_filter(filter)
        return ColorReconstruction(self.data, self.spacing, self.origin, filter, kernel_width, kernel_radius)

    def describe(self) -> str:
        nx, ny, nz = self.dims
        lo, hi = self.value_range
        turned = "" if self.direction == IDENTITY else f", direction {[list(r) for r in self.direction]}"
        return (f"{self.name}: {nx}x{ny}x{nz} colour ({self.encoding}, linear float32 rgb), spacing {self.spacing}, "
                f"origin {self.origin}{turned}, {self.opacity_source} {lo:g}..{hi:g}")

    def __repr__(self) -> str:
        nx, ny, nz = self.dims
        lo, hi = self.value_range
        return (f"ColorVolume({self.name!r}, {nx}x{ny}x{nz} {self.encoding}, spacing={_short(self.spacing)}, "
                f"origin={_short(self.origin)}, {self.opacity_source} {lo:g}..{hi:g})")


class ColorReconstruction(SampledField):
    """The four components ``(r, g, b, x)`` reconstructed alike (``sample``: ``(N, 4)`` float64); ``gradient``:
    that of ``x`` alone (value units per world unit), what shading and gradient opacity read."""

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """Central differences of ``x`` one voxel apart along each world axis, ``(N, 3)``, as a scalar
        grid's (:meth:`SampledField.gradient`)."""
        p = np.asarray(points, dtype=np.float64)
        g = np.empty((len(p), 3))
        for axis in range(3):
            h = np.zeros(3)
            h[axis] = self.spacing[axis]
            g[:, axis] = (self.sample(p + h)[:, 3] - self.sample(p - h)[:, 3]) / (2.0 * self.spacing[axis])
        return g


def _components(array, name: str) -> tuple[np.ndarray, str]:
    """``array`` as ``(z, y, x, 3|4)`` components, native byte order, or one line saying what it is."""
    array = np.asarray(array)
    if array.ndim != 4 or array.shape[3] not in (3, 4):
        raise VolumeError(f"{name}: colour must be an array (z, y, x, 3) of r, g, b or (z, y, x, 4) with alpha; "
                          f"got shape {array.shape}")
    if array.dtype.kind not in "uif":
        raise VolumeError(f"{name}: colour must be numbers (uint8, uint16 or floats); got {array.dtype}")
    return array.astype(array.dtype.newbyteorder("="), copy=False), name


def _alpha(array: np.ndarray, alpha, name: str, bits: int | None) -> tuple[np.ndarray, float] | None:
    """The straight alpha the constructors were given and the value that stands for 1 (its largest code:
    alpha is stored linearly; 1 for floats), checked; None for the luminance."""
    if alpha is False or (alpha is None and array.shape[3] == 3):
        return None
    if alpha is None:
        alpha = array[..., 3]
    elif alpha is True:
        raise VolumeError(f"{name}: alpha = True: the colour has no fourth component; give alpha as an array "
                          f"(z, y, x) or None")
    else:
        alpha = np.asarray(alpha)
        if alpha.shape != array.shape[:3]:
            raise VolumeError(f"{name}: alpha must have the colour's shape (z, y, x) = {array.shape[:3]}; got "
                              f"{alpha.shape}")
    top = 1.0 if bits is None else float(2 ** bits - 1)
    return _unit_range(alpha, name, "alpha", top), top


def _unit_range(values: np.ndarray, name: str, what: str, top: float = 1.0) -> np.ndarray:
    """``values`` if every one is finite and in [0, ``top``] (``top`` stands for 1); else one line saying how
    many are not."""
    with np.errstate(invalid="ignore"):
        bad = ~((values >= 0) & (values <= top))
    if bad.any():
        count = int(np.count_nonzero(bad))
        nonfinite = not np.isfinite(values[bad]).all()
        raise VolumeError(f"{name}: {count} {what} value{'s' * (count != 1)} "
                          f"{'NaN, Inf or ' if nonfinite else ''}outside [0, 1]; scale the colour into [0, 1]"
                          f"{' and replace NaN (volume.nan_value)' if nonfinite else ''}")
    return values


def rgb_transfer_function(spec, field: ColorVolume, base_dir: Path | str = "."):
    """The transfer function of a colour volume's member: its opacity (alpha per ``unit_distance``, or
    extinction) as a function of ``x`` (luminance or alpha, in [0, 1]).  Its colour columns are not used: a
    sample's colour is the data's.

    ``spec`` (a :class:`~dvr_gl.scene.schema.TransferFunctionSpec`): its ``points`` (over ``x``), its
    ``preset`` (stretched over ``x``'s range) or ``file`` (relative to ``base_dir``) where given; else the
    default: with the file's alpha the identity, opacity = alpha per ``unit_distance`` (points
    ``[[0, 1, 1, 1, 0], [1, 1, 1, 1, 1]]``); with luminance a ramp from opacity 0 at the smallest luminance
    to :data:`DEFAULT_OPACITY` at the largest."""
    from ..transfer_function import TransferFunction, from_property, preset, read_transfer_function_file

    if getattr(field, "role", None) != "rgb":
        raise SceneError(f"{getattr(field, 'name', 'field')}: role rgb needs a colour volume (ColorVolume: "
                         f"(z, y, x, 3|4) colour); this field holds scalars: give it role scalar")
    unit = spec.unit_distance
    if spec.points is not None:
        return TransferFunction(spec.points, unit, spec.opacity_model)
    if spec.preset is not None or spec.file is not None:
        if spec.opacity_model != "alpha":
            raise SceneError("transfer_function: presets and files are written in alpha; use opacity_model = 'alpha'")
        if spec.preset is not None:
            return preset(spec.preset, field.value_range, spec.rescale_intercept, unit)
        path = Path(spec.file).expanduser()
        prop = read_transfer_function_file(path if path.is_absolute() else Path(base_dir) / path, spec.name,
                                           spec.stretch)
        return from_property(prop, field.value_range, spec.rescale_intercept, unit)
    if spec.opacity_model != "alpha":
        raise SceneError("transfer_function.opacity_model = extinction needs points (the default opacity of a "
                         "colour volume is written in alpha): give transfer_function.points over x")
    if field.opacity_source == "alpha":
        lo, hi, top = 0.0, 1.0, 1.0
    else:
        lo, hi = field.value_range
        hi, top = (hi if hi > lo else lo + 1.0), DEFAULT_OPACITY
    return TransferFunction(np.array([[lo, *UNUSED_COLOUR, 0.0], [hi, *UNUSED_COLOUR, top]]), unit_distance=unit)

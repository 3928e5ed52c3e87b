"""SPH particle sets: CSV and NumPy ``.npz`` tables, and HDF5 snapshots in the GADGET/SWIFT layout
(h5py, the ``particles`` extra).  Each returns a :class:`~dvr_gl.fields.particles.ParticleSet`.

Tables (``.csv`` with a header row; ``.npz`` with one array per column) name their columns, in
any case: the positions ``x``, ``y``, ``z`` (or one ``(N, 3)`` array ``positions`` in a ``.npz``), the
smoothing length ``h`` (also ``smoothing_length``, ``hsml``; support ``2h``, Monaghan's convention),
the mass ``m`` (``mass``), the density ``rho`` (``density``; without it the density is the SPH
sum at each particle) and any other column; ``volume.array`` names the quantity to render (default:
the density).

Snapshots: the gas particles (``PartType0``): ``Coordinates``, ``Masses`` (or the header's
``MassTable``), and the smoothing length and density as GADGET (``SmoothingLength``, the kernel's
support, so ``h`` is half of it; ``Density``) or SWIFT (``SmoothingLengths``, Dehnen and Aly's
``h``, support ``1.825742 h`` for the cubic spline; ``Densities``) writes them; ``volume.array``
names another dataset of ``PartType0`` (``InternalEnergy``, ``Temperatures``, ...).  A SWIFT
snapshot made with another kernel is refused: the field here is the cubic spline's.  Values are
taken in the file's units, unconverted.
"""

from __future__ import annotations

import csv
import zipfile
from pathlib import Path

import numpy as np

from ..errors import DvrError, VolumeError
from ..fields import sph
from ..fields.particles import ParticleSet
from ..sandbox import check_bytes, check_input_path
from .common import require

ALIASES = {"h": ("h", "smoothing_length", "smoothing_lengths", "hsml"), "m": ("m", "mass", "masses"),
           "rho": ("rho", "density", "densities")}


def read_particles(path: Path, fmt: str, array: str | None = None) -> ParticleSet:
    path = check_input_path(Path(path), "particle file")
    check_bytes(path.stat().st_size * 6.0, f"{path.name}: reading the particles", "use fewer particles")
    reader = {"csv": _read_csv, "npz": _read_npz, "hdf5": _read_hdf5}[fmt]
    return reader(path, array)


def _table(path: Path, columns: dict[str, np.ndarray], array: str | None) -> ParticleSet:
    """A particle set from named columns (lower-cased names)."""
    def find(key):
        for name in ALIASES[key]:
            if name in columns:
                return name
        return None

    if "positions" in columns:
        positions = np.asarray(columns["positions"], dtype=np.float64)
    elif all(c in columns for c in "xyz"):
        positions = np.stack([columns[c] for c in "xyz"], axis=1)
    else:
        raise VolumeError(f"{path}: no particle positions; name the columns x, y, z (or an (N, 3) array "
                          f"positions); found {', '.join(sorted(columns)) or 'none'}")
    h, m, rho = find("h"), find("m"), find("rho")
    for key, name in (("h", h), ("m", m)):
        if name is None:
            raise VolumeError(f"{path}: no {' or '.join(ALIASES[key])} column; SPH particles need a smoothing "
                              "length and a mass each")
    values, label = None, "density"
    if array is not None:
        if array.lower() not in columns:
            raise VolumeError(f"{path}: no column {array!r} (volume.array); it has {', '.join(sorted(columns))}")
        label = array
        if array.lower() != rho:
            values = columns[array.lower()]
    return _particles(path, positions, columns[h], columns[m], None if rho is None else columns[rho], values,
                      label)


def _particles(path: Path, positions, h, m, rho, values, label: str) -> ParticleSet:
    for name, column in (("smoothing length", h), ("mass", m)):
        if np.ndim(column) not in (0, 1):
            raise VolumeError(f"{path}: the {name} must be one number per particle")
    if rho is None:  # the SPH density at each particle: sum_j m_j W(x_i - x_j, h_j)
        probe = ParticleSet(positions, h, m, 1.0, name=path.name)
        rho = probe.reconstruct().sample(probe.positions)
    return ParticleSet(positions, h, m, rho, values, name=path.name, array=label, source=str(path))


def _read_csv(path: Path, array: str | None) -> ParticleSet:
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = csv.reader(f)
            header = next(rows, None)
            if not header:
                raise VolumeError(f"{path}: empty; a particle table starts with a header row (x,y,z,h,m,...)")
            names = [c.strip().lower() for c in header]
            if len(set(names)) != len(names):
                raise VolumeError(f"{path}: repeated column names in the header {header}")
            data = []
            for line, row in enumerate(rows, start=2):
                if not row or all(not c.strip() for c in row):
                    continue
                if len(row) != len(names):
                    raise VolumeError(f"{path}: line {line} has {len(row)} fields, the header {len(names)}")
                try:
                    data.append([float(c) for c in row])
                except ValueError:
                    raise VolumeError(f"{path}: line {line} holds a value that is not a number: {row}") from None
    except UnicodeDecodeError:
        raise VolumeError(f"{path}: not a text CSV file (not UTF-8); a particle table is CSV with a header "
                          "row") from None
    except csv.Error as exc:
        raise VolumeError(f"{path}: not a readable CSV file ({exc})") from None
    if not data:
        raise VolumeError(f"{path}: a header and no particles")
    table = np.asarray(data, dtype=np.float64)
    return _table(path, {n: table[:, i] for i, n in enumerate(names)}, array)


def _read_npz(path: Path, array: str | None) -> ParticleSet:
    try:
        with zipfile.ZipFile(path) as archive:  # the members' sizes, before numpy inflates any
            check_bytes(sum(i.file_size for i in archive.infolist()) * 2.0, f"{path.name}: its arrays",
                        "use fewer particles")
        with np.load(path, allow_pickle=False) as z:
            columns = {k.lower(): np.asarray(z[k]) for k in z.files}
    except DvrError:
        raise
    except Exception as exc:  # zipfile, zlib and numpy's own errors on a damaged archive or member
        raise VolumeError(f"{path}: not a readable .npz of numeric arrays ({_reason(exc)})") from None
    for name, column in columns.items():
        if column.dtype.kind not in "iuf":
            raise VolumeError(f"{path}: array {name!r} holds {column.dtype}, not numbers")
    return _table(path, columns, array)


def _read_hdf5(path: Path, array: str | None) -> ParticleSet:
    h5py = require("h5py", "h5py", "particles")
    try:
        with h5py.File(path, "r") as f:
            return _snapshot(path, f, array)
    except DvrError:
        raise
    except Exception as exc:  # HDF5's errors on a damaged file: OSError, RuntimeError, KeyError, ...
        raise VolumeError(f"{path}: not a readable HDF5 snapshot ({_reason(exc)})") from None


def _reason(exc: Exception) -> str:
    return " ".join(str(exc).split())[:120] or type(exc).__name__


def _snapshot(path: Path, f, array: str | None) -> ParticleSet:
    if "PartType0" not in f:
        raise VolumeError(f"{path}: no PartType0 group; dvr-gl reads the gas particles of GADGET/SWIFT "
                          f"snapshots (groups here: {', '.join(f.keys()) or 'none'})")
    gas = f["PartType0"]

    def dataset(name):
        item = gas[name]
        if not hasattr(item, "dtype") or item.dtype.kind not in "iuf":
            raise VolumeError(f"{path}: PartType0/{name} is not a numeric dataset")
        check_bytes(float(np.prod(item.shape, dtype=np.float64)) * 8.0, f"{path.name}: PartType0/{name}",
                    "use fewer particles")
        return np.asarray(item[()], dtype=np.float64)

    if "Coordinates" not in gas:
        raise VolumeError(f"{path}: no PartType0/Coordinates")
    positions = dataset("Coordinates")
    if "SmoothingLengths" in gas:  # SWIFT: Dehnen and Aly's h
        kernel = _swift_kernel(f)
        if kernel is not None and "cubic" not in kernel.lower():
            raise VolumeError(f"{path}: made with the {kernel} kernel; dvr-gl interpolates SPH particles with "
                              "the cubic spline (M4) only")
        h = dataset("SmoothingLengths") * sph.SWIFT_CUBIC_GAMMA / sph.SUPPORT
    elif "SmoothingLength" in gas:  # GADGET: the support radius
        h = dataset("SmoothingLength") / sph.SUPPORT
    else:
        raise VolumeError(f"{path}: no PartType0/SmoothingLength (GADGET) or SmoothingLengths (SWIFT)")
    if "Masses" in gas:
        m = dataset("Masses")
    else:
        table = f["Header"].attrs.get("MassTable") if "Header" in f else None
        if table is None or not len(table) or not float(table[0]) > 0:
            raise VolumeError(f"{path}: no PartType0/Masses and no gas mass in Header/MassTable")
        m = float(table[0])
    rho_name = next((n for n in ("Densities", "Density") if n in gas), None)
    rho = dataset(rho_name) if rho_name else None
    values, label = None, "density"
    if array is not None:
        if array not in gas:
            raise VolumeError(f"{path}: no dataset PartType0/{array} (volume.array); it has "
                              f"{', '.join(gas.keys())}")
        label = array
        if array != rho_name:
            values = dataset(array)
            if values.ndim != 1:
                raise VolumeError(f"{path}: PartType0/{array} has shape {values.shape}; choose a dataset of "
                                  "one number per particle")
    if positions.ndim != 2 or positions.shape[1:] != (3,):
        raise VolumeError(f"{path}: PartType0/Coordinates has shape {positions.shape}, expected (N, 3)")
    return _particles(path, positions, h, m, rho, values, label)


def _swift_kernel(f) -> str | None:
    scheme = f.get("HydroScheme")
    if scheme is None:
        return None
    value = scheme.attrs.get("Kernel function")
    if value is None:
        return None
    if isinstance(value, np.ndarray):
        value = value.ravel()[0] if value.size else ""
    return value.decode(errors="replace") if isinstance(value, bytes) else str(value)


def write_npz(path, particles: ParticleSet):
    """Save a particle set as a ``.npz`` table this module reads back (positions, h, m, rho and its
    quantity)."""
    columns = {"positions": particles.positions, "h": particles.smoothing_lengths, "m": particles.masses,
               "rho": particles.densities}
    if particles.array.lower() not in ("density", "rho"):
        columns[particles.array] = particles.values
    np.savez(path, **columns)


__all__ = ["read_particles", "write_npz"]

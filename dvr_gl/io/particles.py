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
import io
import math
import warnings
import zipfile
from pathlib import Path

import numpy as np

from ..errors import DvrError, VolumeError
from ..fields import sph
from ..fields.particles import ParticleSet
from ..sandbox import SandboxError, check_bytes, check_input_path, current
from .common import require

ALIASES = {"h": ("h", "smoothing_length", "smoothing_lengths", "hsml"), "m": ("m", "mass", "masses"),
           "rho": ("rho", "density", "densities")}


def read_particles(path: Path, fmt: str, array: str | None = None) -> ParticleSet:
    path = check_input_path(Path(path), "particle file")
    check_bytes(path.stat().st_size * 6.0, f"{path.name}: reading the particles", "use fewer particles")
    reader = {"csv": _read_csv, "npz": _read_npz, "hdf5": _read_hdf5}[fmt]
    return reader(path, array)


def _table(path: Path, columns: dict[str, np.ndarray], array: str | None, row=None) -> ParticleSet:
    """A particle set from named columns (lower-cased names); ``row(i)`` names the ``i``-th particle's
    place in the file (default: its row, from 1)."""
    def find(key):
        for name in ALIASES[key]:
            if name in columns:
                return name
        return None

    if "positions" in columns:
        used = {"positions": columns["positions"]}
        if np.ndim(used["positions"]) != 2 or np.shape(used["positions"])[1] != 3:
            raise VolumeError(f"{path}: positions has shape {np.shape(used['positions'])}; give an (N, 3) array "
                              "(or the columns x, y, z)")
    elif all(c in columns for c in "xyz"):
        used = {c: columns[c] for c in "xyz"}
    else:
        raise VolumeError(f"{path}: no particle positions; name the columns x, y, z (or an (N, 3) array "
                          f"positions); found {_listed(sorted(columns))}")
    h, m, rho = find("h"), find("m"), find("rho")
    for key, name in (("h", h), ("m", m)):
        if name is None:
            raise VolumeError(f"{path}: no {' or '.join(ALIASES[key])} column; SPH particles need a smoothing "
                              "length and a mass each")
    used.update({h: columns[h], m: columns[m]})
    if rho is not None:
        used[rho] = columns[rho]
    values, label = None, "density"
    if array is not None:
        if array.lower() not in columns:
            raise VolumeError(f"{path}: no column {array!r} (volume.array); it has {_listed(sorted(columns))}")
        label = array
        if array.lower() != rho:
            values = used[array.lower()] = columns[array.lower()]
    _check_columns(path, used, positive=(h, m, rho), row=row)
    if "positions" in used:
        positions = np.asarray(used["positions"], dtype=np.float64)
    else:
        positions = np.stack([np.asarray(columns[c], dtype=np.float64) for c in "xyz"], axis=1)
    return _particles(path, positions, columns[h], columns[m], None if rho is None else columns[rho], values,
                      label)


def _check_columns(path: Path, columns: dict, kind: str = "column", positive=(), row=None):
    """The columns a particle set is made of: one value (or row of values) per particle each, at least one
    particle, every value finite, those of ``positive`` above zero; refused naming the column and its first
    bad particle (``row(i)``: where particle ``i`` lies in the file).  A scalar column (a snapshot's mass
    table) stands for every particle."""
    row = row or (lambda i: f"row {i + 1}")
    coordinates = ("positions", "PartType0/Coordinates")  # (N, 3); every other column (N,)
    for name, column in columns.items():
        if np.ndim(column) > (2 if name in coordinates else 1):
            raise VolumeError(f"{path}: {kind} {name!r} has shape {np.shape(column)}; give one number per "
                              "particle")
    lengths = {name: len(c) for name, c in columns.items() if np.ndim(c) > 0}
    if not lengths or not max(lengths.values()):
        raise VolumeError(f"{path}: no particles (its {kind}s are empty or single numbers)")
    (a, n_a), *others = lengths.items()
    for b, n_b in others:
        if n_b != n_a:
            raise VolumeError(f"{path}: {kind}s of unequal length: {a!r} has {n_a} values, {b!r} {n_b}; every "
                              f"{kind} needs one value per particle")
    for name, column in columns.items():
        values = np.asarray(column, dtype=np.float64)
        bad = ~np.isfinite(values)
        if name in positive:
            bad |= ~(values > 0)
        if bad.ndim == 2:
            bad = bad.any(axis=1)
        if bad.any():
            first = int(np.argmax(bad)) if bad.ndim else 0
            value = values.reshape(len(bad) if bad.ndim else 1, -1)[first]
            shown = ", ".join(f"{v:g}" for v in value)
            need = "positive and finite" if name in positive else "finite"
            raise VolumeError(f"{path}: {kind} {name!r} holds {shown} at {row(first)} ({int(bad.sum())} such "
                              f"particle{'s' if bad.sum() > 1 else ''}); every value must be {need}: fix the file")


def _particles(path: Path, positions, h, m, rho, values, label: str) -> ParticleSet:
    if rho is None:  # the SPH density at each particle: sum_j m_j W(x_i - x_j, h_j)
        probe = ParticleSet(positions, h, m, 1.0, name=path.name)
        rho = probe.reconstruct().sample(probe.positions, progress=f"{path.name}: the SPH density at the particles")
    return ParticleSet(positions, h, m, rho, values, name=path.name, array=label, source=str(path))


def _read_csv(path: Path, array: str | None) -> ParticleSet:
    """A CSV table: numpy's parser where the file is regular (a 400k-particle table in about a second,
    the csv module took 8 s); on any complaint the csv module reads it again, line by line, to name the
    line at fault."""
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark (spreadsheets write one) is no name
    except UnicodeDecodeError:
        raise VolumeError(f"{path}: not a text CSV file (not UTF-8); a particle table is CSV with a header "
                          "row") from None
    first, _, body = text.partition("\n")
    try:
        header = next(csv.reader([first]), None)
    except csv.Error as exc:
        raise VolumeError(f"{path}: not a readable CSV file ({exc})") from None
    if not header or all(not c.strip() for c in header):
        raise VolumeError(f"{path}: empty; a particle table starts with a header row (x,y,z,h,m,...)")
    names = [c.strip().lower() for c in header]
    if len(set(names)) != len(names):
        raise VolumeError(f"{path}: repeated column names in the header {_shown(header)}")
    table = _fast_csv(body, len(names))
    if table is None:
        table = _csv_rows(path, text, len(names))
    if not len(table):
        raise VolumeError(f"{path}: a header and no particles")
    return _table(path, {n: table[:, i] for i, n in enumerate(names)}, array, row=lambda i: _csv_line(text, i))


def _fast_csv(body: str, width: int) -> np.ndarray | None:
    """The rows below the header by numpy's C parser, None where it objects (or reads another width)."""
    if "\x00" in body or '"' in body:  # NULs and quoting: the csv module's rules
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "input contained no data": an empty table, refused after
            table = np.loadtxt(io.StringIO(body), delimiter=",", dtype=np.float64, ndmin=2, comments=None)
    except ValueError:
        return None
    if table.size and table.shape[1] != width:
        return None
    return table.reshape(-1, width)


def _csv_rows(path: Path, text: str, width: int) -> np.ndarray:
    """The rows below the header by the csv module, a line at a time: the line at fault named."""
    data = []
    try:
        rows = csv.reader(io.StringIO(text, newline=""))
        next(rows, None)
        for line, row in enumerate(rows, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) != width:
                raise VolumeError(f"{path}: line {line} has {len(row)} fields, the header {width}")
            try:
                data.append([float(c) for c in row])
            except ValueError:
                raise VolumeError(f"{path}: line {line} holds a value that is not a number: {_shown(row)}") from None
    except csv.Error as exc:
        raise VolumeError(f"{path}: not a readable CSV file ({exc})") from None
    return np.asarray(data, dtype=np.float64).reshape(-1, width)


def _csv_line(text: str, i: int) -> str:
    """Where the ``i``-th particle (from 0) of a table lies: its line, blank lines skipped as the readers
    skip them."""
    count = -1
    for line, content in enumerate(text.splitlines()[1:], start=2):
        if content.replace(",", "").strip():
            count += 1
            if count == i:
                return f"line {line}"
    return f"row {i + 1}"


def _listed(names) -> str:
    """Names for a message: comma-separated, at most 120 characters of them ("none" for none)."""
    text = ", ".join(str(n) for n in names) or "none"
    return text if len(text) <= 120 else text[:117] + "..."


def _shown(row) -> str:
    """A row for a message: at most 120 characters of it."""
    text = str(list(row))
    return text if len(text) <= 120 else text[:117] + "..."


def _read_npz(path: Path, array: str | None) -> ParticleSet:
    try:
        with zipfile.ZipFile(path) as archive:  # the members' sizes, before numpy inflates any
            check_bytes(sum(i.file_size for i in archive.infolist()) * 2.0, f"{path.name}: its arrays",
                        "use fewer particles")
        with np.load(path, allow_pickle=False) as z:
            if len({k.lower() for k in z.files}) != len(z.files):
                raise VolumeError(f"{path}: arrays whose names differ only in case ({_listed(z.files)}); "
                                  "columns are named in any case, so give each once")
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
    h5py = require("h5py", "h5py", "particles")
    gas = _linked(path, f, "PartType0", h5py)
    if not isinstance(gas, h5py.Group):
        raise VolumeError(f"{path}: no PartType0 group; dvr-gl reads the gas particles of GADGET/SWIFT "
                          f"snapshots (groups here: {_listed(f.keys())})")
    names = set(gas.keys())  # link names only: testing one with `in` would follow it

    def dataset(name):
        item = _linked(path, gas, name, h5py, f"PartType0/{name}")
        if not isinstance(item, h5py.Dataset) or item.dtype.kind not in "iuf":
            raise VolumeError(f"{path}: PartType0/{name} is not a numeric dataset")
        _check_storage(path, item, f"PartType0/{name}")
        check_bytes(float(np.prod(item.shape, dtype=np.float64)) * 8.0, f"{path.name}: PartType0/{name}",
                    "use fewer particles")
        return np.asarray(item[()], dtype=np.float64)

    if "Coordinates" not in names:
        raise VolumeError(f"{path}: no PartType0/Coordinates")
    positions = dataset("Coordinates")
    if "SmoothingLengths" in names:  # SWIFT: Dehnen and Aly's h
        kernel = _swift_kernel(path, f, h5py)
        if kernel is not None and "cubic" not in kernel.lower():
            raise VolumeError(f"{path}: made with the {kernel} kernel; dvr-gl interpolates SPH particles with "
                              "the cubic spline (M4) only")
        h = dataset("SmoothingLengths") * sph.SWIFT_CUBIC_GAMMA / sph.SUPPORT
        h_name = "SmoothingLengths"
    elif "SmoothingLength" in names:  # GADGET: the support radius
        h = dataset("SmoothingLength") / sph.SUPPORT
        h_name = "SmoothingLength"
    else:
        raise VolumeError(f"{path}: no PartType0/SmoothingLength (GADGET) or SmoothingLengths (SWIFT)")
    if "Masses" in names:
        m, m_name = dataset("Masses"), "PartType0/Masses"
    else:
        header = _linked(path, f, "Header", h5py)
        table = header.attrs.get("MassTable") if header is not None else None
        try:
            gas_mass = float(np.asarray(table, dtype=np.float64).ravel()[0])
        except (TypeError, ValueError, IndexError):
            gas_mass = math.nan
        if not gas_mass > 0 or not math.isfinite(gas_mass):
            raise VolumeError(f"{path}: no PartType0/Masses and no positive gas mass in Header/MassTable")
        m, m_name = gas_mass, "Header/MassTable"
    rho_name = next((n for n in ("Densities", "Density") if n in names), None)
    rho = dataset(rho_name) if rho_name else None
    values, label = None, "density"
    if array is not None:
        if array not in names:
            raise VolumeError(f"{path}: no dataset PartType0/{array} (volume.array); it has "
                              f"{_listed(sorted(names))}")
        label = array
        if array != rho_name:
            values = dataset(array)
            if values.ndim != 1:
                raise VolumeError(f"{path}: PartType0/{array} has shape {values.shape}; choose a dataset of "
                                  "one number per particle")
    if positions.ndim != 2 or positions.shape[1:] != (3,):
        raise VolumeError(f"{path}: PartType0/Coordinates has shape {positions.shape}, expected (N, 3)")
    columns = {"PartType0/Coordinates": positions, f"PartType0/{h_name}": h, m_name: m}
    if rho is not None:
        columns[f"PartType0/{rho_name}"] = rho
    if values is not None:
        columns[f"PartType0/{array}"] = values
    _check_columns(path, columns, "dataset", positive=[n for n in columns if n != "PartType0/Coordinates"
                                                       and n != f"PartType0/{array}"])
    return _particles(path, positions, h, m, rho, values, label)


#: How many soft links a path may pass through (HDF5's own limit, H5L_NUM_LINKS).
SOFT_LINK_HOPS = 16


def _linked(path: Path, group, name: str, h5py, shown: str | None = None):
    """The object at ``name`` below ``group`` (None where nothing is linked), every link on the way read
    before it is followed: soft links are followed inside the file; under ``--sandbox`` an external
    link (or a user-defined one) is refused, since HDF5 would open the file it names wherever it lies."""
    shown = shown or name
    parts, node, hops = [p for p in name.split("/") if p not in ("", ".")], group, 0
    while parts:
        if not isinstance(node, h5py.Group):
            return None
        link = node.get(parts[0], getlink=True)
        if link is None:
            return None
        if isinstance(link, h5py.SoftLink):
            hops += 1
            if hops > SOFT_LINK_HOPS:
                raise VolumeError(f"{path}: {shown} passes through more than {SOFT_LINK_HOPS} soft links (a "
                                  "loop?); link the dataset directly")
            target = str(link.path)
            node = node.file if target.startswith("/") else node
            parts = [p for p in target.split("/") if p not in ("", ".")] + parts[1:]
            continue
        if not isinstance(link, h5py.HardLink) and current().roots:
            where = f" to {link.filename}:{link.path}" if isinstance(link, h5py.ExternalLink) else ""
            raise SandboxError(f"{path}: {shown} is an HDF5 external link{where}; links to other files are not "
                               "followed under --sandbox; copy the data into this file")
        node = node[parts[0]]
        parts = parts[1:]
    return node


def _check_storage(path: Path, item, shown: str):
    """Under ``--sandbox``, a dataset whose data lies in other files (a virtual dataset's sources, external
    raw storage) is refused: HDF5 opens them by name, unchecked."""
    if not current().roots:
        return
    if item.is_virtual:
        files = sorted({s.file_name for s in item.virtual_sources()})
        raise SandboxError(f"{path}: {shown} is an HDF5 virtual dataset reading {_listed(files)}; virtual "
                           "datasets are not read under --sandbox; store the data in this file")
    if item.external:
        files = sorted({str(e[0]) for e in item.external})
        raise SandboxError(f"{path}: {shown} keeps its data in external raw files ({_listed(files)}); external "
                           "storage is not read under --sandbox; store the data in this file")


def _swift_kernel(path: Path, f, h5py) -> str | None:
    scheme = _linked(path, f, "HydroScheme", h5py)
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

"""Unstructured grids: legacy VTK ``UNSTRUCTURED_GRID`` and VTK XML ``.vtu``, read strictly by
:mod:`.mesh_vtk`, and PLOT3D curvilinear grids (whole-file binary, big-endian) read directly.

meshio read the VTK files before issue 40; it reads the intact files in ``../shared/data/unstructured/``
correctly but reinterprets damaged ones without a word (zeroed ``.vtu`` offsets give other cells, a
multi-piece file keeps its last piece, short ``CELL_TYPES`` drop cells: ``tests/io/test_mesh_io.py``),
so the cells, offsets, types, counts and arrays are now read and checked here.  meshio still reads
the surface meshes of ``[[renderer.geometry]]`` (:mod:`dvr_gl.geometry`), which validates its result.

Every reader returns a :class:`~dvr_gl.fields.mesh.TetMesh`: cells split into tetrahedra
(:mod:`dvr_gl.fields.mesh_cells`), one scalar array chosen by name (``volume.array``) or, by
default, the first one-component array of finite values (point arrays first).
"""

from __future__ import annotations

import contextlib
import io
import warnings
from pathlib import Path

import numpy as np

from ..errors import VolumeError
from ..fields.mesh import TetMesh
from ..fields.mesh_cells import CORNERS, hexahedra_of_grid, tetrahedralize
from ..sandbox import check_bytes, check_input_path
from .mesh_vtk import SURFACE_TYPES, VTK_CELLS, check_arrays, read_legacy, read_vtu

PLOT3D_ARRAYS = ("density", "momentum_x", "momentum_y", "momentum_z", "energy", "momentum_magnitude")


def is_legacy_unstructured(path: Path) -> bool:
    """Whether a legacy ``.vtk`` file holds an ``UNSTRUCTURED_GRID`` (its DATASET line, within the header)."""
    check_input_path(path, "volume file")  # even these 1024 bytes are read only inside the sandbox
    with open(path, "rb") as f:
        head = f.read(1024)
    return b"DATASET UNSTRUCTURED_GRID" in head.upper()


class UnreadableMesh(Exception):
    """meshio could not read a file; the message is its reason, on one line."""


def quiet_read(meshio, path, **kwargs):
    """``meshio.read(path, **kwargs)`` with what meshio prints kept out of the terminal and its failures
    (exceptions of many kinds, and ``sys.exit`` for some: an unknown cell type, a damaged PLY) raised
    as :class:`UnreadableMesh` with a one-line reason."""
    said = io.StringIO()
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            warnings.simplefilter("ignore")
            return meshio.read(str(path), **kwargs)
    except (Exception, SystemExit) as exc:  # ReadError, ValueError, KeyError, sys.exit... on malformed files
        reason = " ".join((str(exc) if not isinstance(exc, SystemExit) else said.getvalue()).split())[:160]
        raise UnreadableMesh(reason or type(exc).__name__) from None


def read_mesh(path: Path, array: str | None = None) -> TetMesh:
    """A ``.vtu`` or legacy ``.vtk`` unstructured grid as a tetrahedral mesh (read by
    :mod:`.mesh_vtk`, strictly: damaged cells are refused, never reinterpreted)."""
    path = Path(path)
    check_input_path(path, "mesh file")
    size = path.stat().st_size
    # the file's bytes, and what parsing makes of them: ASCII tokens are Python objects (about 24 bytes
    # for each byte of text), binary arrays about one copy (converted to float64 and int64: 2x)
    check_bytes(size * (24.0 if _is_ascii(path) else 4.0), f"{path.name}: reading the mesh", "use a smaller mesh")
    grid = read_vtu(path) if path.suffix.lower() == ".vtu" else read_legacy(path)
    check_arrays(path, grid)
    return tet_mesh(path, grid, array)


def _is_ascii(path: Path) -> bool:
    """Whether a mesh file's data are text (legacy ASCII, or a .vtu without binary or appended data)."""
    with open(path, "rb") as f:
        head = f.read(4096)
    if path.suffix.lower() == ".vtu":
        return b'format="binary"' not in head and b"AppendedData" not in head and b'format="appended"' not in head
    return b"\nASCII" in head.upper()


# tetrahedra per cell of each rendered type, and whether a centroid point is added
TETS_PER_CELL = {"tetra": 1, "tetra10": 8, "pyramid": 2, "wedge": 8, "hexahedron": 12, "voxel": 12}
BYTES_PER_TET = 640     # the split (int64 corners, parents) and TetMesh's float64 corners, edges and volumes
BYTES_PER_POINT = 96    # points, values, the used-point mask and their copies


def tet_mesh(path: Path, grid, array: str | None = None) -> TetMesh:
    """The volume cells of a checked :class:`~.mesh_vtk.RawGrid` split into tetrahedra, with the chosen array."""
    volume_types = {number: name for number, (name, _) in VTK_CELLS.items() if name in CORNERS}
    blocks, skipped = [], {}
    volume_cell = np.isin(grid.types, list(volume_types))
    for t in np.unique(grid.types).tolist():
        name = VTK_CELLS[t][0]
        if t in volume_types:
            continue
        if t in SURFACE_TYPES:
            skipped[name] = int((grid.types == t).sum())
        else:
            raise VolumeError(f"{path}: cells of type {name!r} (VTK {t}) cannot be rendered; dvr-gl takes "
                              f"{', '.join(CORNERS)} (surface cells are ignored)")
    if not volume_cell.any():
        raise VolumeError(f"{path}: no volume cells ({', '.join(f'{n} {t}' for t, n in skipped.items()) or 'no cells'})"
                          "; a mesh needs tetrahedra, hexahedra, wedges or pyramids")
    cells = np.flatnonzero(volume_cell)
    # blocks of one type each, in file order within a type (cell arrays follow the same order)
    order = []
    for t, name in volume_types.items():
        picked = cells[grid.types[cells] == t]
        if len(picked):
            starts = grid.offsets[picked]
            blocks.append((name, grid.connectivity[starts[:, None] + np.arange(CORNERS[name])]))
            order.append(picked)
    order = np.concatenate(order)
    tets = sum(TETS_PER_CELL[name] * len(c) for name, c in blocks)
    added = sum(len(c) for name, c in blocks if name in ("wedge", "hexahedron", "voxel"))
    check_bytes(tets * float(BYTES_PER_TET) + (len(grid.points) + added) * float(BYTES_PER_POINT),
                f"{path.name}: splitting {len(order)} cells into {tets} tetrahedra", "use a smaller mesh")
    if not np.isfinite(grid.points).all():
        bad = int((~np.isfinite(grid.points)).any(axis=1).sum())
        raise VolumeError(f"{path}: {bad} points have NaN or Inf coordinates; fix the file")
    point_arrays = {k: np.asarray(v) for k, v in grid.point_arrays.items()}
    cell_arrays = {k: np.asarray(v)[order] for k, v in grid.cell_arrays.items()}
    name, association, values = choose_array(path, point_arrays, cell_arrays, array)
    new_points, tets, parent, point_values = tetrahedralize(
        grid.points, blocks, values if association == "point" else None)
    cell_values = point_values if association == "point" else values[parent]
    return TetMesh(new_points, tets, cell_values, association, name=path.name, array=name, source=str(path))


def choose_array(path, point_arrays: dict, cell_arrays: dict, wanted: str | None):
    """``(name, association, values)``: the array named ``wanted``, or the first one-component array
    of finite values (point arrays, then cell arrays)."""
    def usable(v):
        return v.ndim == 1 or (v.ndim == 2 and v.shape[1] == 1)

    listing = ", ".join([f"{k} (point)" for k in point_arrays] + [f"{k} (cell)" for k in cell_arrays]) or "none"
    if wanted is not None:
        for association, arrays in (("point", point_arrays), ("cell", cell_arrays)):
            if wanted in arrays:
                v = arrays[wanted]
                if not usable(v):
                    raise VolumeError(f"{path}: array {wanted!r} has {v.shape[1]} components; choose a "
                                      f"one-component array (volume.array): {listing}")
                v = v.reshape(-1).astype(np.float64)
                if not np.isfinite(v).all():
                    raise VolumeError(f"{path}: array {wanted!r} has {int((~np.isfinite(v)).sum())} NaN or Inf "
                                      f"values; choose another array (volume.array): {listing}")
                return wanted, association, v
        raise VolumeError(f"{path}: no array named {wanted!r}; the file has: {listing}")
    for association, arrays in (("point", point_arrays), ("cell", cell_arrays)):
        for k, v in arrays.items():
            if usable(v) and v.dtype.kind in "iuf" and np.isfinite(v).all():
                return k, association, v.reshape(-1).astype(np.float64)
    raise VolumeError(f"{path}: no one-component array of finite values to render (has: {listing}); "
                      "add scalars to the file")


# --- PLOT3D ------------------------------------------------------------------------------------

def _dims(blob: bytes, path: Path) -> tuple[int, int, int]:
    if len(blob) < 12:
        raise VolumeError(f"{path}: too short for a PLOT3D header (ni, nj, nk); is this a PLOT3D file?")
    dims = tuple(int(x) for x in np.frombuffer(blob[:12], ">i4"))
    if min(dims) < 2 or np.prod(dims, dtype=np.int64) > 1 << 31:
        raise VolumeError(f"{path}: PLOT3D dimensions {dims} are not a single whole-file big-endian grid "
                          "(each 2 or more); multi-grid and Fortran-record files are not supported")
    return dims


def _default_plot3d_array(arrays: dict, q: Path) -> str:
    """Density, or energy where density is constant (a solution of no flow).  Density with NaN or Inf is
    refused, not passed over for energy: its range says nothing then, and another array rendered in its
    place would be a silently wrong image."""
    density = arrays["density"]
    bad = int((~np.isfinite(density)).sum())
    if bad:
        raise VolumeError(f"{q}: array 'density' has {bad} NaN or Inf values; choose another array "
                          f"(volume.array): {', '.join(PLOT3D_ARRAYS[1:])}")
    return "density" if np.ptp(density) > 0 else "energy"


def read_plot3d(xyz: Path, q: Path | None = None, array: str | None = None) -> TetMesh:
    """A single-grid, whole-file, big-endian PLOT3D grid (``xyz``, optional IBLANK) and its solution
    (``q``: density, momentum x/y/z, stagnation energy) as hexahedra split into tetrahedra.  ``q``
    defaults to the grid's name with ``xyz`` replaced by ``q``.  Cells touching a point with IBLANK
    0 (a hole) are left out.  ``array``: one of :data:`PLOT3D_ARRAYS` (default: density, or energy
    where density is constant)."""
    xyz = Path(xyz)
    check_input_path(xyz, "PLOT3D grid file")
    if q is None:
        guess = xyz.with_name(xyz.name.replace("xyz", "q"))
        if guess == xyz or not guess.exists():
            raise VolumeError(f"{xyz}: no solution file; give it as volume.solution (a PLOT3D q file)")
        q = guess
    q = Path(q)
    check_input_path(q, "PLOT3D solution file")
    check_bytes(float(xyz.stat().st_size + q.stat().st_size) * 2.5, f"{xyz.name}: reading the PLOT3D grid and "
                "solution", "use a smaller grid")
    blob = xyz.read_bytes()
    ni, nj, nk = _dims(blob, xyz)
    n = ni * nj * nk
    need = 12 + 12 * n
    if len(blob) not in (need, need + 4 * n):
        raise VolumeError(f"{xyz}: {len(blob)} bytes, but a {ni}x{nj}x{nk} grid needs {need} (or {need + 4 * n} "
                          "with IBLANK); is it big-endian, whole-file, single-grid PLOT3D?")
    coords = np.frombuffer(blob, ">f4", 3 * n, 12).astype(np.float64).reshape(3, n).T
    iblank = np.frombuffer(blob, ">i4", n, need) if len(blob) > need else None
    qblob = q.read_bytes()
    if _dims(qblob, q) != (ni, nj, nk):
        raise VolumeError(f"{q}: solution dimensions {_dims(qblob, q)} differ from the grid's {(ni, nj, nk)}")
    if len(qblob) < 28 + 20 * n:
        raise VolumeError(f"{q}: {len(qblob)} bytes, but a {ni}x{nj}x{nk} solution needs {28 + 20 * n}")
    qv = np.frombuffer(qblob, ">f4", 5 * n, 28).astype(np.float64).reshape(5, n)
    arrays = dict(zip(PLOT3D_ARRAYS[:5], qv))
    arrays["momentum_magnitude"] = np.sqrt(qv[1] ** 2 + qv[2] ** 2 + qv[3] ** 2)
    if array is None:
        array = _default_plot3d_array(arrays, q)
    if array not in arrays:
        raise VolumeError(f"{q}: no array {array!r}; PLOT3D solutions have {', '.join(PLOT3D_ARRAYS)}")
    cells = (ni - 1) * (nj - 1) * (nk - 1)
    check_bytes(cells * 12.0 * BYTES_PER_TET + (n + cells) * float(BYTES_PER_POINT),
                f"{xyz.name}: splitting {cells} hexahedra into {12 * cells} tetrahedra", "use a smaller grid")
    hexes = hexahedra_of_grid(ni, nj, nk)
    if iblank is not None:
        hexes = hexes[(iblank[hexes] != 0).all(axis=1)]
    points, tets, _, values = tetrahedralize(coords, [("hexahedron", hexes)], arrays[array])
    return TetMesh(points, tets, values, "point", name=xyz.name, array=array, source=str(xyz))

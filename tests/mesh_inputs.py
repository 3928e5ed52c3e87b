"""Small valid mesh files, written by hand in every layout the mesh readers take, for the reader
tests (``tests/io/test_mesh_io.py``) and the mesh fuzzing (``tests/io/test_fuzz_meshes.py``).

The volume mesh :data:`CELLS` holds one cell of each rendered type (tetrahedron, hexahedron, wedge,
pyramid, quadratic tetrahedron) over :data:`POINTS`, with a point array ``s`` and a cell array ``c``.
"""

from __future__ import annotations

import base64
import struct
import tempfile
import zlib
from pathlib import Path

import numpy as np
import pytest

from dvr_gl.fields.mesh import TetMesh
from dvr_gl.fields.mesh_cells import hexahedra_of_grid, tetrahedralize
from dvr_gl.scene.resolve import load_scene

POINTS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1],
                   [2, 0, 0], [2, 1, 0], [2, 0, 1], [2, 1, 1], [0.5, 0.5, -1],
                   [0.5, 0, 0.5], [0.5, 0.5, 0], [0, 0.5, 0], [0, 0, 0.5], [0.5, 0, 0], [0, 0.5, 0.5]],
                  dtype=np.float64)
# (VTK type, points): tetrahedron, hexahedron, wedge, pyramid below the hexahedron, quadratic tetrahedron
# (corners 0, 1, 3, 4 and the mid-edge nodes 17, 14, 15, 16, 13, 18 in VTK's order)
CELLS = [(10, [0, 1, 3, 4]), (12, [0, 1, 2, 3, 4, 5, 6, 7]), (13, [1, 8, 5, 2, 9, 6]),
         (14, [0, 1, 2, 3, 12]), (24, [0, 1, 3, 4, 17, 14, 15, 16, 13, 18])]
POINT_VALUES = np.arange(len(POINTS), dtype=np.float64) * 0.5
CELL_VALUES = np.array([1.0, 2.0, 3.0, 4.0, 5.0])


def cell_arrays(cells=CELLS):
    """(connectivity, offsets (ends, one per cell), types) of ``cells``."""
    connectivity = np.concatenate([c for _, c in cells]).astype(np.int64)
    offsets = np.cumsum([len(c) for _, c in cells]).astype(np.int64)
    types = np.array([t for t, _ in cells], np.uint8)
    return connectivity, offsets, types


def _ascii(values) -> str:
    return " ".join(repr(float(v)) if isinstance(v, (float, np.floating)) else str(int(v))
                    for v in np.asarray(values).ravel())


def vtu(encoding: str = "ascii", points=POINTS, cells=CELLS, point_values=POINT_VALUES, cell_values=CELL_VALUES,
        connectivity=None, offsets=None, types=None, pieces: int = 1) -> bytes:
    """A ``.vtu`` file: ``encoding`` ascii, binary (inline base64), zlib (inline base64 in zlib blocks),
    raw (appended raw) or appended64 (appended base64); arrays given explicitly override ``cells``'.
    ``pieces`` > 1 repeats the piece (its points and cells numbered within it, as VTK writes pieces)."""
    conn, offs, typ = cell_arrays(cells)
    conn = conn if connectivity is None else np.asarray(connectivity)
    offs = offs if offsets is None else np.asarray(offsets)
    typ = typ if types is None else np.asarray(types)
    appended = bytearray()
    arrays = [("Points", np.asarray(points, "<f8"), "Float64", 3), ("connectivity", conn.astype("<i8"), "Int64", 1),
              ("offsets", offs.astype("<i8"), "Int64", 1), ("types", typ.astype("u1"), "UInt8", 1),
              ("s", np.asarray(point_values, "<f8"), "Float64", 1), ("c", np.asarray(cell_values, "<f8"), "Float64", 1)]
    xml = {}
    for name, data, kind, components in arrays:
        raw = data.tobytes()
        attrs = f'type="{kind}" Name="{name}" NumberOfComponents="{components}"'
        if encoding == "ascii":
            xml[name] = f'<DataArray {attrs} format="ascii">{_ascii(data)}</DataArray>'
        elif encoding == "binary":
            text = base64.b64encode(struct.pack("<I", len(raw))).decode() + base64.b64encode(raw).decode()
            xml[name] = f'<DataArray {attrs} format="binary">{text}</DataArray>'
        elif encoding == "zlib":
            packed = zlib.compress(raw)
            head = struct.pack("<IIII", 1, len(raw), len(raw), len(packed))
            text = base64.b64encode(head).decode() + base64.b64encode(packed).decode()
            xml[name] = f'<DataArray {attrs} format="binary">{text}</DataArray>'
        else:
            block = struct.pack("<I", len(raw)) + raw
            offset = len(appended)
            appended += block if encoding == "raw" else base64.b64encode(block)
            xml[name] = f'<DataArray {attrs} format="appended" offset="{offset}"/>'
    n_points, n_cells = len(np.asarray(points)), len(typ)
    piece = (f'<Piece NumberOfPoints="{n_points}" NumberOfCells="{n_cells}"><Points>{xml["Points"]}</Points>'
             f'<Cells>{xml["connectivity"]}{xml["offsets"]}{xml["types"]}</Cells>'
             f'<PointData>{xml["s"]}</PointData><CellData>{xml["c"]}</CellData></Piece>')
    compressor = ' compressor="vtkZLibDataCompressor"' if encoding == "zlib" else ""
    head = (f'<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
            f'header_type="UInt32"{compressor}>\n<UnstructuredGrid>{piece * pieces}</UnstructuredGrid>\n').encode()
    if encoding in ("raw", "appended64"):
        kind = "raw" if encoding == "raw" else "base64"
        head += f'<AppendedData encoding="{kind}">\n_'.encode() + bytes(appended) + b"\n</AppendedData>\n"
    return head + b"</VTKFile>\n"


def legacy(binary: bool = False, version: str = "4.2", points=POINTS, cells=CELLS, point_values=POINT_VALUES,
           cell_values=CELL_VALUES, types=None) -> bytes:
    """A legacy ``.vtk`` UNSTRUCTURED_GRID: ``version`` 4.2 (``CELLS n size`` of counted cells) or 5.1
    (OFFSETS and CONNECTIVITY), ASCII or big-endian binary."""
    conn, ends, typ = cell_arrays(cells)
    typ = typ if types is None else np.asarray(types)

    def block(values, dtype):
        values = np.asarray(values)
        return (values.astype(">" + dtype).tobytes() + b"\n") if binary else (_ascii(values) + "\n").encode()

    out = [f"# vtk DataFile Version {version}\nmesh\n{'BINARY' if binary else 'ASCII'}\n"
           f"DATASET UNSTRUCTURED_GRID\nPOINTS {len(points)} double\n".encode(), block(points, "f8")]
    if version == "5.1":
        out += [f"CELLS {len(ends) + 1} {len(conn)}\nOFFSETS vtktypeint64\n".encode(),
                block(np.concatenate([[0], ends]), "i8"), b"CONNECTIVITY vtktypeint64\n", block(conn, "i8")]
    else:
        counted = np.concatenate([[len(c), *c] for _, c in cells])
        out += [f"CELLS {len(cells)} {len(counted)}\n".encode(), block(counted, "i4")]
    out += [f"CELL_TYPES {len(typ)}\n".encode(), block(typ, "i4"),
            f"POINT_DATA {len(points)}\nSCALARS s double 1\nLOOKUP_TABLE default\n".encode(),
            block(point_values, "f8"),
            f"CELL_DATA {len(cells)}\nFIELD FieldData 1\nc 1 {len(cells)} double\n".encode(), block(cell_values, "f8")]
    return b"".join(out)


# --- surface meshes ([[renderer.geometry]]) ------------------------------------------------------

TRIANGLES = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])  # a tetrahedron's surface
CORNERS = np.array([[0.1, 0.1, 0.1], [0.9, 0.1, 0.1], [0.1, 0.9, 0.1], [0.1, 0.1, 0.9]])


def obj() -> bytes:
    lines = [f"v {x} {y} {z}" for x, y, z in CORNERS] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in TRIANGLES]
    return ("\n".join(lines) + "\n").encode()


def ply(binary: bool = False) -> bytes:
    head = (f"ply\nformat {'binary_little_endian' if binary else 'ascii'} 1.0\nelement vertex {len(CORNERS)}\n"
            f"property float x\nproperty float y\nproperty float z\nelement face {len(TRIANGLES)}\n"
            "property list uchar int vertex_indices\nend_header\n").encode()
    if binary:
        body = CORNERS.astype("<f4").tobytes() + b"".join(struct.pack("<Biii", 3, *t) for t in TRIANGLES.tolist())
    else:
        body = ("\n".join(" ".join(map(str, p)) for p in CORNERS) + "\n"
                + "\n".join("3 " + " ".join(map(str, t)) for t in TRIANGLES.tolist()) + "\n").encode()
    return head + body


def stl(binary: bool = False) -> bytes:
    tris = CORNERS[TRIANGLES]
    if binary:
        body = b"".join(struct.pack("<12fH", 0, 0, 0, *t.ravel(), 0) for t in tris)
        return b"\0" * 80 + struct.pack("<I", len(tris)) + body
    facets = "".join("facet normal 0 0 0\n outer loop\n" + "".join(f"  vertex {x} {y} {z}\n" for x, y, z in t)
                     + " endloop\nendfacet\n" for t in tris)
    return f"solid s\n{facets}endsolid s\n".encode()


def polydata(binary: bool = False) -> bytes:
    """The tetrahedron's surface as a legacy POLYDATA of POLYGONS."""
    def block(values, dtype):
        values = np.asarray(values)
        return (values.astype(">" + dtype).tobytes() + b"\n") if binary else (_ascii(values) + "\n").encode()

    counted = np.concatenate([[3, *t] for t in TRIANGLES.tolist()])
    return b"".join([f"# vtk DataFile Version 3.0\ns\n{'BINARY' if binary else 'ASCII'}\nDATASET POLYDATA\n"
                     f"POINTS {len(CORNERS)} float\n".encode(), block(CORNERS, "f4"),
                     f"POLYGONS {len(TRIANGLES)} {len(counted)}\n".encode(), block(counted, "i4")])


# --- meshes for the mesh renderers' tests (projected tetrahedra, cell ray casting, clipping) ---

def jittered_mesh(n=(4, 3, 3), size=(1.0, 0.8, 0.9), seed=0):
    """A box of hexahedra (interior points moved) split into tetrahedra, with a smooth point scalar."""
    axes = [np.linspace(0.0, s, k) for s, k in zip(size, n)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    p = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    inner = np.all([(p[:, i] > 0) & (p[:, i] < size[i]) for i in range(3)], axis=0)
    step = np.array(size) / (np.array(n) - 1)
    p[inner] += np.random.default_rng(seed).uniform(-0.3, 0.3, (inner.sum(), 3)) * step
    values = np.sin(3.0 * p[:, 0]) + p[:, 1] * p[:, 2] * 2.0
    points, tets, _, v = tetrahedralize(p, [("hexahedron", hexahedra_of_grid(*n))], values)
    return TetMesh(points, tets, v, name="jittered")


# a narrow bright band (0.05 wide) that most cells span from one end to the other: a feature inside
# cells, missed by anything that classifies only the cells' end values
BAND_TF = [[-1.0, 0.2, 0.3, 0.9, 0.3], [0.40, 0.2, 0.3, 0.9, 0.3], [0.45, 1.0, 0.9, 0.2, 0.95],
           [0.50, 0.2, 0.3, 0.9, 0.3], [2.0, 0.9, 0.3, 0.2, 0.6]]


def mesh_scene(mesh, **keys):
    """The scene of ``mesh`` written as a .vtu (read back through the scene's reader)."""
    meshio = pytest.importorskip("meshio", reason="meshes are read with meshio (pip install 'dvr-gl[mesh]')")
    path = Path(tempfile.mkdtemp(prefix="dvr-pt-")) / f"{mesh.name}.vtu"
    data = {"point_data": {"s": mesh.values}} if mesh.association == "point" else {"cell_data": {"s": [mesh.values]}}
    meshio.write(str(path), meshio.Mesh(mesh.points, [("tetra", mesh.tets)], **data))
    base = {"volume.path": str(path), "image.width": 40, "image.height": 32,
            "transfer_function.points": BAND_TF, "renderer.converged_tolerance": 1e-6}
    return load_scene(None, {**base, **keys})


# perspective and orthographic, oblique and along an axis (faces seen edge on)
REFERENCE_VIEWS = [
    {"camera.azimuth": 30.0, "camera.elevation": 20.0},
    {"camera.azimuth": 0.0, "camera.elevation": 0.0},
    {"camera.projection": "orthographic", "camera.azimuth": 90.0, "camera.elevation": 0.0},
    {"camera.projection": "orthographic", "camera.azimuth": -50.0, "camera.elevation": 35.0},
]


def rms(a, b):
    return float(np.sqrt(np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2)))

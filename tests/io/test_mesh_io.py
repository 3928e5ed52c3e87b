"""Reading the shared unstructured grids (``../shared/data/unstructured``): every file, checked against
the counts and ranges its README states; and malformed mesh files refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import SHARED_DATA
from dvr_gl.errors import DvrError
from dvr_gl.io import load_field
from dvr_gl.io.mesh import read_plot3d

pytest.importorskip("meshio", reason="meshes are read with meshio (pip install 'dvr-gl[mesh]')")

UNSTRUCTURED = SHARED_DATA / "unstructured"
needs_data = pytest.mark.skipif(not UNSTRUCTURED.is_dir(), reason=f"{UNSTRUCTURED} is absent (shared datasets)")

# file -> (points in the file, tetrahedra after splitting, zero-volume tetrahedra, association,
#          array, value range) from ../shared/data/README.md
FILES = {
    "bluntfin_tets.vtk": (40_960, 187_395, 77, "point", "density", (0.1926, 4.9775)),
    "comb_tets.vtk": (47_025, 215_040, 0, "point", "density", (0.1978, 0.7104)),
    "post_tets.vtk": (109_744, 513_375, 0, "point", "q4_energy", (-0.5415, 4.3958)),
    # 56,786 tetra10, eight linear tetrahedra each
    "kiefer_jaw_tet10.vtu": (102_578, 8 * 56_786, 0, "cell", None, (0.014, 23.27)),
    # 2,188 hexahedra (12 each) and 4 wedges (8 each), plus a centroid point per cell
    "notch_stress.vtk": (12_717 + 2_192, 12 * 2_188 + 8 * 4, 0, "point", None, (-1.45e5, 8.11e6)),
    "tetraMesh.vtk": (55, 160, 0, "point", None, None),
}


@needs_data
@pytest.mark.parametrize("name", list(FILES))
def test_every_shared_mesh_reads_as_its_readme_says(name):
    points, tets, degenerate, association, array, value_range = FILES[name]
    kwargs = {"array": array} if array and name != "post_tets.vtk" else {}
    if name == "post_tets.vtk":
        kwargs = {"array": "q4_energy"}
    mesh = load_field(UNSTRUCTURED / name, **kwargs)
    assert mesh.kind == "mesh"
    assert len(mesh.points) == points
    assert len(mesh.tets) + mesh.n_degenerate == tets
    assert mesh.n_degenerate == degenerate
    assert mesh.association == association
    if array:
        assert mesh.array == array
    if value_range:
        lo, hi = mesh.value_range
        scale = max(abs(value_range[0]), abs(value_range[1]))
        assert lo == pytest.approx(value_range[0], abs=1e-3 * scale)
        assert hi == pytest.approx(value_range[1], abs=1e-3 * scale)


@needs_data
def test_a_mesh_with_a_nan_array_defaults_to_a_finite_one_and_names_the_bad_one():
    """notch_stress's 'normed' array holds 9,180 NaNs: not chosen by default, refused by name."""
    path = UNSTRUCTURED / "notch_stress.vtk"
    mesh = load_field(path)
    assert np.isfinite(mesh.values).all()
    normed = next(k for k in __import__("meshio").read(str(path)).point_data if "normed" in k)
    with pytest.raises(DvrError, match="9180 NaN or Inf values; choose another array"):
        load_field(path, array=normed)
    with pytest.raises(DvrError, match="has 6 components; choose a one-component array"):
        load_field(path, array=next(k for k in __import__("meshio").read(str(path)).point_data
                                    if k.endswith("Stress")))


@needs_data
@pytest.mark.parametrize("stem, array, expected", [("bluntfin", "density", (0.1926, 4.9775)),
                                                   ("comb", "density", (0.1978, 0.7104)),
                                                   ("post", "energy", (-0.5415, 4.3958))])
def test_plot3d_grids_read_as_hexahedra(stem, array, expected):
    """The original PLOT3D grids: the same points and scalars as the tetrahedral files derived from
    them (README: 'DERIVED'), read as hexahedra (12 tetrahedra each)."""
    mesh = load_field(UNSTRUCTURED / f"{stem}xyz.bin", format="plot3d")
    assert mesh.array == array  # post's density is constant 1: the default falls to energy
    lo, hi = mesh.value_range
    assert (lo, hi) == pytest.approx(expected, abs=1e-3 * max(map(abs, expected)))
    derived = load_field(UNSTRUCTURED / f"{stem}_tets.vtk", array="q4_energy" if stem == "post" else "density")
    n = len(derived.points)
    np.testing.assert_array_equal(mesh.points[:n].astype(np.float32), derived.points.astype(np.float32))
    np.testing.assert_array_equal(mesh.values[:n].astype(np.float32), derived.values.astype(np.float32))


@needs_data
def test_plot3d_points_are_located_in_their_cells():
    """At the grid's own points the field is the point's value, whichever of the cells sharing the
    point is found (inside a cell the hexahedral and the five-tetrahedra splits differ: two linear
    splits of one trilinear cell)."""
    hexes = load_field(UNSTRUCTURED / "bluntfinxyz.bin", format="plot3d").reconstruct()
    corners = hexes.mesh.points[:40_960:97]
    expected = hexes.mesh.values[:40_960:97]
    # a grid point lies on several cells: whichever is found, the value there is the point's
    np.testing.assert_allclose(hexes.sample(corners), expected, rtol=1e-6, atol=1e-6)


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text) if isinstance(text, str) else path.write_bytes(text)
    return path


TET_HEADER = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n"


@pytest.mark.parametrize("case, text, message", [
    ("truncated", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0\n", "POINTS claims 12 values, more than the rest"),
    ("surface only", TET_HEADER + "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nCELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n5\n"
     "POINT_DATA 3\nSCALARS s float 1\nLOOKUP_TABLE default\n1 2 3\n", "no volume cells"),
    ("no scalars", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
     "no one-component array"),
    ("bad index", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 9\nCELL_TYPES 1\n10\n"
     "POINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n1 2 3 4\n", "outside 0..3"),
    ("quadratic hexahedron, short", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\n"
     "CELL_TYPES 1\n25\n", "a quadratic_hexahedron cell \\(VTK type 25\\) has 4 points, not 20"),
    ("quadratic hexahedron", TET_HEADER + "POINTS 20 float\n" + "0 0 0 " * 20 + "\nCELLS 1 21\n20 "
     + " ".join(map(str, range(20))) + "\nCELL_TYPES 1\n25\n", "type 'quadratic_hexahedron' \\(VTK 25\\) cannot be"),
])
def test_malformed_mesh_files_are_one_line_errors(tmp_path, case, text, message):
    path = _write(tmp_path, "bad.vtk", text)
    with pytest.raises(DvrError, match=message) as info:
        load_field(path)
    assert "\n" not in str(info.value)


def test_grid_options_on_a_mesh_and_mesh_options_on_a_grid_are_refused(tmp_path):
    path = _write(tmp_path, "t.vtk", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\n"
                  "CELL_TYPES 1\n10\nPOINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n1 2 3 4\n")
    assert load_field(path).describe().startswith("t.vtk: mesh, 4 points, 1 tetrahedra")
    with pytest.raises(DvrError, match="volume.spacing applies to regular grids"):
        load_field(path, spacing=(1, 1, 1))
    np.save(tmp_path / "g.npy", np.zeros((2, 2, 2), np.float32))
    with pytest.raises(DvrError, match="volume.array applies to meshes"):
        load_field(tmp_path / "g.npy", array="s")


@pytest.mark.parametrize("case, message", [("short", "too short for a PLOT3D header"),
                                           ("size", "bytes, but a 2x2x2 grid needs"),
                                           ("dims", "solution dimensions"),
                                           ("no q", "no solution file")])
def test_malformed_plot3d_is_refused_in_one_line(tmp_path, case, message):
    dims = np.array([2, 2, 2], ">i4").tobytes()
    xyz = dims + np.zeros(24, ">f4").tobytes()
    q = dims + np.zeros(4, ">f4").tobytes() + np.ones(40, ">f4").tobytes()
    if case == "short":
        xyz = dims[:8]
    elif case == "size":
        xyz = xyz[:-4]
    elif case == "dims":
        q = np.array([3, 2, 2], ">i4").tobytes() + q[12:]
    _write(tmp_path, "gxyz.bin", xyz)
    if case != "no q":
        _write(tmp_path, "gq.bin", q)
    with pytest.raises(DvrError, match=message):
        read_plot3d(tmp_path / "gxyz.bin")


# --- the strict VTK readers (issue 40): every layout, every damage refused --------------------------

import mesh_inputs as mi  # noqa: E402


def _reference_mesh(tmp_path):
    return load_field(_write(tmp_path, "ref.vtk", mi.legacy()), array="s")


@pytest.mark.parametrize("encoding", ["ascii", "binary", "zlib", "raw", "appended64"])
def test_every_vtu_layout_reads_the_same_mesh(tmp_path, encoding):
    ref = _reference_mesh(tmp_path)
    mesh = load_field(_write(tmp_path, f"m-{encoding}.vtu", mi.vtu(encoding)), array="s")
    np.testing.assert_array_equal(mesh.points, ref.points)
    np.testing.assert_array_equal(mesh.tets, ref.tets)
    np.testing.assert_array_equal(mesh.values, ref.values)
    cells = load_field(_write(tmp_path, f"c-{encoding}.vtu", mi.vtu(encoding)), array="c")
    assert cells.association == "cell" and sorted(set(cells.values)) == [1.0, 2.0, 3.0, 4.0, 5.0]


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("version", ["4.2", "5.1"])
def test_every_legacy_layout_reads_the_same_mesh(tmp_path, binary, version):
    ref = load_field(_write(tmp_path, "ref.vtu", mi.vtu()), array="s")
    mesh = load_field(_write(tmp_path, "m.vtk", mi.legacy(binary, version)), array="s")
    np.testing.assert_array_equal(mesh.tets, ref.tets)
    np.testing.assert_array_equal(mesh.values, ref.values)
    # 1 + 12 + 8 + 2 + 8 tetrahedra, a centroid added for the hexahedron and the wedge
    assert len(mesh.tets) + mesh.n_degenerate == 31 and len(mesh.points) == len(mi.POINTS) + 2
    cells = load_field(_write(tmp_path, "c.vtk", mi.legacy(binary, version)), array="c")
    assert cells.association == "cell" and sorted(set(cells.values)) == [1.0, 2.0, 3.0, 4.0, 5.0]


def test_a_multi_piece_vtu_is_joined_where_meshio_keeps_the_last_piece(tmp_path):
    meshio = pytest.importorskip("meshio")
    path = _write(tmp_path, "two.vtu", mi.vtu(pieces=2))
    mesh = load_field(path, array="s")
    one = load_field(_write(tmp_path, "one.vtu", mi.vtu()), array="s")
    assert len(mesh.tets) == 2 * len(one.tets)
    assert sum(len(b.data) for b in meshio.read(path).cells) == len(mi.CELLS)  # meshio: one piece's cells


def test_vtu_offsets_all_zero_are_refused_where_meshio_reads_other_cells(tmp_path):
    """Issue 40: zeroed offsets rendered a different picture with exit 0 (meshio takes each cell as the
    entries ending at its offset, wherever that is)."""
    meshio = pytest.importorskip("meshio")
    conn, ends, _ = mi.cell_arrays()
    path = _write(tmp_path, "z.vtu", mi.vtu(offsets=np.zeros_like(ends)))
    misread = meshio.read(path)
    assert [b.data.tolist() for b in misread.cells] != [c for _, c in mi.CELLS]  # no error: other cells
    with pytest.raises(DvrError, match="offsets run from 0 to 0, not from 0 to the connectivity's length 33"):
        load_field(path)


@pytest.mark.parametrize("case, change, message", [
    ("offsets decrease", dict(offsets=[4, 12, 10, 23, 33]), "offsets decrease at cell 2"),
    ("offsets short", dict(offsets=[4, 12, 18, 23, 30]), "offsets run from 0 to 30"),
    ("offsets past the end", dict(offsets=[4, 12, 18, 23, 40]), "offsets run from 0 to 40"),
    ("offsets shifted", dict(offsets=[4, 11, 18, 23, 33]), "hexahedron cell .VTK type 12. has 7 points"),
    ("unknown type", dict(types=[10, 12, 13, 14, 99]), "cell 4 has type 99, not a VTK cell type"),
    ("type swapped", dict(types=[10, 13, 12, 14, 24]), "hexahedron cell .VTK type 12. has 6 points"),
    ("types short", dict(types=[10, 12, 13, 14]), "5 offsets and 4 types for NumberOfCells"),
    ("tetrahedron index", dict(connectivity=[0, 1, 3, 40] + mi.cell_arrays()[0].tolist()[4:]), "names point 40"),
    ("hexahedron index", dict(connectivity=mi.cell_arrays()[0].tolist()[:4] + [0, 1, 2, 3, 4, 5, 6, 19]
                              + mi.cell_arrays()[0].tolist()[12:]), "names point 19, outside 0..18"),
    ("wedge index", dict(connectivity=mi.cell_arrays()[0].tolist()[:12] + [1, 8, 5, 2, 9, -1]
                         + mi.cell_arrays()[0].tolist()[18:]), "names point -1"),
    ("pyramid index", dict(connectivity=mi.cell_arrays()[0].tolist()[:18] + [0, 1, 2, 3, 1000]
                           + mi.cell_arrays()[0].tolist()[23:]), "names point 1000"),
    ("tetra10 index", dict(connectivity=mi.cell_arrays()[0].tolist()[:23] + [0, 1, 3, 4, 17, 14, 15, 16, 13, 19]),
     "names point 19"),
    ("point data short", dict(point_values=mi.POINT_VALUES[:-1]), "array 's' holds 18 values; 19 points"),
    ("cell data long", dict(cell_values=np.ones(6)), "array 'c' holds 6 values; 5 cells"),
    ("points short", dict(points=mi.POINTS[:-1]), "Points holds 54 values"),
])
@pytest.mark.parametrize("encoding", ["ascii", "raw"])
def test_damaged_vtu_cells_and_arrays_are_one_line_errors(tmp_path, case, change, message, encoding):
    text = mi.vtu(encoding, **change)
    if case == "points short":  # NumberOfPoints from the intact mesh, the data one point short
        text = text.replace(b'NumberOfPoints="18"', b'NumberOfPoints="19"')
    with pytest.raises(DvrError, match=message) as info:
        load_field(_write(tmp_path, "bad.vtu", text))
    assert "\n" not in str(info.value)


def test_legacy_cell_types_fewer_than_cells_are_refused_where_meshio_drops_cells(tmp_path):
    meshio = pytest.importorskip("meshio")
    text = mi.legacy(types=[10, 12, 13, 14]).replace(b"CELL_TYPES 4", b"CELL_TYPES 4")
    path = _write(tmp_path, "short.vtk", text)
    try:
        kept = sum(len(b.data) for b in meshio.read(path).cells)
    except Exception:  # noqa: BLE001 - only the silent drop is shown here
        kept = None
    assert kept in (None, 4)
    with pytest.raises(DvrError, match="CELL_TYPES has 4 entries for 5 CELLS"):
        load_field(path)


@pytest.mark.parametrize("case, mutate, message", [
    ("counts overrun", lambda t: t.replace(b"CELLS 5 38\n4 ", b"CELLS 5 38\n9 "), "point count lies past|add up to"),
    ("size too large", lambda t: t.replace(b"CELLS 5 38", b"CELLS 5 39"), "CELLS holds b?'CELL_TYPES', not a number"),
    ("hexahedron index", lambda t: t.replace(b"8 0 1 2 3 4 5 6 7", b"8 0 1 2 3 4 5 6 77"), "names point 77"),
    ("wedge index", lambda t: t.replace(b"6 1 8 5 2 9 6", b"6 1 8 5 2 9 -6"), "names point -6"),
    ("nan point", lambda t: t.replace(b"POINTS 19 double\n0.0", b"POINTS 19 double\nnan"), "1 points have NaN"),
    ("inf point", lambda t: t.replace(b"POINTS 19 double\n0.0", b"POINTS 19 double\ninf"), "1 points have NaN"),
    ("point data count", lambda t: t.replace(b"POINT_DATA 19", b"POINT_DATA 18"), "a number .9.0. where"),
    ("cell data count", lambda t: t.replace(b"c 1 5 double", b"c 1 4 double"), "'c' has 4 tuples for 5"),
    ("huge count", lambda t: t.replace(b"POINTS 19", b"POINTS 99999999999"), "more than the rest of the file"),
    ("not a count", lambda t: t.replace(b"CELL_TYPES 5", b"CELL_TYPES five"), "CELL_TYPES n must be a count"),
    ("bad number", lambda t: t.replace(b"CELL_TYPES 5\n10", b"CELL_TYPES 5\n1x"), "holds b?'1x', not a number"),
])
def test_damaged_legacy_files_are_one_line_errors(tmp_path, case, mutate, message):
    text = mutate(mi.legacy())
    assert text != mi.legacy()
    with pytest.raises(DvrError, match=message) as info:
        load_field(_write(tmp_path, "bad.vtk", text))
    assert "\n" not in str(info.value)


@needs_data
def test_notch_stress_cells_are_drawn_from_their_corners_not_the_mid_edge_nodes(tmp_path):
    """notch_stress.vtk writes 20-point 'hexahedra' and 15-point 'wedges' (quadratic cells under linear
    types): VTK draws them from their first 8 (6) points, the corners; meshio took the last 8 (6),
    mid-edge nodes, a smaller cell turned 45 degrees.  The centroid added for each hexahedron is the
    mean of its corners."""
    from dvr_gl.io.mesh_vtk import read_legacy

    path = UNSTRUCTURED / "notch_stress.vtk"
    grid = read_legacy(path)
    mesh = load_field(path)
    first = grid.connectivity[grid.offsets[0]:grid.offsets[0] + 8]
    centroid = mesh.points[len(grid.points)]  # the first cell's added point
    np.testing.assert_allclose(centroid, grid.points[first].mean(axis=0))
    meshio = pytest.importorskip("meshio")
    misread = meshio.read(path).cells[0].data[0]
    assert not np.allclose(grid.points[misread].mean(axis=0), centroid)


def test_vtu_cell_arrays_must_be_integers(tmp_path):
    """A Float32 types array of 10.5 was cast to 10 (a tetrahedron) by meshio; VTK stores them as integers."""
    text = mi.vtu().replace(b'type="UInt8" Name="types"', b'type="Float32" Name="types"')
    text = text.replace(b'>10 12 13 14 24<', b'>10.5 12 13 14 24<')
    with pytest.raises(DvrError, match="types is of type float32; VTK stores it as integers"):
        load_field(_write(tmp_path, "f.vtu", text))


def test_large_meshes_are_checked_against_the_budget_before_splitting(tmp_path):
    from dvr_gl.sandbox import Sandbox, SandboxError, active

    path = _write(tmp_path, "m.vtk", mi.legacy(binary=True))
    with active(Sandbox(max_bytes=12_000)), pytest.raises(SandboxError, match="splitting 5 cells into 31 "
                                                                              "tetrahedra would take"):
        load_field(path)
    dims = np.array([3, 3, 3], ">i4").tobytes()
    _write(tmp_path, "gxyz.bin", dims + np.arange(81, dtype=">f4").tobytes())
    _write(tmp_path, "gq.bin", dims + np.zeros(4, ">f4").tobytes() + np.ones(135, ">f4").tobytes())
    with active(Sandbox(max_bytes=20_000)), pytest.raises(SandboxError, match="splitting 8 hexahedra into 96"):
        read_plot3d(tmp_path / "gxyz.bin")


@pytest.mark.parametrize("scale, words", [(1e300, "points lie 2e.300 world units from the origin"),
                                          (1e-300, "the mesh spans 2e-300 world units, below 1e-18")])
def test_meshes_beyond_the_world_range_are_refused(tmp_path, scale, words):
    """A mesh at 1e300 or 1e-300: its volumes over- or underflow, and every cell was 'of zero volume'
    (or, with one far point, the cells touching it were left out without a word)."""
    with pytest.raises(DvrError, match=words):
        load_field(_write(tmp_path, "far.vtk", mi.legacy(points=mi.POINTS * scale)))


def test_cell_arrays_follow_their_cells_whatever_the_order_of_types(tmp_path):
    """Cells are split type by type; each cell's value must stay with its own tetrahedra."""
    cells = [mi.CELLS[i] for i in (3, 1, 0, 4, 2)]  # pyramid, hexahedron, tetrahedron, tetra10, wedge
    path = _write(tmp_path, "mixed.vtu", mi.vtu("raw", cells=cells, cell_values=[40.0, 20, 10, 50, 30]))
    values, counts = np.unique(load_field(path, array="c").values, return_counts=True)
    assert dict(zip(values.tolist(), counts.tolist())) == {10.0: 1, 20.0: 12, 30.0: 8, 40.0: 2, 50.0: 8}


def test_telling_a_legacy_mesh_from_a_grid_reads_nothing_outside_the_sandbox(tmp_path):
    """load_field read a .vtk's first 1024 bytes (to find its DATASET line) before any sandbox check."""
    from dvr_gl.sandbox import Sandbox, SandboxError, active

    outside, inside = tmp_path / "outside", tmp_path / "inside"
    outside.mkdir()
    inside.mkdir()
    _write(outside, "m.vtk", mi.legacy())
    (inside / "link.vtk").symlink_to(outside / "m.vtk")
    from dvr_gl.io.mesh import is_legacy_unstructured

    with active(Sandbox(roots=(inside,))):
        for read in (load_field, is_legacy_unstructured):  # the peek itself is checked, not only the reader
            with pytest.raises(SandboxError, match="outside the allowed folders"):
                read(inside / "link.vtk")


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_plot3d_density_of_nan_is_refused_not_passed_over_for_energy(tmp_path, bad):
    """A density with one NaN (or Inf) had no range (``np.ptp`` NaN, not > 0), so energy was rendered in its
    place, silently; it is refused in one line, and a named other array still reads."""
    dims = np.array([2, 2, 2], ">i4").tobytes()
    xyz = dims + np.array([[i & 1, i >> 1 & 1, i >> 2] for i in range(8)], ">f4").T.tobytes()
    density = np.arange(1, 9, dtype=">f4")
    density[3] = bad
    energy = np.arange(10, 18, dtype=">f4")
    q = dims + np.zeros(4, ">f4").tobytes() + density.tobytes() + np.zeros(24, ">f4").tobytes() + energy.tobytes()
    _write(tmp_path, "gxyz.bin", xyz)
    _write(tmp_path, "gq.bin", q)
    with pytest.raises(DvrError, match=r"gq.bin: array 'density' has 1 NaN or Inf values; choose another array "
                                       r"\(volume.array\)") as refused:
        read_plot3d(tmp_path / "gxyz.bin")
    assert "\n" not in str(refused.value)
    mesh = read_plot3d(tmp_path / "gxyz.bin", array="energy")
    assert mesh.array == "energy"
    assert (mesh.values.min(), mesh.values.max()) == (10, 17)  # energy's, not density's (1 to 8)
